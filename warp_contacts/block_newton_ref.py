"""NumPy reference of the block Newton step (:mod:`warp_contacts.block_newton`): one static Newton
step of every active copy from its summed residual Q (n,) and tangent dQ/dq (n, n).

The step of :mod:`warp_contacts.batched_newton_ref` (see there: regularization springs times the
copy's homotopy factor, the output torque, identity rows of the fixed coordinates, a dense
solve, step limiting, plausibility bounds, warm start -> homotopy stages -> CONVERGED / FAILED)
for any family set: the per-copy blocks come summed already (the rows' block scatter, on the
host or on the device), so the step itself does not know the families. Vectorized over the
copies with ``numpy.linalg.solve``; the kernel solves each copy by Gaussian elimination with
partial pivoting (the last bits of a step may differ, a converged state agrees to the Newton
tolerance).
"""
from dataclasses import dataclass

import numpy as np

from .batched_newton_ref import ACTIVE, CONVERGED, FAILED, WARM


@dataclass(frozen=True)
class StepModel:
    """What the step of every copy shares: spring_k (n,) regularization springs [N/m, N m/rad];
    free (n,) bool (False: drive, coordinate locks, journal locks: identity rows); rot (n,) bool
    rotation coordinates; out_index the output coordinate (the torque's); stiffening (S,) the
    homotopy factors; abs_tol [N]; max_iterations per stage; max_step_translation [m],
    max_step_rotation [rad]; bound_translation [m], bound_rotation [rad] (plausibility about the
    kinematic state); homotopy: a failed warm start runs the stages."""
    spring_k: np.ndarray
    free: np.ndarray
    rot: np.ndarray
    out_index: int
    stiffening: np.ndarray
    abs_tol: float
    max_iterations: int
    max_step_translation: float
    max_step_rotation: float
    bound_translation: float
    bound_rotation: float
    homotopy: bool


def block_step(Qc, Kc, q, kin, tq, status, stage, iters, total, residual, m):
    """One step of every copy with status ACTIVE; Qc (P, n) residual forces, Kc (P, n, n) dQ/dq,
    q (P, n) state, kin (P, n) kinematic states, tq (P,) output torques [N m]; status, stage,
    iters, total (P,) int and residual (P,) [N] updated in place, as q; m: :class:`StepModel`."""
    act = np.flatnonzero(status == ACTIVE)
    n = q.shape[1]
    stiff = np.asarray(m.stiffening, float)
    free, rot = m.free, m.rot
    total[act] += 1
    f = np.where(stage[act] == WARM, 1.0, stiff[np.maximum(stage[act], 0)])
    ks = f[:, None] * m.spring_k[None]
    r = Qc[act] - ks * (q[act] - kin[act])
    r[:, m.out_index] += tq[act]
    A = -Kc[act]
    A[:, np.arange(n), np.arange(n)] += ks
    r[:, ~free] = 0.0
    A[:, ~free, :] = 0.0
    A[:, :, ~free] = 0.0
    A[:, ~free, ~free] = 1.0
    ok = np.isfinite(r).all(axis=1) & np.isfinite(A).all(axis=(1, 2))
    norm = np.sqrt(np.sum(r * r, axis=1))
    residual[act] = norm
    converged = ok & (norm <= m.abs_tol)
    dq = np.zeros_like(r)
    good = np.flatnonzero(ok)
    if len(good):
        try:
            dq[good] = np.linalg.solve(A[good], r[good][:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:               # one singular block: solve them one by one
            for i in good:
                try:
                    dq[i] = np.linalg.solve(A[i], r[i])
                except np.linalg.LinAlgError:
                    ok[i] = False
    ok &= np.isfinite(dq).all(axis=1)
    mt = np.max(np.abs(dq[:, ~rot]), axis=1)
    mr = np.max(np.abs(dq[:, rot]), axis=1)
    scale = np.ones(len(act))
    lim_t = ~converged & (mt > m.max_step_translation)
    scale[lim_t] = m.max_step_translation / mt[lim_t]
    lim_r = ~converged & (mr * scale > m.max_step_rotation)
    scale[lim_r] = m.max_step_rotation / mr[lim_r]
    upd = act[ok]
    q[upd] += scale[ok, None] * dq[ok]
    iters[upd] += 1
    dev = np.abs(q[act] - kin[act])
    implausible = np.any(np.where(rot[None], dev > m.bound_rotation, dev > m.bound_translation), axis=1)
    ok &= ~implausible
    last = len(stiff) - 1
    done = ok & converged
    fin = done & ((stage[act] == WARM) | (stage[act] == last))
    status[act[fin]] = CONVERGED
    nxt = act[done & ~fin]
    stage[nxt] += 1
    iters[nxt] = 0
    bad = act[~done & (~ok | (iters[act] >= m.max_iterations))]
    to_h = bad[(stage[bad] == WARM) & bool(m.homotopy)]
    stage[to_h] = 0
    iters[to_h] = 0
    q[to_h] = kin[to_h]
    status[np.setdiff1d(bad, to_h)] = FAILED


__all__ = ["ACTIVE", "CONVERGED", "FAILED", "WARM", "StepModel", "block_step"]
