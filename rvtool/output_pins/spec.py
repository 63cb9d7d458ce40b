"""Specification of an output-pin mechanism (plain data, validated on
construction; packed once into the parameter rows of
:mod:`warp_contacts.output_pins_ref`).

The mechanism is one flange carrying ``n_pins`` pins on the pin circle and
one or two wheels whose holes lie on the hole circle (paper, subsection
"Output-pin transfer and a reproducible two-wheel coupling"; inputs of
Table (tab:supp_pin_inputs)). ``mode`` selects the plain rigid-pin contacts
(the "nothing" variant: no sleeve, no shaft compliance) or the shared-pin
condensation with a massless sleeve and the station compliance of Eq.
(pin_compliance).
"""
import math
from dataclasses import dataclass, field
from enum import Enum
from functools import cached_property

import numpy as np

from warp_contacts import anchor_ref
from warp_contacts import output_pins_ref as ref

from ..contact.circle_set import FrictionLaw, FrictionModel
from ..errors import RvtoolInputError
from ..units import angle_field
from ..structure.pin_beam import PinSupport
from ..validation import check_finite, check_nonnegative, check_positive, check_range
from .calibration import PIN_EXPONENT, hertz_calibrated_coefficient, mindlin_tangential_ratio

MAX_SLICES = 64
"""Largest ``n_slices`` (the wheels' bound, :class:`rvtool.assembly.spec.Wheels`: the largest resolution
the solvers are built and tested for; ``output_pins.n_slices = 1000000`` built for minutes)."""
MAX_SLEEVE_UPDATES = 256
"""Largest ``output_pins.sleeve.updates`` (a cost limit, :class:`SleeveFit`: 16 x the default 16)."""


class PinMode(str, Enum):
    """Output-pin contact model."""
    PLAIN = "plain"      # rigid pin, one independent contact per (pin, wheel)
    SHARED = "shared"    # shared pin: sleeve clearance fit and condensed shaft compliance


@dataclass(frozen=True, kw_only=True)
class SharedPinCompliance:
    """Station compliance of the pin shaft at the two wheel stations (Eq. (pin_compliance)).

    self_compliance_0: C_00 [m/N]; self_compliance_1: C_11 [m/N];
    cross_compliance: C_01 [m/N] (multiplied by n_0 . n_1 in C_p);
    inner_compliance: declared inner-contact compliance added to both
    diagonal terms [m/N] (0: inner Hertz indentation omitted).
    """
    self_compliance_0: float
    self_compliance_1: float
    cross_compliance: float = 0.0
    inner_compliance: float = 0.0

    def __post_init__(self):
        check_nonnegative("self_compliance_0", self.self_compliance_0)
        check_nonnegative("self_compliance_1", self.self_compliance_1)
        bound = math.sqrt(self.self_compliance_0 * self.self_compliance_1)
        # a beam compliance matrix is positive semi-definite: |C_01| <= sqrt(C_00 C_11)
        check_range("cross_compliance", self.cross_compliance, -bound, bound)
        check_nonnegative("inner_compliance", self.inner_compliance)


@dataclass(frozen=True, kw_only=True)
class SleeveFit:
    """Massless sleeve in its radial clearance disk and the numerical settings of Eq. (supp_pin_fit).

    clearance: radial clearance c [m]; updates: number of sleeve updates (16);
    relaxation: step factor (0.7) [-]; tangent_floor: floor of K_0 + K_1 in the
    update [N/m]; determinant_floor: floor of det(I + K_c C_p) [-];
    distance_floor: floor of centre distances before normalising [m];
    indentation_floor: d_min of the open tangent, Eq. (pin_open_state) [m].
    """
    clearance: float = 5e-6
    updates: int = 16
    relaxation: float = 0.7
    tangent_floor: float = 1e3
    determinant_floor: float = 1e-12
    distance_floor: float = 1e-9
    indentation_floor: float = 1e-9

    def __post_init__(self):
        check_nonnegative("clearance", self.clearance)
        # upper bound: a cost limit. Every update is a pass over every pin slice in the kernel, its derivative
        # carried through each; the relaxed update converges geometrically (the default 16 reaches the Newton
        # tolerance), so 16 x the default only costs time, and a mistyped 1e6 would run for hours without a word
        if isinstance(self.updates, bool) or not isinstance(self.updates, (int, np.integer)) \
                or not 0 <= self.updates <= MAX_SLEEVE_UPDATES:
            raise RvtoolInputError(f"updates = {self.updates!r} is outside the valid range [0, {MAX_SLEEVE_UPDATES}] "
                                   "(an integer)")
        check_range("relaxation", self.relaxation, 0.0, 2.0, low_open=True, high_open=True)
        check_positive("tangent_floor", self.tangent_floor)
        check_positive("determinant_floor", self.determinant_floor)
        check_positive("distance_floor", self.distance_floor)
        check_positive("indentation_floor", self.indentation_floor)


@dataclass(frozen=True, kw_only=True)
class OutputPinMechanism:
    """Flange pins in wheel holes.

    pin_circle_radius: radius of the pin centres on the flange [m].
    hole_circle_radius: radius of the hole centres on each wheel [m].
    n_pins: number of pins, equally spaced from the first at ``phase``; phase: angle of the first pin [rad].
    pin_radius: outer pin (sleeve) radius r_p [m]; hole_radius: R_h [m] > r_p.
    coefficient: whole-contact coefficient k [N m^-p], or None: k calibrated so that the law
    meets the Hertz pin-in-hole approach at the reference force; :attr:`law_coefficient` is the k
    in use. reference_force: the load [N] at which a coefficient left out is calibrated to the Hertz
    pin-in-hole approach. youngs_modulus: E of pins and
    flange [Pa]. poisson_ratio: nu of pins and flange [-].
    exponent: p [-] (10/9).
    contact_length: axial contact width [m], integrated by ``n_slices`` equal-weight
    midpoint slices (stations s relative to each wheel midplane).
    wheel_midplanes: axial positions z_i of the wheel midplanes relative to the flange [m].
    gap_offsets: u_off of Eq. (output_gap) per wheel [m] (e.g. thermal; positive opens).
    mode: the output-pin model, "plain" or "shared" (:class:`PinMode`). compliance: the pins' station
    compliance of the shared mode [m/N], required there and unused in plain mode (a design file's
    sub-table ``[output_pins.compliance]``: self_compliance_0, self_compliance_1, optional
    cross_compliance and inner_compliance, :class:`SharedPinCompliance`). sleeve: the sleeve
    iteration of the shared mode.
    support: the pin as a beam (:class:`~rvtool.structure.pin_beam.PinSupport`; rigid by default).
    The mechanism's own contacts are those of rigid pins; an elastic pin is closed per pin by the
    assembly (:class:`~rvtool.contact.pin_closure.ElasticPinClosure` with the beam's station
    compliance, :func:`rvtool.assembly.cycloid.build`).
    mu: friction coefficient [-] of the anchor (stick--slip) model per slice (Eq. (friction),
    anchor model; plain mode; 0 = none); tangential_stiffness: k_t [N/m] of the whole pin--hole
    contact, divided among the slices like the coefficient (0 = Mindlin's ratio 2(1 - nu)/(2 - nu)
    of the law's secant stiffness at ``reference_force``); :attr:`friction` is the resulting
    :class:`~rvtool.contact.circle_set.FrictionLaw`. anchor_release_distance: d_rel [m] of
    :mod:`warp_contacts.anchor_ref`; None: 10 % of the pin radius (far above the stick stroke
    mu F_n / k_t, far below a pin).
    """
    pin_circle_radius: float
    hole_circle_radius: float
    n_pins: int = 1
    phase: float = angle_field(0.0)
    pin_radius: float
    hole_radius: float
    coefficient: float | None = None
    reference_force: float = 1000.0
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3
    exponent: float = PIN_EXPONENT
    contact_length: float
    n_slices: int = 4
    wheel_midplanes: tuple = (0.0,)
    gap_offsets: tuple | None = None
    mode: PinMode = PinMode.PLAIN
    compliance: SharedPinCompliance | None = None
    sleeve: SleeveFit = field(default_factory=SleeveFit)
    support: PinSupport = field(default_factory=PinSupport)
    mu: float = 0.0
    tangential_stiffness: float = 0.0
    anchor_release_distance: float | None = None

    def __post_init__(self):
        try:
            object.__setattr__(self, "mode", PinMode(self.mode))
        except ValueError:
            raise RvtoolInputError(f"mode = {self.mode!r} is not valid; valid choices are "
                                   f"{[m.value for m in PinMode]}") from None
        check_positive("pin_circle_radius", self.pin_circle_radius)
        check_positive("hole_circle_radius", self.hole_circle_radius)
        # upper bound 64: more pins than any pin-hole output mechanism carries; a named error, not an hours-long build
        if isinstance(self.n_pins, bool) or not isinstance(self.n_pins, (int, np.integer)) or not 1 <= self.n_pins <= 64:
            raise RvtoolInputError(f"n_pins = {self.n_pins!r} is outside the valid range [1, 64] (an integer)")
        check_finite("phase", self.phase)
        check_positive("pin_radius", self.pin_radius)
        check_range("hole_radius", self.hole_radius, self.pin_radius, math.inf, low_open=True)
        if self.coefficient is not None:
            check_nonnegative("coefficient", self.coefficient)
        check_positive("reference_force", self.reference_force)
        check_positive("youngs_modulus", self.youngs_modulus)
        check_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        check_range("exponent", self.exponent, 1.0)
        check_positive("contact_length", self.contact_length)
        # upper bound: the wheels' (rvtool.assembly.spec.Wheels); a mistyped 1e6 built for minutes instead of failing
        if isinstance(self.n_slices, bool) or not isinstance(self.n_slices, (int, np.integer)) \
                or not 1 <= self.n_slices <= MAX_SLICES:
            raise RvtoolInputError(f"n_slices = {self.n_slices!r} is outside the valid range [1, {MAX_SLICES}] (integer)")
        z = np.asarray(self.wheel_midplanes, dtype=float)
        if z.ndim != 1 or z.size < 1:
            raise RvtoolInputError(f"wheel_midplanes must list one axial position per wheel [m]; got {self.wheel_midplanes!r}")
        check_finite("wheel_midplanes", z)
        object.__setattr__(self, "wheel_midplanes", tuple(float(v) for v in z))
        offs = (0.0,) * z.size if self.gap_offsets is None else tuple(float(v) for v in self.gap_offsets)
        if len(offs) != z.size:
            raise RvtoolInputError(f"gap_offsets has {len(offs)} entries; it must have one per wheel ({z.size})")
        check_finite("gap_offsets", offs)
        object.__setattr__(self, "gap_offsets", offs)
        if self.mode == PinMode.SHARED:
            if z.size != 2:
                raise RvtoolInputError(f"wheel_midplanes has {z.size} entries; the shared-pin mode couples exactly 2 wheels")
            if not isinstance(self.compliance, SharedPinCompliance):
                raise RvtoolInputError(f"mode = 'shared' needs the pins' station compliance, the sub-table "
                                       "[output_pins.compliance] (self_compliance_0, self_compliance_1 [m/N], optional "
                                       f"cross_compliance, inner_compliance); got compliance = {self.compliance!r}")
        if not isinstance(self.sleeve, SleeveFit):
            raise RvtoolInputError(f"sleeve = {self.sleeve!r} must be a SleeveFit")
        if not isinstance(self.support, PinSupport):
            raise RvtoolInputError(f"support = {self.support!r} must be a PinSupport")
        check_nonnegative("mu", self.mu)
        check_nonnegative("tangential_stiffness", self.tangential_stiffness)
        if self.anchors and self.mode == PinMode.SHARED:
            raise RvtoolInputError("mu > 0 (anchor friction) is available for mode = 'plain' only (the shared-pin "
                                   "condensation carries no tangential history)")
        if self.anchor_release_distance is not None:
            check_positive("anchor_release_distance", self.anchor_release_distance)

    @cached_property
    def friction(self):
        """The :class:`FrictionLaw` of the pins: none for mu = 0, else the anchor model with k_t =
        ``tangential_stiffness`` or Mindlin's ratio of the law's secant stiffness F_ref /
        delta(F_ref) at ``reference_force``."""
        if self.mu == 0.0:
            return FrictionLaw()
        k, p, F = self.law_coefficient, self.exponent, self.reference_force
        kt = self.tangential_stiffness or mindlin_tangential_ratio(self.poisson_ratio) * F / (F / k) ** (1.0 / p)
        return FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=self.mu, tangential_stiffness=kt)

    @property
    def anchors(self):
        """True where the pins carry anchors (ANCHOR law with mu > 0)."""
        return self.friction.model == FrictionModel.ANCHOR and self.friction.mu_kinetic > 0.0

    def anchor_params(self):
        """(n_pins n_wheels n_slices, anchor_ref.N_ANCHOR) anchor columns of the slice rows, in the
        order of the plain rows' slice observations."""
        n = self.n_pins * self.n_wheels * self.n_slices
        ap = np.zeros((n, anchor_ref.N_ANCHOR))
        ap[:, anchor_ref.ANCHOR_KT] = self.friction.tangential_stiffness / self.n_slices
        ap[:, anchor_ref.ANCHOR_MU] = self.friction.mu_kinetic
        ap[:, anchor_ref.ANCHOR_RELEASE] = (0.1 * self.pin_radius if self.anchor_release_distance is None
                                            else self.anchor_release_distance)
        return ap

    @property
    def n_wheels(self):
        return len(self.wheel_midplanes)

    @cached_property
    def law_coefficient(self):
        """k [N m^-p] of the contact law: ``coefficient``, or the Hertz calibration at
        ``reference_force`` over ``contact_length`` where it is None."""
        if self.coefficient is not None:
            return self.coefficient
        return hertz_calibrated_coefficient(self.reference_force, self.pin_radius, self.hole_radius,
                                            self.contact_length, self.youngs_modulus, self.poisson_ratio,
                                            exponent=self.exponent)

    @property
    def stations(self):
        """Midpoint slice stations s relative to each wheel midplane [m] (equal weights)."""
        w = self.contact_length / self.n_slices
        return -0.5 * self.contact_length + w * (np.arange(self.n_slices) + 0.5)

    def pin_angles(self):
        return self.phase + 2.0 * np.pi * np.arange(self.n_pins) / self.n_pins

    def packed(self, flange=0, wheels=None):
        """(fparams, iparams) rows of :mod:`warp_contacts.output_pins_ref` for the given body indices.

        Shared mode: one row per pin (N_SHARED_F, N_SHARED_I). Plain mode: one row per
        (pin, wheel) pair, pins outer (N_PLAIN_F, N_PLAIN_I).
        """
        wheels = tuple(range(1, self.n_wheels + 1)) if wheels is None else tuple(wheels)
        if len(wheels) != self.n_wheels:
            raise RvtoolInputError(f"wheels has {len(wheels)} body indices; the mechanism has {self.n_wheels} wheels")
        ang = self.pin_angles()
        xp = self.pin_circle_radius * np.column_stack([np.cos(ang), np.sin(ang)])
        xh = self.hole_circle_radius * np.column_stack([np.cos(ang), np.sin(ang)])
        if self.mode == PinMode.SHARED:
            fp = np.zeros((self.n_pins, ref.N_SHARED_F))
            ip = np.zeros((self.n_pins, ref.N_SHARED_I), dtype=np.int32)
            fp[:, ref.P_XI_PIN:ref.P_XI_PIN + 2] = xp
            fp[:, ref.P_XI_HOLE0:ref.P_XI_HOLE0 + 2] = xh
            fp[:, ref.P_XI_HOLE1:ref.P_XI_HOLE1 + 2] = xh
            fp[:, ref.P_R_PIN], fp[:, ref.P_R_HOLE] = self.pin_radius, self.hole_radius
            fp[:, ref.P_OFF0], fp[:, ref.P_OFF1] = self.gap_offsets
            fp[:, ref.P_K], fp[:, ref.P_EXP] = self.law_coefficient, self.exponent
            fp[:, ref.P_Z0], fp[:, ref.P_Z1] = self.wheel_midplanes
            c = self.compliance
            fp[:, ref.P_C00], fp[:, ref.P_C11] = c.self_compliance_0, c.self_compliance_1
            fp[:, ref.P_C01], fp[:, ref.P_CIN] = c.cross_compliance, c.inner_compliance
            s = self.sleeve
            fp[:, ref.P_CLEAR], fp[:, ref.P_RELAX], fp[:, ref.P_KFLOOR] = s.clearance, s.relaxation, s.tangent_floor
            fp[:, ref.P_DETFLOOR], fp[:, ref.P_DISTFLOOR] = s.determinant_floor, s.distance_floor
            fp[:, ref.P_DMIN] = s.indentation_floor
            ip[:, ref.I_FLANGE], ip[:, ref.I_WHEEL0], ip[:, ref.I_WHEEL1] = flange, wheels[0], wheels[1]
            ip[:, ref.I_UPDATES] = s.updates
            return fp, ip
        n = self.n_pins * self.n_wheels
        fp = np.zeros((n, ref.N_PLAIN_F))
        ip = np.zeros((n, ref.N_PLAIN_I), dtype=np.int32)
        for k in range(n):
            pin, w = divmod(k, self.n_wheels)
            fp[k, ref.Q_XI_PIN:ref.Q_XI_PIN + 2] = xp[pin]
            fp[k, ref.Q_XI_HOLE:ref.Q_XI_HOLE + 2] = xh[pin]
            fp[k, ref.Q_R_PIN], fp[k, ref.Q_R_HOLE] = self.pin_radius, self.hole_radius
            fp[k, ref.Q_OFF], fp[k, ref.Q_K], fp[k, ref.Q_EXP] = self.gap_offsets[w], self.law_coefficient, self.exponent
            fp[k, ref.Q_Z], fp[k, ref.Q_DISTFLOOR] = self.wheel_midplanes[w], self.sleeve.distance_floor
            ip[k, ref.J_FLANGE], ip[k, ref.J_WHEEL] = flange, wheels[w]
        return fp, ip


def shared_pin_study_mechanism(cross_compliance=0.0, **overrides):
    """The shared-pin inputs of Table (tab:supp_pin_inputs) (one pin, two wheels).

    R = 35 mm, r_p = 1.50 mm, R_h = 1.55 mm, k = 2e8 N m^-10/9, 6 mm contact width
    in four midpoint slices, z_0 = -3 mm, z_1 = 3 mm, C_00 = C_11 = 1.5e-9 m/N,
    C_01 = ``cross_compliance`` (0 or 0.9e-9 m/N), 5 um clearance, no inner compliance.
    """
    kw = dict(pin_circle_radius=35e-3, hole_circle_radius=35e-3, n_pins=1, phase=0.0, pin_radius=1.50e-3,
              hole_radius=1.55e-3, coefficient=2e8, exponent=PIN_EXPONENT, contact_length=6e-3, n_slices=4,
              wheel_midplanes=(-3e-3, 3e-3), mode=PinMode.SHARED,
              compliance=SharedPinCompliance(self_compliance_0=1.5e-9, self_compliance_1=1.5e-9,
                                             cross_compliance=cross_compliance),
              sleeve=SleeveFit())
    kw.update(overrides)
    return OutputPinMechanism(**kw)


@dataclass(frozen=True, kw_only=True)
class ExplicitSleeveInterface:
    """Explicit sleeve with its own coordinates: inner (shaft-to-sleeve) contact settings.

    clearance: radial clearance between shaft and sleeve bore [m];
    inner_coefficient: whole inner-contact coefficient k_in per wheel station
    [N m^-p], spread over the slices like the outer law; inner_exponent: p_in [-];
    tolerance: Newton tolerance of the flexible interface on the approaches [m];
    max_iterations: Newton iterations of the interface solve.
    """
    clearance: float = 5e-6
    inner_coefficient: float
    inner_exponent: float = PIN_EXPONENT
    tolerance: float = 1e-15
    max_iterations: int = 60

    def __post_init__(self):
        check_nonnegative("clearance", self.clearance)
        check_positive("inner_coefficient", self.inner_coefficient)
        check_range("inner_exponent", self.inner_exponent, 1.0)
        check_positive("tolerance", self.tolerance)
        if not isinstance(self.max_iterations, (int, np.integer)) or self.max_iterations < 1:
            raise RvtoolInputError(f"max_iterations = {self.max_iterations!r} is outside the valid range [1, inf)")
