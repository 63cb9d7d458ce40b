"""Transverse-panel contact solver (paper Eqs. obs_pressure_contact, obs_panel_influence).

Each panel spans the face width b and a length dx along the profile; its
unknown is the panel force. The two-body compliance is the Boussinesq 1/r
kernel integrated analytically over the rectangular panel (self panel
included) for a receiver at the panel centre. On a uniform grid the matrix is
symmetric Toeplitz: only one column is stored, the reduced (active-set)
systems are gathered from it and the gap of the inactive panels is a FFT
convolution. Complementarity is exact: an active-set iteration with a direct
solve of the bordered system [A_aa -1; 1^T 0][f; delta] = [-h_a; F].
Direct solves were chosen over CG because the active set of a
non-conformal contact is a small fraction of the domain, so a dense LU of the
reduced block is cheap and gives the load balance to round-off.
"""
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.signal

from rvtool.errors import RvtoolInputError
from rvtool.validation import check_positive


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
    """Width of the fixed window for the mean pressure [m] (0: the panel width)."""

    def __post_init__(self):
        check_positive("face_width", self.face_width)
        check_positive("e_star", self.e_star)
        check_positive("force", self.force)


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
    """Peak fixed-window mean pressure [Pa]."""
    span: float
    """Loaded span: extent of the active panels [m]."""
    load_residual: float
    """|sum f - F| / F [-]."""
    iterations: int


def solve_panels(contact, x, gap0, max_iter=200):
    """Solve the complementarity problem for panel forces on the uniform grid x with undeformed gap gap0."""
    x = np.asarray(x, float)
    h = np.asarray(gap0, float)
    n = x.size
    if n < 3:
        raise RvtoolInputError(f"x: {n} panels given, need at least 3")
    dx = x[1] - x[0]
    if not np.allclose(np.diff(x), dx, rtol=1e-9, atol=0):
        raise RvtoolInputError("x: panel centres must be uniformly spaced (Toeplitz compliance)")
    b, F = contact.face_width, contact.force
    col = influence_column(n, dx, b, contact.e_star)
    full = np.concatenate([col[::-1], col[1:]])  # kernel for offsets -(n-1)..(n-1)

    def displ(f):
        return scipy.signal.fftconvolve(f, full, mode="valid") if n > 64 else scipy.linalg.toeplitz(col) @ f

    active = np.zeros(n, bool)
    active[np.argsort(h)[: max(3, n // 50)]] = True
    f = np.zeros(n)
    delta = 0.0
    for it in range(1, max_iter + 1):
        idx = np.flatnonzero(active)
        m = idx.size
        K = np.empty((m + 1, m + 1))
        K[:m, :m] = col[np.abs(idx[:, None] - idx[None, :])]
        K[:m, m] = -1.0
        K[m, :m] = 1.0
        K[m, m] = 0.0
        rhs = np.concatenate([-h[idx], [F]])
        sol = scipy.linalg.solve(K, rhs)
        fa, delta = sol[:m], sol[m]
        if np.any(fa < 0):
            # drop the most negative forces, keep the rest for the next solve
            neg = fa < 0
            active[idx[neg]] = False
            if not active.any():
                active[np.argmin(h)] = True
            continue
        f = np.zeros(n)
        f[idx] = fa
        g = h + displ(f) - delta
        tol = 1e-10 * max(np.ptp(h[idx]) if m > 1 else 0.0, abs(delta), 1e-12)
        viol = (~active) & (g < -tol)
        if not viol.any():
            break
        active |= viol
    else:
        raise RuntimeError(f"solve_panels: active set not settled after {max_iter} iterations")
    g[active] = 0.0
    p = f / (b * dx)
    w = max(1, int(round(contact.mean_window / dx))) if contact.mean_window > 0 else 1
    pw = np.convolve(p, np.ones(w) / w, mode="valid").max()
    idx = np.flatnonzero(f > 0)
    span = (x[idx[-1]] - x[idx[0]] + dx) if idx.size else 0.0
    return PanelResult(x=x, pressure=p, force=f, gap=g, approach=float(delta), p_raw=float(p.max()),
                       p_window=float(pw), span=float(span), load_residual=float(abs(f.sum() - F) / F),
                       iterations=it)
