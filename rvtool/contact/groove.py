"""A ring pin in its housing groove: the conformal pin-in-hole contact in series with the pin
(issue 30, Deliver 1, first member). Design keys ``[pins] groove = "rigid" | "conformal"`` and
``groove_clearance`` [m] (the radial clearance Delta R = R_groove - r_p > 0).

**Law.** The conformal contact of a pin in a hole of nearly its radius, Persson's problem, solved
numerically and tabulated as one dimensionless curve (:mod:`rvtool.contact.conformal_pin`): the
pin of radius r_p under a line load P = F / l [N/m] approaches its groove (same material, contact
modulus 1/E* = 2 (1 - nu^2) / E) by

    delta(F) = Delta R psi(F / (E* Delta R l))                                         (1)

where psi is the local elastic approach (the groove's net-force, global deformation belongs to the
housing, ``housing.model = "ports"``; the clearance itself is taken up at zero load: the pin sits in
its groove). Hertz's line contact (Johnson's approach, :func:`hertz_approach`) is its small-load
limit and fails where Delta R << r_p: at rv40e's rated torque (largest station load 490 N) the
contact half-angle is 17 deg at Delta R = 5 um, where Hertz's local approach is 1.6 % below (1), and
35 deg at 1 um, where it is 11 % below; at P = E* Delta R it is 50 deg and 35 % below
(``cases/rv/compliance_members.py``).

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
from .conformal_pin import psi, psi_inverse

GROOVE_MODELS = ("rigid", "conformal")

GROOVE_CLEARANCE_RANGE = (1e-7, 1e-3)
"""Valid radial groove clearance [m]: 0.1 um (a press fit is not a clearance: the law needs the pin
to seat under load) to 1 mm (a loose pin, not a groove fit)."""


def hertz_approach(force, clearance, length, contact_modulus):
    """Johnson's two-body centre approach of a pin in a hole, F / (pi l E*) [ln(4 pi l E* Delta R / F)
    - 1] [m] (K. L. Johnson, Contact Mechanics, CUP 1985, Sec. 5.6; the closed form of
    :func:`rvtool.output_pins.calibration.hertz_pin_in_hole_approach`): the Hertz limit the case
    compares (1) with; it includes the net-force mode (ln 4 - 1) F / (pi l E*) that (1) leaves to
    the housing."""
    f = np.asarray(force, float)
    return f / (math.pi * length * contact_modulus) * (np.log(4 * math.pi * length * contact_modulus * clearance / f)
                                                       - 1.0)


@dataclass(frozen=True)
class GrooveLaw:
    """The pin--groove law (1) of one station: radial clearance Delta R [m], length l [m] and
    contact modulus E* [Pa]."""
    clearance: float
    length: float
    contact_modulus: float

    def __post_init__(self):
        check_range("groove_clearance", self.clearance, *GROOVE_CLEARANCE_RANGE)
        check_positive("length", self.length)
        check_positive("contact_modulus", self.contact_modulus)

    @property
    def force_scale(self):
        """F_s = E* Delta R l [N]: (1) is delta / Delta R = psi(F / F_s)."""
        return self.contact_modulus * self.clearance * self.length

    @property
    def zero_load_stiffness(self):
        """dF/d delta at zero load [N/m] (the law's floor, :mod:`rvtool.contact.conformal_pin`)."""
        return self.force_scale / (self.clearance * float(psi(0.0)[1]))

    def approach(self, force):
        """(delta [m], d delta / dF [m/N]) at ``force`` >= 0 [N] (array)."""
        f = np.asarray(force, float)
        if np.any(~np.isfinite(f)) or np.any(f < 0):
            raise RvtoolInputError("groove force must be finite and >= 0 N")
        v, d = psi(f / self.force_scale)
        return self.clearance * v, self.clearance * d / self.force_scale

    def force(self, approach):
        """(F [N], dF/d delta [N/m]) at ``approach`` >= 0 [m] (array): the inverse of (1)."""
        x = psi_inverse(np.asarray(approach, float) / self.clearance)
        _, d = psi(x)
        return self.force_scale * x, self.force_scale / (self.clearance * d)


class GrooveSupport:
    """Nonlinear station law of the pins in their grooves for
    :class:`~rvtool.contact.pin_closure.ElasticPinClosure` (``support=``): every station obeys
    ``law`` isotropically (module docstring)."""

    #: every station's force depends on its own deflection only and vanishes only at zero deflection
    #: (isotropic, s(u) = F(|u|) u/|u|, F(0) = 0): a station that carries no contact force rests at u = 0
    #: exactly, which the joint network uses (:class:`rvtool.contact.pin_closure.JointNetwork`: Newton
    #: reaches that zero only linearly, by a factor ~ ln(Delta R / |u|) per iteration, on the
    #: logarithmic law near zero load)
    isolated_stations = True

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
                     contact_modulus=m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio ** 2)))
