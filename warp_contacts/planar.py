"""Shared pieces of the planar contact kernels: 2D vector helpers as Warp
functions, the unit seed directions of the forward-mode tangent, and the
host/device buffers of a recorded launch."""
import functools
import types

import numpy as np
import warp as wp


@functools.lru_cache(maxsize=None)
def planar_funcs(dtype):
    """perp, cross2, rot and body_seed for scalar type ``dtype``."""
    vec2 = wp.types.vector(2, dtype)

    @wp.func
    def perp(a: vec2):
        return vec2(-a[1], a[0])

    @wp.func
    def cross2(a: vec2, b: vec2):
        return a[0] * b[1] - a[1] * b[0]

    @wp.func
    def rot(th: dtype, x: vec2):
        c = wp.cos(th)
        s = wp.sin(th)
        return vec2(c * x[0] - s * x[1], s * x[0] + c * x[1])

    @wp.func
    def body_seed(j: int):
        """Unit seed j (0..5) over (x_A, y_A, theta_A, x_B, y_B, theta_B):
        returns (dx_A, dtheta_A, dx_B, dtheta_B)."""
        dxa = vec2(dtype(0.0), dtype(0.0))
        dxb = vec2(dtype(0.0), dtype(0.0))
        dtha = dtype(0.0)
        dthb = dtype(0.0)
        if j == 0:
            dxa = vec2(dtype(1.0), dtype(0.0))
        elif j == 1:
            dxa = vec2(dtype(0.0), dtype(1.0))
        elif j == 2:
            dtha = dtype(1.0)
        elif j == 3:
            dxb = vec2(dtype(1.0), dtype(0.0))
        elif j == 4:
            dxb = vec2(dtype(0.0), dtype(1.0))
        else:
            dthb = dtype(1.0)
        return dxa, dtha, dxb, dthb

    @wp.func
    def store_pair_forces(q_out: wp.array2d(dtype=dtype), i: int, f_a: vec2, m_a: dtype, m_b: dtype):
        """Generalized forces of row i: (f_A, M_A) on body A and (-f_A, M_B) on body B."""
        q_out[i, 0] = f_a[0]
        q_out[i, 1] = f_a[1]
        q_out[i, 2] = m_a
        q_out[i, 3] = -f_a[0]
        q_out[i, 4] = -f_a[1]
        q_out[i, 5] = m_b

    @wp.func
    def store_pair_column(dqdq_out: wp.array3d(dtype=dtype), dqdv_out: wp.array3d(dtype=dtype), i: int, j: int,
                          df_a: vec2, dm_a: dtype, dm_b: dtype):
        """Tangent column j of row i: columns 0-5 go to dQ/dq, 6-11 to dQ/dv."""
        if j < 6:
            dqdq_out[i, 0, j] = df_a[0]
            dqdq_out[i, 1, j] = df_a[1]
            dqdq_out[i, 2, j] = dm_a
            dqdq_out[i, 3, j] = -df_a[0]
            dqdq_out[i, 4, j] = -df_a[1]
            dqdq_out[i, 5, j] = dm_b
        else:
            dqdv_out[i, 0, j - 6] = df_a[0]
            dqdv_out[i, 1, j - 6] = df_a[1]
            dqdv_out[i, 2, j - 6] = dm_a
            dqdv_out[i, 3, j - 6] = -df_a[0]
            dqdv_out[i, 4, j - 6] = -df_a[1]
            dqdv_out[i, 5, j - 6] = dm_b

    return types.SimpleNamespace(vec2=vec2, perp=perp, cross2=cross2, rot=rot, body_seed=body_seed,
                                 store_pair_forces=store_pair_forces, store_pair_column=store_pair_column)


class LaunchBuffers:
    """Host arrays and their device twins for a recorded launch.

    On the CPU the Warp arrays alias the NumPy buffers (no copies per call); on
    a GPU ``upload`` copies named inputs in and ``download`` named outputs out.
    """

    def __init__(self, shapes, wdtype, ndtype, device):
        self.on_cpu = wp.get_device(device).is_cpu
        self.host = {}
        self.dev = {}
        for name, (shape, kind) in shapes.items():
            nd, wd = (np.int32, wp.int32) if kind == "int" else (ndtype, wdtype)
            self.host[name] = np.zeros(shape, nd)
            self.dev[name] = (wp.array(self.host[name], dtype=wd, device=device, copy=False) if self.on_cpu
                              else wp.zeros(shape, dtype=wd, device=device))

    def upload(self, names):
        if not self.on_cpu:
            for k in names:
                self.dev[k].assign(self.host[k])

    def download(self, names):
        if not self.on_cpu:
            for k in names:
                self.host[k][...] = self.dev[k].numpy()
