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

    return types.SimpleNamespace(vec2=vec2, perp=perp, cross2=cross2, rot=rot, body_seed=body_seed)


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
