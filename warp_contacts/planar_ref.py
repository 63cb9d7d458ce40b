"""NumPy twins of the planar helpers of :mod:`warp_contacts.planar` (the readable
references use them; vectorized over leading axes, complex-step safe)."""
import numpy as np

#: Seeds of the forward-mode pair tangent: 6 coordinate seeds (q_A, q_B), then 6 velocity
#: seeds (v_A, v_B); dQ/dq is columns 0-5 of the (6, N_SEEDS) tangent, dQ/dv columns 6-11.
N_COORD_SEEDS = 6
N_SEEDS = 12


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


def pair_seeds():
    """The unit seeds of the pair tangent in column order: yields (j, dq_A, dq_B, dv_A, dv_B),
    each a (3,) unit or zero direction over (x, y, theta) or (vx, vy, omega)."""
    for j in range(N_SEEDS):
        seed = np.zeros(N_SEEDS)
        seed[j] = 1.0
        yield j, seed[0:3], seed[3:6], seed[6:9], seed[9:12]
