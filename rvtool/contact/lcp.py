"""Frictionless unilateral contact of a linear body as a mixed linear complementarity problem.

With the normal contact forces lam (n,) [N] (compression positive) on n candidate nodes, the
condensed compliance A (n, n) [m/N] of the body (symmetric positive definite on the balanced
loads), the gaps at zero force b (n,) [m] and k equality rows E (k, n) on the forces (e.g. the
balance of a free body, E lam = e), the gaps

    g = A lam + b + E^T w >= 0,   lam >= 0,   lam . g = 0,   E lam = e

with w (k,) free multipliers (the body's rigid motion along the rows of E, up to their scale) are
the optimality conditions of the strictly convex quadratic programme
min 1/2 lam^T A lam + b^T lam subject to lam >= 0 and E lam = e, so the solution is unique.

:func:`solve_contact_lcp` (dense A) finds it by active sets: the bordered system on the active set,
[A_aa E_a^T; E_a 0] (lam_a, w) = (-b_a, e), then the primal--dual update (Hintermueller, Ito &
Kunisch, SIAM J. Optim. 13 (2003) 865) that makes active every node with lam > 0 or g < 0 at
once. That update can cycle for a matrix A that is not an M-matrix; when an active set repeats
the solver changes to Murty's least-index rule (one node at a time, the lowest index that
violates a condition), which is finite for the positive definite reduced problem (Murty, Linear
Complementarity, Linear and Nonlinear Programming, Heldermann 1988, Sec. 4.2).
:func:`active_set_contact` runs the same iterations for any body that can solve itself with a
given active set (e.g. a finite element model with the active gaps as constraints, no
condensation). No tolerance is tuned to a reference: a node is taken as violating when its force
or gap is below ``-tol`` times the problem's own scale.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError


@dataclass(frozen=True)
class ContactLcpSolution:
    """lam (n,) [N] contact forces; gap (n,) [m] loaded gaps (0 on the active set); w (k,) the
    multipliers of the equality rows; active (n,) bool; iterations: active-set solves; murty: whether
    the least-index rule was needed."""
    lam: np.ndarray
    gap: np.ndarray
    w: np.ndarray
    active: np.ndarray
    iterations: int
    murty: bool


def _bordered(A, b, E, e, act):
    a = np.flatnonzero(act)
    k = E.shape[0]
    na = len(a)
    M = np.zeros((na + k, na + k))
    M[:na, :na] = A[np.ix_(a, a)]
    M[:na, na:] = E[:, a].T
    M[na:, :na] = E[:, a]
    rhs = np.concatenate([-b[a], e])
    try:
        x = np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError:
        x = None
    if x is None or not np.all(np.isfinite(x)):
        raise RvtoolInputError(f"the active set of {na} contact nodes does not hold the {k} equality rows (singular "
                               "bordered system); valid: candidate nodes whose normals can balance the body")
    lam = np.zeros(len(b))
    lam[a] = x[:na]
    w = x[na:]
    return lam, w


def active_set_contact(solve_active, active, gap_tol, force_rtol=1e-10, max_iterations=200):
    """Active-set iterations of a frictionless unilateral contact (module docstring), for any linear
    body: ``solve_active(active)`` -> (lam (n,), gap (n,), extra) solves the body with the gaps of the
    active nodes closed (bilateral) and the others free of force; lam is read on the active nodes,
    gap on the others. active (n,) bool: the first active set; gap_tol [m]: a gap below -gap_tol
    violates; force_rtol: a force below -force_rtol max |lam| violates.

    Returns (lam, gap, active, iterations, murty, extra) at the set where nothing violates; lam is 0
    off the set, gap 0 on it. Raises :class:`RvtoolInputError` after ``max_iterations`` solves.
    """
    act = np.asarray(active, bool).copy()
    n = len(act)
    seen = set()
    murty = False
    for it in range(1, max_iterations + 1):
        lam, gap, extra = solve_active(act)
        f_tol = force_rtol * max(np.abs(lam[act]).max(initial=0.0), 1e-300)
        bad_lam = act & (lam < -f_tol)
        bad_gap = ~act & (gap < -gap_tol)
        if not (bad_lam.any() or bad_gap.any()):
            return (np.where(act, np.maximum(lam, 0.0), 0.0), np.where(act, 0.0, gap), act, it, murty, extra)
        seen.add(act.tobytes())
        if not murty:
            new = (act & ~bad_lam) | bad_gap
            if new.tobytes() in seen:
                murty = True
            else:
                act = new
                continue
        i = int(np.flatnonzero(bad_lam | bad_gap)[0])       # Murty's least-index rule
        act[i] = not act[i]
    raise RvtoolInputError(f"the contact active set did not settle in {max_iterations} solves (n = {n})")


def solve_contact_lcp(A, b, E=None, e=None, active=None, tol=1e-10, max_iterations=500):
    """The unique solution of the mixed LCP of the module docstring (dense A).

    A (n, n) symmetric positive definite [m/N]; b (n,) [m]; E (k, n) and e (k,) (default: none);
    active (n,) bool: the first active set (default: the nodes with b <= 0); tol: relative
    tolerance of the complementarity conditions (forces against max |lam|, gaps against max |b|).
    Raises :class:`RvtoolInputError` on bad shapes, a singular bordered system or no convergence in
    ``max_iterations`` active-set solves.
    """
    A = np.asarray(A, float)
    b = np.asarray(b, float)
    n = len(b)
    if A.shape != (n, n) or not np.all(np.isfinite(A)) or not np.all(np.isfinite(b)):
        raise RvtoolInputError(f"A must be a finite ({n}, {n}) matrix and b finite (got A {A.shape})")
    E = np.zeros((0, n)) if E is None else np.atleast_2d(np.asarray(E, float))
    e = np.zeros(E.shape[0]) if e is None else np.asarray(e, float)
    if E.shape[1] != n or e.shape != (E.shape[0],):
        raise RvtoolInputError(f"E must be (k, {n}) and e (k,) (got E {E.shape}, e {e.shape})")
    A = 0.5 * (A + A.T)
    act = (b <= 0) if active is None else np.asarray(active, bool)
    if act.shape != (n,):
        raise RvtoolInputError(f"active must be ({n},) booleans")

    def solve_active(a):
        lam, w = _bordered(A, b, E, e, a)
        return lam, A @ lam + b + E.T @ w, w

    gap_tol = tol * max(np.abs(b).max(initial=0.0), 1e-300)
    lam, gap, act, it, murty, w = active_set_contact(solve_active, act, gap_tol=gap_tol, force_rtol=tol,
                                                     max_iterations=max_iterations)
    return ContactLcpSolution(lam=lam, gap=gap, w=w, active=act, iterations=it, murty=murty)
