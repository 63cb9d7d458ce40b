"""Static load distribution of a ball bearing under radial load (Stribeck's problem)."""
import numpy as np

from ..contact.circle_set import GROUND
from ..errors import SolverFailure
from .set import BearingSet, Mounting


def radial_load_distribution(bearing, radial_load, *, backend="numpy", tol=1e-9, max_iterations=60):
    """Equilibrium of the inner ring (x, y) of ``bearing`` under ``radial_load`` [N] along -y,
    outer ring fixed; Newton on the element forces and analytic tangent. Returns
    (ball loads Q_j [N], element angles psi_j [rad], ring displacement [m])."""
    s = BearingSet([Mounting(name="b", bearing=bearing, inner=0, outer=GROUND)], 1, backend=backend)
    pose = np.zeros((1, 3))
    f_ext = np.array([0.0, -radial_load])
    pose[0, 1] = -1e-6
    for _ in range(max_iterations):
        e = s.evaluate(pose)
        r = e.Q[:2] + f_ext
        if np.linalg.norm(r) < tol * radial_load:
            break
        K = e.dQdq[:2, :2]
        step = np.linalg.solve(K, -r)
        # damped step: no element may be asked to jump far past the unloaded state
        scale = min(1.0, 2e-6 / max(np.linalg.norm(step), 1e-30))
        pose[0, :2] += scale * step
    else:
        raise SolverFailure(f"radial_load_distribution did not converge for radial_load = {radial_load} N")
    obs = s.evaluate(pose).obs
    psi = np.arctan2(obs[:, 6], obs[:, 5])
    return obs[:, 0], psi, pose[0, :2].copy()


def stribeck_exact_sum(n_balls, psi_loaded_line=0.0):
    """Zero-clearance discrete Stribeck sum: Q_max = F_r / sum_{cos psi > 0} cos^(5/2)(psi_j) (per unit F_r),
    balls at psi_j = psi_0 + 2 pi j / Z measured from the load line."""
    psi = psi_loaded_line + 2 * np.pi * np.arange(n_balls) / n_balls
    c = np.cos(psi)
    return 1.0 / np.sum(np.where(c > 0, c, 0.0) ** 2.5)


def sjovall_radial_integral(epsilon=0.5, n=200001):
    """J_r(epsilon) = (1/2pi) int (1 - (1 - cos psi)/(2 epsilon))^(3/2) cos psi dpsi over the loaded zone."""
    psi = np.linspace(-np.pi, np.pi, n)
    f = np.clip(1 - (1 - np.cos(psi)) / (2 * epsilon), 0, None) ** 1.5 * np.cos(psi)
    return np.trapezoid(f, psi) / (2 * np.pi)
