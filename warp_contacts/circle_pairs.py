"""Warp kernel of the circle--circle contact-pair evaluation with analytic
tangent: one batched launch evaluates every contact of a set.

The physics, conventions and parameter layout are documented in the NumPy
reference :mod:`warp_contacts.circle_pairs_ref`, which this kernel mirrors
line by line (a test compares the two). Outputs per contact: generalized
forces Q (6), dQ/dq (6x6), dQ/dv (6x6) (Eq. (assembled_contact_tangent)),
observation values and the trial anchor history.
"""
import functools

import numpy as np
import warp as wp

from .circle_geometry import circle_funcs
from .circle_pairs_ref import (FRICTION_ANCHOR, FRICTION_REGULARIZED, I_BODY_A, I_BODY_B, I_FRICTION,
                               I_INTERNAL, N_FLOAT_PARAMS, N_INT_PARAMS, N_OBS, P_C, P_DR, P_K, P_KT, P_MUK, P_MUS,
                               P_P, P_RA, P_RB, P_VREG, P_VS, P_XI_A, P_XI_B)
from .laws import law_funcs
from .planar import LaunchBuffers, planar_funcs
from .planar_ref import N_SEEDS
from .precision import resolve_device, scalar_types
from .recorded import RecordedRows


def _kernel(dtype):
    """The family's kernel."""
    return _parts(dtype)[0]


def row_function(dtype):
    """The ``@wp.func`` of one row, ``circle_pair_row(i, <the kernel's arguments>)``: the body of
    the kernel (a thin wrapper over it), for kernels that evaluate rows of their own
    (:mod:`warp_contacts.fused_step`)."""
    return _parts(dtype)[1]


@functools.lru_cache(maxsize=None)
def _parts(dtype):
    """(kernel, row function) of the family."""
    L = law_funcs(dtype)
    C = circle_funcs(dtype)
    G = planar_funcs(dtype)
    vec2, perp, cross2, rot = C.vec2, G.perp, G.cross2, G.rot
    body_state, param_vec2, row_vec2, store_row_vec2, pair_seed = (G.body_state, G.param_vec2, G.row_vec2,
                                                                 G.store_row_vec2, G.pair_seed)
    store_pair_forces, store_pair_column, store_pair_observation = (G.store_pair_forces, G.store_pair_column,
                                                                    G.store_pair_observation)
    normal_force = L.normal_force
    friction_coefficient = L.friction_coefficient
    circle_gap = C.circle_gap

    @wp.func
    def circle_pair_row(
        i: int,
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
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
        internal = iparams[i, I_INTERNAL]
        mode = iparams[i, I_FRICTION]
        s = dtype(1.0)
        if internal != 0:
            s = dtype(-1.0)
        xa, tha, vxa, wa = body_state(pose_in, vel_in, iparams[i, I_BODY_A])
        xb, thb, vxb, wb = body_state(pose_in, vel_in, iparams[i, I_BODY_B])
        ra = fparams[i, P_RA]
        rb = fparams[i, P_RB]
        muk = fparams[i, P_MUK]
        kt = fparams[i, P_KT]

        pa = rot(tha, param_vec2(fparams, i, P_XI_A))
        pb = rot(thb, param_vec2(fparams, i, P_XI_B))
        g, n, Lc = circle_gap(xa + pa, xb + pb, ra, rb, internal)
        Ls = Lc
        if Ls <= dtype(0.0):
            Ls = dtype(1.0)
        t = perp(n)
        delta = -g
        w = (vxb + wb * perp(pb)) - (vxa + wa * perp(pa))
        Ldot = wp.dot(n, w)
        delta_dot = -s * Ldot
        F, Fd, Fdd = normal_force(fparams[i, P_K], fparams[i, P_P], fparams[i, P_C], fparams[i, P_DR], delta,
                                  delta_dot)
        fnA = (-s * F) * n

        aa = pa + (s * ra) * n
        bb = pb - rb * n
        ua = vxa + wa * perp(aa)
        ub = vxb + wb * perp(bb)
        vrel = ua - ub
        vt = wp.dot(t, vrel)

        mu, dmu = friction_coefficient(muk, fparams[i, P_MUS], fparams[i, P_VS], fparams[i, P_VREG], vt)
        hla = row_vec2(hist_a_in, i)
        hlb = row_vec2(hist_b_in, i)
        ha = rot(tha, hla)
        hb = rot(thb, hlb)
        e = (xa + ha) - (xb + hb)
        st = wp.dot(t, e)
        lim = muk * F
        contact = delta > dtype(0.0)
        anchored = mode == FRICTION_ANCHOR and contact and hist_active_in[i] != 0
        stick = anchored and wp.abs(kt * st) <= lim
        slip = anchored and not stick
        sg = wp.sign(st)
        if st == dtype(0.0):
            sg = dtype(0.0)
        reg = mode == FRICTION_REGULARIZED and F > dtype(0.0)
        ft_mag = dtype(0.0)
        if reg:
            ft_mag = -F * mu
        if stick:
            ft_mag = -kt * st
        if slip:
            ft_mag = -lim * sg
        ftA = ft_mag * t
        armA = aa
        armB = bb
        if anchored:
            armA = ha
            armB = hb

        store_pair_forces(q_out, i, fnA + ftA, cross2(pa, fnA) + cross2(armA, ftA),
                          -(cross2(pb, fnA) + cross2(armB, ftA)))

        for j in range(N_SEEDS):
            dxa, dtha, dxb, dthb, dva, dwa, dvb, dwb = pair_seed(j)
            dpa = dtha * perp(pa)
            dpb = dthb * perp(pb)
            dd = (dxb + dpb) - (dxa + dpa)
            dL = wp.dot(n, dd)
            dn = (dd - dL * n) / Ls
            dt = perp(dn)
            ddelta = -s * dL
            dvca = dva + dwa * perp(pa) + wa * perp(dpa)
            dvcb = dvb + dwb * perp(pb) + wb * perp(dpb)
            dw = dvcb - dvca
            dLdot = wp.dot(dn, w) + wp.dot(n, dw)
            ddelta_dot = -s * dLdot
            dF = Fd * ddelta + Fdd * ddelta_dot
            dfnA = -s * (dF * n + F * dn)
            daa = dpa + (s * ra) * dn
            dbb = dpb - rb * dn
            dua = dva + dwa * perp(aa) + wa * perp(daa)
            dub = dvb + dwb * perp(bb) + wb * perp(dbb)
            dvt = wp.dot(dt, vrel) + wp.dot(t, dua - dub)
            dha = dtha * perp(ha)
            dhb = dthb * perp(hb)
            de = (dxa + dha) - (dxb + dhb)
            dst = wp.dot(dt, e) + wp.dot(t, de)
            dft_mag = dtype(0.0)
            if reg:
                dft_mag = -(dF * mu + F * dmu * dvt)
            if stick:
                dft_mag = -kt * dst
            if slip:
                dft_mag = -muk * dF * sg
            dftA = dft_mag * t + ft_mag * dt
            darmA = daa
            darmB = dbb
            if anchored:
                darmA = dha
                darmB = dhb
            dfA = dfnA + dftA
            dQa = cross2(dpa, fnA) + cross2(pa, dfnA) + cross2(darmA, ftA) + cross2(armA, dftA)
            dQb = -(cross2(dpb, fnA) + cross2(pb, dfnA) + cross2(darmB, ftA) + cross2(armB, dftA))
            store_pair_column(dqdq_out, dqdv_out, i, j, dfA, dQa, dQb)

        # trial anchor history (committed by the driver only for accepted steps)
        act = 0
        na = vec2(dtype(0.0), dtype(0.0))
        nbv = vec2(dtype(0.0), dtype(0.0))
        if mode == FRICTION_ANCHOR and contact:
            act = 1
            if anchored:
                na = hla
                nbv = hlb
                if slip:
                    st_lim = dtype(0.0)
                    if kt > dtype(0.0):
                        st_lim = sg * lim / kt
                    na = rot(-tha, ha - (st - st_lim) * t)
            else:
                na = rot(-tha, aa)
                nbv = rot(-thb, bb)
        hist_active_out[i] = act
        store_row_vec2(hist_a_out, i, na)
        store_row_vec2(hist_b_out, i, nbv)

        store_pair_observation(obs_out, i, F, vt, g, dtype(0.5) * ((xa + aa) + (xb + bb)), n, ft_mag)

    @wp.kernel(module="unique")
    def eval_circle_pairs(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
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
        circle_pair_row(wp.tid(), fparams, iparams, pose_in, vel_in, hist_active_in, hist_a_in, hist_b_in, q_out, dqdq_out, dqdv_out, obs_out, hist_active_out, hist_a_out, hist_b_out)

    return eval_circle_pairs, circle_pair_row


class CirclePairKernel(RecordedRows):
    """Device-resident evaluator of one circle contact set.

    Parameters are uploaded once; per evaluation only poses/velocities and the
    committed history go in, and forces, tangent blocks, observations and the
    trial history come out.
    """

    def __init__(self, fparams, iparams, n_bodies, precision="float64", device="cpu"):
        self.wdtype, self.ndtype = scalar_types(precision)
        self.device = resolve_device(device, len(fparams))
        self.precision = precision
        fparams = np.ascontiguousarray(fparams, dtype=self.ndtype)
        iparams = np.ascontiguousarray(iparams, dtype=np.int32)
        assert fparams.shape[1] == N_FLOAT_PARAMS and iparams.shape[1] == N_INT_PARAMS
        self.n = n = fparams.shape[0]
        self.n_bodies = n_bodies
        self.kernel = _kernel(self.wdtype)
        d, dt = self.device, self.wdtype
        self._buf = LaunchBuffers({
            "pose": ((n_bodies + 1, 3), "f"), "vel": ((n_bodies + 1, 3), "f"), "h_act_in": (n, "int"),
            "h_a_in": ((n, 2), "f"), "h_b_in": ((n, 2), "f"), "q": ((n, 6), "f"), "dqdq": ((n, 6, 6), "f"),
            "dqdv": ((n, 6, 6), "f"), "obs": ((n, N_OBS), "f"), "h_act_out": (n, "int"), "h_a_out": ((n, 2), "f"),
            "h_b_out": ((n, 2), "f")}, dt, self.ndtype, d)
        self._dev = self._buf.dev
        self.fparams = wp.array(fparams, dtype=dt, device=d)
        self.iparams = wp.array(iparams, dtype=wp.int32, device=d)
        self._inputs = [self.fparams, self.iparams] + [self._dev[k] for k in ("pose", "vel", "h_act_in", "h_a_in", "h_b_in")]
        self._outputs = [self._dev[k] for k in ("q", "dqdq", "dqdv", "obs", "h_act_out", "h_a_out", "h_b_out")]
        # the argument list never changes, so the launch is packed once and replayed
        self._cmd = wp.launch(self.kernel, dim=self.n, device=self.device, inputs=self._inputs,
                              outputs=self._outputs, record_cmd=True)
        self._needs_history = bool(np.any(iparams[:, I_FRICTION] == FRICTION_ANCHOR))

    def evaluate(self, pose, vel, hist_active, hist_a, hist_b):
        """Same signature and results as :func:`circle_pairs_ref.evaluate` (arrays in NumPy).

        The returned arrays are owned by this object and overwritten by the next call.
        """
        h = self._buf.host
        h["pose"][...] = pose
        h["vel"][...] = vel
        names = ["pose", "vel"]
        if self._needs_history:
            h["h_act_in"][...] = hist_active
            h["h_a_in"][...] = hist_a
            h["h_b_in"][...] = hist_b
            names += ["h_act_in", "h_a_in", "h_b_in"]
        self._buf.upload(names)
        self._cmd.launch()
        names = [k for k in ("q", "dqdq", "dqdv", "obs", "h_act_out", "h_a_out", "h_b_out")
                 if k not in self.keep_on_device]
        self._buf.download(names)
        g = {k: (h[k] if k in names else None) for k in h}
        return g["q"], g["dqdq"], g["dqdv"], g["obs"], (g["h_act_out"], g["h_a_out"], g["h_b_out"])

    # outputs left on the device (returned as None; read them with device_array)
    keep_on_device = frozenset()

