"""Linearized coupling path of Eq. (obs_coupling_path) and its nonlinear check.

On an equilibrium branch R(q, zeta) = 0 (static residual at fixed external
loading and constraints), a small slow-state change Delta zeta (a gap
offset written by wear or thermal expansion) changes the coordinates and the
normal contact loads by

    R_q Delta q = -R_zeta Delta zeta,   Delta F_n = F_n,q Delta q + F_n,zeta Delta zeta.

The linear prediction is compared with the re-solved equilibrium
R(q0 + Delta q, zeta0 + Delta zeta) = 0 (Newton from q0). Their difference
is O(|Delta zeta|^2) while the same contact set stays loaded; a change of
the contact set needs the nonlinear solution. Everything here is generic
(callables and matrices), so the reducer's static residual can be plugged in.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_positive


def _matrix(name, value, shape):
    a = np.array(value, dtype=np.float64)
    if a.shape != shape:
        raise RvtoolInputError(f"{name} must have shape {shape}; got {a.shape}")
    check_finite(name, a)
    return a


def linearized_load_change(R_q, R_zeta, F_q, F_zeta, delta_zeta):
    """(Delta q, Delta F_n) of Eq. (obs_coupling_path).

    R_q: (n, n) residual Jacobian in q; R_zeta: (n, k) in zeta; F_q: (p, n)
    and F_zeta: (p, k) Jacobians of the p normal loads [N per coordinate
    unit, N/m]; delta_zeta: (k,) slow-state change [m].
    """
    dz = np.atleast_1d(np.array(delta_zeta, dtype=np.float64))
    check_finite("delta_zeta", dz)
    k = dz.size
    Rq = np.array(R_q, dtype=np.float64)
    if Rq.ndim != 2 or Rq.shape[0] != Rq.shape[1]:
        raise RvtoolInputError(f"R_q must be square (n, n); got {Rq.shape}")
    n = Rq.shape[0]
    check_finite("R_q", Rq)
    Rz = _matrix("R_zeta", R_zeta, (n, k))
    Fq = np.array(F_q, dtype=np.float64)
    if Fq.ndim != 2 or Fq.shape[1] != n:
        raise RvtoolInputError(f"F_q must have shape (p, {n}); got {Fq.shape}")
    check_finite("F_q", Fq)
    Fz = _matrix("F_zeta", F_zeta, (Fq.shape[0], k))
    try:
        dq = np.linalg.solve(Rq, -Rz @ dz)
    except np.linalg.LinAlgError:
        raise RvtoolInputError("R_q is singular: the equilibrium branch is not isolated (a free mode or a lost "
                               "contact); valid: a nonsingular static tangent") from None
    return dq, Fq @ dq + Fz @ dz


def solve_equilibrium(residual, jacobian_q, q0, zeta, *, tol: float = 1e-12, max_iterations: int = 50):
    """Newton solution of residual(q, zeta) = 0 from q0, with jacobian_q(q, zeta) = R_q.

    tol: on max|R| relative to max|R(q0, zeta)| and an absolute floor of tol
    times the scale of R at q0 [residual units]. Raises RvtoolInputError when
    Newton does not reach it in max_iterations (a lost equilibrium branch).
    """
    q = np.array(q0, dtype=np.float64)
    r = np.asarray(residual(q, zeta), dtype=np.float64)
    scale = max(float(np.max(np.abs(r))), 1e-300)
    for _ in range(max_iterations):
        if float(np.max(np.abs(r))) <= tol * scale:
            return q
        q = q - np.linalg.solve(np.asarray(jacobian_q(q, zeta), dtype=np.float64), r)
        r = np.asarray(residual(q, zeta), dtype=np.float64)
        if not np.all(np.isfinite(r)):
            break
    raise RvtoolInputError(f"Newton did not re-solve the equilibrium within {max_iterations} iterations "
                           f"(max|R| = {float(np.max(np.abs(r))):.3e}); valid: a Delta zeta that keeps the branch")


@dataclass(frozen=True, kw_only=True, eq=False)
class CouplingComparison:
    """Linear vs nonlinear load change for one Delta zeta.

    delta_zeta [m]; dF_linear, dF_nonlinear [N] per contact; abs_error =
    max|dF_linear - dF_nonlinear| [N]; rel_error = abs_error / max|F_n(q0)|
    [-] (a fixed scale, so that the O(Delta zeta^2) error halves twice per
    halving of Delta zeta).
    """
    delta_zeta: np.ndarray
    dF_linear: np.ndarray
    dF_nonlinear: np.ndarray
    abs_error: float
    rel_error: float


def compare_with_resolve(*, residual, jacobian_q, jacobian_zeta, forces, forces_q, forces_zeta, q0, zeta0,
                         delta_zeta, equilibrium_tol: float = 1e-9) -> CouplingComparison:
    """Eq. (obs_coupling_path) at the equilibrium (q0, zeta0) against the nonlinear re-solve.

    residual(q, zeta) -> (n,); jacobian_q, jacobian_zeta: its Jacobians;
    forces(q, zeta) -> (p,) normal loads [N]; forces_q, forces_zeta: their
    Jacobians. q0 must satisfy max|R(q0, zeta0)| <= equilibrium_tol * max|F_n(q0, zeta0)|
    (checked: the linearization is about an equilibrium).
    """
    q0 = np.array(q0, dtype=np.float64)
    z0 = np.atleast_1d(np.array(zeta0, dtype=np.float64))
    dz = np.atleast_1d(np.array(delta_zeta, dtype=np.float64))
    check_finite("q0", q0)
    check_finite("zeta0", z0)
    check_positive("equilibrium_tol", equilibrium_tol)
    r0 = np.asarray(residual(q0, z0), dtype=np.float64)
    F0 = np.asarray(forces(q0, z0), dtype=np.float64)
    scale = max(float(np.max(np.abs(F0))), 1e-300)
    if float(np.max(np.abs(r0))) > equilibrium_tol * scale:
        raise RvtoolInputError(f"q0 is not an equilibrium: max|R(q0, zeta0)| = {float(np.max(np.abs(r0))):.3e} > "
                               f"equilibrium_tol * max|F_n| = {equilibrium_tol * scale:.3e}")
    _, dF_lin = linearized_load_change(jacobian_q(q0, z0), jacobian_zeta(q0, z0), forces_q(q0, z0),
                                       forces_zeta(q0, z0), dz)
    q1 = solve_equilibrium(residual, jacobian_q, q0, z0 + dz)
    dF_nl = np.asarray(forces(q1, z0 + dz), dtype=np.float64) - F0
    err = float(np.max(np.abs(dF_lin - dF_nl)))
    return CouplingComparison(delta_zeta=dz, dF_linear=dF_lin, dF_nonlinear=dF_nl, abs_error=err,
                              rel_error=err / scale)
