"""Static load distribution of a ball bearing under a radial load (Stribeck's
problem), solved with the element forces and analytic tangent of the
rolling-element family, and its classical references.

Stribeck (1901) with Sjoevall's integral (Harris & Kotzalas, *Rolling Bearing
Analysis*, 5th ed., vol. 1, ch. 7): for a loaded-zone factor epsilon,

    F_r = Z Q_max J_r(epsilon) cos(alpha),
    J_r(epsilon) = 1/(2 pi) int_{-psi_l}^{psi_l} [1 - (1 - cos psi)/(2 epsilon)]^(3/2) cos psi dpsi,

with psi_l = arccos(1 - 2 epsilon). Zero clearance gives epsilon = 1/2,
J_r = 0.2288 and Q_max = 4.37 F_r / (Z cos alpha). For Z discrete balls the
exact zero-clearance relation is F_r = Q_max sum_{cos psi_j > 0} cos^(5/2) psi_j.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..contact.circle_set import GROUND
from ..errors import RvtoolInputError, SolverFailure
from ..validation import check_positive
from .set import BearingSet, Mounting
from .spec import AngularContactPair, BallBearing


def sjovall_radial_integral(epsilon=0.5):
    """J_r(epsilon) of point contact (exponent 3/2) for 0 < epsilon <= 1 (adaptive quadrature)."""
    from scipy.integrate import quad
    if not 0 < epsilon <= 1:
        raise RvtoolInputError(f"epsilon = {epsilon} is outside the valid range (0, 1]")
    psi_l = math.acos(1 - 2 * epsilon)
    val, _ = quad(lambda p: max(1 - (1 - math.cos(p)) / (2 * epsilon), 0.0) ** 1.5 * math.cos(p), -psi_l, psi_l,
                  epsabs=1e-14, epsrel=1e-13)
    return val / (2 * math.pi)


def stribeck_discrete_sum(n_balls, phase=0.0):
    """sum_{cos psi_j > 0} cos^(5/2) psi_j for balls at psi_j = phase + 2 pi j / Z from the load
    line: F_r / Q_max of the zero-clearance bearing with a constant contact angle."""
    c = np.cos(phase + 2 * np.pi * np.arange(n_balls) / n_balls)
    return float(np.sum(np.where(c > 0, c, 0.0) ** 2.5))


@dataclass(frozen=True, kw_only=True)
class LoadDistribution:
    """Static equilibrium of a ball bearing under a radial load.

    loads: element normal forces Q_j [N] (id order); angles: element angles from the
    load line [rad]; working_angles: alpha_w [rad]; displacement: inner-ring (x, y) [m];
    iterations: Newton iterations; residual: |R| / F_r at the solution.
    """
    loads: np.ndarray
    angles: np.ndarray
    working_angles: np.ndarray
    displacement: np.ndarray
    iterations: int
    residual: float


def radial_load_distribution(bearing, radial_load, *, load_angle=-math.pi / 2, backend="numpy", tol=1e-12,
                             max_iterations=50):
    """Equilibrium of the inner ring (x, y; rotation held) of ``bearing`` (a BallBearing or an
    AngularContactPair) under ``radial_load`` F_r [N] along ``load_angle`` [rad], outer ring fixed.

    Newton on the element forces with their analytic tangent, started from Stribeck's
    estimate of the displacement (zero clearance); cage phase psi_0 = load_angle puts a
    ball on the load line.
    """
    check_positive("radial_load", radial_load)
    if not isinstance(bearing, (BallBearing, AngularContactPair)):
        raise RvtoolInputError(f"bearing must be a BallBearing or AngularContactPair; got {type(bearing).__name__}")
    row = bearing.rows[0] if isinstance(bearing, AngularContactPair) else bearing
    n_rows = 2 if isinstance(bearing, AngularContactPair) else 1
    s = BearingSet([Mounting(name="b", bearing=bearing, inner=0, outer=GROUND, cage_phase=load_angle)], 1,
                   backend=backend)
    e = np.array([math.cos(load_angle), math.sin(load_angle)])
    ca = math.cos(row.contact_angle)
    q_max = 4.37 * radial_load / (n_rows * row.n_balls * ca)
    r0 = (q_max / row.hertz.combined) ** (2 / 3) / ca + max(row.radial_clearance, 0.0) / ca
    pose = np.zeros((1, 3))
    pose[0, :2] = r0 * e
    f_ext = radial_load * e
    for it in range(max_iterations + 1):
        ev = s.evaluate(pose)
        res = ev.Q[:2] + f_ext
        rel = float(np.linalg.norm(res) / radial_load)
        if rel < tol:
            break
        if it == max_iterations:
            raise SolverFailure(f"radial_load_distribution: no equilibrium for radial_load = {radial_load} N "
                                f"after {max_iterations} Newton iterations (|R|/F_r = {rel:.2e})")
        step = np.linalg.solve(ev.dQdq[:2, :2], -res)
        # bisect the step while it raises the residual (Newton on delta^(3/2) can overshoot)
        t = 1.0
        while t > 1e-6:
            trial = pose.copy()
            trial[0, :2] += t * step
            if np.linalg.norm(s.evaluate(trial).Q[:2] + f_ext) < np.linalg.norm(res):
                break
            t *= 0.5
        pose[0, :2] += t * step
    _, _, _, obs, aux = s.raw(pose)
    u = obs[:, 5:7]
    angles = np.arctan2(e[0] * u[:, 1] - e[1] * u[:, 0], u @ e)
    return LoadDistribution(loads=np.array(obs[:, 0]), angles=angles, working_angles=np.array(aux[:, 2]),
                            displacement=pose[0, :2].copy(), iterations=it, residual=rel)
