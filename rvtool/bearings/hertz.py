"""Contact constants of rolling elements: Hertz point contacts of a ball on
its two raceways, and Palmgren's line-contact law of a roller.

Ball (paper, after Eq. (ball_bearing)): each race contact obeys
Q = K delta^(3/2). The relative radii of curvature at contact angle alpha
(Harris & Kotzalas, *Rolling Bearing Analysis*, 5th ed. 2007, vol. 1, ch. 2;
gamma = D cos(alpha) / d_m) are

    inner: R_x = D (1 - gamma) / 2,   R_y = f_i D / (2 f_i - 1),
    outer: R_x = D (1 + gamma) / 2,   R_y = f_o D / (2 f_o - 1),

and K follows from Hertz theory. ``method="hamrock_brewe"`` (the one the
kernels use, closed form and differentiable) takes the curve fits of
Brewe & Hamrock (1977, J. Lubr. Technol. 99:485) and Hamrock & Brewe (1983,
J. Lubr. Technol. 105:171) for the ellipticity and the elliptic integrals;
``method="exact"`` solves Hertz's ellipticity equation with the complete
elliptic integrals (Harris & Kotzalas, ch. 6, Eqs. 6.26-6.36):

    F(rho) = [(kappa^2 + 1) E(e) - 2 K(e)] / [(kappa^2 - 1) E(e)],
    delta = (delta*/2) (3 Q / (Sigma rho E'))^(2/3) Sigma rho,
    delta* = (2 K(e) / pi) (pi / (2 kappa^2 E(e)))^(1/3),  e^2 = 1 - 1/kappa^2.

The two contacts carry the same load and combine as
K = (K_i^(-2/3) + K_o^(-2/3))^(-3/2).

Roller (Palmgren 1959, as given by Harris & Kotzalas ch. 6):
delta = 3.84e-5 Q^0.9 / l^0.8 [mm, N, mm] per raceway contact of a steel
roller of effective length l; inner and outer contacts in series double the
approach, so a roller carries Q = k delta^(10/9) with
k = l^(8/9) / (2 * 3.84e-5)^(10/9) [N mm^-10/9].
"""
from dataclasses import dataclass

import numpy as np

from warp_contacts.rolling_elements_ref import HB_K_COEF, HB_K_EXP, hertz_point_stiffness

from ..validation import check_choice, check_positive, check_range

HERTZ_METHODS = ("hamrock_brewe", "exact")
#: Palmgren's line-contact approach coefficient of one steel roller--raceway contact [mm N^-0.9 mm^0.8].
PALMGREN_LINE = 3.84e-5


def effective_modulus(youngs_modulus, poisson_ratio):
    """E' = 2 / [(1 - nu^2)/E + (1 - nu^2)/E] = E / (1 - nu^2) [Pa] of two bodies of one material."""
    return youngs_modulus / (1.0 - poisson_ratio ** 2)


def race_radii(ball_diameter, pitch_diameter, contact_angle, inner_curvature, outer_curvature):
    """(R_x, R_y) [m] of the inner and of the outer ball--race contact at ``contact_angle`` [rad]."""
    D = ball_diameter
    g = D * np.cos(contact_angle) / pitch_diameter
    return ((0.5 * D * (1 - g), inner_curvature * D / (2 * inner_curvature - 1)),
            (0.5 * D * (1 + g), outer_curvature * D / (2 * outer_curvature - 1)))


def hertz_exact(rx, ry, e_eff):
    """K [N m^-3/2] and ellipticity kappa = a/b of one point contact from the complete elliptic
    integrals (Harris & Kotzalas ch. 6), for R_x <= R_y [m] and effective modulus E' [Pa]."""
    from scipy.optimize import brentq
    from scipy.special import ellipe, ellipk
    srho = 1.0 / rx + 1.0 / ry
    frho = (1.0 / rx - 1.0 / ry) / srho

    def residual(kappa):
        m = 1.0 - 1.0 / kappa ** 2
        E, K = ellipe(m), ellipk(m)
        return ((kappa ** 2 + 1) * E - 2 * K) / ((kappa ** 2 - 1) * E) - frho

    kappa = brentq(residual, 1.0 + 1e-9, 1e3, xtol=1e-14, rtol=1e-14)
    m = 1.0 - 1.0 / kappa ** 2
    dstar = 2 * ellipk(m) / np.pi * (np.pi / (2 * kappa ** 2 * ellipe(m))) ** (1 / 3)
    delta_unit = 0.5 * dstar * (3.0 / (srho * e_eff)) ** (2 / 3) * srho      # approach at Q = 1 N
    return delta_unit ** -1.5, kappa


@dataclass(frozen=True, kw_only=True)
class HertzConstants:
    """Load--deflection constants of one ball, Q = K delta^(3/2) (all in N m^-3/2).

    inner, outer: K_i, K_o of the two race contacts; combined: K of the ball
    (both contacts in series); inner_ellipticity, outer_ellipticity: a/b [-].
    """
    inner: float
    outer: float
    combined: float
    inner_ellipticity: float
    outer_ellipticity: float


def hertz_constants(*, ball_diameter, pitch_diameter, contact_angle, inner_curvature, outer_curvature,
                    youngs_modulus, poisson_ratio, method="hamrock_brewe"):
    """Hertz constants of a ball between its raceways at ``contact_angle`` [rad] (see the module
    docstring): ball_diameter D [m], pitch_diameter d_m [m], groove curvature ratios f_i, f_o
    (> 0.5), youngs_modulus E [Pa], poisson_ratio nu; method "hamrock_brewe" or "exact".

    Example (RD-40 main bearing): ``hertz_constants(ball_diameter=7.938e-3, pitch_diameter=0.068,
    contact_angle=math.radians(25), inner_curvature=0.52, outer_curvature=0.52,
    youngs_modulus=206e9, poisson_ratio=0.3)``.
    """
    check_positive("ball_diameter", ball_diameter)
    check_range("pitch_diameter", pitch_diameter, ball_diameter, np.inf, low_open=True)
    check_range("contact_angle", contact_angle, 0.0, np.pi / 2, high_open=True)
    check_range("inner_curvature", inner_curvature, 0.5, 1.0, low_open=True)
    check_range("outer_curvature", outer_curvature, 0.5, 1.0, low_open=True)
    check_positive("youngs_modulus", youngs_modulus)
    check_range("poisson_ratio", poisson_ratio, 0.0, 0.5, high_open=True)
    check_choice("method", method, HERTZ_METHODS)
    e_eff = effective_modulus(youngs_modulus, poisson_ratio)
    (rxi, ryi), (rxo, ryo) = race_radii(ball_diameter, pitch_diameter, contact_angle, inner_curvature,
                                        outer_curvature)
    if method == "exact":
        (ki, ei), (ko, eo) = hertz_exact(rxi, ryi, e_eff), hertz_exact(rxo, ryo, e_eff)
    else:
        ki, ko = hertz_point_stiffness(rxi, ryi, e_eff)[0], hertz_point_stiffness(rxo, ryo, e_eff)[0]
        ei, eo = HB_K_COEF * (ryi / rxi) ** HB_K_EXP, HB_K_COEF * (ryo / rxo) ** HB_K_EXP
    combined = (ki ** (-2 / 3) + ko ** (-2 / 3)) ** -1.5
    return HertzConstants(inner=float(ki), outer=float(ko), combined=float(combined), inner_ellipticity=float(ei),
                          outer_ellipticity=float(eo))


def roller_stiffness(roller_length):
    """k [N m^-10/9] of one steel roller of effective length l [m] on both raceways,
    Q = k delta^(10/9) (Palmgren, both contacts in series)."""
    check_positive("roller_length", roller_length)
    k_mm = (roller_length * 1e3) ** (8 / 9) / (2 * PALMGREN_LINE) ** (10 / 9)
    return k_mm * 1e3 ** (10 / 9)
