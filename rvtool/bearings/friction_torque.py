"""Bearing friction torque with Palmgren's load- and speed-dependent model.

Source: A. Palmgren, *Ball and Roller Bearing Engineering*, 3rd ed., SKF
Industries, Philadelphia, 1959; as restated in T. A. Harris and
M. N. Kotzalas, *Rolling Bearing Analysis* (5th ed., 2007), the section on
bearing friction torque. The friction moment of a rolling bearing is the sum
of a load-independent (viscous, lubricant) part and a load-dependent part,

    M = M0 + M1,
    M0 = 1e-7 f0 (nu n)^(2/3) d_m^3          for nu n >= 2000,
    M0 = 160e-7 f0 d_m^3                      for nu n <  2000,
    M1 = f1 P1 d_m,

in the units of the sources: M [N mm], kinematic viscosity nu [mm^2/s],
speed n [r/min], pitch diameter d_m [mm], load P1 [N]. The specification
and the functions here take SI units and convert with named constants.
(The two M0 branches meet within 0.8 %: 2000^(2/3) = 158.7, not 160; the
jump at the threshold is the source's.)

The moment is a loss on a bearing's relative rotation: as a generalized force
on the relative angle it is Q = -M(|omega|, P1) tanh(omega / omega_reg), the
sign regularized over ``regularization_speed`` as the friction law of
Eq. (friction) is. ``None`` for the model means no friction torque, and
:func:`friction_generalized_force` then returns zeros without evaluating
anything.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_positive

#: Palmgren's units: r/min per rad/s, mm^2/s per m^2/s, mm per m, N m per N mm.
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)
MM2_S_PER_M2_S = 1e6
MM_PER_M = 1e3
NM_PER_NMM = 1e-3
#: nu n [mm^2/s r/min] below which M0 no longer depends on speed.
PALMGREN_VN_LIMIT = 2000.0
#: Coefficients of M0 in the source: 1e-7 above the limit, 160e-7 below it.
M0_COEFFICIENT = 1e-7
M0_LOW_SPEED_COEFFICIENT = 160e-7


@dataclass(frozen=True, kw_only=True)
class PalmgrenFrictionTorque:
    """Palmgren's friction moment of one bearing (module docstring).

    f0: lubrication and bearing-type factor f_0 [-], > 0 (tabulated in the
    sources by bearing type and lubrication method).
    f1: load factor f_1 [-], >= 0 (for ball bearings the sources give it from
    the ratio of the static equivalent to the static load rating; a declared
    constant here).
    pitch_diameter: d_m [m], > 0.
    kinematic_viscosity: nu [m^2/s] of the lubricant at operating temperature, > 0.
    regularization_speed: omega_reg [rad/s], > 0, of the sign regularization
    of the generalized force.
    """
    f0: float
    f1: float
    pitch_diameter: float
    kinematic_viscosity: float
    regularization_speed: float = 1e-2

    def __post_init__(self):
        check_positive("f0", self.f0)
        check_nonnegative("f1", self.f1)
        check_positive("pitch_diameter", self.pitch_diameter)
        check_positive("kinematic_viscosity", self.kinematic_viscosity)
        check_positive("regularization_speed", self.regularization_speed)


def _finite(name, value):
    a = np.asarray(value, np.float64)
    bad = ~np.isfinite(a)
    if bad.any():
        raise RvtoolInputError(f"{name} must be finite (valid range: finite real numbers); got {a[bad].ravel()[:4].tolist()}")
    return a


def palmgren_torque(model: PalmgrenFrictionTorque, speed, load):
    """Friction moment M [N m] and its derivatives at relative speed |omega| and load P1.

    speed: |omega| [rad/s], >= 0; load: P1 [N], >= 0 (arrays broadcast).
    Returns (M [N m], dM/d|omega| [N m s/rad], dM/dP1 [m]).
    """
    w = _finite("speed", speed)
    p = _finite("load", load)
    check_nonnegative("speed", w)
    check_nonnegative("load", p)
    d_mm = model.pitch_diameter * MM_PER_M
    n = w * RPM_PER_RAD_S
    vn = model.kinematic_viscosity * MM2_S_PER_M2_S * n
    fast = vn >= PALMGREN_VN_LIMIT
    vn_safe = np.where(fast, vn, PALMGREN_VN_LIMIT)
    m0_fast = M0_COEFFICIENT * model.f0 * vn_safe ** (2.0 / 3.0) * d_mm ** 3
    m0 = np.where(fast, m0_fast, M0_LOW_SPEED_COEFFICIENT * model.f0 * d_mm ** 3)
    # d M0 / d n = (2/3) M0 / n on the fast branch (n > 0 there), zero below the limit
    n_safe = np.where(fast, n, 1.0)
    dm0_dw = np.where(fast, (2.0 / 3.0) * m0_fast / n_safe * RPM_PER_RAD_S, 0.0)
    m1 = model.f1 * p * d_mm
    return ((m0 + m1) * NM_PER_NMM, dm0_dw * NM_PER_NMM,
            np.broadcast_to(model.f1 * d_mm * NM_PER_NMM, np.shape(m1)).copy())


def friction_generalized_force(model: PalmgrenFrictionTorque | None, omega, load):
    """Generalized force on a bearing's relative rotation, Q = -M(|omega|, P1) tanh(omega/omega_reg).

    omega: relative angular velocity [rad/s] (signed); load: P1 [N], >= 0.
    Returns (Q [N m], dQ/domega [N m s/rad], dQ/dP1 [m]). ``model=None``: no
    friction torque, (0, 0, 0) at no cost.
    """
    if model is None:
        return 0.0, 0.0, 0.0
    w = _finite("omega", omega)
    M, dM_dw, dM_dp = palmgren_torque(model, np.abs(w), load)
    th = np.tanh(w / model.regularization_speed)
    dth = (1.0 - th * th) / model.regularization_speed
    return -M * th, -(dM_dw * np.sign(w) * th + M * dth), -dM_dp * th
