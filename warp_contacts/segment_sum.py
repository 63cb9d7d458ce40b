"""Warp kernels: the merged contact element's force vector and tangent summed from the contact
rows on the device (Eq. (contact_mapping)), with deterministic segmented sums.

One thread per output entry sums its own list of sources (:func:`segment_sum_ref.segments`)
in a fixed order: no atomics, so the bits do not depend on scheduling and equal those of the
CSR product of :class:`rvtool.contact.assembly.RowScatter`. Per Newton evaluation of the
merged element every family's kernel writes its rows into its own buffers and one launch of
:func:`_scatter_kernel` per family sums them: the forces into the element vector (the first
family writes, the next ones add, in family order) and the tangents into the family's slot;
the Jacobian call launches :func:`_jacobian_kernel` once, which combines the slots with
Exudyn's factors. NumPy reference: :mod:`warp_contacts.segment_sum_ref`.
"""
import functools

import numpy as np
import warp as wp

from .segment_sum_ref import segments, weighted_segments


@functools.lru_cache(maxsize=None)
def _scatter_kernel(dtype):
    @wp.kernel(module="unique")
    def scatter_family(
            # Model:
            vec_start: wp.array(dtype=wp.int32), vec_src: wp.array(dtype=wp.int32),
            mat_start: wp.array(dtype=wp.int32), mat_src: wp.array(dtype=wp.int32),
            n: int, slot: int, accumulate: int, with_v: int,
            # Data in:
            q_in: wp.array2d(dtype=dtype), dqdq_in: wp.array3d(dtype=dtype), dqdv_in: wp.array3d(dtype=dtype),
            # Data out:
            q_out: wp.array(dtype=dtype), kq_out: wp.array2d(dtype=dtype), kv_out: wp.array2d(dtype=dtype)):
        e = wp.tid()
        k = q_in.shape[1]
        if e < n:
            s = dtype(0.0)
            for j in range(vec_start[e], vec_start[e + 1]):
                src = vec_src[j]
                s += q_in[src // k, src % k]
            if accumulate != 0:
                q_out[e] = q_out[e] + s
            else:
                q_out[e] = s
        sq = dtype(0.0)
        sv = dtype(0.0)
        kk = k * k
        for j in range(mat_start[e], mat_start[e + 1]):
            src = mat_src[j]
            i = src // kk
            r = src % kk
            sq += dqdq_in[i, r // k, r % k]
            if with_v != 0:
                sv += dqdv_in[i, r // k, r % k]
        kq_out[slot, e] = sq
        kv_out[slot, e] = sv
    return scatter_family


@functools.lru_cache(maxsize=None)
def _weighted_scatter_kernel(dtype):
    """:func:`_scatter_kernel` for a family whose row entries reach the element through a linear
    map (:func:`segment_sum_ref.weighted_segments`): every source times its weight."""
    @wp.kernel(module="unique")
    def scatter_weighted_family(
            # Model:
            vec_start: wp.array(dtype=wp.int32), vec_src: wp.array(dtype=wp.int32), vec_w: wp.array(dtype=dtype),
            mat_start: wp.array(dtype=wp.int32), mat_src: wp.array(dtype=wp.int32), mat_w: wp.array(dtype=dtype),
            n: int, slot: int, accumulate: int, with_v: int,
            # Data in:
            q_in: wp.array2d(dtype=dtype), dqdq_in: wp.array3d(dtype=dtype), dqdv_in: wp.array3d(dtype=dtype),
            # Data out:
            q_out: wp.array(dtype=dtype), kq_out: wp.array2d(dtype=dtype), kv_out: wp.array2d(dtype=dtype)):
        e = wp.tid()
        k = q_in.shape[1]
        if e < n:
            s = dtype(0.0)
            for j in range(vec_start[e], vec_start[e + 1]):
                src = vec_src[j]
                s += vec_w[j] * q_in[src // k, src % k]
            if accumulate != 0:
                q_out[e] = q_out[e] + s
            else:
                q_out[e] = s
        sq = dtype(0.0)
        sv = dtype(0.0)
        kk = k * k
        for j in range(mat_start[e], mat_start[e + 1]):
            src = mat_src[j]
            i = src // kk
            r = src % kk
            sq += mat_w[j] * dqdq_in[i, r // k, r % k]
            if with_v != 0:
                sv += mat_w[j] * dqdv_in[i, r // k, r % k]
        kq_out[slot, e] = sq
        kv_out[slot, e] = sv
    return scatter_weighted_family


@functools.lru_cache(maxsize=None)
def _jacobian_kernel(dtype):
    @wp.kernel(module="unique")
    def element_jacobian(
            # Model:
            used: wp.array(dtype=wp.int32),
            # Data in:
            kq_in: wp.array2d(dtype=dtype), kv_in: wp.array2d(dtype=dtype), factors: wp.array(dtype=dtype),
            # Data out:
            j_out: wp.array(dtype=dtype)):
        e = wp.tid()
        f_q = factors[0]
        f_v = factors[1]
        s = dtype(0.0)
        for f in range(kq_in.shape[0]):
            if used[f] != 0:
                if f_v == dtype(0.0):
                    s += f_q * kq_in[f, e]
                else:
                    s += f_q * kq_in[f, e] + f_v * kv_in[f, e]
        j_out[e] = -s
    return element_jacobian


class ElementSums:
    """Device-side sums of several contact families' rows into one element's vector and tangent.

    families: per family its row index (N_f, k_f) (element coordinate of each row entry, -1
    dropped) -- or the sparse maps (C, D) (n, N_f k_f) of forces and displacements through which its
    row entries reach the element (weighted sources, :func:`segment_sum_ref.weighted_segments`) --
    and its row buffers as Warp arrays (q (N_f, k_f), dqdq (N_f, k_f, k_f), dqdv
    (N_f, k_f, k_f) or None), the arrays its kernel writes in place at every launch;
    n: element coordinates. Scalar type and device are the row buffers' (one for all families).

    Per evaluation: :meth:`run` (or :meth:`add` once per family, in family order, ``first`` for the
    first one), then :meth:`vector`; per Jacobian call :meth:`jacobian`. Results are host arrays owned by
    this object (overwritten by the next call).
    """

    def __init__(self, families, n):
        q0 = families[0][1]
        if any(f[1].dtype != q0.dtype or f[1].device != q0.device for f in families):
            raise ValueError("the families' row buffers differ in scalar type or device")
        self.wdtype = q0.dtype
        self.ndtype = np.float64 if q0.dtype == wp.float64 else np.float32
        self.device = q0.device
        self.on_cpu = wp.get_device(self.device).is_cpu
        self.n = n = int(n)
        F = len(families)
        d, dt = self.device, self.wdtype
        # one host block [Q | K_q slots | K_v slots]: on the CPU the device arrays alias it, and
        # a single sum checks every result for NaN/inf
        self.block = np.zeros(n + 2 * F * n * n, self.ndtype)
        self.Q = self.block[:n]
        self.Kq = self.block[n:n + F * n * n].reshape(F, n * n)
        self.Kv = self.block[n + F * n * n:].reshape(F, n * n)
        self.J = np.zeros(n * n, self.ndtype)
        self.used = np.ones(F, np.int32)
        self._used_key = (True,) * F
        self._graphs = {}
        if self.on_cpu:
            wrap = lambda a, t=dt: wp.array(a, dtype=t, device=d, copy=False)
        else:
            wrap = lambda a, t=dt: wp.array(a, dtype=t, device=d)
        self._q, self._kq, self._kv, self._j = wrap(self.Q), wrap(self.Kq), wrap(self.Kv), wrap(self.J)
        self._used = wrap(self.used, wp.int32)
        dummy = wp.zeros((1, 1, 1), dtype=dt, device=d)
        self._cmds = []
        for f, (index, q, dqdq, dqdv) in enumerate(families):
            if isinstance(index, np.ndarray):
                scatter = _scatter_kernel(dt)
                maps = [wp.array(a, dtype=wp.int32, device=d) for a in segments(index, n)]
            else:       # sparse maps (C, D): weighted sources
                C, D = index
                if C.shape[0] != n or D.shape != C.shape:
                    raise ValueError(f"family {f}'s maps have shapes {C.shape}, {D.shape} for an element of {n} "
                                     "coordinates")
                scatter = _weighted_scatter_kernel(dt)
                vs, vsrc, vw, ms, msrc, mw = weighted_segments(C, q.shape[1], D)
                maps = [wp.array(vs, dtype=wp.int32, device=d), wp.array(vsrc, dtype=wp.int32, device=d),
                        wp.array(vw, dtype=dt, device=d), wp.array(ms, dtype=wp.int32, device=d),
                        wp.array(msrc, dtype=wp.int32, device=d), wp.array(mw, dtype=dt, device=d)]
            # one recorded launch per (accumulate, with_v): the argument list never changes
            cmds = {}
            for acc in (0, 1):
                for wv in ((0, 1) if dqdv is not None else (0,)):
                    cmds[acc, wv] = wp.launch(scatter, dim=n * n, device=d,
                                              inputs=maps + [n, f, acc, wv, q, dqdq, dqdv if wv else dummy],
                                              outputs=[self._q, self._kq, self._kv], record_cmd=True)
            self._cmds.append(cmds)
        # Exudyn's factors (f_ODE2, f_ODE2_t) as an input array, so that the Jacobian launch is
        # captured once and replayed (a scalar launch parameter would be repacked at every call)
        self.factors = np.zeros(2, self.ndtype)
        self._factors = wrap(self.factors)
        with wp.ScopedCapture(device=d) as cap:
            wp.launch(_jacobian_kernel(dt), dim=n * n, device=d, inputs=[self._used, self._kq, self._kv, self._factors],
                      outputs=[self._j])
        self._jac = cap.graph

    def run(self, launches):
        """Launch the staged families and sum their rows: ``launches`` lists (slot, launch, with_v)
        in family order, ``launch()`` the family kernel's recorded launch on its staged inputs.
        Every sequence runs as one captured graph (CPU: Warp's APIC replay in C++; GPU: a CUDA
        graph), captured at its first use: one Python call instead of two launches per family.
        The sequence is idempotent (pure kernels, the first sum writes), so a capture that also
        executes is harmless."""
        key = tuple(launches)      # slots, launch methods (bound: equal for one kernel) and with_v
        g = self._graphs.get(key)
        if g is None:
            with wp.ScopedCapture(device=self.device) as cap:
                self._sequence(launches)
            g = self._graphs[key] = cap.graph
        wp.capture_launch(g)

    def _sequence(self, launches):
        for j, (slot, launch, wv) in enumerate(launches):
            launch()
            self.add(slot, j == 0, wv)

    def add(self, f, first, with_v):
        """Sum family ``f``'s rows (its kernel has just written them): forces into the vector
        (``first``: written, else added), tangents into slot f (``with_v``: the velocity
        tangent too; else its slot is zero)."""
        self._cmds[f][0 if first else 1, 1 if with_v else 0].launch()

    def set_used(self, used):
        """Slots the Jacobian combines (a tuple of bool per family): the families summed in the
        current evaluation (a family evaluated the old way is added on the host)."""
        u = tuple(used)
        if u != self._used_key:
            self._used_key = u
            self.used[...] = u
            if not self.on_cpu:
                self._used.assign(self.used)

    def vector(self):
        """(Q (n,) float64, finite) of the families added in this evaluation; ``finite`` is False if
        a force or a tangent entry is NaN or inf."""
        if not self.on_cpu:
            self.block[:self.n] = self._q.numpy()
            self.Kq[...] = self._kq.numpy()
            self.Kv[...] = self._kv.numpy()
        # float32 sums (the explicit precision option) go back to Exudyn in double
        Q = self.Q if self.ndtype == np.float64 else self.Q.astype(np.float64)
        return Q, bool(np.isfinite(self.block.sum()))

    def slot_finite(self, f):
        """True if family f's tangent slot holds only finite entries (after :meth:`vector`)."""
        return bool(np.isfinite(self.Kq[f].sum() + self.Kv[f].sum()))

    def jacobian(self, f_q, f_v):
        """J = -(sum_f (f_q K_q,f + f_v K_v,f)) over the used slots, (n, n) host array."""
        self.factors[0] = f_q
        self.factors[1] = f_v
        if not self.on_cpu:
            self._factors.assign(self.factors)
        wp.capture_launch(self._jac)
        if not self.on_cpu:
            self.J[...] = self._j.numpy()
        J = self.J.reshape(self.n, self.n)
        return J if self.ndtype == np.float64 else J.astype(np.float64)
