"""Tooth compliance of an involute spur gear by the potential-energy method, with the
fillet-foundation term of Sainsot et al., and the ISO 6336-1 single-stiffness estimate
used as an outside reference.

Model (named): the potential-energy method of Yang & Lin (1987, ASME J. Mech. Trans.
Autom. Des. 109:189) as generalized by Tian (2004, MSc thesis, U. Alberta) and Chaari,
Fakhfakh & Haddar (2009, Eur. J. Mech. A/Solids 28:461): the tooth is a cantilever on
its centre line from the root circle, of the actual half-thickness y(xi) (trochoid fillet
and involute); a unit load along the flank normal at the contact point stores the energy
of bending, shear (coefficient 1.2) and axial compression, and the displacement along
the load line is

    c' = integral [ 12 m(s)^2 / (E (2y)^3) + 1.2 v^2 / (G 2y) + n^2 / (E 2y) ] ds      [m^2/N]

per unit face width (m = moment per unit load about the section centre, v and n the
load components across and along the centre line, plane stress E as in Tian).
The gear body (fillet foundation) of an external gear adds Sainsot, Velex & Duverger
(2004, ASME J. Mech. Des. 126:748), Eq. (8) and Table 1:

    c'_f = cos^2(alpha_m) / E [ L* (u_f/S_f)^2 + M* (u_f/S_f) + P* (1 + Q* tan^2 alpha_m) ],

alpha_m the load angle to the section, u_f the distance from the root circle to where the
load line crosses the centre line, S_f = 2 r_f theta_f the root chord, and each X* a fit
in h_f = r_f / r_bore and theta_f (the fit's range, 1.4 <= h_f <= 7 and
0.01 <= theta_f <= 0.12 rad, is reported, not enforced: a pinion of 16 teeth has theta_f ~ 0.19).
The foundation is allocated once per gear body, here, and never again in the contact law.
Internal (ring) teeth get the beam terms only; their rim is a separate structural concern.

The contact (Hertz) flattening is not part of this module: it is resolved with the load in
the contact law, Eq. (series_contact) (:mod:`warp_contacts.involute_pairs_ref`), which
needs Weber's load-line depth h(u) supplied here.
"""
from dataclasses import dataclass
import math

import functools

import numpy as np

from ..geometry.involute import InvoluteGear

#: Sainsot et al. (2004), Table 1: X* = A/theta_f^2 + B h_f^2 + C h_f/theta_f + D/theta_f + E h_f + F.
SAINSOT_COEFFICIENTS = {
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}
SAINSOT_RANGE = {"h_f": (1.4, 7.0), "theta_f": (0.01, 0.12)}

#: shear correction of a rectangular section in the energy method (Yang & Lin; Tian)
SHEAR_COEFFICIENT = 1.2
#: degree of the polynomials in the roll angle that carry c'(u) and h(u) to the kernel
POLY_DEGREE = 8


def sainsot_factors(h_f, theta_f):
    """(L*, M*, P*, Q*) of the fillet-foundation formula."""
    out = []
    for k in ("L", "M", "P", "Q"):
        A, B, C, D, E, F = SAINSOT_COEFFICIENTS[k]
        out.append(A / theta_f ** 2 + B * h_f ** 2 + C * h_f / theta_f + D / theta_f + E * h_f + F)
    return tuple(out)


def _load(gear: InvoluteGear, u):
    """Contact point P (tooth frame: centre line +x for external, material at y > 0 side flank),
    unit load direction f onto the flank, for roll angles u (counter-clockwise flank of the tooth)."""
    u = np.asarray(u, float)
    r = gear.radius_of_roll(u)
    psi = gear.half_angle(r)
    P = np.stack([r * np.cos(psi), r * np.sin(psi)], -1)
    omega = -gear.eps            # ccw-side flank: external unwinds clockwise, internal counter-clockwise
    phit = gear.base_half_angle + omega * u
    dT = -omega * np.stack([-np.sin(phit), np.cos(phit)], -1)
    return P, -gear.eps * dT


@functools.lru_cache(maxsize=8)
def _gauss_legendre(n):
    """Gauss--Legendre nodes and weights on [-1, 1] (read-only, computed once per n: an
    eigenvalue problem of order n that every gear of every variant would otherwise repeat)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x.flags.writeable = w.flags.writeable = False
    return x, w


def beam_compliance(gear: InvoluteGear, u, n_sections=400, section=None):
    """(c'_bending, c'_shear, c'_axial) [m^2/N] per unit face width at roll angles u.

    section: the tooth half-section (xi, y) from the root (default
    :meth:`InvoluteGear.half_section`); the beam starts at its first point."""
    E, nu = gear.youngs_modulus, gear.poisson_ratio
    G = E / (2 * (1 + nu))
    sec = gear.half_section() if section is None else np.asarray(section, float)
    order = np.argsort(sec[:, 0])
    xi_tab, y_tab = sec[order, 0], sec[order, 1]
    axis = np.array([1.0, 0.0]) if not gear.internal else np.array([-1.0, 0.0])
    xi_root = sec[0, 0]
    P, f = _load(gear, u)
    s_p = (P[:, 0] - xi_root) * axis[0]
    out = np.zeros((3, len(s_p)))
    v = f @ np.array([-axis[1], axis[0]])
    nrm = f @ axis
    # Gauss-Legendre on [0, s_P]: the integrands are smooth in s (y > 0 over the whole tooth)
    xg, wg = _gauss_legendre(n_sections // 4)
    for i, sp in enumerate(s_p):
        s = 0.5 * sp * (xg + 1.0)
        w = 0.5 * sp * wg
        xi = xi_root + s * axis[0]
        y = np.interp(xi, xi_tab, y_tab)
        arm = P[i, 0] - xi           # section centre (xi, 0) to the load point
        mom = arm * f[i, 1] - P[i, 1] * f[i, 0]
        out[0, i] = np.sum(w * 12 * mom ** 2 / (E * (2 * y) ** 3))
        out[1, i] = np.sum(w * SHEAR_COEFFICIENT * v[i] ** 2 / (G * 2 * y))
        out[2, i] = np.sum(w * nrm[i] ** 2 / (E * 2 * y))
    return out


def foundation_compliance(gear: InvoluteGear, u):
    """c'_f [m^2/N] of Sainsot et al. (external gears; zero for internal gears) and whether
    (h_f, theta_f) lie in the fit's range."""
    if gear.internal:
        return np.zeros(np.shape(u)), True
    E = gear.youngs_modulus
    rf = gear.root_radius
    theta_f = gear.root_half_angle()
    h_f = rf / gear.bore_radius
    L, M, Pc, Q = sainsot_factors(h_f, theta_f)
    P, f = _load(gear, u)
    # load line P + t f crosses the centre line (y = 0) at xi_L
    xi_l = P[:, 0] - P[:, 1] * f[:, 0] / f[:, 1]
    uf = xi_l - rf
    sf = 2 * rf * theta_f
    cos_m = np.abs(f[:, 1])
    tan_m = np.abs(f[:, 0]) / cos_m
    c = cos_m ** 2 / E * (L * (uf / sf) ** 2 + M * (uf / sf) + Pc * (1 + Q * tan_m ** 2))
    ok = (SAINSOT_RANGE["h_f"][0] <= h_f <= SAINSOT_RANGE["h_f"][1]
          and SAINSOT_RANGE["theta_f"][0] <= theta_f <= SAINSOT_RANGE["theta_f"][1])
    return c, ok


def load_line_depth(gear: InvoluteGear, u):
    """Weber's depth h [m]: from the contact point to the tooth centre line along the load line."""
    P, f = _load(gear, u)
    return np.abs(P[:, 1] / f[:, 1])


@dataclass(frozen=True)
class ToothCompliance:
    """c'(u) [m^2/N] (tooth + foundation, per unit face width) and h(u) [m] of one gear as
    polynomials of degree POLY_DEGREE in t = (u - u_mid) / u_half over the roll range
    [u_mid - u_half, u_mid + u_half]; ``fit_error`` is the largest relative residual at the
    fitting nodes and ``foundation_in_range`` whether Sainsot's fit is used inside its range."""
    u_mid: float
    u_half: float
    compliance_coefficients: tuple
    depth_coefficients: tuple
    fit_error: float
    foundation_in_range: bool

    @classmethod
    def of(cls, gear: InvoluteGear, n_nodes=41):
        lo, hi = gear.involute_range
        # the fitted range reaches the tip (corner contacts are evaluated at the edge start)
        lo, hi = min(lo, gear.tip_roll), max(hi, gear.tip_roll)
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        t = np.cos(np.linspace(np.pi, 0.0, n_nodes))      # Chebyshev nodes: no Runge oscillation
        u = mid + half * t
        cb, cs, ca = beam_compliance(gear, u)
        cf, ok = foundation_compliance(gear, u)
        c = cb + cs + ca + cf
        h = load_line_depth(gear, u)
        pc = np.polynomial.polynomial.polyfit(t, c, POLY_DEGREE)
        ph = np.polynomial.polynomial.polyfit(t, h, POLY_DEGREE)
        err = max(np.max(np.abs(np.polynomial.polynomial.polyval(t, pc) / c - 1)),
                  np.max(np.abs(np.polynomial.polynomial.polyval(t, ph) / h - 1)))
        return cls(mid, half, tuple(pc), tuple(ph), float(err), bool(ok))

    def compliance(self, u):
        return np.polynomial.polynomial.polyval((np.asarray(u) - self.u_mid) / self.u_half, self.compliance_coefficients)


def iso6336_single_stiffness(gear_a: InvoluteGear, gear_b: InvoluteGear):
    """ISO 6336-1 (2006) Method B single stiffness c' [N/(mm um)] of a solid spur pair with
    C_M = 0.8, C_R = 1 and the basic-rack factor C_B, from
    q' = 0.04723 + 0.15551/z_1 + 0.25791/z_2 - 0.00635 x_1 - 0.11654 x_1/z_1 - 0.00193 x_2
         - 0.24188 x_2/z_2 + 0.00529 x_1^2 + 0.00182 x_2^2   [mm um / N],  c'_th = 1/q'.
    An empirical fit to Weber--Banaschek-type calculations, not a measurement."""
    z1, z2, x1, x2 = gear_a.n_teeth, gear_b.n_teeth, gear_a.profile_shift, gear_b.profile_shift
    if gear_b.internal:
        z2 = math.inf
    q = (0.04723 + 0.15551 / z1 + 0.25791 / z2 - 0.00635 * x1 - 0.11654 * x1 / z1 - 0.00193 * x2
         - 0.24188 * x2 / z2 + 0.00529 * x1 ** 2 + 0.00182 * x2 ** 2)
    alpha_deg = math.degrees(gear_a.alpha)
    c_b = (1 + 0.5 * (1.2 - gear_a.rack.dedendum_coefficient)) * (1 - 0.02 * (20.0 - alpha_deg))
    return 0.8 * c_b / q
