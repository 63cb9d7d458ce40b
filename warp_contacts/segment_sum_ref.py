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

Weighted families: a family whose row entries reach the element through linear maps rather
than one coordinate each (the width slices of tilting bodies, :class:`rvtool.contact.skew.SkewSlices`:
a slice's row entry on a body's x or y is moved by that coordinate and by the body's tilt times the
slice's arm, and its force counts with the slice's width fraction w_s) gives the force map C and the
displacement map D as sparse matrices (n, N k): Q = C vec(q) and K = sum_i C_i K_i D_i^T over the
rows i (C_i, D_i the row's k columns). :func:`weighted_segments` lists the sources
of every output entry with their weights (the products of two entries of C for the tangent), in
ascending source order as above.

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


def weighted_segments(C, k, D=None):
    """CSR lists of the weighted sources of the vector (n) and tangent (n * n) entries of a family
    whose row entries reach the element through the sparse maps C (n, N k) (forces, Q = C vec(q)) and
    D (n, N k) (displacements, default C): K = sum_i C_i K_i D_i^T (module docstring).

    Returns (vec_start, vec_src, vec_w, mat_start, mat_src, mat_w): sources as in :func:`segments`
    (int32, ascending per entry), weights float64. A 0/1 map with one entry per column gives the
    lists of :func:`segments` with unit weights."""
    def entries(M):
        M = M.tocoo()
        e, col, v = M.row.astype(np.int64), M.col.astype(np.int64), M.data.astype(np.float64)
        keep = v != 0.0
        e, col, v = e[keep], col[keep], v[keep]
        order = np.argsort(col // k, kind="stable")
        return e[order], col[order], v[order], col[order] // k
    n = C.shape[0]
    e, col, v, r = entries(C)
    vec_start, vec_src, vec_w = _csr(e, col, n, v)
    # the tangent: every pair (C entry a, D entry b) on the same row i: target (e_a, e_b), source (i k + a) k + b
    eD, colD, vD, rD = (e, col, v, r) if D is None else entries(D)
    first = np.searchsorted(rD, r, side="left")
    cnt = np.searchsorted(rD, r, side="right") - first
    a = np.repeat(np.arange(len(r)), cnt)
    b = first[a] + np.arange(len(a)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    target = e[a] * n + eD[b]
    source = col[a] * k + colD[b] % k
    mat_start, mat_src, mat_w = _csr(target, source, n * n, v[a] * vD[b])
    return vec_start, vec_src, vec_w, mat_start, mat_src, mat_w


def _csr(target, source, size, weights=None):
    """(start, src) grouping ``source`` positions by ``target`` entry, sources ascending; with
    ``weights`` (one per source) their weights in the same order as a third result."""
    order = np.lexsort((source, target))
    start = np.zeros(size + 1, np.int64)
    np.add.at(start, target + 1, 1)
    out = np.cumsum(start).astype(np.int32), source[order].astype(np.int32)
    return out if weights is None else out + (np.asarray(weights, np.float64)[order],)


def segment_sum(values, start, src, weights=None):
    """out[e] = sum of values.flat[src[start[e]:start[e+1]]] (each times its weight, if given),
    summed from 0.0 in list order."""
    v = np.asarray(values, np.float64).reshape(-1)
    out = np.zeros(len(start) - 1)
    for e in range(len(out)):
        s = 0.0
        for j in range(start[e], start[e + 1]):
            s += v[src[j]] if weights is None else weights[j] * v[src[j]]
        out[e] = s
    return out


def family_sums(q, dqdq, dqdv, index, n):
    """(Q (n,), K_q (n, n), K_v (n, n)) of one family; dqdv None gives K_v = 0."""
    vs, vsrc, ms, msrc = segments(index, n)
    Kv = np.zeros((n, n)) if dqdv is None else segment_sum(dqdv, ms, msrc).reshape(n, n)
    return segment_sum(q, vs, vsrc), segment_sum(dqdq, ms, msrc).reshape(n, n), Kv


def weighted_family_sums(q, dqdq, dqdv, C, D=None):
    """:func:`family_sums` of a family whose rows reach the element through the sparse maps C and D
    (n, N k) (:func:`weighted_segments`)."""
    k = np.shape(q)[1]
    n = C.shape[0]
    vs, vsrc, vw, ms, msrc, mw = weighted_segments(C, k, D)
    Kv = np.zeros((n, n)) if dqdv is None else segment_sum(dqdv, ms, msrc, mw).reshape(n, n)
    return segment_sum(q, vs, vsrc, vw), segment_sum(dqdq, ms, msrc, mw).reshape(n, n), Kv


def element_jacobian(Kq, Kv, f_q, f_v):
    """J = -(sum_f (f_q K_q,f + f_v K_v,f)) over the slots (F, n, n), summed in slot order
    (f_v = 0: the K_v terms are left out, as the per-family tangent does)."""
    J = np.zeros(np.shape(Kq)[1:])
    for f in range(len(Kq)):
        J += f_q * Kq[f] if f_v == 0 else f_q * Kq[f] + f_v * Kv[f]
    return -J
