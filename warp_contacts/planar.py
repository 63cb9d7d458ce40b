"""Shared pieces of the planar contact kernels: 2D vector helpers as Warp
functions, the kernel prologue (a body's pose and velocity, a point stored in
two parameter columns), the unit seed directions of the forward-mode tangent,
the stores of a pair row's forces, tangent columns and observations, and the
host/device buffers of a recorded launch.

The NumPy twins of the vector helpers are in :mod:`warp_contacts.planar_ref`.
A pair family's kernel reads like this (see :mod:`warp_contacts.circle_pairs`)::

    # columns are named once, in the family's _ref module (I_BODY_A, P_XI_A, ...)
    xa, tha, vxa, wa = body_state(pose_in, vel_in, iparams[i, I_BODY_A])
    pa = rot(tha, param_vec2(fparams, i, P_XI_A))
    ...
    for j in range(N_SEEDS):                       # compile-time trip count: Warp unrolls it
        dxa, dtha, dxb, dthb, dva, dwa, dvb, dwb = pair_seed(j)
        ...
        store_pair_column(dqdq_out, dqdv_out, i, j, df_a, dm_a, dm_b)
"""
import functools
import types

import numpy as np
import warp as wp

from .circle_pairs_ref import O_FN, O_FT, O_GAP, O_NX, O_NY, O_PX, O_PY, O_VT
from .planar_ref import N_COORD_SEEDS

# Seeds of the pair tangent: planar_ref.N_SEEDS (coordinates, then velocities). Kernels loop
# over a compile-time count (N_SEEDS, or N_COORD_SEEDS without the velocity tangent) so that
# Warp unrolls the loop (a runtime bound measured 1.7x slower on the cycloid family).


@functools.lru_cache(maxsize=None)
def planar_funcs(dtype):
    """The planar helpers for scalar type ``dtype`` (a namespace of Warp functions)."""
    vec2 = wp.types.vector(2, dtype)

    @wp.func
    def body_pose(pose: wp.array2d(dtype=dtype), b: int):
        """Position x_b [m] and angle theta_b [rad] of pose row b (rows are (x, y, theta))."""
        return vec2(pose[b, 0], pose[b, 1]), pose[b, 2]

    @wp.func
    def body_state(pose: wp.array2d(dtype=dtype), vel: wp.array2d(dtype=dtype), b: int):
        """Position x_b [m], angle theta_b [rad], velocity v_b [m/s] and angular velocity
        omega_b [rad/s] of pose/velocity row b (rows are (x, y, theta) and (vx, vy, omega))."""
        return vec2(pose[b, 0], pose[b, 1]), pose[b, 2], vec2(vel[b, 0], vel[b, 1]), vel[b, 2]

    @wp.func
    def param_vec2(a: wp.array2d(dtype=dtype), i: int, col: int):
        """The planar vector stored in columns (col, col + 1) of row i (e.g. a local centre xi)."""
        return vec2(a[i, col], a[i, col + 1])

    @wp.func
    def row_vec2(a: wp.array2d(dtype=dtype), i: int):
        """Row i of an (N, 2) array of planar vectors (a table point, an anchor)."""
        return vec2(a[i, 0], a[i, 1])

    @wp.func
    def store_row_vec2(a: wp.array2d(dtype=dtype), i: int, v: vec2):
        """Write v to row i of an (N, 2) array of planar vectors."""
        a[i, 0] = v[0]
        a[i, 1] = v[1]

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
    def pair_seed(j: int):
        """Unit seed j (0..11) of the pair tangent, columns in the order of :func:`store_pair_column`:
        0-5 move the coordinates, 6-11 the velocities (each as in :func:`body_seed`). Returns the
        coordinate seed (dx_A, dtheta_A, dx_B, dtheta_B) and the velocity seed (dv_A, domega_A,
        dv_B, domega_B), one of them zero."""
        zero2 = vec2(dtype(0.0), dtype(0.0))
        zero = dtype(0.0)
        dxa, dtha, dxb, dthb = body_seed(j % N_COORD_SEEDS)
        if j < N_COORD_SEEDS:
            return dxa, dtha, dxb, dthb, zero2, zero, zero2, zero
        return zero2, zero, zero2, zero, dxa, dtha, dxb, dthb

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

    @wp.func
    def store_pair_observation(obs_out: wp.array2d(dtype=dtype), i: int, fn: dtype, vt: dtype, gap: dtype,
                               point: vec2, normal: vec2, ft: dtype):
        """Observation row i in the columns O_* of :mod:`warp_contacts.circle_pairs_ref`: normal
        force [N], tangential slip velocity [m/s], gap [m], contact point [m], unit normal and
        tangential force [N]."""
        obs_out[i, O_FN] = fn
        obs_out[i, O_VT] = vt
        obs_out[i, O_GAP] = gap
        obs_out[i, O_PX] = point[0]
        obs_out[i, O_PY] = point[1]
        obs_out[i, O_NX] = normal[0]
        obs_out[i, O_NY] = normal[1]
        obs_out[i, O_FT] = ft

    return types.SimpleNamespace(vec2=vec2, perp=perp, cross2=cross2, rot=rot, body_pose=body_pose,
                                 body_state=body_state,
                                 param_vec2=param_vec2, row_vec2=row_vec2,
                                 store_row_vec2=store_row_vec2, body_seed=body_seed, pair_seed=pair_seed,
                                 store_pair_forces=store_pair_forces, store_pair_column=store_pair_column,
                                 store_pair_observation=store_pair_observation)


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
