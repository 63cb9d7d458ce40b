"""Warp kernel of the cycloid--pin contact family (search, gap, force and
analytic tangent in one launch; one thread per pin slice).

Mirrors :mod:`warp_contacts.cycloid_pins_ref` line by line; see there for
the equations. Several profile tables (e.g. two wheels with different
modifications) are concatenated, each addressed by offset and length.
"""
import functools

import numpy as np
import warp as wp

from .circle_pairs_ref import N_OBS
from .cycloid_pins_ref import N_FLOAT, N_INT
from .laws import law_funcs
from .planar import LaunchBuffers, planar_funcs
from .precision import resolve_device, scalar_types


@functools.lru_cache(maxsize=None)
def _kernel(dtype, velocity_tangent=True):
    L = law_funcs(dtype)
    G = planar_funcs(dtype)
    vec2, perp, cross2, rot, body_seed = G.vec2, G.perp, G.cross2, G.rot, G.body_seed
    store_pair_forces, store_pair_column = G.store_pair_forces, G.store_pair_column
    normal_force = L.normal_force
    friction_coefficient = L.friction_coefficient

    @wp.func
    def analytic_point(R: dtype, K1: dtype, zb: dtype, rc: dtype, rot_angle: dtype, phi: dtype):
        """Profile point, outward normal, curvature and d(arc)/d(phi) (see the reference)."""
        s = wp.sin(phi)
        c = wp.cos(phi)
        S = wp.sin(zb * phi)
        C = wp.cos(zb * phi)
        E = R * vec2(s - K1 / zb * S, c - K1 / zb * C)
        dE = R * vec2(c - K1 * C, -s + K1 * S)
        ddE = R * vec2(-s + K1 * zb * S, -c + K1 * zb * C)
        speed = wp.length(dE)
        tau = dE / speed
        n = vec2(-tau[1], tau[0])
        kE = -(dE[0] * ddE[1] - dE[1] * ddE[0]) / (speed * speed * speed)
        pt = E - rc * n
        kap = kE / (dtype(1.0) - rc * kE)
        ds = speed * (dtype(1.0) - rc * kE)
        return rot(rot_angle, pt), rot(rot_angle, n), kap, ds

    # a compile-time trip count (Warp unrolls the seed loop; a runtime bound measured 1.7x slower)
    N_SEEDS = 12 if velocity_tangent else 6

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
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        vel_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        dqdv_out: wp.array3d(dtype=dtype),
        obs_out: wp.array2d(dtype=dtype),
    ):
        i = wp.tid()
        ia = iparams[i, 0]
        ib = iparams[i, 1]
        mode = iparams[i, 2]
        tb = iparams[i, 3]
        xa = vec2(pose_in[ia, 0], pose_in[ia, 1])
        xb = vec2(pose_in[ib, 0], pose_in[ib, 1])
        tha = pose_in[ia, 2]
        thb = pose_in[ib, 2]
        vxa = vec2(vel_in[ia, 0], vel_in[ia, 1])
        vxb = vec2(vel_in[ib, 0], vel_in[ib, 1])
        wa = vel_in[ia, 2]
        wb = vel_in[ib, 2]
        r = fparams[i, 2]
        e_off = fparams[i, 3]
        k = fparams[i, 4]
        p_exp = fparams[i, 5]
        c_damp = fparams[i, 6]
        dr = fparams[i, 7]
        muk = fparams[i, 8]
        mus = fparams[i, 9]
        vs = fparams[i, 10]
        vreg = fparams[i, 11]
        zs = fparams[i, 12]
        tx = fparams[i, 13]
        ty = fparams[i, 14]

        b = rot(thb, vec2(fparams[i, 0], fparams[i, 1]))
        p = xb + b
        pl = rot(-tha, p - xa)

        # -- discrete search: binary search of the polar angle, then a window ----
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
            d = pl - vec2(tab_pts[off + idx, 0], tab_pts[off + idx, 1])
            d2 = wp.dot(d, d)
            if d2 < bestd:
                bestd = d2
                best = idx
        ci = vec2(tab_pts[off + best, 0], tab_pts[off + best, 1])
        ni = vec2(tab_nrm[off + best, 0], tab_nrm[off + best, 1])
        kap = tab_kap[off + best]
        ti = perp(ni)
        wi = pl - ci
        tt = wp.dot(wi, ti) / (dtype(1.0) + kap * wp.dot(wi, ni))
        hh = tab_h[tb]
        clamped = wp.abs(tt) > hh
        tt = wp.clamp(tt, -hh, hh)
        cl = ci + tt * ti - (dtype(0.5) * kap * tt * tt) * ni
        nl = wp.normalize(ni + (kap * tt) * ti)
        if tab_ana[tb, 0] > dtype(0.0):
            # analytic closest point: Newton on (c - p) . c' = 0 from the nearest sample
            aR = tab_ana[tb, 1]
            aK1 = tab_ana[tb, 2]
            azb = tab_ana[tb, 3]
            arc = tab_ana[tb, 4]
            arot = tab_ana[tb, 5]
            phi = tab_phi[off + best]
            for it in range(4):
                pa, na, ka, dsa = analytic_point(aR, aK1, azb, arc, arot, phi)
                wa_ = pl - pa
                dsn = wp.dot(wa_, -perp(na)) / (dtype(1.0) + ka * wp.dot(wa_, na))
                phi = phi + dsn / dsa
            pa, na, ka, dsa = analytic_point(aR, aK1, azb, arc, arot, phi)
            cl = pa
            nl = na
            kap = ka
            clamped = False

        a = rot(tha, cl)
        nv = rot(tha, nl)
        t = perp(nv)
        c = xa + a
        w = p - c
        hw = wp.dot(nv, w)
        e_tilt = zs * (ty * nv[0] - tx * nv[1])
        g = hw - r + e_off + e_tilt
        if clamped:
            g = wp.sqrt(bestd) - r + e_off + e_tilt
        delta = -g
        vc = vxa + wa * perp(a)
        vp = vxb + wb * perp(b)
        u = vp - vc
        delta_dot = -wp.dot(nv, u)
        F, Fd, Fdd = normal_force(k, p_exp, c_damp, dr, delta, delta_dot)
        fA = -F * nv
        bpc = b - r * nv
        vpc = vxb + wb * perp(bpc)
        vt = wp.dot(t, vc - vpc)
        mu, dmu = friction_coefficient(muk, mus, vs, vreg, vt)
        reg = mode == 1 and F > dtype(0.0)
        ft = dtype(0.0)
        if reg:
            ft = -F * mu
        ftA = ft * t

        fsum = fA + ftA
        store_pair_forces(q_out, i, fsum, cross2(a, fsum), -(cross2(b, fA) + cross2(bpc, ftA)))

        den = dtype(1.0) + kap * hw
        wt = wp.dot(w, t)
        for j in range(N_SEEDS):
            # seeds: columns 0-5 move the coordinates, 6-11 the velocities (12 seeds; 6 when the
            # velocity tangent is switched off, see CycloidPinKernel.velocity_tangent)
            dqa, dtha, dqb, dthb = body_seed(j)
            dva, dwa, dvb, dwb = body_seed(j - 6)
            if j < 6:
                dva = vec2(dtype(0.0), dtype(0.0))
                dvb = vec2(dtype(0.0), dtype(0.0))
                dwa = dtype(0.0)
                dwb = dtype(0.0)
            else:
                dqa = vec2(dtype(0.0), dtype(0.0))
                dqb = vec2(dtype(0.0), dtype(0.0))
                dtha = dtype(0.0)
                dthb = dtype(0.0)
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
            dftA = dft * t + ft * dt
            dsum = dfA + dftA
            dQa = cross2(da, fsum) + cross2(a, dsum)
            dQb = -(cross2(db, fA) + cross2(b, dfA) + cross2(dbpc, ftA) + cross2(bpc, dftA))
            store_pair_column(dqdq_out, dqdv_out, i, j, dsum, dQa, dQb)

        cp = c + (dtype(0.5) * (hw - r)) * nv
        obs_out[i, 0] = F
        obs_out[i, 1] = vt
        obs_out[i, 2] = g
        obs_out[i, 3] = cp[0]
        obs_out[i, 4] = cp[1]
        obs_out[i, 5] = nv[0]
        obs_out[i, 6] = nv[1]
        obs_out[i, 7] = ft

    return eval_cycloid_pins


class CycloidPinKernel:
    """Device-resident evaluator of one cycloid--pin contact set (one launch per call)."""

    def __init__(self, fparams, iparams, tables, window, n_bodies, precision="float64", device="cpu", analytic=None):
        self.wdtype, self.ndtype = scalar_types(precision)
        self.device = d = resolve_device(device, len(fparams))
        fparams = np.ascontiguousarray(fparams, dtype=self.ndtype)
        iparams = np.ascontiguousarray(iparams, dtype=np.int32)
        assert fparams.shape[1] == N_FLOAT and iparams.shape[1] == N_INT
        self.n = n = len(fparams)
        dt = self.wdtype
        lens = [len(tb[0]) for tb in tables]
        offs = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int32)
        model = [
            wp.array(fparams, dtype=dt, device=d), wp.array(iparams, dtype=wp.int32, device=d),
            wp.array(np.vstack([tb[0] for tb in tables]).astype(self.ndtype), dtype=dt, device=d),
            wp.array(np.vstack([tb[1] for tb in tables]).astype(self.ndtype), dtype=dt, device=d),
            wp.array(np.concatenate([tb[2] for tb in tables]).astype(self.ndtype), dtype=dt, device=d),
            wp.array(np.concatenate([tb[3] for tb in tables]).astype(self.ndtype), dtype=dt, device=d),
            wp.array(offs, dtype=wp.int32, device=d), wp.array(np.array(lens, np.int32), dtype=wp.int32, device=d),
            wp.array(np.array([tb[4] for tb in tables], self.ndtype), dtype=dt, device=d),
            wp.array(np.concatenate([tb[5] for tb in tables]).astype(self.ndtype), dtype=dt, device=d),
            wp.array(np.array([[0.0] * 6 if (analytic is None or analytic[k] is None) else [1.0, *analytic[k]]
                               for k in range(len(tables))], self.ndtype), dtype=dt, device=d),
            int(window)]
        self._model = model
        self._buf = LaunchBuffers({"pose": ((n_bodies + 1, 3), "f"), "vel": ((n_bodies + 1, 3), "f"),
                                   "q": ((n, 6), "f"), "dqdq": ((n, 6, 6), "f"), "dqdv": ((n, 6, 6), "f"),
                                   "obs": ((n, N_OBS), "f")}, dt, self.ndtype, d)
        self.velocity_tangent = True
        self._record()

    def _record(self):
        dev = self._buf.dev
        self._cmd = wp.launch(_kernel(self.wdtype, self.velocity_tangent), dim=self.n, device=self.device,
                              inputs=self._model + [dev["pose"], dev["vel"]],
                              outputs=[dev[k] for k in ("q", "dqdq", "dqdv", "obs")], record_cmd=True)

    def set_velocity_tangent(self, on):
        """Switch the velocity tangent dQ/dv on (default) or off. Off, the kernel skips the six
        velocity seeds of the tangent loop (about a third of its work) and dQ/dv is returned as
        None: for static solves, whose residual does not depend on velocities."""
        self.velocity_tangent = bool(on)
        self._record()

    def evaluate(self, pose, vel):
        """Returns (Q (N,6), dQdq, dQdv, obs (N,8)); arrays are reused by the next call."""
        h = self._buf.host
        h["pose"][...] = pose
        h["vel"][...] = vel
        self._buf.upload(("pose", "vel"))
        self._cmd.launch()
        names = [k for k in ("q", "dqdq", "dqdv", "obs") if k not in self.keep_on_device
                 and (k != "dqdv" or self.velocity_tangent)]
        self._buf.download(names)
        return tuple(h[k] if k in names else None for k in ("q", "dqdq", "dqdv", "obs"))

    # outputs left on the device (returned as None; read them with device_array), e.g. the
    # per-row tangents that a device-side block scatter sums (warp_contacts.block_scatter)
    keep_on_device = frozenset()

    def device_array(self, name):
        return self._buf.dev[name]
