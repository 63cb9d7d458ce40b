"""NumPy double-precision reference implementations of :mod:`warp_contacts.laws`.

These are the readable versions; the Warp functions must match them.
All functions are vectorized over NumPy arrays.
"""
import numpy as np


def power_law(k, p, delta):
    """F = k <delta>_+^p and dF/d delta (Eq. (normal_force), elastic part)."""
    k, p, delta = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (k, p, delta)))
    d = np.where(delta > 0.0, delta, 1.0)
    f = np.where(delta > 0.0, k * d ** p, 0.0)
    return f, np.where(delta > 0.0, p * f / d, 0.0)


def damping_ramp(delta, delta_r):
    """r = min(delta/delta_r, 1) for delta > 0 and its derivative."""
    delta, delta_r = np.broadcast_arrays(np.asarray(delta, float), np.asarray(delta_r, float))
    r = np.clip(delta / delta_r, 0.0, 1.0)
    dr = np.where((delta > 0.0) & (delta < delta_r), 1.0 / delta_r, 0.0)
    return np.where(delta > 0.0, r, 0.0), dr


def normal_force(k, p, c, delta_r, delta, delta_dot):
    """F_n = max(0, k delta^p + c r(delta) delta_dot) with its two partials."""
    fe, dfe = power_law(k, p, delta)
    r, dr = damping_ramp(delta, delta_r)
    f = fe + c * r * delta_dot
    on = (np.asarray(delta) > 0.0) & (f > 0.0)
    return (np.where(on, f, 0.0), np.where(on, dfe + c * dr * delta_dot, 0.0),
            np.where(on, c * r, 0.0))


def friction_coefficient(mu_k, mu_s, v_s, v_reg, v):
    """mu_reg(v) = [mu_k + (mu_s-mu_k) exp(-(v/v_s)^2)] tanh(v/v_reg) and its derivative."""
    x = v / v_s
    e = np.exp(-x * x)
    mu = mu_k + (mu_s - mu_k) * e
    dmu = (mu_s - mu_k) * e * (-2.0 * x / v_s)
    th = np.tanh(v / v_reg)
    dth = (1.0 - th * th) / v_reg
    return mu * th, dmu * th + mu * dth
