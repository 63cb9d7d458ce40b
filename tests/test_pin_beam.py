"""Issue 21: elastic pins (beam station compliance, series with the contact law, rigid = nothing)."""
import dataclasses

import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.cycloid import output_pin_mechanism, pin_meshes, pin_station_compliance
from rvtool.assembly.spec import load_design, replace
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.output_pins.evaluator import OutputPinEvaluator
from rvtool.output_pins.spec import PinMode
from rvtool.structure.pin_beam import PinBeam, PinSupport

E, NU, R, L = 206e9, 0.3, 0.004, 0.024
# the beam is discretized exactly (Timoshenko element, nodal loads); the remaining error is the
# composite Gauss quadrature on the kinked diagonal and round-off of a 130-node solve (2e-8 measured)
TOL = 1e-6


@pytest.mark.parametrize("shear", [False, True])
def test_point_and_line_loads_against_closed_forms(shear):
    a, b = 0.3 * L, 0.7 * L
    cant = PinBeam(PinSupport(model="cantilever", ends=(0.0, L), shear=shear), R, E, NU)
    EI, kGA = cant.EI, cant.kGA
    assert np.isinf(kGA) != shear
    # cantilever: P a^3/(3EI) + P a/kGA at the load; uniform q: q L^4/(8EI) + q L^2/(2kGA) at the tip
    assert cant.influence([a], [a])[0, 0] == pytest.approx(a ** 3 / (3 * EI) + a / kGA, rel=TOL)
    assert cant.line_load_deflection(L, 0, L)[0] == pytest.approx(L ** 4 / (8 * EI) + L ** 2 / (2 * kGA), rel=TOL)
    ss = PinBeam(PinSupport(model="simply_supported", ends=(0.0, L), shear=shear), R, E, NU)
    # simply supported: P a^2 b^2/(3 L EI) + P a b/(L kGA); Maxwell reciprocity g(x, xi) = g(xi, x)
    assert ss.influence([a], [a])[0, 0] == pytest.approx(a * a * b * b / (3 * L * EI) + a * b / (L * kGA), rel=TOL)
    g = ss.influence([a, 0.5 * L], [a, 0.5 * L])
    assert g[0, 1] == pytest.approx(g[1, 0], rel=1e-12)
    assert ss.line_load_deflection(0.5 * L, 0, L)[0] == pytest.approx(5 * L ** 4 / (384 * EI) + L ** 2 / (8 * kGA),
                                                                        rel=TOL)
    # a station over the whole span: mean deflection under a unit resultant, L^3/(120 EI) + L/(12 kGA)
    assert ss.station_compliance([0.5 * L], L)[0, 0] == pytest.approx(L ** 3 / (120 * EI) + L / (12 * kGA), rel=TOL)
    cc = PinBeam(PinSupport(model="clamped_clamped", ends=(0.0, L), shear=shear), R, E, NU)
    assert cc.influence([0.5 * L], [0.5 * L])[0, 0] == pytest.approx(L ** 3 / (192 * EI) + L / (4 * kGA), rel=TOL)
    assert cc.line_load_deflection(0.5 * L, 0, L)[0] == pytest.approx(L ** 4 / (384 * EI) + L ** 2 / (8 * kGA), rel=TOL)


def test_station_compliance_is_symmetric_positive_definite():
    beam = PinBeam(PinSupport(model="cantilever", ends=(-0.012, 0.012)), R, E, NU)
    C = beam.station_compliance([-0.006, 0.006], 0.008)
    assert C[0, 1] == pytest.approx(C[1, 0], rel=1e-12)
    assert np.all(np.linalg.eigvalsh(C) > 0)
    assert C[1, 1] > C[0, 0]            # the station farther from the clamp is softer


def test_support_errors_name_the_key():
    d = load_design(designs.path("rd40"))
    with pytest.raises(RvtoolInputError, match="pins.support.model"):
        replace(d, pins={"support": {"model": "glued"}})
    with pytest.raises(RvtoolInputError, match="output_pins.support.ends"):
        replace(d, output_pins={"support": {"model": "cantilever", "ends": [0.01, 0.01]}})
    short = replace(d, pins={"support": {"model": "simply_supported", "ends": [-0.005, 0.005]}})
    with pytest.raises(RvtoolInputError, match="pins.support.ends"):
        pin_station_compliance(short, Family.PINS)
    power = replace(d, pins={"support": {"model": "simply_supported", "ends": [-0.015, 0.015]}},
                    pin_contact={"law": "power", "stiffness": 1e9})
    with pytest.raises(RvtoolInputError, match="pin_contact.law"):
        pin_meshes(power)
    single = replace(d, n_wheels=1, wheels={"midplanes": (0.0,), "phases_deg": (0.0,)},
                     output_pins={"support": {"model": "cantilever", "ends": [-0.012, 0.012]}})
    with pytest.raises(RvtoolInputError, match="n_wheels = 2"):
        output_pin_mechanism(single)


def test_rigid_is_nothing_and_elastic_ring_pins_are_in_series():
    d = load_design(designs.path("rd40"))
    assert pin_station_compliance(d, Family.PINS) is None and pin_station_compliance(d, Family.OUTPUT_PINS) is None
    assert output_pin_mechanism(d).mode == PinMode.PLAIN
    el = replace(d, pins={"support": {"model": "simply_supported", "ends": [-0.015, 0.015]}})
    C = pin_station_compliance(el, Family.PINS)
    _, rigid = pin_meshes(d)
    _, elastic = pin_meshes(el)
    for k, (mr, me) in enumerate(zip(rigid, elastic)):
        # Eq. (series_contact): 1/k = 1/k_c + C_kk, each pin station allocated once
        assert 1.0 / me.normal.stiffness == pytest.approx(1.0 / mr.normal.stiffness + C[k, k], rel=1e-12)


def test_elastic_output_pin_shared_closure_reduces_to_plain_at_zero_compliance():
    d = load_design(designs.path("rd40"))
    el = replace(d, output_pins={"support": {"model": "cantilever", "ends": [-0.012, 0.012]}})
    mech = output_pin_mechanism(el)
    assert mech.mode == PinMode.SHARED and mech.sleeve.clearance == 0.0
    C = pin_station_compliance(el, Family.OUTPUT_PINS)
    assert mech.compliance.cross_compliance == pytest.approx(C[0, 1])
    zero = dataclasses.replace(mech, compliance=dataclasses.replace(mech.compliance, self_compliance_0=0.0,
                                                                    self_compliance_1=0.0, cross_compliance=0.0))
    pose = np.zeros((4, 3))
    pose[1, :2], pose[2, :2] = (0.0, 8e-4), (0.0, -8e-4)
    pose[1:3, 2] = 4e-4
    ev = {m: OutputPinEvaluator(mm, flange=3, wheels=(1, 2), n_bodies=4, backend="numpy").evaluate(pose, 0 * pose)
          for m, mm in (("plain", output_pin_mechanism(d)), ("zero", zero), ("elastic", mech))}
    assert np.array_equal(ev["plain"].obs, ev["zero"].obs)
    assert np.array_equal(ev["plain"].Q, ev["zero"].Q)
    # the beam in series can only relieve the contacts at prescribed poses
    f_plain, f_el = ev["plain"].obs[:, 0].sum(), ev["elastic"].obs[:, 0].sum()
    assert 0 < f_el < f_plain
