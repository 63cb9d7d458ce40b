"""NumPy reference of the merged contact element's row sums (Eq. (contact_mapping)).

A contact family evaluates N rows, each coupling m bodies: per-row forces q (N, k) and
tangent blocks dQ/dq, dQ/dv (N, k, k), k = 3 m. ``index`` (N, k) gives the element
coordinate of every row entry (-1: the ground, dropped), as built by
:func:`rvtool.contact.assembly.coordinate_index`. The element's vector entry c is the sum
of every q[i, a] with index[i, a] = c, and its tangent entry (c, d) the sum of every
K[i, a, b] with (index[i, a], index[i, b]) = (c, d).

Segmented sums: the sources of every output entry are listed once (:func:`segments`, CSR
layout: ``start`` (n_out + 1,) and ``src`` (flat source positions)), in ascending flat
source order, and each output entry is summed over its own list from 0.0 in that order.
Nothing depends on thread scheduling (no atomics), and the order is the one of the CSR
product of :class:`rvtool.contact.assembly.RowScatter` (rows summed in ascending column
order), so both give the same bits.

Per-family slots: the element sums several families. Their forces are summed in family
order into one vector; their tangents are kept per family ("slots") and combined when the
Jacobian is asked for, J = -(sum_f (f_q K_q,f + f_v K_v,f)) in family order (Exudyn's
convention for ``ObjectGenericODE2``, J_user = -(f_ODE2 dQ/dq + f_ODE2_t dQ/dq_t)).
"""
import numpy as np


def segments(index, n):
    """CSR lists of the sources of the vector (n) and tangent (n * n) entries.

    index: (N, k) element coordinate of each row entry or -1. Returns
    (vec_start (n + 1,), vec_src, mat_start (n n + 1,), mat_src), int32; vec_src holds
    flat positions i k + a into q (N, k), mat_src flat positions (i k + a) k + b into K
    (N, k, k), each list in ascending order."""
    index = np.asarray(index, np.int64)
    N, k = index.shape
    flat = index.reshape(-1)
    keep = np.flatnonzero(flat >= 0)
    vec_start, vec_src = _csr(flat[keep], keep, n)
    rows = np.repeat(index[:, :, None], k, axis=2)
    cols = np.repeat(index[:, None, :], k, axis=1)
    pair = np.where((rows >= 0) & (cols >= 0), rows * n + cols, -1).reshape(-1)
    keep = np.flatnonzero(pair >= 0)
    mat_start, mat_src = _csr(pair[keep], keep, n * n)
    return vec_start, vec_src, mat_start, mat_src


def _csr(target, source, size):
    """(start, src) grouping ``source`` positions by ``target`` entry, sources ascending."""
    order = np.lexsort((source, target))
    start = np.zeros(size + 1, np.int64)
    np.add.at(start, target + 1, 1)
    return np.cumsum(start).astype(np.int32), source[order].astype(np.int32)


def segment_sum(values, start, src):
    """out[e] = sum of values.flat[src[start[e]:start[e+1]]], summed from 0.0 in list order."""
    v = np.asarray(values, np.float64).reshape(-1)
    out = np.zeros(len(start) - 1)
    for e in range(len(out)):
        s = 0.0
        for j in range(start[e], start[e + 1]):
            s += v[src[j]]
        out[e] = s
    return out


def family_sums(q, dqdq, dqdv, index, n):
    """(Q (n,), K_q (n, n), K_v (n, n)) of one family; dqdv None gives K_v = 0."""
    vs, vsrc, ms, msrc = segments(index, n)
    Kv = np.zeros((n, n)) if dqdv is None else segment_sum(dqdv, ms, msrc).reshape(n, n)
    return segment_sum(q, vs, vsrc), segment_sum(dqdq, ms, msrc).reshape(n, n), Kv


def element_jacobian(Kq, Kv, f_q, f_v):
    """J = -(sum_f (f_q K_q,f + f_v K_v,f)) over the slots (F, n, n), summed in slot order
    (f_v = 0: the K_v terms are left out, as the per-family tangent does)."""
    J = np.zeros(np.shape(Kq)[1:])
    for f in range(len(Kq)):
        J += f_q * Kq[f] if f_v == 0 else f_q * Kq[f] + f_v * Kv[f]
    return -J
