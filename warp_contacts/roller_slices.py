"""Warp kernel of the influence-coefficient roller slices (paper Eq. (bearing_ic)): one thread per
roller, float64, all rollers of all bearings in one launch. Mirrors
:mod:`warp_contacts.roller_slices_ref` step by step (Galerkin strip compliance of both races,
half-width modes and their fixed point, Murty's least-index principal pivoting, the tangent
M_AA^-1 with the half-width term); that module documents the equations, the parameter columns and
the outputs. The active blocks are factored without pivoting (C_AA and M_AA are P-matrices: every
leading principal minor is positive, so no pivot vanishes).

Per-roller scratch (compliance and its half-width derivatives, the LU factor of the active block,
work vectors, active flags) lives in device arrays owned by :class:`RollerSliceKernel`, sized by the
largest slice count.
"""
import functools

import numpy as np
import warp as wp

from .planar import LaunchBuffers
from .precision import resolve_device
from .roller_slices_ref import (B_FLOOR_FRACTION, HALF_WIDTH_FIXED, HALF_WIDTH_ROLLER_LOAD, HALF_WIDTH_SLICE_LOAD,
                                LCP_RTOL, MAX_HALF_WIDTH_ITERATIONS, MAX_PIVOTS, N_QUAD, NEWTON_RTOL,
                                N_SLICE_FLOAT, N_SLICE_INT, SI_COUNT, SI_MODE, SIN_Q, SL_BIN, SL_BOUT, SL_DY, SL_ESTAR,
                                SL_LEN, SL_RIN, SL_ROUT, W_Q)

f64 = wp.float64
# scratch slots of the per-roller work vectors: forces, right-hand side, strip integrals I_k, dI_k/db
W_F, W_RHS, W_I, W_DI = 0, 1, 2, 3
N_WORK = 4


@functools.lru_cache(maxsize=None)
def _kernel():
    zero, one, two = f64(0.0), f64(1.0), f64(2.0)
    pi = f64(np.pi)
    rtol = f64(LCP_RTOL)
    newton_rtol = f64(NEWTON_RTOL)
    floor_frac = f64(B_FLOOR_FRACTION)

    @wp.func
    def smooth_h(u: f64, c: f64):
        """S(u, c) = |u| ln(|u| + sqrt(u^2 + c^2)) - sqrt(u^2 + c^2) and dS/dc."""
        a = wp.abs(u)
        r = wp.sqrt(a * a + c * c)
        if a > zero:
            return a * wp.log(a + r) - r, a * c / (r * (a + r)) - c / r
        return -r, -c / r

    @wp.func
    def strips(j: int, n: int, dy: f64, b: f64, sin_q: wp.array(dtype=f64), w_q: wp.array(dtype=f64),
               work: wp.array3d(dtype=f64)):
        """I_k(b) and dI_k/db, k < n, into work[j, W_I], work[j, W_DI] (Galerkin strip integrals of the
        reference): per node, S at |u| = 0, dy, ..., n dy once, the second differences from them."""
        for k in range(n):
            work[j, W_I, k] = zero
            work[j, W_DI, k] = zero
        for q in range(N_QUAD):
            c = b * sin_q[q]
            s0, d0 = smooth_h(zero, c)
            s1, d1 = smooth_h(dy, c)
            sm = s1          # S(|-dy|)
            dm = d1
            for k in range(n):
                sp, dp = smooth_h(f64(k + 1) * dy, c)
                work[j, W_I, k] = work[j, W_I, k] + w_q[q] * (sp - two * s0 + sm)
                work[j, W_DI, k] = work[j, W_DI, k] + w_q[q] * (dp - two * d0 + dm) * sin_q[q]
                sm = s0
                dm = d0
                s0 = sp
                d0 = dp
        for k in range(n):
            work[j, W_I, k] = work[j, W_I, k] / dy
            work[j, W_DI, k] = work[j, W_DI, k] / dy
        work[j, W_I, 0] = work[j, W_I, 0] + two * wp.log(two / b) + one
        work[j, W_DI, 0] = work[j, W_DI, 0] - two / b

    @wp.func
    def fill_compliance(j: int, n: int, mode: int, dy: f64, scale: f64, hw: wp.array3d(dtype=f64),
                        sin_q: wp.array(dtype=f64), w_q: wp.array(dtype=f64), cm: wp.array3d(dtype=f64),
                        dcm: wp.array4d(dtype=f64), work: wp.array3d(dtype=f64)):
        """C (cm[j]) and dC/db_r (dcm[j, r]) at the half-widths hw[j] (2, n)."""
        if mode == HALF_WIDTH_SLICE_LOAD:
            for c in range(n):
                for i in range(n):
                    cm[j, i, c] = zero
                for r in range(2):
                    strips(j, n, dy, hw[j, r, c], sin_q, w_q, work)
                    for i in range(n):
                        k = wp.abs(i - c)
                        cm[j, i, c] = cm[j, i, c] + scale * work[j, W_I, k]
                        dcm[j, r, i, c] = scale * work[j, W_DI, k]
        else:
            # one half-width per race: a symmetric Toeplitz matrix from its first column
            for k in range(n):
                cm[j, k, 0] = zero
            for r in range(2):
                strips(j, n, dy, hw[j, r, 0], sin_q, w_q, work)
                for k in range(n):
                    cm[j, k, 0] = cm[j, k, 0] + scale * work[j, W_I, k]
                    dcm[j, r, k, 0] = scale * work[j, W_DI, k]
            for c in range(1, n):
                for i in range(n):
                    k = wp.abs(i - c)
                    cm[j, i, c] = cm[j, k, 0]
                    dcm[j, 0, i, c] = dcm[j, 0, k, 0]
                    dcm[j, 1, i, c] = dcm[j, 1, k, 0]

    @wp.func
    def update_half_widths(j: int, n: int, mode: int, fp: wp.array2d(dtype=f64), f: wp.array3d(dtype=f64),
                           hw: wp.array3d(dtype=f64)):
        """Half-widths of the load modes at the forces work[j, W_F] into hw[j]."""
        dy = fp[j, SL_DY]
        es = fp[j, SL_ESTAR]
        floor = floor_frac * dy
        total = zero
        for i in range(n):
            total += f[j, W_F, i]
        for r in range(2):
            radius = fp[j, SL_RIN]
            if r == 1:
                radius = fp[j, SL_ROUT]
            for i in range(n):
                q = total / fp[j, SL_LEN]
                if mode == HALF_WIDTH_SLICE_LOAD:
                    q = wp.max(f[j, W_F, i], zero) / dy
                hw[j, r, i] = wp.max(wp.sqrt(f64(4.0) * wp.max(q, zero) * radius / (pi * es)), floor)

    @wp.func
    def add_half_width_term(j: int, n: int, mode: int, floor: f64, hw: wp.array3d(dtype=f64),
                            dcm: wp.array4d(dtype=f64), work: wp.array3d(dtype=f64), cm: wp.array3d(dtype=f64)):
        """cm[j] += D: M = C + D of the tangent (the reference's half_width_term)."""
        total = zero
        for i in range(n):
            total += work[j, W_F, i]
        if mode == HALF_WIDTH_ROLLER_LOAD:
            ok = total > zero
            for r in range(2):
                if hw[j, r, 0] <= floor:
                    ok = False
            if ok:
                for i in range(n):
                    v = zero
                    for r in range(2):
                        for k in range(n):
                            v += dcm[j, r, i, k] * work[j, W_F, k] * hw[j, r, 0]
                    v = v / (two * total)
                    for c in range(n):
                        cm[j, i, c] = cm[j, i, c] + v
        if mode == HALF_WIDTH_SLICE_LOAD:
            for c in range(n):
                for r in range(2):
                    b = hw[j, r, c]
                    if b > floor:
                        for i in range(n):
                            cm[j, i, c] = cm[j, i, c] + f64(0.5) * dcm[j, r, i, c] * b

    @wp.func
    def gather(j: int, n: int, act: wp.array2d(dtype=wp.int32), idx: wp.array2d(dtype=wp.int32)):
        """Active slice indices into idx[j, :m]; returns m."""
        m = int(0)
        for i in range(n):
            if act[j, i] != 0:
                idx[j, m] = i
                m += 1
        return m

    @wp.func
    def factor(j: int, m: int, idx: wp.array2d(dtype=wp.int32), mat: wp.array3d(dtype=f64),
               lu: wp.array3d(dtype=f64)):
        """LU (Doolittle, no pivoting) of the active block mat[j][A, A] into lu[j, :m, :m]."""
        for a in range(m):
            for c in range(m):
                lu[j, a, c] = mat[j, idx[j, a], idx[j, c]]
        for k in range(m):
            for a in range(k + 1, m):
                lu[j, a, k] = lu[j, a, k] / lu[j, k, k]
                for c in range(k + 1, m):
                    lu[j, a, c] = lu[j, a, c] - lu[j, a, k] * lu[j, k, c]

    @wp.func
    def substitute(j: int, m: int, lu: wp.array3d(dtype=f64), work: wp.array3d(dtype=f64), slot: int):
        """Solve (LU) x = work[j, slot, :m] in place."""
        for a in range(m):
            acc = work[j, slot, a]
            for k in range(a):
                acc -= lu[j, a, k] * work[j, slot, k]
            work[j, slot, a] = acc
        for t in range(m):
            a = m - 1 - t
            acc = work[j, slot, a]
            for k in range(a + 1, m):
                acc -= lu[j, a, k] * work[j, slot, k]
            work[j, slot, a] = acc / lu[j, a, a]

    @wp.func
    def murty(j: int, n: int, s_in: wp.array2d(dtype=f64), act: wp.array2d(dtype=wp.int32),
              idx: wp.array2d(dtype=wp.int32), cm: wp.array3d(dtype=f64), lu: wp.array3d(dtype=f64),
              work: wp.array3d(dtype=f64)):
        """Exact LCP solution into work[j, W_F, :n] from the active set act[j]; returns the pivots."""
        smax = zero
        for i in range(n):
            smax = wp.max(smax, wp.abs(s_in[j, i]))
        tol = rtol * smax
        pivots = int(0)
        for it in range(MAX_PIVOTS + 1):
            m = gather(j, n, act, idx)
            factor(j, m, idx, cm, lu)
            for a in range(m):
                work[j, W_RHS, a] = s_in[j, idx[j, a]]
            substitute(j, m, lu, work, W_RHS)
            for i in range(n):
                work[j, W_F, i] = zero
            for a in range(m):
                work[j, W_F, idx[j, a]] = work[j, W_RHS, a]
            bad = int(-1)
            for i in range(n):
                if bad < 0:
                    if act[j, i] != 0:
                        if work[j, W_F, i] < zero:
                            bad = i
                    else:
                        w = -s_in[j, i]
                        for k in range(n):
                            w += cm[j, i, k] * work[j, W_F, k]
                        if w < -tol:
                            bad = i
            if bad < 0:
                return pivots
            act[j, bad] = 1 - act[j, bad]
            pivots += 1
        # the pivots ran out (C not a P-matrix): NaN forces, the evaluation reports itself non-finite
        for i in range(n):
            work[j, W_F, i] = f64(wp.nan)
        return pivots

    @wp.kernel(module="unique")
    def solve_slices(
        # Model:
        fp: wp.array2d(dtype=f64),
        ip: wp.array2d(dtype=wp.int32),
        sin_q: wp.array(dtype=f64),
        w_q: wp.array(dtype=f64),
        # Data in:
        s_in: wp.array2d(dtype=f64),
        # Scratch:
        cm: wp.array3d(dtype=f64),
        dcm: wp.array4d(dtype=f64),
        lu: wp.array3d(dtype=f64),
        work: wp.array3d(dtype=f64),
        act: wp.array2d(dtype=wp.int32),
        idx: wp.array2d(dtype=wp.int32),
        # Data out:
        f_out: wp.array2d(dtype=f64),
        J_out: wp.array3d(dtype=f64),
        hw_out: wp.array3d(dtype=f64),
        na_out: wp.array(dtype=wp.int32),
    ):
        j = wp.tid()
        n = ip[j, SI_COUNT]
        mode = ip[j, SI_MODE]
        dy = fp[j, SL_DY]
        scale = one / (pi * fp[j, SL_ESTAR] * dy)
        floor = floor_frac * dy
        for i in range(n):
            hw_out[j, 0, i] = fp[j, SL_BIN]
            hw_out[j, 1, i] = fp[j, SL_BOUT]
            act[j, i] = 0
            if s_in[j, i] > zero:
                act[j, i] = 1
        # the first solve at the fixed half-widths: one per race, the Toeplitz fill
        fill_compliance(j, n, HALF_WIDTH_FIXED, dy, scale, hw_out, sin_q, w_q, cm, dcm, work)
        murty(j, n, s_in, act, idx, cm, lu, work)
        if mode != HALF_WIDTH_FIXED:
            for it in range(MAX_HALF_WIDTH_ITERATIONS):
                # Newton on C(b(f)) f_A = s_A, the active set held (see the reference)
                update_half_widths(j, n, mode, fp, work, hw_out)
                fill_compliance(j, n, mode, dy, scale, hw_out, sin_q, w_q, cm, dcm, work)
                m = gather(j, n, act, idx)
                for a in range(m):
                    res = -s_in[j, idx[j, a]]
                    for k in range(n):
                        res += cm[j, idx[j, a], k] * work[j, W_F, k]
                    work[j, W_RHS, a] = res
                add_half_width_term(j, n, mode, floor, hw_out, dcm, work, cm)
                factor(j, m, idx, cm, lu)
                substitute(j, m, lu, work, W_RHS)
                step = zero
                fmax = zero
                left = int(0)
                for a in range(m):
                    fa = work[j, W_F, idx[j, a]] - work[j, W_RHS, a]
                    work[j, W_F, idx[j, a]] = fa
                    step = wp.max(step, wp.abs(work[j, W_RHS, a]))
                    fmax = wp.max(fmax, wp.abs(fa))
                    if fa <= zero:
                        left = 1
                converged = step <= newton_rtol * fmax
                if converged or left == 1:
                    update_half_widths(j, n, mode, fp, work, hw_out)
                    fill_compliance(j, n, mode, dy, scale, hw_out, sin_q, w_q, cm, dcm, work)
                    p = murty(j, n, s_in, act, idx, cm, lu, work)
                    if converged and p == 0:
                        break
        # tangent: M = C + D on the active block, J_AA = M_AA^-1
        for i in range(n):
            f_out[j, i] = work[j, W_F, i]
        add_half_width_term(j, n, mode, floor, hw_out, dcm, work, cm)
        m = gather(j, n, act, idx)
        for r in range(n):
            for c in range(n):
                J_out[j, r, c] = zero
        factor(j, m, idx, cm, lu)
        for c in range(m):
            for a in range(m):
                work[j, W_RHS, a] = zero
            work[j, W_RHS, c] = one
            substitute(j, m, lu, work, W_RHS)
            for a in range(m):
                J_out[j, idx[j, a], idx[j, c]] = work[j, W_RHS, a]
        na_out[j] = m

    return solve_slices


class RollerSliceKernel:
    """Device-resident influence-coefficient slice solver for R rollers (one recorded launch per call).

    fparams (R, N_SLICE_FLOAT), iparams (R, N_SLICE_INT): the columns of
    :mod:`warp_contacts.roller_slices_ref`. float64 only (the active-set decisions and the
    Cholesky factor of a stiff Toeplitz block need it). ``evaluate(s)`` returns the same
    (f, J, half-widths, active counts) as :func:`roller_slices_ref.evaluate`.
    """

    def __init__(self, fparams, iparams, device="cpu"):
        fparams = np.ascontiguousarray(fparams, np.float64)
        iparams = np.ascontiguousarray(iparams, np.int32)
        assert fparams.shape[1] == N_SLICE_FLOAT and iparams.shape[1] == N_SLICE_INT
        R = len(fparams)
        n = int(iparams[:, SI_COUNT].max())
        self.n_max = n
        self.device = d = resolve_device(device, R * n)
        self._buf = LaunchBuffers({"s": ((R, n), "f"), "f": ((R, n), "f"), "J": ((R, n, n), "f"),
                                   "hw": ((R, 2, n), "f"), "na": ((R,), "int")}, f64, np.float64, d)
        dev = self._buf.dev
        scratch = [wp.zeros((R, n, n), dtype=f64, device=d), wp.zeros((R, 2, n, n), dtype=f64, device=d),
                   wp.zeros((R, n, n), dtype=f64, device=d), wp.zeros((R, N_WORK, n), dtype=f64, device=d),
                   wp.zeros((R, n), dtype=wp.int32, device=d), wp.zeros((R, n), dtype=wp.int32, device=d)]
        self._cmd = wp.launch(_kernel(), dim=R, device=d,
                              inputs=[wp.array(fparams, dtype=f64, device=d),
                                      wp.array(iparams, dtype=wp.int32, device=d),
                                      wp.array(SIN_Q, dtype=f64, device=d), wp.array(W_Q, dtype=f64, device=d),
                                      dev["s"]] + scratch,
                              outputs=[dev[k] for k in ("f", "J", "hw", "na")], record_cmd=True)

    def evaluate(self, s):
        """Slice approaches s (R, n_max) [m] -> (f, J, half-widths, active counts), arrays owned by
        this object and overwritten by the next call."""
        h = self._buf.host
        h["s"][...] = s
        self._buf.upload(("s",))
        self._cmd.launch()
        self._buf.download(("f", "J", "hw", "na"))
        return h["f"], h["J"], h["hw"], h["na"]
