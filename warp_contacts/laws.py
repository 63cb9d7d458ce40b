"""Scalar contact laws as Warp functions (float64 by default, float32 option).

Each factory returns functions that give a value together with its
derivative, because the contact element needs the analytic tangent.
The NumPy reference implementations live in :mod:`warp_contacts.laws_ref`.

Laws (paper, Eq. (normal_force) and Eq. (friction)):

* elastic power law  F_el = k <delta>^p  with p = 3/2 (point contact),
  p = 1 (linearized line contact), p = 10/9 (output-pin law) or any p >= 1;
  the coefficient k has units N m^-p.
* damping ramp  r(delta) = min(delta / delta_r, 1),
  F_n = max(0, F_el(delta) + c r(delta) d(delta)/dt).
* regularized friction  F_t = -F_n mu_reg(v_t),
  mu_reg(v) = [mu_k + (mu_s - mu_k) exp(-(v/v_s)^2)] tanh(v / v_reg),
  which satisfies mu_reg(v) v >= 0 (dissipative) for mu_k, mu_s >= 0.
"""
import functools
import types

import warp as wp


@functools.lru_cache(maxsize=None)
def law_funcs(dtype):
    """Warp functions of the scalar contact laws for scalar type ``dtype``."""
    @wp.func
    def power_law(k: dtype, p: dtype, delta: dtype):
        """F = k delta^p and dF/d delta for delta > 0, else (0, 0)."""
        if delta <= dtype(0.0):
            return dtype(0.0), dtype(0.0)
        f = k * wp.pow(delta, p)
        return f, p * f / delta

    @wp.func
    def damping_ramp(delta: dtype, delta_r: dtype):
        """r = min(delta/delta_r, 1) and dr/d delta of Eq. (normal_force)."""
        if delta <= dtype(0.0):
            return dtype(0.0), dtype(0.0)
        if delta >= delta_r:
            return dtype(1.0), dtype(0.0)
        return delta / delta_r, dtype(1.0) / delta_r

    @wp.func
    def normal_force(k: dtype, p: dtype, c: dtype, delta_r: dtype, delta: dtype, delta_dot: dtype):
        """F_n of Eq. (normal_force) and its partials (dF/d delta, dF/d delta_dot).

        An open contact (delta <= 0) and a damping term that would pull the
        surfaces together (F_n < 0) both give zero force and zero derivative.
        """
        if delta <= dtype(0.0):
            return dtype(0.0), dtype(0.0), dtype(0.0)
        fe, dfe = power_law(k, p, delta)
        r, dr = damping_ramp(delta, delta_r)
        f = fe + c * r * delta_dot
        if f <= dtype(0.0):
            return dtype(0.0), dtype(0.0), dtype(0.0)
        return f, dfe + c * dr * delta_dot, c * r

    @wp.func
    def friction_coefficient(mu_k: dtype, mu_s: dtype, v_s: dtype, v_reg: dtype, v: dtype):
        """mu_reg(v) of Eq. (friction) and d mu_reg / dv (Stribeck times tanh)."""
        x = v / v_s
        e = wp.exp(-x * x)
        mu = mu_k + (mu_s - mu_k) * e
        dmu = (mu_s - mu_k) * e * (dtype(-2.0) * x / v_s)
        th = wp.tanh(v / v_reg)
        dth = (dtype(1.0) - th * th) / v_reg
        return mu * th, dmu * th + mu * dth

    return types.SimpleNamespace(power_law=power_law, damping_ramp=damping_ramp,
                                 normal_force=normal_force, friction_coefficient=friction_coefficient)
