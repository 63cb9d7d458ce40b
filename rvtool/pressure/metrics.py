"""Pressure observables of piecewise-constant panel fields (Eqs. pressure_metrics, pressure_field_difference).

A panel field is given by its uniform panel centres x [m] and panel pressures p [Pa]; the pressure is
constant on [x_j - dx/2, x_j + dx/2] and zero outside the panel domain.
"""
import numpy as np

from rvtool.errors import RvtoolInputError
from rvtool.validation import check_positive


def panel_edges(x):
    """Edges (n + 1,) [m] of the uniform panels with centres x (n,) [m]."""
    x = np.asarray(x, float)
    if x.ndim != 1 or x.size < 2:
        raise RvtoolInputError(f"x: need a 1-D array of at least 2 panel centres; got shape {x.shape}")
    dx = x[1] - x[0]
    if not dx > 0:
        raise RvtoolInputError(f"x: panel centres must increase; got spacing {dx!r} m")
    return np.concatenate([x - 0.5 * dx, [x[-1] + 0.5 * dx]])


def _cumulative(edges, p):
    """Integral of the piecewise-constant field from the first edge to each edge [Pa m]."""
    return np.concatenate([[0.0], np.cumsum(np.asarray(p, float) * np.diff(edges))])


def window_mean_max(x, p, window):
    """Peak fixed-window mean pressure of Eq. (pressure_metrics) [Pa].

    max_s (1/w) int_{s-w/2}^{s+w/2} p dx for a physical window w [m] held fixed between
    resolutions; pressure outside the panel domain is zero and the denominator stays w.
    The windowed integral is piecewise linear in s with kinks where a window end crosses a
    panel edge, so its maximum is attained at s = edge -+ w/2 and the search over those
    candidates is exact.
    """
    check_positive("window", window)
    e = panel_edges(x)
    c = _cumulative(e, p)
    s = np.concatenate([e - 0.5 * window, e + 0.5 * window])

    def cum(u):
        # zero before the first edge and the total beyond the last: zero pressure outside the domain
        return np.interp(u, e, c, left=0.0, right=c[-1])

    return float(np.max(cum(s + 0.5 * window) - cum(s - 0.5 * window)) / window)


def field_difference(x_n, p_n, x_m, p_m):
    """e_1(N, M) of Eq. (pressure_field_difference) [-]: int |p_N - p_M| dx / int p_M dx.

    Integrated exactly for the two piecewise-constant fields on the sorted union of their
    panel edges, zero pressure outside each domain."""
    en, em = panel_edges(x_n), panel_edges(x_m)
    u = np.union1d(en, em)
    mid = 0.5 * (u[1:] + u[:-1])

    def value(e, p, xs):
        j = np.searchsorted(e, xs, side="right") - 1
        inside = (j >= 0) & (j < len(p))
        return np.where(inside, np.asarray(p, float)[np.clip(j, 0, len(p) - 1)], 0.0)

    d = np.abs(value(en, p_n, mid) - value(em, p_m, mid))
    den = float(np.sum(np.asarray(p_m, float) * np.diff(em)))
    if not den > 0:
        raise RvtoolInputError("p_m: the reference field carries no load (int p_M dx = 0)")
    return float(np.sum(d * np.diff(u)) / den)


def successive_changes_pct(values):
    """|v_{k+1} - v_k| / |v_{k+1}| in % between successive resolutions (len - 1 values)."""
    v = np.asarray(values, float)
    return [float(100 * abs(b - a) / abs(b)) for a, b in zip(v[:-1], v[1:])]
