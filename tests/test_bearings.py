"""Rolling-element bearings: kernel vs reference, tangent, Stribeck, clearance, preload, cage."""
import math

import numpy as np
import pytest

from rvtool.bearings import AngularContactPair, BallBearing, BearingSet, CrossedRollerBearing, Mounting, RollerBearing
from rvtool.bearings.checks import radial_load_distribution, sjovall_radial_integral, stribeck_exact_sum
from rvtool.bearings.reducer import preload_offset
from rvtool.contact.circle_set import GROUND
from rvtool.errors import RvtoolInputError

BALL = BallBearing(n_balls=16, ball_diameter=0.007938, pitch_diameter=0.068)


def _set(backend="numpy", precision="float64", device="cpu"):
    ac = BallBearing(n_balls=16, ball_diameter=0.007938, pitch_diameter=0.068, contact_angle=math.radians(25))
    ac = BallBearing(**{**ac.__dict__, "axial_preload_offset": preload_offset(ac, 200.0)})
    ms = [Mounting(name="main", bearing=AngularContactPair(row=ac, row_spacing=0.04), inner=0, outer=GROUND),
          Mounting(name="needle", bearing=RollerBearing(inner_radius=0.012, roller_diameter=0.003, roller_length=0.008,
                                                        n_rollers=16, radial_clearance=1e-6, crowning=1e-6),
                   inner=1, outer=0, inner_centre=(0.0, 8e-4)),
          Mounting(name="xr", bearing=CrossedRollerBearing(inner_radius=0.03, roller_diameter=0.005, roller_length=0.005,
                                                           n_rollers=30), inner=1, outer=GROUND)]
    pose = np.array([[3e-6, -2e-6, 0.2], [-1e-6, 8e-4 + 4e-6, -0.4]])
    return BearingSet(ms, 2, backend=backend, precision=precision, device=device), pose


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401
    wp.init()
    return [d.alias for d in wp.get_devices()]


@pytest.mark.parametrize("device", _devices())
@pytest.mark.parametrize("precision,tol", [("float64", 1e-9), ("float32", 2e-2)])
def test_kernel_matches_reference(precision, tol, device):
    """Approaches ~1e-6 m from positions ~3e-2 m: rounding is amplified ~3e4 (see test_cycloid)."""
    s, pose = _set("warp", precision, device)
    r, _ = _set("numpy")
    a, b = s.evaluate(pose), r.evaluate(pose)
    assert np.max(np.abs(a.Q - b.Q)) <= tol * np.max(np.abs(b.Q))
    assert np.max(np.abs(a.dQdq - b.dQdq)) <= tol * np.max(np.abs(b.dQdq))


def test_tangent_matches_central_differences_including_cage_motion():
    s, pose = _set()
    e = s.evaluate(pose)
    assert np.min(np.abs(e.obs[:, 2])) > 3e-9          # no element at its switch
    K = np.zeros((6, 6))
    for j in range(6):
        b, c = divmod(j, 3)
        h = 1e-9 if c < 2 else 1e-7
        P = pose.copy()
        P[b, c] += h
        qp = s.evaluate(P).Q
        P = pose.copy()
        P[b, c] -= h
        K[:, j] = (qp - s.evaluate(P).Q) / (2 * h)
    assert np.linalg.norm(e.dQdq - K) / np.linalg.norm(K) < 1e-6


def test_virtual_work_of_radial_elements():
    """Forces act through the ring centres along u_j: v^T Q = (v_cA - v_cB) . f for rigid motion."""
    s, pose = _set()
    Qc, _, obs = s.raw(pose)
    rng = np.random.default_rng(1)
    v = np.vstack([rng.normal(size=(2, 3)), np.zeros(3)])
    ia, ib = s.iparams[:, 0], s.iparams[:, 1]
    p_gen = np.sum(Qc[:, :3] * v[ia], axis=1) + np.sum(Qc[:, 3:] * v[ib], axis=1)
    P = np.vstack([pose, np.zeros(3)])
    def vc(body, xi):
        th = P[body, 2]
        r = np.column_stack([np.cos(th) * xi[:, 0] - np.sin(th) * xi[:, 1], np.sin(th) * xi[:, 0] + np.cos(th) * xi[:, 1]])
        return v[body, :2] + v[body, 2:3] * np.column_stack([-r[:, 1], r[:, 0]])
    p_ct = np.sum((vc(ia, s.fparams[:, 0:2]) - vc(ib, s.fparams[:, 2:4])) * Qc[:, :2], axis=1)
    np.testing.assert_allclose(p_gen, p_ct, rtol=1e-10, atol=1e-9)


def test_stribeck_zero_clearance():
    """Q_max: exact discrete zero-clearance sum (closed form) and Stribeck's 4.37 F_r / Z."""
    Fr = 5000.0
    Q, psi, _ = radial_load_distribution(BALL, Fr)
    exact = Fr * stribeck_exact_sum(BALL.n_balls, psi_loaded_line=np.pi / 2)
    assert abs(Q.max() / exact - 1) < 1e-9
    assert abs(Q.max() / (4.37 * Fr / BALL.n_balls) - 1) < 0.01
    assert abs(1 / sjovall_radial_integral(0.5) - 4.37) < 0.01


def test_clearance_opens_and_preload_loads_every_ball():
    loose = BallBearing(n_balls=12, ball_diameter=0.008, pitch_diameter=0.05, radial_clearance=5e-6)
    s = BearingSet([Mounting(name="b", bearing=loose, inner=0, outer=GROUND)], 1)
    assert not np.any(s.evaluate(np.array([[3e-6, -2e-6, 0.1]])).obs[:, 0])
    ac = BallBearing(n_balls=12, ball_diameter=0.008, pitch_diameter=0.05, contact_angle=math.radians(25))
    ac = BallBearing(**{**ac.__dict__, "axial_preload_offset": preload_offset(ac, 300.0)})
    q = BearingSet([Mounting(name="b", bearing=ac, inner=0, outer=GROUND)], 1).evaluate(np.zeros((1, 3))).obs[:, 0]
    # every ball carries its axial share at the working angle: Z Q sin(alpha_w) = F_a
    A = ac.groove_centre_distance
    a_z = A * math.sin(ac.contact_angle) + ac.axial_preload_offset
    sin_w = a_z / math.hypot(A * math.cos(ac.contact_angle), a_z)
    np.testing.assert_allclose(q * sin_w * 12, 300.0, rtol=1e-9)


def test_cage_advances_with_the_rings():
    s = BearingSet([Mounting(name="b", bearing=BALL, inner=0, outer=GROUND)], 1)
    n0 = s.evaluate(np.zeros((1, 3))).obs[0, 5:7]
    n1 = s.evaluate(np.array([[0.0, 0.0, 0.5]])).obs[0, 5:7]
    gamma = BALL.ball_diameter / BALL.pitch_diameter
    turned = math.atan2(n0[0] * n1[1] - n0[1] * n1[0], n0 @ n1)
    assert abs(turned - 0.5 * (1 - gamma) * 0.5) < 1e-12


def test_bad_inputs_name_the_parameter():
    with pytest.raises(RvtoolInputError, match="inner_curvature"):
        BallBearing(n_balls=12, ball_diameter=0.008, pitch_diameter=0.05, inner_curvature=0.5)
    with pytest.raises(RvtoolInputError, match="n_balls"):
        BallBearing(n_balls=30, ball_diameter=0.008, pitch_diameter=0.05)
    with pytest.raises(RvtoolInputError, match="n_rollers"):
        RollerBearing(inner_radius=0.01, roller_diameter=0.003, roller_length=0.008, n_rollers=40)
    with pytest.raises(RvtoolInputError, match="outer"):
        BearingSet([Mounting(name="b", bearing=BALL, inner=0, outer=5)], 1)
