"""Warp kernels of the output-pin contact family with analytic tangent:
the plain rigid-pin pairs and the shared-pin condensation (one thread per
pin, so one launch evaluates every pin of any number of mechanisms).

Physics, conventions and parameter layout are documented in the NumPy
reference :mod:`warp_contacts.output_pins_ref`, which these kernels mirror
(a test compares them on every available device). The tangent is forward
mode with all seed directions carried at once: each scalar has a ``vec9``
tangent, each planar vector a pair of them, so the fixed sleeve updates are
differentiated in one pass (Eq. (moment_chain_rule) force-arm term
included).

Parameter, coordinate and output columns are named once in the reference and
used here as ``ref.NAME`` (qualified, because some column names, e.g. the pin
outputs K0/K1, equal the symbols of the physics).
"""
import functools

import numpy as np
import warp as wp

from . import output_pins_ref as ref
from .anchor import anchor_funcs
from .anchor_ref import N_ANCHOR
from .planar import planar_funcs
from .precision import resolve_device, scalar_types
from .recorded import RecordedRows


@functools.lru_cache(maxsize=None)
def _funcs(dtype):
    """Warp functions of the output-pin family for scalar type ``dtype``."""
    G = planar_funcs(dtype)
    vec2, cross2 = G.vec2, G.cross2
    vec9 = wp.types.vector(9, dtype)

    @wp.func
    def seed(k: int):
        """Unit tangent of coordinate k (0..8: the (x, y, theta) triples starting at X_FLANGE, X_WHEEL0, X_WHEEL1)."""
        e = vec9()
        e[k] = dtype(1.0)
        return e

    @wp.func
    def tilt_offset(t: vec2, z: dtype):
        """Planar offset (theta_y z, -theta_x z) of a point at axial plane z (small tilts)."""
        return vec2(t[1] * z, -t[0] * z)

    @wp.func
    def unit(v: vec2, dvx: vec9, dvy: vec9, floor: dtype):
        """L = max(|v|, floor), n = v/L and tangents (dL, dn_x, dn_y)."""
        Lr = wp.sqrt(v[0] * v[0] + v[1] * v[1])
        L = floor
        dL = vec9()
        if Lr > floor:
            L = Lr
            dL = (v[0] * dvx + v[1] * dvy) / Lr
        n = v / L
        return L, n, dL, (dvx - n[0] * dL) / L, (dvy - n[1] * dL) / L

    @wp.func
    def wheel_open(a: vec2, dax: vec9, day: vec9, b: vec2, u: vec2, dux: vec9, duy: vec9, clr: dtype, ks: dtype,
                   p: dtype, dmin: dtype, dfloor: dtype, stations: wp.array(dtype=dtype)):
        """Open resultant F^0 and tangent K of one wheel with their tangents (Eq. (pin_open_state))."""
        F0 = dtype(0.0)
        K = dtype(0.0)
        dF0 = vec9()
        dK = vec9()
        for js in range(stations.shape[0]):
            L, n, dL, dnx, dny = unit(a + stations[js] * b + u, dax + dux, day + duy, dfloor)
            d = L - clr
            if d > dtype(0.0):
                # one pow per slice: the derivatives follow as F p / d and K (p - 1) / d
                f = ks * wp.pow(d, p)
                k = p * f / d
                F0 += f
                dF0 += k * dL
                if d > dmin:
                    K += k
                    dK += ((p - dtype(1.0)) * k / d) * dL
                else:
                    K += p * ks * wp.pow(dmin, p - dtype(1.0))
        return F0, K, dF0, dK

    @wp.func
    def closure(F00: dtype, F01: dtype, K0: dtype, K1: dtype, dF00: vec9, dF01: vec9, dK0: vec9, dK1: vec9,
                n0: vec2, dn0x: vec9, dn0y: vec9, n1: vec2, dn1x: vec9, dn1y: vec9,
                c00: dtype, c11: dtype, cross: dtype, detfloor: dtype):
        """Local closure (I + K_c C_p) F^c = F^0 with tensile clipping, u_p = C_p F^c (Eq. (supp_pin_closure))."""
        c01 = cross * wp.dot(n0, n1)
        dc01 = cross * (n1[0] * dn0x + n1[1] * dn0y + n0[0] * dn1x + n0[1] * dn1y)
        A00 = dtype(1.0) + K0 * c00
        A11 = dtype(1.0) + K1 * c11
        A01 = K0 * c01
        A10 = K1 * c01
        dA00 = c00 * dK0
        dA11 = c11 * dK1
        dA01 = c01 * dK0 + K0 * dc01
        dA10 = c01 * dK1 + K1 * dc01
        det = A00 * A11 - A01 * A10
        ddet = vec9()
        if det > detfloor:
            ddet = A11 * dA00 + A00 * dA11 - A10 * dA01 - A01 * dA10
        else:
            det = detfloor
        Fc0 = (A11 * F00 - A01 * F01) / det
        Fc1 = (A00 * F01 - A10 * F00) / det
        dFc0 = (F00 * dA11 + A11 * dF00 - F01 * dA01 - A01 * dF01 - Fc0 * ddet) / det
        dFc1 = (F01 * dA00 + A00 * dF01 - F00 * dA10 - A10 * dF00 - Fc1 * ddet) / det
        if Fc0 <= dtype(0.0):
            Fc0 = dtype(0.0)
            dFc0 = vec9()
        if Fc1 <= dtype(0.0):
            Fc1 = dtype(0.0)
            dFc1 = vec9()
        up0 = c00 * Fc0 + c01 * Fc1
        up1 = c01 * Fc0 + c11 * Fc1
        dup0 = c00 * dFc0 + Fc1 * dc01 + c01 * dFc1
        dup1 = Fc0 * dc01 + c01 * dFc0 + c11 * dFc1
        return Fc0, Fc1, dFc0, dFc1, up0, up1, dup0, dup1

    @wp.func
    def sleeve_update(u: vec2, dux: vec9, duy: vec9, Fc0: dtype, Fc1: dtype, dFc0: vec9, dFc1: vec9, n0: vec2,
                      dn0x: vec9, dn0y: vec9, n1: vec2, dn1x: vec9, dn1y: vec9, K0: dtype, K1: dtype, dK0: vec9,
                      dK1: vec9, relax: dtype, kfloor: dtype, clear: dtype):
        """One projected sleeve update of Eq. (supp_pin_fit) with its tangent: a relaxed step along the
        net force on the sleeve, projected onto the clearance disk. Returns (u, du_x, du_y)."""
        g = Fc0 * n0 + Fc1 * n1
        dgx = n0[0] * dFc0 + Fc0 * dn0x + n1[0] * dFc1 + Fc1 * dn1x
        dgy = n0[1] * dFc0 + Fc0 * dn0y + n1[1] * dFc1 + Fc1 * dn1y
        Kt = K0 + K1
        dKt = dK0 + dK1
        if Kt <= kfloor:
            Kt = kfloor
            dKt = vec9()
        w = u - (relax / Kt) * g
        dwx = dux - (relax / Kt) * dgx + (relax * g[0] / (Kt * Kt)) * dKt
        dwy = duy - (relax / Kt) * dgy + (relax * g[1] / (Kt * Kt)) * dKt
        wl = wp.sqrt(w[0] * w[0] + w[1] * w[1])
        if wl > clear:
            # projection onto the clearance disk: d(c w/|w|) = c (I - w_hat w_hat^T) dw / |w|
            wh = w / wl
            wdw = wh[0] * dwx + wh[1] * dwy
            return clear * wh, (clear / wl) * (dwx - wh[0] * wdw), (clear / wl) * (dwy - wh[1] * wdw)
        return w, dwx, dwy

    @wp.func
    def wheel_react(a: vec2, dax: vec9, day: vec9, b: vec2, u: vec2, dux: vec9, duy: vec9, up: dtype, dup: vec9,
                    clr: dtype, ks: dtype, p: dtype, dfloor: dtype, rsum: dtype, pf: vec2, ph: vec2, xw: vec2,
                    tf: vec2, tw: vec2, zw: dtype, cw: int, stations: wp.array(dtype=dtype),
                    row: int, wheel: int, write_tan: int,
                    slice_out: wp.array3d(dtype=dtype), slice_df_out: wp.array4d(dtype=dtype)):
        """Nonlinear slice re-evaluation after subtracting the station deflection and reaction assembly.

        Returns the wheel triple (F_x, F_y, M_z), the flange moment, their tangents,
        tilt moments (M_x, M_y) of flange and wheel and the wheel resultant sum_s F_is.
        """
        fx = dtype(0.0)
        fy = dtype(0.0)
        mw = dtype(0.0)
        mf = dtype(0.0)
        dfx = vec9()
        dfy = vec9()
        dmw = vec9()
        dmf = vec9()
        mtf = vec2()
        mtw = vec2()
        fw = dtype(0.0)
        ns = stations.shape[0]
        for js in range(ns):
            s = stations[js]
            L, n, dL, dnx, dny = unit(a + s * b + u, dax + dux, day + duy, dfloor)
            d = L - clr
            de = d - up
            F = dtype(0.0)
            dF = vec9()
            if de > dtype(0.0):
                F = ks * wp.pow(de, p)
                dF = (p * F / de) * (dL - dup)
            fw += F
            fv = F * n
            dfvx = n[0] * dF + F * dnx
            dfvy = n[1] * dF + F * dny
            arm_w = ph + tilt_offset(tw, s)
            zf = zw + s
            arm_f = pf + tilt_offset(tf, zf) + u
            darm_wx = (-ph[1]) * seed(cw + 2)
            darm_wy = ph[0] * seed(cw + 2)
            darm_fx = dux + (-pf[1]) * seed(ref.X_FLANGE + 2)
            darm_fy = duy + pf[0] * seed(ref.X_FLANGE + 2)
            fx += fv[0]
            fy += fv[1]
            mw += cross2(arm_w, fv)
            mf -= cross2(arm_f, fv)
            dfx += dfvx
            dfy += dfvy
            # Eq. (moment_chain_rule): force term r x df plus force-arm term dr x f
            dmw += arm_w[0] * dfvy - arm_w[1] * dfvx + fv[1] * darm_wx - fv[0] * darm_wy
            dmf -= arm_f[0] * dfvy - arm_f[1] * dfvx + fv[1] * darm_fx - fv[0] * darm_fy
            mtf -= vec2(-zf * fv[1], zf * fv[0])
            mtw += vec2(-s * fv[1], s * fv[0])
            r = wheel * ns + js
            pc = xw + arm_w + (dtype(0.5) * (L + rsum)) * n
            slice_out[row, r, ref.S_FORCE] = F
            slice_out[row, r, ref.S_APPROACH] = de
            slice_out[row, r, ref.S_GEOM] = d
            slice_out[row, r, ref.S_NX] = n[0]
            slice_out[row, r, ref.S_NY] = n[1]
            slice_out[row, r, ref.S_PX] = pc[0]
            slice_out[row, r, ref.S_PY] = pc[1]
            if write_tan != 0:
                for j in range(9):
                    slice_df_out[row, r, 0, j] = dfvx[j]
                    slice_df_out[row, r, 1, j] = dfvy[j]
        return fx, fy, mw, mf, dfx, dfy, dmw, dmf, mtf, mtw, fw

    @wp.func
    def separation(xf: vec2, pf: vec2, tf: vec2, zw: dtype, xw: vec2, ph: vec2, tw: vec2, cw: int):
        """e_s = a + s b (pin minus hole centre in slice plane s) and the tangent of a."""
        a = (xf + pf + tilt_offset(tf, zw)) - (xw + ph)
        b = tilt_offset(tf, dtype(1.0)) - tilt_offset(tw, dtype(1.0))
        dax = seed(ref.X_FLANGE) - pf[1] * seed(ref.X_FLANGE + 2) - seed(cw) + ph[1] * seed(cw + 2)
        day = seed(ref.X_FLANGE + 1) + pf[0] * seed(ref.X_FLANGE + 2) - seed(cw + 1) - ph[0] * seed(cw + 2)
        return a, b, dax, day

    @wp.func
    def store_triple(q_out: wp.array2d(dtype=dtype), i: int, k: int, fx: dtype, fy: dtype, m: dtype):
        """(F_x, F_y, M_z) on the body whose coordinates start at k."""
        q_out[i, k] = fx
        q_out[i, k + 1] = fy
        q_out[i, k + 2] = m

    @wp.func
    def store_triple_column(dqdq_out: wp.array3d(dtype=dtype), i: int, k: int, j: int, dfx: dtype, dfy: dtype,
                            dm: dtype):
        """Tangent column j of the triple at k."""
        dqdq_out[i, k, j] = dfx
        dqdq_out[i, k + 1, j] = dfy
        dqdq_out[i, k + 2, j] = dm

    @wp.func
    def store_tilt_moment(tilt_out: wp.array3d(dtype=dtype), i: int, body: int, m: vec2):
        """Tilt moments (M_x, M_y) on body slot ``body`` (0 flange, 1 and 2 the wheels)."""
        tilt_out[i, body, 0] = m[0]
        tilt_out[i, body, 1] = m[1]

    return dict(vec2=vec2, vec9=vec9, seed=seed, rot=G.rot, unit=unit, wheel_open=wheel_open, closure=closure,
                wheel_react=wheel_react, separation=separation, sleeve_update=sleeve_update,
                body_pose=G.body_pose, param_vec2=G.param_vec2, row_vec2=G.row_vec2, store_triple=store_triple,
                store_triple_column=store_triple_column, store_tilt_moment=store_tilt_moment)


@functools.lru_cache(maxsize=None)
def _shared_kernel(dtype):
    F = _funcs(dtype)
    vec2, vec9 = F["vec2"], F["vec9"]
    rot, unit, wheel_open, closure = F["rot"], F["unit"], F["wheel_open"], F["closure"]
    wheel_react, separation, sleeve_update = F["wheel_react"], F["separation"], F["sleeve_update"]
    body_pose, param_vec2, row_vec2 = F["body_pose"], F["param_vec2"], F["row_vec2"]
    store_triple, store_triple_column, store_tilt_moment = (F["store_triple"], F["store_triple_column"],
                                                            F["store_tilt_moment"])

    @wp.kernel(enable_backward=False, module="unique")
    def eval_shared_pins(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        stations: wp.array(dtype=dtype),
        write_tan: int,
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        tilt_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        tilt_out: wp.array3d(dtype=dtype),
        slice_out: wp.array3d(dtype=dtype),
        pin_out: wp.array2d(dtype=dtype),
        sleeve_du_out: wp.array3d(dtype=dtype),
        slice_df_out: wp.array4d(dtype=dtype),
    ):
        i = wp.tid()
        bf = iparams[i, ref.I_FLANGE]
        b0 = iparams[i, ref.I_WHEEL0]
        b1 = iparams[i, ref.I_WHEEL1]
        ns = stations.shape[0]
        smean = dtype(0.0)
        for js in range(ns):
            smean += stations[js]
        smean = smean / dtype(ns)
        ks = fparams[i, ref.P_K] / dtype(ns)
        p = fparams[i, ref.P_EXP]
        rp = fparams[i, ref.P_R_PIN]
        rh = fparams[i, ref.P_R_HOLE]
        clr0 = rh - rp + fparams[i, ref.P_OFF0]
        clr1 = rh - rp + fparams[i, ref.P_OFF1]
        z0 = fparams[i, ref.P_Z0]
        z1 = fparams[i, ref.P_Z1]
        c00 = fparams[i, ref.P_C00] + fparams[i, ref.P_CIN]
        c11 = fparams[i, ref.P_C11] + fparams[i, ref.P_CIN]
        cross = fparams[i, ref.P_C01]
        clear = fparams[i, ref.P_CLEAR]
        relax = fparams[i, ref.P_RELAX]
        kfloor = fparams[i, ref.P_KFLOOR]
        detfloor = fparams[i, ref.P_DETFLOOR]
        dfloor = fparams[i, ref.P_DISTFLOOR]
        dmin = fparams[i, ref.P_DMIN]

        xf, thf = body_pose(pose_in, bf)
        x0, th0 = body_pose(pose_in, b0)
        x1, th1 = body_pose(pose_in, b1)
        tf = row_vec2(tilt_in, bf)
        t0 = row_vec2(tilt_in, b0)
        t1 = row_vec2(tilt_in, b1)
        pf = rot(thf, param_vec2(fparams, i, ref.P_XI_PIN))
        ph0 = rot(th0, param_vec2(fparams, i, ref.P_XI_HOLE0))
        ph1 = rot(th1, param_vec2(fparams, i, ref.P_XI_HOLE1))
        a0, bb0, da0x, da0y = separation(xf, pf, tf, z0, x0, ph0, t0, ref.X_WHEEL0)
        a1, bb1, da1x, da1y = separation(xf, pf, tf, z1, x1, ph1, t1, ref.X_WHEEL1)

        u = vec2()
        dux = vec9()
        duy = vec9()
        for it in range(iparams[i, ref.I_UPDATES]):
            F00, K0, dF00, dK0 = wheel_open(a0, da0x, da0y, bb0, u, dux, duy, clr0, ks, p, dmin, dfloor, stations)
            F01, K1, dF01, dK1 = wheel_open(a1, da1x, da1y, bb1, u, dux, duy, clr1, ks, p, dmin, dfloor, stations)
            m0L, n0, m0dL, dn0x, dn0y = unit(a0 + smean * bb0 + u, da0x + dux, da0y + duy, dfloor)
            m1L, n1, m1dL, dn1x, dn1y = unit(a1 + smean * bb1 + u, da1x + dux, da1y + duy, dfloor)
            Fc0, Fc1, dFc0, dFc1, up0, up1, dup0, dup1 = closure(F00, F01, K0, K1, dF00, dF01, dK0, dK1, n0, dn0x,
                                                                dn0y, n1, dn1x, dn1y, c00, c11, cross, detfloor)
            u, dux, duy = sleeve_update(u, dux, duy, Fc0, Fc1, dFc0, dFc1, n0, dn0x, dn0y, n1, dn1x, dn1y, K0, K1,
                                        dK0, dK1, relax, kfloor, clear)

        F00, K0, dF00, dK0 = wheel_open(a0, da0x, da0y, bb0, u, dux, duy, clr0, ks, p, dmin, dfloor, stations)
        F01, K1, dF01, dK1 = wheel_open(a1, da1x, da1y, bb1, u, dux, duy, clr1, ks, p, dmin, dfloor, stations)
        m0L, n0, m0dL, dn0x, dn0y = unit(a0 + smean * bb0 + u, da0x + dux, da0y + duy, dfloor)
        m1L, n1, m1dL, dn1x, dn1y = unit(a1 + smean * bb1 + u, da1x + dux, da1y + duy, dfloor)
        Fc0, Fc1, dFc0, dFc1, up0, up1, dup0, dup1 = closure(F00, F01, K0, K1, dF00, dF01, dK0, dK1, n0, dn0x, dn0y,
                                                            n1, dn1x, dn1y, c00, c11, cross, detfloor)
        rsum = rp + rh
        fx0, fy0, mw0, mf0, dfx0, dfy0, dmw0, dmf0, mtf0, mtw0, fw0 = wheel_react(
            a0, da0x, da0y, bb0, u, dux, duy, up0, dup0, clr0, ks, p, dfloor, rsum, pf, ph0, x0, tf, t0, z0,
            ref.X_WHEEL0, stations, i, 0, write_tan, slice_out, slice_df_out)
        fx1, fy1, mw1, mf1, dfx1, dfy1, dmw1, dmf1, mtf1, mtw1, fw1 = wheel_react(
            a1, da1x, da1y, bb1, u, dux, duy, up1, dup1, clr1, ks, p, dfloor, rsum, pf, ph1, x1, tf, t1, z1,
            ref.X_WHEEL1, stations, i, 1, write_tan, slice_out, slice_df_out)

        store_triple(q_out, i, ref.X_FLANGE, -(fx0 + fx1), -(fy0 + fy1), mf0 + mf1)
        store_triple(q_out, i, ref.X_WHEEL0, fx0, fy0, mw0)
        store_triple(q_out, i, ref.X_WHEEL1, fx1, fy1, mw1)
        for j in range(9):
            store_triple_column(dqdq_out, i, ref.X_FLANGE, j, -(dfx0[j] + dfx1[j]), -(dfy0[j] + dfy1[j]),
                                dmf0[j] + dmf1[j])
            store_triple_column(dqdq_out, i, ref.X_WHEEL0, j, dfx0[j], dfy0[j], dmw0[j])
            store_triple_column(dqdq_out, i, ref.X_WHEEL1, j, dfx1[j], dfy1[j], dmw1[j])
            sleeve_du_out[i, 0, j] = dux[j]
            sleeve_du_out[i, 1, j] = duy[j]
        store_tilt_moment(tilt_out, i, 0, mtf0 + mtf1)
        store_tilt_moment(tilt_out, i, 1, mtw0)
        store_tilt_moment(tilt_out, i, 2, mtw1)
        pin_out[i, ref.U_X] = u[0]
        pin_out[i, ref.U_Y] = u[1]
        pin_out[i, ref.FC0] = Fc0
        pin_out[i, ref.FC1] = Fc1
        pin_out[i, ref.UP0] = up0
        pin_out[i, ref.UP1] = up1
        pin_out[i, ref.K0] = K0
        pin_out[i, ref.K1] = K1
        pin_out[i, ref.FOPEN0] = F00
        pin_out[i, ref.FOPEN1] = F01
        pin_out[i, ref.FW0] = fw0
        pin_out[i, ref.FW1] = fw1
        pin_out[i, ref.N0X] = n0[0]
        pin_out[i, ref.N0Y] = n0[1]
        pin_out[i, ref.N1X] = n1[0]
        pin_out[i, ref.N1Y] = n1[1]

    return eval_shared_pins


def _plain_kernel(dtype):
    """The plain (rigid pin, no sleeve) kernel."""
    return _plain_parts(dtype)[0]


def plain_row_function(dtype):
    """The ``@wp.func`` of one plain row, ``plain_pin_row(i, <the plain kernel's arguments>)``: the
    body of the plain kernel (a thin wrapper over it), for kernels that evaluate rows of their own
    (:mod:`warp_contacts.fused_step`)."""
    return _plain_parts(dtype)[1]


@functools.lru_cache(maxsize=None)
def _plain_parts(dtype):
    """(plain kernel, plain row function)."""
    F = _funcs(dtype)
    vec2, vec9 = F["vec2"], F["vec9"]
    rot, wheel_react, separation = F["rot"], F["wheel_react"], F["separation"]
    body_pose, param_vec2, row_vec2 = F["body_pose"], F["param_vec2"], F["row_vec2"]
    store_triple, store_triple_column, store_tilt_moment = (F["store_triple"], F["store_triple_column"],
                                                            F["store_tilt_moment"])

    @wp.func
    def plain_pin_row(
        i: int,
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        stations: wp.array(dtype=dtype),
        write_tan: int,
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        tilt_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        tilt_out: wp.array3d(dtype=dtype),
        slice_out: wp.array3d(dtype=dtype),
        slice_df_out: wp.array4d(dtype=dtype),
    ):
        """Row i of the set (the kernel's body; the fused stepper calls it for its own rows)."""
        bf = iparams[i, ref.J_FLANGE]
        bw = iparams[i, ref.J_WHEEL]
        ns = stations.shape[0]
        ks = fparams[i, ref.Q_K] / dtype(ns)
        xf, thf = body_pose(pose_in, bf)
        xw, thw = body_pose(pose_in, bw)
        tf = row_vec2(tilt_in, bf)
        tw = row_vec2(tilt_in, bw)
        pf = rot(thf, param_vec2(fparams, i, ref.Q_XI_PIN))
        ph = rot(thw, param_vec2(fparams, i, ref.Q_XI_HOLE))
        zw = fparams[i, ref.Q_Z]
        # the plain pair's coordinates are (flange, wheel): the wheel triple takes the place of wheel 0
        a, b, dax, day = separation(xf, pf, tf, zw, xw, ph, tw, ref.X_WHEEL0)
        r_pin = fparams[i, ref.Q_R_PIN]
        r_hole = fparams[i, ref.Q_R_HOLE]
        clr = r_hole - r_pin + fparams[i, ref.Q_OFF]
        # a rigid pin without sleeve: zero sleeve offset and zero station deflection
        fx, fy, mw, mf, dfx, dfy, dmw, dmf, mtf, mtw, fw = wheel_react(
            a, dax, day, b, vec2(), vec9(), vec9(), dtype(0.0), vec9(), clr, ks, fparams[i, ref.Q_EXP],
            fparams[i, ref.Q_DISTFLOOR], r_pin + r_hole, pf, ph, xw, tf, tw, zw, ref.X_WHEEL0, stations, i, 0,
            write_tan, slice_out, slice_df_out)
        store_triple(q_out, i, ref.X_FLANGE, -fx, -fy, mf)
        store_triple(q_out, i, ref.X_WHEEL0, fx, fy, mw)
        for j in range(6):
            store_triple_column(dqdq_out, i, ref.X_FLANGE, j, -dfx[j], -dfy[j], dmf[j])
            store_triple_column(dqdq_out, i, ref.X_WHEEL0, j, dfx[j], dfy[j], dmw[j])
        store_tilt_moment(tilt_out, i, 0, mtf)
        store_tilt_moment(tilt_out, i, 1, mtw)

    @wp.kernel(enable_backward=False, module="unique")
    def eval_plain_pins(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        stations: wp.array(dtype=dtype),
        write_tan: int,
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        tilt_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        tilt_out: wp.array3d(dtype=dtype),
        slice_out: wp.array3d(dtype=dtype),
        slice_df_out: wp.array4d(dtype=dtype),
    ):
        plain_pin_row(wp.tid(), fparams, iparams, stations, write_tan, pose_in, tilt_in, q_out, dqdq_out, tilt_out, slice_out, slice_df_out)

    return eval_plain_pins, plain_pin_row


@functools.lru_cache(maxsize=None)
def _plain_anchor_kernel(dtype):
    """The plain kernel with anchor friction per slice (:func:`output_pins_ref.evaluate_plain_anchor`):
    a kernel of its own, so the frictionless plain kernel stays as it is."""
    F = _funcs(dtype)
    G = planar_funcs(dtype)
    A = anchor_funcs(dtype)
    vec2, vec9 = F["vec2"], F["vec9"]
    rot, wheel_react, separation = F["rot"], F["wheel_react"], F["separation"]
    body_pose, param_vec2, row_vec2 = F["body_pose"], F["param_vec2"], F["row_vec2"]
    store_triple, store_triple_column, store_tilt_moment = (F["store_triple"], F["store_triple_column"],
                                                            F["store_tilt_moment"])
    perp, cross2, store_row_vec2 = G.perp, G.cross2, G.store_row_vec2
    anchor_state, anchor_force_tangent, anchor_trial = A.anchor_state, A.anchor_force_tangent, A.anchor_trial

    @wp.kernel(enable_backward=False, module="unique")
    def eval_plain_pins_anchor(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        stations: wp.array(dtype=dtype),
        anchor_params: wp.array2d(dtype=dtype),
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        tilt_in: wp.array2d(dtype=dtype),
        hist_active_in: wp.array(dtype=wp.int32),
        hist_a_in: wp.array2d(dtype=dtype),
        hist_b_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        tilt_out: wp.array3d(dtype=dtype),
        slice_out: wp.array3d(dtype=dtype),
        slice_df_out: wp.array4d(dtype=dtype),
        ft_out: wp.array2d(dtype=dtype),
        hist_active_out: wp.array(dtype=wp.int32),
        hist_a_out: wp.array2d(dtype=dtype),
        hist_b_out: wp.array2d(dtype=dtype),
    ):
        i = wp.tid()
        bf = iparams[i, ref.J_FLANGE]
        bw = iparams[i, ref.J_WHEEL]
        ns = stations.shape[0]
        ks = fparams[i, ref.Q_K] / dtype(ns)
        xf, thf = body_pose(pose_in, bf)
        xw, thw = body_pose(pose_in, bw)
        tf = row_vec2(tilt_in, bf)
        tw = row_vec2(tilt_in, bw)
        pf = rot(thf, param_vec2(fparams, i, ref.Q_XI_PIN))
        ph = rot(thw, param_vec2(fparams, i, ref.Q_XI_HOLE))
        zw = fparams[i, ref.Q_Z]
        a, b, dax, day = separation(xf, pf, tf, zw, xw, ph, tw, ref.X_WHEEL0)
        r_pin = fparams[i, ref.Q_R_PIN]
        r_hole = fparams[i, ref.Q_R_HOLE]
        clr = r_hole - r_pin + fparams[i, ref.Q_OFF]
        # the slice force tangents are written (write_tan = 1): the friction tangent reads them
        fx, fy, mw, mf, dfx, dfy, dmw, dmf, mtf, mtw, fw = wheel_react(
            a, dax, day, b, vec2(), vec9(), vec9(), dtype(0.0), vec9(), clr, ks, fparams[i, ref.Q_EXP],
            fparams[i, ref.Q_DISTFLOOR], r_pin + r_hole, pf, ph, xw, tf, tw, zw, ref.X_WHEEL0, stations, i, 0,
            1, slice_out, slice_df_out)
        for r in range(ns):
            k = i * ns + r
            Fs = slice_out[i, r, ref.S_FORCE]
            n = vec2(slice_out[i, r, ref.S_NX], slice_out[i, r, ref.S_NY])
            pc = vec2(slice_out[i, r, ref.S_PX], slice_out[i, r, ref.S_PY])
            contact = slice_out[i, r, ref.S_APPROACH] > dtype(0.0)
            t = perp(n)
            hla = row_vec2(hist_a_in, k)
            hlb = row_vec2(hist_b_in, k)
            ha = rot(thw, hla)
            hb = rot(thf, hlb)
            e = (xw + ha) - (xf + hb)
            anchored, stick, slip, s_anc, sg, ft = anchor_state(Fs, contact, hist_active_in[k], e, t, anchor_params, k)
            ftv = ft * t
            if anchored:
                fx += ftv[0]
                fy += ftv[1]
                mw += cross2(ha, ftv)
                mf -= cross2(hb, ftv)
                Fsafe = Fs
                if Fsafe <= dtype(0.0):
                    Fsafe = dtype(1.0)
                for j in range(6):
                    dfv = vec2(slice_df_out[i, r, 0, j], slice_df_out[i, r, 1, j])
                    dF = wp.dot(n, dfv)
                    dn = vec2(dtype(0.0), dtype(0.0))
                    if Fs > dtype(0.0):
                        dn = (dfv - dF * n) / Fsafe
                    dt = perp(dn)
                    # seed j moves the flange (0-2) or the wheel (3-5); anchors turn with their bodies
                    dxw = vec2(dtype(0.0), dtype(0.0))
                    dxf = vec2(dtype(0.0), dtype(0.0))
                    dha = vec2(dtype(0.0), dtype(0.0))
                    dhb = vec2(dtype(0.0), dtype(0.0))
                    if j == 0:
                        dxf = vec2(dtype(1.0), dtype(0.0))
                    elif j == 1:
                        dxf = vec2(dtype(0.0), dtype(1.0))
                    elif j == 2:
                        dhb = perp(hb)
                    elif j == 3:
                        dxw = vec2(dtype(1.0), dtype(0.0))
                    elif j == 4:
                        dxw = vec2(dtype(0.0), dtype(1.0))
                    else:
                        dha = perp(ha)
                    dft = anchor_force_tangent(stick, slip, sg, e, t, dF, dt, (dxw + dha) - (dxf + dhb),
                                               anchor_params, k)
                    dftv = dft * t + ft * dt
                    dfx[j] = dfx[j] + dftv[0]
                    dfy[j] = dfy[j] + dftv[1]
                    dmw[j] = dmw[j] + cross2(dha, ftv) + cross2(ha, dftv)
                    dmf[j] = dmf[j] - (cross2(dhb, ftv) + cross2(hb, dftv))
            ft_out[i, r] = ft
            # trial history: a new anchor forms at the slice's contact point as material points of
            # the wheel and of the flange; committed by the evaluator once per accepted step
            flag, na, nb = anchor_trial(Fs, contact, anchored, slip, s_anc, sg, t, thw, ha, hla, hlb,
                                        rot(-thw, pc - xw), rot(-thf, pc - xf), anchor_params, k)
            hist_active_out[k] = flag
            store_row_vec2(hist_a_out, k, na)
            store_row_vec2(hist_b_out, k, nb)
        store_triple(q_out, i, ref.X_FLANGE, -fx, -fy, mf)
        store_triple(q_out, i, ref.X_WHEEL0, fx, fy, mw)
        for j in range(6):
            store_triple_column(dqdq_out, i, ref.X_FLANGE, j, -dfx[j], -dfy[j], dmf[j])
            store_triple_column(dqdq_out, i, ref.X_WHEEL0, j, dfx[j], dfy[j], dmw[j])
        store_tilt_moment(tilt_out, i, 0, mtf)
        store_tilt_moment(tilt_out, i, 1, mtw)

    return eval_plain_pins_anchor


class OutputPinKernel(RecordedRows):
    """Device-resident evaluator of a set of output pins (``mode`` "shared" or "plain").

    Parameters are uploaded once; per evaluation only poses and tilts go in.
    On the CPU the Warp arrays alias NumPy buffers (no copies per call) and the
    launch is recorded once and replayed; on a GPU inputs are copied in and
    outputs out once per evaluation. ``slice_tangent`` enables the per-slice
    force tangents (needed only by the separate moment assembly).
    """

    def __init__(self, fparams, iparams, stations, n_rows_pose, mode="shared", precision="float64", device="cpu",
                 slice_tangent=False, anchor_params=None):
        """anchor_params: None, or (N ns, N_ANCHOR) anchor columns of the slice rows (plain mode
        only): the plain kernel with anchor friction; evaluate then takes the committed history."""
        self.wdtype, self.ndtype = scalar_types(precision)
        self.device = resolve_device(device, len(fparams))
        self.precision = precision
        self.mode = mode
        nf, ni, nq = (ref.N_SHARED_F, ref.N_SHARED_I, 9) if mode == "shared" else (ref.N_PLAIN_F, ref.N_PLAIN_I, 6)
        fparams = np.ascontiguousarray(fparams, dtype=self.ndtype)
        iparams = np.ascontiguousarray(iparams, dtype=np.int32)
        assert fparams.shape[1] == nf and iparams.shape[1] == ni
        self.n = n = fparams.shape[0]
        ns = len(stations)
        nw = 2 if mode == "shared" else 1
        self.anchor = anchor_params is not None
        if self.anchor and mode == "shared":
            raise ValueError("anchor friction is implemented for the plain mode only")
        self.slice_tangent = bool(slice_tangent)
        dft_shape = (n, nw * ns, 2, 9) if (slice_tangent or self.anchor) else (1, 1, 2, 9)
        h = {"pose": np.zeros((n_rows_pose, 3), self.ndtype), "tilt": np.zeros((n_rows_pose, 2), self.ndtype),
             "q": np.zeros((n, nq), self.ndtype), "dqdq": np.zeros((n, nq, nq), self.ndtype),
             "tilt_m": np.zeros((n, nw + 1, 2), self.ndtype), "slices": np.zeros((n, nw * ns, ref.N_SLICE_COLS), self.ndtype),
             "slice_df": np.zeros(dft_shape, self.ndtype)}
        if mode == "shared":
            h["pin"] = np.zeros((n, ref.N_PIN_COLS), self.ndtype)
            h["sleeve_du"] = np.zeros((n, 2, 9), self.ndtype)
        if self.anchor:
            h.update(ft=np.zeros((n, ns), self.ndtype), anchor=np.ascontiguousarray(anchor_params, self.ndtype),
                     h_a_in=np.zeros((n * ns, 2), self.ndtype), h_b_in=np.zeros((n * ns, 2), self.ndtype),
                     h_a_out=np.zeros((n * ns, 2), self.ndtype), h_b_out=np.zeros((n * ns, 2), self.ndtype))
            assert h["anchor"].shape == (n * ns, N_ANCHOR)
        self._host = h
        self._on_cpu = wp.get_device(self.device).is_cpu
        d, dt = self.device, self.wdtype
        self._dev = {k: (wp.array(v, dtype=dt, device=d, copy=False) if self._on_cpu
                         else wp.zeros(v.shape, dtype=dt, device=d)) for k, v in h.items()}
        if self.anchor:
            for k in ("h_act_in", "h_act_out"):
                h[k] = np.zeros(n * ns, np.int32)
                self._dev[k] = (wp.array(h[k], dtype=wp.int32, device=d, copy=False) if self._on_cpu
                                else wp.zeros(n * ns, dtype=wp.int32, device=d))
            if not self._on_cpu:
                self._dev["anchor"].assign(h["anchor"])
        self.fparams = wp.array(fparams, dtype=dt, device=d)
        self.iparams = wp.array(iparams, dtype=wp.int32, device=d)
        self.stations = wp.array(np.asarray(stations, self.ndtype), dtype=dt, device=d)
        D = self._dev
        if mode == "shared":
            kernel = _shared_kernel(dt)
            self._out_names = ("q", "dqdq", "tilt_m", "slices", "pin", "sleeve_du", "slice_df")
        elif self.anchor:
            kernel = _plain_anchor_kernel(dt)
            self._out_names = ("q", "dqdq", "tilt_m", "slices", "slice_df", "ft", "h_act_out", "h_a_out", "h_b_out")
        else:
            kernel = _plain_kernel(dt)
            self._out_names = ("q", "dqdq", "tilt_m", "slices", "slice_df")
        if self.anchor:
            inputs = [self.fparams, self.iparams, self.stations, D["anchor"], D["pose"], D["tilt"], D["h_act_in"],
                      D["h_a_in"], D["h_b_in"]]
        else:
            inputs = [self.fparams, self.iparams, self.stations, int(self.slice_tangent), D["pose"], D["tilt"]]
        self._cmd = wp.launch(kernel, dim=n, device=d, inputs=inputs, outputs=[D[k] for k in self._out_names],
                              record_cmd=True)

    # outputs left on the device (returned as None; read them with device_array)
    keep_on_device = frozenset()


    def evaluate(self, pose, tilt=None, history=None):
        """Results in the layout of :mod:`output_pins_ref` (arrays owned by this object, overwritten next call).

        pose: (n_rows_pose, 3) [m, m, rad]; tilt: (n_rows_pose, 2) [rad] or None (zero).
        Returns a dict: Q, dQdq, tilt_moments, slices (N, n_wheels*ns, cols) and, in
        shared mode, pin and sleeve_tangent; slice_force_tangent if enabled.
        """
        h = self._host
        h["pose"][...] = pose
        names = ["pose"]
        if self.anchor:
            # committed history (flags, anchor_A, anchor_B) of the slice rows
            h["h_act_in"][...], h["h_a_in"][...], h["h_b_in"][...] = history
            names += ["h_act_in", "h_a_in", "h_b_in"]
        if tilt is not None:
            h["tilt"][...] = tilt
            names.append("tilt")
        elif h["tilt"].any():
            h["tilt"][...] = 0.0
            names.append("tilt")
        if not self._on_cpu:
            for k in names:
                self._dev[k].assign(h[k])
        self._cmd.launch()
        if not self._on_cpu:
            for k in self._out_names:
                if k not in self.keep_on_device:
                    h[k][...] = self._dev[k].numpy()
        g = {k: (None if k in self.keep_on_device else v) for k, v in h.items()}
        out = {"Q": g["q"], "dQdq": g["dqdq"], "tilt_moments": g["tilt_m"], "slices": g["slices"]}
        if self.mode == "shared":
            out["pin"] = h["pin"]
            out["sleeve_tangent"] = h["sleeve_du"]
        if self.slice_tangent:
            out["slice_force_tangent"] = h["slice_df"]
        if self.anchor:
            out["ft"] = h["ft"]
            out["trial"] = (h["h_act_out"], h["h_a_out"], h["h_b_out"])
        return out


# --------------------------------------------------------------------------------------------
# Force-only shared-pin kernel for Warp's reverse mode (wp.Tape): the moment diagnostic of
# Appendix "Independent check of the geometric moment derivative" differentiates the force
# routine itself instead of the hand-written forward-mode tangent. ``static_loops`` = 0 keeps
# the natural dynamic loops over slices and sleeve updates (runtime bounds); a positive value
# (the slice count) unrolls both loops at code generation, so every accumulation is a new SSA
# value that the adjoint can replay.
@functools.lru_cache(maxsize=None)
def _adjoint_kernel(dtype, static_slices, static_updates):
    F = _funcs(dtype)
    vec2, body_pose, param_vec2, store_triple = F["vec2"], F["body_pose"], F["param_vec2"], F["store_triple"]
    rot = F["rot"]              # the planar helper of warp_contacts/planar.py, as the forward kernels
    unrolled = static_slices > 0

    @wp.func
    def dist(v: vec2, floor: dtype):
        return wp.max(wp.sqrt(v[0] * v[0] + v[1] * v[1]), floor)

    if unrolled:
        @wp.func
        def wheel_open(e: vec2, u: vec2, clr: dtype, ks: dtype, p: dtype, dmin: dtype, dfloor: dtype):
            F0 = dtype(0.0)
            K = dtype(0.0)
            for js in range(wp.static(static_slices)):
                d = dist(e + u, dfloor) - clr
                if d > dtype(0.0):
                    F0 = F0 + ks * wp.pow(d, p)
                    K = K + p * ks * wp.pow(wp.max(d, dmin), p - dtype(1.0))
            return F0, K
    else:
        @wp.func
        def wheel_open(e: vec2, u: vec2, clr: dtype, ks: dtype, p: dtype, dmin: dtype, dfloor: dtype,
                       ns: int):
            F0 = dtype(0.0)
            K = dtype(0.0)
            for js in range(ns):
                d = dist(e + u, dfloor) - clr
                if d > dtype(0.0):
                    F0 += ks * wp.pow(d, p)
                    K += p * ks * wp.pow(wp.max(d, dmin), p - dtype(1.0))
            return F0, K

    @wp.func
    def closure(F00: dtype, F01: dtype, K0: dtype, K1: dtype, n0: vec2, n1: vec2, c00: dtype, c11: dtype,
                cross: dtype, detfloor: dtype):
        c01 = cross * wp.dot(n0, n1)
        A00 = dtype(1.0) + K0 * c00
        A11 = dtype(1.0) + K1 * c11
        det = wp.max(A00 * A11 - K0 * K1 * c01 * c01, detfloor)
        Fc0 = wp.max((A11 * F00 - K0 * c01 * F01) / det, dtype(0.0))
        Fc1 = wp.max((A00 * F01 - K1 * c01 * F00) / det, dtype(0.0))
        return Fc0, Fc1, c00 * Fc0 + c01 * Fc1, c01 * Fc0 + c11 * Fc1

    # max_unroll covers the sleeve updates plus the final closure (17 passes), so the static
    # variant is fully unrolled; above the limit Warp would silently emit a dynamic loop again
    @wp.kernel(module="unique", module_options={"max_unroll": max(16, static_updates + 1)})
    def shared_pin_forces(fparams: wp.array2d(dtype=dtype), iparams: wp.array2d(dtype=wp.int32),
                          stations: wp.array(dtype=dtype), pose_in: wp.array2d(dtype=dtype),
                          q_out: wp.array2d(dtype=dtype)):
        i = wp.tid()
        bf = iparams[i, ref.I_FLANGE]
        b0 = iparams[i, ref.I_WHEEL0]
        b1 = iparams[i, ref.I_WHEEL1]
        ns = stations.shape[0]
        ks = fparams[i, ref.P_K] / dtype(ns)
        p = fparams[i, ref.P_EXP]
        clr0 = fparams[i, ref.P_R_HOLE] - fparams[i, ref.P_R_PIN] + fparams[i, ref.P_OFF0]
        clr1 = fparams[i, ref.P_R_HOLE] - fparams[i, ref.P_R_PIN] + fparams[i, ref.P_OFF1]
        c00 = fparams[i, ref.P_C00] + fparams[i, ref.P_CIN]
        c11 = fparams[i, ref.P_C11] + fparams[i, ref.P_CIN]
        cross = fparams[i, ref.P_C01]
        clear = fparams[i, ref.P_CLEAR]
        relax = fparams[i, ref.P_RELAX]
        kfloor = fparams[i, ref.P_KFLOOR]
        detfloor = fparams[i, ref.P_DETFLOOR]
        dfloor = fparams[i, ref.P_DISTFLOOR]
        dmin = fparams[i, ref.P_DMIN]
        xf, thf = body_pose(pose_in, bf)
        x0, th0 = body_pose(pose_in, b0)
        x1, th1 = body_pose(pose_in, b1)
        pf = rot(thf, param_vec2(fparams, i, ref.P_XI_PIN))
        ph0 = rot(th0, param_vec2(fparams, i, ref.P_XI_HOLE0))
        ph1 = rot(th1, param_vec2(fparams, i, ref.P_XI_HOLE1))
        # planar (untilted) separations: every slice of a wheel shares e_i
        e0 = (xf + pf) - (x0 + ph0)
        e1 = (xf + pf) - (x1 + ph1)
        u = vec2()
        F00 = dtype(0.0)
        F01 = dtype(0.0)
        K0 = dtype(0.0)
        K1 = dtype(0.0)
        n0 = vec2()
        n1 = vec2()
        Fc0 = dtype(0.0)
        Fc1 = dtype(0.0)
        up0 = dtype(0.0)
        up1 = dtype(0.0)
        if wp.static(unrolled):
            for it in range(wp.static(static_updates + 1)):
                F00, K0 = wheel_open(e0, u, clr0, ks, p, dmin, dfloor)
                F01, K1 = wheel_open(e1, u, clr1, ks, p, dmin, dfloor)
                n0 = (e0 + u) / dist(e0 + u, dfloor)
                n1 = (e1 + u) / dist(e1 + u, dfloor)
                Fc0, Fc1, up0, up1 = closure(F00, F01, K0, K1, n0, n1, c00, c11, cross, detfloor)
                if it < wp.static(static_updates):
                    w = u - (relax / wp.max(K0 + K1, kfloor)) * (Fc0 * n0 + Fc1 * n1)
                    wl = wp.sqrt(w[0] * w[0] + w[1] * w[1])
                    u = w
                    if wl > clear:
                        u = (clear / wl) * w
        else:
            nupd = iparams[i, ref.I_UPDATES]
            for it in range(nupd + 1):
                F00, K0 = wheel_open(e0, u, clr0, ks, p, dmin, dfloor, ns)
                F01, K1 = wheel_open(e1, u, clr1, ks, p, dmin, dfloor, ns)
                n0 = (e0 + u) / dist(e0 + u, dfloor)
                n1 = (e1 + u) / dist(e1 + u, dfloor)
                Fc0, Fc1, up0, up1 = closure(F00, F01, K0, K1, n0, n1, c00, c11, cross, detfloor)
                if it < nupd:
                    w = u - (relax / wp.max(K0 + K1, kfloor)) * (Fc0 * n0 + Fc1 * n1)
                    wl = wp.sqrt(w[0] * w[0] + w[1] * w[1])
                    u = w
                    if wl > clear:
                        u = (clear / wl) * w
        # nonlinear re-evaluation after subtracting the station deflections; reaction assembly
        f0 = ks * wp.pow(wp.max(dist(e0 + u, dfloor) - clr0 - up0, dtype(0.0)), p) * dtype(ns) * n0
        f1 = ks * wp.pow(wp.max(dist(e1 + u, dfloor) - clr1 - up1, dtype(0.0)), p) * dtype(ns) * n1
        arm = pf + u
        store_triple(q_out, i, ref.X_FLANGE, -(f0[0] + f1[0]), -(f0[1] + f1[1]),
                     -(arm[0] * (f0[1] + f1[1]) - arm[1] * (f0[0] + f1[0])))
        store_triple(q_out, i, ref.X_WHEEL0, f0[0], f0[1], ph0[0] * f0[1] - ph0[1] * f0[0])
        store_triple(q_out, i, ref.X_WHEEL1, f1[0], f1[1], ph1[0] * f1[1] - ph1[1] * f1[0])

    return shared_pin_forces


def shared_pin_adjoint_jacobian(fparams, iparams, stations, pose, unrolled, precision="float64", device="cpu"):
    """dQ/dpose (N, 9, nb, 3) of the force-only shared-pin kernel by Warp's reverse mode (wp.Tape).

    Planar states only (no tilts; untilted slices of a wheel share one
    separation). ``unrolled``: unroll the slice and update loops at code
    generation (static bounds) instead of the dynamic loops. Also returns Q (N, 9).
    """
    wdt, ndt = scalar_types(precision)
    device = resolve_device(device)
    fparams = np.ascontiguousarray(fparams, ndt)
    iparams = np.ascontiguousarray(iparams, np.int32)
    n = fparams.shape[0]
    if unrolled:
        nupd = set(int(v) for v in iparams[:, ref.I_UPDATES])
        assert len(nupd) == 1, "the unrolled kernel needs one update count for all pins"
        kernel = _adjoint_kernel(wdt, len(stations), nupd.pop())
    else:
        kernel = _adjoint_kernel(wdt, 0, 0)
    fa = wp.array(fparams, dtype=wdt, device=device)
    ia = wp.array(iparams, dtype=wp.int32, device=device)
    sa = wp.array(np.asarray(stations, ndt), dtype=wdt, device=device)
    pa = wp.array(np.asarray(pose, ndt), dtype=wdt, device=device, requires_grad=True)
    qa = wp.zeros((n, 9), dtype=wdt, device=device, requires_grad=True)
    tape = wp.Tape()
    with tape:
        wp.launch(kernel, dim=n, inputs=[fa, ia, sa, pa], outputs=[qa], device=device)
    Q = qa.numpy().astype(np.float64)
    J = np.zeros((n, 9) + pa.shape)
    for r in range(9):
        # one reverse sweep per output component; pins are independent, so one sweep serves all rows
        seed = np.zeros((n, 9), ndt)
        seed[:, r] = 1.0
        tape.backward(grads={qa: wp.array(seed, dtype=wdt, device=device)})
        g = pa.grad.numpy().astype(np.float64)
        for k in range(n):
            bodies = iparams[k, [ref.I_FLANGE, ref.I_WHEEL0, ref.I_WHEEL1]]
            J[k, r][bodies] = g[bodies]   # each pose row feeds only the pins that read it
        tape.zero()
    return Q, J
