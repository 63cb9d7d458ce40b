"""Conformal contact of a pin in a hole of nearly its radius (Persson's problem): the numerical
solution and the law the pin--groove member uses (:mod:`rvtool.contact.groove`).

**Problem.** A pin of radius R in a hole of radius R + Delta R of an elastically similar body
(plane strain, frictionless; contact modulus 1/E* = 2 (1 - nu^2) / E), pressed by a line load P
[N/m]. A. Persson, "On the stress distribution of cylindrical elastic bodies in contact",
dissertation, Chalmers University of Technology, Goteborg 1964, formulated and solved it; Hertz's
line contact (K. L. Johnson, Contact Mechanics, CUP 1985, Sec. 5.6) is its small-angle limit
and fails where Delta R << R (the contact arc grows to tens of degrees at ordinary loads; here
50 deg at P = E* Delta R). With the pressure p(theta) = sum_n p_n cos(n theta) on the contact arc
|theta| < eps, the radial opening of the two surfaces is w(theta) = sum_n c_n p_n cos(n theta) with

    c_0 = R / E*,   c_n = (2 R / E*) n / (n^2 - 1)   (n >= 2)                              (1)

(derived here from Michell's stress functions r^n, r^(n+2) for the disc and r^-n, r^(2-n) for the
plate with the hole, each loaded by p_n cos(n theta) with no shear, summed over both bodies:
:func:`body_coefficients`; every n >= 2 reduces to (1), in which nu cancels -- elastic similarity).
The mode n = 1 is the net force, whose displacement depends on the bodies' far geometry (log-
divergent in an infinite plate): it is the housing's *global* compliance, not the groove's, and is
excluded, so the approach delta of this law is the *local* approach of the pin centre to the groove
(the global part belongs to the housing member, ``housing.model = "ports"``). The gap of the
displaced pin is Delta R - delta cos(theta) + w(theta); on the contact arc it vanishes, outside it
is >= 0, p >= 0, and R int p cos(theta) dtheta = P.

**Scaling.** With x = P / (E* Delta R), delta / Delta R = 1 + psi(x): psi is one dimensionless
curve for every radius, clearance and material (elastic similarity). The law's approach is the
elastic part delta_el = Delta R psi(P / (E* Delta R)): the pin sits in its groove (the clearance
is taken up kinematically at zero load).

**Numerical solution** (:func:`reference`): the pressure at M equally spaced nodes on the circle,
(1) as a circulant matrix (its symbol is c_n), active-set iterations on the contact nodes with
delta as the unknown of the force balance. The approach is an integral of the pressure and
converges fast: M = 2048 and 8192 nodes agree in psi to 4e-5 relative at x = 1e-3 (11 nodes on
the half-arc), 1e-5 at 1e-2 and 2e-6 from 0.1 to 1e3 (measured; the contact angle's edge by the
square-root law to about 0.01 deg).

**Closed-form limit.** For x -> 0 (Hertz), psi -> (x / pi) ln(pi / x): Johnson's two-body approach
(x/pi)(ln(4 pi / x) - 1) less (ln 4 - 1) x / pi, the n = 1 mode Johnson's reference points
include (the difference is identified from the numerical solution to 5e-6 of (ln 4 - 1)/pi at
x = 1e-5; ``cases/rv/compliance_members.py`` reports it).

**Law** (:func:`psi`): the numerical solution tabulated at 8 points per decade on x in
[1e-3, 1e3] (:data:`TABLE_X`, :data:`TABLE_PSI`; regenerate with ``python -m
rvtool.contact.conformal_pin``), a monotone cubic (PCHIP) in (ln x, ln psi) between them (C^1, its
derivative analytic); below 1e-3 the Hertz limit plus a cubic correction a x^2 + b x^3 matching the
table's value and slope at 1e-3; below 1e-9 a quadratic with the same value and slope at 1e-9 (a
finite stiffness at zero load, where the logarithm gives none; a pin at 1e-9 E* Delta R l carries
no torque worth a figure, and the closure needs a regular tangent); above 1e3 the power law of the
table's end slope.
"""
import math

import numpy as np

from ..errors import RvtoolInputError

X_TABLE_LO, X_TABLE_HI = 1e-3, 1e3
X_FLOOR = 1e-9
N_NODES = 2048


def body_coefficients(n, R=1.0, shear_modulus=1.0, poisson_ratio=0.3):
    """(c_hole, c_disc) [m/Pa]: the outward radial displacement of the hole and the inward one of
    the disc at r = R under the normal pressure cos(n theta) (no shear), from Michell's stress
    functions f(r) cos(n theta), f = sum K_m r^m: sigma_rr = (m - n^2) r^(m-2), sigma_r theta =
    n (m - 1) r^(m-2) (times sin), u_r = [(1 - nu)(m - n^2) - nu m (m - 1)] r^(m-1) / (2 G (m - 1)),
    m in (-n, 2 - n) for the plate with the hole and (n, n + 2) for the disc; n = 0 by the Lame
    solutions. n = 1 (the net force) has none (module docstring)."""
    G, nu = shear_modulus, poisson_ratio
    if n == 0:
        return R / (2 * G), (1 - 2 * nu) * R / (2 * G)
    if n == 1:
        raise RvtoolInputError("n = 1 is the net force: no local coefficient (module docstring)")
    out = []
    for ms in ((-n, 2 - n), (n, n + 2)):
        # at r = 1 (the coefficients scale with R: powers of R would overflow at large n)
        A = np.array([[m - n * n for m in ms], [n * (m - 1) for m in ms]], float)
        K = np.linalg.solve(A, [-1.0, 0.0])
        out.append(R * sum(k * ((1 - nu) * (m - n * n) - nu * m * (m - 1)) / (m - 1) / (2 * G) for k, m in zip(K, ms)))
    return out[0], -out[1]


def symbol(n_nodes):
    """c_n E* / R of Eq. (1) for n = 0 .. n_nodes/2 (n = 1: 0, the excluded net-force mode)."""
    n = np.arange(n_nodes // 2 + 1, dtype=float)
    c = np.where(n >= 2, 2.0 * n / np.maximum(n * n - 1.0, 1.0), 0.0)
    c[0] = 1.0
    return c


def reference(x, n_nodes=N_NODES, max_iterations=100):
    """Numerical solution at x = P / (E* Delta R) > 0: (psi = delta / Delta R - 1, contact
    half-angle eps [rad], iterations). Units: R = Delta R = E* = 1 (module docstring)."""
    if not (np.isfinite(x) and x > 0):
        raise RvtoolInputError(f"x = {x!r}; valid: a finite load ratio > 0")
    M = int(n_nodes)
    th = 2 * np.pi * np.arange(M) / M
    th = np.where(th > np.pi, th - 2 * np.pi, th)
    c = symbol(M)
    row = np.fft.irfft(c, n=M)                 # first row of the circulant closure matrix
    w = 2 * np.pi / M
    contact = np.abs(th) <= min(2 * math.atan(math.sqrt(x / math.pi)), 1.5)
    for it in range(max_iterations):
        ic = np.flatnonzero(contact)
        if len(ic) < 3:
            raise RvtoolInputError(f"x = {x:.3g}: the contact spans fewer than 3 of {M} nodes; valid: more nodes")
        k = len(ic)
        A = np.zeros((k + 1, k + 1))
        A[:k, :k] = row[(ic[:, None] - ic[None, :]) % M]
        A[:k, k] = -np.cos(th[ic])
        A[k, :k] = np.cos(th[ic]) * w
        b = np.zeros(k + 1)
        b[:k], b[k] = -1.0, x
        sol = np.linalg.solve(A, b)
        p = np.zeros(M)
        p[ic] = sol[:k]
        delta = sol[k]
        gap = 1.0 - delta * np.cos(th) + np.fft.irfft(np.fft.rfft(p) * c, n=M)
        new = contact.copy()
        new[contact & (p < 0)] = False
        new[~contact & (gap < 0)] = True
        if np.array_equal(new, contact):
            break
        contact = new
    else:
        raise RvtoolInputError(f"x = {x:.3g}: the active set did not settle in {max_iterations} iterations")
    pos = np.flatnonzero(contact & (th >= 0))
    j1, j0 = pos[-1], pos[-2]
    y1, y0 = p[j1] ** 2, p[j0] ** 2           # the square-root edge: p^2 linear in theta
    eps = th[j1] + y1 * (th[j1] - th[j0]) / (y0 - y1) if y0 > y1 else th[j1]
    return float(delta - 1.0), float(eps), it


def hertz_limit(x):
    """(psi, dpsi/dx) of the small-load limit (x / pi) ln(pi / x) (module docstring)."""
    x = np.asarray(x, float)
    return x / np.pi * np.log(np.pi / x), (np.log(np.pi / x) - 1.0) / np.pi


# -- the table (python -m rvtool.contact.conformal_pin regenerates it) --------------------------
TABLE_X = np.logspace(-3, 3, 49)
TABLE_PSI = np.array([     # reference(x)[0] at TABLE_X, N_NODES = 2048 (1e-7 relative, module docstring)
    0.0025635466639701843,
    0.0032960550199321315,
    0.004232878021749098,
    0.0054284747635642283,
    0.0069496012383654104,
    0.0088826863037878567,
    0.011331271746172211,
    0.01442818502131904,
    0.018330405360233337,
    0.023233914167623437,
    0.029376491717521214,
    0.037039073758836194,
    0.046564004661029168,
    0.05834989260376755,
    0.07287036434617522,
    0.090673971903071582,
    0.11240122352131388,
    0.13879602648653577,
    0.17073355486307218,
    0.20926583270699584,
    0.25569935512373876,
    0.31171879823578785,
    0.37959630497258767,
    0.46247788312508975,
    0.56480114081471311,
    0.69282560029280371,
    0.85532259964751689,
    1.0643993164504848,
    1.3365471884769335,
    1.6939624545184753,
    2.1662880641334765,
    2.792968326314532,
    3.6264184663344823,
    4.7363316931592658,
    6.215442478637784,
    8.187246042393971,
    10.81630795346762,
    14.321989442006281,
    18.996753913238617,
    25.230573435053344,
    33.543460548699663,
    44.628844502309292,
    59.411427887708498,
    79.124309479215071,
    105.41185596753657,
    140.46685901398092,
    187.21345688096517,
    249.5510451689247,
    332.67955389358383
])


def _table():
    return np.array([reference(float(x))[0] for x in TABLE_X])


class _Law:
    """The continued law of the module docstring, built once from the table."""

    def __init__(self, table_psi):
        from scipy.interpolate import PchipInterpolator
        lx, lp = np.log(TABLE_X), np.log(table_psi)
        self.spline = PchipInterpolator(lx, lp, extrapolate=False)
        self.dspline = self.spline.derivative()
        # below the table: Hertz + a x^2 + b x^3 with the table's value and slope at x0
        x0 = TABLE_X[0]
        v0 = float(table_psi[0])
        s0 = v0 / x0 * float(self.dspline(lx[0]))
        h0, dh0 = hertz_limit(x0)
        r, dr = v0 - h0, s0 - dh0
        # a x0^2 + b x0^3 = r,  2 a x0 + 3 b x0^2 = dr
        self.b = (dr * x0 - 2 * r) / x0 ** 3
        self.a = (r - self.b * x0 ** 3) / x0 ** 2
        # the floor: value and slope of the low branch at X_FLOOR
        vf, sf = self._low(np.array(X_FLOOR))
        self.fb = (sf * X_FLOOR - vf) / X_FLOOR ** 2
        self.fa = sf - 2 * self.fb * X_FLOOR
        # above: psi_end (x / x_end)^s
        self.v_end = float(table_psi[-1])
        self.s_end = float(self.dspline(lx[-1]))

    def _low(self, x):
        h, dh = hertz_limit(x)
        return h + self.a * x ** 2 + self.b * x ** 3, dh + 2 * self.a * x + 3 * self.b * x ** 2

    def __call__(self, x):
        x = np.asarray(x, float)
        v, d = np.zeros_like(x), np.zeros_like(x)
        floor = x <= X_FLOOR
        low = (x > X_FLOOR) & (x < X_TABLE_LO)
        mid = (x >= X_TABLE_LO) & (x <= X_TABLE_HI)
        high = x > X_TABLE_HI
        v[floor] = self.fa * x[floor] + self.fb * x[floor] ** 2
        d[floor] = self.fa + 2 * self.fb * x[floor]
        if np.any(low):
            v[low], d[low] = self._low(x[low])
        if np.any(mid):
            lx = np.log(x[mid])
            v[mid] = np.exp(self.spline(lx))
            d[mid] = v[mid] / x[mid] * self.dspline(lx)
        if np.any(high):
            v[high] = self.v_end * (x[high] / X_TABLE_HI) ** self.s_end
            d[high] = self.s_end * v[high] / x[high]
        return v, d


_LAW = None


def psi(x):
    """(psi(x), dpsi/dx) of the law (module docstring), x = P / (E* Delta R) >= 0 (array)."""
    global _LAW
    x = np.asarray(x, float)
    if np.any(~np.isfinite(x)) or np.any(x < 0):
        raise RvtoolInputError("conformal pin law: the load ratio x = P / (E* Delta R) must be finite and >= 0")
    if _LAW is None:
        _LAW = _Law(TABLE_PSI)
    return _LAW(x)


def psi_inverse(y, tol=1e-14, max_iterations=100):
    """x >= 0 with psi(x) = y >= 0 (array): Newton in ln x, safeguarded by a bracket."""
    y = np.asarray(y, float)
    if np.any(~np.isfinite(y)) or np.any(y < 0):
        raise RvtoolInputError("conformal pin law: the approach must be finite and >= 0")
    if _LAW is None:
        psi(0.0)
    flat = y.ravel()
    out = np.zeros_like(flat)
    # the floor (x <= X_FLOOR): the smaller root of fb x^2 + fa x - y = 0, cancellation-free
    y_floor = float(psi(X_FLOOR)[0])
    fl = flat <= y_floor
    fa, fb = _LAW.fa, _LAW.fb
    out[fl] = 2 * flat[fl] / (fa + np.sqrt(np.maximum(fa * fa + 4 * fb * flat[fl], 0.0)))
    pos = ~fl
    if not np.any(pos):
        return out.reshape(y.shape)
    yy = flat[pos]
    lo = np.full(yy.shape, math.log(X_FLOOR))                       # ln x brackets
    hi = np.maximum(60.0, np.log(yy) + 10.0)
    u = np.log(np.clip(yy, 1e-300, None))                          # psi ~ x at moderate x
    u = np.clip(u, lo, hi)
    for _ in range(max_iterations):
        v, d = psi(np.exp(u))
        r = v - yy
        lo = np.where(r < 0, u, lo)
        hi = np.where(r > 0, u, hi)
        step = r / (d * np.exp(u))
        un = u - step
        # a converged step (below tol, possibly below u's round-off: un == u, which may equal the bracket end the
        # residual's round-off sign just set) is accepted, not bisected: bisecting it restarted from the far end of
        # the initial bracket (~50 halvings back to the same root)
        bad = (np.abs(step) > tol) & ((un <= lo) | (un >= hi)) | ~np.isfinite(un)
        un = np.where(bad, 0.5 * (lo + hi), un)
        done = np.abs(un - u) <= tol
        u = un
        if np.all(done):
            break
    out[pos] = np.exp(u)
    v, _ = psi(out[pos])
    if not np.all(np.abs(v - yy) <= 1e-12 * yy):
        raise RvtoolInputError("conformal pin law inversion did not converge (internal error)")
    return out.reshape(y.shape)


if __name__ == "__main__":      # regenerate TABLE_PSI
    print(",\n".join(f"    {v:.17g}" for v in _table()))
