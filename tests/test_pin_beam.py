"""Issue 21: elastic pins (beam station compliance, series with the contact law, rigid = nothing)."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.cycloid import pin_meshes, pin_station_compliance
from rvtool.assembly.spec import load_design, replace
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
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


def test_rigid_is_nothing():
    d = load_design(designs.path("rd40"))
    assert pin_station_compliance(d, Family.PINS) is None and pin_station_compliance(d, Family.OUTPUT_PINS) is None
    assert d.output_pins.mode == PinMode.PLAIN
    _, meshes = pin_meshes(d)
    assert all(m.pin_bodies is None for m in meshes)


@pytest.mark.parametrize("shear", [False, True])
def test_bending_moment_against_closed_forms(shear):
    a, P, q = 0.3 * L, 1000.0, 1000.0 / L
    b = L - a
    W = np.pi * R ** 3 / 4

    def m_max(model, points, loads):
        beam = PinBeam(PinSupport(model=model, ends=(0.0, L), shear=shear), R, E, NU)
        return np.abs(beam.internal_forces(points, loads)[1][:, 0]).max()
    # point load P at a: cantilever P a at the clamp; simply supported P a b / L under the load
    # (statically determinate: shear deformation leaves the moments as they are)
    assert m_max("cantilever", [a], [[P, 0]]) == pytest.approx(P * a, rel=1e-12)
    assert m_max("simply_supported", [a], [[P, 0]]) == pytest.approx(P * a * b / L, rel=1e-12)
    if not shear:
        # clamped--clamped (indeterminate, Euler--Bernoulli): P a b^2 / L^2 at the nearer clamp
        assert m_max("clamped_clamped", [a], [[P, 0]]) == pytest.approx(P * a * b * b / L ** 2, rel=1e-12)
    # uniform q over the span as one station: q L^2/2, q L^2/8, q L^2/12 (the symmetric
    # clamped--clamped moment does not depend on shear); the lumped Gauss-point loads reproduce
    # them to 1e-9 (measured 5e-10)
    for model, ref in (("cantilever", q * L * L / 2), ("simply_supported", q * L * L / 8),
                       ("clamped_clamped", q * L * L / 12)):
        beam = PinBeam(PinSupport(model=model, ends=(0.0, L), shear=shear), R, E, NU)
        sigma, tau, _ = beam.station_stresses([0.5 * L], L, [[0.6 * q * L, 0.8 * q * L]])
        assert sigma * W == pytest.approx(ref, rel=1e-9)
    # shear: a cantilever carries the whole load at the clamp, 4 V / (3 A)
    sigma, tau, z = PinBeam(PinSupport(model="cantilever", ends=(0.0, L), shear=shear), R, E, NU).station_stresses(
        [0.5 * L], L, [[P, 0.0]])
    assert tau == pytest.approx(4 * P / (3 * np.pi * R * R), rel=1e-12) and z == pytest.approx(0.0)


def test_rd40_pin_bending_from_station_loads():
    from rvtool.assembly import build
    from rvtool.solver.static import StaticSolver
    d = load_design(designs.path("rd40"))
    m = build(d, bearing_model="lumped")
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    assert m.pin_bending(q, "output_pins") is None            # rigid pins and nothing assumed
    cant = PinSupport(model="cantilever", ends=(-0.012, 0.012))
    b = m.pin_bending(q, "output_pins", cant)
    loads = m.pin_station_loads(q, "output_pins")
    # the station resultants are the per-contact loads
    assert np.linalg.norm(loads, axis=2).max() == pytest.approx(m.family_contact_peaks(q)["output_pins"], rel=1e-12)
    # each RD-40 output pin is loaded by one wheel only at this state: a cantilever with its load
    # F at the station centre z_s (uniform over the width) has M = F (z_s - z_clamp) at the clamp
    F = np.linalg.norm(loads, axis=2)
    p = b["pin"]
    k = int(np.argmax(F[p]))
    assert F[p].min() == 0.0
    r = d.output_pins.pin_radius
    M = F[p, k] * (d.wheels.midplanes[k] + 0.012)
    assert b["sigma_max_Pa"] == pytest.approx(M / (np.pi * r ** 3 / 4), rel=1e-9)
    assert b["z_m"] == pytest.approx(-0.012) and b["support_source"].startswith("assumed")


def test_support_compliance_in_series():
    # springs of compliance c_s at the supports: a cantilever's clamp translates by P c_s (tip
    # P L^3/(3EI) + P L/kGA + P c_s); a simply supported pin under a central load sinks by the mean
    # of its support motions, P c_s / 2 (P L^3/(48 EI) + P L/(4 kGA) + P c_s/2); the moments stay
    # (statically determinate)
    cs = 2e-9
    cant = PinBeam(PinSupport(model="cantilever", ends=(0.0, L), support_compliance=cs), R, E, NU)
    rigid = PinBeam(PinSupport(model="cantilever", ends=(0.0, L)), R, E, NU)
    assert cant.influence([L], [L])[0, 0] == pytest.approx(rigid.influence([L], [L])[0, 0] + cs, rel=1e-10)
    ss = PinBeam(PinSupport(model="simply_supported", ends=(0.0, L), support_compliance=cs), R, E, NU)
    EI, kGA = ss.EI, ss.kGA
    assert ss.influence([0.5 * L], [0.5 * L])[0, 0] == pytest.approx(L ** 3 / (48 * EI) + L / (4 * kGA) + cs / 2,
                                                                      rel=1e-10)
    assert np.abs(ss.internal_forces([0.3 * L], [[1000.0, 0]])[1][:, 0]).max() == pytest.approx(1000 * 0.21 * L,
                                                                                              rel=1e-10)
    with pytest.raises(RvtoolInputError, match="support_compliance"):
        PinSupport(model="cantilever", ends=(0.0, L), support_compliance=-1.0)


@pytest.mark.parametrize("model", ["cantilever", "simply_supported", "clamped_clamped"])
def test_station_stress_map_equals_the_beam_solve(model):
    # the map is the beam solve under unit station loads; superposition of two stations' x and y
    # resultants must reproduce the direct solve to round-off (1e-9: the shear of the
    # Euler-Bernoulli element is a difference of large end forces)
    beam = PinBeam(PinSupport(model=model, ends=(-0.015, 0.015), shear=True), R, E, NU)
    centres, width = [-0.006, 0.006], 0.008
    smap = beam.station_stress_map(centres, width)
    for res in ([[300.0, -50.0], [-20.0, 900.0]], [[0.0, 1.0], [0.0, 0.0]], [[1e3, 1e3], [-1e3, 2e3]]):
        direct = beam.station_stresses(centres, width, res)
        mapped = smap.stresses(res)
        assert mapped[0] == pytest.approx(direct[0], rel=1e-9) and mapped[1] == pytest.approx(direct[1], rel=1e-9)
        assert mapped[2] == pytest.approx(direct[2], abs=1e-12)


def test_rd40_pin_bending_over_states_is_the_largest_single_state():
    # the stress over a sequence of states is the largest of the single-state stresses (same pins,
    # same support), and names the state where it occurs
    from rvtool.assembly import build
    from rvtool.solver.static import StaticSolver
    d = load_design(designs.path("rd40"))
    m = build(d, bearing_model="lumped")
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    solver = StaticSolver(m)
    states = [solver.solve(a) for a in (0.0, 0.05, 0.1)]
    cant = PinSupport(model="cantilever", ends=(-0.012, 0.012))
    single = [m.pin_bending(q, "output_pins", cant)["sigma_max_Pa"] for q in states]
    over = m.pin_bending(states, "output_pins", cant)
    assert over["sigma_max_Pa"] == pytest.approx(max(single), rel=1e-12)
    assert over["state"] == int(np.argmax(single))
    assert max(single) > min(single)          # the angles differ: the test can tell the states apart
