"""A ring pin in its housing groove: the conformal pin-in-hole contact in series with the pin
(issue 30, Deliver 1, first member). Design keys ``[pins] groove = "rigid" | "conformal"`` and
``groove_clearance`` [m] (the radial clearance Delta R = R_groove - r_p > 0).

**Law.** A pin of radius r_p pressed by a line load P = F / l [N/m] into a groove of radius
r_p + Delta R of the same material (contact modulus 1/E* = 2 (1 - nu^2)/E) approaches the groove
by the sum of Johnson's two-dimensional centre approaches of the two bodies,

    delta(F) = F / (pi l E*) [ln(4 pi l E* Delta R / F) - 1]                        (1)

(K. L. Johnson, Contact Mechanics, Cambridge University Press 1985, Sec. 5.6: the approach of a
line-loaded cylinder's axis, P (1 - nu^2)/(pi E) (2 ln(4 R / a) - 1), with the Hertz half-width
a = sqrt(4 P R / (pi E*)), 1/R = 1/r_p - 1/(r_p + Delta R); summed over pin and hole the radii
combine to ln(4 pi E* Delta R / P); the "Johnson" internal-contact model of Pereira, Ramalho and
Ambrosio, Nonlinear Dyn. 63 (2011) 681-697, and the closed form this project already uses for the
output pins, :func:`rvtool.output_pins.calibration.hertz_pin_in_hole_approach`). With the force
scale F_c = 4 pi l E* Delta R and x = F / F_c, (1) reads delta = 4 Delta R h(x) with
h(x) = x (-ln x - 1), h'(x) = -ln x - 2.

Validity. (1) is Hertz's: it holds while the contact half-angle eps = a / r_p is small. It is
NOT Persson's conformal solution (Persson 1964; closed form by Ciavarella and Decuzzi, Int. J.
Solids Struct. 38 (2001) 4507-4523), which corrects the Hertz relation where Delta R << r_p and
eps grows to tens of degrees; that solution could not be retrieved for this work, so the law is
the Hertz-based closed form and :func:`contact_half_angle` reports eps with every use (the case
states it at the rated pin loads). The law is monotone only while h' > 0 (x < e^-2); it is used
on x in (x_lo, x_hi] = (e^-12, e^-3] and continued C^1 outside that interval:

- x <= x_lo: h = 12 x - x^2 / x_lo (value and slope of (1) at x_lo; finite stiffness F_c / (48 Delta R)
  at zero load, where (1)'s logarithm gives none: a pin at 6e-6 F_c carries no torque worth a
  figure, and the closure needs a regular tangent);
- x > x_hi: h = x + x_hi (the tangent of (1) at x_hi, slope 1: eps at x_hi is reported; beyond it
  the contact is conformal and the law is an extrapolation, which the case flags).

**Station law.** Each (pin, wheel) station carries the groove over the wheel's width l (the pin's
bending between the stations and any spreading of the load beyond the wheel are neglected: the
conservative, more compliant reading). The groove is taken as a full hole (isotropic): the station
force is s(u) = F(|u|) u/|u| with the tangent F'(r) e e^T + F(r)/r (I - e e^T), e = u/|u|; the wheel
pushes every ring pin outward into its groove, within the groove's half circle.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_positive, check_range

X_LO = math.exp(-12.0)
"""Lower end of (1)'s use, x = F / F_c (module docstring)."""
X_HI = math.exp(-3.0)
"""Upper end of (1)'s use (h' = 1 there)."""

GROOVE_MODELS = ("rigid", "conformal")

GROOVE_CLEARANCE_RANGE = (1e-7, 1e-3)
"""Valid radial groove clearance [m]: 0.1 um (below it the law's force scale F_c makes the contact
conformal at any load) to 1 mm (a loose pin, not a groove fit)."""


def shape(x):
    """(h(x), h'(x)) of the continued law (module docstring), x = F / F_c >= 0 (array)."""
    x = np.asarray(x, float)
    lo, hi = x <= X_LO, x > X_HI
    mid = ~(lo | hi)
    xm = np.where(mid, x, 1.0)
    lnx = np.log(xm)
    h = np.where(mid, xm * (-lnx - 1.0), 0.0)
    dh = np.where(mid, -lnx - 2.0, 0.0)
    h = np.where(lo, 12.0 * x - x * x / X_LO, h)
    dh = np.where(lo, 12.0 - 2.0 * x / X_LO, dh)
    h = np.where(hi, x + X_HI, h)
    dh = np.where(hi, 1.0, dh)
    return h, dh


def inverse_shape(y, tol=1e-15, max_iterations=80):
    """x >= 0 with h(x) = y >= 0 (array): closed forms on the two continuations, Newton on (1)
    (h concave increasing there: from a point left of the root every step stays left and rises
    monotonically to it)."""
    y = np.asarray(y, float)
    if np.any(~np.isfinite(y)) or np.any(y < 0):
        raise RvtoolInputError("groove approach must be finite and >= 0 (the station law is evaluated at |u|)")
    y_lo, y_hi = 11.0 * X_LO, 2.0 * X_HI
    # the smaller root of x^2 - 12 x_lo x + x_lo y = 0 in the cancellation-free form (product of the roots)
    x = np.where(y <= y_lo, X_LO * y / (6.0 * X_LO + np.sqrt(np.maximum(36.0 * X_LO ** 2 - X_LO * y, 0.0))), 0.0)
    x = np.where(y >= y_hi, y - X_HI, x)
    mid = (y > y_lo) & (y < y_hi)
    if np.any(mid):
        ym = y[mid]
        xm = np.full(ym.shape, X_LO)
        for _ in range(max_iterations):
            h, dh = shape(xm)
            step = (ym - h) / dh
            xm = np.minimum(xm + step, X_HI)
            if np.all(np.abs(step) <= tol * xm):
                break
        # round-off can hold the last step a few ulps above tol; the residual decides
        h, _ = shape(xm)
        if not np.all(np.abs(h - ym) <= 1e-13 * ym):
            raise RvtoolInputError("groove law inversion did not converge (internal error)")
        x = np.array(x)
        x[mid] = xm
    return x


@dataclass(frozen=True)
class GrooveLaw:
    """The pin--groove law (1) of one station: radial clearance Delta R [m], length l [m], contact
    modulus E* [Pa] and pin radius r_p [m] (for the contact half-angle only)."""
    clearance: float
    length: float
    contact_modulus: float
    pin_radius: float

    def __post_init__(self):
        check_range("groove_clearance", self.clearance, *GROOVE_CLEARANCE_RANGE)
        check_positive("length", self.length)
        check_positive("contact_modulus", self.contact_modulus)
        check_positive("pin_radius", self.pin_radius)

    @property
    def force_scale(self):
        """F_c = 4 pi l E* Delta R [N]."""
        return 4.0 * math.pi * self.length * self.contact_modulus * self.clearance

    @property
    def zero_load_stiffness(self):
        """dF/d delta at zero load [N/m] of the continued law: F_c / (48 Delta R)."""
        return self.force_scale / (48.0 * self.clearance)

    def approach(self, force):
        """(delta [m], d delta / dF [m/N]) at ``force`` >= 0 [N] (array)."""
        f = np.asarray(force, float)
        if np.any(~np.isfinite(f)) or np.any(f < 0):
            raise RvtoolInputError("groove force must be finite and >= 0 N")
        h, dh = shape(f / self.force_scale)
        return 4.0 * self.clearance * h, 4.0 * self.clearance * dh / self.force_scale

    def force(self, approach):
        """(F [N], dF/d delta [N/m]) at ``approach`` >= 0 [m] (array): the inverse of (1)."""
        x = inverse_shape(np.asarray(approach, float) / (4.0 * self.clearance))
        _, dh = shape(x)
        return self.force_scale * x, self.force_scale / (4.0 * self.clearance * dh)

    def contact_half_angle(self, force):
        """Hertz contact half-angle eps = a / r_p [rad] at ``force`` [N] (array): a = sqrt(4 P R /
        (pi E*)), 1/R = 1/r_p - 1/(r_p + Delta R). Where it is tens of degrees Hertz's relation
        (1) is outside its assumptions (module docstring)."""
        R = self.pin_radius * (self.pin_radius + self.clearance) / self.clearance
        P = np.asarray(force, float) / self.length
        return np.sqrt(4.0 * P * R / (math.pi * self.contact_modulus)) / self.pin_radius


class GrooveSupport:
    """Nonlinear station law of the pins in their grooves for
    :class:`~rvtool.contact.pin_closure.ElasticPinClosure` (``support=``): every station obeys
    ``law`` isotropically (module docstring)."""

    def __init__(self, law: GrooveLaw):
        self.law = law
        self.zero_load_stiffness = law.zero_load_stiffness

    def forces(self, u):
        """(s (n_pins, n_s, 2) [N], ds/du (n_pins, 2 n_s, 2 n_s) [N/m]) at deflections u
        (n_pins, n_s, 2) [m]."""
        u = np.asarray(u, float)
        n_p, n_s, _ = u.shape
        r = np.sqrt(np.einsum("psi,psi->ps", u, u))
        F, dF = self.law.force(r)
        k0 = self.zero_load_stiffness
        small = r <= 1e-300
        rs = np.where(small, 1.0, r)
        e = u / rs[..., None]
        secant = np.where(small, k0, F / rs)
        s = secant[..., None] * u
        ee = np.einsum("psi,psj->psij", e, e)
        I2 = np.eye(2)
        blk = dF[..., None, None] * ee + secant[..., None, None] * (I2 - ee)
        blk = np.where(small[..., None, None], k0 * I2, blk)
        G = np.zeros((n_p, 2 * n_s, 2 * n_s))
        for k in range(n_s):
            G[:, 2 * k:2 * k + 2, 2 * k:2 * k + 2] = blk[:, k]
        return s, G


def groove_law(design):
    """The :class:`GrooveLaw` of a design's ring pins (``[pins] groove = "conformal"``), or None for
    ``"rigid"``: length = ``wheels.width``, E* of pin and housing from ``[material]``."""
    p = design.pins
    if p.groove == "rigid":
        return None
    m = design.material
    return GrooveLaw(clearance=p.groove_clearance, length=design.wheels.width,
                     contact_modulus=m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio ** 2)),
                     pin_radius=p.pin_radius + p.radius_error)
