"""Tapered roller bearings: kernel vs NumPy reference on every device, analytic 5-DOF and planar
tangents vs central differences, Sjoevall's combined-load integrals (computed here by quadrature),
the pair's axial and tilt reactions vs statics, preload and end play, rib contact on/off, the
Exudyn contact element, and input errors."""
import math

import numpy as np
import pytest

from rvtool.bearings.tapered import TaperedPair, TaperedRollerBearing
from rvtool.bearings.tapered_checks import epsilon_from_loads, sjovall_integrals, static_equilibrium
from rvtool.bearings.tapered_set import TaperedBearingSet, TaperedMounting
from rvtool.contact.circle_set import GROUND
from rvtool.errors import RvtoolInputError
from warp_contacts import circle_pairs_ref as O

# a 30204-class row (chosen plausible dimensions; the RV crank support of issue 16)
ROW = dict(n_rollers=14, pitch_diameter=0.0335, roller_diameter=0.0055, roller_length=0.010, cup_angle=math.radians(14.0),
           cone_angle=math.radians(11.0))
# a larger row with many rollers for the load-distribution checks
WIDE = dict(n_rollers=20, pitch_diameter=0.06, roller_diameter=0.007, roller_length=0.012, cup_angle=math.radians(15.0),
            cone_angle=math.radians(12.0))
LINE_N = 10.0 / 9.0


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401  (sets Warp's log level)
    wp.init()
    return [d.alias for d in wp.get_devices()]


def _rot(th, v):
    return np.array([math.cos(th) * v[0] - math.sin(th) * v[1], math.sin(th) * v[0] + math.cos(th) * v[1]])


def _scene(**kw):
    """A preloaded pair (row 0 lumped rib with damping, row 1 elastic rib) between a crank (body 0)
    and a carrier (body 1), and a single elastic-rib row from the crank to ground; a state that
    loads rollers of every kind, with velocities."""
    lumped = TaperedRollerBearing(**ROW, n_slices=3, crowning=1e-6, damping=500.0, ramp_depth=2e-6)
    rib = TaperedRollerBearing(**ROW, n_slices=3, crowning=1e-6, rib_contact=True)
    pair = TaperedPair(rows=(lumped, rib), row_spacing=0.04, axial_preload=300.0)
    xi_a, xi_b = np.array([1e-3, 0.0]), np.array([0.0, 2e-3])
    th_a, th_b = 0.3, -0.1
    x_b = np.array([1e-6, -1e-6])
    # ring centres a few micrometres apart: x_A + R(th_A) xi_A - x_B - R(th_B) xi_B = (3, -2) um
    x_a = x_b + _rot(th_b, xi_b) - _rot(th_a, xi_a) + [3e-6, -2e-6]
    ms = [TaperedMounting(name="crank_bearing", bearing=pair, inner=0, outer=1, inner_centre=tuple(xi_a),
                          outer_centre=tuple(xi_b), cage_phase=0.1),
          TaperedMounting(name="support", bearing=rib, inner=0, outer=GROUND, inner_centre=tuple(xi_a),
                          outer_centre=tuple(x_a + _rot(th_a, xi_a) + [1e-6, 4e-6]), cage_phase=0.3)]
    pose = np.array([[*x_a, th_a], [*x_b, th_b]])
    vel = np.array([[1e-3, -2e-3, 150.0], [2e-3, 1e-3, -4.0]])
    return TaperedBearingSet(ms, 2, **kw), pose, vel


Q5 = np.array([[3e-6, -2e-6, 4e-6, 1e-4, -2e-4], [-2e-6, 5e-6, -6e-6, -5e-5, 1e-4]])
QD5 = np.array([[1e-3, -2e-3, 5e-4, 0.02, -0.01], [2e-3, 1e-3, -1e-3, 0.01, 0.03]])
CAGE, CAGE_RATE = np.array([0.2, -0.4]), np.array([3.0, -2.0])


@pytest.mark.parametrize("device", _devices())
@pytest.mark.parametrize("precision,tol", [("float64", 1e-11), ("float32", 1e-4)])
def test_kernel_matches_reference(precision, tol, device):
    """Same operations as the reference. float64: libm rounding amplified by the cancellation of
    ring-centre positions (~1e-3 m) into approaches (~1e-6 m), ~1e3 eps ~ 1e-13, and the rib balance
    stopped within a few ulp. float32 (eps 6e-8): the same 1e3 amplification bounds the error by
    ~6e-5 of the forces (the rib balance stops at 8 eps of its bracket); measured <= 8e-6."""
    s, pose, vel = _scene(backend="warp", precision=precision, device=device)
    r, _, _ = _scene(backend="numpy")
    a, b = s.relative(Q5, QD5, CAGE, CAGE_RATE), r.relative(Q5, QD5, CAGE, CAGE_RATE)
    for k in ("wrench", "stiffness", "damping", "cage_sensitivity", "cage_rate_sensitivity", "row_wrench",
              "rib_force", "lamina_force"):
        x, y = getattr(a, k), getattr(b, k)
        assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y)), k
    pa, pb = s.evaluate(pose, vel), r.evaluate(pose, vel)
    for x, y in ((pa.Q, pb.Q), (pa.dQdq, pb.dQdq), (pa.dQdv, pb.dQdv), (pa.obs[:, O.O_FN], pb.obs[:, O.O_FN])):
        assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y))


def _central(fun, x, h):
    cols = []
    for i in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp.flat[i] += h.flat[i] if np.ndim(h) else h
        xm.flat[i] -= h.flat[i] if np.ndim(h) else h
        cols.append((fun(xp) - fun(xm)) / (2 * (h.flat[i] if np.ndim(h) else h)))
    return np.stack(cols, axis=-1)


# steps: 1e-10 m and 1e-8 rad move the approaches (~1e-6 m) by ~1e-10 m, so the truncation
# (h/delta)^2 stays < 1e-7 and round-off (eps F / h) ~1e-6 of the derivative at most; the
# elastic-rib balance is converged to a few ulp, so it adds no more noise than that.
H5 = np.array([1e-10, 1e-10, 1e-10, 1e-8, 1e-8])
FD_RTOL = 2e-6


@pytest.mark.parametrize("m", [0, 1])
def test_relative_tangents_match_central_differences(m):
    """d wrench / dq (5 x 5, with the elimination of the roller's axial position for the elastic
    rib), d / dq_dot (damping ramp), d / d cage angle and d / d cage rate vs central differences."""
    s, _, _ = _scene(backend="numpy")
    e = s.relative(Q5, QD5, CAGE, CAGE_RATE)
    assert np.sum(e.lamina_force > 0) >= 10 and np.any(e.rib_force > 0)

    def at(q=Q5, qd=QD5, ca=CAGE, cr=CAGE_RATE):
        return s.relative(q, qd, ca, cr).wrench[m]

    def put(base, x):
        out = base.copy()
        out[m] = x
        return out
    checks = [(e.stiffness[m], _central(lambda x: at(q=put(Q5, x)), Q5[m].copy(), H5)),
              (e.damping[m], _central(lambda x: at(qd=put(QD5, x)), QD5[m].copy(), 1e-4)),
              (e.cage_sensitivity[m], _central(lambda x: at(ca=put(CAGE, x[0])), CAGE[m:m + 1].copy(), 1e-6)[:, 0]),
              (e.cage_rate_sensitivity[m],
               _central(lambda x: at(cr=put(CAGE_RATE, x[0])), CAGE_RATE[m:m + 1].copy(), 1e-3)[:, 0])]
    for analytic, fd in checks:
        # (the elastic-rib mounting has no damping: both sides are exactly zero there)
        assert np.linalg.norm(analytic - fd) <= FD_RTOL * np.linalg.norm(fd)
    # the elastic part of the tangent is symmetric (a potential: the rib elimination keeps it so)
    Ke = s.relative(Q5).stiffness[m]
    assert np.linalg.norm(Ke - Ke.T) <= 1e-10 * np.linalg.norm(Ke)


def test_planar_tangent_matches_central_differences():
    """Planar use: dQ/dq (ring centres on rotating arms, cage advancing with the rings) and dQ/dv
    vs central differences (steps as for the 5-DOF tangent; Q is affine in the velocities)."""
    s, pose, vel = _scene(backend="numpy")
    e = s.evaluate(pose, vel)
    assert np.sum(e.obs[:, O.O_FN] > 0) >= 10
    h = np.tile([1e-10, 1e-10, 1e-8], 2)
    Kq = _central(lambda x: s.evaluate(x.reshape(2, 3), vel).Q, pose.ravel().copy(), h)
    Kv = _central(lambda x: s.evaluate(pose, x.reshape(2, 3)).Q, vel.ravel().copy(), 1e-3)
    assert np.linalg.norm(e.dQdq - Kq) <= FD_RTOL * np.linalg.norm(Kq)
    assert np.linalg.norm(e.dQdv - Kv) <= FD_RTOL * np.linalg.norm(Kv)
    # planar forces are the x, y wrench components at the same relative displacement and cage
    loads = s.resultants(pose, vel)
    assert np.allclose(e.Q[0:2], loads["crank_bearing"].force + loads["support"].force, rtol=1e-12, atol=0)



@pytest.mark.parametrize("backend", ["numpy", "warp"])
def test_planar_mounting_sums_in_roller_order(backend):
    """The per-mounting sums of the planar use (one CSR product over every summed column) add each
    mounting's rollers in roller order from zero, as np.add.at does: the same forces bit for bit."""
    s, pose, vel = _scene(backend=backend)
    Q, _, _, (f, _, _), _ = s.raw(pose, vel)
    F = np.zeros((len(s.mountings), 2))
    np.add.at(F, s.roller_owner, f[:, :2])
    assert np.any(F != 0.0)
    assert np.array_equal(Q[:, 0:2], F) and np.array_equal(Q[:, 3:5], -F)

def _phase_averaged(s, q, n_phases):
    """Wrench averaged over cage phases across one roller pitch: the midpoint rule of Z n_phases
    points over the circle, i.e. Z / (2 pi) times the azimuth integral of the roller load."""
    Z = s.mountings[0].bearing.n_rollers
    ph = (np.arange(n_phases) + 0.5) / n_phases * 2 * np.pi / Z
    return np.mean([s.relative(q[None], cage_angle=np.array([p])).wrench[0] for p in ph], axis=0)


def _sjovall_quadrature(eps, n=LINE_N):
    """J_r, J_a by adaptive quadrature of their definitions (Harris & Kotzalas, vol. 1, ch. 7):
    J_r = 1/(2 pi) int [1 - (1 - cos psi)/(2 eps)]_+^n cos psi dpsi, J_a the same without cos psi."""
    from scipy.integrate import quad
    edge = math.acos(1 - 2 * eps) if eps <= 1 else math.pi

    def load(p):
        return max(1 - (1 - math.cos(p)) / (2 * eps), 0.0) ** n
    jr = quad(lambda p: load(p) * math.cos(p), -edge, edge, points=[0.0], epsabs=1e-14, epsrel=1e-12, limit=200)[0]
    ja = quad(load, -edge, edge, points=[0.0], epsabs=1e-14, epsrel=1e-12, limit=200)[0]
    return jr / (2 * math.pi), ja / (2 * math.pi)


@pytest.mark.parametrize("eps", [0.25, 0.5, 0.8, 1.0, 2.0])
def test_sjovall_combined_load(eps):
    """Displacement control: radial delta_r and axial delta_a with
    epsilon = (1 + delta_a tan(alpha) / delta_r) / 2 (Harris & Kotzalas, ch. 7), line contact n = 10/9,
    Q_max = k (delta_r cos(alpha) + delta_a sin(alpha))^(10/9). The phase-averaged rows give
    F_r = Z Q_max J_r(eps) cos(alpha) and F_a = Z Q_max J_a(eps) sin(alpha).

    Tolerance: the average is the midpoint rule with N = Z x 200 = 4,000 points; at the loaded-zone
    edge the integrand behaves as (psi_l - psi)^(10/9), whose rule error is O(h^(n+1)) =
    (2 pi / N)^2.1 ~ 1e-6; 1e-5 leaves room for its constant. Laminae (3 slices) and the cup-normal
    load path must reproduce the unsliced constant-angle law exactly under a pure translation."""
    row = TaperedRollerBearing(**WIDE, n_slices=3)
    s = TaperedBearingSet([TaperedMounting(name="r", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy")
    al, Z = row.cup_angle, row.n_rollers
    dr = 2e-6
    da = (2 * eps - 1) * dr / math.tan(al)
    w = _phase_averaged(s, np.array([dr, 0.0, -da, 0.0, 0.0]), 200)   # loaded direction: +x, -z (sigma = +1)
    q_max = row.roller_coefficient * (dr * math.cos(al) + da * math.sin(al)) ** LINE_N
    jr, ja = _sjovall_quadrature(eps)
    assert abs(-w[0] / (Z * q_max * math.cos(al)) / jr - 1) < 1e-5
    assert abs(w[2] / (Z * q_max * math.sin(al)) / ja - 1) < 1e-5
    # the package's quadrature (used by the case) agrees with this one
    assert np.allclose(sjovall_integrals(eps), (jr, ja), rtol=1e-9)


def test_sjovall_load_controlled():
    """Load control: F_r = 5 kN and F_a = 3 kN on the WIDE row (20 rollers, one on the load line)
    solved for (delta_x, delta_z) with the analytic tangent. epsilon from the displacements matches
    the root of F_r tan(alpha) / F_a = J_r / J_a, and J_r, J_a from Q_max match the integrals.
    Here epsilon > 1 (every roller loaded), the integrand is smooth and periodic, and the 20-point
    sum is spectrally accurate: measured 1e-9, asserted 1e-6. With epsilon < 1 the discrete rollers
    differ from the integral by the loaded-zone edge (the displacement-controlled test averages it)."""
    row = TaperedRollerBearing(**WIDE, n_slices=1)
    s = TaperedBearingSet([TaperedMounting(name="r", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy")
    al, Z = row.cup_angle, row.n_rollers
    Fr, Fa = 5000.0, 3000.0
    q, ev, it, rel = static_equilibrium(s, np.array([Fr, 0.0, -Fa, 0.0, 0.0]), free=(0, 2))
    assert rel < 1e-10 and it < 30
    eps = 0.5 * (1 - q[2] * math.tan(al) / q[0])
    assert eps > 1 and abs(eps / epsilon_from_loads(Fr, Fa, al) - 1) < 1e-6
    q_max = np.max(ev.lamina_force)
    jr, ja = _sjovall_quadrature(eps)
    assert abs(Fr / (Z * q_max * math.cos(al)) / jr - 1) < 1e-6
    assert abs(Fa / (Z * q_max * math.sin(al)) / ja - 1) < 1e-6


@pytest.mark.parametrize("arrangement", ["back_to_back", "face_to_face"])
def test_pair_reactions_match_statics(arrangement):
    """A shaft on a tapered pair under a radial load P at z_P, an axial load F_a and a tilting
    moment M, all five relative coordinates free. With one lamina per roller every roller force
    of a row acts along the cup normal through the row's load centre z_ck on the axis, so the
    rows act as simple supports there (the effective spread): statics gives
    R_0 = P (z_c1 - z_P) / L - M / L, R_1 = P (z_P - z_c0) / L + M / L, L = z_c1 - z_c0, and the
    axial loads of the rows sum to F_a. Asserted to the Newton tolerance (1e-10 of the load)."""
    row = TaperedRollerBearing(**ROW, n_slices=1)
    pair = TaperedPair(rows=(row, row), row_spacing=0.04, arrangement=arrangement, axial_preload=200.0)
    s = TaperedBearingSet([TaperedMounting(name="p", bearing=pair, inner=0, outer=GROUND)], 1, backend="numpy")
    zc0, zc1 = pair.load_centres
    L = pair.effective_spread
    big = 0.04 + 2 * row.load_centre_offset
    assert L == pytest.approx(big if arrangement == "back_to_back" else 0.04 - 2 * row.load_centre_offset, rel=1e-12)
    P, zP, Fa, M = 2000.0, 0.012, 800.0, 15.0
    # load on the cone about the mounting centre: P along +x at z_P gives M_y = z_P P; the moment M about y
    load = np.array([P, 0.0, Fa, 0.0, zP * P + M])
    q, ev, it, rel = static_equilibrium(s, load, q0=np.array([1e-6, 0, 0, 0, 0]))
    assert rel < 1e-10
    rows = ev.row_wrench[0]
    # rows as supports at their load centres: the moment of each row about its own load centre vanishes
    for k, zc in enumerate((zc0, zc1)):
        Mx, My = rows[k, 3] + zc * rows[k, 1], rows[k, 4] - zc * rows[k, 0]
        assert abs(Mx) < 1e-9 * P * L and abs(My) < 1e-9 * P * L
    R0 = P * (zc1 - zP) / L - M / L
    R1 = P * (zP - zc0) / L + M / L
    assert -rows[0, 0] == pytest.approx(R0, rel=1e-9)
    assert -rows[1, 0] == pytest.approx(R1, rel=1e-9)
    assert -(rows[0, 2] + rows[1, 2]) == pytest.approx(Fa, rel=1e-9)


def test_back_to_back_is_stiffer_in_tilt():
    """Same rows and spacing: the O arrangement's larger effective spread gives the smaller tilt
    under a pure moment (paper: paired supports resist overturning through their separation)."""
    tilt = {}
    for arrangement in ("back_to_back", "face_to_face"):
        row = TaperedRollerBearing(**ROW, n_slices=2)
        pair = TaperedPair(rows=(row, row), row_spacing=0.04, arrangement=arrangement, axial_preload=200.0)
        s = TaperedBearingSet([TaperedMounting(name="p", bearing=pair, inner=0, outer=GROUND)], 1, backend="numpy")
        q, *_ = static_equilibrium(s, np.array([0.0, 0.0, 0.0, 0.0, 20.0]))
        tilt[arrangement] = q[4]
    assert 0 < tilt["back_to_back"] < tilt["face_to_face"]


def test_preload_and_end_play():
    """Preload F_p: at zero external load every roller of both rows carries Q = F_p / (Z sin alpha)
    (one lamina, no crowning: Z k (s sin alpha)^(10/9) sin alpha = F_p), the rows' axial forces are
    -+F_p and the pair's wrench vanishes. End play e: nothing touches until the cone has moved e/2."""
    row = TaperedRollerBearing(**ROW, n_slices=1)
    Fp = 300.0
    al, Z, k = row.cup_angle, row.n_rollers, row.roller_coefficient
    s_exact = (Fp / (Z * k * math.sin(al))) ** 0.9 / math.sin(al)
    assert row.axial_approach_for(Fp) == pytest.approx(s_exact, rel=1e-10)
    for arrangement in ("back_to_back", "face_to_face"):
        pair = TaperedPair(rows=(row, row), row_spacing=0.04, arrangement=arrangement, axial_preload=Fp)
        s = TaperedBearingSet([TaperedMounting(name="p", bearing=pair, inner=0, outer=GROUND)], 1, backend="numpy")
        e = s.relative(np.zeros((1, 5)))
        assert np.allclose(e.lamina_force, Fp / (Z * math.sin(al)), rtol=1e-9)
        assert np.allclose(sorted(e.row_wrench[0, :, 2]), [-Fp, Fp], rtol=1e-9)
        assert np.all(np.abs(e.wrench[0]) < 1e-9 * Fp)
        # the preload stiffens the pair: a nonzero radial stiffness at zero load
        assert e.stiffness[0, 0, 0] < 0
    play = TaperedPair(rows=(row, row), row_spacing=0.04, end_play=10e-6)
    s = TaperedBearingSet([TaperedMounting(name="p", bearing=play, inner=0, outer=GROUND)], 1, backend="numpy")
    assert not np.any(s.relative(np.array([[0.0, 0, 4.9e-6, 0, 0]])).lamina_force)
    assert np.any(s.relative(np.array([[0.0, 0, 5.1e-6, 0, 0]])).lamina_force > 0)


def test_rib_contact_on_off():
    """Rib contact: (i) the rib carries the roller's axial squeeze, F_f = 2 sin(phi) sum_s F_s, per
    roller, lumped or elastic; (ii) a near-rigid rib (end radius 1e6 m: K_f x 3,500) reproduces the
    lumped wrench under a translation (the lumped model is its rigid limit: n_i - 2 sin(phi) e_a = n_o),
    to O(rib compliance); (iii) the elastic rib only adds compliance: the axial force at the same
    axial approach is smaller, and the rib force is positive."""
    q = np.array([[2e-6, -1e-6, -3e-6, 0.0, 0.0]])
    kappa = 2 * math.sin(TaperedRollerBearing(**ROW).roller_half_angle)
    out = {}
    for name, kw in (("lumped", {}), ("rib", dict(rib_contact=True)), ("stiff", dict(rib_contact=True,
                                                                                    rib_end_radius=1e6))):
        row = TaperedRollerBearing(**ROW, n_slices=2, **kw)
        s = TaperedBearingSet([TaperedMounting(name="r", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy")
        e = s.relative(q)
        per_roller = np.zeros(row.n_rollers)
        np.add.at(per_roller, s.lamina_roller, e.lamina_force)
        assert np.allclose(e.rib_force, kappa * per_roller, rtol=1e-9, atol=1e-9 * per_roller.max())
        out[name] = e.wrench[0]
    assert 0 < out["rib"][2] < out["lumped"][2]
    assert np.linalg.norm(out["stiff"] - out["lumped"]) < 2e-3 * np.linalg.norm(out["lumped"])
    assert np.linalg.norm(out["rib"] - out["lumped"]) > 5 * np.linalg.norm(out["stiff"] - out["lumped"])


def test_crowning_and_tilt_load_the_laminae():
    """Crowning drops the edge laminae under a uniform approach; a tilt loads one end of the
    roller more than the other (Eq. (width_resultant) keeps the end moments)."""
    row = TaperedRollerBearing(**ROW, n_slices=4, crowning=1e-6)
    s = TaperedBearingSet([TaperedMounting(name="r", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy")
    f = s.relative(np.array([[0.0, 0, -4e-6, 0, 0]])).lamina_force[:4]
    assert f[0] == pytest.approx(f[3], rel=1e-12) and f[1] == pytest.approx(f[2], rel=1e-12) and f[0] < f[1]
    f = s.relative(np.array([[0.0, 0, -4e-6, 0, 2e-4]])).lamina_force[:4]    # roller 0 at psi = 0
    assert abs(f[0] - f[3]) > 0.1 * f.max()


def test_tapered_set_as_exudyn_contact_element():
    """The planar evaluator plugs into the Exudyn contact element: callbacks return its forces."""
    exu = pytest.importorskip("exudyn")
    from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D

    from exudyn_user_elements.contact_element import ContactElement
    s, pose, vel = _scene(backend="warp")
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0])) for _ in range(2)]
    for n in nodes:
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=1.0, inertia=1e-3))
    el = ContactElement(mbs, nodes, s)
    mbs.Assemble()
    q, v = pose.ravel(), vel.ravel()
    np.testing.assert_allclose(el.force_callback(mbs, 0.0, el.object_number, q, v), s.evaluate(pose, vel).Q, rtol=1e-12)
    assert el.ids == s.ids and el.commit(q, v).normal_force.shape == (len(s.ids),)
    assert "crank_bearing/row1/roller13/slice2" in s.ids and "support/row0/roller0/slice0" in s.ids


def test_bad_inputs_name_the_parameter():
    bad = [(dict(cup_angle=math.radians(75.0)), "cup_angle_deg"), (dict(cup_angle=math.radians(0.0)), "cup_angle_deg"),
           (dict(cone_angle=math.radians(14.0)), "cone_angle_deg"), (dict(cone_angle=math.radians(-6.0)), "cone_angle_deg"),
           (dict(n_rollers=30), "n_rollers"), (dict(n_slices=0), "n_slices"), (dict(crowning=-1e-6), "crowning"),
           (dict(crowning=(1e-6, 2e-6)), "crowning"), (dict(law="cubic"), "law"),
           (dict(rib_contact=True, damping=10.0), "damping"), (dict(rib_clearance=-1e-6), "rib_clearance"),
           (dict(roller_length=0.0), "roller_length"), (dict(poisson_ratio=0.5), "poisson_ratio")]
    for kw, name in bad:
        with pytest.raises(RvtoolInputError, match=name):
            TaperedRollerBearing(**{**ROW, **kw})
    # a design file's row table gives the angles in degrees (NAME_deg); the spec holds radians
    file_row = {**{k: v for k, v in ROW.items() if not k.endswith("_angle")}, "cup_angle_deg": 14.0,
                "cone_angle_deg": 11.0}
    with pytest.raises(RvtoolInputError, match=r"crank_bearing\.cup_angle_deg = 95.0 is outside the valid range"):
        TaperedRollerBearing.from_mapping({**file_row, "cup_angle_deg": 95.0}, key="crank_bearing")
    with pytest.raises(RvtoolInputError, match=r"crank_bearing\.cup_angle: a design file gives this angle in degrees"):
        TaperedRollerBearing.from_mapping(ROW, key="crank_bearing")
    with pytest.raises(RvtoolInputError, match=r"crank_bearing\.rows\[1\]\.cone_angle_deg"):
        TaperedPair.from_mapping({"rows": [file_row, {**file_row, "cone_angle_deg": 20.0}], "row_spacing": 0.04},
                                 key="crank_bearing")
    with pytest.raises(RvtoolInputError, match=r"crank_bearing\.spacing is not a parameter"):
        TaperedPair.from_mapping({"row": file_row, "spacing": 0.04}, key="crank_bearing")
    with pytest.raises(RvtoolInputError, match=r"crank_bearing\.axial_preload"):
        TaperedPair.from_mapping({"row": file_row, "row_spacing": 0.04, "axial_preload": -5.0}, key="crank_bearing")
    assert TaperedPair.from_mapping({"row": file_row, "row_spacing": 0.04}).rows[1].cup_angle == math.radians(14.0)
    row = TaperedRollerBearing(**ROW)
    for kw, name in [(dict(row_spacing=0.005), "row_spacing"), (dict(arrangement="tandem"), "arrangement"),
                     (dict(axial_preload=100.0, end_play=1e-6), "end_play"), (dict(end_play=1e-3), "end_play")]:
        with pytest.raises(RvtoolInputError, match=name):
            TaperedPair(**{"rows": (row, row), "row_spacing": 0.04, **kw})
    with pytest.raises(RvtoolInputError, match="tapered bearing"):
        TaperedMounting(name="b", bearing=object(), inner=0, outer=GROUND)
    s = TaperedBearingSet([TaperedMounting(name="b", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy")
    with pytest.raises(RvtoolInputError, match="q must have shape"):
        s.relative(np.zeros((2, 5)))
    with pytest.raises(RvtoolInputError, match="non-finite"):
        s.evaluate(np.array([[np.nan, 0.0, 0.0]]))
    with pytest.raises(RvtoolInputError, match="outer"):
        TaperedBearingSet([TaperedMounting(name="b", bearing=row, inner=0, outer=4)], 1)
