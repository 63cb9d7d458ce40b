"""NumPy reference of the influence-coefficient roller slices (paper Eq. (bearing_ic)), the readable
version of :mod:`warp_contacts.roller_slices`; one roller per row, batched over rollers.

Compliance. A roller of length l is cut into n slices of width dy = l / n (centres y_i). Slice j
carries its force f_j as a strip of Hertz-elliptic pressure across the rolling direction,

    p_j(x, y) = f_j (2 / (pi b_j dy)) sqrt(1 - x^2 / b_j^2),   |x| < b_j,  |y - y_j| < dy / 2,

(b_j its contact half-width). The surface displacement of two elastic half-spaces (Boussinesq;
Johnson, Contact Mechanics, 1985, Section 3.2: u_z = P / (pi E* r) for a point load P on the two
bodies, 1/E* = (1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2) on the roller's centre line x = 0, averaged
over slice i (Galerkin collocation: the slice's mean approach), is u_i = sum_j C_ij f_j with

    C_ij = I_{|i-j|}(b_j) / (pi E* dy),
    I_k(b) = (4/pi) int_0^{pi/2} cos^2(theta) M_k(b sin theta) dtheta,
    M_k(c) = [H((k+1) dy) - 2 H(k dy) + H((k-1) dy)] / dy,   H(u) = u asinh(u/c) - sqrt(u^2 + c^2),

the y-integrals in closed form (int asinh(u/c) du = H(u); strip over y, mean over the receiving
slice), then x = b sin(theta). With u asinh(u/c) = |u| ln(|u| + sqrt(u^2 + c^2)) - |u| ln c the
logarithmic singularity at theta = 0 appears in the slice's own term only (second difference of
|u|: 2 dy at k = 0) and is integrated in closed form, -2 (4/pi) int cos^2 ln(b sin) = 2 ln(2/b) + 1
(int_0^{pi/2} cos^2 ln sin = -(pi/4) ln 2 - pi/8); the smooth remainder by Gauss--Legendre with
N_QUAD nodes (exact for the prescribed shape to ~1e-12: tests/test_roller_slices.py checks it against
an adaptive 2-D quadrature). The inner- and outer-race contacts are in series, each with its own
half-widths: C_l = C(b_in) + C(b_out) (paper: "contributions from both races add"). This is the
slicing of de Mul, Kalker & Fredriksson (J. Tribol. 108, 1986, 140-148) and Hartnett (J. Lubr.
Technol. 101, 1979, 105-109) with the pressure shape across the contact prescribed (Hertz) instead
of discretised.

Half-width (integer column SI_MODE), Hertz b = sqrt(4 q R' / (pi E*)) of a line load q (Johnson
1985, Section 4.3), R' the race contact's effective radius:

* HALF_WIDTH_FIXED: the columns SL_BIN, SL_BOUT (the bearing's reference load); C symmetric Toeplitz;
* HALF_WIDTH_ROLLER_LOAD: from the roller's mean line load q = sum f / l (the paper's "updated from the
  total line load"); symmetric Toeplitz at each iterate;
* HALF_WIDTH_SLICE_LOAD: each slice's b_j from its own line load f_j / dy (C then has column-wise
  half-widths, not symmetric); the form that follows tilt and edge loading (verification case).

The updated half-widths and the slice forces are solved together by Newton's method on
C(b(f)) f_A = s_A (the tangent's matrix M below), the active set settled by the exact solve at the
converged half-widths (floor B_FLOOR_FRACTION dy).

Complementarity (Eq. (bearing_ic)): w = C f - s, f >= 0, w >= 0, f^T w = 0, s the slices' rigid
approach (positive: interference). C is a P-matrix (positive definite in the symmetric modes), so
Murty's least-index principal pivoting method (Murty, Linear Complementarity, Linear and Nonlinear
Programming, 1988, ch. 4) ends in finitely many pivots at the exact solution: solve the active block,
then flip the lowest-index slice that violates f_A >= 0 or w >= 0; warm start on s > 0 (and on the
last active set in the fixed point).

Tangent (the active set's Schur complement): with the active set A fixed, C_AA(b) f_A = s_A, so
df_A/ds_A = M_AA^-1, M = C + D with D = 0 (fixed), D = v 1^T, v = sum_r (dC/db_r) f b_r / (2F)
(roller load, F = 1^T f, db/dF = b / (2F)), or D_ij = sum_r (dC_ij/db_rj) b_rj / 2 (slice load,
db_j/df_j = b_j / (2 f_j)); 0 outside A.
"""
import numpy as np

# ---- per-roller float parameters (named once, shared with the Warp kernel and the packer
# rvtool.bearings.influence; SI units) ----
SL_DY = 0        # slice width dy = l / n [m]
SL_ESTAR = 1     # two-body modulus E* [Pa]
SL_RIN = 2       # effective radius R' of the inner-race contact [m]
SL_ROUT = 3      # effective radius R' of the outer-race contact [m]
SL_BIN = 4       # fixed half-width of the inner-race contact [m]
SL_BOUT = 5      # fixed half-width of the outer-race contact [m]
SL_LEN = 6       # roller contact length l [m]
N_SLICE_FLOAT = 7
# ---- per-roller integer parameters ----
SI_COUNT = 0     # number of slices n
SI_MODE = 1      # HALF_WIDTH_FIXED, HALF_WIDTH_ROLLER_LOAD or HALF_WIDTH_SLICE_LOAD
N_SLICE_INT = 2
HALF_WIDTH_FIXED, HALF_WIDTH_ROLLER_LOAD, HALF_WIDTH_SLICE_LOAD = 0, 1, 2

#: Gauss--Legendre nodes of the smooth part of the strip integral (the integrand is analytic in
#: theta once the log singularity is split off): against 64 nodes, 16 nodes differ by < 1e-14
#: relative for half-widths up to the slice width and by 7e-13 at three slice widths
N_QUAD = 16
#: largest number of slices per roller (the specifications allow up to 64)
MAX_SLICES = 64
#: principal pivots per solve (a warm start needs a few; the bound only guards the kernel's loop)
MAX_PIVOTS = 8 * MAX_SLICES
#: Newton iterations of the load-dependent half-widths and the relative step that ends them (Newton
#: converges quadratically: the error after a step of 1e-11 is ~1e-22; a bound, not a tuning)
MAX_HALF_WIDTH_ITERATIONS = 60
NEWTON_RTOL = 1e-11
#: smallest half-width of the line-load mode as a fraction of dy (keeps ln b finite at zero load)
B_FLOOR_FRACTION = 1e-6
#: relative tolerance of the complementarity test (a few ulp of the approach scale)
LCP_RTOL = 1e-13


def quadrature():
    """Gauss--Legendre nodes theta_k on [0, pi/2] and the weights (4/pi) w_k cos^2(theta_k)."""
    x, w = np.polynomial.legendre.leggauss(N_QUAD)
    theta = 0.25 * np.pi * (x + 1.0)
    return np.sin(theta), (4.0 / np.pi) * 0.25 * np.pi * w * np.cos(theta) ** 2


SIN_Q, W_Q = quadrature()


def _smooth_h(u, c):
    """S(u, c) = |u| ln(|u| + sqrt(u^2 + c^2)) - sqrt(u^2 + c^2) (H without its -|u| ln c) and dS/dc."""
    a = np.abs(u)
    r = np.sqrt(a * a + c * c)
    return a * np.log(a + r) - r, a * c / (r * (a + r)) - c / r


def strip_integral(k, dy, b):
    """I_k(b) and dI_k/db (broadcast over offsets k = |i - j| and half-widths b; module docstring)."""
    k, b = np.broadcast_arrays(np.asarray(k, float), np.asarray(b, float))
    c = b[..., None] * SIN_Q
    kk = k[..., None]
    sp, dp = _smooth_h((kk + 1.0) * dy, c)
    s0, d0 = _smooth_h(kk * dy, c)
    sm, dm = _smooth_h((kk - 1.0) * dy, c)
    I = np.sum(W_Q * (sp - 2.0 * s0 + sm), axis=-1) / dy
    dI = np.sum(W_Q * (dp - 2.0 * d0 + dm) * SIN_Q, axis=-1) / dy
    own = k == 0
    return I + np.where(own, 2.0 * np.log(2.0 / b) + 1.0, 0.0), dI + np.where(own, -2.0 / b, 0.0)


def compliance(fp, n, B):
    """C_l (n, n) [m/N] with source-slice half-widths B (2, n) [m] (inner, outer race) and
    dC/db_r (2, n, n) [1/N]: entry (i, j) is the derivative by the half-width of column j."""
    i = np.arange(n)
    K = np.abs(i[:, None] - i[None, :])
    scale = 1.0 / (np.pi * fp[SL_ESTAR] * fp[SL_DY])
    I, dI = strip_integral(K[None, :, :], fp[SL_DY], B[:, None, :])
    return scale * I.sum(axis=0), scale * dI


def line_load_half_width(force, length, radius, e_star):
    """Hertz half-width b = sqrt(4 q R' / (pi E*)) [m] of a line load q = force / length (Johnson 1985, 4.3)."""
    return np.sqrt(4.0 * np.maximum(force, 0.0) / length * radius / (np.pi * e_star))


def half_widths(fp, mode, f, n):
    """Half-widths B (2, n) [m] of the mode at slice forces f (n,)."""
    if mode == HALF_WIDTH_FIXED:
        return np.array([np.full(n, fp[SL_BIN]), np.full(n, fp[SL_BOUT])])
    floor = B_FLOOR_FRACTION * fp[SL_DY]
    if mode == HALF_WIDTH_ROLLER_LOAD:
        q = np.full(n, np.sum(f) / fp[SL_LEN])
    else:
        q = np.maximum(f, 0.0) / fp[SL_DY]
    return np.array([np.maximum(line_load_half_width(q, 1.0, fp[r], fp[SL_ESTAR]), floor) for r in (SL_RIN, SL_ROUT)])


def solve_lcp(C, s, warm=None):
    """Exact solution f >= 0 of w = C f - s >= 0, f^T w = 0 (C a P-matrix) by Murty's least-index
    principal pivoting; returns (f, active mask, pivots). ``warm``: the first active set (default s > 0).
    Should the pivots run out (C not a P-matrix), f is NaN: the evaluation reports itself non-finite
    instead of returning forces that violate the complementarity conditions."""
    n = len(s)
    tol = LCP_RTOL * max(np.max(np.abs(s)), 1e-300)
    A = (s > 0) if warm is None else np.asarray(warm, bool).copy()
    for pivots in range(MAX_PIVOTS + 1):
        f = np.zeros(n)
        if A.any():
            f[A] = np.linalg.solve(C[np.ix_(A, A)], s[A])
        w = C @ f - s
        bad = np.flatnonzero((A & (f < 0)) | (~A & (w < -tol)))
        if bad.size == 0:
            break
        A[bad[0]] = ~A[bad[0]]
    else:
        f = np.full(n, np.nan)
    return f, A, pivots


def half_width_term(fp, mode, f, B, dC):
    """D (n, n) of the tangent M = C + D: the derivative of C(b(f)) f by f through the half-widths."""
    n = len(f)
    floor = B_FLOOR_FRACTION * fp[SL_DY]
    if mode == HALF_WIDTH_ROLLER_LOAD and f.sum() > 0 and np.all(B > floor):
        return np.outer(np.einsum("rij,j,r->i", dC, f, B[:, 0]) / (2.0 * f.sum()), np.ones(n))
    if mode == HALF_WIDTH_SLICE_LOAD:
        return 0.5 * np.einsum("rij,rj->ij", dC, np.where(B > floor, B, 0.0))
    return np.zeros((n, n))


def solve_roller(s, fp, ip):
    """Slice forces f (n,) [N], tangent J = df/ds (n, n) [N/m], half-widths B (2, n) [m],
    active mask and pivots of one roller at slice approaches s (n,) [m].

    Load modes: from the solve at the fixed half-widths, Newton's method on C(b(f)) f_A = s_A with
    the active set held (the matrix M = C + D of the tangent); when it has converged (step <=
    NEWTON_RTOL of the largest force) or a force left the active set, the exact complementarity
    solve at the half-widths of the current forces settles the active set; done when it needs no
    pivot after a converged Newton step."""
    n = int(ip[SI_COUNT])
    mode = int(ip[SI_MODE])
    s = np.asarray(s, float)[:n]
    B = half_widths(fp, HALF_WIDTH_FIXED, None, n)
    C, dC = compliance(fp, n, B)
    f, A, pivots = solve_lcp(C, s)
    if mode != HALF_WIDTH_FIXED:
        for _ in range(MAX_HALF_WIDTH_ITERATIONS):
            B = half_widths(fp, mode, f, n)
            C, dC = compliance(fp, n, B)
            step = 0.0
            if A.any():
                M = C + half_width_term(fp, mode, f, B, dC)
                df = np.linalg.solve(M[np.ix_(A, A)], (C @ f - s)[A])
                f = f.copy()
                f[A] -= df
                step = np.max(np.abs(df))
            converged = step <= NEWTON_RTOL * max(np.max(np.abs(f)), 1e-300)
            if converged or np.any(f[A] <= 0):
                B = half_widths(fp, mode, f, n)
                C, dC = compliance(fp, n, B)
                f, A, p = solve_lcp(C, s, warm=A)
                pivots += p
                if converged and p == 0:
                    break
    J = np.zeros((n, n))
    if A.any():
        M = C + half_width_term(fp, mode, f, B, dC)
        J[np.ix_(A, A)] = np.linalg.inv(M[np.ix_(A, A)])
    return f, J, B, A, pivots


def evaluate(s, fparams, iparams):
    """All rollers: s (R, n_max) slice approaches [m] -> f (R, n_max) [N], J (R, n_max, n_max) [N/m],
    half-widths (R, 2, n_max) [m], active-slice counts (R,) (padding slices beyond a roller's count: zero)."""
    s = np.asarray(s, float)
    R, nmax = s.shape
    f, J, hw, na = np.zeros((R, nmax)), np.zeros((R, nmax, nmax)), np.zeros((R, 2, nmax)), np.zeros(R, int)
    for j in range(R):
        n = int(iparams[j, SI_COUNT])
        fj, Jj, B, A, _ = solve_roller(s[j], fparams[j], iparams[j])
        f[j, :n], J[j, :n, :n], hw[j, :, :n], na[j] = fj, Jj, B, A.sum()
    return f, J, hw, na
