"""Issue 30, Deliver 1: the ring pin in its housing groove and crank torsion (rvtool.contact.groove,
rvtool.structure.crank_torsion, their switches in the RV builder)."""
import math

import numpy as np
import pytest

import rvtool
from rvtool.contact import conformal_pin as cp
from rvtool.contact.groove import GrooveLaw, GrooveSupport, hertz_approach
from rvtool.errors import RvtoolInputError
from rvtool.output_pins.calibration import hertz_pin_in_hole_approach
from rvtool.structure.crank_torsion import polar_moment, shear_modulus, torsion_compliance

E, NU = 206e9, 0.3
ES = E / (2 * (1 - NU ** 2))
LAW = GrooveLaw(clearance=5e-6, length=0.012, contact_modulus=ES)


@pytest.mark.parametrize("nu", [0.25, 0.3])
def test_michell_coefficients_sum_to_persson_kernel(nu):
    # Eq. (1): both bodies' coefficients from Michell's functions sum to (2 R / E*) n / (n^2 - 1), nu-free;
    # each body tends to the half-plane's (1 - nu) R / (G n) (1e-3 at n = 1000: O(1/n) curvature terms)
    R, G = 0.0035, E / (2 * (1 + nu))
    es = E / (2 * (1 - nu ** 2))
    for n in range(2, 30):
        h, d = cp.body_coefficients(n, R, G, nu)
        assert math.isclose(h + d, 2 * R / es * n / (n * n - 1), rel_tol=1e-11)
    h, d = cp.body_coefficients(0, R, G, nu)
    assert math.isclose(h + d, R / es, rel_tol=1e-14)
    for c in cp.body_coefficients(1000, R, G, nu):
        assert math.isclose(c, (1 - nu) * R / (G * 1000), rel_tol=1e-3)


def test_reference_converges_and_meets_the_hertz_limit():
    # the approach is an integral of the pressure: 2048 vs 4096 nodes within 3e-6 (measured 1.0e-6)
    a, eps, _ = cp.reference(1.0)
    b, _, _ = cp.reference(1.0, n_nodes=4096)
    assert abs(a - b) <= 3e-6 * b
    assert 45 < math.degrees(eps) < 55          # 50.4 deg: far outside Hertz's small-angle assumption
    # small load: (x / pi) ln(pi / x); the next term is O(x) relative (1.6e-5 measured at 1e-4)
    x = 1e-4
    v, _, _ = cp.reference(x, n_nodes=32768)
    assert abs(v / cp.hertz_limit(x)[0] - 1) <= 1e-4
    # Johnson's two-body approach less its net-force mode (ln 4 - 1) x / pi (identified to 5e-6 at 1e-5)
    j = x / math.pi * (math.log(4 * math.pi / x) - 1) - (math.log(4) - 1) * x / math.pi
    assert abs(v / j - 1) <= 1e-4


def test_law_reproduces_the_reference_between_table_points():
    # PCHIP in (ln x, ln psi) at 8 points per decade: O(h^3) with h = ln(10)/8; 2e-4 bound, measured 9e-5
    xm = np.sqrt(cp.TABLE_X[:-1] * cp.TABLE_X[1:])[::6]
    for x in xm:
        assert abs(cp.psi(x)[0] / cp.reference(x)[0] - 1) <= 2e-4


def test_law_is_c1_monotone_and_inverts():
    for x0 in (cp.X_FLOOR, cp.X_TABLE_LO, cp.X_TABLE_HI):
        v_m, d_m = cp.psi(x0 * (1 - 1e-12))
        v_p, d_p = cp.psi(x0 * (1 + 1e-12))
        assert abs(v_p - v_m) <= 1e-10 * v_m and abs(d_p - d_m) <= 1e-8 * d_m
    x = np.geomspace(1e-14, 1e5, 3000)
    v, d = cp.psi(x)
    assert np.all(np.diff(v) > 0) and np.all(d > 0)
    np.testing.assert_allclose(cp.psi_inverse(v), x, rtol=1e-12)
    assert cp.psi_inverse(0.0) == 0.0


def test_hertz_approach_is_the_output_pin_closed_form():
    F = np.geomspace(10.0, 2000.0, 7)
    ref = [hertz_pin_in_hole_approach(f, 0.0035, 0.0035 + 5e-6, 0.012, E, NU) for f in F]
    np.testing.assert_allclose(hertz_approach(F, 5e-6, 0.012, ES), ref, rtol=1e-12)


@pytest.mark.parametrize("x", [1e-7, 1e-3, 0.02, 0.2, 5.0, 3e3])
def test_law_tangents_match_central_differences(x):
    # 1e-6: central differences at a relative step 1e-6 carry O(step^2) truncation and 1e-10 round-off
    F = LAW.force_scale * x
    h = 1e-6 * F
    d, dd = LAW.approach(F)
    fd = (LAW.approach(F + h)[0] - LAW.approach(F - h)[0]) / (2 * h)
    assert abs(dd - fd) <= 1e-6 * abs(dd)
    f_back, k = LAW.force(d)
    hd = 1e-6 * d
    fd = (LAW.force(d + hd)[0] - LAW.force(d - hd)[0]) / (2 * hd)
    assert abs(k - fd) <= 1e-6 * abs(k)
    assert abs(f_back - F) <= 1e-12 * F


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
    ("cranks", {"shaft": {"torsion": "elastic", "radius": None}}, "radius"),
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
    # measured (groove, 5 um; torsion 0.92 %): each lowers the tangent; bounds 0.1-20 % / 0.1-5 %
    d = rvtool.load_design("rvtool/designs/rv40e.toml")
    k0 = _rated_tangent(d)
    kg = _rated_tangent(d.replace(pins={"groove": "conformal", "groove_clearance": 5e-6}))
    kt = _rated_tangent(d.replace(cranks={"shaft": {"torsion": "elastic"}}))
    assert 1e-3 < 1 - kg / k0 < 0.2
    assert 1e-3 < 1 - kt / k0 < 0.05


@pytest.mark.parametrize("switch,path", [
    ({"pins": {"groove": "conformal", "groove_clearance": 5e-6}}, "pin_grooves"),
    ({"cranks": {"shaft": {"torsion": "elastic"}}}, "crank_torsion")])
def test_budget_books_the_member_as_its_own_path(switch, path):
    # the energy share of the member's path (du^T ds/du du) against its switch-on share (C_on - C_off)/C_on:
    # members in series agree up to the load redistribution they cause (measured 5e-5 absolute); 2e-3
    from rvtool.protocols.budget import stiffness_budget
    from rvtool.solver.static import StaticSolver
    d0 = rvtool.load_design("rvtool/designs/rv40e.toml")
    d = d0.replace(**switch)
    m = rvtool.build(d)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    b = stiffness_budget(m, StaticSolver(m).solve(0.0))
    switch_on = 1 - _rated_tangent(d) / _rated_tangent(d0)
    assert abs(b["shares"][path] - switch_on) <= 2e-3
    assert abs(b["sensitivity_shares"][path] - b["shares"][path]) <= 1e-4
    assert abs(b["shares"]["geometric_and_regularization"]) <= 1e-3


def test_torsion_with_bending_adds_the_same_compliance():
    # the twisting journals inside the beam's closure: torsion adds to the bending variant's compliance what it
    # adds to the rigid cranks' (members in series; 2 % for the load redistribution, measured 0.1 %)
    d0 = rvtool.load_design("rvtool/designs/rv40e.toml")
    db = d0.replace(cranks={"shaft": {"model": "simply_supported"}})
    k0, kt = _rated_tangent(d0), _rated_tangent(d0.replace(cranks={"shaft": {"torsion": "elastic"}}))
    kb, kbt = _rated_tangent(db), _rated_tangent(db.replace(cranks={"shaft": {"torsion": "elastic"}}))
    added_rigid, added_bent = 1 / kt - 1 / k0, 1 / kbt - 1 / kb
    assert added_rigid > 0 and abs(added_bent / added_rigid - 1) <= 0.02
