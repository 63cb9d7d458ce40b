"""Warp kernel of the rolling-element rows between a ring body with retained axial and tilt
coordinates and its housing (issue 32; one thread per ball or roller lamina, every mounting of a
set in one launch). Mirrors the NumPy reference
:meth:`rvtool.bearings.spatial_set.SpatialBearingSet.balls` line by line; that module documents the
kinematics (Jones 1960; Harris & Kotzalas 2007, ch. 1), the laws and the outputs.

Per element i: the 12 coordinates (x, y, theta, z, gamma_x, gamma_y of ring A, then of ring B) are
four pose rows (``iparams`` columns S_*: A's planar row, A's out-of-plane row, B's planar row, B's
out-of-plane row; the ground row, index n_bodies, is zero); outputs the forces q (N, 12) on those
coordinates, the tangent dqdq (N, 12, 12) (row: force entry, column: coordinate; forward mode over
the 12 unit seeds), the observation row (N, 8) and the auxiliary values (f_u, f_z, alpha_w, m).
"""
import functools

import numpy as np
import warp as wp

from .circle_pairs_ref import N_OBS, O_FN, O_GAP, O_NX, O_NY, O_PX, O_PY
from .laws import law_funcs
from .planar import LaunchBuffers, planar_funcs
from .precision import resolve_device, scalar_types
from .recorded import RecordedRows
from .rolling_elements import stiffness_funcs
from .rolling_elements_ref import (KIND_BALL, N_FLOAT, R_A, R_ALPHA, R_CLEAR, R_CROWN, R_DBALL, R_EMOD, R_FI, R_FO,
                                   R_GAMMA, R_K, R_KSCALE, R_P, R_PITCH, R_PSI0, R_RAMP, R_SIGMA, R_XI_A, R_XI_B)

#: ``iparams`` columns: pose rows of A's planar and out-of-plane coordinates, B's, the element kind
S_A, S_TA, S_B, S_TB, S_KIND = 0, 1, 2, 3, 4
N_INT = 5
#: ``geom`` columns: pitch radius rho [m], axial station z_k [m], groove-centre distance at zero
#: displacement (a_r0, a_z0) [m] (balls; zero for laminae)
G_RHO, G_Z, G_AR0, G_AZ0 = 0, 1, 2, 3
N_GEOM = 4
#: ``aux`` columns: f_u, f_z [N] on A, working angle alpha_w [rad], moment arm term m [N m]
A_FU, A_FZ, A_ALPHA, A_M = 0, 1, 2, 3
N_AUX = 4
#: coordinates of one element (A: x, y, theta, z, gamma_x, gamma_y; then B)
N_COORDS = 12


@functools.lru_cache(maxsize=None)
def _kernel(dtype):
    G = planar_funcs(dtype)
    L = law_funcs(dtype)
    vec2, perp, cross2, rot = G.vec2, G.perp, G.cross2, G.rot
    normal_force = L.normal_force
    _, ball_stiffness = stiffness_funcs(dtype)

    @wp.func
    def seed(j: int, k: int):
        """Component k of the unit seed j."""
        if j == k:
            return dtype(1.0)
        return dtype(0.0)

    @wp.func
    def ball_law(ar: dtype, az: dtype, A: dtype, c: dtype, D: dtype, dm: dtype, fi: dtype, fo: dtype,
                 e_eff: dtype, kscale: dtype):
        """(delta, F, alpha_w, Fr, Fa, dFr/da_r, dFr/da_z, dFa/da_r, dFa/da_z) of a ball (reference:
        ball_law_spatial)."""
        Lc = wp.sqrt(ar * ar + az * az)
        Ls = Lc
        if Lc <= dtype(0.0):
            Ls = dtype(1.0)
        delta = Lc - A - c
        alw = wp.atan2(az, ar)
        zero = dtype(0.0)
        cw = ar / Ls
        sw = az / Ls
        L3 = Ls * Ls * Ls
        cw_r = az * az / L3
        cw_z = -ar * az / L3
        sw_r = -ar * az / L3
        sw_z = ar * ar / L3
        if delta <= zero:
            return delta, zero, alw, zero, zero, zero, zero, zero, zero
        K, dK = ball_stiffness(cw, D, dm, fi, fo, e_eff)
        K = kscale * K
        dK = kscale * dK
        root = wp.sqrt(delta)
        d15 = delta * root
        F = K * d15
        F_r = dK * cw_r * d15 + dtype(1.5) * K * root * cw
        F_z = dK * cw_z * d15 + dtype(1.5) * K * root * sw
        return (delta, F, alw, F * cw, F * sw, F_r * cw + F * cw_r, F_z * cw + F * cw_z, F_r * sw + F * sw_r,
                F_z * sw + F * sw_z)

    @wp.func
    def lamina_law(ar: dtype, az: dtype, k: dtype, p: dtype, alpha: dtype, c: dtype, crown: dtype, ramp: dtype):
        """The same outputs for a roller lamina at fixed contact angle (reference: lamina_law_spatial)."""
        ca = wp.cos(alpha)
        sa = wp.sin(alpha)
        delta = ar * ca + az * sa - c - crown
        F, dF, _ = normal_force(k, p, dtype(0.0), ramp, delta, dtype(0.0))
        return delta, F, alpha, F * ca, F * sa, dF * ca * ca, dF * ca * sa, dF * sa * ca, dF * sa * sa

    @wp.kernel(module="unique")
    def eval_spatial_rows(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        geom: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        obs_out: wp.array2d(dtype=dtype),
        aux_out: wp.array2d(dtype=dtype),
    ):
        i = wp.tid()
        sA = iparams[i, S_A]
        tA = iparams[i, S_TA]
        sB = iparams[i, S_B]
        tB = iparams[i, S_TB]
        tha = pose_in[sA, 2]
        thb = pose_in[sB, 2]
        a = rot(tha, vec2(fparams[i, R_XI_A], fparams[i, R_XI_A + 1]))
        b = rot(thb, vec2(fparams[i, R_XI_B], fparams[i, R_XI_B + 1]))
        g = fparams[i, R_GAMMA]
        one = dtype(1.0)
        half = dtype(0.5)
        psi = fparams[i, R_PSI0] + half * ((one - g) * tha + (one + g) * thb)
        c = wp.cos(psi)
        s = wp.sin(psi)
        u = vec2(c, s)
        pu = perp(u)
        d = vec2(pose_in[sA, 0], pose_in[sA, 1]) + a - vec2(pose_in[sB, 0], pose_in[sB, 1]) - b
        zr = pose_in[tA, 0] - pose_in[tB, 0]
        gx = pose_in[tA, 1] - pose_in[tB, 1]
        gy = pose_in[tA, 2] - pose_in[tB, 2]
        rho = geom[i, G_RHO]
        zk = geom[i, G_Z]
        sig = fparams[i, R_SIGMA]
        dr = wp.dot(d, u) + zk * (gy * c - gx * s)
        da = zr + rho * (gx * s - gy * c)
        ar = geom[i, G_AR0] + dr
        az = geom[i, G_AZ0] + sig * da
        delta = dtype(0.0)
        F = dtype(0.0)
        alw = dtype(0.0)
        Fr = dtype(0.0)
        Fa = dtype(0.0)
        Fr_r = dtype(0.0)
        Fr_z = dtype(0.0)
        Fa_r = dtype(0.0)
        Fa_z = dtype(0.0)
        if iparams[i, S_KIND] == KIND_BALL:
            delta, F, alw, Fr, Fa, Fr_r, Fr_z, Fa_r, Fa_z = ball_law(
                ar, az, fparams[i, R_A], fparams[i, R_CLEAR], fparams[i, R_DBALL], fparams[i, R_PITCH],
                fparams[i, R_FI], fparams[i, R_FO], fparams[i, R_EMOD], fparams[i, R_KSCALE])
        else:
            delta, F, alw, Fr, Fa, Fr_r, Fr_z, Fa_r, Fa_z = lamina_law(
                ar, az, fparams[i, R_K], fparams[i, R_P], fparams[i, R_ALPHA], fparams[i, R_CLEAR],
                fparams[i, R_CROWN], fparams[i, R_RAMP])
        fu = -Fr
        fz = -sig * Fa
        m = rho * fz - zk * fu
        fA = fu * u
        q_out[i, 0] = fA[0]
        q_out[i, 1] = fA[1]
        q_out[i, 2] = cross2(a, fA)
        q_out[i, 3] = fz
        q_out[i, 4] = m * s
        q_out[i, 5] = -m * c
        q_out[i, 6] = -fA[0]
        q_out[i, 7] = -fA[1]
        q_out[i, 8] = -cross2(b, fA)
        q_out[i, 9] = -fz
        q_out[i, 10] = -m * s
        q_out[i, 11] = m * c
        pa = perp(a)
        pb = perp(b)
        dpu = wp.dot(d, pu) - zk * (gy * s + gx * c)
        rgc = rho * (gx * c + gy * s)
        for j in range(N_COORDS):
            e2 = seed(j, 2)
            e8 = seed(j, 8)
            dpsi = half * ((one - g) * e2 + (one + g) * e8)
            dgx = seed(j, 4) - seed(j, 10)
            dgy = seed(j, 5) - seed(j, 11)
            dd = vec2(seed(j, 0), seed(j, 1)) + e2 * pa - vec2(seed(j, 6), seed(j, 7)) - e8 * pb
            ddr = wp.dot(dd, u) + dpu * dpsi + zk * (c * dgy - s * dgx)
            dda = (seed(j, 3) - seed(j, 9)) + rho * (s * dgx - c * dgy) + rgc * dpsi
            daz = sig * dda
            dfu = -(Fr_r * ddr + Fr_z * daz)
            dfz = -sig * (Fa_r * ddr + Fa_z * daz)
            dm = rho * dfz - zk * dfu
            dfA = dfu * u + (fu * dpsi) * pu
            dq2 = cross2(e2 * pa, fA) + cross2(a, dfA)
            dq4 = dm * s + m * c * dpsi
            dq5 = -dm * c + m * s * dpsi
            dq8 = -(cross2(e8 * pb, fA) + cross2(b, dfA))
            dqdq_out[i, 0, j] = dfA[0]
            dqdq_out[i, 1, j] = dfA[1]
            dqdq_out[i, 2, j] = dq2
            dqdq_out[i, 3, j] = dfz
            dqdq_out[i, 4, j] = dq4
            dqdq_out[i, 5, j] = dq5
            dqdq_out[i, 6, j] = -dfA[0]
            dqdq_out[i, 7, j] = -dfA[1]
            dqdq_out[i, 8, j] = dq8
            dqdq_out[i, 9, j] = -dfz
            dqdq_out[i, 10, j] = -dq4
            dqdq_out[i, 11, j] = -dq5
        for k in range(N_OBS):
            obs_out[i, k] = dtype(0.0)
        obs_out[i, O_FN] = F
        obs_out[i, O_GAP] = -delta
        pc = vec2(pose_in[sB, 0], pose_in[sB, 1]) + b + rho * u
        obs_out[i, O_PX] = pc[0]
        obs_out[i, O_PY] = pc[1]
        obs_out[i, O_NX] = c
        obs_out[i, O_NY] = s
        aux_out[i, A_FU] = fu
        aux_out[i, A_FZ] = fz
        aux_out[i, A_ALPHA] = alw
        aux_out[i, A_M] = m

    return eval_spatial_rows


class SpatialBallKernel(RecordedRows):
    """Device-resident evaluator of one set of spatial rolling-element rows (one recorded launch per
    call). fparams (N, N_FLOAT) in the layout of :mod:`warp_contacts.rolling_elements_ref`, geom
    (N, N_GEOM), iparams (N, N_INT) (module constants), n_bodies pose rows (the ground row added)."""

    def __init__(self, fparams, geom, iparams, n_bodies, precision="float64", device="cpu"):
        self.wdtype, self.ndtype = scalar_types(precision)
        self.device = d = resolve_device(device, len(fparams))
        fparams = np.ascontiguousarray(fparams, self.ndtype)
        geom = np.ascontiguousarray(geom, self.ndtype)
        iparams = np.ascontiguousarray(iparams, np.int32)
        assert fparams.shape[1] == N_FLOAT and geom.shape[1] == N_GEOM and iparams.shape[1] == N_INT
        n = self.n = len(fparams)
        dt = self.wdtype
        self._buf = LaunchBuffers({"pose": ((n_bodies + 1, 3), "f"), "q": ((n, N_COORDS), "f"),
                                   "dqdq": ((n, N_COORDS, N_COORDS), "f"), "obs": ((n, N_OBS), "f"),
                                   "aux": ((n, N_AUX), "f")}, dt, self.ndtype, d)
        dev = self._buf.dev
        self._fparams = wp.array(fparams, dtype=dt, device=d)
        self._geom = wp.array(geom, dtype=dt, device=d)
        self._iparams = wp.array(iparams, dtype=wp.int32, device=d)
        self._cmd = wp.launch(_kernel(dt), dim=n, device=d, inputs=[self._fparams, self._geom, self._iparams,
                                                                    dev["pose"]],
                              outputs=[dev[k] for k in ("q", "dqdq", "obs", "aux")], record_cmd=True)

    def parameter_arrays(self):
        return self._fparams, self._iparams

    def data_array(self, name):
        return self._buf.dev[name]

    def evaluate(self, pose):
        """(q (N, 12), dqdq (N, 12, 12), obs (N, 8), aux (N, 4)) at poses (n_bodies, 3) (NumPy arrays owned
        by this object, overwritten by the next call)."""
        h = self._buf.host
        h["pose"][:-1] = pose
        self._buf.upload(("pose",))
        self._cmd.launch()
        self._buf.download(("q", "dqdq", "obs", "aux"))
        return h["q"], h["dqdq"], h["obs"], h["aux"]
