"""Warp kernels: one copy's force vector and tangents summed from several families' row buffers
by gathering (no atomics: the sums are deterministic, the same on every device).

The row stepper (:mod:`rvtool.solver.row_dynamics`) needs f (n,), K = df/dq and C = df/dv
(n, n) of one reducer copy at every Newton iteration; its families write their rows into their
own buffers (Q (R, k), dQ/dq and dQ/dv (R, k, k)). Each output is a fixed sum of row entries:
f_e of slot s (a family) sums ``Q_s[idx_s[j]]`` for j in ``ptr_s[e] .. ptr_s[e + 1]``, and the
tangent entry (i, j) sums ``dQdq_s`` (K) and ``dQdv_s`` (C) over the list of output n + i n + j
(both tangents have the same rows); the row buffers are read flattened. One thread per output
entry (f) or per reached tangent entry (K and C together; an entry no family's rows reach stays 0)
walks every slot's list, in row order. Up to
``MAX_SLOTS`` families (one launch for all); unused slots have empty lists. f and the tangents
are two launches, so that a caller gathers the tangents only where it needs them (a Newton
iterate that has converged does not). The lists are :mod:`warp_contacts.segment_sum_ref`'s
(the merged Exudyn element's sums, :class:`warp_contacts.segment_sum.ElementSums`, which launches
per family and keeps each family's tangents in a slot for Exudyn's Jacobian factors; the row
stepper needs K and C apart, all families in one launch, tangents on demand). NumPy reference:
:func:`gather_ref` (:func:`warp_contacts.segment_sum_ref.family_sums` per family; and the host
``np.bincount`` sums of :class:`rvtool.solver.row_dynamics.RowDrivenModel`).
"""
import functools

import numpy as np
import warp as wp

from .segment_sum_ref import family_sums, segments

MAX_SLOTS = 8


@functools.lru_cache(maxsize=None)
def _kernels(dtype):
    """(gather_forces, gather_tangents) for ``dtype``."""

    @wp.func
    def slot_forces(e: int, ptr: wp.array(dtype=wp.int32), idx: wp.array(dtype=wp.int32), q: wp.array(dtype=dtype)):
        acc = dtype(0.0)
        for j in range(ptr[e], ptr[e + 1]):
            acc += q[idx[j]]
        return acc

    @wp.func
    def slot_tangents(e: int, ptr: wp.array(dtype=wp.int32), idx: wp.array(dtype=wp.int32),
                      dq: wp.array(dtype=dtype), dv: wp.array(dtype=dtype)):
        # dQ/dv has the rows of dQ/dq where the family has one (else a one-entry placeholder)
        k = dtype(0.0)
        c = dtype(0.0)
        if dv.shape[0] == dq.shape[0]:
            for j in range(ptr[e], ptr[e + 1]):
                i = idx[j]
                k += dq[i]
                c += dv[i]
        else:
            for j in range(ptr[e], ptr[e + 1]):
                k += dq[idx[j]]
        return k, c

    @wp.kernel(module="unique")
    def gather_forces(
        # Model:
        p0: wp.array(dtype=wp.int32), i0: wp.array(dtype=wp.int32),
        p1: wp.array(dtype=wp.int32), i1: wp.array(dtype=wp.int32),
        p2: wp.array(dtype=wp.int32), i2: wp.array(dtype=wp.int32),
        p3: wp.array(dtype=wp.int32), i3: wp.array(dtype=wp.int32),
        p4: wp.array(dtype=wp.int32), i4: wp.array(dtype=wp.int32),
        p5: wp.array(dtype=wp.int32), i5: wp.array(dtype=wp.int32),
        p6: wp.array(dtype=wp.int32), i6: wp.array(dtype=wp.int32),
        p7: wp.array(dtype=wp.int32), i7: wp.array(dtype=wp.int32),
        # Data in:
        q0: wp.array(dtype=dtype),
        q1: wp.array(dtype=dtype),
        q2: wp.array(dtype=dtype),
        q3: wp.array(dtype=dtype),
        q4: wp.array(dtype=dtype),
        q5: wp.array(dtype=dtype),
        q6: wp.array(dtype=dtype),
        q7: wp.array(dtype=dtype),
        # Data out:
        out: wp.array(dtype=dtype),
    ):
        e = wp.tid()
        acc = slot_forces(e, p0, i0, q0)
        acc += slot_forces(e, p1, i1, q1)
        acc += slot_forces(e, p2, i2, q2)
        acc += slot_forces(e, p3, i3, q3)
        acc += slot_forces(e, p4, i4, q4)
        acc += slot_forces(e, p5, i5, q5)
        acc += slot_forces(e, p6, i6, q6)
        acc += slot_forces(e, p7, i7, q7)
        out[e] = acc

    @wp.kernel(module="unique")
    def gather_tangents(
        # Model:
        p0: wp.array(dtype=wp.int32), i0: wp.array(dtype=wp.int32),
        p1: wp.array(dtype=wp.int32), i1: wp.array(dtype=wp.int32),
        p2: wp.array(dtype=wp.int32), i2: wp.array(dtype=wp.int32),
        p3: wp.array(dtype=wp.int32), i3: wp.array(dtype=wp.int32),
        p4: wp.array(dtype=wp.int32), i4: wp.array(dtype=wp.int32),
        p5: wp.array(dtype=wp.int32), i5: wp.array(dtype=wp.int32),
        p6: wp.array(dtype=wp.int32), i6: wp.array(dtype=wp.int32),
        p7: wp.array(dtype=wp.int32), i7: wp.array(dtype=wp.int32),
        n: int,
        entries: wp.array(dtype=wp.int32),
        # Data in:
        k0: wp.array(dtype=dtype), v0: wp.array(dtype=dtype),
        k1: wp.array(dtype=dtype), v1: wp.array(dtype=dtype),
        k2: wp.array(dtype=dtype), v2: wp.array(dtype=dtype),
        k3: wp.array(dtype=dtype), v3: wp.array(dtype=dtype),
        k4: wp.array(dtype=dtype), v4: wp.array(dtype=dtype),
        k5: wp.array(dtype=dtype), v5: wp.array(dtype=dtype),
        k6: wp.array(dtype=dtype), v6: wp.array(dtype=dtype),
        k7: wp.array(dtype=dtype), v7: wp.array(dtype=dtype),
        # Data out:
        out: wp.array(dtype=dtype),
    ):
        e = entries[wp.tid()]                      # a K entry (row-major) that some family's rows reach
        m = n + e                                  # its list
        K = dtype(0.0)
        C = dtype(0.0)
        k, c = slot_tangents(m, p0, i0, k0, v0)
        K += k
        C += c
        k, c = slot_tangents(m, p1, i1, k1, v1)
        K += k
        C += c
        k, c = slot_tangents(m, p2, i2, k2, v2)
        K += k
        C += c
        k, c = slot_tangents(m, p3, i3, k3, v3)
        K += k
        C += c
        k, c = slot_tangents(m, p4, i4, k4, v4)
        K += k
        C += c
        k, c = slot_tangents(m, p5, i5, k5, v5)
        K += k
        C += c
        k, c = slot_tangents(m, p6, i6, k6, v6)
        K += k
        C += c
        k, c = slot_tangents(m, p7, i7, k7, v7)
        K += k
        C += c
        out[n + e] = K
        out[n + n * n + e] = C

    return gather_forces, gather_tangents


def gather_lists(local, n):
    """(ptr (n + n^2 + 1,), idx) of one family: ``local`` (R, k) the copy's coordinate of each row
    entry (-1: the ground). Output e < n (f) sums the flattened Q rows at idx[ptr[e]:ptr[e + 1]],
    output n + i n + j (K, and C with the same list) the flattened dQ/dq (dQ/dv) rows: the lists
    of :func:`warp_contacts.segment_sum_ref.segments` (ascending source order) joined."""
    vec_start, vec_src, mat_start, mat_src = segments(local, n)
    ptr = np.concatenate([vec_start, vec_start[-1] + mat_start[1:]]).astype(np.int32)
    return ptr, np.concatenate([vec_src, mat_src]).astype(np.int32)


def gather_ref(locals_, data, n):
    """NumPy reference: (f (n,), K (n, n), C (n, n)) of the families' rows ``data`` [(Q (R, k),
    dQ/dq, dQ/dv or None)] at their coordinates ``locals_`` [(R, k)], each family summed by
    :func:`warp_contacts.segment_sum_ref.family_sums` and the families added in order."""
    f, K, C = np.zeros(n), np.zeros((n, n)), np.zeros((n, n))
    for loc, (q, dq, dv) in zip(locals_, data):
        fq, Kq, Kv = family_sums(q, dq, dv, loc, n)
        f += fq
        K += Kq
        C += Kv
    return f, K, C


class RowGather:
    """The gather launch for up to MAX_SLOTS families on ``device``: ``lists`` [(ptr, idx)] from
    :func:`gather_lists`, ``buffers`` [(Q, dQ/dq, dQ/dv or None)] the families' Warp row arrays
    (contiguous; read in place at every :meth:`launch`), n coordinates. :attr:`out` (n + 2 n^2,)
    holds f, K (row-major), C after :meth:`launch` (f alone after :meth:`launch_forces`)."""

    def __init__(self, lists, buffers, n, dtype, device):
        if len(lists) > MAX_SLOTS:
            raise ValueError(f"{len(lists)} families; the gather launch takes at most {MAX_SLOTS}")
        empty_ptr = wp.zeros(n + n * n + 1, dtype=wp.int32, device=device)
        dummy = wp.zeros(1, dtype=dtype, device=device)
        dummy_i = wp.zeros(1, dtype=wp.int32, device=device)
        model, qs, kv = [], [], []
        for s in range(MAX_SLOTS):
            if s < len(lists):
                ptr, idx = lists[s]
                q, dq, dv = buffers[s]
                model += [wp.array(ptr, dtype=wp.int32, device=device),
                          wp.array(idx if len(idx) else np.zeros(1, np.int32), dtype=wp.int32, device=device)]
                qs.append(q.flatten())
                kv += [dq.flatten(), dummy if dv is None else dv.flatten()]
            else:
                model += [empty_ptr, dummy_i]
                qs.append(dummy)
                kv += [dummy, dummy]
        # the tangent entries some family's rows reach (the others stay 0): one thread each, not n^2 (the
        # extended models' tangents are sparse: rv80e 119^2 entries, RD-40's elastic pins 204^2)
        reach = np.zeros(n * n, bool)
        for ptr, _ in lists:
            reach |= np.diff(np.asarray(ptr, np.int64)[n:n + n * n + 1]) > 0
        self.entries = wp.array(np.flatnonzero(reach).astype(np.int32) if reach.any() else np.zeros(1, np.int32),
                                dtype=wp.int32, device=device)
        self._args = (model, qs, kv)                      # the launches read these arrays in place
        self.out = wp.zeros(n + 2 * n * n, dtype=dtype, device=device)
        forces, tangents = _kernels(dtype)
        self._forces_cmd = wp.launch(forces, dim=n, inputs=model + qs, outputs=[self.out], device=device,
                                     record_cmd=True)
        self._tangents_cmd = wp.launch(tangents, dim=int(reach.sum()) if reach.any() else 1,
                                       inputs=model + [n, self.entries] + kv, outputs=[self.out], device=device,
                                       record_cmd=True)
        self.n = n

    def launch_forces(self):
        """Recompute f (:attr:`out`'s first n entries) from the row buffers as they are."""
        self._forces_cmd.launch()

    def launch_tangents(self):
        """Recompute K and C (:attr:`out`'s entries n ..) from the row buffers as they are."""
        self._tangents_cmd.launch()

    def launch(self):
        """Recompute all of :attr:`out` (f, K, C)."""
        self.launch_forces()
        self.launch_tangents()
        return self.out


__all__ = ["MAX_SLOTS", "RowGather", "gather_lists", "gather_ref"]
