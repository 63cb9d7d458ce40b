"""NumPy reference of :mod:`warp_contacts.linear_rows`: the rows of constant linear blocks.

Row r carries a block K_r (m, m) [N/m, N m/rad] over m coordinates whose values x_r (m,) are read
from a pose array (the row's m / 3 pseudo-bodies, padded with zeros); its generalized forces are
Q_r = -K_r x_r and its tangent dQ_r/dx_r = -K_r (a constant: written once). The device row Newton's
elastic closures and port structures (:mod:`rvtool.solver.row_extension`).
"""
import numpy as np


def linear_rows(K, x):
    """Q (N, m) = -K x for blocks K (N, m, m) and values x (N, m)."""
    return -np.einsum("rij,rj->ri", np.asarray(K, float), np.asarray(x, float))


__all__ = ["linear_rows"]
