"""The involute tooth-pair contact family (warp_contacts.involute_pairs and its NumPy reference,
rvtool.contact.involute_set): kernel against reference on every device, conjugate action,
the series law against the closed form of Weber's line-contact approach, the analytic tangent
against central differences, friction, the width resultant and input errors."""
import math

import numpy as np
import pytest
import warp as wp

from rvtool.contact.circle_set import FrictionLaw, FrictionModel
from rvtool.contact.involute_set import GearMesh, InvoluteContactSet
from rvtool.errors import RvtoolInputError
from rvtool.geometry.involute import FlankModification, InvoluteGear, InvolutePair
from warp_contacts import involute_pairs_ref as ref
from warp_contacts.precision import resolve_device

resolve_device("cpu")
DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(wp.get_cuda_device_count() == 0,
                                                                    reason="no CUDA device"))]
M = 4.5e-3
FRICTION = FrictionLaw(model=FrictionModel.REGULARIZED, mu_kinetic=0.05, mu_static=0.06, regularization_speed=1e-3)


def fzg(modified=False, deviations=False, centre_distance=91.5e-3):
    md = FlankModification(tip_relief=4e-6, tip_relief_diameter=79.5e-3, relief_shape="parabolic", lead_crowning=3e-6,
                           profile_crowning=1e-6) if modified else FlankModification()
    f = np.zeros(16)
    if deviations:
        f[5], f[6] = 4e-6, -4e-6
    A = InvoluteGear(module=M, n_teeth=16, face_width=14e-3, profile_shift=0.1817, tip_diameter=82.46e-3,
                     bore_diameter=30e-3, modification=md, single_pitch_deviations=tuple(f), name="gear_a")
    B = InvoluteGear(module=M, n_teeth=24, face_width=14e-3, profile_shift=0.1715, tip_diameter=118.36e-3,
                     bore_diameter=40e-3, name="gear_b")
    return InvolutePair(gear_a=A, gear_b=B, centre_distance=centre_distance)


def ring_pair():
    """Four-tooth-difference internal pair (z 30/34, x 0/-1, m = 1 mm), feasible (see the geometry tests)."""
    A = InvoluteGear(module=1e-3, n_teeth=30, face_width=5e-3, tip_diameter=31.6e-3, name="gear_a")
    B = InvoluteGear(module=1e-3, n_teeth=34, face_width=5e-3, internal=True, profile_shift=-1.0, tip_diameter=33.18e-3,
                     name="gear_b")
    return InvolutePair(gear_a=A, gear_b=B)


def scene(pair, backend="warp", precision="float64", device="cpu", **kw):
    mesh = GearMesh(pair=pair, body_a=0, body_b=1, **kw)
    return InvoluteContactSet([mesh], 2, backend=backend, precision=precision, device=device)


def poses(pair, thetas, dtheta_b):
    th0 = pair.mesh_phase(0)
    return [np.array([[0.0, 0.0, t], [pair.a, 0.0, th0 + pair.ratio * t + dtheta_b]]) for t in thetas]


def external_kw():
    return dict(n_slices=2, damping=80.0, friction=FRICTION, tilt_x=1e-4, tilt_y=-2e-4, skew=1e-4)


def _cases():
    """(name, pair, mesh kwargs, approach as a turn of gear B [rad], velocities)."""
    vel_e = np.array([[1e-3, -2e-3, 10.0], [5e-4, 1e-3, -10 * 16 / 24 + 0.3]])
    vel_i = np.array([[1e-3, -2e-3, 10.0], [5e-4, 1e-3, 10 * 30 / 34 - 0.3]])
    return [("external", fzg(modified=True, deviations=True), external_kw(), 6e-4, vel_e),
            ("internal", ring_pair(), dict(n_slices=2, damping=20.0, friction=FRICTION, tilt_y=1e-4), 3e-4, vel_i)]


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("precision,tol", [("float64", 1e-9), ("float32", 2e-2)])
@pytest.mark.parametrize("case", [0, 1])
def test_kernel_matches_numpy_reference(case, precision, tol, device):
    """The gap is a difference of positions ~5e-2 m for approaches ~1e-5 m (amplification ~5e3).
    float64: another operation order (fused multiply-add on GPUs) gives ~1e-16 x 5e3 plus the
    series iteration's stopping rule (1e-14 relative); measured <= 1e-12 on the CPU; 1e-9 leaves
    margin. float32: ~4e-9 m of rounding against ~1e-5 m approaches (4e-4), amplified in the
    friction tangent by v / v_reg where sliding is slow; measured on the CPU <= 1.1e-3 (Q),
    5e-5 (dQ/dq) and 3.4e-3 (dQ/dv entries above 1e-3 of its largest, the ones the solver
    feels); 2e-2 leaves margin and still catches a formula error, which is O(1)."""
    name, pair, kw, dth, vel = _cases()[case]
    s_w = scene(pair, "warp", precision, device, **kw)
    s_n = scene(pair, "numpy", **kw)
    cycle = 2 * np.pi / pair.gear_a.n_teeth
    modes = set()
    for pose in poses(pair, np.linspace(0.0, cycle, 7), dth):
        a, b = s_w.evaluate(pose, vel), s_n.evaluate(pose, vel)
        modes |= set(b.obs[b.obs[:, ref.O_FN] > 0, ref.O_MODE].astype(int))
        for x, y in ((a.Q, b.Q), (a.dQdq, b.dQdq)):
            assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y))
        big = np.abs(b.dQdv) > 1e-3 * np.max(np.abs(b.dQdv))
        assert np.max(np.abs(a.dQdv - b.dQdv)[big]) <= tol * np.max(np.abs(b.dQdv))
        np.testing.assert_array_equal(a.obs[:, ref.O_MODE], b.obs[:, ref.O_MODE])
    # the sweep exercises the line of action and the tip edges of both gears
    assert {ref.MODE_LINE, ref.MODE_CORNER_A, ref.MODE_CORNER_B} <= modes


@pytest.mark.parametrize("pair", [fzg(centre_distance=None), ring_pair()], ids=["external", "internal"])
def test_conjugate_action_at_zero_load(pair):
    """Unmodified pair at its zero-backlash centre distance, rigidly turned (theta_B = theta_B0 +
    ratio theta_A): every pair on the line of action touches with gap 0, so the transmission
    error g / r_bB of the kinematic motion is round-off (|g| < 1e-13 m ~ 1e-12 rad) over two
    mesh cycles, on both flanks."""
    s = scene(pair, "numpy")
    cycle = 2 * np.pi / pair.gear_a.n_teeth
    n_line = 0
    for pose in poses(pair, np.linspace(0.0, 2 * cycle, 41), 0.0):
        o = s.evaluate(pose, np.zeros((2, 3))).obs
        line = o[:, ref.O_MODE] == ref.MODE_LINE
        n_line += line.sum()
        assert np.max(np.abs(o[line, ref.O_GAP])) < 1e-13
        # a round-off penetration (~1e-17 m) carries a round-off force
        assert np.all(o[:, ref.O_FN] < 1e-6)
    assert n_line >= 2 * 41


def test_series_law_inverts_webers_closed_form():
    """Eq. (series_contact) with Weber's approach in closed form, written out here:
    delta(F) = c F + sum_i 2 F (1 - nu_i^2) / (pi E_i b) [ln(2 h_i / a) - nu_i / (2 (1 - nu_i))],
    a = sqrt(4 F R' / (pi b E*)) (Hertz line contact half-width). The iteration must return F
    to round-off, and dF/d delta = 1 / (d delta / dF) with the derivative by central differences."""
    E1, n1, E2, n2, b = 206e9, 0.3, 190e9, 0.28, 3.5e-3
    c, h1, h2, R1, R2 = 4e-12 / b, 3e-3, 4e-3, 8e-3, 12e-3
    estar = 1 / ((1 - n1 ** 2) / E1 + (1 - n2 ** 2) / E2)
    Rp = R1 * R2 / (R1 + R2)

    def delta(F):
        a = math.sqrt(4 * F * Rp / (math.pi * b * estar))
        return c * F + sum(2 * F * (1 - nu ** 2) / (math.pi * E * b) * (math.log(2 * h / a) - nu / (2 * (1 - nu)))
                           for E, nu, h in ((E1, n1, h1), (E2, n2, h2)))

    F0 = np.array([1.0, 50.0, 2000.0, 20000.0])
    d0 = np.array([delta(f) for f in F0])
    one = np.ones_like(F0)
    F, dFdd, *_ = ref.series_force(d0, c * one, h1 * one, h2 * one, (1 / R1 + 1 / R2) * one, E1 * one, n1 * one,
                                   E2 * one, n2 * one, b * one)
    np.testing.assert_allclose(F, F0, rtol=1e-13)
    slope = np.array([(delta(f * (1 + 1e-6)) - delta(f * (1 - 1e-6))) / (2e-6 * f) for f in F0])
    np.testing.assert_allclose(dFdd, 1 / slope, rtol=1e-8)


def _fd_tangent(s, pose, vel, h=1e-9):
    J = np.zeros((6, 6))
    Jv = np.zeros((6, 6))
    for c in range(6):
        d = np.zeros(6)
        d[c] = h
        d = d.reshape(2, 3)
        J[:, c] = (s.evaluate(pose + d, vel).Q - s.evaluate(pose - d, vel).Q) / (2 * h)
        Jv[:, c] = (s.evaluate(pose, vel + 1e3 * d).Q - s.evaluate(pose, vel - 1e3 * d).Q) / (2e3 * h)
    return J, Jv


@pytest.mark.parametrize("case", [0, 1])
def test_tangent_matches_central_differences(case):
    """Both terms of Eq. (assembled_contact_tangent) on the smooth branch, at states in line contact
    and at both tip edges, with friction, damping, tilt and modifications. Central differences with
    h = 1e-9 (m, rad) err by ~h^2 Q''' + eps Q / h ~ 1e-8 relative; the tolerance 1e-6 sits between
    that and the arm term (dG^T/dq) f, which the test shows to exceed five times the tolerance."""
    name, pair, kw, dth, vel = _cases()[case]
    s = scene(pair, "numpy", **kw)
    cycle = 2 * np.pi / pair.gear_a.n_teeth
    seen = set()
    for pose in poses(pair, np.linspace(0.0, cycle, 9)[:-1], dth):
        ev = s.evaluate(pose, vel)
        on = ev.obs[:, ref.O_FN] > 0
        seen |= set(ev.obs[on, ref.O_MODE].astype(int))
        J, Jv = _fd_tangent(s, pose, vel)
        scale = np.max(np.abs(ev.dQdq))
        assert np.max(np.abs(J - ev.dQdq)) <= 1e-6 * scale
        assert np.max(np.abs(Jv - ev.dQdv)) <= 1e-6 * np.max(np.abs(ev.dQdv))
    assert {ref.MODE_LINE, ref.MODE_CORNER_A, ref.MODE_CORNER_B} <= seen
    # the arm term: without friction the force acts along one line through all contact points,
    # so cross(r, df) is the force term of the moment rows and the rest is (dG^T/dq) f
    s0 = scene(pair, "numpy", n_slices=1)
    pose = poses(pair, [0.3 * cycle], dth)[0]
    ev = s0.evaluate(pose, np.zeros((2, 3)))
    on = ev.obs[:, ref.O_FN] > 0
    r = ev.obs[on, ref.O_PX:ref.O_PY + 1][0]
    J, _ = _fd_tangent(s0, pose, np.zeros((2, 3)))
    arm = J[2] - (r[0] * J[1] - r[1] * J[0])
    assert np.max(np.abs(arm)) >= 5 * 1e-6 * np.max(np.abs(J))


def test_friction_opposes_sliding_and_vanishes_at_the_pitch_point():
    """Sliding speed of involute flanks, |v_t| = (|omega_A| + |omega_B|) |s| for an external pair, s the
    distance of the contact point from the pitch point P along the line of action (material
    velocities at the contact point); friction on A opposes A's sliding (F_t v_t <= 0), changes sign
    across P and vanishes at P."""
    pair = fzg()
    s = scene(pair, "numpy", friction=FRICTION, lines=(0,))
    wa = 10.0
    vel = np.array([[0.0, 0.0, wa], [0.0, 0.0, pair.ratio * wa]])
    P = np.array([pair.working_pitch_radii[0], 0.0])

    def loaded(th):
        o = s.evaluate(poses(pair, [th], -2e-4)[0], vel).obs
        on = np.flatnonzero((o[:, ref.O_FN] > 0) & (o[:, ref.O_MODE] == ref.MODE_LINE))
        return o, on, np.sum((o[on, ref.O_PX:ref.O_PY + 1] - P) * o[on, ref.O_NX:ref.O_NY + 1], axis=1)

    signs = []
    for th in np.linspace(-0.08, 0.08, 9):
        o, on, dist = loaded(th)
        np.testing.assert_allclose(np.abs(o[on, ref.O_VT]), wa * (1 + abs(pair.ratio)) * np.abs(dist), rtol=1e-9,
                                   atol=1e-13)
        assert np.all(o[on, ref.O_FT] * o[on, ref.O_VT] <= 0.0)
        signs += list(np.sign(o[on, ref.O_VT]))
    assert min(signs) < 0 < max(signs)
    # the pinion angle that puts a loaded contact on P: the contact moves by r_bA per radian
    o, on, dist = loaded(0.0)
    k = np.argmin(np.abs(dist))
    th = 0.0
    for _ in range(3):
        th += dist[k] / pair.gear_a.base_radius
        o, on, dist = loaded(th)
        k = np.argmin(np.abs(dist))
    assert abs(dist[k]) < 1e-12
    assert abs(o[on[k], ref.O_VT]) < 1e-10 and abs(o[on[k], ref.O_FT]) <= 1e-7 * o[on[k], ref.O_FN]
    # rolling speed: the surface speed along the flank relative to the contact, omega_A rho_A with the
    # radius of curvature rho_A = r_bA tan(alpha_w) at P
    assert abs(o[on[k], ref.O_VROLL]) == pytest.approx(wa * pair.gear_a.base_radius * math.tan(pair.working_pressure_angle),
                                                       rel=1e-9)


def test_width_resultant_of_slices():
    """Eq. (width_resultant): the slice forces sum to the mesh force and their moments about the
    midplane, sum z_s (e_z x f_s), appear with a relative tilt (unequal end loads)."""
    pair = fzg()
    s = scene(pair, "numpy", n_slices=4, tilt_y=2e-4, lines=(1,))
    pose = poses(pair, [0.02], 2e-4)[0]
    Qc, _, _, obs = s.raw(pose, np.zeros((2, 3)))
    f = Qc[:, 0:2]
    assert np.allclose(f.sum(axis=0), s.evaluate(pose, np.zeros((2, 3))).Q[0:2], rtol=1e-12)
    z = s.fparams[:, ref.C_Z]
    Mx, My = s.width_moments(obs)[0]
    assert Mx == pytest.approx(np.sum(-z * f[:, 1]), rel=1e-12)
    assert My == pytest.approx(np.sum(z * f[:, 0]), rel=1e-12)
    loaded = obs[:, ref.O_FN] > 0
    assert np.ptp(obs[loaded, ref.O_FN]) > 0.05 * np.max(obs[loaded, ref.O_FN])


def test_internal_pair_contact_torques():
    """One evaluation of the four-tooth-difference internal pair: on the line of action the contact
    torques are omega F r_bA on the wheel and omega eps F r_bB on the ring (module docstring)."""
    pair = ring_pair()
    s = scene(pair, "numpy", lines=(0,))
    pose = poses(pair, [0.01], -3e-4)[0]
    Qc, _, _, obs = s.raw(pose, np.zeros((2, 3)))
    line = (obs[:, ref.O_MODE] == ref.MODE_LINE) & (obs[:, ref.O_FN] > 0)
    assert line.any()
    omega = -1.0  # line 0 of an internal pair: omega = s eps = -1
    F = obs[line, ref.O_FN]
    np.testing.assert_allclose(Qc[line, 2], omega * F * pair.gear_a.base_radius, rtol=1e-10)
    np.testing.assert_allclose(Qc[line, 5], omega * pair.eps * F * pair.gear_b.base_radius, rtol=1e-10)


@pytest.mark.parametrize("kw,match", [
    (dict(n_slices=0), r"mesh.n_slices"),
    (dict(lines=(2,)), r"mesh.lines"),
    (dict(window=-1), r"mesh.window"),
    (dict(clearance=float("nan")), r"mesh.clearance"),
    # anchors are available since issue 17 (tests/test_friction_anchor.py); their release distance is checked
    (dict(anchor_release_distance=0.0), r"mesh.anchor_release_distance"),
])
def test_bad_mesh_inputs(kw, match):
    with pytest.raises(RvtoolInputError, match=match):
        GearMesh(pair=fzg(), body_a=0, **kw)


def test_bad_set_inputs():
    with pytest.raises(RvtoolInputError, match=r"body_b = 5"):
        InvoluteContactSet([GearMesh(pair=fzg(), body_a=0, body_b=5)], 2, backend="numpy")
    with pytest.raises(RvtoolInputError, match=r"backend"):
        InvoluteContactSet([GearMesh(pair=fzg(), body_a=0)], 1, backend="jax")
    s = scene(fzg(), "numpy")
    with pytest.raises(RvtoolInputError, match=r"pose must be a finite array"):
        s.evaluate(np.full((2, 3), np.nan), np.zeros((2, 3)))
