"""Warp kernel of the rolling-element bearing family (one thread per ball or
roller lamina, all bearings of a set in one launch). Mirrors
:mod:`warp_contacts.rolling_elements_ref` line by line; that module documents
the equations, the parameter layout and the outputs."""
import functools

import numpy as np
import warp as wp

from .circle_pairs_ref import N_OBS
from .laws import law_funcs
from .planar import LaunchBuffers, planar_funcs
from .planar_ref import N_SEEDS
from .precision import resolve_device, scalar_types
from .recorded import RecordedRows
from .rolling_elements_ref import (AUX_ALPHA, AUX_FU, AUX_FZ, HB_E0, HB_E1, HB_F0, HB_F1, HB_K_COEF, HB_K_EXP, K_BODY_A,
                                   K_BODY_B, K_KIND, KIND_BALL, KIND_SLICE, N_AUX, N_FLOAT, N_INT, R_A, R_ALPHA,
                                   R_CLEAR, R_CROWN,
                                   R_DAMP, R_DBALL, R_EMOD, R_FI, R_FO, R_GAMMA, R_K, R_KSCALE, R_P, R_PITCH, R_PSI0,
                                   R_RAMP, R_SAX, R_SIGMA, R_SLICE_DF, R_SLICE_F, R_XI_A, R_XI_B)


@functools.lru_cache(maxsize=None)
def stiffness_funcs(dtype):
    """(hertz_point_stiffness, ball_stiffness): the Hamrock--Brewe point contact and a ball's two
    contacts in series as Warp functions for scalar type ``dtype`` (shared with the spatial rows of
    :mod:`warp_contacts.spatial_balls`)."""
    kc, ke, e0, e1, f0, f1 = (dtype(HB_K_COEF), dtype(HB_K_EXP), dtype(HB_E0), dtype(HB_E1), dtype(HB_F0),
                              dtype(HB_F1))

    @wp.func
    def hertz_point_stiffness(rx: dtype, ry: dtype, e_eff: dtype):
        """Hamrock--Brewe K [N m^-3/2] and d ln K / d r_x (see the reference)."""
        ar = ry / rx
        R = rx * ry / (rx + ry)
        k = kc * wp.pow(ar, ke)
        E = e0 + e1 / ar
        F = f0 + f1 * wp.log(ar)
        K = dtype(3.141592653589793) * k * e_eff * wp.sqrt(dtype(2.0) * E * R / dtype(9.0)) / (F * wp.sqrt(F))
        dlnK_dar = ke / ar - dtype(0.5) * e1 / (ar * ar * E) - dtype(1.5) * f1 / (ar * F)
        return K, dlnK_dar * (-ar / rx) + dtype(0.5) * ry / (rx * (rx + ry))

    @wp.func
    def ball_stiffness(cw: dtype, D: dtype, dm: dtype, fi: dtype, fo: dtype, e_eff: dtype):
        """K(alpha) of one ball (inner and outer contacts in series) and dK / d cos(alpha)."""
        g = D * cw / dm
        dg = D / dm
        Ki, dlki = hertz_point_stiffness(dtype(0.5) * D * (dtype(1.0) - g), fi * D / (dtype(2.0) * fi - dtype(1.0)), e_eff)
        Ko, dlko = hertz_point_stiffness(dtype(0.5) * D * (dtype(1.0) + g), fo * D / (dtype(2.0) * fo - dtype(1.0)), e_eff)
        dlki = dlki * (dtype(-0.5) * D * dg)
        dlko = dlko * (dtype(0.5) * D * dg)
        wi = wp.pow(Ki, dtype(-2.0) / dtype(3.0))
        wo = wp.pow(Ko, dtype(-2.0) / dtype(3.0))
        s = wi + wo
        K = dtype(1.0) / (s * wp.sqrt(s))
        return K, K * (wi * dlki + wo * dlko) / s

    return hertz_point_stiffness, ball_stiffness


@functools.lru_cache(maxsize=None)
def _kernel(dtype):
    G = planar_funcs(dtype)
    L = law_funcs(dtype)
    vec2, perp, cross2, rot = G.vec2, G.perp, G.cross2, G.rot
    body_state, param_vec2, pair_seed = G.body_state, G.param_vec2, G.pair_seed
    store_pair_forces, store_pair_column, store_pair_observation = (G.store_pair_forces, G.store_pair_column,
                                                                    G.store_pair_observation)
    normal_force, damping_ramp = L.normal_force, L.damping_ramp
    _, ball_stiffness = stiffness_funcs(dtype)

    @wp.func
    def lamina_law(r: dtype, rdot: dtype, k: dtype, p: dtype, alpha: dtype, c: dtype, crown: dtype, cd: dtype,
                   dr: dtype):
        """(delta, F, f_r, F sin(alpha), alpha, df_r/dr, df_r/drdot) of a roller lamina."""
        ca = wp.cos(alpha)
        sa = wp.sin(alpha)
        delta = r * ca - c - crown
        F, Fd, Fdd = normal_force(k, p, cd, dr, delta, rdot * ca)
        return delta, F, F * ca, F * sa, alpha, Fd * ca * ca, Fdd * ca * ca

    @wp.func
    def ball_law(r: dtype, rdot: dtype, alpha0: dtype, A: dtype, sax: dtype, c: dtype, cd: dtype, dr: dtype,
                 D: dtype, dm: dtype, fi: dtype, fo: dtype, e_eff: dtype, kscale: dtype):
        """(delta, F, f_r, F sin(alpha_w), alpha_w, df_r/dr, df_r/drdot) of a ball, Eq. (ball_bearing)."""
        ar = A * wp.cos(alpha0) + r
        az = A * wp.sin(alpha0) + sax
        Lc = wp.sqrt(ar * ar + az * az)
        delta = Lc - A - c
        alpha_w = wp.atan2(az, ar)
        zero = dtype(0.0)
        if delta <= zero or Lc <= zero:
            return delta, zero, zero, zero, alpha_w, zero, zero
        cw = ar / Lc
        dcw = az * az / (Lc * Lc * Lc)
        K, dKc = ball_stiffness(cw, D, dm, fi, fo, e_eff)
        K = kscale * K
        dKc = kscale * dKc
        sd = wp.sqrt(delta)
        Fel = K * delta * sd
        dFel = dKc * dcw * delta * sd + dtype(1.5) * K * sd * cw
        rho, drho = damping_ramp(delta, dr)
        ddot = cw * rdot
        F = Fel + cd * rho * ddot
        if F <= zero:
            return delta, zero, zero, zero, alpha_w, zero, zero
        dF = dFel + cd * (drho * cw * ddot + rho * dcw * rdot)
        dFd = cd * rho * cw
        return delta, F, F * cw, F * az / Lc, alpha_w, dF * cw + F * dcw, dFd * cw

    @wp.kernel(module="unique")
    def eval_rolling(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        vel_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        dqdv_out: wp.array3d(dtype=dtype),
        obs_out: wp.array2d(dtype=dtype),
        aux_out: wp.array2d(dtype=dtype),
    ):
        i = wp.tid()
        xa, tha, vxa, wa = body_state(pose_in, vel_in, iparams[i, K_BODY_A])
        xb, thb, vxb, wb = body_state(pose_in, vel_in, iparams[i, K_BODY_B])
        a = rot(tha, param_vec2(fparams, i, R_XI_A))
        b = rot(thb, param_vec2(fparams, i, R_XI_B))
        g = fparams[i, R_GAMMA]
        one = dtype(1.0)
        half = dtype(0.5)
        psi = fparams[i, R_PSI0] + half * ((one - g) * tha + (one + g) * thb)
        psid = half * ((one - g) * wa + (one + g) * wb)
        u = vec2(wp.cos(psi), wp.sin(psi))
        pu = perp(u)
        d = (xa + a) - (xb + b)
        w = (vxa + wa * perp(a)) - (vxb + wb * perp(b))
        r = wp.dot(d, u)
        rdot = wp.dot(w, u) + wp.dot(d, pu) * psid
        delta = dtype(0.0)
        F = dtype(0.0)
        fr = dtype(0.0)
        fzm = dtype(0.0)
        alpha_w = dtype(0.0)
        fr_r = dtype(0.0)
        fr_rd = dtype(0.0)
        if iparams[i, K_KIND] == KIND_BALL:
            delta, F, fr, fzm, alpha_w, fr_r, fr_rd = ball_law(
                r, rdot, fparams[i, R_ALPHA], fparams[i, R_A], fparams[i, R_SAX], fparams[i, R_CLEAR],
                fparams[i, R_DAMP], fparams[i, R_RAMP], fparams[i, R_DBALL], fparams[i, R_PITCH], fparams[i, R_FI],
                fparams[i, R_FO], fparams[i, R_EMOD], fparams[i, R_KSCALE])
        elif iparams[i, K_KIND] == KIND_SLICE:
            ca = wp.cos(fparams[i, R_ALPHA])
            delta = r * ca - fparams[i, R_CLEAR] - fparams[i, R_CROWN]
            alpha_w = fparams[i, R_ALPHA]
            fel = fparams[i, R_SLICE_F]
            rho, drho = damping_ramp(delta, fparams[i, R_RAMP])
            ddot = rdot * ca
            Fs = fel + fparams[i, R_DAMP] * rho * ddot
            if fel > dtype(0.0) and Fs > dtype(0.0):
                F = Fs
                fr = F * ca
                fzm = F * wp.sin(fparams[i, R_ALPHA])
                fr_r = (fparams[i, R_SLICE_DF] + fparams[i, R_DAMP] * drho * ddot) * ca * ca
                fr_rd = fparams[i, R_DAMP] * rho * ca * ca
        else:
            delta, F, fr, fzm, alpha_w, fr_r, fr_rd = lamina_law(
                r, rdot, fparams[i, R_K], fparams[i, R_P], fparams[i, R_ALPHA], fparams[i, R_CLEAR],
                fparams[i, R_CROWN], fparams[i, R_DAMP], fparams[i, R_RAMP])
        fA = -fr * u
        store_pair_forces(q_out, i, fA, cross2(a, fA), -cross2(b, fA))
        for j in range(N_SEEDS):
            dxa, dtha, dxb, dthb, dva, dwa, dvb, dwb = pair_seed(j)
            da = dtha * perp(a)
            db = dthb * perp(b)
            dpsi = half * ((one - g) * dtha + (one + g) * dthb)
            dpsid = half * ((one - g) * dwa + (one + g) * dwb)
            du = dpsi * pu
            dd = (dxa + da) - (dxb + db)
            dw = (dva + dwa * perp(a) + wa * perp(da)) - (dvb + dwb * perp(b) + wb * perp(db))
            dr = wp.dot(dd, u) + wp.dot(d, du)
            drdot = (wp.dot(dw, u) + wp.dot(w, du) + (wp.dot(dd, pu) - wp.dot(d, u) * dpsi) * psid
                     + wp.dot(d, pu) * dpsid)
            dfr = fr_r * dr + fr_rd * drdot
            dfA = -dfr * u - fr * du
            store_pair_column(dqdq_out, dqdv_out, i, j, dfA, cross2(da, fA) + cross2(a, dfA),
                              -(cross2(db, fA) + cross2(b, dfA)))
        zero = dtype(0.0)
        store_pair_observation(obs_out, i, F, zero, -delta, xb + b + (half * fparams[i, R_PITCH]) * u, u, zero)
        aux_out[i, AUX_FU] = -fr
        aux_out[i, AUX_FZ] = -fparams[i, R_SIGMA] * fzm
        aux_out[i, AUX_ALPHA] = alpha_w

    return eval_rolling


class RollingElementKernel(RecordedRows):
    """Device-resident evaluator of one rolling-element set (one recorded launch per call).

    Parameters are uploaded once; per call the poses (and velocities) go in and
    forces, tangent blocks, observations and the auxiliary axial values come out.
    """

    def __init__(self, fparams, iparams, n_bodies, precision="float64", device="cpu"):
        self.wdtype, self.ndtype = scalar_types(precision)
        self.device = d = resolve_device(device, len(fparams))
        fparams = np.ascontiguousarray(fparams, self.ndtype)
        iparams = np.ascontiguousarray(iparams, np.int32)
        assert fparams.shape[1] == N_FLOAT and iparams.shape[1] == N_INT
        n = len(fparams)
        dt = self.wdtype
        self._buf = LaunchBuffers({"pose": ((n_bodies + 1, 3), "f"), "vel": ((n_bodies + 1, 3), "f"),
                                   "q": ((n, 6), "f"), "dqdq": ((n, 6, 6), "f"), "dqdv": ((n, 6, 6), "f"),
                                   "obs": ((n, N_OBS), "f"), "aux": ((n, N_AUX), "f")}, dt, self.ndtype, d)
        dev = self._buf.dev
        self.n = n
        self._fparams = wp.array(fparams, dtype=dt, device=d)
        self._iparams = wp.array(iparams, dtype=wp.int32, device=d)
        self._cmd = wp.launch(_kernel(dt), dim=n, device=d,
                              inputs=[self._fparams, self._iparams, dev["pose"], dev["vel"]],
                              outputs=[dev[k] for k in ("q", "dqdq", "dqdv", "obs", "aux")], record_cmd=True)

    def parameter_arrays(self):
        return self._fparams, self._iparams

    def data_array(self, name):
        return self._buf.dev[name]

    def evaluate(self, pose, vel=None):
        """Same results as :func:`rolling_elements_ref.evaluate` (NumPy arrays owned by this
        object, overwritten by the next call); ``vel=None`` means zero velocities."""
        h = self._buf.host
        h["pose"][...] = pose
        h["vel"][...] = 0.0 if vel is None else vel
        self._buf.upload(("pose", "vel"))
        self._cmd.launch()
        self._buf.download(("q", "dqdq", "dqdv", "obs", "aux"))
        return h["q"], h["dqdq"], h["dqdv"], h["obs"], h["aux"]
