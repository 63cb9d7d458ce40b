"""Warp kernels: one copy's generalized-alpha Newton iteration on the device, for the row stepper
(:mod:`rvtool.solver.row_dynamics`, ``device_step``), so that an iteration moves only the
residual norm to the host.

Notation of :mod:`warp_contacts.fused_step_ref` (Exudyn's step): n coordinates, the free ones
``free`` (nf) and the fixed ones ``fixed`` (the drive and the locks), masses M (n,), the
step's constants coef = (s, beta', gamma'), the force sums ``sums`` = [f (n) | K (n n) | C (n n)]
(:class:`warp_contacts.row_gather.RowGather`'s output; f without the output torque).

* ``newton_update`` (one thread): J_ff = s (beta' M - K - gamma' C) on the free block, solved
  in place for D_f = J_ff^-1 s r_f (:func:`warp_contacts.dense_lu.lu_funcs`, partial pivoting),
  the fixed rows' multipliers lambda_x -= (s r_x - J_xf D_f) / s, q_f -= D_f,
  v_f -= gamma' D_f, a_f -= beta' D_f, and the bodies' absolute poses (reference + q) and
  velocities written into the evaluation's staging arrays; a zero pivot sets status[1] = 1;
* ``residual`` (one thread): r = M a - (f + torque e_out) + lambda and its norm |r| into
  status[0] (status: the one array the host reads per iteration).

NumPy reference: :meth:`rvtool.solver.row_dynamics.RowDrivenModel.attempt` with the host step
(the same formulas; the solve and the norm in another order: last bits).
"""
import functools

import warp as wp

from .dense_lu import lu_funcs


@functools.lru_cache(maxsize=None)
def kernels():
    """(newton_update, residual) in float64."""
    dt = wp.float64
    lu_solve = lu_funcs(dt)

    @wp.kernel(module="unique")
    def newton_update(
        # Model:
        mass: wp.array(dtype=dt),
        free: wp.array(dtype=wp.int32),
        fixed: wp.array(dtype=wp.int32),
        reference: wp.array(dtype=dt),
        # Data in:
        coef: wp.array(dtype=dt),
        sums: wp.array(dtype=dt),
        r: wp.array(dtype=dt),
        # Data in/out:
        J: wp.array3d(dtype=dt),
        rhs: wp.array2d(dtype=dt),
        d: wp.array2d(dtype=dt),
        q: wp.array(dtype=dt),
        v: wp.array(dtype=dt),
        a: wp.array(dtype=dt),
        lam: wp.array(dtype=dt),
        # Data out:
        pose: wp.array2d(dtype=dt),
        vel: wp.array2d(dtype=dt),
        status: wp.array(dtype=dt),
    ):
        n = q.shape[0]
        nf = free.shape[0]
        sc = coef[0]
        bp = coef[1]
        gp = coef[2]
        for i in range(nf):
            fi = free[i]
            for j in range(nf):
                fj = free[j]
                m = dt(0.0)
                if i == j:
                    m = mass[fi]
                J[0, i, j] = sc * (bp * m - sums[n + fi * n + fj] - gp * sums[n + n * n + fi * n + fj])
            rhs[0, i] = sc * r[fi]
        ok = lu_solve(J, rhs, d, 0, nf)
        if ok == 0:
            status[1] = dt(1.0)
            return
        for k in range(fixed.shape[0]):
            xk = fixed[k]
            s = dt(0.0)
            for j in range(nf):
                fj = free[j]
                s += sc * (dt(0.0) - sums[n + xk * n + fj] - gp * sums[n + n * n + xk * n + fj]) * d[0, j]
            lam[xk] = lam[xk] - (sc * r[xk] - s) / sc
        for j in range(nf):
            fj = free[j]
            q[fj] = q[fj] - d[0, j]
            v[fj] = v[fj] - gp * d[0, j]
            a[fj] = a[fj] - bp * d[0, j]
        for b in range(n // 3):
            for c in range(3):
                pose[b, c] = reference[3 * b + c] + q[3 * b + c]
                vel[b, c] = v[3 * b + c]

    @wp.kernel(module="unique")
    def residual(
        # Model:
        mass: wp.array(dtype=dt),
        output_index: int,
        # Data in:
        torque: wp.array(dtype=dt),
        sums: wp.array(dtype=dt),
        a: wp.array(dtype=dt),
        lam: wp.array(dtype=dt),
        # Data out:
        r: wp.array(dtype=dt),
        status: wp.array(dtype=dt),
    ):
        acc = dt(0.0)
        for i in range(a.shape[0]):
            f = sums[i]
            if i == output_index:
                f = f + torque[0]
            ri = mass[i] * a[i] - f + lam[i]
            r[i] = ri
            acc += ri * ri
        status[0] = wp.sqrt(acc)

    return newton_update, residual


__all__ = ["kernels"]
