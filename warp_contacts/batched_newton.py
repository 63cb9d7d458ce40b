"""Warp kernels of the batched static Newton (one thread per copy; the same code on cpu and cuda).

Mirrors :mod:`warp_contacts.batched_newton_ref` (see there for the step): the residual and the
dense tangent block of each copy are summed from its own contact rows in a fixed order by the
copy's thread (deterministic: no atomics, so two runs give bit-identical states), springs,
loads and fixed coordinates are added, the block is solved by Gaussian elimination with
partial pivoting, and the step is limited and checked. Three contact families of k = 6 entries
per row (two planar bodies) enter, as produced by the cycloid-pin, output-pin (plain) and
circle-pair kernels.

``scatter_poses`` writes the absolute poses reference + q of every copy into the pose arrays
of the contact kernels (their ground row stays zero); ``count_active`` is folded into the
step (an integer atomic: its sum does not depend on the order); ``sweep_gate`` counts the
sweeps and ends a loop after a cap (the solver then continues the remaining copies in a
smaller launch); ``gather_rows`` / ``gather_bodies`` fill the contact kernels' parameter
rows of every copy from its variant's rows on the device (no per-copy host work).
"""
import functools

import warp as wp

from .dense_lu import lu_funcs
from .batched_newton_ref import ACTIVE, CONVERGED, FAILED, ROW_ENTRIES, WARM


@functools.lru_cache(maxsize=None)
def kernels(dtype):
    """(scatter_poses, newton_step, sweep_gate, gather_rows, gather_bodies) for ``dtype``."""
    lu_solve = lu_funcs(dtype)

    @wp.func
    def add_rows(qr: wp.array2d(dtype=dtype), kr: wp.array3d(dtype=dtype), loc: wp.array2d(dtype=wp.int32), p: int,
                 r: wp.array2d(dtype=dtype), A: wp.array3d(dtype=dtype)):
        """r[p] += sum of the rows' forces, A[p] -= sum of their tangents (rows of copy p in order)."""
        nr = loc.shape[0]
        for rr in range(nr):
            row = p * nr + rr
            # ROW_ENTRIES is a compile-time trip count: Warp unrolls both loops
            for a in range(ROW_ENTRIES):
                la = loc[rr, a]
                if la >= 0:
                    r[p, la] = r[p, la] + qr[row, a]
                    for b in range(ROW_ENTRIES):
                        lb = loc[rr, b]
                        if lb >= 0:
                            A[p, la, lb] = A[p, la, lb] - kr[row, a, b]

    @wp.kernel(module="unique")
    def scatter_poses(
        # Model:
        reference: wp.array2d(dtype=dtype),
        # Data in:
        q: wp.array2d(dtype=dtype),
        # Data out:
        pose_a: wp.array2d(dtype=dtype),
        pose_b: wp.array2d(dtype=dtype),
        pose_c: wp.array2d(dtype=dtype),
    ):
        p, i = wp.tid()
        nb = q.shape[1] // 3
        row = p * nb + i // 3
        col = i % 3
        x = reference[p, i] + q[p, i]
        pose_a[row, col] = x
        pose_b[row, col] = x
        pose_c[row, col] = x

    @wp.kernel(module="unique")
    def newton_step(
        # Model:
        loc_a: wp.array2d(dtype=wp.int32),
        loc_b: wp.array2d(dtype=wp.int32),
        loc_c: wp.array2d(dtype=wp.int32),
        kin: wp.array2d(dtype=dtype),
        spring_k: wp.array2d(dtype=dtype),
        free: wp.array(dtype=wp.int32),
        torque: wp.array(dtype=dtype),
        out_index: int,
        stiffening: wp.array(dtype=dtype),
        abs_tol: dtype,
        max_iterations: int,
        max_step_translation: dtype,
        max_step_rotation: dtype,
        bound_translation: dtype,
        bound_rotation: dtype,
        homotopy: int,
        # Data in:
        q_a: wp.array2d(dtype=dtype),
        k_a: wp.array3d(dtype=dtype),
        q_b: wp.array2d(dtype=dtype),
        k_b: wp.array3d(dtype=dtype),
        q_c: wp.array2d(dtype=dtype),
        k_c: wp.array3d(dtype=dtype),
        # Data out (state and scratch):
        q: wp.array2d(dtype=dtype),
        status: wp.array(dtype=wp.int32),
        stage: wp.array(dtype=wp.int32),
        iters: wp.array(dtype=wp.int32),
        total: wp.array(dtype=wp.int32),
        residual: wp.array(dtype=dtype),
        r: wp.array2d(dtype=dtype),
        A: wp.array3d(dtype=dtype),
        dq: wp.array2d(dtype=dtype),
        active: wp.array(dtype=wp.int32),
    ):
        p = wp.tid()
        if status[p] != ACTIVE:
            return
        n = q.shape[1]
        total[p] = total[p] + 1
        f = dtype(1.0)
        if stage[p] != WARM:
            f = stiffening[stage[p]]
        for i in range(n):
            r[p, i] = dtype(0.0)
            for j in range(n):
                A[p, i, j] = dtype(0.0)
        add_rows(q_a, k_a, loc_a, p, r, A)
        add_rows(q_b, k_b, loc_b, p, r, A)
        add_rows(q_c, k_c, loc_c, p, r, A)
        ok = int(1)
        norm2 = dtype(0.0)
        for i in range(n):
            ks = f * spring_k[p, i]
            ri = r[p, i] - ks * (q[p, i] - kin[p, i])
            if i == out_index:
                ri = ri + torque[p]
            A[p, i, i] = A[p, i, i] + ks
            if free[i] == 0:
                ri = dtype(0.0)
                for j in range(n):
                    A[p, i, j] = dtype(0.0)
                    A[p, j, i] = dtype(0.0)
            r[p, i] = ri
            norm2 = norm2 + ri * ri
        for i in range(n):
            if free[i] == 0:
                A[p, i, i] = dtype(1.0)
            for j in range(n):
                if not wp.isfinite(A[p, i, j]):
                    ok = int(0)
        norm = wp.sqrt(norm2)
        if not wp.isfinite(norm):
            ok = int(0)
        residual[p] = norm
        converged = int(0)
        if ok != 0 and norm <= abs_tol:
            converged = int(1)
        if ok != 0:
            # Gaussian elimination with partial pivoting on (A | r), back substitution into dq
            ok = lu_solve(A, r, dq, p, n)
        mt = dtype(0.0)
        mr = dtype(0.0)
        if ok != 0:
            for i in range(n):
                x = dq[p, i]
                if not wp.isfinite(x):
                    ok = int(0)
                if i % 3 == 2:
                    mr = wp.max(mr, wp.abs(x))
                else:
                    mt = wp.max(mt, wp.abs(x))
        if ok != 0:
            scale = dtype(1.0)
            if converged == 0:
                if mt > max_step_translation:
                    scale = max_step_translation / mt
                if mr * scale > max_step_rotation:
                    scale = max_step_rotation / mr
            iters[p] = iters[p] + 1
            for i in range(n):
                qi = q[p, i] + scale * dq[p, i]
                q[p, i] = qi
                dev = wp.abs(qi - kin[p, i])
                if i % 3 == 2:
                    if dev > bound_rotation:
                        ok = int(0)
                elif dev > bound_translation:
                    ok = int(0)
        if ok != 0 and converged != 0:
            if stage[p] == WARM or stage[p] == stiffening.shape[0] - 1:
                status[p] = CONVERGED
            else:
                stage[p] = stage[p] + 1
                iters[p] = 0
        elif ok == 0 or iters[p] >= max_iterations:
            if stage[p] == WARM and homotopy != 0:
                stage[p] = 0
                iters[p] = 0
                for i in range(n):
                    q[p, i] = kin[p, i]
            else:
                status[p] = FAILED
        if status[p] == ACTIVE:
            wp.atomic_add(active, 0, 1)

    @wp.kernel(module="unique")
    def sweep_gate(
        # Model:
        cap: int,
        # Data out:
        counter: wp.array(dtype=wp.int32),
        active: wp.array(dtype=wp.int32),
    ):
        """Count the sweeps of a loop and end it (active = 0) after ``cap`` of them."""
        counter[0] = counter[0] + 1
        if counter[0] >= cap:
            active[0] = 0

    @wp.kernel(module="unique")
    def gather_rows(
        # Model:
        rows: wp.array3d(dtype=dtype),
        # Data in:
        variant: wp.array(dtype=wp.int32),
        # Data out:
        out: wp.array2d(dtype=dtype),
    ):
        """Row r of copy p = row r of its variant: out[p R + r, :] = rows[variant[p], r, :]."""
        p, r = wp.tid()
        nr = rows.shape[1]
        for c in range(rows.shape[2]):
            out[p * nr + r, c] = rows[variant[p], r, c]

    @wp.kernel(module="unique")
    def gather_bodies(
        # Model:
        rows: wp.array3d(dtype=wp.int32),
        body_cols: wp.array(dtype=wp.int32),
        nb: int,
        ground: int,
        # Data in:
        variant: wp.array(dtype=wp.int32),
        # Data out:
        out: wp.array2d(dtype=wp.int32),
    ):
        """Integer rows of copy p from its variant's, with the body columns made global: copy p
        owns bodies p nb .. p nb + nb - 1, a local index >= nb is the pose array's ground row
        ``ground`` (its last row, which stays zero)."""
        p, r = wp.tid()
        nr = rows.shape[1]
        for c in range(rows.shape[2]):
            v = rows[variant[p], r, c]
            for k in range(body_cols.shape[0]):
                if body_cols[k] == c:
                    if v >= nb:
                        v = ground
                    else:
                        v = p * nb + v
            out[p * nr + r, c] = v

    return scatter_poses, newton_step, sweep_gate, gather_rows, gather_bodies
