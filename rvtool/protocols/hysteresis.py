"""Hysteresis measures of a signed loading cycle, on (torque, angle) sequences.

Topology-neutral building blocks of the hysteresis protocol (paper, Section
"Observation": "∮T dθ is interpreted as cycle dissipation only after closure
and repeatability have been established"):

* :class:`Cycle`: one signed loading cycle as sampled (torque T_i [N m],
  angle θ_i [rad]; any generalized force/coordinate pair works alike, e.g.
  force [N] and displacement [m]);
* :func:`closure_gap`: how far a cycle ends from where it started;
* :func:`repeatability`: the largest angle difference between two cycles of
  the same torque sequence, against a declared tolerance;
* :func:`loop_integral`: ∮T dθ over the closed cycle (trapezoidal rule on the
  samples; exact for piecewise-linear branches sampled at their corners);
* :func:`zero_torque_width`: the hysteresis loss, the width of the loop at
  zero torque (the angle between the descending and the ascending crossing);
* :func:`cycle_dissipation`: ∮T dθ, returned only for a closed cycle that
  repeats its predecessor within the declared tolerances;
* :func:`jenkins_branch`: the closed-form branches of a Jenkins element (a
  spring in series with a Coulomb slider), the reference of the tests and
  of ``cases/verification/verify_jenkins.py``.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_positive


@dataclass(frozen=True, kw_only=True, eq=False)
class Cycle:
    """One signed loading cycle.

    torque: T_i [N m] (or a force [N]), shape (N,), N >= 3, finite.
    angle: θ_i [rad] (or a displacement [m]), shape (N,), finite.
    The samples are in loading order; the cycle is closed from the last
    sample back to the first.
    """
    torque: np.ndarray
    angle: np.ndarray

    def __post_init__(self):
        T = np.asarray(self.torque, np.float64)
        th = np.asarray(self.angle, np.float64)
        if T.ndim != 1 or T.shape[0] < 3:
            raise RvtoolInputError(f"torque must be a 1-D sequence of at least 3 samples; got shape {T.shape}")
        if th.shape != T.shape:
            raise RvtoolInputError(f"angle must have the shape of torque {T.shape}; got {th.shape}")
        for name, a in (("torque", T), ("angle", th)):
            bad = ~np.isfinite(a)
            if bad.any():
                raise RvtoolInputError(f"{name} must be finite (valid range: finite real numbers); non-finite at "
                                       f"samples {np.flatnonzero(bad)[:4].tolist()}")
        object.__setattr__(self, "torque", T)
        object.__setattr__(self, "angle", th)


def closure_gap(cycle: Cycle):
    """(|θ_last - θ_first| [rad], |T_last - T_first| [N m]): the open end of the cycle."""
    return abs(cycle.angle[-1] - cycle.angle[0]), abs(cycle.torque[-1] - cycle.torque[0])


@dataclass(frozen=True)
class Repeatability:
    """Largest angle difference [rad] between two cycles at equal torque samples, the declared
    tolerance [rad], and whether it holds."""
    max_angle_diff: float
    tolerance: float
    passed: bool


def repeatability(first: Cycle, second: Cycle, *, tolerance, torque_rtol=1e-9):
    """Compare two cycles of the same signed torque sequence sample by sample.

    tolerance: the declared bound on max |θ_2 - θ_1| [rad], >= 0.
    torque_rtol: relative tolerance [-] within which the two torque sequences
    must agree (they are the same protocol levels).
    """
    check_nonnegative("tolerance", tolerance)
    check_nonnegative("torque_rtol", torque_rtol)
    if first.torque.shape != second.torque.shape:
        raise RvtoolInputError(f"second has {second.torque.size} samples, first {first.torque.size}; cycles of "
                               "one torque sequence have equal sample counts")
    scale = max(np.abs(first.torque).max(), 1e-300)
    off = np.abs(second.torque - first.torque) > torque_rtol * scale
    if off.any():
        raise RvtoolInputError(f"second.torque differs from first.torque at samples {np.flatnonzero(off)[:4].tolist()} "
                               f"(valid: equal within torque_rtol = {torque_rtol} of max |T|)")
    diff = float(np.abs(second.angle - first.angle).max())
    return Repeatability(diff, float(tolerance), diff <= tolerance)


def loop_integral(cycle: Cycle):
    """∮T dθ [J] over the closed cycle: trapezoidal sum over consecutive samples and the
    closing segment (last -> first). Positive for a loop that dissipates (the
    torque does net work on the angle)."""
    T = np.append(cycle.torque, cycle.torque[0])
    th = np.append(cycle.angle, cycle.angle[0])
    return float(np.sum(0.5 * (T[1:] + T[:-1]) * np.diff(th)))


def zero_torque_crossings(cycle: Cycle):
    """Angles [rad] and directions (+1 ascending, -1 descending torque) of the closed cycle's zero-torque crossings.

    A crossing inside a segment is interpolated linearly; a sample at exactly
    zero torque is a crossing where its neighbours have opposite signs. A
    repeated closing sample (last = first) is dropped.
    """
    T, th = cycle.torque, cycle.angle
    if T.size > 3 and T[-1] == T[0] and th[-1] == th[0]:
        T, th = T[:-1], th[:-1]
    n = T.size
    angles, dirs = [], []
    for i in range(n):
        a, b = T[i], T[(i + 1) % n]
        if a == 0.0:
            prev = T[(i - 1) % n]
            if prev * b < 0:
                angles.append(th[i])
                dirs.append(1 if b > 0 else -1)
            elif prev == 0.0 or b == 0.0:
                raise RvtoolInputError(f"torque is zero at consecutive samples around {i}; the zero-torque "
                                       "crossing of the loop is then not a point (valid: isolated zero samples)")
        elif a * b < 0:
            s = a / (a - b)
            angles.append(th[i] + s * (th[(i + 1) % n] - th[i]))
            dirs.append(1 if b > a else -1)
    return np.array(angles), np.array(dirs, int)


def zero_torque_width(cycle: Cycle):
    """Hysteresis loss [rad]: the angle between the descending and the ascending zero-torque
    crossing of the loop. A signed cycle crosses zero torque exactly twice."""
    angles, dirs = zero_torque_crossings(cycle)
    if angles.size != 2 or set(dirs.tolist()) != {1, -1}:
        raise RvtoolInputError(f"cycle crosses zero torque {angles.size} times with directions {dirs.tolist()}; a "
                               "signed loading cycle crosses it twice, once descending and once ascending")
    return float(abs(angles[dirs == -1][0] - angles[dirs == 1][0]))


@dataclass(frozen=True)
class CycleDissipation:
    """∮T dθ [J] of a closed, repeating cycle with the checks that admit it."""
    loop_integral: float
    closure_angle: float
    closure_torque: float
    repeatability: Repeatability
    hysteresis_width: float


def cycle_dissipation(previous: Cycle, cycle: Cycle, *, angle_tolerance, torque_tolerance):
    """∮T dθ of ``cycle`` as a cycle dissipation, with the checks that make it one.

    angle_tolerance [rad]: bound on the closure gap in angle and on the
    repeatability against ``previous`` (same torque sequence).
    torque_tolerance [N m]: bound on the closure gap in torque.
    Raises :class:`RvtoolInputError` (naming the failed check and its value)
    when the cycle is open or does not repeat: its area is then no dissipation.
    """
    check_positive("angle_tolerance", angle_tolerance)
    check_positive("torque_tolerance", torque_tolerance)
    gap_angle, gap_torque = closure_gap(cycle)
    if gap_angle > angle_tolerance or gap_torque > torque_tolerance:
        raise RvtoolInputError(f"cycle is not closed: end-to-start gap {gap_angle:.3e} rad, {gap_torque:.3e} N m "
                               f"(valid: <= angle_tolerance = {angle_tolerance}, torque_tolerance = {torque_tolerance})")
    rep = repeatability(previous, cycle, tolerance=angle_tolerance)
    if not rep.passed:
        raise RvtoolInputError(f"cycle does not repeat its predecessor: max angle difference {rep.max_angle_diff:.3e} "
                               f"rad (valid: <= angle_tolerance = {angle_tolerance})")
    return CycleDissipation(loop_integral(cycle), gap_angle, gap_torque, rep, zero_torque_width(cycle))


def jenkins_branch(x, *, stiffness, slip_force, x_reversal=0.0, f_reversal=0.0):
    """Closed-form force [N] of a Jenkins element (spring of ``stiffness`` k [N/m] in series
    with a Coulomb slider of ``slip_force`` F_c [N]) on the branch that starts at the
    reversal point (``x_reversal`` [m], ``f_reversal`` [N]):

        F(x) = clip(F_r + k (x - x_r), -F_c, F_c)         (Masing branch)

    The virgin branch is x_r = F_r = 0. For a drive cycling between ±x_a > F_c/k the
    reversal points are (±x_a, ±F_c) and the loop encloses 4 F_c (x_a - F_c/k).
    """
    check_positive("stiffness", stiffness)
    check_nonnegative("slip_force", slip_force)
    if abs(f_reversal) > slip_force:
        raise RvtoolInputError(f"f_reversal = {f_reversal} is outside the valid range [-{slip_force}, {slip_force}] N "
                               "(the slider carries at most the slip force)")
    x = np.asarray(x, np.float64)
    return np.clip(f_reversal + stiffness * (x - x_reversal), -slip_force, slip_force)
