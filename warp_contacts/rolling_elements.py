"""Warp kernel of the rolling-element bearing family (one thread per element or
lamina, all bearings of a set in one launch). Mirrors
:mod:`warp_contacts.rolling_elements_ref`, which documents the equations."""
import functools

import numpy as np
import warp as wp

from .circle_pairs_ref import N_OBS
from .planar import LaunchBuffers, planar_funcs
from .precision import resolve_device, scalar_types
from .rolling_elements_ref import KIND_BALL, N_FLOAT, N_INT


@functools.lru_cache(maxsize=None)
def _kernel(dtype):
    G = planar_funcs(dtype)
    vec2, perp, cross2, rot, body_seed = G.vec2, G.perp, G.cross2, G.rot, G.body_seed
    store_pair_forces, store_pair_column = G.store_pair_forces, G.store_pair_column

    @wp.func
    def radial_law(kind: int, r: dtype, k: dtype, p: dtype, alpha: dtype, A: dtype, sax: dtype, c: dtype,
                   crown: dtype):
        """(delta, F, f_r, df_r/dr) of one row (see the reference)."""
        ca = wp.cos(alpha)
        if kind == KIND_BALL:
            ar = A * ca + r
            az = A * wp.sin(alpha) + sax
            L = wp.sqrt(ar * ar + az * az)
            delta = L - A - c
            if delta <= dtype(0.0) or L <= dtype(0.0):
                return delta, dtype(0.0), dtype(0.0), dtype(0.0)
            F = k * delta * wp.sqrt(delta)
            dF = dtype(1.5) * k * wp.sqrt(delta)
            return delta, F, F * ar / L, dF * (ar / L) * (ar / L) + F * (dtype(1.0) / L - ar * ar / (L * L * L))
        delta = r * ca - c - crown
        if delta <= dtype(0.0):
            return delta, dtype(0.0), dtype(0.0), dtype(0.0)
        F = k * wp.pow(delta, p)
        return delta, F, F * ca, p * F / delta * ca * ca

    @wp.kernel(module="unique")
    def eval_rolling(
        # Model:
        fparams: wp.array2d(dtype=dtype),
        iparams: wp.array2d(dtype=wp.int32),
        # Data in:
        pose_in: wp.array2d(dtype=dtype),
        # Data out:
        q_out: wp.array2d(dtype=dtype),
        dqdq_out: wp.array3d(dtype=dtype),
        obs_out: wp.array2d(dtype=dtype),
    ):
        i = wp.tid()
        ia = iparams[i, 0]
        ib = iparams[i, 1]
        kind = iparams[i, 2]
        tha = pose_in[ia, 2]
        thb = pose_in[ib, 2]
        a = rot(tha, vec2(fparams[i, 0], fparams[i, 1]))
        b = rot(thb, vec2(fparams[i, 2], fparams[i, 3]))
        g = fparams[i, 5]
        psi = fparams[i, 4] + dtype(0.5) * ((dtype(1.0) - g) * tha + (dtype(1.0) + g) * thb)
        u = vec2(wp.cos(psi), wp.sin(psi))
        d = (vec2(pose_in[ia, 0], pose_in[ia, 1]) + a) - (vec2(pose_in[ib, 0], pose_in[ib, 1]) + b)
        r = wp.dot(d, u)
        delta, F, fr, dfr = radial_law(kind, r, fparams[i, 7], fparams[i, 8], fparams[i, 9], fparams[i, 10],
                                       fparams[i, 11], fparams[i, 6], fparams[i, 12])
        fA = -fr * u
        store_pair_forces(q_out, i, fA, cross2(a, fA), -cross2(b, fA))
        for j in range(6):
            dxa, dtha, dxb, dthb = body_seed(j)
            da = dtha * perp(a)
            db = dthb * perp(b)
            dpsi = dtype(0.5) * ((dtype(1.0) - g) * dtha + (dtype(1.0) + g) * dthb)
            du = dpsi * perp(u)
            dd = (dxa + da) - (dxb + db)
            dr = wp.dot(u, dd) + wp.dot(d, du)
            dfA = -(dfr * dr) * u - fr * du
            # only coordinate columns (j < 6): the elements carry no velocity dependence
            store_pair_column(dqdq_out, dqdq_out, i, j, dfA, cross2(da, fA) + cross2(a, dfA),
                              -(cross2(db, fA) + cross2(b, dfA)))
        pos = vec2(pose_in[ib, 0], pose_in[ib, 1]) + b + (dtype(0.5) * fparams[i, 13]) * u
        obs_out[i, 0] = F
        obs_out[i, 1] = dtype(0.0)
        obs_out[i, 2] = -delta
        obs_out[i, 3] = pos[0]
        obs_out[i, 4] = pos[1]
        obs_out[i, 5] = u[0]
        obs_out[i, 6] = u[1]
        obs_out[i, 7] = dtype(0.0)

    return eval_rolling


class RollingElementKernel:
    """Device-resident evaluator of one rolling-element set (one launch per call)."""

    def __init__(self, fparams, iparams, n_bodies, precision="float64", device="cpu"):
        self.wdtype, self.ndtype = scalar_types(precision)
        d = resolve_device(device, len(fparams))
        fparams = np.ascontiguousarray(fparams, self.ndtype)
        iparams = np.ascontiguousarray(iparams, np.int32)
        assert fparams.shape[1] == N_FLOAT and iparams.shape[1] == N_INT
        n = len(fparams)
        dt = self.wdtype
        self._buf = LaunchBuffers({"pose": ((n_bodies + 1, 3), "f"), "q": ((n, 6), "f"), "dqdq": ((n, 6, 6), "f"),
                                   "obs": ((n, N_OBS), "f")}, dt, self.ndtype, d)
        dev = self._buf.dev
        self._cmd = wp.launch(_kernel(dt), dim=n, device=d,
                              inputs=[wp.array(fparams, dtype=dt, device=d), wp.array(iparams, dtype=wp.int32, device=d),
                                      dev["pose"]],
                              outputs=[dev[k] for k in ("q", "dqdq", "obs")], record_cmd=True)

    def evaluate(self, pose):
        h = self._buf.host
        h["pose"][...] = pose
        self._buf.upload(("pose",))
        self._cmd.launch()
        self._buf.download(("q", "dqdq", "obs"))
        return h["q"], h["dqdq"], h["obs"]
