"""Fatigue: Eq. (obs_damage) at constant load in closed form, the mean-load
underestimate, constant-amplitude Miner with rainflow counting, and the ISO
281 rating life of a catalogue-like ball bearing (6205) and roller bearing,
computed by hand in the comments.
"""
import math

import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.slow.exposure import WindowExposure
from rvtool.slow.fatigue import (ForceLifeLaw, RatingGeometry, SNCurve, mean_equivalent_load, mean_load_underestimate,
                                 miner_damage, radial_load_from_elements, rating_life)

HAND = 1e-5    # hand values below carry 6-7 significant digits


def test_force_life_damage_at_constant_load():
    # N(F) = N_ref (F_ref / F)^m; constant F: I_m / tau_w = F^m, so Eq. (obs_damage) gives
    # Delta D = nu Delta tau F^m / (N_ref F_ref^m) = (cycles in Delta tau) / N(F)
    law = ForceLifeLaw(reference_life=1e7, reference_force=2000.0, exponent=10 / 3)
    F, tau_w, nu, service = 1500.0, 0.04, 25.0, 1000 * 3600.0
    x = WindowExposure(ids=("pins/0",), tau_w=tau_w, m=10 / 3, I_s=[0.0], I_m=[F ** (10 / 3) * tau_w],
                       I_F=[F * tau_w], F_pk=[F], position=np.zeros((1, 3)))
    D = law.damage_increment(x, nu, service)[0]
    assert D == pytest.approx(nu * service / law.life(F), rel=1e-13)
    # by hand: N(1500 N) = 1e7 (4/3)^(10/3) = 1e7 exp(3.333333 * 0.2876821) = 2.608930e7 cycles;
    # 25 /s * 3.6e6 s = 9e7 cycles -> D = 9e7 / 2.608930e7 = 3.449690
    assert D == pytest.approx(3.449690, rel=HAND)
    with pytest.raises(RvtoolInputError, match="exposure.m = 3.0 differs"):
        law.damage_rate(WindowExposure(ids=("a",), tau_w=1, m=3, I_s=[0], I_m=[1], I_F=[1], F_pk=[1],
                                       position=np.zeros((1, 3))), 1.0)


def test_mean_load_underestimate():
    assert mean_load_underestimate(5.0, 125.0, 1.0, 3.0) == pytest.approx(1.0, rel=1e-15)   # constant 5 N
    # two levels 1 N and 3 N, half the window each (tau_w = 2 s): I_F = 4, I_m = 1 + 27 = 28;
    # (I_F / tau)^3 / (I_m / tau) = 2^3 / 14 = 0.571429
    assert mean_load_underestimate(4.0, 28.0, 2.0, 3.0) == pytest.approx(8 / 14, rel=1e-15)
    with pytest.raises(RvtoolInputError, match="I_m"):
        mean_load_underestimate(1.0, 0.0, 1.0, 3.0)


def test_constant_amplitude_miner():
    # sigma(t) = 100 MPa + 300 MPa cos(2 pi j / 8), n = 50 cycles sampled exactly at the extremes:
    # rainflow gives 2n half cycles of range 600 MPa; D = n / N(300 MPa) = 50 / (1e6 (500/300)^9)
    n, sa = 50, 300e6
    s = 100e6 + sa * np.cos(2 * np.pi * np.arange(8 * n + 1) / 8)
    curve = SNCurve(reference_amplitude=500e6, reference_life=1e6, exponent=9.0)
    res = miner_damage(s, curve)
    assert res.count.sum() == pytest.approx(n, rel=1e-15)
    np.testing.assert_allclose(res.amplitude, sa, rtol=1e-12)
    np.testing.assert_allclose(res.mean, 100e6, rtol=1e-12)
    # (5/3)^9 = 99.22903; N = 9.922903e7 cycles; D = 50 / 9.922903e7 = 5.038848e-7
    assert res.damage == pytest.approx(5.038848e-7, rel=HAND)
    assert miner_damage(s, curve, repeats=1000).damage == pytest.approx(1000 * res.damage, rel=1e-14)
    assert miner_damage(np.full(10, 5e6), curve).damage == 0.0          # no cycle, no damage
    with pytest.raises(RvtoolInputError, match="stress_history"):
        miner_damage([1.0, np.nan, 2.0], curve)


def test_iso281_rating_life_of_a_6205_by_hand():
    # deep-groove ball bearing 6205-like: Z = 9 balls of D_w = 7.938 mm (5/16 in), D_pw = 38.5 mm, alpha = 0, i = 1
    # gamma = 7.938 / 38.5 = 0.206182;  ISO 281 Table 2: f_c(0.20) = 59.9, f_c(0.21) = 59.8
    #   -> f_c = 59.9 - 0.6182 * 0.1 = 59.83818
    # C_r = b_m f_c (i cos a)^0.7 Z^(2/3) D_w^1.8 = 1.3 * 59.83818 * 1 * 4.326749 * 41.63703 = 14,014.0 N
    #   with 9^(2/3) = 4.326749 and 7.938^1.8 = exp(1.8 * 2.071661) = 41.63703
    #   (catalogues list 14.0 kN for the 6205 under ISO 281 without manufacturer's quality factors)
    # P = 2,000 N at 1,500 rpm: L10 = (C / P)^3 = 7.007020^3 = 344.033 10^6 rev;
    # L10h = L10 1e6 / (60 * 1500) = 3,822.6 h
    g = RatingGeometry(element="ball", n_elements=9, element_diameter=7.938e-3, pitch_diameter=38.5e-3)
    assert g.gamma == pytest.approx(0.2061818, rel=HAND)
    life = rating_life(g, 2000.0, 1500 * 2 * math.pi / 60)
    assert life.dynamic_load_rating == pytest.approx(14014.0, rel=HAND)
    assert life.L10_million_rev == pytest.approx(344.033, rel=HAND)
    assert life.L10_hours == pytest.approx(3822.6, rel=HAND)


def test_iso281_roller_rating_by_hand():
    # cylindrical roller bearing: Z = 13 rollers of D_we = 7.5 mm, L_we = 8 mm, D_pw = 39 mm, i = 1, alpha = 0
    # gamma = 7.5 / 39 = 0.192308; ISO 281 Table 7: f_c(0.19) = 88.8, f_c(0.20) = 88.7 -> 88.8 - 0.02308 = 88.77692
    # C_r = 1.1 * 88.77692 * 8^(7/9) * 13^(3/4) * 7.5^(29/27)
    #     = 1.1 * 88.77692 * 5.039684 * 6.846325 * 8.707242 = 29,338.2 N
    # p = 10/3: L10 at P = 5,000 N = (5.867650)^(10/3) = 364.374 10^6 rev
    g = RatingGeometry(element="roller", n_elements=13, element_diameter=7.5e-3, pitch_diameter=39e-3,
                       roller_length=8e-3)
    C = g.dynamic_load_rating()
    assert C == pytest.approx(29338.2, rel=HAND)
    assert rating_life(g, 5000.0, 100.0).L10_million_rev == pytest.approx(364.374, rel=HAND)
    with pytest.raises(RvtoolInputError, match="roller_length is required"):
        RatingGeometry(element="roller", n_elements=13, element_diameter=7.5e-3, pitch_diameter=39e-3)
    with pytest.raises(RvtoolInputError, match=r"gamma \(D cos\(alpha\) / D_pw of the roller bearing\)"):
        RatingGeometry(element="roller", n_elements=8, element_diameter=15e-3, pitch_diameter=30e-3,
                       roller_length=8e-3).dynamic_load_rating()


def test_equivalent_load_from_elements():
    # three loaded balls at -30, 0, +30 degrees: F_r = Q0 + 2 Q1 cos 30 deg
    ang = np.radians([-30.0, 0.0, 30.0])
    dirs = np.column_stack([np.cos(ang), np.sin(ang)])
    assert radial_load_from_elements([500.0, 1000.0, 500.0], dirs) == pytest.approx(1000 + 1000 * math.cos(math.pi / 6),
                                                                                  rel=1e-14)
    # variable load at constant speed: P_m = (sum P^p dt / tau)^(1/p); constant P gives P
    assert mean_equivalent_load(2000.0 ** 3 * 0.5, 0.5, 3.0) == pytest.approx(2000.0, rel=1e-14)
