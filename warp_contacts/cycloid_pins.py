"""Warp kernel of the cycloid--pin contact family (search, gap, force and
analytic tangent in one launch; one thread per pin slice).

Mirrors :mod:`warp_contacts.cycloid_pins_ref` line by line; see there for
the equations. Several profile tables (e.g. two wheels with different
modifications) are concatenated, each addressed by offset and length.
"""
import functools

import numpy as np
import warp as wp

from .anchor import anchor_funcs
from .circle_pairs_ref import FRICTION_ANCHOR, FRICTION_REGULARIZED, N_OBS
from .cycloid_pins_ref import (A_ANALYTIC, A_K1, A_NLOBE, A_R, A_RC, A_ROT, A_ZB, ANALYTIC_ITERATIONS, LOBE_BLEND, C_C, C_DR, C_E, C_K,
                               C_MUK, C_MUS, C_P, C_RP, C_TX, C_TY, C_VREG, C_VS, C_XI_B, C_Z, J_BODY_A, J_BODY_B,
                               J_FRICTION, J_TABLE, N_ANALYTIC, N_FLOAT, N_INT)
from .laws import law_funcs
from .planar import planar_funcs
from .planar_ref import N_COORD_SEEDS, N_SEEDS
from .precision import resolve_device, scalar_types
from .recorded import PairLaunch


def _kernel(dtype, velocity_tangent=True, anchor=False):
    """The family's kernel; ``anchor`` compiles the anchor friction of :mod:`anchor_ref` in
    (without it the anchor arguments are never read and the code is the frictionless one)."""
    return _parts(dtype, velocity_tangent, anchor)[0]


def row_function(dtype, velocity_tangent=True, anchor=False):
    """The ``@wp.func`` of one row, ``cycloid_pin_row(i, <the kernel's arguments>)``: the body of
    the kernel (which is a thin wrapper over it), for kernels that evaluate rows of their own
    (:mod:`warp_contacts.fused_step`)."""
    return _parts(dtype, velocity_tangent, anchor)[1]


@functools.lru_cache(maxsize=None)
def _parts(dtype, velocity_tangent=True, anchor=False):
    """(kernel, row function) of the family."""
    L = law_funcs(dtype)
    A = anchor_funcs(dtype)
    anchor_state, anchor_force_tangent, anchor_trial = A.anchor_state, A.anchor_force_tangent, A.anchor_trial
    G = planar_funcs(dtype)
    vec2, perp, cross2, rot = G.vec2, G.perp, G.cross2, G.rot
    body_state, param_vec2, row_vec2, pair_seed = G.body_state, G.param_vec2, G.row_vec2, G.pair_seed
    store_pair_forces, store_pair_column, store_pair_observation = (G.store_pair_forces, G.store_pair_column,
                                                                    G.store_pair_observation)
    store_row_vec2 = G.store_row_vec2
    normal_force = L.normal_force
    friction_coefficient = L.friction_coefficient

    @wp.func
    def epitrochoid(R: dtype, K1: dtype, zb: dtype, phi: dtype):
        """The unmodified curve's point, unit tangent, speed |E'| and signed curvature at phi
        (cycloid_pins_ref._epitrochoid), shared by analytic_point and analytic_point_turned."""
        s = wp.sin(phi)
        c = wp.cos(phi)
        S = wp.sin(zb * phi)
        C = wp.cos(zb * phi)
        E = R * vec2(s - K1 / zb * S, c - K1 / zb * C)
        dE = R * vec2(c - K1 * C, -s + K1 * S)
        ddE = R * vec2(-s + K1 * zb * S, -c + K1 * zb * C)
        speed = wp.length(dE)
        tau = dE / speed
        kE = -(dE[0] * ddE[1] - dE[1] * ddE[0]) / (speed * speed * speed)
        return E, tau, speed, kE

    @wp.func
    def analytic_point(R: dtype, K1: dtype, zb: dtype, rc: dtype, rot_angle: dtype, phi: dtype):
        """Profile point, outward normal, curvature and d(arc)/d(phi) (see the reference)."""
        E, tau, speed, kE = epitrochoid(R, K1, zb, phi)
        n = perp(tau)
        pt = E - rc * n
        kap = kE / (dtype(1.0) - rc * kE)
        ds = speed * (dtype(1.0) - rc * kE)
        return rot(rot_angle, pt), rot(rot_angle, n), kap, ds

    @wp.func
    def analytic_point_turned(R: dtype, K1: dtype, zb: dtype, rc: dtype, rot_angle: dtype, d: dtype, dd: dtype,
                              phi: dtype):
        """The point turned by the extra rotation d(phi), the turned curve's normal and arc length per phi
        (d' = dd), the unturned curvature (cycloid_pins_ref.analytic_point_turned)."""
        E, tau, speed, kE = epitrochoid(R, K1, zb, phi)
        pt = E - rc * perp(tau)
        kap = kE / (dtype(1.0) - rc * kE)
        v = (speed * (dtype(1.0) - rc * kE)) * tau + dd * perp(pt)
        ds = wp.length(v)
        n = perp(v / ds)
        return rot(rot_angle + d, pt), rot(rot_angle + d, n), kap, ds

    @wp.func
    def lobe_turn(tab_ana: wp.array2d(dtype=dtype), tb: int, nlobe: int, phi: dtype):
        """(d, d') of the pitch units' rotations at generating angle phi (cycloid_pins_ref.lobe_turn)."""
        two_pi = dtype(6.283185307179586)
        nl = dtype(nlobe)
        u = phi * nl / two_pi + dtype(0.5)
        fl = wp.floor(u)
        t = u - fl
        j = ((int(fl) % nlobe) + nlobe) % nlobe
        dj = tab_ana[tb, N_ANALYTIC + j]
        b = dtype(LOBE_BLEND)
        d = dj
        dd = dtype(0.0)
        if t < b:
            prev = tab_ana[tb, N_ANALYTIC + (j + nlobe - 1) % nlobe]
            d = dj + (prev - dj) * ((b - t) / (dtype(2.0) * b))
            dd = (dj - prev) * (nl / (dtype(2.0) * two_pi * b))
        elif t > dtype(1.0) - b:
            nxt = tab_ana[tb, N_ANALYTIC + (j + 1) % nlobe]
            d = dj + (nxt - dj) * ((t - dtype(1.0) + b) / (dtype(2.0) * b))
            dd = (nxt - dj) * (nl / (dtype(2.0) * two_pi * b))
        return d, dd

    @wp.func
    def profile_point(tab_ana: wp.array2d(dtype=dtype), tb: int, nlobe: int, R: dtype, K1: dtype, zb: dtype,
                      rc: dtype, rot_angle: dtype, phi: dtype):
        """Analytic point of generating angle phi, turned by its pitch unit's rotation where the profile has
        lobe rotations (nlobe > 0: cycloid_pins_ref.analytic_point_turned, else analytic_point)."""
        pa = vec2(dtype(0.0), dtype(0.0))
        na = vec2(dtype(0.0), dtype(0.0))
        ka = dtype(0.0)
        dsa = dtype(1.0)
        if nlobe > 0:
            dl, ddl = lobe_turn(tab_ana, tb, nlobe, phi)
            pa, na, ka, dsa = analytic_point_turned(R, K1, zb, rc, rot_angle, dl, ddl, phi)
        else:
            pa, na, ka, dsa = analytic_point(R, K1, zb, rc, rot_angle, phi)
        return pa, na, ka, dsa

    @wp.func
    def locate(pl: vec2, tb: int, tab_pts: wp.array2d(dtype=dtype), tab_nrm: wp.array2d(dtype=dtype),
               tab_kap: wp.array(dtype=dtype), tab_polar: wp.array(dtype=dtype), tab_offset: wp.array(dtype=wp.int32),
               tab_len: wp.array(dtype=wp.int32), tab_h: wp.array(dtype=dtype), tab_phi: wp.array(dtype=dtype),
               tab_ana: wp.array2d(dtype=dtype), window: int):
        """Contact location of the pin centre pl (wheel coordinates) on profile table tb, as
        :func:`cycloid_pins_ref.search`: binary search of the polar angle, a window of samples,
        projection on the nearest sample's osculating arc (or Newton on the analytic profile).
        Returns point, unit normal, curvature, the clamped flag and the squared sample distance."""
        off = tab_offset[tb]
        n = tab_len[tb]
        two_pi = dtype(6.283185307179586)
        beta = wp.atan2(pl[1], pl[0])
        if beta < dtype(0.0):
            beta = beta + two_pi
        lo = int(0)
        hi = n
        while lo < hi:
            mid = (lo + hi) // 2
            if tab_polar[off + mid] < beta:
                lo = mid + 1
            else:
                hi = mid
        best = int(0)
        bestd = dtype(1.0e30)
        for jw in range(2 * window + 1):
            idx = (lo + jw - window + n) % n
            d = pl - row_vec2(tab_pts, off + idx)
            d2 = wp.dot(d, d)
            if d2 < bestd:
                bestd = d2
                best = idx
        ci = row_vec2(tab_pts, off + best)
        ni = row_vec2(tab_nrm, off + best)
        kap = tab_kap[off + best]
        ti = perp(ni)
        wi = pl - ci
        tt = wp.dot(wi, ti) / (dtype(1.0) + kap * wp.dot(wi, ni))
        hh = tab_h[tb]
        clamped = wp.abs(tt) > hh
        tt = wp.clamp(tt, -hh, hh)
        cl = ci + tt * ti - (dtype(0.5) * kap * tt * tt) * ni
        nl = wp.normalize(ni + (kap * tt) * ti)
        if tab_ana[tb, A_ANALYTIC] > dtype(0.0):
            # analytic closest point: Newton on (c - p) . c' = 0 from the nearest sample
            aR = tab_ana[tb, A_R]
            aK1 = tab_ana[tb, A_K1]
            azb = tab_ana[tb, A_ZB]
            arc = tab_ana[tb, A_RC]
            arot = tab_ana[tb, A_ROT]
            phi = tab_phi[off + best]
            nlobe = int(tab_ana[tb, A_NLOBE])
            for it in range(ANALYTIC_ITERATIONS):
                # lobe rotations: each iterate turned by its pitch unit's rotation (cycloid_pins_ref.lobe_turn)
                pa, na, ka, dsa = profile_point(tab_ana, tb, nlobe, aR, aK1, azb, arc, arot, phi)
                wa_ = pl - pa
                dsn = wp.dot(wa_, -perp(na)) / (dtype(1.0) + ka * wp.dot(wa_, na))
                phi = phi + dsn / dsa
            pa, na, ka, dsa = profile_point(tab_ana, tb, nlobe, aR, aK1, azb, arc, arot, phi)
            cl = pa
            nl = na
            kap = ka
            clamped = False
        return cl, nl, kap, clamped, bestd

    # the seed loop's trip count is a compile-time constant, so Warp unrolls it (see planar);
    # without the velocity tangent only the coordinate seeds run
    n_seeds = N_SEEDS if velocity_tangent else N_COORD_SEEDS

    @wp.func
    def cycloid_pin_row(
        i: int,
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        tab_pts: wp.array2d(dtype=dtype),
        tab_nrm: wp.array2d(dtype=dtype),
        tab_kap: wp.array(dtype=dtype),
        tab_polar: wp.array(dtype=dtype),
        tab_offset: wp.array(dtype=wp.int32),
        tab_len: wp.array(dtype=wp.int32),
        tab_h: wp.array(dtype=dtype),
        tab_phi: wp.array(dtype=dtype),
        tab_ana: wp.array2d(dtype=dtype),
        window: int,
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
        """Row i of the set (the kernel's body; the fused stepper calls it for its own rows)."""
        xa, tha, vxa, wa = body_state(pose_in, vel_in, iparams[i, J_BODY_A])
        xb, thb, vxb, wb = body_state(pose_in, vel_in, iparams[i, J_BODY_B])
        r = fparams[i, C_RP]
        zs = fparams[i, C_Z]
        tx = fparams[i, C_TX]
        ty = fparams[i, C_TY]

        b = rot(thb, param_vec2(fparams, i, C_XI_B))
        p = xb + b
        pl = rot(-tha, p - xa)

        cl, nl, kap, clamped, bestd = locate(pl, iparams[i, J_TABLE], tab_pts, tab_nrm, tab_kap, tab_polar,
                                             tab_offset, tab_len, tab_h, tab_phi, tab_ana, window)

        a = rot(tha, cl)
        nv = rot(tha, nl)
        t = perp(nv)
        c = xa + a
        w = p - c
        hw = wp.dot(nv, w)
        e_off = fparams[i, C_E]
        e_tilt = zs * (ty * nv[0] - tx * nv[1])
        g = hw - r + e_off + e_tilt
        if clamped:
            g = wp.sqrt(bestd) - r + e_off + e_tilt
        delta = -g
        vc = vxa + wa * perp(a)
        vp = vxb + wb * perp(b)
        u = vp - vc
        delta_dot = -wp.dot(nv, u)
        F, Fd, Fdd = normal_force(fparams[i, C_K], fparams[i, C_P], fparams[i, C_C], fparams[i, C_DR], delta,
                                  delta_dot)
        fA = -F * nv
        bpc = b - r * nv
        vpc = vxb + wb * perp(bpc)
        vt = wp.dot(t, vc - vpc)
        mu, dmu = friction_coefficient(fparams[i, C_MUK], fparams[i, C_MUS], fparams[i, C_VS], fparams[i, C_VREG], vt)
        reg = iparams[i, J_FRICTION] == FRICTION_REGULARIZED and F > dtype(0.0)
        ft = dtype(0.0)
        if reg:
            ft = -F * mu
        armA = a
        armB = bpc
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
            is_anchor = iparams[i, J_FRICTION] == FRICTION_ANCHOR and delta > dtype(0.0)
            ha = rot(tha, row_vec2(hist_a_in, i))
            hb = rot(thb, row_vec2(hist_b_in, i))
            e_anc = (xa + ha) - (xb + hb)
            anchored, stick, slip, s_anc, sg, ft_anc = anchor_state(F, is_anchor, hist_active_in[i], e_anc, t,
                                                                   anchor_params, i)
            if anchored:
                ft = ft_anc
                armA = ha
                armB = hb
        ftA = ft * t

        fsum = fA + ftA
        if wp.static(anchor):
            store_pair_forces(q_out, i, fsum, cross2(a, fA) + cross2(armA, ftA), -(cross2(b, fA) + cross2(armB, ftA)))
        else:
            store_pair_forces(q_out, i, fsum, cross2(a, fsum), -(cross2(b, fA) + cross2(bpc, ftA)))

        den = dtype(1.0) + kap * hw
        wt = wp.dot(w, t)
        for j in range(n_seeds):
            dqa, dtha, dqb, dthb, dva, dwa, dvb, dwb = pair_seed(j)
            dca = dqa + dtha * perp(a)
            db = dthb * perp(b)
            dp = dqb + db
            D = dp - dca
            dn = ((kap * wp.dot(t, D) + dtha) / den) * t
            dt = perp(dn)
            dg = wp.dot(nv, D) + wt * wp.dot(t, dn) + zs * (ty * dn[0] - tx * dn[1])
            da = dtha * perp(a) + ((wp.dot(t, D) - dtha * hw) / den) * t
            dvc = dva + dwa * perp(a) + wa * perp(da)
            dvp = dvb + dwb * perp(b) + wb * perp(db)
            ddelta_dot = -(wp.dot(dn, u) + wp.dot(nv, dvp - dvc))
            dF = Fd * (-dg) + Fdd * ddelta_dot
            dfA = -(dF * nv + F * dn)
            dbpc = db - r * dn
            dvpc = dvb + dwb * perp(bpc) + wb * perp(dbpc)
            dvt = wp.dot(dt, vc - vpc) + wp.dot(t, dvc - dvpc)
            dft = dtype(0.0)
            if reg:
                dft = -(dF * mu + F * dmu * dvt)
            if wp.static(anchor):
                darmA = da
                darmB = dbpc
                if anchored:
                    # anchors are material points: they turn with their bodies and do not migrate
                    dha = dtha * perp(ha)
                    dhb = dthb * perp(hb)
                    dft = anchor_force_tangent(stick, slip, sg, e_anc, t, dF, dt, (dqa + dha) - (dqb + dhb),
                                               anchor_params, i)
                    darmA = dha
                    darmB = dhb
                dftA = dft * t + ft * dt
                dsum = dfA + dftA
                dQa = cross2(da, fA) + cross2(a, dfA) + cross2(darmA, ftA) + cross2(armA, dftA)
                dQb = -(cross2(db, fA) + cross2(b, dfA) + cross2(darmB, ftA) + cross2(armB, dftA))
                store_pair_column(dqdq_out, dqdv_out, i, j, dsum, dQa, dQb)
            else:
                dftA = dft * t + ft * dt
                dsum = dfA + dftA
                dQa = cross2(da, fsum) + cross2(a, dsum)
                dQb = -(cross2(db, fA) + cross2(b, dfA) + cross2(dbpc, ftA) + cross2(bpc, dftA))
                store_pair_column(dqdq_out, dqdv_out, i, j, dsum, dQa, dQb)

        store_pair_observation(obs_out, i, F, vt, g, c + (dtype(0.5) * (hw - r)) * nv, nv, ft)
        if wp.static(anchor):
            # trial history: a new anchor forms at the contact point c, as the profile's material
            # point (wheel coordinates) and the pin's (pin-body coordinates); committed by the
            # evaluator once per accepted step
            flag, na, nb = anchor_trial(F, is_anchor, anchored, slip, s_anc, sg, t, tha, ha, row_vec2(hist_a_in, i),
                                        row_vec2(hist_b_in, i), cl, rot(-thb, c - xb), anchor_params, i)
            hist_active_out[i] = flag
            store_row_vec2(hist_a_out, i, na)
            store_row_vec2(hist_b_out, i, nb)

    @wp.kernel(module="unique")
    def eval_cycloid_pins(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        tab_pts: wp.array2d(dtype=dtype),
        tab_nrm: wp.array2d(dtype=dtype),
        tab_kap: wp.array(dtype=dtype),
        tab_polar: wp.array(dtype=dtype),
        tab_offset: wp.array(dtype=wp.int32),
        tab_len: wp.array(dtype=wp.int32),
        tab_h: wp.array(dtype=dtype),
        tab_phi: wp.array(dtype=dtype),
        tab_ana: wp.array2d(dtype=dtype),
        window: int,
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
        cycloid_pin_row(wp.tid(), fparams, iparams, tab_pts, tab_nrm, tab_kap, tab_polar, tab_offset, tab_len, tab_h, tab_phi, tab_ana, window, anchor_params, pose_in, vel_in, hist_active_in, hist_a_in, hist_b_in, q_out, dqdq_out, dqdv_out, obs_out, hist_active_out, hist_a_out, hist_b_out)

    return eval_cycloid_pins, cycloid_pin_row


def _analytic_rows(tables, analytic, ndtype):
    """One analytic row per profile table (columns A_* of cycloid_pins_ref, then the lobe rotations of
    a profile that has them: the rows as wide as the most lobes); all zero for a table searched on its
    samples."""
    n_l = [len(a[5]) if a is not None and len(a) > 5 else 0
           for a in (analytic if analytic is not None else [None] * len(tables))]
    rows = np.zeros((len(tables), N_ANALYTIC + max(n_l, default=0)), ndtype)
    for k in range(len(tables)):
        if analytic is not None and analytic[k] is not None:
            rows[k, A_ANALYTIC] = 1.0
            rows[k, A_R:A_ROT + 1] = analytic[k][:5]
            if n_l[k]:
                rows[k, A_NLOBE] = n_l[k]
                rows[k, N_ANALYTIC:N_ANALYTIC + n_l[k]] = analytic[k][5]
    return rows



def analytic_rows(tables, analytic, ndtype=np.float64):
    """The kernel's analytic-profile rows (one per table; columns A_*), for kernels that evaluate
    the rows themselves (:mod:`warp_contacts.fused_step`)."""
    return _analytic_rows(tables, analytic, ndtype)


def stacked_column(parts, ndtype, wdtype, device):
    """The device array of the table columns ``parts`` (arrays of equal trailing shape) stacked along
    their first axis in ``ndtype``: on the cpu written into the Warp array's own memory, on a GPU
    stacked once on the host and copied (one pass over the tables instead of stack, cast and copy:
    the tables of 1,000 RD-40 variants are ~0.5 GB)."""
    parts = [np.asarray(p) for p in parts]
    shape = (sum(len(p) for p in parts),) + parts[0].shape[1:]
    if wp.get_device(device).is_cpu:
        out = wp.empty(shape, dtype=wdtype, device=device)
        np.concatenate(parts, axis=0, out=out.numpy(), casting="same_kind")
        return out
    return wp.array(np.concatenate(parts, axis=0, dtype=ndtype, casting="same_kind"), dtype=wdtype, device=device)


def gathered_column(sources, wdtype, device):
    """The device array of table columns that are rows of device arrays already: ``sources`` [(array
    (T, n) or (T, n, 2) on ``device``, row t)], stacked along the samples by device copies (runs of
    consecutive rows of one array in one copy), or None where a source is elsewhere or of another type
    (the caller stacks host columns then)."""
    dev = wp.get_device(device)
    if not sources or any(x is None or x[0].device != dev or x[0].dtype != wdtype for x in sources):
        return None
    first = sources[0][0]
    inner = first.shape[2] if first.ndim == 3 else 1
    total = sum(a.shape[1] for a, _ in sources)
    out = wp.empty((total, inner) if first.ndim == 3 else (total,), dtype=wdtype, device=device)
    runs, dst = [], 0
    for a, t in sources:
        cnt = a.shape[1] * inner
        src = int(t) * cnt
        if runs and runs[-1][0] is a and runs[-1][1] + runs[-1][3] == src:
            runs[-1][3] += cnt
        else:
            runs.append([a, src, dst, cnt])
        dst += cnt
    for a, src, at, cnt in runs:
        wp.copy(out, a, dest_offset=at, src_offset=src, count=cnt)
    return out


def batch_view(sources, wdtype, device):
    """(flat view, row offsets) of table columns that are all rows of ONE device array: ``sources``
    [(array (T, n) or (T, n, 2) on ``device``, row t)] -> the array itself seen as (T n[, 2]) (no copy)
    and each source's first sample in it (t n), or None where the sources are not all rows of one
    array on ``device`` of ``wdtype`` (the caller gathers or stacks them then). The tables of a Monte
    Carlo computed in one batch on the device (rvtool.contact.cycloid_set.compute_profile_tables) are
    read where they are, for the whole batch and for any subset of its copies alike."""
    if not sources or any(x is None for x in sources):
        return None
    first = sources[0][0]
    if first.device != wp.get_device(device) or first.dtype != wdtype or not first.is_contiguous \
            or any(a is not first for a, _ in sources):
        return None
    T, n = first.shape[0], first.shape[1]
    flat = first.reshape((T * n, first.shape[2]) if first.ndim == 3 else (T * n,))
    return flat, np.array([int(t) * n for _, t in sources], np.int32)


class CycloidPinKernel(PairLaunch):
    """Device-resident evaluator of one cycloid--pin contact set (one launch per call)."""

    def __init__(self, fparams, iparams, tables, window, n_bodies, precision="float64", device="cpu", analytic=None,
                 anchor_params=None):
        """anchor_params: None (no anchors: the frictionless/regularized kernel), or (N, N_ANCHOR)
        columns of :mod:`anchor_ref` for a set with anchor rows (use :meth:`evaluate_anchor`)."""
        self.wdtype, self.ndtype = scalar_types(precision)
        self.device = d = resolve_device(device, len(fparams))
        fparams = np.ascontiguousarray(fparams, dtype=self.ndtype)
        iparams = np.ascontiguousarray(iparams, dtype=np.int32)
        assert fparams.shape[1] == N_FLOAT and iparams.shape[1] == N_INT
        self.n = len(fparams)
        dt = self.wdtype
        # a table computed on this device (rvtool.contact.cycloid_set.ProfileTable.device_column) is copied
        # there, not read back and stacked on the host
        on_dev = all(callable(getattr(tb, "device_column", None)) for tb in tables)
        lens = [tb.n_samples if on_dev else len(tb[0]) for tb in tables]
        offs = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int32)
        # tables that are rows of one device batch: the kernel reads the batch in place (no copy), each
        # table at its row's offset; the same samples, so the same rows bit for bit
        cols = {i: [tb.device_column(i, d) for tb in tables] for i in (0, 1, 2, 3, 5)} if on_dev else None
        views = {i: batch_view(cols[i], dt, d) for i in cols} if on_dev else {}
        if views and all(v is not None for v in views.values()) \
                and len({v[1].tobytes() for v in views.values()}) == 1:
            offs = views[0][1]
            self.table_source = "device_batch_view"
        else:
            views = {}
            self.table_source = "gathered" if on_dev else "host"

        def col(i):
            if views:
                return views[i][0]
            got = gathered_column(cols[i], dt, d) if on_dev else None
            if got is None:
                self.table_source = "host"
                return stacked_column([tb[i] for tb in tables], self.ndtype, dt, d)
            return got
        model = [
            wp.array(fparams, dtype=dt, device=d), wp.array(iparams, dtype=wp.int32, device=d),
            col(0), col(1), col(2), col(3),
            wp.array(offs, dtype=wp.int32, device=d), wp.array(np.array(lens, np.int32), dtype=wp.int32, device=d),
            wp.array(np.array([tb.spacing if on_dev else tb[4] for tb in tables], self.ndtype), dtype=dt, device=d),
            col(5),
            wp.array(_analytic_rows(tables, analytic, self.ndtype), dtype=dt, device=d),
            int(window)]
        self._setup_launch(_kernel, model, anchor_params, n_bodies, N_OBS)
