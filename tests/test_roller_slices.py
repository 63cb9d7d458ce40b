"""Influence-coefficient roller slices (paper Eq. (bearing_ic)): the compliance is the prescribed
pressure shape's, the solve is the exact complementarity solution, the tangent is its derivative, the
Warp kernel is the NumPy reference on every device, and the bearing sets honour the design switch."""
import math

import numpy as np
import pytest
import warp as wp
from scipy import integrate

from rvtool.assembly.spec import build_section
from rvtool.bearings.influence import bearing_slice_parameters, compliance_matrix, edge_weights, two_body_modulus
from rvtool.bearings.set import BearingSet, InfluenceBearingSet, Mounting
from rvtool.bearings.spec import NeedleBearing
from rvtool.bearings.tapered import TaperedPair, TaperedRollerBearing
from rvtool.bearings.tapered_set import TaperedBearingSet, TaperedMounting
from rvtool.errors import RvtoolInputError
from warp_contacts import roller_slices_ref as sref

E_STAR = two_body_modulus(206e9, 0.3)
MODES = (sref.HALF_WIDTH_FIXED, sref.HALF_WIDTH_ROLLER_LOAD, sref.HALF_WIDTH_SLICE_LOAD)


def _roller(n, length=8e-3, diameter=3e-3, inner_radius=0.012):
    fp, ip = bearing_slice_parameters(NeedleBearing(inner_radius=inner_radius, roller_diameter=diameter,
                                                    roller_length=length, n_rollers=16, n_slices=n,
                                                    slices="influence"))
    return fp, ip


def _approach(n, length, mean, tilt, crown):
    y = (np.arange(n) + 0.5) / n * length - 0.5 * length
    return mean + tilt * y - crown * (2 * y / length) ** 2


@pytest.mark.parametrize("k", [0, 1, 3])
def test_strip_integral_is_the_hertz_strip_mean_displacement(k):
    # I_k = (2/(pi b)) (1/dy) int_{receiver slice} int_{-b}^{b} sqrt(1 - x^2/b^2) int_{strip} dy' / r, with
    # x = b sin(theta) and the strip's y' integral in closed form (asinh); adaptive 2-D quadrature.
    # Tolerance: the quadrature's own accuracy on the log-singular self term (epsabs 1e-10 per unit).
    dy, b = 1e-3, 1.5e-4
    Y1, Y2 = (k - 0.5) * dy, (k + 0.5) * dy

    def integrand(theta, t):
        c = b * math.sin(theta)
        return math.cos(theta) ** 2 * (math.asinh((Y2 - t) / c) - math.asinh((Y1 - t) / c))

    pts = 0.5 * dy
    val, err = integrate.dblquad(integrand, -pts, pts, 1e-14, 0.5 * math.pi, epsabs=1e-11, epsrel=1e-11)
    direct = (4.0 / math.pi) * val / dy
    I, _ = sref.strip_integral(k, dy, b)
    assert I == pytest.approx(direct, rel=1e-7)


def test_half_width_derivative_of_the_compliance():
    # dI/db analytic vs central differences (step 1e-4 b: truncation ~1e-8, round-off ~1e-12 of I / h)
    dy, b = 1e-3, 1.5e-4
    for k in range(4):
        h = 1e-4 * b
        fd = (sref.strip_integral(k, dy, b + h)[0] - sref.strip_integral(k, dy, b - h)[0]) / (2 * h)
        assert sref.strip_integral(k, dy, b)[1] == pytest.approx(fd, rel=1e-6)


def test_compliance_is_both_races_and_positive_definite():
    fp, ip = _roller(8)
    n = 8
    B = np.array([np.full(n, fp[sref.SL_BIN]), np.full(n, fp[sref.SL_BOUT])])
    C = sref.compliance(fp, n, B)[0]
    i = np.arange(n)
    K = np.abs(i[:, None] - i[None, :])
    single = [sref.strip_integral(K, fp[sref.SL_DY], B[r, 0])[0] / (np.pi * E_STAR * fp[sref.SL_DY]) for r in (0, 1)]
    assert np.allclose(C, single[0] + single[1], rtol=1e-12, atol=0)
    assert np.allclose(C, C.T, rtol=1e-14, atol=0)
    assert np.all(np.linalg.eigvalsh(C) > 0)
    # the fatter inner-race contact is the stiffer one: smaller self compliance at the larger half-width
    assert fp[sref.SL_BOUT] > fp[sref.SL_BIN]
    assert np.allclose(compliance_matrix(NeedleBearing(inner_radius=0.012, roller_diameter=3e-3, roller_length=8e-3,
                                                       n_rollers=16, n_slices=8, slices="influence")), C)


@pytest.mark.parametrize("mode", MODES)
def test_complementarity_holds(mode):
    rng = np.random.default_rng(mode)
    n, length = 12, 8e-3
    fp, ip = _roller(n, length)
    ip[sref.SI_MODE] = mode
    for _ in range(8):
        s = _approach(n, length, rng.uniform(-2e-6, 8e-6), rng.uniform(-2e-3, 2e-3), rng.uniform(0, 5e-6))
        f, J, B, A, _ = sref.solve_roller(s, fp, ip)
        C = sref.compliance(fp, n, B)[0]
        w = C @ f - s
        scale = np.max(np.abs(s))
        assert np.all(f >= 0)
        assert np.all(w >= -1e-12 * scale)          # a few ulp of the approach
        assert np.all(np.abs(w[A]) <= 1e-12 * scale)
        assert np.all(f[~A] == 0)


@pytest.mark.parametrize("mode", MODES)
def test_tangent_matches_central_differences(mode):
    # the active set's Schur complement (with the half-width term of the load modes); central
    # differences with step 1e-6 of the approach: truncation and fixed-point noise < 1e-8 relative
    n, length = 10, 8e-3
    fp, ip = _roller(n, length)
    ip[sref.SI_MODE] = mode
    s = _approach(n, length, 5e-6, 1.2e-3, 3e-6)
    f, J, _, A, _ = sref.solve_roller(s, fp, ip)
    assert 0 < A.sum() < n       # a partly open roller: the tangent restricted to the active set
    h = 1e-6 * np.max(np.abs(s))
    Jfd = np.column_stack([(sref.solve_roller(s + h * e, fp, ip)[0] - sref.solve_roller(s - h * e, fp, ip)[0])
                           / (2 * h) for e in np.eye(n)])
    assert np.max(np.abs(J - Jfd)) <= 1e-6 * np.max(np.abs(J))


def _devices():
    wp.init()
    return ["cpu"] + [d.alias for d in wp.get_devices() if d.is_cuda]


@pytest.mark.parametrize("device", _devices())
def test_kernel_matches_reference(device):
    from warp_contacts.roller_slices import RollerSliceKernel
    rng = np.random.default_rng(3)
    R, n, length = 30, 8, 8e-3
    fp, ip = _roller(n, length)
    fps, ips = np.tile(fp, (R, 1)), np.tile(ip, (R, 1))
    ips[:, sref.SI_MODE] = np.arange(R) % 3
    ips[::4, sref.SI_COUNT] = 5                     # padded rollers of another slice count
    s = np.array([_approach(n, length, rng.uniform(-3e-6, 8e-6), rng.uniform(-3e-3, 3e-3), rng.uniform(0, 4e-6))
                  for _ in range(R)])
    f0, J0, B0, na0 = sref.evaluate(s, fps, ips)
    f1, J1, B1, na1 = RollerSliceKernel(fps, ips, device).evaluate(s)
    # the same float64 operations in another order (LU vs LAPACK, sums): round-off of the
    # conditioning of C_AA (~1e3) times a few ulp
    assert np.array_equal(na0, na1)
    assert np.max(np.abs(f1 - f0)) <= 1e-11 * np.max(np.abs(f0))
    assert np.max(np.abs(J1 - J0)) <= 1e-10 * np.max(np.abs(J0))
    assert np.max(np.abs(B1 - B0)) <= 1e-11 * np.max(B0)


def test_edge_weights_load_the_ends():
    # uniform approach: the coupled solve loads the end slices more (finite-length edge effect)
    w = edge_weights(NeedleBearing(inner_radius=0.012, roller_diameter=3e-3, roller_length=8e-3, n_rollers=16,
                                   n_slices=8, slices="influence"))
    assert w.mean() == pytest.approx(1.0)
    assert w[0] == pytest.approx(w[-1], rel=1e-12) and w[0] > 1.1 and np.argmin(w) in (3, 4)


def _needle(**kw):
    return NeedleBearing(inner_radius=0.012, roller_diameter=0.003, roller_length=0.008, n_rollers=16,
                         radial_clearance=5e-6, n_slices=4, crowning=2e-6, **kw)


@pytest.mark.parametrize("half_width", ["fixed", "slice_load"])
def test_bearing_set_influence_tangent_and_backends(half_width):
    sets = {b: BearingSet([Mounting(name="ecc", bearing=_needle(slices="influence", half_width=half_width),
                                    inner=0, outer=1)], n_bodies=2, backend=b) for b in ("numpy", "warp")}
    assert isinstance(sets["numpy"], InfluenceBearingSet)
    pose = np.array([[1.5e-5, 0.3e-5, 0.01], [0.0, 0.0, 0.02]])
    ev = {b: s.evaluate(pose) for b, s in sets.items()}
    assert np.allclose(ev["warp"].Q, ev["numpy"].Q, rtol=1e-12, atol=1e-9)
    assert np.allclose(ev["warp"].dQdq, ev["numpy"].dQdq, rtol=1e-11, atol=1e-3)
    s = sets["numpy"]
    K = np.zeros((6, 6))
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-10 if k % 3 < 2 else 1e-8
        K[:, k] = (s.evaluate(pose + d.reshape(2, 3)).Q - s.evaluate(pose - d.reshape(2, 3)).Q) / (2 * d[k])
    assert np.max(np.abs(ev["numpy"].dQdq - K)) <= 1e-6 * np.max(np.abs(K))
    loads = s.element_loads(ev["numpy"].obs)["ecc"]
    assert loads.sum() > 0 and np.all(loads >= 0)


def test_influence_slices_damping_and_velocity_tangent():
    # the lamina's viscous term on slices in contact: dQ/dv and the velocity part of dQ/dq against
    # central differences (steps 1e-6 m/s, 1e-10 m), Warp against NumPy
    sets = {b: BearingSet([Mounting(name="ecc", bearing=_needle(slices="influence", damping=400.0), inner=0, outer=1)],
                          n_bodies=2, backend=b) for b in ("numpy", "warp")}
    pose = np.array([[1.5e-5, 0.3e-5, 0.01], [0.0, 0.0, 0.02]])
    vel = np.array([[2e-3, -1e-3, 3.0], [0.0, 0.0, 1.0]])
    ev = {b: s.evaluate(pose, vel) for b, s in sets.items()}
    assert np.allclose(ev["warp"].Q, ev["numpy"].Q, rtol=1e-12, atol=1e-9)
    s = sets["numpy"]
    assert not np.allclose(ev["numpy"].Q, s.evaluate(pose).Q)        # the damping acts
    Kv, Kq = np.zeros((6, 6)), np.zeros((6, 6))
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-6
        Kv[:, k] = (s.evaluate(pose, vel + d.reshape(2, 3)).Q - s.evaluate(pose, vel - d.reshape(2, 3)).Q) / 2e-6
        d[k] = 1e-10 if k % 3 < 2 else 1e-8
        Kq[:, k] = (s.evaluate(pose + d.reshape(2, 3), vel).Q - s.evaluate(pose - d.reshape(2, 3), vel).Q) / (2 * d[k])
    assert np.max(np.abs(ev["numpy"].dQdv - Kv)) <= 1e-6 * np.max(np.abs(Kv))
    assert np.max(np.abs(ev["numpy"].dQdq - Kq)) <= 1e-6 * np.max(np.abs(Kq))


def test_laminae_set_is_untouched_by_the_switch():
    # the default is the laminae law, with the plain (stageable) set
    s = BearingSet([Mounting(name="ecc", bearing=_needle(), inner=0, outer=1)], n_bodies=2, backend="numpy")
    assert type(s) is BearingSet and _needle().slices == "laminae"
    with pytest.raises(RvtoolInputError, match="energy account"):
        BearingSet([Mounting(name="ecc", bearing=_needle(slices="influence", half_width="slice_load"), inner=0,
                             outer=1)], n_bodies=2, backend="numpy").energy_law()


def test_influence_slices_potential_gives_the_forces():
    # fixed half-width: V = 1/2 f^T C_l f per roller = sum 1/2 f_i delta_i, and Q = -dV/dq for the ring
    # translations (central differences, step 1e-10 m: truncation ~1e-9 relative)
    # (the set is damped and evaluated at rest: the potential reads the elastic part only)
    s = BearingSet([Mounting(name="ecc", bearing=_needle(slices="influence", damping=400.0), inner=0, outer=1)],
                   n_bodies=2, backend="numpy")
    s.energy_law()
    pose = np.array([[1.5e-5, 0.3e-5, 0.0], [0.0, 0.0, 0.0]])
    moving = s.evaluate(pose, np.array([[1e-2, 0.0, 0.0], [0.0, 0.0, 0.0]])).obs

    def V(p):
        return s.elastic_energy(s.evaluate(p).obs)[1].sum()

    assert s.elastic_energy(moving)[1].sum() == pytest.approx(V(pose), rel=1e-12)
    Q = s.evaluate(pose).Q
    for k in (0, 1):
        d = np.zeros((2, 3))
        d[0, k] = 1e-10
        assert -(V(pose + d) - V(pose - d)) / 2e-10 == pytest.approx(Q[k], rel=1e-7)


def _row(**kw):
    return TaperedRollerBearing(n_rollers=14, pitch_diameter=0.0335, roller_diameter=0.0055, roller_length=0.010,
                                cup_angle=math.radians(14.0), cone_angle=math.radians(11.0), n_slices=6,
                                crowning=3e-6, **kw)


@pytest.mark.parametrize("half_width", ["fixed", "slice_load"])
def test_tapered_influence_tangent_and_preload(half_width):
    row = _row(slices="influence", half_width=half_width)
    pair = TaperedPair(rows=(row, row), row_spacing=0.04, axial_preload=300.0)
    sets = {b: TaperedBearingSet([TaperedMounting(name="c", bearing=pair, inner=0, outer=1)], n_bodies=2, backend=b)
            for b in ("numpy", "warp")}
    q = np.array([[8e-6, 3e-6, 1e-6, 2e-4, -1e-4]])
    ca = np.array([0.1])
    r = {b: s.relative(q, cage_angle=ca) for b, s in sets.items()}
    assert np.allclose(r["warp"].wrench, r["numpy"].wrench, rtol=1e-12, atol=1e-9)
    s = sets["numpy"]
    K = np.zeros((5, 5))
    for k in range(5):
        e = np.zeros((1, 5))
        e[0, k] = 1e-11 if k >= 3 else 1e-12
        up, down = s.relative(q + e, cage_angle=ca).wrench[0], s.relative(q - e, cage_angle=ca).wrench[0]
        K[:, k] = (up - down) / (2 * e[0, k])
    assert np.max(np.abs(r["numpy"].stiffness[0] - K)) <= 1e-6 * np.max(np.abs(K))
    # the preload approach is the row's own (influence) law's: zero external load carries 300 N per row
    z = s.relative(np.zeros((1, 5)))
    assert z.row_wrench[0, 0, 2] == pytest.approx(-z.row_wrench[0, 1, 2])
    assert abs(z.row_wrench[0, 1, 2]) == pytest.approx(300.0, rel=1e-9)


def test_tapered_influence_damping_tangents():
    # the lamina's viscous term on slices in contact: every tangent of the 5-DOF wrench (q, q_dot, cage
    # angle and rate) against central differences, Warp against NumPy
    row = _row(slices="influence", half_width="slice_load", damping=300.0)
    pair = TaperedPair(rows=(row, row), row_spacing=0.04, axial_preload=300.0)
    sets = {b: TaperedBearingSet([TaperedMounting(name="c", bearing=pair, inner=0, outer=1)], n_bodies=2, backend=b)
            for b in ("numpy", "warp")}
    q, qd = np.array([[8e-6, 3e-6, 1e-6, 2e-4, -1e-4]]), np.array([[2e-3, -1e-3, 5e-4, 0.1, 0.05]])
    ca, cr = np.array([0.1]), np.array([30.0])
    s = sets["numpy"]

    def w(**kw):
        args = dict(q=q, qdot=qd, cage_angle=ca, cage_rate=cr)
        args.update(kw)
        return s.relative(**args).wrench[0]

    r = s.relative(q, qd, ca, cr)
    assert np.allclose(sets["warp"].relative(q, qd, ca, cr).wrench, r.wrench, rtol=1e-12, atol=1e-9)
    assert not np.allclose(r.wrench, s.relative(q, None, ca, None).wrench)     # the damping acts
    E = np.eye(5)[:, None, :]
    hq = np.array([1e-12, 1e-12, 1e-12, 1e-11, 1e-11])
    K = np.column_stack([(w(q=q + hq[k] * E[k]) - w(q=q - hq[k] * E[k])) / (2 * hq[k]) for k in range(5)])
    Cd = np.column_stack([(w(qdot=qd + 1e-6 * E[k]) - w(qdot=qd - 1e-6 * E[k])) / 2e-6 for k in range(5)])
    dpsi = (w(cage_angle=ca + 1e-7) - w(cage_angle=ca - 1e-7)) / 2e-7
    dpsid = (w(cage_rate=cr + 1e-4) - w(cage_rate=cr - 1e-4)) / 2e-4
    for got, fd in ((r.stiffness[0], K), (r.damping[0], Cd), (r.cage_sensitivity[0], dpsi),
                    (r.cage_rate_sensitivity[0], dpsid)):
        assert np.max(np.abs(got - fd)) <= 1e-6 * np.max(np.abs(fd))


def test_tapered_influence_potential_gives_the_wrench():
    # fixed half-width, rigid rib: Q_x = -dV/dx of the planar pair (cone on body 0, cup on ground-like body 1)
    row = _row(slices="influence")
    s = TaperedBearingSet([TaperedMounting(name="c", bearing=TaperedPair(rows=(row, row), row_spacing=0.04,
                                                                         axial_preload=300.0), inner=0, outer=1)],
                          n_bodies=2, backend="numpy")
    s.energy_law()
    pose = np.array([[1.2e-5, -0.4e-5, 0.0], [0.0, 0.0, 0.0]])

    def V(p):
        return s.elastic_energy(s.evaluate(p).obs)[1].sum()

    Q = s.evaluate(pose).Q
    for k in (0, 1):
        d = np.zeros((2, 3))
        d[0, k] = 1e-10
        assert -(V(pose + d) - V(pose - d)) / 2e-10 == pytest.approx(Q[k], rel=1e-6)


def test_design_file_switch_and_named_errors():
    nb = build_section(NeedleBearing, "eccentric_bearing",
                       {"inner_radius": 0.012, "n_rollers": 16, "roller_diameter": 0.003, "roller_length": 0.008,
                        "slices": "influence", "half_width": "slice_load"})
    assert nb.slices == "influence" and nb.half_width == "slice_load"
    with pytest.raises(RvtoolInputError, match="slices"):
        _needle(slices="coupled")
    with pytest.raises(RvtoolInputError, match="half_width"):
        _needle(slices="influence", half_width="variable")
    with pytest.raises(RvtoolInputError, match="rib_contact"):
        _row(slices="influence", rib_contact=True)


def test_lumped_bearing_model_refuses_influence_slices():
    # the lumped bearing has no slices to couple: a design asking for them is told, not ignored
    import rvtool
    from rvtool.bearings.influence import check_lumped
    d = rvtool.replace_design(rvtool.load_design("rvtool/designs/rd40.toml"), eccentric_bearing={"slices": "influence"})
    with pytest.raises(RvtoolInputError, match="bearing_model = 'rolling'"):
        check_lumped(d, "lumped")
    check_lumped(d, "rolling")


def test_exhausted_pivots_report_nan(monkeypatch):
    # a solve that cannot settle its active set returns NaN (the evaluation is then non-finite),
    # never forces that violate complementarity: allow no pivot where one is needed
    C = np.array([[2.0, 1.0], [1.0, 2.0]])
    s = np.array([1.0, -1.0])
    f, A, _ = sref.solve_lcp(C, s, warm=np.array([True, True]))
    assert np.allclose(f, [0.5, 0.0]) and A.tolist() == [True, False]
    monkeypatch.setattr(sref, "MAX_PIVOTS", 0)
    f, _, _ = sref.solve_lcp(C, s, warm=np.array([True, True]))
    assert np.all(np.isnan(f))


def test_angle_batched_copies_of_an_influence_set():
    # the replica backend's copier: B copies behind one set reproduce the single set's rows per copy
    from rvtool.solver.replica import COPIERS
    s = BearingSet([Mounting(name="ecc", bearing=_needle(slices="influence", half_width="slice_load"), inner=0,
                             outer=1)], n_bodies=2, backend="numpy")
    copies = COPIERS[type(s)]([s] * 3, 2, "float64", "cpu")
    assert isinstance(copies, InfluenceBearingSet)
    poses = np.array([[[1.5e-5, 0.3e-5, 0.01], [0.0, 0.0, 0.02]], [[-1e-5, 0.8e-5, 0.2], [0.0, 0.0, 0.1]],
                      [[0.2e-5, -1.2e-5, 1.0], [0.0, 0.0, -0.3]]])
    Qc = np.asarray(copies.raw(poses.reshape(-1, 3))[0])
    n = len(s.ids)
    for c in range(3):
        assert np.allclose(Qc[c * n:(c + 1) * n], np.asarray(s.raw(poses[c])[0]), rtol=1e-12, atol=1e-9)
