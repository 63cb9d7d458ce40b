"""Flexible RV crankshafts as floating bodies (issue 33, Deliver 2): the free beam and its basis, the
switch, frozen = rigid, the element tangent against the linear model, mounted vs full FE modes, the
refusals, the markers and a short driven run."""
import numpy as np
import pytest

import rvtool
from _flex_helpers import (COARSE, assert_backends_refuse, assert_frozen_is_rigid, assert_tangent_is_the_linear_model,
                           short_driven_run)
from _flex_helpers import flexible_cranks as flexible
from _flex_helpers import rated_state as _rated_state
from rvtool import designs
from rvtool.assembly.spec import replace
from rvtool.errors import RvtoolInputError
from rvtool.units import ARCSEC_PER_RAD


@pytest.fixture(scope="module")
def rv40e():
    return rvtool.load_design(designs.path("rv40e"))


@pytest.fixture(scope="module")
def flex_model(rv40e):
    return rvtool.build(flexible(rv40e))


@pytest.fixture(scope="module")
def rated_state(rv40e, flex_model):
    return _rated_state(flex_model, rv40e)


def test_free_beam_modes_against_the_euler_bernoulli_closed_form():
    # a free-free slender steel shaft: first bending mode (beta L)^2 sqrt(EI / (rho A L^4)) / 2 pi with
    # beta L = 4.7300 (Euler-Bernoulli); L / r = 100 so shear and rotary inertia move it by ~1e-3
    # (Timoshenko correction ~ (1 + 12.5 (r / L)^2 ...)); first torsion mode pi / L sqrt(G / rho)
    from rvtool.structure.crank_modes import CrankStation, crank_beam_model, elastic_modes
    r, L, E, nu, rho = 0.005, 0.5, 2.1e11, 0.3, 7850.0
    beam = crank_beam_model(r, (CrankStation("a", 0.0, 0.0), CrankStation("b", L, 0.0)), E, nu, rho,
                            element_length=L / 100)
    lam, Phi = elastic_modes(beam)
    f = np.sqrt(lam) / (2 * np.pi)
    I, A = np.pi * r ** 4 / 4, np.pi * r ** 2
    f_b = 4.7300 ** 2 * np.sqrt(E * I / (rho * A * L ** 4)) / (2 * np.pi)
    f_t = np.pi / L * np.sqrt(E / (2 * (1 + nu)) / rho) / (2 * np.pi)
    assert abs(f[0] / f_b - 1) < 2e-3 and abs(f[1] / f_b - 1) < 2e-3          # the two bending planes
    assert np.min(np.abs(f / f_t - 1)) < 1e-3
    # mean axis: the elastic modes are M-orthogonal to the five rigid modes
    assert np.abs(Phi.T @ beam.mass @ beam.rigid).max() < 1e-9


def test_switch_defaults_to_rigid(rv40e):
    assert rv40e.cranks.dynamics.model == "rigid"
    m = rvtool.build(rv40e)
    assert m.flexible_cranks is None and "crank_modes_hz" not in m.marker_frequencies(rv40e.input_speed_rpm)
    with pytest.raises(RvtoolInputError, match="valid choices are \\['rigid', 'flexible'\\]"):
        replace(rv40e, cranks={"dynamics": {"model": "elastic"}})


def test_frozen_flexible_cranks_reproduce_the_rigid_te(rv40e):
    # held modal coordinates: every virtual body sits on its crank, so only the Newton system's size changes
    # its round-off; TE within 1e-6 arcsec (the golden backends' bound), equilibria 1e-9 relative
    angles = np.arange(3) * rvtool.build(rv40e).mesh_period / 3
    assert_frozen_is_rigid(rv40e, flexible(rv40e, frozen=True), angles, structure="cranks")


def test_element_tangent_equals_the_crank_linear_model(flex_model, rated_state):
    from rvtool.protocols.flexible_modes import crank_linear_model
    m, q = flex_model, rated_state
    assert np.abs(m.structures["cranks"].coordinates()).max() > 0
    assert_tangent_is_the_linear_model(m, q, crank_linear_model(m, q))


def test_mounted_crank_modes_against_the_full_beam(flex_model, rated_state):
    from rvtool.protocols.flexible_modes import crank_modes
    red = crank_modes(flex_model, rated_state, n=6)
    ful = crank_modes(flex_model, rated_state, n=6, full=True)
    # the 1 % on the first modes (4 free-free modes + the station static responses)
    assert np.abs(red["frequencies_hz"] / ful["frequencies_hz"] - 1).max() < 0.01
    # Rayleigh-Ritz: a subspace of the full elastic space can only be stiffer
    assert np.all(red["frequencies_hz"] >= ful["frequencies_hz"] * (1 - 1e-9))
    assert ful["n_coordinates"] > red["n_coordinates"]


@pytest.mark.parametrize("section, change, key", [
    ("cranks", {"shaft": {"model": "simply_supported"}}, "cranks.shaft.model"),
    ("bodies", {"crank_coordinates": "spatial"}, "bodies.crank_coordinates"),
    ("carrier", {"body": "ported"}, "carrier.body"),
])
def test_unsupported_combinations_are_refused_by_name(rv40e, section, change, key):
    d = replace(flexible(rv40e), **{section: change})
    with pytest.raises(RvtoolInputError, match=key.replace(".", r"\.")):
        rvtool.build(d)


def test_backends_markers_and_a_short_driven_run(rv40e, flex_model):
    assert_backends_refuse(flex_model, (("device", "equilibria"), ("fused", "dynamic")))
    mk = flex_model.marker_frequencies(rv40e.input_speed_rpm)
    assert mk["crank_modes_hz"] == sorted({float(f) for f in flex_model.flexible_cranks.body.frequencies_hz})
    short_driven_run(flex_model, rv40e, 10)


def test_flexible_wheels_and_cranks_share_one_modal_structure(rv40e):
    # both switches on: one modal structure (wheels, then cranks), the needle rows between two virtual bodies;
    # frozen both = rigid, and each frozen flag holds its own bodies only
    from rvtool.protocols.precision import quasi_static_te

    def both(wf, cf):
        d = replace(flexible(rv40e, frozen=cf), wheels={"dynamics": {"model": "flexible", "n_modes": 4,
                                                                     "static_orders": 1, "frozen": wf},
                                                        "structure": COARSE})
        return rvtool.build(d)
    rigid = rvtool.build(rv40e)
    angles = np.arange(2) * rigid.mesh_period / 2
    frozen = both(True, True)
    fb = frozen.structures["flexible_bodies"]
    assert frozen.flexible is not None and frozen.flexible_cranks is not None
    assert fb is frozen.flexible.coordinates is frozen.flexible_cranks.coordinates
    assert set(fb.coordinate_indices()) <= frozen.fixed_coordinates()
    te_r = np.asarray(quasi_static_te(rigid, torque=rv40e.rated_torque, input_angles=angles)["te"])
    te_f = np.asarray(quasi_static_te(frozen, torque=rv40e.rated_torque, input_angles=angles)["te"])
    assert np.abs(te_f - te_r).max() * ARCSEC_PER_RAD < 1e-6
    m = both(False, True)
    held = set(m.fixed_coordinates())
    idx = m.structures["flexible_bodies"].coordinate_indices()
    assert not set(idx[fb.slice("wheel0")]) & held and set(idx[fb.slice("crank0")]) <= held
    needles = m.elements["eccentric_bearings"].evaluator
    nm = len(needles.mountings)
    assert all(mt.inner == m.layout.n_bodies + i and mt.outer == m.layout.n_bodies + nm + i
               for i, mt in enumerate(needles.mountings))
    from rvtool.protocols.flexible_modes import crank_modes
    with pytest.raises(RvtoolInputError, match="not implemented"):
        crank_modes(m, np.zeros(1))
