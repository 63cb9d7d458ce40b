"""NumPy reference of the batched static Newton step (:mod:`warp_contacts.batched_newton`).

B independent copies of one topology (each with n = 3 nb planar coordinates) are solved for
their static equilibria side by side. One step, per copy p that is still active:

1. Residual and tangent by segmented sums over the copy's own contact rows (every family's
   rows of copy p are the contiguous block p R_f .. p R_f + R_f - 1; ``local`` (R_f, k) maps a
   row entry to the copy's coordinate, -1: ground), in a fixed order (no atomics):
   r = sum Q_row (Eq. (contact_mapping)) - f k_reg (q - q_kin) + T e_out,
   A = f k_reg I - sum dQ/dq_row  (so that A dq = r is the Newton correction).
   f is the copy's regularization factor: 1 in the warm start, ``stiffening[s]`` in stage s of
   the homotopy (stiff springs first, the unmodified problem last; as
   :meth:`rvtool.solver.static.StaticSolver.stiffened_start`).
2. Fixed coordinates (the drive, the coordinate locks) get identity rows and a zero residual.
3. Convergence: |r| over the free coordinates <= ``abs_tol`` [N, N m]. The Newton step is
   applied in any case (a converged copy takes its last, quadratically small correction).
4. The step dq = A^-1 r (Gaussian elimination with partial pivoting) is scaled so that no
   translation changes by more than ``max_step_translation`` [m] and no rotation by more than
   ``max_step_rotation`` [rad] (step limiting: a full step in the free play of an unloaded
   direction jumps to a periodic copy of the engagement).
5. Plausibility: every coordinate within ``bound_translation`` / ``bound_rotation`` of its
   kinematic value (as :meth:`StaticSolver.plausible`), finite residual and pivots.
6. Stage bookkeeping: a converged warm start or last homotopy stage -> CONVERGED; a converged
   intermediate stage -> next stage (same state); a failure (iteration limit, non-finite,
   singular, implausible) of the warm start -> homotopy stage 0 from the kinematic state (if
   enabled), otherwise FAILED.

States are displacement coordinates q (B, n) from each copy's reference configuration.
"""
import numpy as np

ACTIVE, CONVERGED, FAILED = 0, 1, 2
WARM = -1                 # stage of a warm start (regularization factor 1)
ROW_ENTRIES = 6           # entries of a contact row: two planar bodies (x, y, theta) each


def is_rotation(n):
    """(n,) True for the rotation coordinate of each planar body (x, y, theta)."""
    return np.arange(n) % 3 == 2


def assemble(rows, B):
    """Residual contributions and tangents of the contact rows summed per copy.

    rows: list of (Q (B R, k), dQdq (B R, k, k), local (R, k)) per family. Returns
    r (B, n) = sum Q, K (B, n, n) = sum dQ/dq, with n inferred from the local maps."""
    n = 1 + max(int(loc.max()) for _, _, loc in rows)
    n = 3 * ((n + 2) // 3)
    r = np.zeros((B, n))
    K = np.zeros((B, n, n))
    for Q, dQ, loc in rows:
        R, k = loc.shape
        Q = Q.reshape(B, R, k)
        dQ = dQ.reshape(B, R, k, k)
        for rr in range(R):
            for a in range(k):
                la = loc[rr, a]
                if la < 0:
                    continue
                r[:, la] += Q[:, rr, a]
                for b in range(k):
                    lb = loc[rr, b]
                    if lb >= 0:
                        K[:, la, lb] += dQ[:, rr, a, b]
    return r, K


def newton_step(rows, q, kin, spring_k, free, torque, out_index, status, stage, iters, total, *, stiffening, abs_tol,
                max_iterations, max_step_translation, max_step_rotation, bound_translation, bound_rotation,
                homotopy):
    """One step of every active copy (see the module docstring). Arrays are updated in place:
    q (B, n), status, stage, iters (iterations of the current stage), total (all steps) (B,) int.
    spring_k (B, n): regularization stiffness per coordinate [N/m, N m/rad]; free (n,) bool;
    torque (B,): load on coordinate ``out_index`` [N m]. Returns the residual norms (B,) over the free
    coordinates (NaN for copies that were not active)."""
    B, n = q.shape
    rot = is_rotation(n)
    rK, K = assemble(rows, B)
    norms = np.full(B, np.nan)
    for p in range(B):
        if status[p] != ACTIVE:
            continue
        total[p] += 1
        f = 1.0 if stage[p] == WARM else stiffening[stage[p]]
        ks = f * spring_k[p]
        r = rK[p] - ks * (q[p] - kin[p])
        r[out_index] += torque[p]
        A = np.diag(ks) - K[p]
        r = np.where(free, r, 0.0)
        A = np.where(free[:, None] & free[None, :], A, 0.0) + np.diag(~free * 1.0)
        ok = bool(np.all(np.isfinite(r)) and np.all(np.isfinite(A)))
        norm = float(np.sqrt(np.sum(r * r)))
        norms[p] = norm
        converged = ok and norm <= abs_tol
        if ok:
            try:
                dq = np.linalg.solve(A, r)
                ok = bool(np.all(np.isfinite(dq)))
            except np.linalg.LinAlgError:
                ok = False
        if ok:
            if not converged:
                mt = np.max(np.abs(dq[~rot]))
                mr = np.max(np.abs(dq[rot]))
                scale = 1.0
                if mt > max_step_translation:
                    scale = max_step_translation / mt
                if mr * scale > max_step_rotation:
                    scale = max_step_rotation / mr
                dq = scale * dq
            q[p] += dq
            iters[p] += 1
            dev = np.abs(q[p] - kin[p])
            ok = not np.any(np.where(rot, dev > bound_rotation, dev > bound_translation))
        if ok and converged:
            if stage[p] == WARM or stage[p] == len(stiffening) - 1:
                status[p] = CONVERGED
            else:
                stage[p] += 1
                iters[p] = 0
            continue
        if ok and iters[p] < max_iterations:
            continue
        # failure of this stage: the warm start goes to the homotopy, the homotopy fails
        if stage[p] == WARM and homotopy:
            stage[p] = 0
            iters[p] = 0
            q[p] = kin[p]
        else:
            status[p] = FAILED
    return norms


def gather_rows(rows, variant):
    """(P R, C) rows of P copies from the rows (V, R, C) of their variants (P,)."""
    return np.asarray(rows)[np.asarray(variant)].reshape(-1, np.shape(rows)[2])


def gather_bodies(rows, variant, body_cols, nb, ground):
    """As :func:`gather_rows` for integer rows whose columns ``body_cols`` hold local body
    indices (0..nb-1, >= nb: ground): copy p's bodies become p nb + local, the ground the pose
    array's row ``ground``."""
    variant = np.asarray(variant)
    P = len(variant)
    out = np.asarray(rows)[variant].copy()
    base = (np.arange(P) * nb)[:, None]
    for c in body_cols:
        out[:, :, c] = np.where(out[:, :, c] >= nb, ground, out[:, :, c] + base)
    return out.reshape(-1, out.shape[2])
