"""Warp kernel of the influence-coefficient roller slices (paper Eq. (bearing_ic)): one thread per
roller, float64, all rollers of all bearings in one launch. Mirrors
:mod:`warp_contacts.roller_slices_ref` step by step (compliance columns, Lawson--Hanson active set
with warm start, line-load half-width fixed point, Schur-complement tangent with the rank-one
half-width term); that module documents the equations, the parameter columns and the outputs.

Per-roller scratch (Toeplitz columns, Cholesky factor of the active block, work vectors, active
flags) lives in device arrays owned by :class:`RollerSliceKernel`, sized by the largest slice count.
"""
import functools

import numpy as np
import warp as wp

from .planar import LaunchBuffers
from .precision import resolve_device
from .roller_slices_ref import (B_FLOOR_FRACTION, HALF_WIDTH_LINE_LOAD, HALF_WIDTH_RTOL, HW_IN, HW_OUT, LCP_RTOL,
                                MAX_ACTIVE_SET_STEPS, MAX_HALF_WIDTH_ITERATIONS, N_QUAD, N_SLICE_FLOAT, N_SLICE_INT,
                                SI_COUNT, SI_MODE, SIN_Q, SL_BIN, SL_BOUT, SL_DY, SL_ESTAR, SL_LEN, SL_RIN, SL_ROUT,
                                W_Q)

f64 = wp.float64
# scratch slots of the per-roller work vectors
W_Z, W_RHS, W_T = 0, 1, 2
N_WORK = 3
# column slots: compliance C_l, dC/db of the inner race, dC/db of the outer race
C_L, C_DIN, C_DOUT = 0, 1, 2


@functools.lru_cache(maxsize=None)
def _kernel():
    zero, one, half, two = f64(0.0), f64(1.0), f64(0.5), f64(2.0)
    pi = f64(np.pi)
    rtol = f64(LCP_RTOL)
    hw_rtol = f64(HALF_WIDTH_RTOL)
    floor_frac = f64(B_FLOOR_FRACTION)

    @wp.func
    def log_term(Y: f64, c: f64):
        """sgn(Y) ln(|Y| + sqrt(Y^2 + c^2)) and its c-derivative."""
        a = wp.abs(Y)
        r = wp.sqrt(a * a + c * c)
        sg = one
        if Y < zero:
            sg = -one
        return sg * wp.log(a + r), sg * c / (r * (a + r))

    @wp.func
    def race_columns(j: int, n: int, dy: f64, b: f64, scale: f64, sin_q: wp.array(dtype=f64),
                     w_q: wp.array(dtype=f64), col: wp.array3d(dtype=f64), slot: int):
        """Add this race's Toeplitz column to col[j, C_L] and write its b-derivative to col[j, slot]."""
        for k in range(n):
            kk = f64(k)
            Y1 = (kk - half) * dy
            Y2 = (kk + half) * dy
            I = zero
            dI = zero
            for q in range(N_QUAD):
                c = b * sin_q[q]
                l2, d2 = log_term(Y2, c)
                l1, d1 = log_term(Y1, c)
                I += w_q[q] * (l2 - l1)
                dI += w_q[q] * (d2 - d1) * sin_q[q]
            if k == 0:
                I += two * wp.log(two / b) + one
                dI -= two / b
            col[j, C_L, k] = col[j, C_L, k] + scale * I
            col[j, slot, k] = scale * dI

    @wp.func
    def columns(j: int, n: int, dy: f64, es: f64, b_in: f64, b_out: f64, sin_q: wp.array(dtype=f64),
                w_q: wp.array(dtype=f64), col: wp.array3d(dtype=f64)):
        for k in range(n):
            col[j, C_L, k] = zero
        scale = one / (pi * es * dy)
        race_columns(j, n, dy, b_in, scale, sin_q, w_q, col, C_DIN)
        race_columns(j, n, dy, b_out, scale, sin_q, w_q, col, C_DOUT)

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
    def factor(j: int, m: int, idx: wp.array2d(dtype=wp.int32), col: wp.array3d(dtype=f64),
               chol: wp.array3d(dtype=f64)):
        """Cholesky factor of the active block C_AA into chol[j, :m, :m] (lower)."""
        for a in range(m):
            for c in range(a + 1):
                acc = col[j, C_L, wp.abs(idx[j, a] - idx[j, c])]
                for k in range(c):
                    acc -= chol[j, a, k] * chol[j, c, k]
                if a == c:
                    chol[j, a, a] = wp.sqrt(acc)
                else:
                    chol[j, a, c] = acc / chol[j, c, c]

    @wp.func
    def substitute(j: int, m: int, chol: wp.array3d(dtype=f64), work: wp.array3d(dtype=f64), slot: int):
        """Solve C_AA x = work[j, slot, :m] in place with the factor."""
        for a in range(m):
            acc = work[j, slot, a]
            for k in range(a):
                acc -= chol[j, a, k] * work[j, slot, k]
            work[j, slot, a] = acc / chol[j, a, a]
        for t in range(m):
            a = m - 1 - t
            acc = work[j, slot, a]
            for k in range(a + 1, m):
                acc -= chol[j, k, a] * work[j, slot, k]
            work[j, slot, a] = acc / chol[j, a, a]

    @wp.func
    def subproblem(j: int, n: int, s_in: wp.array2d(dtype=f64), act: wp.array2d(dtype=wp.int32),
                   idx: wp.array2d(dtype=wp.int32), col: wp.array3d(dtype=f64), chol: wp.array3d(dtype=f64),
                   work: wp.array3d(dtype=f64)):
        """z = C_AA^-1 s_A scattered into work[j, W_Z, :n] (zero off A); returns 1 when z_A > 0."""
        m = gather(j, n, act, idx)
        factor(j, m, idx, col, chol)
        for a in range(m):
            work[j, W_RHS, a] = s_in[j, idx[j, a]]
        substitute(j, m, chol, work, W_RHS)
        for i in range(n):
            work[j, W_Z, i] = zero
        positive = int(1)
        for a in range(m):
            work[j, W_Z, idx[j, a]] = work[j, W_RHS, a]
            if work[j, W_RHS, a] <= zero:
                positive = 0
        return positive

    @wp.func
    def lawson_hanson(j: int, n: int, s_in: wp.array2d(dtype=f64), act: wp.array2d(dtype=wp.int32),
                      idx: wp.array2d(dtype=wp.int32), col: wp.array3d(dtype=f64), chol: wp.array3d(dtype=f64),
                      work: wp.array3d(dtype=f64), f: wp.array2d(dtype=f64)):
        """Exact LCP solution into f[j, :n], warm-started from act[j]; returns the steps taken."""
        smax = zero
        n_act = int(0)
        for i in range(n):
            smax = wp.max(smax, wp.abs(s_in[j, i]))
            f[j, i] = zero
            n_act += act[j, i]
        tol = rtol * smax
        if n_act > 0:
            if subproblem(j, n, s_in, act, idx, col, chol, work) == 1:
                for i in range(n):
                    f[j, i] = work[j, W_Z, i]
            else:
                for i in range(n):
                    act[j, i] = 0
        steps = int(0)
        while steps < MAX_ACTIVE_SET_STEPS:
            best = int(-1)
            bv = tol
            for i in range(n):
                if act[j, i] == 0:
                    g = s_in[j, i]
                    for k in range(n):
                        g -= col[j, C_L, wp.abs(i - k)] * f[j, k]
                    if g > bv:
                        bv = g
                        best = i
            if best < 0:
                break
            act[j, best] = 1
            settled = int(0)
            while settled == 0 and steps < MAX_ACTIVE_SET_STEPS:
                steps += 1
                if subproblem(j, n, s_in, act, idx, col, chol, work) == 1:
                    for i in range(n):
                        f[j, i] = work[j, W_Z, i]
                    settled = 1
                else:
                    alpha = one
                    for i in range(n):
                        z = work[j, W_Z, i]
                        if act[j, i] != 0 and z <= zero:
                            den = f[j, i] - z
                            ratio = zero
                            if den > zero:
                                ratio = f[j, i] / den
                            alpha = wp.min(alpha, ratio)
                    for i in range(n):
                        if act[j, i] != 0:
                            fi = f[j, i] + alpha * (work[j, W_Z, i] - f[j, i])
                            if fi <= zero:
                                fi = zero
                                act[j, i] = 0
                            f[j, i] = fi
        return steps

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
        col: wp.array3d(dtype=f64),
        chol: wp.array3d(dtype=f64),
        work: wp.array3d(dtype=f64),
        act: wp.array2d(dtype=wp.int32),
        idx: wp.array2d(dtype=wp.int32),
        # Data out:
        f_out: wp.array2d(dtype=f64),
        J_out: wp.array3d(dtype=f64),
        hw_out: wp.array2d(dtype=f64),
        na_out: wp.array(dtype=wp.int32),
    ):
        j = wp.tid()
        n = ip[j, SI_COUNT]
        line_load = ip[j, SI_MODE] == HALF_WIDTH_LINE_LOAD
        dy = fp[j, SL_DY]
        es = fp[j, SL_ESTAR]
        b_in = fp[j, SL_BIN]
        b_out = fp[j, SL_BOUT]
        floor = floor_frac * dy
        for i in range(n):
            act[j, i] = 0
            if s_in[j, i] > zero:
                act[j, i] = 1
        iters = int(1)
        if line_load:
            iters = MAX_HALF_WIDTH_ITERATIONS
        for it in range(iters):
            columns(j, n, dy, es, b_in, b_out, sin_q, w_q, col)
            lawson_hanson(j, n, s_in, act, idx, col, chol, work, f_out)
            if line_load:
                F = zero
                for i in range(n):
                    F += f_out[j, i]
                q = wp.max(F, zero) / fp[j, SL_LEN]
                bi = wp.max(wp.sqrt(f64(4.0) * q * fp[j, SL_RIN] / (pi * es)), floor)
                bo = wp.max(wp.sqrt(f64(4.0) * q * fp[j, SL_ROUT] / (pi * es)), floor)
                done = wp.abs(bi - b_in) <= hw_rtol * bi and wp.abs(bo - b_out) <= hw_rtol * bo
                b_in = bi
                b_out = bo
                if done:
                    columns(j, n, dy, es, b_in, b_out, sin_q, w_q, col)
                    lawson_hanson(j, n, s_in, act, idx, col, chol, work, f_out)
                    break
        # tangent: C_AA^-1 on the active block
        m = gather(j, n, act, idx)
        for r in range(n):
            for c in range(n):
                J_out[j, r, c] = zero
        factor(j, m, idx, col, chol)
        for c in range(m):
            for a in range(m):
                work[j, W_RHS, a] = zero
            work[j, W_RHS, c] = one
            substitute(j, m, chol, work, W_RHS)
            for a in range(m):
                J_out[j, idx[j, a], idx[j, c]] = work[j, W_RHS, a]
        if line_load and m > 0:
            F = zero
            for i in range(n):
                F += f_out[j, i]
            if F > zero and b_in > floor and b_out > floor:
                # v = sum_r dC_AA/db_r f_A b_r / (2F); u = C_AA^-1 v; J -= u colsum^T / (1 + sum u)
                for a in range(m):
                    v = zero
                    for c in range(m):
                        dk = wp.abs(idx[j, a] - idx[j, c])
                        v += (col[j, C_DIN, dk] * b_in + col[j, C_DOUT, dk] * b_out) * f_out[j, idx[j, c]]
                    work[j, W_T, a] = v / (two * F)
                su = zero
                for a in range(m):
                    u = zero
                    for c in range(m):
                        u += J_out[j, idx[j, a], idx[j, c]] * work[j, W_T, c]
                    work[j, W_Z, a] = u
                    su += u
                for c in range(m):
                    cs = zero
                    for a in range(m):
                        cs += J_out[j, idx[j, a], idx[j, c]]
                    work[j, W_RHS, c] = cs
                for a in range(m):
                    for c in range(m):
                        J_out[j, idx[j, a], idx[j, c]] = (J_out[j, idx[j, a], idx[j, c]]
                                                          - work[j, W_Z, a] * work[j, W_RHS, c] / (one + su))
        hw_out[j, HW_IN] = b_in
        hw_out[j, HW_OUT] = b_out
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
                                   "hw": ((R, 2), "f"), "na": ((R,), "int")}, f64, np.float64, d)
        dev = self._buf.dev
        scratch = [wp.zeros((R, 3, n), dtype=f64, device=d), wp.zeros((R, n, n), dtype=f64, device=d),
                   wp.zeros((R, N_WORK, n), dtype=f64, device=d), wp.zeros((R, n), dtype=wp.int32, device=d),
                   wp.zeros((R, n), dtype=wp.int32, device=d)]
        self._cmd = wp.launch(_kernel(), dim=R, device=d,
                              inputs=[wp.array(fparams, dtype=f64, device=d), wp.array(iparams, dtype=wp.int32, device=d),
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
