"""NumPy reference for :mod:`warp_contacts.circle_geometry` (double precision)."""
import numpy as np


def circle_gap(ca, cb, ra, rb, internal):
    """Signed gap g, unit direction n (A->B) and centre distance L, vectorized.

    External: g = |c_B - c_A| - r_A - r_B; internal: g = R_B - r_A - |c_B - c_A|.
    """
    ca = np.asarray(ca, float)
    cb = np.asarray(cb, float)
    d = cb - ca
    L = np.linalg.norm(d, axis=-1)
    safe = np.where(L > 0.0, L, 1.0)
    n = np.where((L > 0.0)[..., None], d / safe[..., None], np.array([1.0, 0.0]))
    internal = np.asarray(internal).astype(bool)
    g = np.where(internal, rb - ra - L, L - ra - rb)
    return g, n, L


def circle_force_on_a(fn, n, internal):
    """Force on circle A: -fn n (external, away from B) or +fn n (internal, toward B's centre)."""
    s = np.where(np.asarray(internal).astype(bool), 1.0, -1.0)
    return (s * np.asarray(fn, float))[..., None] * np.asarray(n, float)
