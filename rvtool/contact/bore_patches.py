"""Compression-only bore patches of an elastic wheel (issue 30): the journal presses on the loaded arc
of its crank bore only.

A wheel with ``wheels.structure.bore_ports = N`` carries N radial patch ports around each crank bore
(:mod:`rvtool.structure.wheel_body`: patch k reads the weighted mean outward radial displacement w_k
of its arc and spreads its force p_k over the arc along the local radii). The journal -- in the RV
model the needle row's outer envelope, a rigid race on the bore station of
:class:`~rvtool.contact.wheel_closure.WheelBodyClosure` -- presses on patch k through a frictionless
compression-only contact without clearance (the needle law keeps the bearing's own clearance): with
the patch's mean outward normal n_k and the race's translation d relative to the wheel,

    z_k = w_k - n_k . d >= 0,   p_k >= 0,   p_k z_k = 0.

The law is displacement driven. The station displacements are u = (u_f, d): u_f on rows fixed by
their stations (the pins' profile ports), d (2 per bore) the races. With the wheel's port stiffness K
over the rows (fixed, patches) (the inverse of its port compliance) the rows' displacements are
v = P u + (0, z), P u = (u_f, N^T d), and the patch forces p = (K v)_p; the gaps z solve the LCP

    p = K_pp z + (K P u)_p >= 0,   z >= 0,   z . p = 0

(the minimum of the wheel's energy 1/2 v^T K v over patch displacements on or outside the race;
K_pp positive definite: one solution), by :func:`rvtool.contact.lcp.solve_contact_lcp`. The station
forces are s = P^T K v: the fixed rows' forces and each race's resultant sum_k p_k n_k. With O the
open patches (z_k > 0),

    s = P^T K_S P u,   K_S = K - K_:O K_OO^-1 K_O:,

so the law is piecewise linear and positively homogeneous, and P^T K_S P is its exact tangent away
from a change of O. A patch with z_k = 0 and p_k = 0 counts as closed (at u = 0 the tangent is the
all-closed one, the stiffest: a Newton iteration starting there sees every patch).
"""
import numpy as np

from ..errors import RvtoolInputError
from .lcp import solve_contact_lcp

OPEN_TOLERANCE = 1e-10
"""A patch is open where its gap exceeds this times the largest displacement of the rows (the LCP's
own relative tolerance: below it a gap is round-off of the closed solution)."""


def patch_matrix(n_fixed, normals):
    """P ((n_fixed + sum N_b), (n_fixed + 2 n_b)): identity on the fixed rows, the patches of bore b
    reading n_k . d_b (normals: per bore an (N_b, 2) array of mean outward normals, the stations'
    frame)."""
    normals = [np.asarray(n, float) for n in normals]
    n_p = sum(len(n) for n in normals)
    P = np.zeros((n_fixed + n_p, n_fixed + 2 * len(normals)))
    P[:n_fixed, :n_fixed] = np.eye(n_fixed)
    r = n_fixed
    for b, n in enumerate(normals):
        if n.ndim != 2 or n.shape[1] != 2:
            raise RvtoolInputError(f"normals of bore {b} must be (N, 2); got {n.shape}")
        P[r:r + len(n), n_fixed + 2 * b:n_fixed + 2 * b + 2] = n
        r += len(n)
    return P


def condensed_stiffness(K, n_fixed, open_):
    """K_S = K - K_:O K_OO^-1 K_O: (module docstring) for the open patches ``open_`` (n_p,) bool."""
    K = np.asarray(K, float)
    o = n_fixed + np.flatnonzero(np.asarray(open_, bool))
    if len(o) == 0:
        return K
    Ko = K[:, o]
    return K - Ko @ np.linalg.solve(K[np.ix_(o, o)], Ko.T)


def station_tangent(K, P, n_fixed, open_):
    """P^T K_S P: the stations' stiffness at a fixed set of open patches."""
    T = P.T @ condensed_stiffness(K, n_fixed, open_) @ P
    return 0.5 * (T + T.T)


def patch_law(K, P, n_fixed, u, open_guess=None):
    """(s (n_u,) [N], ds/du (n_u, n_u) [N/m], open (n_p,) bool, p (n_p,) [N], z (n_p,) [m]) of the
    compression-only patches (module docstring) at station displacements u (n_u,) [m].

    K (n_r, n_r) [N/m]: the rows' stiffness, symmetric positive definite; P: :func:`patch_matrix`;
    n_fixed: the leading rows fixed by their stations; open_guess: a first set of open patches (the
    last one: a warm start; the solution does not depend on it)."""
    K = np.asarray(K, float)
    u = np.asarray(u, float)
    n_r = K.shape[0]
    if K.shape != (n_r, n_r) or P.shape[0] != n_r or u.shape != (P.shape[1],):
        raise RvtoolInputError(f"K {K.shape}, P {P.shape} and u {u.shape} do not agree")
    v0 = P @ u
    Kpp = K[n_fixed:, n_fixed:]
    b = (K @ v0)[n_fixed:]                      # the patch forces with every gap closed
    guess = (b < 0) if open_guess is None else np.asarray(open_guess, bool)
    sol = solve_contact_lcp(Kpp, b, active=guess)
    z = sol.lam
    scale = max(float(np.abs(v0).max(initial=0.0)), 1e-300)
    open_ = z > OPEN_TOLERANCE * scale
    z = np.where(open_, z, 0.0)
    T = station_tangent(K, P, n_fixed, open_)
    return T @ u, T, open_, np.clip(sol.gap, 0.0, None), z
