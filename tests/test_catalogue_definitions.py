"""The catalogue's definitions (rvtool/protocols/catalogue.py) against a synthetic
spring--Coulomb--backlash reducer whose figures are known in closed form, run through the same
protocol (catalogue_sequence -> catalogue_loops -> catalogue_metrics) as a real design.

The reference reducer (catalogue.SpringCoulombBacklash): output angle theta against the grounded
input through a free play +-beta in series with a bilinear spring s (k1 up to the knee torque
T_k, k2 beyond; s^-1(y) = y/k1 for y <= T_k, T_k/k1 + (y - T_k)/k2 beyond), a Coulomb torque T_c
in parallel. Quasi-static under a commanded torque T (after the virgin preload to -T_R):

  loading branch, T > T_c:        theta = beta + s^-1(T - T_c)
  loading branch, 0 < T < T_c:    theta = -beta - s^-1(T_c - T)      (still on the far flank)
  unloading branch, 0 < T < T_R - 2 T_c:  theta = beta + s^-1(T + T_c)
  (the negative side by symmetry theta(-T) = -theta(T) with loading <-> loading)

hence, with t = 0.03 T_R the lost-motion torque and 0 < T_1 < T_2 the rigidity points:

  rigidity b/a     = (T_2 - T_1) / (s^-1(T_2 - T_c) - s^-1(T_1 - T_c))           (T_1 > T_c)
  lost motion      = 2 beta + 2 t / k1     (t > T_c, t + T_c <= T_k)
                   = 2 t / k1              (t < T_c: the free play stays hidden in the loop's width)
  hysteresis loss  = 2 beta + 2 T_c / k1   (T_c <= T_k: the clearance is included)

The unloading branches are linear near zero torque (T + T_c < T_k), so their extrapolation to
T = 0 is exact; every figure is a difference of a few angles of order 1e-3 rad computed in
double precision, hence the 1e-9 relative tolerance (round-off ~1e-13, the issue's bound 1e-9).
"""
import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.protocols import catalogue as C
from rvtool.protocols import hysteresis as H
from rvtool.protocols import stiffness as S
from rvtool.units import RAD_PER_ARCMIN

T_R = 400.0                                   # N m
K1 = 100.0 / RAD_PER_ARCMIN                   # N m/rad (100 N m/arcmin)
K2 = 150.0 / RAD_PER_ARCMIN                   # N m/rad beyond the knee
T_K = 240.0                                   # N m, knee at 0.6 T_R (between the rigidity points)
BETA = 0.5 * RAD_PER_ARCMIN                   # rad, half the free play
POINTS = (0.5, 1.0)                           # rigidity points [fraction of T_R] of the synthetic check
TOL = 1e-9


def s_inv(y):
    return y / K1 if y <= T_K else T_K / K1 + (y - T_K) / K2


def run(tc, beta=BETA, step=0.0625):
    red = C.SpringCoulombBacklash(stiffness=K1, stiffness_2=K2, knee_torque=T_K, backlash=beta, friction_torque=tc)
    seq = C.catalogue_sequence(T_R, rigidity_points=POINTS, step=step)
    return C.catalogue_loops(red, seq, rigidity_points=POINTS, repeat_tolerance=0.0), seq


@pytest.mark.parametrize("tc", [5.0, 0.0])           # T_c below the 3 % level (12 N m); no friction
def test_synthetic_reducer_closed_forms_small_friction(tc):
    r, _ = run(tc)
    m = r["metrics"]
    t1, t2 = POINTS[0] * T_R, POINTS[1] * T_R
    t = 0.03 * T_R
    rig = (t2 - t1) / (s_inv(t2 - tc) - s_inv(t1 - tc))
    assert m.rigidity.per_branch["pos_loading"] == pytest.approx(rig, rel=TOL)
    assert m.rigidity.per_branch["neg_loading"] == pytest.approx(rig, rel=TOL)
    assert m.rigidity.value == pytest.approx(rig, rel=TOL)
    assert m.lost_motion == pytest.approx(2 * BETA + 2 * t / K1, rel=TOL)
    assert m.hysteresis_loss.value == pytest.approx(2 * BETA + 2 * tc / K1, rel=TOL)
    assert m.hysteresis_loss.error == pytest.approx(0.0, abs=TOL * m.hysteresis_loss.value)
    # the loops repeat exactly after the virgin preload (Masing; tolerance 0)
    assert r["repeatability"].passed and r["repeatability"].max_angle_diff == 0.0


def test_synthetic_reducer_closed_forms_large_friction():
    tc = 20.0                                   # T_c above the 3 % level: the loading branch is still on the far flank
    r, _ = run(tc)
    m = r["metrics"]
    t = 0.03 * T_R
    t1, t2 = POINTS[0] * T_R, POINTS[1] * T_R
    assert m.rigidity.value == pytest.approx((t2 - t1) / (s_inv(t2 - tc) - s_inv(t1 - tc)), rel=TOL)
    assert m.lost_motion == pytest.approx(2 * t / K1, rel=TOL)
    assert m.hysteresis_loss.value == pytest.approx(2 * BETA + 2 * tc / K1, rel=TOL)


def test_definitions_differ_from_the_former_readings():
    """Why the definitions matter (each test above fails with the former reading): the
    least-squares fit over 50-100 % T_R is not b/a across the knee, and the zero-torque width
    interpolated across the free play (hysteresis.zero_torque_width between the two branches'
    samples nearest zero) is not the width along the unloading branches."""
    r, _ = run(0.0)
    last = r["cycles"][-1]
    T, th, lab = last["torque_Nm"], last["angle_rad"], last["labels"]
    fits = S.branch_fits(T, th, lab, T_R)
    assert abs(fits["pos_loading"]["K_Nm_per_arcmin"] / r["metrics"].rigidity.value - 1.0) > 1e-2
    interpolated = H.zero_torque_width(H.Cycle(torque=T, angle=th))
    assert interpolated < 0.5 * r["metrics"].hysteresis_loss.value   # pure backlash: the crossing misses the play


def test_rigidity_points_between_samples_and_outside():
    r, _ = run(5.0)
    last = r["cycles"][-1]
    T, th, lab = last["torque_Nm"], last["angle_rad"], last["labels"]
    # below the knee the loading branch is linear: b/a between two unsampled torques is k1 exactly
    rig = C.torsional_rigidity(T, th, lab, torque_points=(0.07 * T_R, 0.33 * T_R))
    assert rig.value == pytest.approx(K1, rel=TOL)
    with pytest.raises(RvtoolInputError, match="outside branch"):
        C.branch_angle(T, th, lab, "pos_loading", 0.001 * T_R)
    with pytest.raises(RvtoolInputError, match="not on branch"):
        C.branch_angle(T, th, lab, "pos_loading", -0.5 * T_R)
    with pytest.raises(RvtoolInputError, match="torque_points"):
        C.torsional_rigidity(T, th, lab, torque_points=(0.5 * T_R, 0.2 * T_R))
    with pytest.raises(RvtoolInputError, match="branch labels"):
        C.lost_motion(T, th, ["x"] * len(T), rated_torque=T_R)
    with pytest.raises(RvtoolInputError, match="finite"):
        C.hysteresis_loss(T, np.where(np.arange(len(th)) == 3, np.nan, th), lab)


def test_catalogue_sequence_never_samples_zero_and_holds_the_points():
    seq = C.catalogue_sequence(T_R, rigidity_points=(0.25, 1.0), step=0.25)
    fr, labels = seq.cycle()
    assert not np.any(fr == 0.0)
    up = fr[[l == "pos_loading" for l in labels]]
    np.testing.assert_allclose(up, [0.01, 0.02, 0.03, 0.25, 0.5, 0.75, 1.0])


def test_zero_torque_samples_are_not_used():
    """A sample at exactly zero torque lies in the free play: the unloading branch ignores it."""
    T = np.array([-2.0, -1.0, 1.0, 2.0, 1.0, 0.0, -1.0, -2.0])
    th = np.array([-3.0, -2.5, 1.5, 3.0, 2.5, 99.0, -1.5, -3.0])
    lab = ["neg_unloading", "neg_unloading", "pos_loading", "pos_loading", "pos_unloading", "pos_unloading",
           "neg_loading", "neg_loading"]
    # pos_unloading: reversal (2, 3.0) and (1, 2.5) -> 2.0 at zero; neg_unloading: (-2, -3), (-1, -2.5) -> -2.0
    assert C.hysteresis_loss(T, th, lab).value == pytest.approx(4.0, rel=1e-15)


def test_linear_reference_and_its_input_errors():
    """Without a knee the spring is linear: b/a = k1 on any points above T_c."""
    red = C.SpringCoulombBacklash(stiffness=K1, backlash=BETA, friction_torque=5.0)
    seq = C.catalogue_sequence(T_R, rigidity_points=(0.25, 1.0), step=0.25)
    r = C.catalogue_loops(red, seq, rigidity_points=(0.25, 1.0), repeat_tolerance=0.0)
    assert r["metrics"].rigidity.value == pytest.approx(K1, rel=TOL)
    for kw, name in (({"stiffness": -1.0}, "stiffness"), ({"backlash": float("nan")}, "backlash"),
                     ({"friction_torque": -2.0}, "friction_torque"), ({"knee_torque": 0.0}, "knee_torque")):
        args = {"stiffness": K1, "backlash": BETA, "friction_torque": 1.0, **kw}
        with pytest.raises(RvtoolInputError, match=name):
            C.SpringCoulombBacklash(**args)
