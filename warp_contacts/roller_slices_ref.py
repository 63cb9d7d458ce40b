"""NumPy reference of the influence-coefficient roller slices (paper Eq. (bearing_ic)), the readable
version of :mod:`warp_contacts.roller_slices`; one roller per row, batched over rollers.

Compliance. A roller of length l is cut into n slices of width dy = l / n (centres y_i). Slice j
carries its force f_j as a strip of Hertz-elliptic pressure across the rolling direction,

    p_j(x, y) = f_j (2 / (pi b dy)) sqrt(1 - x^2 / b^2),   |x| < b,  |y - y_j| < dy / 2,

(b the contact half-width of the race contact). The surface displacement of two elastic half-spaces
under p (Boussinesq; Johnson, Contact Mechanics, 1985, Section 3.2: u_z = P / (pi E* r) for a point
load P on the two bodies, 1/E* = (1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2) at the centre (0, y_i) of
slice i, integrated over the strip (y first, in closed form: int dy / sqrt(x^2 + y^2) = asinh(y/|x|);
then x = b sin(theta)), is u_i = sum_j C_ij f_j with

    C_ij = I(Y1, Y2, b) / (pi E* dy),   Y1,2 = y_j - y_i -+ dy / 2,
    I = (4/pi) int_0^{pi/2} cos^2(theta) [asinh(Y2 / (b sin theta)) - asinh(Y1 / (b sin theta))] dtheta.

With asinh(Y/c) = sgn(Y) [ln(|Y| + sqrt(Y^2 + c^2)) - ln c] the logarithmic singularity at theta = 0
of the slice's own strip (Y1 < 0 < Y2) is integrated in closed form,
-2 (4/pi) int cos^2 ln(b sin) = 2 ln(2 / b) + 1 (int_0^{pi/2} cos^2 ln sin = -(pi/4) ln 2 - pi/8),
and the smooth remainder by Gauss--Legendre with N_QUAD nodes (the exactness of the prescribed
shape is checked against a 2-D adaptive quadrature in tests/test_roller_slices.py). The matrix is
symmetric Toeplitz (uniform slices); C_l = C(b_inner) + C(b_outer), the inner- and outer-race
contacts of the roller in series (paper: "contributions from both races add"). This is the slicing
of de Mul, Kalker & Fredriksson (J. Tribol. 108, 1986, 140-148) and Hartnett (J. Lubr. Technol.
101, 1979, 105-109) with the pressure shape across the contact prescribed (Hertz) instead of
discretised.

Half-width: fixed (column SL_BIN, SL_BOUT) or, mode HALF_WIDTH_LINE_LOAD, the Hertz half-width of
the roller's mean line load q = sum f / l, b = sqrt(4 q R' / (pi E*)) (Johnson 1985, Section 4.3),
R' the race contact's effective radius; the line load and b are iterated to a fixed point
(C depends on b through ln b only, so the map contracts fast; floor B_FLOOR_FRACTION dy).

Complementarity (Eq. (bearing_ic)): w = C f - s, f >= 0, w >= 0, f^T w = 0, s the slices' rigid
approach (positive: interference). C is symmetric positive definite, so this is the convex QP
min 1/2 f^T C f - s^T f, f >= 0, solved exactly by the Lawson--Hanson primal active-set method
(Lawson & Hanson, Solving Least Squares Problems, 1974, ch. 23; finite termination): warm start
on the slices with s > 0 when that set's solution is positive, else from f = 0; add the slice of
largest s_i - (C f)_i; on a nonpositive subproblem solution step back to the feasible set and
release the slices that reach zero.

Tangent (the active set's Schur complement): with the active set A fixed, f_A = C_AA^-1 s_A, so
df/ds = C_AA^-1 on A x A and 0 elsewhere. With the line-load half-width, C_AA(b(F)) f_A = s_A with
F = 1^T f_A and db_r/dF = b_r / (2 F) gives (C_AA + v 1^T) df_A = ds_A,
v = sum_r (dC_AA/db_r) f_A b_r / (2 F) (Sherman--Morrison rank one).
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
SI_MODE = 1      # HALF_WIDTH_FIXED or HALF_WIDTH_LINE_LOAD
N_SLICE_INT = 2
HALF_WIDTH_FIXED, HALF_WIDTH_LINE_LOAD = 0, 1
# ---- per-roller outputs: half-widths used [m], active slices, solver iterations ----
HW_IN, HW_OUT = 0, 1

#: Gauss--Legendre nodes of the smooth part of the strip integral (the integrand is analytic in
#: theta once the log singularity is split off; 24 nodes reach ~1e-12 relative, see the tests)
N_QUAD = 24
#: largest number of slices per roller (the specifications allow up to 64)
MAX_SLICES = 64
#: Lawson--Hanson outer iterations per solve: each adds one slice, so 3 n is ample
MAX_ACTIVE_SET_STEPS = 3 * MAX_SLICES
#: fixed-point iterations of the line-load half-width and their relative stopping step
MAX_HALF_WIDTH_ITERATIONS = 60
HALF_WIDTH_RTOL = 1e-13
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


def _log_term(Y, c):
    """sgn(Y) ln(|Y| + sqrt(Y^2 + c^2)) and its derivative with respect to c."""
    a = np.abs(Y)
    r = np.sqrt(a * a + c * c)
    return np.sign(Y) * np.log(a + r), np.sign(Y) * c / (r * (a + r))


def strip_integral(k, dy, b):
    """I and dI/db (arrays like k) of slice offsets k = |i - j| (dimensionless I, see the module docstring)."""
    k = np.asarray(k, float)[..., None]
    c = b * SIN_Q
    l2, d2 = _log_term((k + 0.5) * dy, c)
    l1, d1 = _log_term((k - 0.5) * dy, c)
    I = np.sum(W_Q * (l2 - l1), axis=-1)
    dI = np.sum(W_Q * (d2 - d1) * SIN_Q, axis=-1)
    own = k[..., 0] == 0
    return I + np.where(own, 2.0 * np.log(2.0 / b) + 1.0, 0.0), dI + np.where(own, -2.0 / b, 0.0)


def compliance_column(n, dy, b, e_star):
    """First column of the Toeplitz compliance of one race contact C [m/N] and dC/db [1/N] (n,)."""
    I, dI = strip_integral(np.arange(n), dy, b)
    s = 1.0 / (np.pi * e_star * dy)
    return s * I, s * dI


def toeplitz(col):
    n = len(col)
    i = np.arange(n)
    return col[np.abs(i[:, None] - i[None, :])]


def line_load_half_width(force, length, radius, e_star):
    """Hertz half-width b = sqrt(4 q R' / (pi E*)) [m] of a line load q = force / length (Johnson 1985, 4.3)."""
    return np.sqrt(4.0 * max(force, 0.0) / length * radius / (np.pi * e_star))


def solve_lcp(C, s, warm=None):
    """Exact solution f >= 0 of w = C f - s >= 0, f^T w = 0 (C symmetric positive definite) by
    Lawson--Hanson's active-set method; returns (f, active mask, steps). ``warm``: a first guess
    of the active set (default s > 0), used when its subproblem solution is positive."""
    n = len(s)
    tol = LCP_RTOL * max(np.max(np.abs(s)), 1e-300)
    P = (s > 0) if warm is None else np.asarray(warm, bool).copy()
    f = np.zeros(n)
    if P.any():
        z = np.linalg.solve(C[np.ix_(P, P)], s[P])
        if np.all(z > 0):
            f[P] = z
        else:
            P[:] = False
    steps = 0
    while steps < MAX_ACTIVE_SET_STEPS:
        grad = s - C @ f
        cand = np.where(~P, grad, -np.inf)
        i = int(np.argmax(cand))
        if not cand[i] > tol:
            break
        P[i] = True
        while True:
            steps += 1
            z = np.zeros(n)
            z[P] = np.linalg.solve(C[np.ix_(P, P)], s[P])
            if np.all(z[P] > 0):
                f = z
                break
            neg = P & (z <= 0)
            # f_i / (f_i - z_i) in [0, 1); a just-added slice (f_i = 0) with z_i = 0 stops the step
            den = f[neg] - z[neg]
            alpha = np.min(np.where(den > 0, f[neg] / np.where(den > 0, den, 1.0), 0.0))
            f = f + alpha * (z - f)
            P &= f > 0
            f[~P] = 0.0
    return f, P, steps


def roller_compliance(fp, n, b_in, b_out):
    """C_l = C(b_in) + C(b_out) (n, n) [m/N] and the columns dC/db of each race."""
    dy, es = fp[SL_DY], fp[SL_ESTAR]
    ci, di = compliance_column(n, dy, b_in, es)
    co, do = compliance_column(n, dy, b_out, es)
    return toeplitz(ci + co), di, do


def solve_roller(s, fp, ip):
    """Slice forces f (n,) [N], tangent J = df/ds (n, n) [N/m], half-widths (b_in, b_out) [m],
    active mask and Lawson--Hanson steps of one roller at slice approaches s (n,) [m]."""
    n = int(ip[SI_COUNT])
    s = np.asarray(s, float)[:n]
    b = np.array([fp[SL_BIN], fp[SL_BOUT]])
    line_load = int(ip[SI_MODE]) == HALF_WIDTH_LINE_LOAD
    floor = B_FLOOR_FRACTION * fp[SL_DY]
    P = None
    total_steps = 0
    for _ in range(MAX_HALF_WIDTH_ITERATIONS if line_load else 1):
        C, di, do = roller_compliance(fp, n, b[0], b[1])
        f, P, steps = solve_lcp(C, s, warm=P)
        total_steps += steps
        if not line_load:
            break
        F = f.sum()
        b_new = np.array([max(line_load_half_width(F, fp[SL_LEN], fp[r], fp[SL_ESTAR]), floor)
                          for r in (SL_RIN, SL_ROUT)])
        done = np.all(np.abs(b_new - b) <= HALF_WIDTH_RTOL * b_new)
        b = b_new
        if done:
            C, di, do = roller_compliance(fp, n, b[0], b[1])
            f, P, steps = solve_lcp(C, s, warm=P)
            total_steps += steps
            break
    J = np.zeros((n, n))
    if P.any():
        A = np.ix_(P, P)
        Cinv = np.linalg.inv(C[A])
        F = f.sum()
        if line_load and F > 0 and np.all(b > floor):
            # (C_AA + v 1^T)^-1 by Sherman--Morrison, v = sum_r dC_AA/db_r f_A b_r / (2F)
            v = (toeplitz(di)[A] @ f[P]) * b[0] / (2 * F) + (toeplitz(do)[A] @ f[P]) * b[1] / (2 * F)
            u = Cinv @ v
            Cinv = Cinv - np.outer(u, Cinv.sum(axis=0)) / (1.0 + u.sum())
        J[A] = Cinv
    return f, J, b, P, total_steps


def evaluate(s, fparams, iparams):
    """All rollers: s (R, n_max) slice approaches [m] -> f (R, n_max) [N], J (R, n_max, n_max) [N/m],
    half-widths (R, 2) [m], active-slice counts (R,) (padding slices beyond a roller's count: zero)."""
    s = np.asarray(s, float)
    R, nmax = s.shape
    f, J, hw, na = np.zeros((R, nmax)), np.zeros((R, nmax, nmax)), np.zeros((R, 2)), np.zeros(R, int)
    for j in range(R):
        n = int(iparams[j, SI_COUNT])
        fj, Jj, b, P, _ = solve_roller(s[j], fparams[j], iparams[j])
        f[j, :n], J[j, :n, :n], hw[j], na[j] = fj, Jj, b, P.sum()
    return f, J, hw, na
