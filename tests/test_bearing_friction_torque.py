"""Palmgren's bearing friction torque (rvtool.bearings.friction_torque): a hand-computed
point on each branch, derivatives against central differences, dissipativity of the
generalized force, the zero-cost "no friction torque" variant, and named input errors."""
import math

import numpy as np
import pytest

from rvtool.bearings.friction_torque import (PalmgrenFrictionTorque, friction_generalized_force, palmgren_torque)
from rvtool.errors import RvtoolInputError

MODEL = PalmgrenFrictionTorque(f0=2.0, f1=7e-4, pitch_diameter=0.05, kinematic_viscosity=2e-5)
# central differences of smooth power laws with h ~ 1e-6 relative: truncation ~ h^2 ~ 1e-12,
# round-off ~ eps / h ~ 1e-10; 1e-7 leaves margin and still catches a wrong factor
FD_RTOL = 1e-7


def test_hand_computed_point_above_the_viscous_limit():
    # n = 1500 r/min, nu = 20 mm^2/s: nu n = 30000 >= 2000, (nu n)^(2/3) = 965.489 (965.489^3 = 9.0e8 = 30000^2)
    # M0 = 1e-7 * 2 * 965.489 * 50^3 = 24.1372 N mm;  M1 = 7e-4 * 1000 N * 50 mm = 35 N mm
    # M = 59.1372 N mm;  dM/domega = (2/3) M0 / n * 60/(2 pi) = 0.102442 N mm s/rad;  dM/dP1 = f1 d_m = 3.5e-5 m
    M, dM_dw, dM_dp = palmgren_torque(MODEL, 1500 * 2 * math.pi / 60, 1000.0)
    assert M == pytest.approx(59.1372e-3, rel=1e-5)
    assert dM_dw == pytest.approx(0.102442e-3, rel=1e-5)
    assert dM_dp == pytest.approx(3.5e-5, rel=1e-12)


def test_hand_computed_point_below_the_viscous_limit():
    # n = 10 r/min: nu n = 200 < 2000, M0 = 160e-7 * 2 * 50^3 = 4 N mm, independent of speed
    M, dM_dw, _ = palmgren_torque(MODEL, 10 * 2 * math.pi / 60, 1000.0)
    assert M == pytest.approx((4.0 + 35.0) * 1e-3, rel=1e-12)
    assert dM_dw == 0.0


@pytest.mark.parametrize("omega", [-300.0, -40.0, 0.005, 157.08])
def test_generalized_force_derivatives_match_central_differences(omega):
    P = 1200.0
    Q, dQ_dw, dQ_dp = friction_generalized_force(MODEL, omega, P)
    hw, hp = 1e-6 * max(abs(omega), MODEL.regularization_speed), 1e-6 * P
    fd_w = (friction_generalized_force(MODEL, omega + hw, P)[0] - friction_generalized_force(MODEL, omega - hw, P)[0]) / (2 * hw)
    fd_p = (friction_generalized_force(MODEL, omega, P + hp)[0] - friction_generalized_force(MODEL, omega, P - hp)[0]) / (2 * hp)
    assert dQ_dw == pytest.approx(fd_w, rel=FD_RTOL, abs=1e-12)
    assert dQ_dp == pytest.approx(fd_p, rel=FD_RTOL)
    assert Q * omega <= 0.0  # a loss: the moment opposes the relative rotation


def test_no_model_is_no_torque():
    assert friction_generalized_force(None, 100.0, 1e3) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("change, name", [
    (dict(f0=-1.0), "f0"), (dict(f1=-1e-4), "f1"), (dict(pitch_diameter=0.0), "pitch_diameter"),
    (dict(kinematic_viscosity=math.nan), "kinematic_viscosity"), (dict(regularization_speed=0.0), "regularization_speed"),
])
def test_bad_specifications_raise_naming_the_parameter(change, name):
    kw = dict(f0=2.0, f1=7e-4, pitch_diameter=0.05, kinematic_viscosity=2e-5) | change
    with pytest.raises(RvtoolInputError, match=name):
        PalmgrenFrictionTorque(**kw)


@pytest.mark.parametrize("speed, load, name", [(-1.0, 10.0, "speed"), (np.nan, 10.0, "speed"),
                                               (1.0, -5.0, "load"), (1.0, np.inf, "load")])
def test_bad_operating_points_raise_naming_the_parameter(speed, load, name):
    with pytest.raises(RvtoolInputError, match=name):
        palmgren_torque(MODEL, speed, load)
    if name == "load" or np.isnan(speed):
        with pytest.raises(RvtoolInputError):
            friction_generalized_force(MODEL, speed, load)
