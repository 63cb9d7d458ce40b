"""NumPy twins of the planar helpers of :mod:`warp_contacts.planar` (the readable
references use them; vectorized over leading axes, complex-step safe)."""
import numpy as np


def perp(a):
    """a rotated by +90 degrees: (-a_y, a_x)."""
    return np.stack([-a[..., 1], a[..., 0]], axis=-1)


def cross2(a, b):
    """Planar cross product a_x b_y - a_y b_x."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rot(theta, xi):
    """R(theta) xi: the body-fixed vector xi of a body turned by theta [rad]."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * xi[..., 0] - s * xi[..., 1], s * xi[..., 0] + c * xi[..., 1]], axis=-1)


def dot(a, b):
    """Dot product over the last axis."""
    return np.sum(a * b, axis=-1)
