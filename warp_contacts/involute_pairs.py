"""Warp kernel of the involute tooth-pair contact family (candidate selection, line-of-action
or tip-edge geometry, series law, friction and analytic tangent in one launch; one thread
per tooth-pair slice).

Mirrors :mod:`warp_contacts.involute_pairs_ref` function by function (``select``,
``geom_line``, ``geom_corner_a``, ``geom_corner_b``, ``gap_terms``, ``series_force``); see
there for the equations. The parameter columns are the reference's named constants.
The tangent's seed loop reuses the seed-independent transcendentals of the geometry
(``geometry_trig``) and the profile values of the gap (``profile_terms``), computed once per
row by the same operations the geometry would repeat for every seed (same results, bit for bit).
"""
import functools

import numpy as np
import warp as wp

from .involute_pairs_ref import (
    C_BS, C_C, C_DR, C_E, C_MUK, C_MUS, C_TANPSI, C_TX, C_TY, C_VREG, C_VS, C_Z, G_B, G_CA, G_CAL, G_CB, G_CF, G_CHI,
    G_E, G_EPS, G_FHB, G_NU, G_PC, G_PH, G_PHALF, G_PMID, G_PSI, G_QA, G_QF, G_RB, G_RHO_C, G_RHO_E, G_UCA, G_UCF,
    G_UEDGE, G_UHALF, G_UHI, G_ULO, G_UMID, G_UREF, G_UROOT, G_UTIP, GEAR_A, GEAR_B, J_BODY_A, J_BODY_B, J_FRICTION,
    J_LINE, J_NA, J_NB, J_TOOTH_A, J_TOOTH_B, J_WINDOW, MODE_CORNER_A, MODE_CORNER_B, MODE_LINE, MODE_OPEN, N_FLOAT,
    N_INT, N_OBS, O_GAP, O_KT, O_MODE, O_TOOTH_A, O_TOOTH_B, O_UA, O_UB, O_VROLL, OPEN_GAP, POLY_TERMS, SERIES_MAX_ITERATIONS, SERIES_RTOL)
from . import circle_pairs_ref, involute_pairs_ref
from .anchor import anchor_funcs
from .circle_pairs_ref import FRICTION_ANCHOR
from .laws import law_funcs
from .planar import planar_funcs
from .recorded import PairLaunch, assign_parameters
from .precision import resolve_device, scalar_types

# the first observation columns are the contact element's (written by planar.store_pair_observation)
assert all(getattr(involute_pairs_ref, c) == getattr(circle_pairs_ref, c)
           for c in ("O_FN", "O_VT", "O_GAP", "O_PX", "O_PY", "O_NX", "O_NY", "O_FT"))


@functools.lru_cache(maxsize=None)
def _kernel(dtype, velocity_tangent=True, anchor=False):
    """The family's kernel; ``anchor`` compiles the anchor friction of :mod:`anchor_ref` in
    (without it the anchor arguments are never read and the code is the frictionless one)."""
    L = law_funcs(dtype)
    P = planar_funcs(dtype)
    A = anchor_funcs(dtype)
    anchor_state, anchor_force_tangent, anchor_trial = A.anchor_state, A.anchor_force_tangent, A.anchor_trial
    vec2, perp, cross2, body_seed = P.vec2, P.perp, P.cross2, P.body_seed
    vec4 = wp.types.vector(4, dtype)      # packs of seed-independent values handed to the seed loop
    rot, row_vec2, store_row_vec2 = P.rot, P.row_vec2, P.store_row_vec2
    store_pair_forces, store_pair_column = P.store_pair_forces, P.store_pair_column
    body_state, store_pair_observation = P.body_state, P.store_pair_observation
    damping_ramp, friction_coefficient = L.damping_ramp, L.friction_coefficient
    np_dtype = np.float64 if dtype == wp.float64 else np.float32
    RTOL = SERIES_RTOL[np_dtype]
    TWO_PI = dtype(2.0 * np.pi)
    PI = dtype(np.pi)

    @wp.func
    def unit(phi: dtype):
        return vec2(wp.cos(phi), wp.sin(phi))

    @wp.func
    def nearest(x: dtype):
        return wp.floor(x + dtype(0.5))

    @wp.func
    def wrap(x: dtype):
        return x + PI - TWO_PI * wp.floor((x + PI) / TWO_PI) - PI

    @wp.func
    def imod(a: int, n: int):
        return ((a % n) + n) % n

    @wp.func
    def poly(fp: wp.array2d(dtype=dtype), i: int, g: int, base: int, u: dtype):
        """Gear polynomial (compliance base G_PC or depth G_PH) and its u-derivative."""
        half = fp[i, g + G_PHALF]
        t = (u - fp[i, g + G_PMID]) / half
        v = dtype(0.0)
        dv = dtype(0.0)
        for m in range(POLY_TERMS):
            dv = dv * t + v
            v = v * t + fp[i, g + base + POLY_TERMS - 1 - m]
        return v, dv / half

    @wp.func
    def relief(amt: dtype, st: dtype, en: dtype, q: dtype, u: dtype):
        if amt <= dtype(0.0):
            return dtype(0.0), dtype(0.0)
        span = en - st
        t = (u - st) / span
        if t <= dtype(0.0):
            return dtype(0.0), dtype(0.0)
        return amt * wp.pow(t, q), amt * q * wp.pow(t, q - dtype(1.0)) / span

    @wp.func
    def modification(fp: wp.array2d(dtype=dtype), i: int, g: int, u: dtype, z: dtype):
        ea, dea = relief(fp[i, g + G_CA], fp[i, g + G_UCA], fp[i, g + G_UTIP], fp[i, g + G_QA], u)
        ef, def_ = relief(fp[i, g + G_CF], fp[i, g + G_UCF], fp[i, g + G_UROOT], fp[i, g + G_QF], u)
        w = (u - fp[i, g + G_UMID]) / fp[i, g + G_UHALF]
        b = fp[i, g + G_B]
        cal = fp[i, g + G_CAL]
        e = ea + ef + cal * w * w + fp[i, g + G_CB] * (dtype(2.0) * z / b) * (dtype(2.0) * z / b) + fp[i, g + G_FHB] * z / b
        return e, dea + def_ + dtype(2.0) * cal * w / fp[i, g + G_UHALF]

    @wp.func
    def weber(F: dtype, hA: dtype, hB: dtype, K: dtype, EA: dtype, nuA: dtype, EB: dtype, nuB: dtype, bs: dtype):
        CA = dtype(2.0) * (dtype(1.0) - nuA * nuA) / (PI * EA * bs)
        CB = dtype(2.0) * (dtype(1.0) - nuB * nuB) / (PI * EB * bs)
        estar = dtype(1.0) / ((dtype(1.0) - nuA * nuA) / EA + (dtype(1.0) - nuB * nuB) / EB)
        aH = wp.sqrt(dtype(4.0) * F / (PI * bs * estar * K))
        dH = F * (CA * (wp.log(dtype(2.0) * hA / aH) - nuA / (dtype(2.0) * (dtype(1.0) - nuA)))
                  + CB * (wp.log(dtype(2.0) * hB / aH) - nuB / (dtype(2.0) * (dtype(1.0) - nuB))))
        return dH, dH / F - dtype(0.5) * (CA + CB), CA, CB

    @wp.func
    def series_force(delta: dtype, C: dtype, hA: dtype, hB: dtype, K: dtype, EA: dtype, nuA: dtype, EB: dtype,
                     nuB: dtype, bs: dtype):
        """F and (dF/d delta, dF/dC, dF/dh_A, dF/dh_B, dF/dK) of Eq. (series_contact)."""
        lo = dtype(0.0)
        hi = delta / C
        dHh, dHdh, CA, CB = weber(hi, hA, hB, K, EA, nuA, EB, nuB, bs)
        bad = not (C * hi + dHh - delta >= dtype(0.0))
        F = dtype(0.5) * hi
        if not bad:
            for it in range(SERIES_MAX_ITERATIONS):
                dH, dHd, CA_, CB_ = weber(F, hA, hB, K, EA, nuA, EB, nuB, bs)
                G = C * F + dH - delta
                Gp = C + dHd
                if G < dtype(0.0):
                    lo = F
                else:
                    hi = F
                Fn = F - G / Gp
                if not (Fn > lo and Fn < hi and Gp > dtype(0.0)):
                    Fn = dtype(0.5) * (lo + hi)
                done = wp.abs(Fn - F) <= dtype(RTOL) * Fn
                F = Fn
                if done:
                    break
        dH, dHd, CA2, CB2 = weber(F, hA, hB, K, EA, nuA, EB, nuB, bs)
        Gp = C + dHd
        if bad or not (Gp > dtype(0.0)):
            nan = wp.nan
            return dtype(nan), dtype(nan), dtype(nan), dtype(nan), dtype(nan), dtype(nan)
        return F, dtype(1.0) / Gp, -F / Gp, -F * CA2 / hA / Gp, -F * CB2 / hB / Gp, -F * dtype(0.5) * (CA2 + CB2) / K / Gp

    @wp.func
    def foot(Pc: vec2, dPc: vec2, O: vec2, dO: vec2, rb: dtype, omega: dtype):
        w = Pc - O
        dw = dPc - dO
        rho = wp.length(w)
        drho = wp.dot(w, dw) / rho
        lam = wp.sqrt(wp.max(rho * rho - rb * rb, dtype(0.0)))
        lam_s = lam
        if lam <= dtype(0.0):
            lam_s = dtype(1.0)
        phit = wp.atan2(w[1], w[0]) + omega * wp.acos(wp.clamp(rb / rho, dtype(-1.0), dtype(1.0)))
        dphit = cross2(w, dw) / (rho * rho) + omega * rb * drho / (rho * lam_s)
        return phit, dphit, lam, rho * drho / lam_s, rho > rb

    @wp.func
    def foot_trig(Pc: vec2, O: vec2, rb: dtype, omega: dtype):
        """The seed-independent part of :func:`foot`: rho, lam and phit (its square root and angles)."""
        w = Pc - O
        rho = wp.length(w)
        lam = wp.sqrt(wp.max(rho * rho - rb * rb, dtype(0.0)))
        phit = wp.atan2(w[1], w[0]) + omega * wp.acos(wp.clamp(rb / rho, dtype(-1.0), dtype(1.0)))
        return rho, lam, phit

    @wp.func
    def foot_seeded(Pc: vec2, dPc: vec2, O: vec2, dO: vec2, rb: dtype, omega: dtype, rho: dtype, lam: dtype,
                    phit: dtype):
        """:func:`foot` with its seed-independent part (:func:`foot_trig`) given: the same operations."""
        w = Pc - O
        dw = dPc - dO
        drho = wp.dot(w, dw) / rho
        lam_s = lam
        if lam <= dtype(0.0):
            lam_s = dtype(1.0)
        dphit = cross2(w, dw) / (rho * rho) + omega * rb * drho / (rho * lam_s)
        return phit, dphit, lam, rho * drho / lam_s, rho > rb

    @wp.func
    def flank_offset(ip: wp.array2d(dtype=wp.int32), dev: wp.array(dtype=dtype), goff: wp.array(dtype=dtype), i: int,
                     k: int, j: int):
        """Gap offset of the row's tooth pair on its line (see the reference's flank_offset)."""
        base = ip[i, J_LINE] * dev.shape[0]
        return goff[base + ip[i, J_TOOTH_A] + k] + goff[base + ip[i, J_TOOTH_B] + j]

    @wp.func
    def tooth_angle(ip: wp.array2d(dtype=wp.int32), dev: wp.array(dtype=dtype), i: int, which: int, k: int):
        """2 pi k / z + deviation of tooth k of gear A (which = 0) or B (which = 1)."""
        z = ip[i, J_NA]
        off = ip[i, J_TOOTH_A]
        if which == 1:
            z = ip[i, J_NB]
            off = ip[i, J_TOOTH_B]
        return TWO_PI * dtype(k) / dtype(z) + dev[off + k]

    @wp.func
    def geom_line(fp: wp.array2d(dtype=dtype), ip: wp.array2d(dtype=wp.int32), dev: wp.array(dtype=dtype), i: int,
                  OA: vec2, tha: dtype, OB: vec2, thb: dtype, k: int, j: int, off_a: dtype, off_b: dtype,
                  dOA: vec2, dtha: dtype, dOB: vec2, dthb: dtype, tv0: vec2, tv1: vec2, trig: vec4):
        eps = fp[i, GEAR_B + G_EPS]
        s = dtype(1.0)
        if ip[i, J_LINE] != 0:
            s = dtype(-1.0)
        omega = s * eps
        rba = fp[i, GEAR_A + G_RB]
        rbb = fp[i, GEAR_B + G_RB]
        D = OB - OA
        dD = dOB - dOA
        a = trig[0]
        da = wp.dot(D, dD) / a
        beta = trig[1]
        dbeta = cross2(D, dD) / (a * a)
        Rs = rbb + eps * rba
        aw = trig[2]
        sw = trig[3]
        daw = Rs * da / (a * a * sw)
        phia = beta + s * aw
        if eps < dtype(0.0):
            phia = beta + s * (PI - aw)
        dphia = dbeta + s * eps * daw
        ea = tv0
        d = -omega * perp(ea)
        dd = (omega * dphia) * ea
        TA = OA + rba * ea
        dTA = dOA + (rba * dphia) * perp(ea)
        TB = OB - (eps * rbb) * ea
        dTB = dOB - (eps * rbb * dphia) * perp(ea)
        Ll = eps * a * sw
        dL = eps * da / sw
        ua = (omega * (phia - tha + omega * fp[i, GEAR_A + G_PSI]) - omega * tooth_angle(ip, dev, i, 0, k)
              - TWO_PI * off_a)
        phib = phia
        if eps > dtype(0.0):
            phib = phia + PI
        ub = (omega * (phib - thb + omega * eps * fp[i, GEAR_B + G_PSI]) - omega * tooth_angle(ip, dev, i, 1, j)
              - TWO_PI * off_b)
        dua = omega * (dphia - dtha)
        dub = omega * (dphia - dthb)
        cA = TA + (rba * ua) * d
        dcA = dTA + (rba * dua) * d + (rba * ua) * dd
        cB = TB - (eps * rbb * ub) * d
        dcB = dTB - (eps * rbb * dub) * d - (eps * rbb * ub) * dd
        g = Ll - rba * ua - eps * rbb * ub
        dg = dL - rba * dua - eps * rbb * dub
        return g, dg, d, dd, cA, dcA, cB, dcB, ua, dua, ub, dub, rba * ua, rba * dua, rbb * ub, rbb * dub, eps

    @wp.func
    def geom_corner_a(fp: wp.array2d(dtype=dtype), ip: wp.array2d(dtype=wp.int32), dev: wp.array(dtype=dtype), i: int,
                      OA: vec2, tha: dtype, OB: vec2, thb: dtype, k: int, j: int, off_a: dtype, off_b: dtype,
                      dOA: vec2, dtha: dtype, dOB: vec2, dthb: dtype, tv0: vec2, tv1: vec2, trig: vec4):
        eps = fp[i, GEAR_B + G_EPS]
        s = dtype(1.0)
        if ip[i, J_LINE] != 0:
            s = dtype(-1.0)
        omega = s * eps
        rbb = fp[i, GEAR_B + G_RB]
        rc = fp[i, GEAR_A + G_RHO_C]
        Pc = OA + rc * tv0
        dPc = dOA + (rc * dtha) * perp(tv0)
        phit, dphit, lam, dlam, ok = foot_seeded(Pc, dPc, OB, dOB, rbb, omega, trig[0], trig[1], trig[2])
        ub = (omega * (phit - thb + omega * eps * fp[i, GEAR_B + G_PSI]) - omega * tooth_angle(ip, dev, i, 1, j)
              - TWO_PI * off_b)
        dub = omega * (dphit - dthb)
        et = tv1
        dT = -omega * perp(et)
        ddT = (omega * dphit) * et
        n = -eps * dT
        dn = -eps * ddT
        cB = OB + rbb * et + (rbb * ub) * dT
        dcB = dOB + (rbb * dphit) * perp(et) + (rbb * dub) * dT + (rbb * ub) * ddT
        rho_e = fp[i, GEAR_A + G_RHO_E]
        cA = Pc + rho_e * n
        dcA = dPc + rho_e * dn
        ue = fp[i, GEAR_A + G_UEDGE]
        zero = dtype(0.0)
        return (eps * (lam - rbb * ub) - rho_e, eps * (dlam - rbb * dub), n, dn, cA, dcA, cB, dcB, ue, zero, ub, dub,
                rho_e, zero, rbb * ub, rbb * dub, eps)

    @wp.func
    def geom_corner_b(fp: wp.array2d(dtype=dtype), ip: wp.array2d(dtype=wp.int32), dev: wp.array(dtype=dtype), i: int,
                      OA: vec2, tha: dtype, OB: vec2, thb: dtype, k: int, j: int, off_a: dtype, off_b: dtype,
                      dOA: vec2, dtha: dtype, dOB: vec2, dthb: dtype, tv0: vec2, tv1: vec2, trig: vec4):
        eps = fp[i, GEAR_B + G_EPS]
        s = dtype(1.0)
        if ip[i, J_LINE] != 0:
            s = dtype(-1.0)
        omega = s * eps
        rba = fp[i, GEAR_A + G_RB]
        rc = fp[i, GEAR_B + G_RHO_C]
        Pc = OB + rc * tv0
        dPc = dOB + (rc * dthb) * perp(tv0)
        phit, dphit, lam, dlam, ok = foot_seeded(Pc, dPc, OA, dOA, rba, omega, trig[0], trig[1], trig[2])
        ua = (omega * (phit - tha + omega * fp[i, GEAR_A + G_PSI]) - omega * tooth_angle(ip, dev, i, 0, k)
              - TWO_PI * off_a)
        dua = omega * (dphit - dtha)
        et = tv1
        n = -omega * perp(et)
        dn = (omega * dphit) * et
        cA = OA + rba * et + (rba * ua) * n
        dcA = dOA + (rba * dphit) * perp(et) + (rba * dua) * n + (rba * ua) * dn
        rho_e = fp[i, GEAR_B + G_RHO_E]
        cB = Pc - rho_e * n
        dcB = dPc - rho_e * dn
        ue = fp[i, GEAR_B + G_UEDGE]
        zero = dtype(0.0)
        return (lam - rba * ua - rho_e, dlam - rba * dua, n, dn, cA, dcA, cB, dcB, ua, dua, ue, zero,
                rba * ua, rba * dua, rho_e, zero, dtype(1.0))

    @wp.func
    def geometry_trig(mode: int, fp: wp.array2d(dtype=dtype), ip: wp.array2d(dtype=wp.int32),
                      dev: wp.array(dtype=dtype), i: int, OA: vec2, tha: dtype, OB: vec2, thb: dtype, k: int, j: int):
        """The seed-independent transcendentals of :func:`geometry` at a state, computed once per row
        and reused by every seed (the same operations as inside geom_*, so the same bits):
        line: tv0 = e(phi_a), trig = (|O_B - O_A|, beta, alpha_w, sin alpha_w); corners: tv0 = the edge
        centre's direction e(ang), tv1 = e(phi_t), trig = (rho, lam, phi_t) of the foot."""
        eps = fp[i, GEAR_B + G_EPS]
        s = dtype(1.0)
        if ip[i, J_LINE] != 0:
            s = dtype(-1.0)
        omega = s * eps
        zero = dtype(0.0)
        if mode == MODE_CORNER_A:
            rbb = fp[i, GEAR_B + G_RB]
            ang = tha + tooth_angle(ip, dev, i, 0, k) - omega * fp[i, GEAR_A + G_PSI] + omega * fp[i, GEAR_A + G_CHI]
            ea = unit(ang)
            rho, lam, phit = foot_trig(OA + fp[i, GEAR_A + G_RHO_C] * ea, OB, rbb, omega)
            return ea, unit(phit), vec4(rho, lam, phit, zero)
        if mode == MODE_CORNER_B:
            rba = fp[i, GEAR_A + G_RB]
            ang = (thb + tooth_angle(ip, dev, i, 1, j) - omega * eps * fp[i, GEAR_B + G_PSI]
                   + omega * fp[i, GEAR_B + G_CHI])
            eb = unit(ang)
            rho, lam, phit = foot_trig(OB + fp[i, GEAR_B + G_RHO_C] * eb, OA, rba, omega)
            return eb, unit(phit), vec4(rho, lam, phit, zero)
        rba = fp[i, GEAR_A + G_RB]
        rbb = fp[i, GEAR_B + G_RB]
        D = OB - OA
        a = wp.length(D)
        beta = wp.atan2(D[1], D[0])
        Rs = rbb + eps * rba
        aw = wp.acos(Rs / a)
        phia = beta + s * aw
        if eps < dtype(0.0):
            phia = beta + s * (PI - aw)
        return unit(phia), vec2(zero, zero), vec4(a, beta, aw, wp.sin(aw))

    @wp.func
    def geometry(mode: int, fp: wp.array2d(dtype=dtype), ip: wp.array2d(dtype=wp.int32), dev: wp.array(dtype=dtype),
                 i: int, OA: vec2, tha: dtype, OB: vec2, thb: dtype, k: int, j: int, off_a: dtype, off_b: dtype,
                 dOA: vec2, dtha: dtype, dOB: vec2, dthb: dtype, tv0: vec2, tv1: vec2, trig: vec4):
        if mode == MODE_CORNER_A:
            return geom_corner_a(fp, ip, dev, i, OA, tha, OB, thb, k, j, off_a, off_b, dOA, dtha, dOB, dthb,
                                 tv0, tv1, trig)
        if mode == MODE_CORNER_B:
            return geom_corner_b(fp, ip, dev, i, OA, tha, OB, thb, k, j, off_a, off_b, dOA, dtha, dOB, dthb,
                                 tv0, tv1, trig)
        return geom_line(fp, ip, dev, i, OA, tha, OB, thb, k, j, off_a, off_b, dOA, dtha, dOB, dthb, tv0, tv1, trig)

    @wp.func
    def profile_terms(fp: wp.array2d(dtype=dtype), i: int, ua: dtype, ub: dtype):
        """The seed-independent profile values of :func:`gap_terms` at the contact's roll parameters:
        (e_A, e_A', e_B, e_B') of the modifications and (c_A, c_A', c_B, c_B'), (h_A, h_A', h_B, h_B')
        of the compliance and depth polynomials (computed once per row, reused by every seed)."""
        z = fp[i, C_Z]
        eA, deA = modification(fp, i, GEAR_A, ua, z)
        eB, deB = modification(fp, i, GEAR_B, ub, z)
        cA, dcA = poly(fp, i, GEAR_A, G_PC, ua)
        cB, dcB = poly(fp, i, GEAR_B, G_PC, ub)
        hA, dhA = poly(fp, i, GEAR_A, G_PH, ua)
        hB, dhB = poly(fp, i, GEAR_B, G_PH, ub)
        return vec4(eA, deA, eB, deB), vec4(cA, dcA, cB, dcB), vec4(hA, dhA, hB, dhB)

    @wp.func
    def gap_terms(fp: wp.array2d(dtype=dtype), i: int, g0: dtype, dg0: dtype, n: vec2, dn: vec2, ua: dtype, dua: dtype,
                  ub: dtype, dub: dtype, RA: dtype, dRA: dtype, RB: dtype, dRB: dtype, sB: dtype, pe: vec4, pc: vec4,
                  ph: vec4):
        z = fp[i, C_Z]
        eA = pe[0]
        deA = pe[1]
        eB = pe[2]
        deB = pe[3]
        tx = fp[i, C_TX]
        ty = fp[i, C_TY]
        g = g0 + eA + eB + fp[i, C_E] + z * (ty * n[0] - tx * n[1]) + z * fp[i, C_TANPSI]
        dg = dg0 + deA * dua + deB * dub + z * (ty * dn[0] - tx * dn[1])
        cA = pc[0]
        dcA = pc[1]
        cB = pc[2]
        dcB = pc[3]
        hA = ph[0]
        dhA = ph[1]
        hB = ph[2]
        dhB = ph[3]
        bs = fp[i, C_BS]
        K = dtype(1.0) / RA + sB / RB
        dK = -dRA / (RA * RA) - sB * dRB / (RB * RB)
        return g, dg, (cA + cB) / bs, (dcA * dua + dcB * dub) / bs, hA, dhA * dua, hB, dhB * dub, K, dK

    N_SEEDS = 12 if velocity_tangent else 6

    @wp.kernel(enable_backward=False, module="unique", module_options={"enable_backward": False, "max_unroll": 1})
    def eval_involute_pairs(
        # Model:
        fp: wp.array2d(dtype=dtype),
        ip: wp.array2d(dtype=wp.int32),
        dev: wp.array(dtype=dtype),
        goff: wp.array(dtype=dtype),
        anchor_params: wp.array2d(dtype=dtype),
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        vel_in: wp.array2d(dtype=dtype),
        hist_active_in: wp.array(dtype=wp.int32),
        hist_a_in: wp.array2d(dtype=dtype),
        hist_b_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        dqdv_out: wp.array3d(dtype=dtype),
        obs_out: wp.array2d(dtype=dtype),
        hist_active_out: wp.array(dtype=wp.int32),
        hist_a_out: wp.array2d(dtype=dtype),
        hist_b_out: wp.array2d(dtype=dtype),
    ):
        i = wp.tid()
        ia = ip[i, J_BODY_A]
        ib = ip[i, J_BODY_B]
        OA, tha, vOA, wA = body_state(pose_in, vel_in, ia)
        OB, thb, vOB, wB = body_state(pose_in, vel_in, ib)
        for c in range(6):
            q_out[i, c] = dtype(0.0)
            for c2 in range(6):
                dqdq_out[i, c, c2] = dtype(0.0)
                dqdv_out[i, c, c2] = dtype(0.0)
        for c in range(N_OBS):
            obs_out[i, c] = dtype(0.0)
        obs_out[i, O_GAP] = dtype(OPEN_GAP)

        # -- selection (primal): line of action, teeth, mode ------------------------
        eps = fp[i, GEAR_B + G_EPS]
        s = dtype(1.0)
        if ip[i, J_LINE] != 0:
            s = dtype(-1.0)
        omega = s * eps
        rba = fp[i, GEAR_A + G_RB]
        rbb = fp[i, GEAR_B + G_RB]
        za = ip[i, J_NA]
        zb = ip[i, J_NB]
        D = OB - OA
        a = wp.length(D)
        beta = wp.atan2(D[1], D[0])
        cw = (rbb + eps * rba) / a
        mode = MODE_OPEN
        k = int(0)
        j = int(0)
        off_a = dtype(0.0)
        off_b = dtype(0.0)
        if cw < dtype(1.0):
            aw = wp.acos(cw)
            phia = beta + s * aw
            if eps < dtype(0.0):
                phia = beta + s * (PI - aw)
            Ll = eps * a * wp.sin(aw)
            uref = fp[i, GEAR_A + G_UREF]
            U0a = omega * (phia - tha + omega * fp[i, GEAR_A + G_PSI])
            kstar = int(omega * nearest((U0a - uref) * dtype(za) / TWO_PI))
            k = imod(kstar + ip[i, J_WINDOW], za)
            Xa = U0a - omega * tooth_angle(ip, dev, i, 0, k)
            ua = uref + wrap(Xa - uref)
            ubt = eps * (Ll - rba * ua) / rbb
            phib = phia
            if eps > dtype(0.0):
                phib = phia + PI
            U0b = omega * (phib - thb + omega * eps * fp[i, GEAR_B + G_PSI])
            j = imod(int(omega * nearest((U0b - ubt) * dtype(zb) / TWO_PI)), zb)
            Xb = U0b - omega * tooth_angle(ip, dev, i, 1, j)
            ub = ubt + wrap(Xb - ubt)
            off_a = nearest((Xa - ua) / TWO_PI)
            off_b = nearest((Xb - ub) / TWO_PI)
            in_a = ua >= fp[i, GEAR_A + G_ULO] and ua <= fp[i, GEAR_A + G_UHI]
            in_b = ub >= fp[i, GEAR_B + G_ULO] and ub <= fp[i, GEAR_B + G_UHI]
            past_a = ua > fp[i, GEAR_A + G_UHI]
            past_b = ub < fp[i, GEAR_B + G_ULO]
            if eps > dtype(0.0):
                past_b = ub > fp[i, GEAR_B + G_UHI]
            zero2 = vec2(dtype(0.0), dtype(0.0))
            if in_a and in_b:
                mode = MODE_LINE
            elif past_a:
                # tip edge of A: its foot on B's flank decides the tooth of B and the admissibility
                ang = tha + tooth_angle(ip, dev, i, 0, k) - omega * fp[i, GEAR_A + G_PSI] + omega * fp[i, GEAR_A + G_CHI]
                Pc = OA + fp[i, GEAR_A + G_RHO_C] * unit(ang)
                phit, dphit, lam, dlam, okf = foot(Pc, zero2, OB, zero2, rbb, omega)
                Xb0 = omega * (phit - thb + omega * eps * fp[i, GEAR_B + G_PSI])
                ubt2 = lam / rbb
                j = imod(int(omega * nearest((Xb0 - ubt2) * dtype(zb) / TWO_PI)), zb)
                Xb2 = Xb0 - omega * tooth_angle(ip, dev, i, 1, j)
                ub2 = ubt2 + wrap(Xb2 - ubt2)
                off_b = nearest((Xb2 - ub2) / TWO_PI)
                if okf and ub2 >= fp[i, GEAR_B + G_ULO] and ub2 <= fp[i, GEAR_B + G_UHI]:
                    mode = MODE_CORNER_A
            elif past_b:
                ang = thb + tooth_angle(ip, dev, i, 1, j) - omega * eps * fp[i, GEAR_B + G_PSI] + omega * fp[i, GEAR_B + G_CHI]
                Pc = OB + fp[i, GEAR_B + G_RHO_C] * unit(ang)
                phit, dphit, lam, dlam, okf = foot(Pc, zero2, OA, zero2, rba, omega)
                Xa2 = omega * (phit - tha + omega * fp[i, GEAR_A + G_PSI]) - omega * tooth_angle(ip, dev, i, 0, k)
                uat = lam / rba
                ua2 = uat + wrap(Xa2 - uat)
                off_a = nearest((Xa2 - ua2) / TWO_PI)
                if okf and ua2 >= fp[i, GEAR_A + G_ULO] and ua2 <= fp[i, GEAR_A + G_UHI]:
                    mode = MODE_CORNER_B
        obs_out[i, O_MODE] = dtype(mode)
        obs_out[i, O_TOOTH_A] = dtype(k)
        obs_out[i, O_TOOTH_B] = dtype(j)
        if wp.static(anchor):
            # an open row has no anchor (overwritten below for a row in mesh)
            hist_active_out[i] = 0
            store_row_vec2(hist_a_out, i, vec2(dtype(0.0), dtype(0.0)))
            store_row_vec2(hist_b_out, i, vec2(dtype(0.0), dtype(0.0)))
        if mode == MODE_OPEN:
            return

        # -- primal geometry, gap and forces ----------------------------------------
        z2 = vec2(dtype(0.0), dtype(0.0))
        zs = dtype(0.0)
        # the seed-independent transcendentals and profile values once per row (every seed reuses them)
        tv0, tv1, trig = geometry_trig(mode, fp, ip, dev, i, OA, tha, OB, thb, k, j)
        g0, dg0, n, dn0, cA, dcA0, cB, dcB0, ua, dua0, ub, dub0, RA, dRA0, RB, dRB0, sB = geometry(
            mode, fp, ip, dev, i, OA, tha, OB, thb, k, j, off_a, off_b, z2, zs, z2, zs, tv0, tv1, trig)
        pe, pc, ph = profile_terms(fp, i, ua, ub)
        g, dg_, C, dC_, hA, dhA_, hB, dhB_, K, dK_ = gap_terms(fp, i, g0, zs, n, z2, ua, zs, ub, zs, RA, zs, RB, zs, sB,
                                                               pe, pc, ph)
        g = g + flank_offset(ip, dev, goff, i, k, j)
        delta = -g
        on = delta > dtype(0.0)
        Fel = dtype(0.0)
        Fd = dtype(0.0)
        FC = dtype(0.0)
        FhA = dtype(0.0)
        FhB = dtype(0.0)
        FK = dtype(0.0)
        if on:
            Fel, Fd, FC, FhA, FhB, FK = series_force(delta, C, hA, hB, K, fp[i, GEAR_A + G_E], fp[i, GEAR_A + G_NU],
                                                     fp[i, GEAR_B + G_E], fp[i, GEAR_B + G_NU], fp[i, C_BS])
        t = perp(n)
        cp = dtype(0.5) * (cA + cB)
        rA = cp - OA
        rB = cp - OB
        vA = vOA + wA * perp(rA)
        vB = vOB + wB * perp(rB)
        ddot = -wp.dot(n, vB - vA)
        r, dr = damping_ramp(delta, fp[i, C_DR])
        cdamp = fp[i, C_C]
        Fn = Fel + cdamp * r * ddot
        act = on and Fn > dtype(0.0)
        if not act:
            Fn = dtype(0.0)
        vt = wp.dot(t, vA - vB)
        mu, dmu = friction_coefficient(fp[i, C_MUK], fp[i, C_MUS], fp[i, C_VS], fp[i, C_VREG], vt)
        fric = act and ip[i, J_FRICTION] == 1
        Ft = dtype(0.0)
        if fric:
            Ft = -Fn * mu
        armA = rA
        armB = rB
        anchored = False
        stick = False
        slip = False
        s_anc = dtype(0.0)
        sg = dtype(0.0)
        ha = vec2(dtype(0.0), dtype(0.0))
        hb = vec2(dtype(0.0), dtype(0.0))
        e_anc = vec2(dtype(0.0), dtype(0.0))
        is_anchor = False
        if wp.static(anchor):
            is_anchor = on and ip[i, J_FRICTION] == FRICTION_ANCHOR
            ha = rot(tha, row_vec2(hist_a_in, i))
            hb = rot(thb, row_vec2(hist_b_in, i))
            e_anc = (OA + ha) - (OB + hb)
            anchored, stick, slip, s_anc, sg, ft_anc = anchor_state(Fn, is_anchor, hist_active_in[i], e_anc, t,
                                                                   anchor_params, i)
            if anchored:
                Ft = ft_anc
                armA = ha
                armB = hb
        fA = -Fn * n + Ft * t
        fnA = -Fn * n
        ftA = Ft * t
        if wp.static(anchor):
            store_pair_forces(q_out, i, fA, cross2(rA, fnA) + cross2(armA, ftA), -(cross2(rB, fnA) + cross2(armB, ftA)))
        else:
            store_pair_forces(q_out, i, fA, cross2(rA, fA), -cross2(rB, fA))

        for jseed in range(N_SEEDS):
            dOA, dtha, dOB, dthb = body_seed(jseed)
            dvOA, dwA, dvOB, dwB = body_seed(jseed - 6)
            if jseed < 6:
                dvOA = z2
                dvOB = z2
                dwA = zs
                dwB = zs
            else:
                dOA = z2
                dOB = z2
                dtha = zs
                dthb = zs
            g0s, dg0, ns, dn, cAs, dcA, cBs, dcB, uas, dua, ubs, dub, RAs, dRA, RBs, dRB, sBs = geometry(
                mode, fp, ip, dev, i, OA, tha, OB, thb, k, j, off_a, off_b, dOA, dtha, dOB, dthb, tv0, tv1, trig)
            gs, dg, Cs, dC, hAs, dhA, hBs, dhB, Ks, dK = gap_terms(fp, i, g0s, dg0, ns, dn, uas, dua, ubs, dub, RAs, dRA,
                                                                    RBs, dRB, sBs, pe, pc, ph)
            ddelta = -dg
            dFel = Fd * ddelta + FC * dC + FhA * dhA + FhB * dhB + FK * dK
            dt = perp(dn)
            dcp = dtype(0.5) * (dcA + dcB)
            drA = dcp - dOA
            drB = dcp - dOB
            dvA = dvOA + dwA * perp(rA) + wA * perp(drA)
            dvB = dvOB + dwB * perp(rB) + wB * perp(drB)
            dddot = -(wp.dot(dn, vB - vA) + wp.dot(n, dvB - dvA))
            dFn = dtype(0.0)
            if act:
                dFn = dFel + cdamp * (dr * ddelta * ddot + r * dddot)
            dvt = wp.dot(dt, vA - vB) + wp.dot(t, dvA - dvB)
            dFt = dtype(0.0)
            if fric:
                dFt = -(dFn * mu + Fn * dmu * dvt)
            if wp.static(anchor):
                darmA = drA
                darmB = drB
                if anchored:
                    # anchors are material points: they turn with their bodies and do not migrate
                    dha = dtha * perp(ha)
                    dhb = dthb * perp(hb)
                    dFt = anchor_force_tangent(stick, slip, sg, e_anc, t, dFn, dt, (dOA + dha) - (dOB + dhb),
                                               anchor_params, i)
                    darmA = dha
                    darmB = dhb
                dfnA = -dFn * n - Fn * dn
                dftA = dFt * t + Ft * dt
                store_pair_column(dqdq_out, dqdv_out, i, jseed, dfnA + dftA,
                                  cross2(drA, fnA) + cross2(rA, dfnA) + cross2(darmA, ftA) + cross2(armA, dftA),
                                  -(cross2(drB, fnA) + cross2(rB, dfnA) + cross2(darmB, ftA) + cross2(armB, dftA)))
            else:
                dfA = -dFn * n - Fn * dn + dFt * t + Ft * dt
                store_pair_column(dqdq_out, dqdv_out, i, jseed, dfA, cross2(drA, fA) + cross2(rA, dfA),
                                  -(cross2(drB, fA) + cross2(rB, dfA)))

        store_pair_observation(obs_out, i, Fn, vt, g, cp, n, Ft)
        obs_out[i, O_VROLL] = dtype(0.5) * wp.dot(t, vA + vB)
        obs_out[i, O_UA] = ua
        obs_out[i, O_UB] = ub
        obs_out[i, O_KT] = Fd
        if wp.static(anchor):
            # trial history: a new anchor forms at the contact point c as material points of both
            # teeth; committed by the evaluator once per accepted step
            flag, na, nb = anchor_trial(Fn, is_anchor, anchored, slip, s_anc, sg, t, tha, ha, row_vec2(hist_a_in, i),
                                        row_vec2(hist_b_in, i), rot(-tha, cp - OA), rot(-thb, cp - OB),
                                        anchor_params, i)
            hist_active_out[i] = flag
            store_row_vec2(hist_a_out, i, na)
            store_row_vec2(hist_b_out, i, nb)

    return eval_involute_pairs


class InvolutePairKernel(PairLaunch):
    """Device-resident evaluator of one involute contact set (one launch per call)."""

    def __init__(self, fparams, iparams, deviations, n_bodies, precision="float64", device="cpu", anchor_params=None):
        """anchor_params: None (no anchors), or (N, N_ANCHOR) columns of :mod:`anchor_ref` (use
        :meth:`evaluate_anchor`)."""
        self.wdtype, self.ndtype = scalar_types(precision)
        self.device = d = resolve_device(device, len(fparams))
        fparams = np.ascontiguousarray(fparams, dtype=self.ndtype)
        iparams = np.ascontiguousarray(iparams, dtype=np.int32)
        assert fparams.shape[1] == N_FLOAT and iparams.shape[1] == N_INT
        self.n = len(fparams)
        dt = self.wdtype
        dev = np.asarray(deviations, self.ndtype)
        # per-flank slow-state gap offsets (reference: flank_offset), zero as built
        self._tooth_offsets = wp.array(np.zeros(2 * len(dev), self.ndtype), dtype=dt, device=d)
        self._setup_launch(_kernel, [wp.array(fparams, dtype=dt, device=d), wp.array(iparams, dtype=wp.int32, device=d),
                                     wp.array(dev, dtype=dt, device=d), self._tooth_offsets],
                           anchor_params, n_bodies, N_OBS)

    def set_tooth_offsets(self, offsets):
        """Overwrite the per-flank gap offsets (2 n_teeth,) [m] in place on the device; the recorded
        launch keeps pointing at them."""
        assign_parameters(self._tooth_offsets, offsets, self.ndtype)
