"""Fused dynamic stepper: one Warp launch advances B copies of a reducer by whole implicit steps.

One thread per copy performs Exudyn's generalized-alpha step of
:mod:`warp_contacts.fused_step_ref` (see there for the equations): predictor, Newton
iterations with the contact rows, the dense solve, the corrector, convergence, rejection with a
halved step, and the recording of the accepted step; it repeats until the copy has recorded
``n_steps`` accepted steps, reached the end time or failed. A launch therefore replaces
``n_steps`` x (iterations + 1) Python crossings of the Exudyn path by one.

The contact rows are evaluated by the row functions of the existing kernels (the kernels' own
bodies: :func:`warp_contacts.cycloid_pins.row_function` with the velocity tangent,
:func:`warp_contacts.output_pins.plain_row_function`,
:func:`warp_contacts.circle_pairs.row_function`) on the copy's own rows, and summed in a fixed
order by the copy's thread (deterministic: two runs are bit-identical). Frictionless or
regularized friction only (no anchors: their history would need a commit per accepted step).
"""
import functools

import numpy as np
import warp as wp

from . import circle_pairs, cycloid_pins, output_pins
from .circle_pairs_ref import N_OBS, O_FN
from .dense_lu import lu_funcs
from .fused_step_ref import (ACTIVE, C_ACCEPTED, C_NEWTON, C_RECORDED, C_REJECTED, C_RUN, DONE, FAILED, H_BEARING,
                             H_INPUT, H_NEWTON, H_OUTPUT, H_OUTPUT_PIN, H_PIN, H_STEP, H_TIME, H_TORQUE, M_ACCEL,
                             M_ANGLE, M_SPEED, N_COUNT, N_HISTORY, S_ABS_TOL, S_ALPHA_F, S_ALPHA_M, S_BETA, S_GAMMA,
                             S_H_MIN, S_H_NOM, S_MAX_IT, S_RECOVERY, S_RECOVERY_ITERATIONS, S_REL_TOL,
                             S_T_END, END_TOLERANCE)
from .output_pins_ref import N_SLICE_COLS
from .precision import resolve_device

__all__ = ["FusedStepper", "ACTIVE", "DONE", "FAILED"]


@functools.lru_cache(maxsize=None)
def kernels(dtype):
    """The fused step kernel for ``dtype``."""
    pin_row = cycloid_pins.row_function(dtype, True, False)
    op_row = output_pins.plain_row_function(dtype)
    brg_row = circle_pairs.row_function(dtype)
    lu_solve = lu_funcs(dtype)

    @wp.func
    def add_row(qr: wp.array2d(dtype=dtype), kr: wp.array3d(dtype=dtype), cr: wp.array3d(dtype=dtype), velocity: int,
                loc: wp.array2d(dtype=wp.int32), rr: int, row: int, p: int, f: wp.array2d(dtype=dtype),
                K: wp.array3d(dtype=dtype), C: wp.array3d(dtype=dtype)):
        """f[p] += the row's forces, K[p] += its dQ/dq, C[p] += its dQ/dv (velocity != 0)."""
        for ea in range(6):
            la = loc[rr, ea]
            if la >= 0:
                f[p, la] = f[p, la] + qr[row, ea]
                for eb in range(6):
                    lb = loc[rr, eb]
                    if lb >= 0:
                        K[p, la, lb] = K[p, la, lb] + kr[row, ea, eb]
                        if velocity != 0:
                            C[p, la, lb] = C[p, la, lb] + cr[row, ea, eb]

    @wp.func
    def evaluate_copy(
        p: int,
        # Model:
        pin_f: wp.array2d(dtype=dtype), pin_i: wp.array2d(dtype=wp.int32), tab_pts: wp.array2d(dtype=dtype),
        tab_nrm: wp.array2d(dtype=dtype), tab_kap: wp.array(dtype=dtype), tab_polar: wp.array(dtype=dtype),
        tab_offset: wp.array(dtype=wp.int32), tab_len: wp.array(dtype=wp.int32), tab_h: wp.array(dtype=dtype),
        tab_phi: wp.array(dtype=dtype), tab_ana: wp.array2d(dtype=dtype), window: int,
        pin_anchor: wp.array2d(dtype=dtype),
        op_f: wp.array2d(dtype=dtype), op_i: wp.array2d(dtype=wp.int32), stations: wp.array(dtype=dtype),
        brg_f: wp.array2d(dtype=dtype), brg_i: wp.array2d(dtype=wp.int32),
        loc_pin: wp.array2d(dtype=wp.int32), loc_op: wp.array2d(dtype=wp.int32), loc_brg: wp.array2d(dtype=wp.int32),
        reference: wp.array2d(dtype=dtype), torque: wp.array(dtype=dtype), output_index: int,
        # Data in:
        qt: wp.array2d(dtype=dtype), vt: wp.array2d(dtype=dtype),
        # Scratch and data out:
        pose: wp.array2d(dtype=dtype), vel: wp.array2d(dtype=dtype), tilt: wp.array2d(dtype=dtype),
        pin_q: wp.array2d(dtype=dtype), pin_k: wp.array3d(dtype=dtype), pin_c: wp.array3d(dtype=dtype),
        pin_obs: wp.array2d(dtype=dtype), pin_hact: wp.array(dtype=wp.int32), pin_ha: wp.array2d(dtype=dtype),
        op_q: wp.array2d(dtype=dtype), op_k: wp.array3d(dtype=dtype), op_tilt: wp.array3d(dtype=dtype),
        op_slices: wp.array3d(dtype=dtype), op_sdf: wp.array4d(dtype=dtype),
        b_q: wp.array2d(dtype=dtype), b_k: wp.array3d(dtype=dtype), b_c: wp.array3d(dtype=dtype),
        b_obs: wp.array2d(dtype=dtype), b_hact: wp.array(dtype=wp.int32), b_ha: wp.array2d(dtype=dtype),
        b_hb: wp.array2d(dtype=dtype), b_hact_out: wp.array(dtype=wp.int32), b_ha_out: wp.array2d(dtype=dtype),
        b_hb_out: wp.array2d(dtype=dtype),
        f: wp.array2d(dtype=dtype), K: wp.array3d(dtype=dtype), C: wp.array3d(dtype=dtype),
    ):
        """f = contact forces + output load, K = df/dq, C = df/dv of copy p at (qt, vt); returns
        the peak pin, output-pin and bearing loads [N]."""
        n = qt.shape[1]
        nb = n // 3
        for b in range(nb):
            for c in range(3):
                pose[p * nb + b, c] = reference[p, 3 * b + c] + qt[p, 3 * b + c]
                vel[p * nb + b, c] = vt[p, 3 * b + c]
        for i in range(n):
            f[p, i] = dtype(0.0)
            for j in range(n):
                K[p, i, j] = dtype(0.0)
                C[p, i, j] = dtype(0.0)
        pk_pin = dtype(0.0)
        pk_op = dtype(0.0)
        pk_brg = dtype(0.0)
        rp = loc_pin.shape[0]
        for rr in range(rp):
            row = p * rp + rr
            # the anchor arguments are never read by the frictionless row (anchor=False)
            pin_row(row, pin_f, pin_i, tab_pts, tab_nrm, tab_kap, tab_polar, tab_offset, tab_len, tab_h, tab_phi,
                    tab_ana, window, pin_anchor, pose, vel, pin_hact, pin_ha, pin_ha, pin_q, pin_k, pin_c, pin_obs,
                    pin_hact, pin_ha, pin_ha)
            add_row(pin_q, pin_k, pin_c, 1, loc_pin, rr, row, p, f, K, C)
            pk_pin = wp.max(pk_pin, pin_obs[row, O_FN])
        ro = loc_op.shape[0]
        for rr in range(ro):
            row = p * ro + rr
            op_row(row, op_f, op_i, stations, 0, pose, tilt, op_q, op_k, op_tilt, op_slices, op_sdf)
            add_row(op_q, op_k, op_k, 0, loc_op, rr, row, p, f, K, C)
            pk_op = wp.max(pk_op, wp.sqrt(op_q[row, 0] * op_q[row, 0] + op_q[row, 1] * op_q[row, 1]))
        rb = loc_brg.shape[0]
        for rr in range(rb):
            row = p * rb + rr
            brg_row(row, brg_f, brg_i, pose, vel, b_hact, b_ha, b_hb, b_q, b_k, b_c, b_obs, b_hact_out, b_ha_out,
                    b_hb_out)
            add_row(b_q, b_k, b_c, 1, loc_brg, rr, row, p, f, K, C)
            pk_brg = wp.max(pk_brg, b_obs[row, O_FN])
        f[p, output_index] = f[p, output_index] + torque[p]
        return pk_pin, pk_op, pk_brg

    # forward only: the fused step is never differentiated, and the adjoint of a kernel this
    # large (every family's row function inlined, Newton and LU loops) made NVRTC's compile run
    # for more than nine minutes on an H100 host (the CPU compile: ~50 s)
    @wp.kernel(enable_backward=False, module="unique")
    def fused_steps(
        # Model:
        pin_f: wp.array2d(dtype=dtype), pin_i: wp.array2d(dtype=wp.int32), tab_pts: wp.array2d(dtype=dtype),
        tab_nrm: wp.array2d(dtype=dtype), tab_kap: wp.array(dtype=dtype), tab_polar: wp.array(dtype=dtype),
        tab_offset: wp.array(dtype=wp.int32), tab_len: wp.array(dtype=wp.int32), tab_h: wp.array(dtype=dtype),
        tab_phi: wp.array(dtype=dtype), tab_ana: wp.array2d(dtype=dtype), window: int,
        pin_anchor: wp.array2d(dtype=dtype),
        op_f: wp.array2d(dtype=dtype), op_i: wp.array2d(dtype=wp.int32), stations: wp.array(dtype=dtype),
        brg_f: wp.array2d(dtype=dtype), brg_i: wp.array2d(dtype=wp.int32),
        loc_pin: wp.array2d(dtype=wp.int32), loc_op: wp.array2d(dtype=wp.int32), loc_brg: wp.array2d(dtype=wp.int32),
        reference: wp.array2d(dtype=dtype), mass: wp.array2d(dtype=dtype), free: wp.array(dtype=wp.int32),
        input_index: int, output_index: int, motion: wp.array2d(dtype=dtype), torque: wp.array(dtype=dtype),
        settings: wp.array(dtype=dtype), n_steps: int,
        # Data in and out (the copies' state):
        q: wp.array2d(dtype=dtype), v: wp.array2d(dtype=dtype), a: wp.array2d(dtype=dtype),
        abar: wp.array2d(dtype=dtype), t: wp.array(dtype=dtype), h: wp.array(dtype=dtype),
        status: wp.array(dtype=wp.int32), counters: wp.array2d(dtype=wp.int32),
        # Scratch:
        qt: wp.array2d(dtype=dtype), vt: wp.array2d(dtype=dtype), at: wp.array2d(dtype=dtype),
        gt: wp.array2d(dtype=dtype), lam: wp.array2d(dtype=dtype), r: wp.array2d(dtype=dtype),
        dx: wp.array2d(dtype=dtype), A: wp.array3d(dtype=dtype),
        pose: wp.array2d(dtype=dtype), vel: wp.array2d(dtype=dtype), tilt: wp.array2d(dtype=dtype),
        pin_q: wp.array2d(dtype=dtype), pin_k: wp.array3d(dtype=dtype), pin_c: wp.array3d(dtype=dtype),
        pin_obs: wp.array2d(dtype=dtype), pin_hact: wp.array(dtype=wp.int32), pin_ha: wp.array2d(dtype=dtype),
        op_q: wp.array2d(dtype=dtype), op_k: wp.array3d(dtype=dtype), op_tilt: wp.array3d(dtype=dtype),
        op_slices: wp.array3d(dtype=dtype), op_sdf: wp.array4d(dtype=dtype),
        b_q: wp.array2d(dtype=dtype), b_k: wp.array3d(dtype=dtype), b_c: wp.array3d(dtype=dtype),
        b_obs: wp.array2d(dtype=dtype), b_hact: wp.array(dtype=wp.int32), b_ha: wp.array2d(dtype=dtype),
        b_hb: wp.array2d(dtype=dtype), b_hact_out: wp.array(dtype=wp.int32), b_ha_out: wp.array2d(dtype=dtype),
        b_hb_out: wp.array2d(dtype=dtype),
        f: wp.array2d(dtype=dtype), K: wp.array3d(dtype=dtype), C: wp.array3d(dtype=dtype),
        # Data out:
        history: wp.array3d(dtype=dtype),
    ):
        p = wp.tid()
        n = q.shape[1]
        am = settings[S_ALPHA_M]
        af = settings[S_ALPHA_F]
        beta = settings[S_BETA]
        gamma = settings[S_GAMMA]
        abs_tol = settings[S_ABS_TOL]
        rel_tol = settings[S_REL_TOL]
        max_it = int(settings[S_MAX_IT])
        t_end = settings[S_T_END]
        h_nom = settings[S_H_NOM]
        one = dtype(1.0)
        counters[p, C_RECORDED] = 0
        if n_steps == 0:
            # Exudyn's computeInitialAccelerations: M a = f on the free coordinates, the
            # prescribed acceleration on the fixed ones; abar starts as a
            pk_pin, pk_op, pk_brg = evaluate_copy(
                p, pin_f, pin_i, tab_pts, tab_nrm, tab_kap, tab_polar, tab_offset, tab_len, tab_h, tab_phi, tab_ana,
                window, pin_anchor, op_f, op_i, stations, brg_f, brg_i, loc_pin, loc_op, loc_brg, reference, torque,
                output_index, q, v, pose, vel, tilt, pin_q, pin_k, pin_c, pin_obs, pin_hact, pin_ha, op_q, op_k,
                op_tilt, op_slices, op_sdf, b_q, b_k, b_c, b_obs, b_hact, b_ha, b_hb, b_hact_out, b_ha_out, b_hb_out,
                f, K, C)
            for i in range(n):
                ai = dtype(0.0)
                if free[i] != 0:
                    ai = f[p, i] / mass[p, i]
                elif i == input_index:
                    ai = motion[p, M_ACCEL]
                a[p, i] = ai
                abar[p, i] = ai
            return
        while status[p] == ACTIVE and counters[p, C_RECORDED] < n_steps:
            t0 = t[p]
            hh = h[p]
            if t0 + hh > t_end:
                hh = t_end - t0
            t1 = t0 + hh
            ang = motion[p, M_ANGLE] + motion[p, M_SPEED] * t1 + dtype(0.5) * motion[p, M_ACCEL] * t1 * t1
            spd = motion[p, M_SPEED] + motion[p, M_ACCEL] * t1
            acc = motion[p, M_ACCEL]
            # predictor (Exudyn's ComputeNewtonUpdate, initial) and the prescribed coordinates
            for i in range(n):
                g0 = abar[p, i]
                qi = q[p, i] + hh * v[p, i] + hh * hh * (dtype(0.5) - beta) * g0
                vi = v[p, i] + hh * (one - gamma) * g0
                gi = (af * a[p, i] - am * g0) / (one - am)
                qi = qi + hh * hh * beta * gi
                vi = vi + hh * gamma * gi
                ai = dtype(0.0)
                if free[i] == 0:
                    qi = dtype(0.0)
                    vi = dtype(0.0)
                    if i == input_index:
                        qi = ang
                        vi = spd
                        ai = acc
                qt[p, i] = qi
                vt[p, i] = vi
                at[p, i] = ai
                gt[p, i] = gi
                lam[p, i] = dtype(0.0)
            sc = beta * hh * hh
            bp = (one - am) / (hh * hh * beta * (one - af))
            gp = gamma / (hh * beta)
            pk_pin, pk_op, pk_brg = evaluate_copy(
                p, pin_f, pin_i, tab_pts, tab_nrm, tab_kap, tab_polar, tab_offset, tab_len, tab_h, tab_phi, tab_ana,
                window, pin_anchor, op_f, op_i, stations, brg_f, brg_i, loc_pin, loc_op, loc_brg, reference, torque,
                output_index, qt, vt, pose, vel, tilt, pin_q, pin_k, pin_c, pin_obs, pin_hact, pin_ha, op_q, op_k,
                op_tilt, op_slices, op_sdf, b_q, b_k, b_c, b_obs, b_hact, b_ha, b_hb, b_hact_out, b_ha_out, b_hb_out,
                f, K, C)
            res2 = dtype(0.0)
            for i in range(n):
                ri = mass[p, i] * at[p, i] - f[p, i] + lam[p, i]
                r[p, i] = ri
                res2 = res2 + ri * ri
            initial = wp.sqrt(res2)
            ok = int(1)
            if not wp.isfinite(initial):
                ok = int(0)
            initial = wp.max(initial, dtype(2.0) * abs_tol)
            converged = int(0)
            its = int(0)
            while ok != 0 and converged == 0 and its < max_it:
                its = its + 1
                # J = s (beta' M - K - gamma' C) on the free block, identity rows on the fixed ones
                for i in range(n):
                    for j in range(n):
                        A[p, i, j] = dtype(0.0)
                    if free[i] == 0:
                        A[p, i, i] = one
                        dx[p, i] = dtype(0.0)
                    else:
                        dx[p, i] = sc * r[p, i]
                        for j in range(n):
                            if free[j] != 0:
                                A[p, i, j] = -sc * (K[p, i, j] + gp * C[p, i, j])
                        A[p, i, i] = A[p, i, i] + sc * bp * mass[p, i]
                # Gaussian elimination with partial pivoting on (A | dx), back substitution into dx
                ok = lu_solve(A, dx, dx, p, n)
                if ok != 0:
                    # Exudyn's multiplier update of the fixed rows: lambda -= (s r_x - J_xf D_f) / s
                    for i in range(n):
                        if free[i] == 0:
                            jd = dtype(0.0)
                            for j in range(n):
                                if free[j] != 0:
                                    jd = jd - sc * (K[p, i, j] + gp * C[p, i, j]) * dx[p, j]
                            lam[p, i] = lam[p, i] - (sc * r[p, i] - jd) / sc
                    for i in range(n):
                        if free[i] != 0:
                            d = dx[p, i]
                            qt[p, i] = qt[p, i] - d
                            vt[p, i] = vt[p, i] - gp * d
                            at[p, i] = at[p, i] - bp * d
                    pk_pin, pk_op, pk_brg = evaluate_copy(
                        p, pin_f, pin_i, tab_pts, tab_nrm, tab_kap, tab_polar, tab_offset, tab_len, tab_h, tab_phi,
                        tab_ana, window, pin_anchor, op_f, op_i, stations, brg_f, brg_i, loc_pin, loc_op, loc_brg,
                        reference, torque, output_index, qt, vt, pose, vel, tilt, pin_q, pin_k, pin_c, pin_obs,
                        pin_hact, pin_ha, op_q, op_k, op_tilt, op_slices, op_sdf, b_q, b_k, b_c, b_obs, b_hact, b_ha,
                        b_hb, b_hact_out, b_ha_out, b_hb_out, f, K, C)
                    res2 = dtype(0.0)
                    for i in range(n):
                        ri = mass[p, i] * at[p, i] - f[p, i] + lam[p, i]
                        r[p, i] = ri
                        res2 = res2 + ri * ri
                    res = wp.sqrt(res2)
                    if not wp.isfinite(res):
                        ok = int(0)
                    else:
                        if its == 1 and res > initial:
                            initial = res
                        if res / initial <= rel_tol or res <= abs_tol:
                            converged = int(1)
            counters[p, C_NEWTON] = counters[p, C_NEWTON] + its
            if ok != 0 and converged != 0:
                fa = (one - af) / (one - am)
                for i in range(n):
                    q[p, i] = qt[p, i]
                    v[p, i] = vt[p, i]
                    a[p, i] = at[p, i]
                    abar[p, i] = gt[p, i] + fa * at[p, i]
                t[p] = t1
                k = counters[p, C_RECORDED]
                history[p, k, H_TIME] = t1
                history[p, k, H_INPUT] = qt[p, input_index]
                history[p, k, H_OUTPUT] = reference[p, output_index] + qt[p, output_index]
                history[p, k, H_TORQUE] = mass[p, input_index] * at[p, input_index] - f[p, input_index]
                history[p, k, H_PIN] = pk_pin
                history[p, k, H_OUTPUT_PIN] = pk_op
                history[p, k, H_BEARING] = pk_brg
                history[p, k, H_STEP] = hh
                history[p, k, H_NEWTON] = dtype(its)
                counters[p, C_RECORDED] = k + 1
                counters[p, C_ACCEPTED] = counters[p, C_ACCEPTED] + 1
                counters[p, C_RUN] = counters[p, C_RUN] + 1
                if dtype(counters[p, C_RUN]) >= settings[S_RECOVERY] and dtype(its + 1) < settings[S_RECOVERY_ITERATIONS]:
                    h[p] = wp.min(h_nom, dtype(2.0) * h[p])
                    counters[p, C_RUN] = 0
                if t1 >= t_end - dtype(END_TOLERANCE):
                    status[p] = DONE
            else:
                counters[p, C_REJECTED] = counters[p, C_REJECTED] + 1
                counters[p, C_RUN] = 0
                if h[p] > settings[S_H_MIN]:
                    h[p] = wp.max(settings[S_H_MIN], dtype(0.5) * h[p])
                else:
                    status[p] = FAILED

    return fused_steps


class FusedStepper:
    """B copies on one Warp device, advanced by :meth:`advance` (one launch).

    Model arrays (NumPy, global rows: copy p owns rows p R .. p R + R - 1 of every family, bodies
    p nb .. p nb + nb - 1; the ground is pose row B nb): pin_f, pin_i, tables, window, analytic
    (the cycloid-pin rows, :class:`warp_contacts.cycloid_pins.CycloidPinKernel`'s layout),
    op_f, op_i, stations (plain output-pin rows), brg_f, brg_i (circle-pair rows), loc_* (R, 6)
    the copy-local coordinate of each row entry (-1: ground), reference (B, n) [m, rad], mass
    (B, n) [kg, kg m^2] (the diagonal mass matrix), free (n,) bool, input_index, output_index,
    motion (B, N_MOTION), torque (B,) [N m] on the output coordinate, settings (N_SETTINGS,).
    State (B, n) q, v, a, abar; (B,) t, h; status; counters: :meth:`set_state` / :meth:`state`.
    """

    def __init__(self, *, pin_f, pin_i, tables, window, analytic, op_f, op_i, stations, brg_f, brg_i, loc_pin, loc_op,
                 loc_brg, reference, mass, free, input_index, output_index, motion, torque, settings, device="cpu"):
        self.device = d = resolve_device(device)
        dt = wp.float64
        self.B, self.n = np.shape(reference)
        B, n = self.B, self.n
        nb = n // 3
        f = lambda x: wp.array(np.ascontiguousarray(x, np.float64), dtype=dt, device=d)
        i32 = lambda x: wp.array(np.ascontiguousarray(x, np.int32), dtype=wp.int32, device=d)
        z = lambda *s: wp.zeros(s, dtype=dt, device=d)
        lens = [len(tb[0]) for tb in tables]
        offs = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int32)
        n_pin, n_op, n_brg = len(pin_f), len(op_f), len(brg_f)
        self._model = [
            f(pin_f), i32(pin_i), f(np.vstack([tb[0] for tb in tables])), f(np.vstack([tb[1] for tb in tables])),
            f(np.concatenate([tb[2] for tb in tables])), f(np.concatenate([tb[3] for tb in tables])), i32(offs),
            i32(np.array(lens)), f(np.array([tb[4] for tb in tables])), f(np.concatenate([tb[5] for tb in tables])),
            f(cycloid_pins.analytic_rows(tables, analytic)), int(window), z(1, 1),
            f(op_f), i32(op_i), f(stations), f(brg_f), i32(brg_i), i32(loc_pin), i32(loc_op), i32(loc_brg),
            f(reference), f(mass), i32(np.asarray(free, bool).astype(np.int32)), int(input_index), int(output_index),
            f(motion), f(torque), f(settings)]
        self._state = {"q": z(B, n), "v": z(B, n), "a": z(B, n), "abar": z(B, n), "t": z(B), "h": z(B),
                       "status": wp.zeros(B, dtype=wp.int32, device=d),
                       "counters": wp.zeros((B, N_COUNT), dtype=wp.int32, device=d)}
        ns = len(stations)
        self._scratch = [
            z(B, n), z(B, n), z(B, n), z(B, n), z(B, n), z(B, n), z(B, n), z(B, n, n),
            z(B * nb + 1, 3), z(B * nb + 1, 3), z(B * nb + 1, 2),
            z(n_pin, 6), z(n_pin, 6, 6), z(n_pin, 6, 6), z(n_pin, N_OBS), wp.zeros(1, dtype=wp.int32, device=d),
            z(1, 2),
            z(n_op, 6), z(n_op, 6, 6), z(n_op, 2, 2), z(n_op, ns, N_SLICE_COLS), z(1, 1, 2, 9),
            z(n_brg, 6), z(n_brg, 6, 6), z(n_brg, 6, 6), z(n_brg, N_OBS), wp.zeros(n_brg, dtype=wp.int32, device=d),
            z(n_brg, 2), z(n_brg, 2), wp.zeros(n_brg, dtype=wp.int32, device=d), z(n_brg, 2), z(n_brg, 2),
            z(B, n), z(B, n, n), z(B, n, n)]
        self._kernel = kernels(dt)
        self._history = {}
        self.launches = 0

    def set_state(self, *, q, v, a, abar, t, h, status=None):
        """Upload the copies' state (B, n) q, v, a, abar, (B,) t, h; status ACTIVE unless given;
        the counters are reset."""
        for k, x in (("q", q), ("v", v), ("a", a), ("abar", abar), ("t", t), ("h", h)):
            self._state[k].assign(np.ascontiguousarray(np.broadcast_to(x, self._state[k].shape), np.float64))
        st = np.zeros(self.B, np.int32) if status is None else np.asarray(status, np.int32)
        self._state["status"].assign(st)
        self._state["counters"].zero_()

    def state(self):
        """The copies' state as NumPy arrays (a dict)."""
        return {k: v.numpy().copy() for k, v in self._state.items()}

    def status(self):
        """(B,) ACTIVE / DONE / FAILED (one host read)."""
        return self._state["status"].numpy().copy()

    def _history_buffer(self, n_steps):
        if n_steps not in self._history:
            self._history[n_steps] = wp.zeros((self.B, n_steps, N_HISTORY), dtype=wp.float64, device=self.device)
        return self._history[n_steps]

    def launch(self, n_steps):
        """One launch: up to ``n_steps`` accepted steps of every active copy; the history stays on
        the device (:meth:`history`)."""
        s = self._state
        hist = self._history_buffer(max(int(n_steps), 1))
        wp.launch(self._kernel, dim=self.B, device=self.device,
                  inputs=self._model + [int(n_steps), s["q"], s["v"], s["a"], s["abar"], s["t"], s["h"], s["status"],
                                        s["counters"]] + self._scratch,
                  outputs=[hist])
        self.launches += 1
        return hist

    def initialize_accelerations(self):
        """a = abar = Exudyn's initial accelerations at the uploaded (q, v) (one launch)."""
        self.launch(0)

    def recorded(self):
        """(B,) accepted steps recorded by the last launch (one host read)."""
        return self._state["counters"].numpy()[:, C_RECORDED].copy()

    def advance(self, n_steps):
        """:meth:`launch`, then the history (B, n_steps, N_HISTORY), the recorded counts (B,) and
        the status (B,) on the host (three reads)."""
        hist = self.launch(n_steps)
        cnt = self._state["counters"].numpy()
        return hist.numpy().copy(), cnt[:, C_RECORDED].copy(), self._state["status"].numpy().copy()
