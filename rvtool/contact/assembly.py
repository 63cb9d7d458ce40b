"""Scatter per-contact generalized forces and tangent blocks into the
coordinates of a contact element (Eq. (contact_mapping)).

Each contact couples two bodies with three coordinates each; the ground has
none, so its rows and columns are dropped. The index maps are computed once
per set; each assembly is then two ``np.bincount`` reductions.
"""
import numpy as np


class PairAssembler:
    """Assemble (N, 6) forces and (N, 6, 6) blocks into n = 3 n_bodies coordinates."""

    def __init__(self, body_a, body_b, n_bodies):
        body_a = np.asarray(body_a)
        body_b = np.asarray(body_b)
        self.n = n = 3 * n_bodies
        gidx = np.concatenate([3 * body_a[:, None] + np.arange(3), 3 * body_b[:, None] + np.arange(3)], axis=1)
        ground = np.concatenate([np.repeat((body_a >= n_bodies)[:, None], 3, 1),
                                 np.repeat((body_b >= n_bodies)[:, None], 3, 1)], axis=1)
        gidx = np.where(ground, -1, gidx)
        self.vec_mask = gidx >= 0
        self.vec_idx = gidx[self.vec_mask]
        rows = np.repeat(gidx[:, :, None], 6, axis=2)
        cols = np.repeat(gidx[:, None, :], 6, axis=1)
        self.mat_mask = (rows >= 0) & (cols >= 0)
        self.mat_idx = (rows * n + cols)[self.mat_mask]

    def vector(self, Qc):
        return np.bincount(self.vec_idx, weights=Qc[self.vec_mask], minlength=self.n)

    def matrix(self, Kc):
        return np.bincount(self.mat_idx, weights=Kc[self.mat_mask], minlength=self.n * self.n).reshape(self.n, self.n)
