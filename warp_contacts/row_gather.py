"""Warp kernel: one copy's force vector and tangents summed from several families' row buffers
in ONE launch, by gathering (no atomics: the sums are deterministic, the same on every device).

The row stepper (:mod:`rvtool.solver.row_dynamics`) needs f (n,), K = df/dq and C = df/dv
(n, n) of one reducer copy at every Newton iteration; its families write their rows into their
own buffers (Q (R, k), dQ/dq and dQ/dv (R, k, k)). Each of the n + 2 n^2 outputs is a fixed sum
of row entries: output e of slot s (a family) sums ``data_s[idx_s[j]]`` for j in
``ptr_s[e] .. ptr_s[e + 1]``, where data_s is the slot's virtual concatenation
[Q | dQ/dq | dQ/dv] (flattened). One thread per output entry walks every slot's list, in the
order the lists were built (row order). Up to ``MAX_SLOTS`` families; unused slots have empty
lists. NumPy reference: :func:`gather_ref` (and the host ``np.bincount`` sums of
:class:`rvtool.solver.row_dynamics.RowDrivenModel`).
"""
import functools

import numpy as np
import warp as wp

MAX_SLOTS = 8


@functools.lru_cache(maxsize=None)
def _kernel(dtype):
    @wp.func
    def slot_sum(e: int, ptr: wp.array(dtype=wp.int32), idx: wp.array(dtype=wp.int32), q: wp.array(dtype=dtype),
                 dq: wp.array(dtype=dtype), dv: wp.array(dtype=dtype)):
        nq = q.shape[0]
        nk = dq.shape[0]
        acc = dtype(0.0)
        for j in range(ptr[e], ptr[e + 1]):
            i = idx[j]
            if i < nq:
                acc += q[i]
            elif i < nq + nk:
                acc += dq[i - nq]
            else:
                acc += dv[i - nq - nk]
        return acc

    @wp.kernel(module="unique")
    def gather_rows(
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
        q0: wp.array(dtype=dtype), k0: wp.array(dtype=dtype), v0: wp.array(dtype=dtype),
        q1: wp.array(dtype=dtype), k1: wp.array(dtype=dtype), v1: wp.array(dtype=dtype),
        q2: wp.array(dtype=dtype), k2: wp.array(dtype=dtype), v2: wp.array(dtype=dtype),
        q3: wp.array(dtype=dtype), k3: wp.array(dtype=dtype), v3: wp.array(dtype=dtype),
        q4: wp.array(dtype=dtype), k4: wp.array(dtype=dtype), v4: wp.array(dtype=dtype),
        q5: wp.array(dtype=dtype), k5: wp.array(dtype=dtype), v5: wp.array(dtype=dtype),
        q6: wp.array(dtype=dtype), k6: wp.array(dtype=dtype), v6: wp.array(dtype=dtype),
        q7: wp.array(dtype=dtype), k7: wp.array(dtype=dtype), v7: wp.array(dtype=dtype),
        # Data out:
        out: wp.array(dtype=dtype),
    ):
        e = wp.tid()
        acc = slot_sum(e, p0, i0, q0, k0, v0)
        acc += slot_sum(e, p1, i1, q1, k1, v1)
        acc += slot_sum(e, p2, i2, q2, k2, v2)
        acc += slot_sum(e, p3, i3, q3, k3, v3)
        acc += slot_sum(e, p4, i4, q4, k4, v4)
        acc += slot_sum(e, p5, i5, q5, k5, v5)
        acc += slot_sum(e, p6, i6, q6, k6, v6)
        acc += slot_sum(e, p7, i7, q7, k7, v7)
        out[e] = acc

    return gather_rows


def gather_lists(local, n, rows, k, has_velocity):
    """(ptr (n + 2 n^2 + 1,), idx) of one family: ``local`` (R, k) the copy's coordinate of each
    row entry (-1: ground), n coordinates, R rows of k entries; outputs f (n), K (n^2), C (n^2)
    read the flattened [Q | dQ/dq | dQ/dv] (dQ/dv only where ``has_velocity``), row order."""
    loc = np.asarray(local, np.int64).reshape(rows, k)
    nq, nk = rows * k, rows * k * k
    src = [np.arange(nq)]
    dst = [loc.reshape(-1)]
    pair = (loc[:, :, None] * n + loc[:, None, :]).reshape(-1)
    pair_ok = ((loc[:, :, None] >= 0) & (loc[:, None, :] >= 0)).reshape(-1)
    pair = np.where(pair_ok, pair, -1)
    src.append(nq + np.arange(nk))
    dst.append(np.where(pair >= 0, n + pair, -1))
    if has_velocity:
        src.append(nq + nk + np.arange(nk))
        dst.append(np.where(pair >= 0, n + n * n + pair, -1))
    src, dst = np.concatenate(src), np.concatenate(dst)
    keep = dst >= 0
    src, dst = src[keep], dst[keep]
    order = np.argsort(dst, kind="stable")                # per output: row order
    ptr = np.zeros(n + 2 * n * n + 1, np.int64)
    np.add.at(ptr, dst + 1, 1)
    return np.cumsum(ptr).astype(np.int32), src[order].astype(np.int32)


def gather_ref(lists, data, size):
    """NumPy reference: out (size,) from per-family (ptr, idx) and flattened [Q | dQ/dq | dQ/dv]."""
    out = np.zeros(size)
    for (ptr, idx), d in zip(lists, data):
        counts = np.diff(ptr)
        out += np.bincount(np.repeat(np.arange(size), counts), d[idx], minlength=size)
    return out


class RowGather:
    """The gather launch for up to MAX_SLOTS families on ``device``: ``lists`` [(ptr, idx)] from
    :func:`gather_lists`, ``buffers`` [(Q, dQ/dq, dQ/dv or None)] the families' Warp row arrays
    (contiguous; read in place at every :meth:`launch`), n coordinates. :attr:`out` (n + 2 n^2,)
    holds f, K (row-major), C after :meth:`launch`."""

    def __init__(self, lists, buffers, n, dtype, device):
        if len(lists) > MAX_SLOTS:
            raise ValueError(f"{len(lists)} families; the gather launch takes at most {MAX_SLOTS}")
        size = n + 2 * n * n
        empty_ptr = wp.zeros(size + 1, dtype=wp.int32, device=device)
        dummy = wp.zeros(1, dtype=dtype, device=device)
        dummy_i = wp.zeros(1, dtype=wp.int32, device=device)
        model, data = [], []
        self._keep = []
        for s in range(MAX_SLOTS):
            if s < len(lists):
                ptr, idx = lists[s]
                p = wp.array(ptr, dtype=wp.int32, device=device)
                i = wp.array(idx if len(idx) else np.zeros(1, np.int32), dtype=wp.int32, device=device)
                q, dq, dv = buffers[s]
                flat = [q.flatten(), dq.flatten(), dummy if dv is None else dv.flatten()]
                self._keep += [p, i] + flat
                model += [p, i]
                data += flat
            else:
                model += [empty_ptr, dummy_i]
                data += [dummy, dummy, dummy]
        self.out = wp.zeros(size, dtype=dtype, device=device)
        self._cmd = wp.launch(_kernel(dtype), dim=size, inputs=model + data, outputs=[self.out], device=device,
                              record_cmd=True)
        self.n = n

    def launch(self):
        """Recompute :attr:`out` from the row buffers as they are."""
        self._cmd.launch()
        return self.out


__all__ = ["MAX_SLOTS", "RowGather", "gather_lists", "gather_ref"]
