"""Bearing marker frequencies of the RV model against a hand-computed bearing (issue 27: the RV builder
passed degrees to bearing_frequencies, which takes radians: cos(14 rad) = 0.14, cos(40 rad) < 0).

Closed forms (rolling bearing, outer ring fixed relative to the load, inner ring at f_r relative to it):
    g    = D cos(alpha) / d_m                       D element diameter, d_m pitch diameter
    FTF  = f_r / 2 (1 - g)                          cage
    BPFO = Z f_r / 2 (1 - g)                        element pass, outer race
    BPFI = Z f_r / 2 (1 + g)                        element pass, inner race
    BSF  = d_m / (2 D) f_r (1 - g^2)                element spin
RV-40E (rvtool/designs/rv40e.toml) at 1500 rpm input (f_in = 25 Hz), ratio 121:
    carrier f_c = 25 / 121 Hz; crank relative to the carrier f_r = (z_sun / z_crank) (f_in - f_c)
    = (18 / 54) 25 (120 / 121) = 1000 / 121 Hz.
    crank bearing (tapered row, Z = 14, D = 5.5 mm, d_m = 33.5 mm, alpha = cup angle 14 deg):
        g = 0.159302283418; FTF 3.47395750654, BPFO 48.6354050915, BPFI 67.0670742473, BSF 24.5303254798 Hz
    main bearing (ball row, Z = 40, D = 7.9375 mm, d_m = 150 mm, alpha = 0.6981317 rad = 40 deg):
        g = 0.0405365184755; FTF 0.0991181282567, BPFO 3.96472513027, BPFI 4.29973767965, BSF 1.94902737815 Hz
The literals carry 12 digits: rel 1e-10 is their rounding, far below the 4 % to 600 % the degree
slip caused (g = 0.0229 and -0.0353 instead of 0.159 and 0.0405).
"""
import pytest

import rvtool

EXPECTED = {
    "crank_bearing": {"ftf": 3.47395750654, "bpfo": 48.6354050915, "bpfi": 67.0670742473, "bsf": 24.5303254798},
    "main_bearing": {"ftf": 0.0991181282567, "bpfo": 3.96472513027, "bpfi": 4.29973767965, "bsf": 1.94902737815},
}


@pytest.fixture(scope="module")
def markers():
    return rvtool.build(rvtool.load_design("rv40e")).marker_frequencies(1500.0)


def test_rv_kinematics_of_the_markers(markers):
    assert markers["output_hz"] == pytest.approx(25.0 / 121, rel=1e-12)
    assert markers["crank_relative_hz"] == pytest.approx(1000.0 / 121, rel=1e-12)


@pytest.mark.parametrize("bearing", sorted(EXPECTED))
def test_rv_bearing_markers_against_the_hand_computed_bearing(markers, bearing):
    for key, want in EXPECTED[bearing].items():
        assert markers[bearing][key] == pytest.approx(want, rel=1e-10), (bearing, key)
