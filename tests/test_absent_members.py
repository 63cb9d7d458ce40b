"""The closed forms of cases/rv/absent_members.py (the needle misalignment estimate): Palmgren's law in slices along
a roller against its unsliced form and against quadrature, and the sign that convexity fixes. No model is built."""
import math

import pytest

from rvtool import casekit

am = casekit.import_case("rv/absent_members")
L = 0.010
C = am.palmgren_c(L)


def test_palmgren_constant():
    # delta = 2 x 3.84e-5 Q^0.9 / l^0.8 [mm, N] over both raceways (Palmgren): 800 N on a 10 mm roller
    assert C * 800.0 ** 0.9 == pytest.approx(2 * 3.84e-5 * 800.0 ** 0.9 / 10.0 ** 0.8 * 1e-3, rel=1e-14)


@pytest.mark.parametrize("Q", [1.0, 250.0, 800.0])
def test_zero_tilt_is_the_unsliced_law(Q):
    assert am.slice_load(C * Q ** 0.9, 0.0, L, C) == pytest.approx(Q, rel=1e-13)
    assert am.tilted_approach(Q, 0.0, L, C) == C * Q ** 0.9


@pytest.mark.parametrize("edge_over_approach", [0.1, 0.9, 2.0, 8.0])
def test_slices_against_quadrature(edge_over_approach):
    # full contact (< 1) and partial contact (> 1: one end of the roller lifts off)
    d0 = C * 500.0 ** 0.9
    g = 2 * edge_over_approach * d0 / L
    for gamma in (g, -g):
        ref = am.slice_quadrature(d0, gamma, L, C)
        assert am.slice_load(d0, gamma, L, C) == pytest.approx(ref, rel=1e-10)


@pytest.mark.parametrize("edge_over_approach", [0.05, 0.5, 1.5, 6.0])
def test_misaligned_roller_carries_its_load_at_no_larger_approach(edge_over_approach):
    # q ~ delta^(10/9) is convex: a linear approach profile carries at least the load of its mean (Jensen), so the
    # mid-plane approach that carries Q under a misalignment never exceeds the aligned one; a wrong exponent or a
    # lost lift-off branch fails here
    Q = 600.0
    flat = C * Q ** 0.9
    gamma = 2 * edge_over_approach * flat / L
    d0 = am.tilted_approach(Q, gamma, L, C)
    assert am.slice_load(d0, gamma, L, C) == pytest.approx(Q, rel=1e-10)
    assert d0 <= flat
    if edge_over_approach > 1.0:
        assert d0 < flat * (1 - 1e-3)         # lift-off: markedly smaller


def test_linear_limit_closed_form():
    # exponent 10/9 -> a check on the partial-contact branch by its own closed form: with d0 = 0 exactly half the
    # roller is loaded, Q = (g l / 2)^(p+1) / ((p + 1) g l c^p)
    g = 1e-4
    p = am.PALMGREN_P
    expect = (g * L / 2) ** (p + 1) / ((p + 1) * g * L * C ** p)
    assert am.slice_load(0.0, g, L, C) == pytest.approx(expect, rel=1e-14)
    assert not math.isnan(am.slice_load(-g * L, g, L, C)) and am.slice_load(-g * L, g, L, C) == 0.0
