"""Scatter per-contact generalized forces and tangent blocks into the
coordinates of a contact element (Eq. (contact_mapping)).

Each contact row couples m bodies with three coordinates each; the ground has
none, so its rows and columns are dropped. The index maps are computed once
per set as 0/1 sparse matrices; each assembly is then one CSR product, which
also sums the entries of rows that share a coordinate. One implementation
serves every family: :class:`BlockAssembler` (any m), :class:`PairAssembler`
(m = 2) and, for independent copies of a reducer, the per-copy blocks of
:class:`rvtool.solver.copy_evaluator.CopyBlockAssembler`.
"""
import numpy as np
import scipy.sparse as sp


class RowScatter:
    """Sum per-row entries into a flat target of ``size`` entries.

    index: (N, k) target position of every entry of the (N, k) values, or -1 to drop it.
    Calling with values of N x k entries returns the (size,) sums (a CSR product: measured
    as fast as ``np.bincount`` for ~100 rows and 2.7x faster for ~3,000).

    The sparse matrix is built on the first call: a set that is only copied (the replica and
    device row paths sum its rows per copy instead) never pays for it, and for a set over B
    copies of a reducer its (3 B nb)^2-row tangent map grows with B^2 (RV-40E, 512 copies:
    16 s of the 34 s it took to copy the families on the development machine).
    """

    def __init__(self, index, size):
        self._index = np.asarray(index, np.int64).reshape(-1)
        self.size = int(size)
        self._S = None

    def __call__(self, values):
        if self._S is None:
            index = self._index
            keep = np.flatnonzero(index >= 0)
            self._S = sp.csr_matrix((np.ones(len(keep)), (index[keep], keep)), shape=(self.size, index.size))
        return self._S @ np.asarray(values, np.float64).reshape(-1)


def coordinate_index(bodies, n_bodies):
    """(N, 3m) coordinate indices 3 b + (0, 1, 2) of each row's m bodies; -1 for the ground
    (any body index >= n_bodies)."""
    bodies = np.asarray(bodies, np.int64)
    gidx = (3 * bodies[:, :, None] + np.arange(3)).reshape(len(bodies), -1)
    return np.where(np.repeat(bodies >= n_bodies, 3, axis=1), -1, gidx)


def pair_index(gidx, n):
    """(N, k, k) flat index row * n + col of every tangent entry; -1 where either is dropped."""
    rows = np.repeat(gidx[:, :, None], gidx.shape[1], axis=2)
    cols = np.repeat(gidx[:, None, :], gidx.shape[1], axis=1)
    return np.where((rows >= 0) & (cols >= 0), rows * n + cols, -1)


class BlockAssembler:
    """Assemble per-row forces Q (N, 3m) and tangents K (N, 3m, 3m) of rows coupling m bodies
    (``bodies`` (N, m)) into n = 3 n_bodies coordinates; ground rows and columns are dropped."""

    def __init__(self, bodies, n_bodies):
        self.n = n = 3 * n_bodies
        #: (N, m) body indices of each row (n_bodies or more: the ground), e.g. to copy the rows
        self.bodies = np.asarray(bodies, np.int64)
        gidx = coordinate_index(bodies, n_bodies)
        self.index = gidx     # element coordinate of every row entry (-1 dropped): device-side sums
        self._vec = RowScatter(gidx, n)
        # the tangent map (N k^2 pair indices) is made on the first matrix(): a set that is only
        # copied onto the device (its rows summed per copy there) never needs it
        self._mat = None

    def vector(self, Q):
        return self._vec(Q)

    def matrix(self, K):
        if self._mat is None:
            self._mat = RowScatter(pair_index(self.index, self.n), self.n * self.n)
        return self._mat(K).reshape(self.n, self.n)


class PairAssembler(BlockAssembler):
    """:class:`BlockAssembler` of two-body rows: (N, 6) forces and (N, 6, 6) blocks."""

    def __init__(self, body_a, body_b, n_bodies):
        super().__init__(np.column_stack([np.asarray(body_a), np.asarray(body_b)]), n_bodies)
