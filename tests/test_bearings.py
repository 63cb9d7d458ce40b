"""Bearings from rolling elements: kernel vs NumPy reference, analytic tangent vs central
differences (cage motion and damping included), virtual work, Hertz constants, the
Stribeck load distribution, clearance, preload, cage kinematics, slicing and input errors."""
import math

import numpy as np
import pytest

from rvtool.bearings import (AngularContactPair, BallBearing, BearingSet, CrossedRollerBearing,
                             CylindricalRollerBearing, Mounting, NeedleBearing, hertz_constants, roller_stiffness)
from rvtool.bearings.checks import radial_load_distribution, sjovall_radial_integral, stribeck_discrete_sum
from rvtool.bearings.hertz import effective_modulus, hertz_exact, race_radii
from rvtool.contact.circle_set import GROUND
from rvtool.errors import RvtoolInputError
from warp_contacts import rolling_elements_ref as R

# RD-40 element sets (issue 5)
RD40_BALLS = dict(n_balls=16, ball_diameter=7.938e-3, pitch_diameter=0.068)
RD40_NEEDLE = dict(inner_radius=0.012, roller_diameter=0.003, roller_length=0.008, n_rollers=16)
ECC = 8e-4


def _rot(th, v):
    return np.array([math.cos(th) * v[0] - math.sin(th) * v[1], math.sin(th) * v[0] + math.cos(th) * v[1]])


def _scene():
    """Bodies 0 shaft, 1 wheel, 2 flange; every element type in partial contact, with damping
    (some elements inside their damping ramp) and velocities. Returns (mountings, pose, vel)."""
    shaft = np.array([2e-6, -3e-6, 0.3])
    journal = shaft[:2] + _rot(shaft[2], (0.0, ECC))
    wheel = np.array([*(journal + [-5e-6, 5e-6]), -0.02])
    flange = np.array([-4e-6, 3e-6, 0.5])
    pose = np.array([shaft, wheel, flange])
    vel = np.array([[1e-3, -2e-3, 150.0], [2e-3, 1e-3, -4.0], [-1e-3, 5e-4, 4.0]])
    row = BallBearing(**RD40_BALLS, contact_angle=math.radians(25), axial_preload=200.0, damping=300.0,
                      ramp_depth=2e-5)
    ms = {
        "input_bearing": Mounting(name="input_bearing", inner=0, outer=GROUND, bearing=BallBearing(
            n_balls=10, ball_diameter=7.938e-3, pitch_diameter=0.037, radial_clearance=2e-6, damping=200.0)),
        "eccentric_bearing": Mounting(name="eccentric_bearing", inner=0, outer=1, inner_centre=(0.0, ECC),
                                      bearing=NeedleBearing(**RD40_NEEDLE, radial_clearance=5e-6, crowning=2e-6,
                                                            damping=2000.0, ramp_depth=1e-6)),
        "main_bearing": Mounting(name="main_bearing", inner=2, outer=GROUND,
                                 bearing=AngularContactPair(rows=(row, row), row_spacing=0.040)),
        "cylindrical": Mounting(name="cylindrical", inner=GROUND, outer=1, inner_centre=tuple(wheel[:2] + [3e-6, 4e-6]),
                                cage_phase=0.1, bearing=CylindricalRollerBearing(
                                    inner_radius=0.02, roller_diameter=0.004, roller_length=0.006, n_rollers=20,
                                    n_slices=3, law="linear", reference_roller_load=500.0,
                                    crowning=(1e-6, 0.0, 2e-6), damping=500.0)),
        "crossed": Mounting(name="crossed", inner=2, outer=GROUND, cage_phase=0.05, bearing=CrossedRollerBearing(
            inner_radius=0.03, roller_diameter=0.005, roller_length=0.005, n_rollers=30, n_slices=3, crowning=1e-6)),
    }
    return ms, pose, vel


def _set(names=None, **kw):
    ms, pose, vel = _scene()
    return BearingSet([m for k, m in ms.items() if names is None or k in names], 3, **kw), pose, vel


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401  (sets Warp's log level)
    wp.init()
    return [d.alias for d in wp.get_devices()]


@pytest.mark.parametrize("device", _devices())
@pytest.mark.parametrize("precision,tol", [("float64", 1e-11), ("float32", 1e-3)])
def test_kernel_matches_reference(precision, tol, device):
    """Same operations as the reference: float64 differs by libm rounding amplified by the
    cancellation in the approach (positions ~1e-2 m, approaches ~1e-6 m: ~1e4, so ~1e-12);
    float32 (eps 6e-8) rounds positions ~1e-3 m by ~5e-11 m, ~5e-5 of the approach (measured 1e-5)."""
    s, pose, vel = _set(backend="warp", precision=precision, device=device)
    r, _, _ = _set(backend="numpy")
    a, b = s.evaluate(pose, vel), r.evaluate(pose, vel)
    for x, y in ((a.Q, b.Q), (a.dQdq, b.dQdq), (a.dQdv, b.dQdv), (a.obs[:, R.O_FN], b.obs[:, R.O_FN])):
        assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y))
    # the auxiliary axial observations follow the same law
    ra, rb = np.asarray(s.raw(pose, vel)[4]), r.raw(pose, vel)[4]
    assert np.max(np.abs(ra[:, :2] - rb[:, :2])) <= tol * np.max(np.abs(rb[:, :2]))


def _fd_tangent(s, pose, vel):
    """Central differences; steps 1e-10 m / 1e-8 rad keep truncation ~(h/delta)^2 < 1e-7 for
    approaches >= 1e-7 m while round-off stays ~1e-12; Q is affine in v (damping), any step is exact."""
    n = 3 * s.n_bodies
    Kq, Kv = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        b, c = divmod(j, 3)
        for K, which, h in ((Kq, 0, 1e-10 if c < 2 else 1e-8), (Kv, 1, 1e-3)):
            st = [pose.copy(), vel.copy()]
            st[which][b, c] += h
            qp = s.evaluate(*st).Q
            st[which][b, c] -= 2 * h
            K[:, j] = (qp - s.evaluate(*st).Q) / (2 * h)
    return Kq, Kv


@pytest.mark.parametrize("name", ["input_bearing", "eccentric_bearing", "main_bearing", "cylindrical", "crossed"])
def test_tangent_matches_central_differences(name):
    """dQ/dq (ring motion, cage rotation with the rings, working-angle dependence of K) and
    dQ/dv (damping ramp of Eq. (normal_force)) against central differences: < 1e-6 relative Frobenius."""
    s, pose, vel = _set([name], backend="numpy")
    e = s.evaluate(pose, vel)
    delta = -e.obs[:, R.O_GAP]
    assert np.sum(e.obs[:, R.O_FN] > 0) >= 2, "the state must load several elements"
    # no element within the FD reach (~1e-9 m) of its activation or ramp kink
    assert np.min(np.abs(delta)) > 1e-8 and np.min(np.abs(delta - s.fparams[:, R.R_RAMP])) > 1e-8
    Kq, Kv = _fd_tangent(s, pose, vel)
    assert np.linalg.norm(e.dQdq - Kq) / np.linalg.norm(Kq) < 1e-6
    if np.any(s.fparams[:, R.R_DAMP] > 0):
        assert np.linalg.norm(Kv) > 0
        assert np.linalg.norm(e.dQdv - Kv) / np.linalg.norm(Kv) < 1e-6
    # the cage term matters: with the cage frozen (psi = psi_0 + theta_B, gamma = 1) the tangent differs
    frozen = BearingSet(s.mountings, 3, backend="numpy")
    frozen.fparams[:, R.R_GAMMA] = 1.0
    assert np.linalg.norm(frozen.evaluate(pose, vel).dQdq - e.dQdq) > 1e-3 * np.linalg.norm(e.dQdq)


def test_virtual_work_identity():
    """Eq. (contact_mapping): v^T Q = sum_j f_A,j . (v_cA - v_cB), each element force acting on the
    two ring centres (radial forces, no traction)."""
    s, pose, vel = _set(backend="numpy")
    Qc, _, _, obs, aux = s.raw(pose, vel)
    rng = np.random.default_rng(1)
    V = np.vstack([rng.normal(size=(3, 3)), np.zeros(3)])
    P = np.vstack([pose, np.zeros(3)])
    ia, ib = s.iparams[:, 0], s.iparams[:, 1]
    p_gen = np.sum(Qc[:, :3] * V[ia], axis=1) + np.sum(Qc[:, 3:] * V[ib], axis=1)

    def v_centre(body, xi):
        th = P[body, 2]
        r = np.column_stack([np.cos(th) * xi[:, 0] - np.sin(th) * xi[:, 1], np.sin(th) * xi[:, 0] + np.cos(th) * xi[:, 1]])
        return V[body, :2] + V[body, 2:3] * np.column_stack([-r[:, 1], r[:, 0]])
    f_a = aux[:, R.AUX_FU, None] * obs[:, R.O_NX:R.O_NY + 1]
    p_ct = np.sum((v_centre(ia, s.fparams[:, 0:2]) - v_centre(ib, s.fparams[:, 2:4])) * f_a, axis=1)
    np.testing.assert_allclose(p_gen, p_ct, rtol=1e-10, atol=1e-9)
    # the normal force and its radial and axial parts are one vector: F^2 = f_u^2 + f_z^2
    np.testing.assert_allclose(obs[:, R.O_FN] ** 2, aux[:, R.AUX_FU] ** 2 + aux[:, R.AUX_FZ] ** 2, rtol=1e-12)


def test_hertz_constants_against_elliptic_integrals():
    """Hamrock-Brewe closed forms vs Hertz with complete elliptic integrals (Harris & Kotzalas
    Eqs. 6.26-6.36): the curve fits are quoted within ~3 % in k, E, F for radius ratios up to
    ~40 (f >= 0.515 here); measured K within 2.5 %. The kernels' K is exact at the free angle."""
    for f in (0.515, 0.52, 0.53, 0.57, 0.6):
        for deg in (0.0, 25.0, 40.0):
            kw = dict(ball_diameter=7.938e-3, pitch_diameter=0.068, contact_angle=math.radians(deg),
                      inner_curvature=f, outer_curvature=f + 0.01, youngs_modulus=206e9, poisson_ratio=0.3)
            hb, ex = hertz_constants(**kw), hertz_constants(**kw, method="exact")
            for a, b in ((hb.inner, ex.inner), (hb.outer, ex.outer), (hb.combined, ex.combined)):
                assert abs(a / b - 1) < 0.025
            assert abs(hb.inner_ellipticity / ex.inner_ellipticity - 1) < 0.025
            row = BallBearing(**RD40_BALLS, contact_angle=kw["contact_angle"], inner_curvature=f, outer_curvature=f + 0.01)
            assert abs(row.stiffness_at(row.contact_angle) / ex.combined - 1) < 1e-12
    # sphere on a flat (R_x = R_y = R): Hertz delta^3 = 9 Q^2 / (16 R E*^2), E* = E'/2, no fit involved
    Ep = effective_modulus(206e9, 0.3)
    K, kappa = hertz_exact(0.004, 0.004 * (1 + 1e-9), Ep)
    assert abs(kappa - 1) < 1e-3 and abs(K / (4 / 3 * (Ep / 2) * math.sqrt(0.004)) - 1) < 1e-3
    # combination of two contacts carrying the same load (paper, after Eq. (ball_bearing))
    h = hertz_constants(**{**kw, "method": "hamrock_brewe"})
    assert abs(h.combined - (h.inner ** (-2 / 3) + h.outer ** (-2 / 3)) ** -1.5) < 1e-9 * h.combined
    (rxi, _), (rxo, _) = race_radii(7.938e-3, 0.068, 0.0, 0.52, 0.52)
    assert rxi < rxo                               # the inner contact is the more curved one


def test_stribeck_zero_clearance():
    """Stribeck: F_r = Z Q_max J_r(1/2) cos(alpha), J_r(1/2) = 0.2288 (Sjoevall integral), i.e.
    Q_max = 4.37 F_r / (Z cos alpha); exact for Z balls: F_r = Q_max sum cos^(5/2) psi_j cos(alpha)."""
    Jr = sjovall_radial_integral(0.5)
    assert abs(Jr - 0.2288) < 1e-4 and abs(1 / Jr - 4.37) < 1e-3
    Fr, Z = 5000.0, 16
    deep = BallBearing(**RD40_BALLS)
    res = radial_load_distribution(deep, Fr)
    q = res.loads.max()
    assert res.residual < 1e-10 and np.sum(res.loads > 0) == 7
    # constant contact angle: the discrete relation holds to solver precision; the integral
    # replaces the sum with a quadrature error ~5e-4 for Z = 16
    assert abs(q * stribeck_discrete_sum(Z) / Fr - 1) < 1e-9
    assert abs(q / (Fr / (Z * Jr)) - 1) < 1e-3
    assert abs(q / (4.37 * Fr / Z) - 1) < 1e-3
    # element loads follow Q_j = Q_max cos^(3/2) psi_j in the loaded zone
    on = res.loads > 0
    np.testing.assert_allclose(res.loads[on], q * np.cos(res.angles[on]) ** 1.5, rtol=1e-9)
    # RD-40 angular-contact row (alpha_0 = 25 deg, axial position held): the working angle of the
    # loaded balls falls as the ring moves radially, which Stribeck's constant angle ignores
    ac = BallBearing(**RD40_BALLS, contact_angle=math.radians(25))
    for load, tol in ((500.0, 0.01), (5000.0, 0.03)):
        q_ac = radial_load_distribution(ac, load).loads.max()
        assert abs(q_ac / (load / (Z * Jr * math.cos(ac.contact_angle))) - 1) < tol


def test_clearance_opens_elements():
    """Ring offsets inside the clearance load nothing (zero force, zero tangent); beyond it they do."""
    ball = BallBearing(n_balls=12, ball_diameter=0.008, pitch_diameter=0.05, radial_clearance=5e-6)
    needle = NeedleBearing(**RD40_NEEDLE, radial_clearance=5e-6)
    for b in (ball, needle):
        s = BearingSet([Mounting(name="b", bearing=b, inner=0, outer=GROUND)], 1, backend="numpy")
        for ang in np.linspace(0, 2 * np.pi, 7):
            inside = s.evaluate(np.array([[4.9e-6 * math.cos(ang), 4.9e-6 * math.sin(ang), 0.3]]))
            assert not np.any(inside.obs[:, R.O_FN]) and not np.any(inside.Q) and not np.any(inside.dQdq)
        outside = s.evaluate(np.array([[0.0, -5.5e-6, 0.3]]))
        assert np.any(outside.obs[:, R.O_FN] > 0) and outside.Q[1] > 0   # pushes the ring back up


def test_preload_loads_every_ball():
    """Axial preload F_a under no external load: every ball carries Q with Z Q sin(alpha_w) = F_a,
    the rows' axial forces are +-F_a, and the pair's radial force, net axial force and
    tilting moment vanish."""
    Fa = 200.0
    row = BallBearing(**RD40_BALLS, contact_angle=math.radians(25), axial_preload=Fa)
    assert 0 < row.axial_preload_offset < 1e-4
    for arrangement in ("back_to_back", "face_to_face"):
        pair = AngularContactPair(rows=(row, row), row_spacing=0.040, arrangement=arrangement)
        s = BearingSet([Mounting(name="main_bearing", bearing=pair, inner=0, outer=GROUND)], 1, backend="numpy")
        _, _, _, obs, aux = s.raw(np.zeros((1, 3)))
        q = obs[:, R.O_FN]
        assert np.all(q > 0) and np.ptp(q) < 1e-9 * q.max()
        np.testing.assert_allclose(q * np.sin(aux[:, R.AUX_ALPHA]) * row.n_balls, Fa, rtol=1e-9)
        loads = s.resultants(np.zeros((1, 3)))["main_bearing"]
        np.testing.assert_allclose(sorted(loads.row_axial_forces), [-Fa, Fa], rtol=1e-9)
        assert abs(loads.axial_force) < 1e-9 * Fa and np.all(np.abs(loads.force) < 1e-9 * Fa)
        assert np.all(np.abs(loads.tilting_moment) < 1e-9 * Fa)
    # without preload the unloaded bearing carries nothing
    free = BallBearing(**RD40_BALLS, contact_angle=math.radians(25))
    s = BearingSet([Mounting(name="b", bearing=free, inner=0, outer=GROUND)], 1, backend="numpy")
    assert not np.any(s.evaluate(np.zeros((1, 3))).obs[:, R.O_FN])


def test_pair_tilting_moment_from_radial_offset():
    """A radial ring offset loads both rows alike; their radial parts act at stations -+s/2 and
    their axial parts at radius d_m/2: M = sum (rho f_z - z f_u)(u x e_z) (Eq. (width_resultant)).
    Rows of one pair cancel the moment of equal radial loads; a single row at z = 0 gives only
    the axial-force moment, checked against the direct sum."""
    row = BallBearing(**RD40_BALLS, contact_angle=math.radians(25), axial_preload=200.0)
    s = BearingSet([Mounting(name="p", bearing=AngularContactPair(rows=(row, row), row_spacing=0.04), inner=0,
                             outer=GROUND)], 1, backend="numpy")
    pose = np.array([[3e-6, -4e-6, 0.0]])
    L = s.resultants(pose)["p"]
    assert np.linalg.norm(L.force) > 100 and abs(L.axial_force) < 1e-9 * np.linalg.norm(L.force)
    assert np.all(np.abs(L.tilting_moment) < 1e-9 * np.linalg.norm(L.force))
    one = BearingSet([Mounting(name="r", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy")
    _, _, _, obs, aux = one.raw(pose)
    u = obs[:, R.O_NX:R.O_NY + 1]
    m = np.sum((0.034 * aux[:, R.AUX_FZ])[:, None] * np.column_stack([u[:, 1], -u[:, 0]]), axis=0)
    np.testing.assert_allclose(one.resultants(pose)["r"].tilting_moment, m, rtol=1e-12)
    assert np.linalg.norm(m) > 1.0


def test_cage_advances_with_the_rings():
    """psi_j = psi_0j + [(1 - gamma) theta_inner + (1 + gamma) theta_outer] / 2, gamma = D cos(alpha)/d_m."""
    for b in (BallBearing(**RD40_BALLS, contact_angle=math.radians(25)), NeedleBearing(**RD40_NEEDLE)):
        s = BearingSet([Mounting(name="b", bearing=b, inner=0, outer=1, cage_phase=0.2)], 2, backend="numpy")
        gamma = s.fparams[0, R.R_GAMMA]
        D = b.ball_diameter if isinstance(b, BallBearing) else b.roller_diameter
        assert abs(gamma - D * math.cos(b.contact_angle) / b.pitch_diameter) < 1e-15
        for th_in, th_out in ((0.5, 0.0), (0.0, 0.5), (0.3, -0.7)):
            n = s.evaluate(np.array([[0.0, 0.0, th_in], [0.0, 0.0, th_out]])).obs[0, R.O_NX:R.O_NY + 1]
            expect = 0.2 + 0.5 * ((1 - gamma) * th_in + (1 + gamma) * th_out)
            assert abs(math.atan2(n[1], n[0]) - expect) < 1e-12
    # passage excites the structure: at a fixed offset the bearing force ripples with the cage
    # (Z = 16: sum cos^(5/2) differs by 8e-4 between a ball on the load line and two straddling it)
    # and repeats after one element pitch of cage rotation (inner ring turned by 2 pi/(Z (1 - gamma)/2))
    b = BallBearing(**RD40_BALLS)
    s = BearingSet([Mounting(name="b", bearing=b, inner=0, outer=GROUND)], 1, backend="numpy")
    g = s.fparams[0, R.R_GAMMA]
    pitch = 2 * np.pi / b.n_balls / (0.5 * (1 - g))
    th = np.linspace(0, pitch, 9)
    fy = np.array([s.evaluate(np.array([[0.0, -5e-6, t]])).Q[1] for t in th])
    assert np.ptp(fy) > 1e-4 * fy.mean() and abs(fy[-1] - fy[0]) < 1e-9 * fy.mean()


def test_roller_slicing_and_laws():
    """Uniform approach: the laminae sum to the unsliced roller law whatever n_slices; the linear
    law is the secant of Palmgren's 10/9 law at the reference roller load; crowning drops the
    edge laminae."""
    k = roller_stiffness(0.008)
    for n in (1, 4, 9):
        b = NeedleBearing(**RD40_NEEDLE, n_slices=n)
        assert abs(np.sum(b.slice_stiffness) - k) < 1e-12 * k
    lin = NeedleBearing(**RD40_NEEDLE, law="linear", reference_roller_load=800.0)
    delta_ref = (800.0 / k) ** 0.9
    assert abs(lin.roller_coefficient * delta_ref - 800.0) < 1e-9 and lin.exponent == 1.0
    crowned = NeedleBearing(**RD40_NEEDLE, n_slices=4, crowning=2e-6)
    s = BearingSet([Mounting(name="n", bearing=crowned, inner=0, outer=GROUND)], 1, backend="numpy")
    f = s.evaluate(np.array([[4e-6, 0.0, 0.0]])).obs[:4, R.O_FN]    # roller 0 on the load line
    assert f[1] == f[2] and f[0] == f[3] and f[0] < f[1]
    np.testing.assert_allclose(crowned.slice_crowning, 2e-6 * np.array([0.75, 0.25, 0.25, 0.75]) ** 2)


def test_bearing_set_as_exudyn_contact_element():
    """The set plugs into the Exudyn contact element: callbacks return its forces and tangent."""
    exu = pytest.importorskip("exudyn")
    from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D

    from exudyn_user_elements.contact_element import ContactElement
    s, pose, vel = _set(backend="warp")
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0])) for _ in range(3)]
    for n in nodes:
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=1.0, inertia=1e-3))
    el = ContactElement(mbs, nodes, s)
    mbs.Assemble()
    q, v = pose.ravel(), vel.ravel()
    np.testing.assert_allclose(el.force_callback(mbs, 0.0, el.object_number, q, v), s.evaluate(pose, vel).Q, rtol=1e-12)
    assert el.ids == s.ids and el.commit(q, v).normal_force.shape == (len(s.ids),)


def test_ids_name_mounting_row_and_element():
    s, pose, vel = _set(backend="numpy")
    assert "main_bearing/row0/ball3" in s.ids and "main_bearing/row1/ball15" in s.ids
    assert "input_bearing/row0/ball9" in s.ids and "eccentric_bearing/roller15/slice3" in s.ids
    assert len(s.ids) == len(set(s.ids)) == 10 + 16 * 4 + 32 + 20 * 3 + 30 * 3
    obs = s.evaluate(pose, vel).obs
    per = s.element_loads(obs)
    assert [len(per[k]) for k in ("input_bearing", "eccentric_bearing", "main_bearing", "crossed")] == [10, 16, 32, 30]
    assert abs(np.sum(per["eccentric_bearing"]) - np.sum(obs[[i for i, c in enumerate(s.ids)
                                                               if c.startswith("eccentric")], R.O_FN])) < 1e-9


def test_bad_inputs_name_the_parameter():
    bad = [
        (dict(inner_curvature=0.5), "inner_curvature"),
        (dict(outer_curvature=1.2), "outer_curvature"),
        (dict(n_balls=30), "n_balls"),
        (dict(radial_clearance=-1e-4), "radial_clearance"),
        (dict(axial_preload=-1.0), "axial_preload"),
        (dict(poisson_ratio=0.5), "poisson_ratio"),
        (dict(contact_angle=math.pi / 2), "contact_angle"),
        (dict(pitch_diameter=0.005), "pitch_diameter"),
    ]
    for kw, name in bad:
        with pytest.raises(RvtoolInputError, match=name):
            BallBearing(**{**RD40_BALLS, **kw})
    for kw, name in [(dict(n_rollers=40), "n_rollers"), (dict(n_slices=0), "n_slices"),
                     (dict(crowning=(1e-6, 0.0)), "crowning"), (dict(lamina_stiffness=-1.0), "lamina_stiffness"),
                     (dict(law="cubic"), "law"), (dict(radial_clearance=-1e-5), "radial_clearance")]:
        with pytest.raises(RvtoolInputError, match=name):
            NeedleBearing(**{**RD40_NEEDLE, **kw})
    with pytest.raises(RvtoolInputError, match="contact_angle"):
        CrossedRollerBearing(**RD40_NEEDLE, contact_angle=0.0)
    row = BallBearing(**RD40_BALLS)
    with pytest.raises(RvtoolInputError, match=r"rows\[0\].contact_angle"):
        AngularContactPair(rows=(row, row), row_spacing=0.04)
    ac = BallBearing(**RD40_BALLS, contact_angle=0.4)
    with pytest.raises(RvtoolInputError, match="arrangement"):
        AngularContactPair(rows=(ac, ac), row_spacing=0.04, arrangement="tandem")
    with pytest.raises(RvtoolInputError, match="row_spacing"):
        AngularContactPair(rows=(ac, ac), row_spacing=-0.04)
    with pytest.raises(RvtoolInputError, match="outer"):
        BearingSet([Mounting(name="b", bearing=row, inner=0, outer=5)], 1)
    with pytest.raises(RvtoolInputError, match="name"):
        Mounting(name="a/b", bearing=row, inner=0, outer=GROUND)
    with pytest.raises(RvtoolInputError, match="unique"):
        BearingSet([Mounting(name="b", bearing=row, inner=0, outer=GROUND)] * 2, 1)
    with pytest.raises(RvtoolInputError, match="pose"):
        BearingSet([Mounting(name="b", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy").evaluate(np.zeros((2, 3)))
