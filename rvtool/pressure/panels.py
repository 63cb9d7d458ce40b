"""Transverse-panel contact solver (paper Eqs. obs_pressure_contact, obs_panel_influence).

Each panel spans the face width b and a length dx along the profile; its
unknown is the panel force. The two-body compliance is the Boussinesq 1/r
kernel integrated analytically over the rectangular panel (self panel
included) for a receiver at the panel centre. On a uniform grid the matrix is
symmetric Toeplitz: only one column is stored and the gap of all panels is a
FFT convolution, O(n log n).

Complementarity is exact: an active-set iteration (add every panel with a
negative gap, drop every panel with a negative force) whose reduced problem,
the bordered system [A_aa -1; 1^T 0][f; delta] = [-h_a; F], is solved directly.
The active set of a single contact is one contiguous run of panels, so A_aa
is itself symmetric Toeplitz: two Levinson solves (O(m^2),
``scipy.linalg.solve_toeplitz``) give u = A_aa^-1 1 and v = A_aa^-1 h_a, then
delta = (F + sum v) / sum u and f = delta u - v, whose sum is F to round-off.
A non-contiguous active set (several lobes) falls back to a dense solve of the
bordered system. Block pivoting can cycle between active sets when there are
several lobes; on a repeated set the iteration continues with primal-feasible
steps (Lawson-Hanson type: add the most violated panel alone; move from the
last feasible forces towards the subproblem solution until a force reaches
zero and release it), along which the convex energy 1/2 f^T A f + h^T f
decreases, so no set repeats. A dense LU of a 2,000-panel active block costs ~0.3 s per
active-set iteration and up to ~10 iterations are needed, which is what made
the 4097-panel solve slow on busy cores; Levinson costs milliseconds. CG on
the full grid (Polonsky-Keer) was not chosen: it converges to a tolerance,
while the active-set solution satisfies the complementarity conditions
exactly once the set has settled.
"""
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.signal

from rvtool.errors import RvtoolInputError
from rvtool.validation import check_nonnegative, check_positive

from .metrics import window_mean_max


def panel_integral(x1, x2, half_width):
    """int_{x1}^{x2} int_{-h}^{h} dy dxi / sqrt(xi^2 + y^2) in m (receiver at the origin)."""

    def g(x):
        x = np.asarray(x, dtype=float)
        ax = np.abs(x)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(ax > 0, x * np.arcsinh(half_width / np.where(ax > 0, ax, 1.0)), 0.0)
        return t + half_width * np.arcsinh(x / half_width)

    return 2.0 * (g(x2) - g(x1))


def influence_column(n, dx, face_width, e_star):
    """First column A[:, 0] of the Toeplitz compliance matrix in m/N (Eq. obs_panel_influence)."""
    d = np.arange(n) * dx
    return panel_integral(d - 0.5 * dx, d + 0.5 * dx, 0.5 * face_width) / (np.pi * e_star * face_width * dx)


@dataclass(frozen=True, kw_only=True)
class PanelContact:
    """Line-contact panel problem on a uniform grid."""

    face_width: float
    """Face width b [m]."""
    e_star: float
    """Plane-strain two-body modulus E* [Pa]."""
    force: float
    """Prescribed total normal force [N]."""
    mean_window: float = 0.0
    """Physical width w of the fixed window of the mean pressure, Eq. (pressure_metrics) [m]
    (0: no window, p_window is then the raw peak)."""

    def __post_init__(self):
        check_positive("face_width", self.face_width)
        check_positive("e_star", self.e_star)
        check_positive("force", self.force)
        check_nonnegative("mean_window", self.mean_window)


@dataclass(frozen=True, kw_only=True)
class PanelResult:
    x: np.ndarray
    """Panel centres [m]."""
    pressure: np.ndarray
    """Panel pressure f/(b dx) [Pa]."""
    force: np.ndarray
    """Panel force [N]."""
    gap: np.ndarray
    """Loaded gap [m] (>= 0, zero on the active set)."""
    approach: float
    """Rigid approach delta [m]."""
    p_raw: float
    """Raw peak panel pressure [Pa]."""
    p_window: float
    """Peak fixed-window mean pressure of Eq. (pressure_metrics) [Pa]."""
    span: float
    """Loaded span: extent of the active panels [m]."""
    load_residual: float
    """|sum f - F| / F [-]."""
    iterations: int


def _bordered_solve(col, idx, h, F):
    """Panel forces f_a and approach delta of the bordered system on the active panels idx."""
    m = idx.size
    if idx[-1] - idx[0] == m - 1:
        # one contiguous run: A_aa is the leading m x m block of the Toeplitz matrix
        uv = scipy.linalg.solve_toeplitz(col[:m], np.column_stack([np.ones(m), h[idx]]))
        u, v = uv[:, 0], uv[:, 1]
        delta = (F + v.sum()) / u.sum()
        return delta * u - v, delta
    K = np.empty((m + 1, m + 1))
    K[:m, :m] = col[np.abs(idx[:, None] - idx[None, :])]
    # the load row written as -1^T f = -F keeps the bordered matrix symmetric (indefinite: LDL^T)
    K[:m, m] = -1.0
    K[m, :m] = -1.0
    K[m, m] = 0.0
    sol = scipy.linalg.solve(K, np.concatenate([-h[idx], [-F]]), assume_a="sym")
    return sol[:m], sol[m]


def solve_panels(contact, x, gap0, max_iter=200, initial_active=None):
    """Solve the complementarity problem (Eq. obs_pressure_contact) for the panel forces.

    x: uniform panel centres [m]; gap0: undeformed gap at the centres [m] (any constant datum);
    initial_active: optional boolean mask of a first active-set guess (e.g. from a coarser grid),
    by default the n/50 (at least 3) panels of smallest gap.
    """
    x = np.asarray(x, float)
    h = np.asarray(gap0, float)
    n = x.size
    if n < 3:
        raise RvtoolInputError(f"x: {n} panels given, need at least 3")
    if h.shape != x.shape or not np.all(np.isfinite(h)):
        raise RvtoolInputError(f"gap0: need {n} finite values (one per panel); got shape {h.shape}")
    dx = x[1] - x[0]
    if not dx > 0 or not np.allclose(np.diff(x), dx, rtol=1e-9, atol=0):
        raise RvtoolInputError("x: panel centres must be uniformly spaced and increasing (Toeplitz compliance)")
    b, F = contact.face_width, contact.force
    col = influence_column(n, dx, b, contact.e_star)
    full = np.concatenate([col[::-1], col[1:]])  # kernel for offsets -(n-1)..(n-1)

    def displ(f):
        return scipy.signal.fftconvolve(f, full, mode="valid") if n > 64 else scipy.linalg.toeplitz(col) @ f

    if initial_active is not None:
        active = np.asarray(initial_active, bool).copy()
        if active.shape != (n,):
            raise RvtoolInputError(f"initial_active: need a boolean mask of {n} panels; got shape {active.shape}")
    else:
        active = np.zeros(n, bool)
        active[np.argsort(h)[: max(3, n // 50)]] = True
    if not active.any():
        active[np.argmin(h)] = True
    # last primal-feasible iterate (f >= 0, sum f = F): all load on the smallest gap
    f = np.zeros(n)
    f[np.argmin(h)] = F
    delta = 0.0
    seen = set()
    safeguarded = False
    for it in range(1, max_iter + 1):
        idx = np.flatnonzero(active)
        fa, delta = _bordered_solve(col, idx, h, F)
        if np.any(fa < 0):
            if safeguarded:
                # step from the feasible f towards the subproblem solution until a force reaches
                # zero, and release those panels: the convex objective does not increase
                fi = f[idx]
                neg = fa < 0
                alpha = np.min(fi[neg] / (fi[neg] - fa[neg]))
                f = np.zeros(n)
                f[idx] = fi + alpha * (fa - fi)
                active[idx[f[idx] <= 1e-14 * F]] = False
                f[~active] = 0.0
            else:
                # block pivoting: drop the negative forces, keep the rest for the next solve
                active[idx[fa < 0]] = False
            if not active.any():
                active[np.argmin(h)] = True
            key = active.tobytes()
            if key in seen and not safeguarded:
                # a repeated active set: block pivoting cycles (several lobes); continue from the last
                # feasible iterate with the safeguarded steps
                safeguarded = True
                active = f > 0
            seen.add(key)
            continue
        f = np.zeros(n)
        f[idx] = fa
        g = h + displ(f) - delta
        tol = 1e-10 * max(np.ptp(h[idx]) if idx.size > 1 else 0.0, abs(delta), 1e-12)
        viol = (~active) & (g < -tol)
        if not viol.any():
            break
        if safeguarded:
            # one panel at a time, the most violated: its force in the enlarged subproblem is
            # positive (Lawson-Hanson), so the energy decreases strictly
            active[np.argmin(np.where(viol, g, np.inf))] = True
        else:
            active |= viol
        key = active.tobytes()
        if key in seen and not safeguarded:
            safeguarded = True
        seen.add(key)
    else:
        raise RuntimeError(f"solve_panels: active set not settled after {max_iter} iterations")
    g[active] = 0.0
    p = f / (b * dx)
    pw = window_mean_max(x, p, contact.mean_window) if contact.mean_window > 0 else float(p.max())
    idx = np.flatnonzero(f > 0)
    span = (x[idx[-1]] - x[idx[0]] + dx) if idx.size else 0.0
    return PanelResult(x=x, pressure=p, force=f, gap=g, approach=float(delta), p_raw=float(p.max()),
                       p_window=float(pw), span=float(span), load_residual=float(abs(f.sum() - F) / F),
                       iterations=it)
