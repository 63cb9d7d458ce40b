"""Signed gap and force direction of circle--circle contact (Warp functions).

Conventions (paper, Section "Contact laws, signed clearance, and force
direction"): positive gap is separation.

* external contact of circle A (radius r_A) and circle B (radius r_B):
  g_ext = |c_B - c_A| - r_A - r_B; the force on A points away from B,
  f_A = -F_n n with n = (c_B - c_A)/|c_B - c_A|.
* internal contact of circle A inside the enclosing circle B (radius R_B):
  g_int = R_B - r_A - |c_B - c_A|; the force on A points toward B's centre,
  f_A = +F_n n.

Both cases are written as g = s (L - r_A) - r_B s' with a sign s = +1
(external) or -1 (internal), so one code path serves both. The NumPy
reference is :mod:`warp_contacts.circle_geometry_ref`.
"""
import functools
import types

import warp as wp


@functools.lru_cache(maxsize=None)
def circle_funcs(dtype):
    """Warp functions for circle--circle gap and force for scalar type ``dtype``."""
    vec2 = wp.types.vector(2, dtype)

    @wp.func
    def circle_gap(ca: vec2, cb: vec2, ra: dtype, rb: dtype, internal: int):
        """Return (g, n, L): signed gap, unit centre direction A->B, centre distance.

        For coincident centres the direction is undefined; (1, 0) is used,
        which only matters for an internal contact at zero eccentricity where
        the gap is then R_B - r_A regardless of direction.
        """
        d = cb - ca
        L = wp.length(d)
        n = vec2(dtype(1.0), dtype(0.0))
        if L > dtype(0.0):
            n = d / L
        g = L - ra - rb
        if internal != 0:
            g = rb - ra - L
        return g, n, L

    @wp.func
    def circle_force_on_a(fn: dtype, n: vec2, internal: int):
        """Force vector on circle A for normal force magnitude fn >= 0."""
        if internal != 0:
            return fn * n
        return -fn * n

    return types.SimpleNamespace(circle_gap=circle_gap, circle_force_on_a=circle_force_on_a, vec2=vec2)
