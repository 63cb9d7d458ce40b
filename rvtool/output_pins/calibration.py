"""Calibration of the output-pin power law k [d]_+^{10/9} from a Hertz
reference load (paper, below Eq. (pin_open_state)):

    k = F_ref / delta_ref^{10/9},

which preserves the units N m^{-10/9} and reproduces F_ref exactly at the
reference approach delta_ref.

Reference approach. A pin (sleeve) of radius r_p in a hole of radius R_h
over a contact length l is a conformal two-dimensional Hertz contact. With
the line load P = F/l, the contact modulus 1/E* = (1 - nu_1^2)/E_1 +
(1 - nu_2^2)/E_2 and the radial clearance Delta R = R_h - r_p,

    delta_ref = F / (pi l E*) [ln(4 pi l E* Delta R / F) - 1].

This is the sum of Johnson's two-dimensional centre approaches of the two
bodies, P (1 - nu_k^2)/(pi E_k) (2 ln(4 R_k / a) - 1) with the contact
half-width a = sqrt(4 P R / (pi E*)) and 1/R = 1/r_p - 1/R_h (K. L. Johnson,
Contact Mechanics, Cambridge University Press 1985, Sec. 5.6, line-loaded
cylinders; the conformal case takes the hole as a cylinder of radius
-R_h). Summed, the radii combine to ln(4 pi E* Delta R / P). The same closed
form is the "Johnson" internal cylindrical contact model reviewed by Pereira,
Ramalho and Ambrosio, Nonlinear Dynamics 63 (2011) 681-697. It is valid
while the logarithm's argument exceeds e (a contact width small against the
radii); the function raises outside that range instead of returning a
negative approach.
"""
import math

from ..errors import RvtoolInputError
from ..validation import check_positive, check_range

PIN_EXPONENT = 10.0 / 9.0
"""Exponent p of the output-pin law (Eq. (pin_open_state))."""


def contact_modulus(youngs_modulus, poisson_ratio, youngs_modulus_2=None, poisson_ratio_2=None):
    """E* [Pa] of two elastic bodies; the second defaults to the first material."""
    e1 = check_positive("youngs_modulus", youngs_modulus)
    n1 = check_range("poisson_ratio", poisson_ratio, -1.0, 0.5, low_open=True, high_open=True)
    e2 = e1 if youngs_modulus_2 is None else check_positive("youngs_modulus_2", youngs_modulus_2)
    n2 = n1 if poisson_ratio_2 is None else check_range("poisson_ratio_2", poisson_ratio_2, -1.0, 0.5,
                                                        low_open=True, high_open=True)
    return 1.0 / ((1.0 - n1 * n1) / e1 + (1.0 - n2 * n2) / e2)


def hertz_pin_in_hole_approach(force, pin_radius, hole_radius, length, youngs_modulus, poisson_ratio,
                               youngs_modulus_2=None, poisson_ratio_2=None):
    """Reference approach delta_ref [m] of a pin in a hole under ``force`` [N] (module docstring).

    pin_radius r_p [m] < hole_radius R_h [m]; length l [m]; youngs_modulus [Pa],
    poisson_ratio [-] (second body defaults to the same material).
    """
    check_positive("force", force)
    check_positive("pin_radius", pin_radius)
    check_range("hole_radius", hole_radius, pin_radius, math.inf, low_open=True)
    check_positive("length", length)
    es = contact_modulus(youngs_modulus, poisson_ratio, youngs_modulus_2, poisson_ratio_2)
    dr = hole_radius - pin_radius
    arg = 4.0 * math.pi * length * es * dr / force
    if arg <= math.e:
        f_max = 4.0 * math.pi * length * es * dr / math.e
        raise RvtoolInputError(f"force = {force} N is outside the valid range (0, {f_max:.6g}] N of the conformal "
                               "line-contact approach for this clearance and length (ln argument must exceed e)")
    return force / (math.pi * length * es) * (math.log(arg) - 1.0)


def calibrate_pin_coefficient(reference_force, reference_approach, exponent=PIN_EXPONENT):
    """Whole-contact coefficient k = F_ref / delta_ref^p [N m^-p] (p = 10/9 by default)."""
    check_positive("reference_force", reference_force)
    check_positive("reference_approach", reference_approach)
    check_range("exponent", exponent, 1.0)
    return reference_force / reference_approach ** exponent


def hertz_calibrated_coefficient(reference_force, pin_radius, hole_radius, length, youngs_modulus, poisson_ratio,
                                 youngs_modulus_2=None, poisson_ratio_2=None, exponent=PIN_EXPONENT):
    """k [N m^-p] calibrated at the Hertz reference load: F_ref / delta_ref(F_ref)^p."""
    delta = hertz_pin_in_hole_approach(reference_force, pin_radius, hole_radius, length, youngs_modulus,
                                       poisson_ratio, youngs_modulus_2, poisson_ratio_2)
    return calibrate_pin_coefficient(reference_force, delta, exponent)


def mindlin_tangential_ratio(poisson_ratio):
    """k_t / k_n = 2 (1 - nu) / (2 - nu) of two elastic bodies of one material (Mindlin's
    tangential compliance of a Hertz contact; 0.82 for steel): the default anchor stiffness
    relative to the contact's normal secant stiffness."""
    return 2.0 * (1.0 - poisson_ratio) / (2.0 - poisson_ratio)
