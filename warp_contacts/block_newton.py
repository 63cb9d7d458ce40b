"""Warp kernel of the block Newton step (one thread per copy; the same code on cpu and cuda).

Mirrors :mod:`warp_contacts.block_newton_ref` (see there and :mod:`warp_contacts.batched_newton_ref`
for the step): copy p's residual and tangent come summed already (Q (B, n), dQ/dq (B, n, n), e.g.
:class:`warp_contacts.block_scatter.BlockScatter`'s device sums), so the kernel serves every family
set (the device row Newton of RV, small-tooth-difference and cycloid models, :mod:`rvtool.solver.device_rows`).
Springs, the output torque and the fixed coordinates are added, the block is solved by Gaussian
elimination with partial pivoting (:mod:`warp_contacts.dense_lu`), the step is limited and checked
and the stage bookkeeping advances, all on the device: the host reads back the states and
statuses once per iteration (or not at all until the loop ends). A copy whose status is not
ACTIVE is left untouched (the copies of a batch that carry no point). ``active[0]`` counts the
copies still active after the step (an integer atomic: its sum does not depend on the order).
"""
import functools

import warp as wp

from .batched_newton_ref import ACTIVE, CONVERGED, FAILED, WARM
from .dense_lu import LAYOUTS, accessors, lu_funcs


@functools.lru_cache(maxsize=None)
def kernel(dtype, layout="copy_major"):
    """The ``block_step`` kernel for ``dtype``; the tangent K and the working arrays A, r, dq in
    ``layout`` (:func:`warp_contacts.dense_lu.accessors`: "copy_major" K and A (B, n, n), r and dq
    (B, n); "copy_fastest" K and A (n, n, B), r and dq (n, B): K from :func:`transpose_kernel`).
    Q, q, kin stay (B, n)."""
    lu_solve = lu_funcs(dtype, layout)
    mat, set_mat, vec, set_vec = accessors(dtype, layout)

    @wp.kernel(module="unique")
    def block_step(
        # Model:
        spring_k: wp.array(dtype=dtype),
        free: wp.array(dtype=wp.int32),
        rot: wp.array(dtype=wp.int32),
        out_index: int,
        stiffening: wp.array(dtype=dtype),
        abs_tol: dtype,
        max_iterations: int,
        max_step_translation: dtype,
        max_step_rotation: dtype,
        bound_translation: dtype,
        bound_rotation: dtype,
        homotopy: int,
        # Data in:
        Q: wp.array2d(dtype=dtype),
        K: wp.array3d(dtype=dtype),
        kin: wp.array2d(dtype=dtype),
        torque: wp.array(dtype=dtype),
        # Data out (state and scratch):
        q: wp.array2d(dtype=dtype),
        status: wp.array(dtype=wp.int32),
        stage: wp.array(dtype=wp.int32),
        iters: wp.array(dtype=wp.int32),
        total: wp.array(dtype=wp.int32),
        residual: wp.array(dtype=dtype),
        r: wp.array2d(dtype=dtype),
        A: wp.array3d(dtype=dtype),
        dq: wp.array2d(dtype=dtype),
        active: wp.array(dtype=wp.int32),
    ):
        p = wp.tid()
        if status[p] != ACTIVE:
            return
        n = q.shape[1]
        total[p] = total[p] + 1
        f = dtype(1.0)
        if stage[p] != WARM:
            f = stiffening[stage[p]]
        ok = int(1)
        norm2 = dtype(0.0)
        for i in range(n):
            ks = f * spring_k[i]
            ri = Q[p, i] - ks * (q[p, i] - kin[p, i])
            if i == out_index:
                ri = ri + torque[p]
            for j in range(n):
                set_mat(A, p, i, j, -mat(K, p, i, j))
            set_mat(A, p, i, i, mat(A, p, i, i) + ks)
            if free[i] == 0:
                ri = dtype(0.0)
            set_vec(r, p, i, ri)
            norm2 = norm2 + ri * ri
        for i in range(n):
            for j in range(n):
                if free[i] == 0 or free[j] == 0:
                    set_mat(A, p, i, j, dtype(0.0))
                if not wp.isfinite(mat(A, p, i, j)):
                    ok = int(0)
            if free[i] == 0:
                set_mat(A, p, i, i, dtype(1.0))
        # NaN in a fixed coordinate's entries is removed above, as the reference's identity rows
        norm = wp.sqrt(norm2)
        if not wp.isfinite(norm):
            ok = int(0)
        residual[p] = norm
        converged = int(0)
        if ok != 0 and norm <= abs_tol:
            converged = int(1)
        if ok != 0:
            ok = lu_solve(A, r, dq, p, n)
        mt = dtype(0.0)
        mr = dtype(0.0)
        if ok != 0:
            for i in range(n):
                x = vec(dq, p, i)
                if not wp.isfinite(x):
                    ok = int(0)
                if rot[i] != 0:
                    mr = wp.max(mr, wp.abs(x))
                else:
                    mt = wp.max(mt, wp.abs(x))
        if ok != 0:
            scale = dtype(1.0)
            if converged == 0:
                if mt > max_step_translation:
                    scale = max_step_translation / mt
                if mr * scale > max_step_rotation:
                    scale = max_step_rotation / mr
            iters[p] = iters[p] + 1
            for i in range(n):
                qi = q[p, i] + scale * vec(dq, p, i)
                q[p, i] = qi
                dev = wp.abs(qi - kin[p, i])
                if rot[i] != 0:
                    if dev > bound_rotation:
                        ok = int(0)
                elif dev > bound_translation:
                    ok = int(0)
        if ok != 0 and converged != 0:
            if stage[p] == WARM or stage[p] == stiffening.shape[0] - 1:
                status[p] = CONVERGED
            else:
                stage[p] = stage[p] + 1
                iters[p] = 0
        elif ok == 0 or iters[p] >= max_iterations:
            if stage[p] == WARM and homotopy != 0:
                stage[p] = 0
                iters[p] = 0
                for i in range(n):
                    q[p, i] = kin[p, i]
            else:
                status[p] = FAILED
        if status[p] == ACTIVE:
            wp.atomic_add(active, 0, 1)

    return block_step


@functools.lru_cache(maxsize=None)
def transpose_kernel(dtype):
    """``to_copy_fastest``: Kt[i, j, p] = K[p, i, j] (launched over (n, n, B): neighbouring threads
    write neighbouring addresses), the copy-fastest tangent of :func:`kernel`."""

    @wp.kernel(module="unique")
    def to_copy_fastest(K: wp.array3d(dtype=dtype), Kt: wp.array3d(dtype=dtype)):
        i, j, p = wp.tid()
        Kt[i, j, p] = K[p, i, j]

    return to_copy_fastest


@functools.lru_cache(maxsize=None)
def pose_kernel(dtype):
    """``write_poses``: pose[p nb + i // 3, i % 3] = reference[p, i] + q[p, i] (the absolute poses of
    every copy in a contact kernel's pose array, its ground row untouched; NumPy:
    ``(reference + q).reshape(B nb, 3)``)."""

    @wp.kernel(module="unique")
    def write_poses(reference: wp.array2d(dtype=dtype), q: wp.array2d(dtype=dtype), nb: int,
                    pose: wp.array2d(dtype=dtype)):
        p, i = wp.tid()
        pose[p * nb + i // 3, i % 3] = reference[p, i] + q[p, i]

    return write_poses


@functools.lru_cache(maxsize=None)
def gather_pose_kernel(dtype):
    """``gather_poses``: pose[i // 3, i % 3] = reference[m // n, m % n] + q[m // n, m % n] for m =
    index[i] >= 0, else 0 (the poses of a set on extended bodies, whose coordinates are selections
    of the copies' row coordinates, :mod:`rvtool.solver.row_extension`; its ground row untouched;
    NumPy: :func:`rvtool.solver.row_extension.gather_poses` of reference + q)."""

    @wp.kernel(module="unique")
    def gather_poses(reference: wp.array2d(dtype=dtype), q: wp.array2d(dtype=dtype), index: wp.array(dtype=wp.int64),
                     pose: wp.array2d(dtype=dtype)):
        i = wp.tid()
        m = index[i]
        n = wp.int64(q.shape[1])
        v = dtype(0.0)
        if m >= wp.int64(0):
            p = int(m // n)
            j = int(m % n)
            v = reference[p, j] + q[p, j]
        pose[i // 3, i % 3] = v

    return gather_poses


class BlockNewtonStep:
    """The step's device state for B copies of n coordinates: ``model`` a
    :class:`warp_contacts.block_newton_ref.StepModel`; arrays ``q``, ``kin``, ``torque``, ``status``,
    ``stage``, ``iters``, ``total``, ``residual`` (device), written by :meth:`load` and read by
    :meth:`read`; :meth:`step` launches one step from device sums Q (B, n), K (B, n, n).

    ``layout`` of the step's tangent and working arrays (the copy's matrix A, residual r, step dq;
    see :func:`kernel`): "copy_fastest" (one thread per copy, neighbouring threads at neighbouring
    addresses: coalesced on a GPU; the tangent transposed by one extra launch) or "copy_major"
    (each copy's block contiguous, the kernel before issue 31's step work; the faster one on a CPU,
    where a thread walks its own block through the cache); None (default): "copy_major" on cpu,
    else "copy_fastest". Both run the same operations in the same order: equal results
    (bit-identical on cpu; tests/test_block_newton.py).

    ``block_dim``: threads per CUDA block of the step launch (default 32, one warp: B = 1,000
    copies spread over 32 multiprocessors instead of Warp's 256 threads on 4; ``None``: Warp's
    default; no effect on results, every copy being its own thread). Assumed from the GPU's
    layout, not measured here: ``cases/benchmarks/bench_block_step.py --device cuda:0`` times 32
    ... 256."""

    def __init__(self, model, n_copies, n, device, dtype=wp.float64, layout=None, block_dim=32):
        import numpy as np
        if layout is None:
            layout = "copy_major" if wp.get_device(device).is_cpu else "copy_fastest"
        if layout not in LAYOUTS:
            raise ValueError(f"layout {layout!r}: one of {LAYOUTS}")
        self.model, self.B, self.n, self.device, self.dtype = model, int(n_copies), int(n), device, dtype
        self.layout = layout
        self.block_dim = None if block_dim is None else int(block_dim)
        self.kernel = kernel(dtype, layout)
        arr = lambda a, t: wp.array(np.ascontiguousarray(a), dtype=t, device=device)
        self.spring_k = arr(np.asarray(model.spring_k, float), dtype)
        self.free = arr(np.asarray(model.free, np.int32), wp.int32)
        self.rot = arr(np.asarray(model.rot, np.int32), wp.int32)
        self.stiffening = arr(np.asarray(model.stiffening, float), dtype)
        B = self.B
        z2 = lambda: wp.zeros((B, n), dtype=dtype, device=device)
        zi = lambda: wp.zeros(B, dtype=wp.int32, device=device)
        self.q, self.kin = z2(), z2()
        if layout == "copy_major":
            self.r, self.dq = z2(), z2()
            self.A = wp.zeros((B, n, n), dtype=dtype, device=device)
        else:
            self.r, self.dq = (wp.zeros((n, B), dtype=dtype, device=device) for _ in range(2))
            self.A = wp.zeros((n, n, B), dtype=dtype, device=device)
            self.Kt = wp.zeros((n, n, B), dtype=dtype, device=device)
        self.torque = wp.zeros(B, dtype=dtype, device=device)
        self.residual = wp.zeros(B, dtype=dtype, device=device)
        self.status, self.stage, self.iters, self.total = zi(), zi(), zi(), zi()
        self.active = wp.zeros(1, dtype=wp.int32, device=device)
        self._cmds = {}

    def load(self, **arrays):
        """Write host arrays (B, ...) into the named device arrays."""
        for k, v in arrays.items():
            getattr(self, k).assign(v)

    def read(self, *names):
        """Host copies of the named device arrays."""
        return tuple(getattr(self, k).numpy() for k in names)

    def _check_device(self, **arrays):
        """Refuse arrays on another device than the step's before a launch is recorded: a recorded cpu
        launch does not check, and would read a CUDA pointer (a segfault, not an error)."""
        want = wp.get_device(self.device)
        for name, a in arrays.items():
            if a.device != want:
                raise ValueError(f"BlockNewtonStep on {want}: array {name!r} is on {a.device}")

    def write_poses(self, reference, pose):
        """Absolute poses reference + q of every copy into ``pose`` ((B nb + 1, 3) device array)."""
        key = ("poses", reference.ptr, pose.ptr)
        hit = self._cmds.get(key)
        if hit is None:
            self._check_device(reference=reference, pose=pose)
            # the arrays are kept with the launch: their addresses stay theirs while it is cached
            hit = self._cmds[key] = (wp.launch(pose_kernel(self.dtype), dim=(self.B, self.n), device=self.device,
                                               inputs=[reference, self.q, self.n // 3], outputs=[pose],
                                               record_cmd=True), (reference, pose))
        hit[0].launch()

    def write_poses_gathered(self, reference, pose, index):
        """Poses of a set on extended bodies into ``pose`` ((N + 1, 3) device array) from the
        absolute row coordinates reference + q through ``index`` ((3 N,) int64 device array, -1:
        zero; :func:`gather_pose_kernel`)."""
        key = ("gather", reference.ptr, pose.ptr, index.ptr)
        hit = self._cmds.get(key)
        if hit is None:
            self._check_device(reference=reference, pose=pose, index=index)
            hit = self._cmds[key] = (wp.launch(gather_pose_kernel(self.dtype), dim=index.shape[0], device=self.device,
                                               inputs=[reference, self.q, index], outputs=[pose], record_cmd=True),
                                     (reference, pose, index))
        hit[0].launch()

    def step(self, Q, K):
        """One step of every active copy from the device sums Q (B, n), K (B, n, n) (a launch
        recorded per pair of arrays, replayed)."""
        key = ("step", Q.ptr, K.ptr)
        hit = self._cmds.get(key)
        if hit is None:
            self._check_device(Q=Q, K=K)
            m = self.model
            d = self.dtype
            pre, held = None, (Q, K)            # the arrays kept with the launches (their addresses)
            if self.layout == "copy_fastest":
                pre = wp.launch(transpose_kernel(d), dim=(self.n, self.n, self.B), device=self.device,
                                inputs=[K], outputs=[self.Kt], record_cmd=True)
                K = self.Kt
            cmd = wp.launch(
                self.kernel, dim=self.B, device=self.device,
                inputs=[self.spring_k, self.free, self.rot, int(m.out_index), self.stiffening, d(m.abs_tol),
                        int(m.max_iterations), d(m.max_step_translation), d(m.max_step_rotation),
                        d(m.bound_translation), d(m.bound_rotation), int(bool(m.homotopy)),
                        Q, K, self.kin, self.torque],
                outputs=[self.q, self.status, self.stage, self.iters, self.total, self.residual, self.r, self.A,
                         self.dq, self.active], record_cmd=True, block_dim=self.block_dim)
            hit = self._cmds[key] = (cmd, held, pre)
        if hit[2] is not None:
            hit[2].launch()
        self.active.zero_()
        hit[0].launch()


__all__ = ["ACTIVE", "BlockNewtonStep", "CONVERGED", "FAILED", "LAYOUTS", "WARM", "gather_pose_kernel", "kernel",
           "pose_kernel",
           "transpose_kernel"]
