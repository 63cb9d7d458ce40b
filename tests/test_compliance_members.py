"""Issue 30, Deliver 1: the ring pin in its housing groove and crank torsion (rvtool.contact.groove,
rvtool.structure.crank_torsion, their switches in the RV builder)."""
import math

import numpy as np
import pytest

import rvtool
from rvtool.contact.groove import X_HI, X_LO, GrooveLaw, GrooveSupport, inverse_shape, shape
from rvtool.errors import RvtoolInputError
from rvtool.output_pins.calibration import hertz_pin_in_hole_approach
from rvtool.structure.crank_torsion import polar_moment, shear_modulus, torsion_compliance

E, NU = 206e9, 0.3
ES = E / (2 * (1 - NU ** 2))
LAW = GrooveLaw(clearance=5e-6, length=0.012, contact_modulus=ES, pin_radius=0.0035)


def test_law_is_johnsons_conformal_approach_on_its_range():
    # the project's independent implementation of Johnson's pin-in-hole approach (output pins);
    # 1e-12: the two differ only by the order of the same floating-point operations
    F = np.geomspace(LAW.force_scale * X_LO * 1.01, LAW.force_scale * X_HI * 0.99, 25)
    ref = [hertz_pin_in_hole_approach(f, 0.0035, 0.0035 + 5e-6, 0.012, E, NU) for f in F]
    np.testing.assert_allclose(LAW.approach(F)[0], ref, rtol=1e-12)


def test_law_continuations_are_c1_and_monotone():
    for x0 in (X_LO, X_HI):
        h_m, d_m = shape(x0 * (1 - 1e-12))
        h_p, d_p = shape(x0 * (1 + 1e-12))
        assert abs(h_p - h_m) <= 1e-10 * h_m and abs(d_p - d_m) <= 1e-9 * d_m
    x = np.geomspace(1e-12, 10.0, 2000)
    h, dh = shape(x)
    assert np.all(np.diff(h) > 0) and np.all(dh > 0)


def test_inverse_round_trip():
    x = np.concatenate([[0.0], np.geomspace(1e-30, 5.0, 400)])
    h, _ = shape(x)
    np.testing.assert_allclose(inverse_shape(h), x, rtol=1e-12, atol=0.0)


@pytest.mark.parametrize("x", [1e-7, 1e-3, 0.02, 0.2])
def test_law_tangents_match_central_differences(x):
    # 1e-6: central differences at a relative step 1e-6 carry O(step^2) truncation and 1e-10 round-off
    F = LAW.force_scale * x
    h = 1e-6 * F
    d, dd = LAW.approach(F)
    fd = (LAW.approach(F + h)[0] - LAW.approach(F - h)[0]) / (2 * h)
    assert abs(dd - fd) <= 1e-6 * abs(dd)
    k_force, k = LAW.force(d)
    hd = 1e-6 * d
    fd = (LAW.force(d + hd)[0] - LAW.force(d - hd)[0]) / (2 * hd)
    assert abs(k - fd) <= 1e-6 * abs(k)
    assert abs(k_force - F) <= 1e-12 * F


def test_station_law_tangent_matches_central_differences():
    rng = np.random.default_rng(3)
    sup = GrooveSupport(LAW)
    u = rng.normal(scale=3e-7, size=(3, 2, 2))
    F, G = sup.forces(u)
    h = 1e-13
    flat = u.ravel()
    J = np.zeros((flat.size, flat.size))
    for i in range(flat.size):
        up, um = flat.copy(), flat.copy()
        up[i] += h
        um[i] -= h
        J[:, i] = (sup.forces(up.reshape(u.shape))[0] - sup.forces(um.reshape(u.shape))[0]).ravel() / (2 * h)
    blocks = np.zeros_like(J)
    for p in range(3):
        blocks[4 * p:4 * p + 4, 4 * p:4 * p + 4] = G[p]
    assert np.abs(J - blocks).max() <= 1e-6 * np.abs(blocks).max()


def test_torsion_compliance_is_the_shaft_formula():
    r, zg, z = 0.01, -0.03, (-0.0075, 0.0075)
    GJ = shear_modulus(E, NU) * polar_moment(r)
    assert math.isclose(GJ, E / (2 * 1.3) * math.pi * r ** 4 / 2, rel_tol=1e-15)
    C = torsion_compliance(r, E, NU, zg, z)
    np.testing.assert_allclose(C, np.array([[0.0225, 0.0225], [0.0225, 0.0375]]) / GJ, rtol=1e-12)
    # a gear between the journals: no shared path
    C2 = torsion_compliance(r, E, NU, 0.0, z)
    assert C2[0, 1] == 0.0 and C2[0, 0] > 0


@pytest.mark.parametrize("section,data,key", [
    ("pins", {"groove": "soft"}, "pins.groove"),
    ("pins", {"groove": "conformal"}, "pins.groove_clearance"),
    ("pins", {"groove": "conformal", "groove_clearance": 0.0}, "pins.groove_clearance"),
    ("pins", {"groove": "conformal", "groove_clearance": 0.01}, "pins.groove_clearance"),
    ("cranks", {"shaft": {"torsion": "yes"}}, "torsion"),
    ("cranks", {"shaft": {"torsion": "elastic", "model": "simply_supported"}}, "torsion"),
])
def test_bad_switches_name_their_key(section, data, key):
    with pytest.raises(RvtoolInputError, match=key):
        rvtool.load_design("rvtool/designs/rv40e.toml").replace(**{section: data})


def test_cycloid_refuses_a_conformal_groove():
    d = rvtool.load_design("rvtool/designs/rd40.toml").replace(pins={"groove": "conformal", "groove_clearance": 5e-6})
    with pytest.raises(RvtoolInputError, match="pins.groove"):
        rvtool.build(d)


def _rated_tangent(design):
    from rvtool.protocols.stiffness import condensed_tangent
    from rvtool.solver.static import StaticSolver
    m = rvtool.build(design)
    m.set_output_torque(-np.sign(m.ratio) * design.rated_torque)
    q = StaticSolver(m).solve(0.0)
    return condensed_tangent(m, q)


def test_rigid_switches_keep_rv40e_bit_identical():
    d = rvtool.load_design("rvtool/designs/rv40e.toml")
    k0 = _rated_tangent(d)
    k1 = _rated_tangent(d.replace(pins={"groove": "rigid"}, cranks={"shaft": {"torsion": "rigid"}}))
    assert k0 == k1


def test_rigid_groove_keeps_rd40_bit_identical():
    from rvtool.protocols.stiffness import condensed_tangent
    from rvtool.solver.static import StaticSolver
    out = []
    d = rvtool.load_design("rvtool/designs/rd40.toml")
    for dd in (d, d.replace(pins={"groove": "rigid"})):
        m = rvtool.build(dd)
        m.set_output_torque(-np.sign(m.ratio) * dd.rated_torque)
        out.append(condensed_tangent(m, StaticSolver(m).solve(0.0)))
    assert out[0] == out[1]


def test_members_soften_rv40e_by_a_bounded_share():
    # measured 3.3 % (groove, 5 um) and 0.92 % (torsion): each lowers the tangent; bounds 0.1-20 % / 0.1-5 %
    d = rvtool.load_design("rvtool/designs/rv40e.toml")
    k0 = _rated_tangent(d)
    kg = _rated_tangent(d.replace(pins={"groove": "conformal", "groove_clearance": 5e-6}))
    kt = _rated_tangent(d.replace(cranks={"shaft": {"torsion": "elastic"}}))
    assert 1e-3 < 1 - kg / k0 < 0.2
    assert 1e-3 < 1 - kt / k0 < 0.05
