"""Warp kernel of the tapered-roller bearing family (one thread per roller,
looping over its laminae; all rollers of all bearings in one launch).
Mirrors :mod:`warp_contacts.tapered_rollers_ref` line by line; that module
documents the equations, the parameter columns and the outputs."""
import functools

import numpy as np
import warp as wp

from .laws import law_funcs
from .planar import LaunchBuffers
from .precision import resolve_device, scalar_types
from .tapered_rollers_ref import (LA_DAMP, LA_K, LA_NR, LA_NZ, LA_OFF, LA_P, LA_RAMP, LA_RHO, LA_Z, LAM_DELTA, LAM_F,
                                  N_LAMINA_FLOAT, N_Q, N_ROLLER_FLOAT, N_ROLLER_INT, RI_COUNT, RI_FIRST, RI_RIB,
                                  RIB_A, RIB_EXPONENT, RIB_F, RIB_MAX_ITERATIONS, RL_CF, RL_FNR, RL_FNZ, RL_FRHO,
                                  RL_FZ, RL_KAPPA, RL_KF, RL_ZPRE)


@functools.lru_cache(maxsize=None)
def _kernel(dtype):
    L = law_funcs(dtype)
    power_law, normal_force = L.power_law, L.normal_force
    vec5 = wp.types.vector(N_Q, dtype)
    mat55 = wp.types.matrix((N_Q, N_Q), dtype)
    rtol = dtype(8.0 * np.finfo(np.float32 if dtype == wp.float32 else np.float64).eps)
    rib_p = dtype(RIB_EXPONENT)

    @wp.func
    def gradient(rho: dtype, z: dtype, nr: dtype, nz: dtype, psi: dtype):
        """g and h = dg/dpsi of the displacement along (n_r, n_z) of the point (rho, z) at psi."""
        c = wp.cos(psi)
        s = wp.sin(psi)
        m = nz * rho - nr * z
        return vec5(nr * c, nr * s, nz, m * s, -m * c), vec5(-nr * s, nr * c, dtype(0.0), m * c, m * s)

    @wp.func
    def lamina_gradient(lam: wp.array2d(dtype=dtype), s: int, psi: dtype):
        return gradient(lam[s, LA_RHO], lam[s, LA_Z], lam[s, LA_NR], lam[s, LA_NZ], psi)

    @wp.func
    def balance(lam: wp.array2d(dtype=dtype), first: int, count: int, psi: dtype, qe: vec5, kappa: dtype,
                a: dtype, kf: dtype, lo0: dtype):
        """H(a) and H'(a) of the roller's axial balance."""
        ff, dff = power_law(kf, rib_p, a - lo0)
        sf = dtype(0.0)
        sdf = dtype(0.0)
        for s in range(first, first + count):
            g, h = lamina_gradient(lam, s, psi)
            fs, dfs = power_law(lam[s, LA_K], lam[s, LA_P], wp.dot(g, qe) - lam[s, LA_OFF] - kappa * a)
            sf += fs
            sdf += dfs
        return ff - kappa * sf, dff + kappa * kappa * sdf

    @wp.func
    def rib_position(lam: wp.array2d(dtype=dtype), first: int, count: int, psi: dtype, qe: vec5, kappa: dtype,
                     bf: dtype, kf: dtype, cf: dtype):
        """Root of H(a) by Newton's method safeguarded by bisection (see the reference)."""
        lo = bf + cf
        g0, h0 = lamina_gradient(lam, first, psi)
        bmax = wp.dot(g0, qe) - lam[first, LA_OFF]
        for s in range(first + 1, first + count):
            g, h = lamina_gradient(lam, s, psi)
            bmax = wp.max(bmax, wp.dot(g, qe) - lam[s, LA_OFF])
        if bmax - kappa * lo <= dtype(0.0):
            return lo
        lo0 = lo
        hi = bmax / kappa
        a = dtype(0.5) * (lo + hi)
        tol = rtol * (wp.abs(lo) + wp.abs(hi))
        for it in range(RIB_MAX_ITERATIONS):
            H, dH = balance(lam, first, count, psi, qe, kappa, a, kf, lo0)
            if H > dtype(0.0):
                hi = a
            else:
                lo = a
            a_new = dtype(0.5) * (lo + hi)
            if dH > dtype(0.0):
                a_newton = a - H / dH
                if a_newton >= lo and a_newton <= hi:
                    a_new = a_newton
            if wp.abs(a_new - a) <= tol:
                return a_new
            a = a_new
        return a

    @wp.kernel(module="unique")
    def eval_tapered(
        # Model:
        roller_fp: wp.array2d(dtype=dtype),
        roller_ip: wp.array2d(dtype=wp.int32),
        lamina_fp: wp.array2d(dtype=dtype),
        # Data in:
        q_in: wp.array2d(dtype=dtype),
        qdot_in: wp.array2d(dtype=dtype),
        psi_in: wp.array(dtype=dtype),
        psidot_in: wp.array(dtype=dtype),
        # Data out:
        f_out: wp.array2d(dtype=dtype),
        dfdq_out: wp.array3d(dtype=dtype),
        dfdv_out: wp.array3d(dtype=dtype),
        dfdpsi_out: wp.array2d(dtype=dtype),
        dfdpsidot_out: wp.array2d(dtype=dtype),
        rib_out: wp.array2d(dtype=dtype),
        lam_out: wp.array2d(dtype=dtype),
    ):
        j = wp.tid()
        first = roller_ip[j, RI_FIRST]
        count = roller_ip[j, RI_COUNT]
        psi = psi_in[j]
        psid = psidot_in[j]
        qd = vec5(qdot_in[j, 0], qdot_in[j, 1], qdot_in[j, 2], qdot_in[j, 3], qdot_in[j, 4])
        qe = vec5(q_in[j, 0], q_in[j, 1], q_in[j, 2] + roller_fp[j, RL_ZPRE], q_in[j, 3], q_in[j, 4])
        kappa = roller_fp[j, RL_KAPPA]
        gf, hf = gradient(roller_fp[j, RL_FRHO], roller_fp[j, RL_FZ], roller_fp[j, RL_FNR], roller_fp[j, RL_FNZ], psi)
        bf = wp.dot(gf, qe)
        zero = dtype(0.0)
        f = vec5()
        K = mat55()
        C = mat55()
        fpsi = vec5()
        fpsid = vec5()
        if roller_ip[j, RI_RIB] != 0:
            kf = roller_fp[j, RL_KF]
            cf = roller_fp[j, RL_CF]
            a = rib_position(lamina_fp, first, count, psi, qe, kappa, bf, kf, cf)
            Ff, dFf = power_law(kf, rib_p, a - bf - cf)
            # first pass: the sums that eliminate a
            sdf = zero
            sdfg = vec5()
            sdfb = zero
            for s in range(first, first + count):
                g, h = lamina_gradient(lamina_fp, s, psi)
                delta = wp.dot(g, qe) - lamina_fp[s, LA_OFF] - kappa * a
                F, dF = power_law(lamina_fp[s, LA_K], lamina_fp[s, LA_P], delta)
                sdf += dF
                sdfg += dF * g
                sdfb += dF * wp.dot(h, qe)
                lam_out[s, LAM_F] = F
                lam_out[s, LAM_DELTA] = delta
            Ha = dFf + kappa * kappa * sdf
            a_q = vec5()
            a_psi = zero
            if Ha > zero:
                a_q = (dFf * gf + kappa * sdfg) / Ha
                a_psi = (dFf * wp.dot(hf, qe) + kappa * sdfb) / Ha
            for s in range(first, first + count):
                g, h = lamina_gradient(lamina_fp, s, psi)
                F, dF = power_law(lamina_fp[s, LA_K], lamina_fp[s, LA_P],
                                  wp.dot(g, qe) - lamina_fp[s, LA_OFF] - kappa * a)
                f -= F * g
                K -= wp.outer(g, dF * (g - kappa * a_q))
                fpsi -= (dF * (wp.dot(h, qe) - kappa * a_psi)) * g + F * h
            f += Ff * gf
            K += dFf * wp.outer(gf, a_q - gf)
            fpsi += (dFf * (a_psi - wp.dot(hf, qe))) * gf + Ff * hf
            rib_out[j, RIB_F] = Ff
            rib_out[j, RIB_A] = a
        else:
            sf = zero
            for s in range(first, first + count):
                g, h = lamina_gradient(lamina_fp, s, psi)
                bpsi = wp.dot(h, qe)
                delta = wp.dot(g, qe) - lamina_fp[s, LA_OFF]
                dd = wp.dot(g, qd) + bpsi * psid
                F, dF, dFd = normal_force(lamina_fp[s, LA_K], lamina_fp[s, LA_P], lamina_fp[s, LA_DAMP],
                                          lamina_fp[s, LA_RAMP], delta, dd)
                dd_psi = wp.dot(h, qd) - (wp.dot(g, qe) - lamina_fp[s, LA_NZ] * qe[2]) * psid
                f -= F * g
                K -= wp.outer(g, dF * g + (dFd * psid) * h)
                C -= wp.outer(g, dFd * g)
                fpsi -= (dF * bpsi + dFd * dd_psi) * g + F * h
                fpsid -= (dFd * bpsi) * g
                sf += F
                lam_out[s, LAM_F] = F
                lam_out[s, LAM_DELTA] = delta
            rib_out[j, RIB_F] = kappa * sf
            rib_out[j, RIB_A] = bf
        for r in range(N_Q):
            f_out[j, r] = f[r]
            dfdpsi_out[j, r] = fpsi[r]
            dfdpsidot_out[j, r] = fpsid[r]
            for c in range(N_Q):
                dfdq_out[j, r, c] = K[r, c]
                dfdv_out[j, r, c] = C[r, c]

    return eval_tapered


class TaperedRollerKernel:
    """Device-resident evaluator of a set of tapered rollers (one recorded launch per call).

    Parameters are uploaded once; per call the per-roller states (q, q_dot, psi, psi_dot)
    go in and the wrenches, tangents, rib values and lamina values come out.
    """

    def __init__(self, roller_fp, roller_ip, lamina_fp, precision="float64", device="cpu"):
        self.wdtype, self.ndtype = scalar_types(precision)
        roller_fp = np.ascontiguousarray(roller_fp, self.ndtype)
        roller_ip = np.ascontiguousarray(roller_ip, np.int32)
        lamina_fp = np.ascontiguousarray(lamina_fp, self.ndtype)
        assert roller_fp.shape[1] == N_ROLLER_FLOAT and roller_ip.shape[1] == N_ROLLER_INT
        assert lamina_fp.shape[1] == N_LAMINA_FLOAT
        R, nl = len(roller_fp), len(lamina_fp)
        self.device = d = resolve_device(device, nl)
        dt = self.wdtype
        self._buf = LaunchBuffers({"q": ((R, N_Q), "f"), "qdot": ((R, N_Q), "f"), "psi": ((R,), "f"),
                                   "psidot": ((R,), "f"), "f": ((R, N_Q), "f"), "dfdq": ((R, N_Q, N_Q), "f"),
                                   "dfdv": ((R, N_Q, N_Q), "f"), "dfdpsi": ((R, N_Q), "f"),
                                   "dfdpsidot": ((R, N_Q), "f"), "rib": ((R, 2), "f"), "lam": ((nl, 2), "f")},
                                  dt, self.ndtype, d)
        dev = self._buf.dev
        self._lamina_fp = wp.array(lamina_fp, dtype=dt, device=d)
        self._cmd = wp.launch(_kernel(dt), dim=R, device=d,
                              inputs=[wp.array(roller_fp, dtype=dt, device=d),
                                      wp.array(roller_ip, dtype=wp.int32, device=d),
                                      self._lamina_fp,
                                      dev["q"], dev["qdot"], dev["psi"], dev["psidot"]],
                              outputs=[dev[k] for k in ("f", "dfdq", "dfdv", "dfdpsi", "dfdpsidot", "rib", "lam")],
                              record_cmd=True)

    def set_lamina_parameters(self, lamina_fp):
        """Overwrite the lamina float parameters (same shape) in place on the device; the recorded
        launch keeps pointing at them (slow-state clearance offsets between mechanical windows)."""
        fp = np.ascontiguousarray(lamina_fp, dtype=self.ndtype)
        assert fp.shape == tuple(self._lamina_fp.shape)
        self._lamina_fp.assign(fp)

    def device_array(self, name):
        """The device array of input or output ``name`` (q, qdot, psi, psidot; f, dfdq, dfdv, dfdpsi,
        dfdpsidot, rib, lam) of the recorded launch."""
        return self._buf.dev[name]

    def launch(self):
        """Replay the recorded launch on the device arrays as they are (no transfer)."""
        self._cmd.launch()

    def evaluate(self, q, qdot, psi, psidot):
        """Same results as :func:`tapered_rollers_ref.evaluate` (NumPy arrays owned by this object,
        overwritten by the next call)."""
        h = self._buf.host
        h["q"][...] = q
        h["qdot"][...] = qdot
        h["psi"][...] = psi
        h["psidot"][...] = psidot
        self._buf.upload(("q", "qdot", "psi", "psidot"))
        self._cmd.launch()
        self._buf.download(("f", "dfdq", "dfdv", "dfdpsi", "dfdpsidot", "rib", "lam"))
        return h["f"], h["dfdq"], h["dfdv"], h["dfdpsi"], h["dfdpsidot"], h["rib"], h["lam"]
