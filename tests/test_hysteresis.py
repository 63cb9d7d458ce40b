"""Hysteresis building blocks (rvtool.protocols.hysteresis) on a synthetic Jenkins loop.

Reference (closed form): a spring k in series with a Coulomb slider F_c, driven
between ±x_a > F_c/k, follows the Masing branches F = clip(±F_c + k (x ∓ x_a), -F_c, F_c);
its loop encloses A = 4 F_c (x_a - F_c/k) and crosses F = 0 at x = ±(x_a - F_c/k),
so the width at zero force is 2 (x_a - F_c/k).
"""
import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.protocols.hysteresis import (Cycle, closure_gap, cycle_dissipation, jenkins_branch, loop_integral,
                                         repeatability, zero_torque_crossings, zero_torque_width)

K, FC, XA = 2e5, 40.0, 1e-3
AREA = 4 * FC * (XA - FC / K)
WIDTH = 2 * (XA - FC / K)
# the trapezoidal loop integral and the linear interpolation of the crossings are exact on
# straight branches; what remains is round-off of sums of ~1e2 terms of size F_c x_a
EXACT_RTOL = 1e-12


def _loop(x):
    """One cycle +peak -> -peak -> +peak through drive samples x (descending then ascending)."""
    half = len(x)
    down = jenkins_branch(x, stiffness=K, slip_force=FC, x_reversal=XA, f_reversal=FC)
    up = jenkins_branch(x[::-1], stiffness=K, slip_force=FC, x_reversal=-XA, f_reversal=-FC)
    return Cycle(torque=np.concatenate([down, up[1:half - 1]]), angle=np.concatenate([x, x[::-1][1:half - 1]]))


def _with_corners(n=50):
    """Drive samples from +x_a to -x_a that contain the branch corners x_a - 2 F_c/k."""
    corner = XA - 2 * FC / K
    return np.unique(np.concatenate([np.linspace(XA, -XA, n), [corner, -corner]]))[::-1]


def test_loop_integral_and_width_are_exact_with_corners_sampled():
    c = _loop(_with_corners())
    assert loop_integral(c) == pytest.approx(AREA, rel=EXACT_RTOL)
    assert zero_torque_width(c) == pytest.approx(WIDTH, rel=EXACT_RTOL)
    angles, dirs = zero_torque_crossings(c)
    assert sorted(dirs.tolist()) == [-1, 1]
    assert angles[dirs == -1][0] == pytest.approx(XA - FC / K, rel=EXACT_RTOL)


def test_loop_integral_without_corners_within_the_cut_corner_bound():
    # Sampling a sinusoidal drive misses the two corners; each cut triangle is at most
    # k dx^2 / 8 for a sample spacing dx, so |error| <= k dx^2 / 4 over the loop.
    n = 401
    x = XA * np.cos(np.linspace(0, np.pi, n))
    c = _loop(x)
    dx = np.abs(np.diff(x)).max()
    err = abs(loop_integral(c) - AREA)
    assert 0 < err <= K * dx ** 2 / 4


def test_repeatability_closure_and_dissipation_of_a_repeating_cycle():
    x = _with_corners()
    first, second = _loop(x), _loop(x)
    rep = repeatability(first, second, tolerance=1e-9)
    assert rep.passed and rep.max_angle_diff == 0.0
    # close the cycle explicitly (last sample = first) for the closure check
    closed = Cycle(torque=np.append(second.torque, second.torque[0]), angle=np.append(second.angle, second.angle[0]))
    prev = Cycle(torque=np.append(first.torque, first.torque[0]), angle=np.append(first.angle, first.angle[0]))
    assert closure_gap(closed) == (0.0, 0.0)
    d = cycle_dissipation(prev, closed, angle_tolerance=1e-9, torque_tolerance=1e-9)
    assert d.loop_integral == pytest.approx(AREA, rel=EXACT_RTOL)
    assert d.hysteresis_width == pytest.approx(WIDTH, rel=EXACT_RTOL)


def test_non_repeating_or_open_cycles_are_no_dissipation():
    x = _with_corners()
    first = _loop(x)
    drifted = Cycle(torque=first.torque, angle=first.angle + np.linspace(0, 3e-9, first.angle.size))
    assert not repeatability(first, drifted, tolerance=1e-9).passed
    with pytest.raises(RvtoolInputError, match="not closed"):
        cycle_dissipation(first, drifted, angle_tolerance=1e-12, torque_tolerance=1e-9)
    closed = Cycle(torque=np.append(first.torque, first.torque[0]), angle=np.append(first.angle, first.angle[0]))
    shifted = Cycle(torque=closed.torque, angle=closed.angle + 1e-6)
    with pytest.raises(RvtoolInputError, match="does not repeat"):
        cycle_dissipation(closed, shifted, angle_tolerance=1e-9, torque_tolerance=1e-9)


@pytest.mark.parametrize("kwargs, name", [
    (dict(torque=[0.0, np.nan, 1.0], angle=[0.0, 1.0, 2.0]), "torque"),
    (dict(torque=[0.0, 1.0, -1.0], angle=[0.0, np.inf, 2.0]), "angle"),
    (dict(torque=[0.0, 1.0], angle=[0.0, 1.0]), "torque"),
    (dict(torque=[0.0, 1.0, 2.0], angle=[0.0, 1.0]), "angle"),
])
def test_bad_cycles_raise_naming_the_parameter(kwargs, name):
    with pytest.raises(RvtoolInputError, match=name):
        Cycle(**kwargs)


def test_ambiguous_inputs_raise():
    with pytest.raises(RvtoolInputError, match="crosses zero torque 0 times"):
        zero_torque_width(Cycle(torque=[1.0, 2.0, 3.0], angle=[0.0, 1.0, 2.0]))
    with pytest.raises(RvtoolInputError, match="f_reversal"):
        jenkins_branch(0.0, stiffness=K, slip_force=FC, f_reversal=2 * FC)
    with pytest.raises(RvtoolInputError, match="slip_force"):
        jenkins_branch(0.0, stiffness=K, slip_force=np.nan)
    with pytest.raises(RvtoolInputError, match="tolerance"):
        repeatability(_loop(_with_corners()), _loop(_with_corners()), tolerance=-1.0)
