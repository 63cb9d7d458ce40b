"""The catalogue's own definitions of a precision reducer's torsional figures, on one hysteresis loop.

Source: Nabtesco, *Precision Reduction Gear RV(TM) E Series / C Series / Original Series* (English
catalogue; the edition and page of each design's figures are recorded in its
``rvtool/designs/<design>_catalogue.toml``), E series technical information, "Rigidity and lost
motion" with its "Hysteresis curve" figure. The catalogue's text (as reproduced e.g. at
chietom.net/News_info/id/641.html, "What is torsional rigidity"): "When a torque is applied to
the output shaft while the input shaft is fixed, torsion is generated according to the torque
value. The torsion can be shown in the hysteresis curves. The value of b/a is referred to as
'torsional rigidity'. The torsion angle at the mid points of the hysteresis curve width within
+-3 % of the rated torque is referred to as 'lost motion'. The torsion angle when the torque
indicated by the hysteresis curve is equal to zero is referred to as 'hysteresis loss'" (the
E-series catalogue's name for the zero-torque width; older editions say 'backlash').

A loop is three arrays of equal length in loading order: torque T_i [N m], output angle θ_i
[rad] (input fixed) and a branch label per sample, one of :data:`BRANCHES` (the labels of
:meth:`rvtool.protocols.hysteresis_cycles.CycleSequence.cycle`): ``neg_unloading`` (-T_R up to
0-), ``pos_loading`` (0+ up to +T_R), ``pos_unloading`` (+T_R down to 0+), ``neg_loading`` (0-
down to -T_R). The functions are pure:

* :func:`branch_angle` -- θ on one branch at a torque of that branch's sign: a sample, or the
  linear interpolation between two samples of the same branch; never across zero torque, where
  the free play leaves θ(T) undetermined;
* :func:`torsional_rigidity` -- b/a on the catalogue's own torque points (a = the angle between
  the curve's points at the two torques, b = their torque difference) per loading branch: a
  secant between two points of the curve, not a least-squares fit over a band;
* :func:`lost_motion` -- the angle between the mid-points of the loop's width at +fraction
  T_R and at -fraction T_R (fraction = 0.03 in the catalogue);
* :func:`hysteresis_loss` -- the loop's width at zero torque along the two unloading branches:
  each unloading branch is extrapolated to T = 0 from its own side (its samples nearest zero),
  never interpolated across the free play to the other branch; the clearance is included;
* :func:`catalogue_metrics` -- all three with their resolution errors.

The free play is resolved by the protocol (:func:`catalogue_loops`): no level at zero torque
(there the clearances are free play and the angle is a numerical artefact), a virgin preload to
the first reversal point -T_R, and identical cycles after it; a rate-independent loop (Masing)
then repeats from the first cycle on, which :func:`catalogue_loops` checks against a declared
tolerance. The protocol drives any *loading path*: an object with ``go_to(torque) -> output angle
[rad]`` that keeps its own history (:class:`ContinuationPath` for a
:class:`~rvtool.model.ReducerModel`; :class:`SpringCoulombBacklash` for the closed-form reference
of the tests and of ``docs/protocols/catalogue_definitions.md``).
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_positive, check_range
from ..solver.torque_path import ContinuationPath  # noqa: F401  (the Exudyn loading path, re-exported)
from . import hysteresis as H

BRANCHES = ("neg_unloading", "pos_loading", "pos_unloading", "neg_loading")
"""Branch labels of one cycle in loading order (as :class:`CycleSequence`)."""

BRANCH_SIGN = {"neg_unloading": -1.0, "pos_loading": 1.0, "pos_unloading": 1.0, "neg_loading": -1.0}
"""Sign of the torque on each branch."""

LOST_MOTION_FRACTION = 0.03
"""The catalogue's lost-motion torque, +-3 % of the rated torque T_R (module docstring)."""


def _loop(torque, angle, labels):
    T = np.asarray(torque, np.float64)
    th = np.asarray(angle, np.float64)
    if T.ndim != 1 or th.shape != T.shape or len(labels) != T.size:
        raise RvtoolInputError(f"torque, angle and labels must be 1-D of one length; got shapes {T.shape}, "
                               f"{th.shape} and {len(labels)} labels")
    for name, a in (("torque", T), ("angle", th)):
        if not np.all(np.isfinite(a)):
            raise RvtoolInputError(f"{name} must be finite (valid range: finite real numbers); non-finite at samples "
                                   f"{np.flatnonzero(~np.isfinite(a))[:4].tolist()}")
    bad = sorted({l for l in labels if l not in BRANCHES})
    if bad:
        raise RvtoolInputError(f"branch labels {bad} are not valid (valid: {list(BRANCHES)})")
    return T, th, list(labels)


def branch_samples(torque, angle, labels, branch):
    """(T, θ) of one branch, the samples of that sign only (a zero-torque sample is dropped: the free
    play leaves it undetermined), with the reversal point that starts an unloading branch (the
    peak sample before it in the loop, cyclically): sorted by |T|."""
    T, th, labels = _loop(torque, angle, labels)
    if branch not in BRANCHES:
        raise RvtoolInputError(f"branch = {branch!r} is not valid (valid: {list(BRANCHES)})")
    idx = [i for i, l in enumerate(labels) if l == branch]
    if not idx:
        raise RvtoolInputError(f"the loop has no sample on branch {branch!r}")
    if branch.endswith("_unloading"):
        idx = [(idx[0] - 1) % T.size] + idx
    s = BRANCH_SIGN[branch]
    idx = [i for i in idx if s * T[i] > 0.0]
    order = np.argsort(np.abs(T[idx]), kind="stable")
    Tb, thb = T[idx][order], th[idx][order]
    keep = np.concatenate([[True], np.diff(np.abs(Tb)) > 0.0])      # a reversal point listed twice
    return Tb[keep], thb[keep]


def branch_angle(torque, angle, labels, branch, level):
    """θ [rad] on ``branch`` at torque ``level`` [N m] (the branch's sign): the sample at that level,
    else the linear interpolation between the two samples of the branch that bracket it. Raises
    where the branch does not bracket the level (no extrapolation, no crossing of zero torque)."""
    Tb, thb = branch_samples(torque, angle, labels, branch)
    level = float(level)
    if BRANCH_SIGN[branch] * level <= 0.0:
        raise RvtoolInputError(f"level = {level:g} N m is not on branch {branch!r} (valid: torques of sign "
                               f"{BRANCH_SIGN[branch]:+g}, nonzero)")
    a = np.abs(Tb)
    x = abs(level)
    hit = np.flatnonzero(np.isclose(a, x, rtol=1e-12, atol=0.0))
    if hit.size:
        return float(thb[hit[0]])
    if x < a[0] or x > a[-1]:
        raise RvtoolInputError(f"level = {level:g} N m lies outside branch {branch!r}'s samples "
                               f"[{BRANCH_SIGN[branch] * a[0]:g}, {BRANCH_SIGN[branch] * a[-1]:g}] N m "
                               "(valid: a level the protocol samples, or between two of its samples)")
    return float(np.interp(x, a, thb))


@dataclass(frozen=True)
class Rigidity:
    """Torsional rigidity b/a [N m/rad]: ``value`` the mean over ``per_branch`` {branch: b/a}, at
    the torque points ``torque_points`` [N m] (magnitudes; negative on the negative branch)."""
    value: float
    per_branch: dict
    torque_points: tuple


def torsional_rigidity(torque, angle, labels, *, torque_points, branches=("pos_loading", "neg_loading")):
    """The catalogue's b/a [N m/rad] (module docstring): on each of ``branches`` the torque
    difference b = T_2 - T_1 of the two ``torque_points`` (magnitudes [N m], 0 < T_1 < T_2; taken
    with the branch's sign) over the angle difference a = θ(T_2) - θ(T_1) on that branch."""
    t1, t2 = (float(t) for t in torque_points)
    check_positive("torque_points[0]", t1)
    check_range("torque_points[1]", t2, t1, low_open=True)
    per = {}
    for b in branches:
        s = BRANCH_SIGN.get(b)
        if s is None:
            raise RvtoolInputError(f"branch = {b!r} is not valid (valid: {list(BRANCHES)})")
        a = branch_angle(torque, angle, labels, b, s * t2) - branch_angle(torque, angle, labels, b, s * t1)
        if s * a <= 0.0:
            raise RvtoolInputError(f"branch {b!r}: the angle does not grow with the torque between {t1:g} and "
                                   f"{t2:g} N m (a = {a:.3e} rad); no rigidity")
        per[b] = float(s * (t2 - t1) / a)
    return Rigidity(float(np.mean(list(per.values()))), per, (t1, t2))


def lost_motion(torque, angle, labels, *, rated_torque, fraction=LOST_MOTION_FRACTION):
    """The catalogue's lost motion [rad]: mid(+t) - mid(-t) with t = fraction T_R and mid(±t) the
    mid-point of the loop's width at ±t, (θ_loading(±t) + θ_unloading(±t)) / 2 on the branches of
    that sign."""
    check_positive("rated_torque", rated_torque)
    check_range("fraction", fraction, 0.0, 1.0, low_open=True)
    t = fraction * rated_torque
    mids = {}
    for s, load, unload in ((1.0, "pos_loading", "pos_unloading"), (-1.0, "neg_loading", "neg_unloading")):
        mids[s] = 0.5 * (branch_angle(torque, angle, labels, load, s * t) +
                         branch_angle(torque, angle, labels, unload, s * t))
    return float(mids[1.0] - mids[-1.0])


def unloading_zero_angle(torque, angle, labels, branch, *, points=2):
    """θ [rad] of an unloading ``branch`` at T -> 0 from its own side: the polynomial of degree
    points - 1 through its ``points`` samples nearest zero torque, evaluated at T = 0 (an
    extrapolation along the branch; the other branch is never used)."""
    if not branch.endswith("_unloading"):
        raise RvtoolInputError(f"branch = {branch!r}: the hysteresis loss is read on the unloading branches "
                               "(valid: 'pos_unloading', 'neg_unloading')")
    if not isinstance(points, (int, np.integer)) or points < 2:
        raise RvtoolInputError(f"points = {points!r} is outside the valid range [2, inf) (an integer)")
    Tb, thb = branch_samples(torque, angle, labels, branch)
    if Tb.size < points:
        raise RvtoolInputError(f"branch {branch!r} has {Tb.size} samples of its sign; the extrapolation to zero "
                               f"torque needs {points}")
    T, th = Tb[:points], thb[:points]
    # Lagrange polynomial at T = 0
    val = 0.0
    for j in range(points):
        w = 1.0
        for m in range(points):
            if m != j:
                w *= (0.0 - T[m]) / (T[j] - T[m])
        val += w * th[j]
    return float(val)


@dataclass(frozen=True)
class HysteresisLoss:
    """Hysteresis loss [rad]: the zero-torque width θ_pos_unloading(0+) - θ_neg_unloading(0-) by
    linear extrapolation of each unloading branch from its two samples nearest zero (``value``),
    and ``error``: its difference to the quadratic extrapolation from three samples (the
    extrapolation's resolution error; None where a branch has only two samples)."""
    value: float
    error: float | None
    zero_angles: tuple


def hysteresis_loss(torque, angle, labels):
    """:class:`HysteresisLoss` of the loop (module docstring)."""
    up = unloading_zero_angle(torque, angle, labels, "pos_unloading", points=2)
    dn = unloading_zero_angle(torque, angle, labels, "neg_unloading", points=2)
    err = None
    try:
        up3 = unloading_zero_angle(torque, angle, labels, "pos_unloading", points=3)
        dn3 = unloading_zero_angle(torque, angle, labels, "neg_unloading", points=3)
        err = float(abs((up3 - dn3) - (up - dn)))
    except RvtoolInputError:
        pass
    return HysteresisLoss(float(up - dn), err, (up, dn))


@dataclass(frozen=True)
class CatalogueMetrics:
    """The catalogue's figures of one loop: rigidity b/a [N m/rad] (:class:`Rigidity`), lost motion
    [rad] and hysteresis loss [rad] (:class:`HysteresisLoss`)."""
    rigidity: Rigidity
    lost_motion: float
    hysteresis_loss: HysteresisLoss


def catalogue_metrics(torque, angle, labels, *, rated_torque, rigidity_points,
                      lost_motion_fraction=LOST_MOTION_FRACTION):
    """:class:`CatalogueMetrics` of one loop; ``rigidity_points`` are fractions of T_R (the
    catalogue's own points of b/a), ``lost_motion_fraction`` the catalogue's ±fraction of T_R."""
    check_positive("rated_torque", rated_torque)
    pts = tuple(float(f) * rated_torque for f in rigidity_points)
    if len(pts) != 2:
        raise RvtoolInputError(f"rigidity_points must be two fractions of the rated torque; got {rigidity_points!r}")
    return CatalogueMetrics(torsional_rigidity(torque, angle, labels, torque_points=pts),
                            lost_motion(torque, angle, labels, rated_torque=rated_torque,
                                        fraction=lost_motion_fraction),
                            hysteresis_loss(torque, angle, labels))


# -- the protocol ----------------------------------------------------------------------------------

def catalogue_sequence(rated_torque, *, rigidity_points, lost_motion_fraction=LOST_MOTION_FRACTION, step=0.0625,
                       n_cycles=2):
    """The :class:`CycleSequence` of the catalogue loop: levels every ``step`` of T_R plus the
    catalogue's rigidity points and ±lost-motion level, and 1/3 and 2/3 of the lost-motion level
    (the unloading branches' samples nearest zero, from which the zero-torque width is
    extrapolated); never a level at zero torque."""
    from .hysteresis_cycles import CycleSequence
    f = lost_motion_fraction
    fine = sorted({round(x, 12) for x in (f / 3.0, 2.0 * f / 3.0, f, *rigidity_points) if 0.0 < x < 1.0})
    return CycleSequence(rated_torque=rated_torque, step=step, fine_levels=tuple(fine), n_cycles=n_cycles)


class SpringCoulombBacklash:
    """The closed-form reference reducer: output angle θ [rad] against the grounded input through a
    free play ±``backlash`` [rad] in series with a bilinear torsional spring (``stiffness`` k_1 [N
    m/rad] up to the ``knee_torque`` T_k [N m], ``stiffness_2`` k_2 beyond), with a Coulomb
    friction torque ``friction_torque`` T_c [N m] in parallel. Quasi-static under a commanded
    torque T: θ stays while |T - F(θ)| <= T_c (stick), else slides to F(θ) = T -+ T_c in the
    direction of the excess (F the spring-backlash torque); in the free play F = 0 and the slide
    crosses it at T = ±T_c. A loading path (``go_to(torque) -> θ``) for :func:`catalogue_loops`."""

    def __init__(self, *, stiffness, backlash, friction_torque, knee_torque=None, stiffness_2=None):
        check_positive("stiffness", stiffness)
        check_nonnegative("backlash", backlash)
        check_nonnegative("friction_torque", friction_torque)
        if knee_torque is not None:       # None: a linear spring (no knee)
            check_positive("knee_torque", knee_torque)
        if stiffness_2 is not None:
            check_positive("stiffness_2", stiffness_2)
        self.k1, self.beta, self.tc = float(stiffness), float(backlash), float(friction_torque)
        self.tk = np.inf if knee_torque is None else float(knee_torque)
        self.k2 = self.k1 if stiffness_2 is None else float(stiffness_2)
        self.theta = 0.0

    def _spring(self, d):            # torque of the bilinear spring at deflection d >= 0
        dk = self.tk / self.k1
        return self.k1 * d if d <= dk else self.tk + self.k2 * (d - dk)

    def _spring_inv(self, y):        # deflection at spring torque y >= 0
        return y / self.k1 if y <= self.tk else self.tk / self.k1 + (y - self.tk) / self.k2

    def torque_of(self, theta):
        """F(θ) [N m]: the spring-backlash torque."""
        if theta > self.beta:
            return self._spring(theta - self.beta)
        if theta < -self.beta:
            return -self._spring(-theta - self.beta)
        return 0.0

    def _angle_of(self, y, theta):   # the angle with F = y nearest theta
        if y > 0.0:
            return self.beta + self._spring_inv(y)
        if y < 0.0:
            return -self.beta - self._spring_inv(-y)
        return min(max(theta, -self.beta), self.beta)

    def go_to(self, torque):
        excess = float(torque) - self.torque_of(self.theta)
        if excess > self.tc:
            self.theta = self._angle_of(float(torque) - self.tc, self.theta)
        elif excess < -self.tc:
            self.theta = self._angle_of(float(torque) + self.tc, self.theta)
        return self.theta

    def stats(self):
        return {}


def _levels(sequence):
    """(torques [N m] of the protocol without the preload's zero level, the number of preload levels):
    the virgin preload starts loaded at its first nonzero level (zero torque is free play)."""
    torques, _ = sequence.levels()
    pre = sequence.preload()
    keep = np.ones(len(torques), bool)
    keep[:len(pre)] = pre != 0.0
    return torques[keep], int(np.count_nonzero(pre != 0.0))


def catalogue_loop(path, sequence, *, rigidity_points, lost_motion_fraction=LOST_MOTION_FRACTION):
    """The preload and the FIRST cycle of ``sequence`` only, and the catalogue's figures on it: the
    cheap form for many variants of a design whose loops are known to repeat from the first cycle
    (Masing; :func:`catalogue_loops` checks it on the central design). Returns the dict of
    :func:`catalogue_loops` with one cycle and ``repeatability`` None."""
    torques, n_pre = _levels(sequence)
    fr, labels = sequence.cycle()
    angles = np.array([path.go_to(float(t)) for t in torques[:n_pre + len(fr)]])
    cyc = {"torque_Nm": fr * sequence.rated_torque, "angle_rad": angles[n_pre:], "labels": labels}
    met = catalogue_metrics(cyc["torque_Nm"], cyc["angle_rad"], labels, rated_torque=sequence.rated_torque,
                            rigidity_points=rigidity_points, lost_motion_fraction=lost_motion_fraction)
    return {"cycles": [cyc], "metrics": met, "repeatability": None, "preload": angles[:n_pre],
            "stats": path.stats()}


def catalogue_loops(path, sequence, *, rigidity_points, lost_motion_fraction=LOST_MOTION_FRACTION,
                    repeat_tolerance):
    """Run ``sequence`` (:func:`catalogue_sequence`) on a loading ``path`` and read the catalogue's
    figures on its last cycle. repeat_tolerance [rad]: declared bound on the largest angle
    difference between the last two cycles at equal torque (the free play is resolved when the
    loops repeat). Returns a dict: ``cycles`` (per cycle torque [N m], angle [rad], labels),
    ``metrics`` (:class:`CatalogueMetrics` of the last cycle), ``repeatability``
    (:class:`rvtool.protocols.hysteresis.Repeatability`), ``preload`` angles [rad], ``stats``."""
    check_nonnegative("repeat_tolerance", repeat_tolerance)
    torques, n_pre = _levels(sequence)
    angles = np.array([path.go_to(float(t)) for t in torques])
    fr, labels = sequence.cycle()
    cyc_T = fr * sequence.rated_torque
    n_cyc = len(fr)
    cycles = [{"torque_Nm": cyc_T, "angle_rad": angles[n_pre + c * n_cyc:n_pre + (c + 1) * n_cyc], "labels": labels}
              for c in range(sequence.n_cycles)]
    rep = H.repeatability(H.Cycle(torque=cyc_T, angle=cycles[-2]["angle_rad"]),
                          H.Cycle(torque=cyc_T, angle=cycles[-1]["angle_rad"]), tolerance=repeat_tolerance)
    last = cycles[-1]
    met = catalogue_metrics(last["torque_Nm"], last["angle_rad"], labels, rated_torque=sequence.rated_torque,
                            rigidity_points=rigidity_points, lost_motion_fraction=lost_motion_fraction)
    return {"cycles": cycles, "metrics": met, "repeatability": rep, "preload": angles[:n_pre],
            "stats": path.stats()}
