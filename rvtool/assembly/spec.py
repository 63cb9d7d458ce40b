"""Cycloid reducer specification: one tree of component specs loaded from a design file.

Every section of a design file IS a component spec (frozen dataclass, SI units, validated on
construction): ``[material]`` an :class:`~rvtool.structure.ElasticMaterial`, ``[profile]`` a
:class:`~rvtool.geometry.cycloid.CycloidProfile`, ``[output_pins]``
an :class:`~rvtool.output_pins.spec.OutputPinMechanism`, ``[eccentric_bearing]`` a
:class:`~rvtool.bearings.spec.NeedleBearing`, ``[main_bearing]`` / ``[input_bearing]`` a
:class:`~rvtool.bearings.spec.BallBearing` or :class:`~rvtool.bearings.spec.AngularContactPair`
(by ``kind``), ``[housing.structure]`` an :class:`~rvtool.structure.AnnularHousingSpec`, and
``[pins]`` (the ring), ``[wheels]``, ``[pin_contact]``, ``[bodies]``, ``[housing]`` the classes
below. The file's keys are the spec's field names (a sub-table is a nested spec); no code copies
fields from one spec into another. Three loader rules, all in :func:`build_section` and :func:`design_from_dict`:

* units: the file is SI except angles, which it gives in degrees under the field name plus
  ``_deg`` (``phases_deg``, ``contact_angle_deg``, ``phase_deg``); :func:`build_section` converts
  them to the field [rad] (the only place a unit is converted);
* links (:data:`LINKS`): a key that another section already states (the profile's pin circle, the
  output pins' contact length = the wheel width, ...) may be left out and then takes that value,
  so the file states each quantity once (material constants of a component default to
  ``[material]``); :data:`DERIVED` keys follow from a section's own (none for the cycloid);
* a ``kind`` key selects the spec class of a bearing section (:data:`BEARING_KINDS`); an
  angular-contact pair's section lists the pair's keys and its (identical) rows' keys.

Validation errors name the key path in the file (``main_bearing.ball_diameter``) and the valid
range. A design keeps its file-form data (:attr:`CycloidDesign.source`), so :func:`replace`
re-loads the changed data and the links follow a change (e.g. of the wheel width).
"""
import copy
import dataclasses
import math
import numbers
import re
import typing
from dataclasses import dataclass, field

import numpy as np

from ..bearings.spec import AngularContactPair, BallBearing, CrossedRollerBearing, NeedleBearing
from ..geometry.cycloid import CycloidProfile
from ..output_pins.spec import OutputPinMechanism
from ..errors import RvtoolInputError
from ..units import angle_columns, angle_field, file_key, is_angle
from ..structure import AnnularHousingSpec, ElasticMaterial
from ..structure.pin_beam import PinSupport
from ..structure.fe_model import MAX_PORTS, MAX_STRUCTURE_MODES
from ..structure.floating_ports import FloatingDynamics
from ..structure.wheel_body import WheelBodySpec
from ..validation import check_finite, check_integer, check_nonnegative, check_positive, check_range

COORDS = ("x", "y", "theta")


@dataclass(frozen=True, kw_only=True)
class Pins:
    """Ring pins.

    n_pins: z_b, the number of ring pins [-]. pin_circle_radius: R_z [m]. pin_radius: r_p, the
    generating radius of the wheel profile [m]. Manufacturing deviations (part of the design, so a
    variant is a design): radius_error: the actual pin radius minus r_p [m]; centre_errors: None
    or (z_b, 2) pin-centre errors in the housing frame [m]. support: the pin as a beam
    (:class:`~rvtool.structure.pin_beam.PinSupport`, sub-table ``[pins.support]``; rigid by default).
    groove: the pin in its housing groove, "rigid" (the default: today's figures) or "conformal"
    (the pin--groove contact law of :mod:`rvtool.contact.groove` in series with the pin; RV
    topology); groove_clearance: its radial clearance Delta R [m] (required for "conformal")."""
    n_pins: int
    pin_circle_radius: float
    pin_radius: float
    radius_error: float = 0.0
    centre_errors: tuple | None = None
    support: PinSupport = field(default_factory=PinSupport)
    groove: str = "rigid"
    groove_clearance: float | None = None

    def __post_init__(self):
        if not isinstance(self.n_pins, int) or self.n_pins < 3:
            raise RvtoolInputError(f"pins.n_pins = {self.n_pins!r} is outside the valid range [3, inf) (integer)")
        check_positive("pins.pin_circle_radius", self.pin_circle_radius)
        check_positive("pins.pin_radius", self.pin_radius)
        check_range("pins.radius_error", self.radius_error, -self.pin_radius, math.inf, low_open=True)
        if self.centre_errors is not None:
            e = np.asarray(self.centre_errors, float)
            if e.shape != (self.n_pins, 2):
                raise RvtoolInputError(f"pins.centre_errors must have shape ({self.n_pins}, 2) (one (x, y) per pin); "
                                       f"got {e.shape}")
            check_finite("pins.centre_errors", e)
        if self.groove not in ("rigid", "conformal"):
            raise RvtoolInputError(f"pins.groove = {self.groove!r}; valid choices are ['rigid', 'conformal']")
        if self.groove_clearance is not None:
            from ..contact.groove import GROOVE_CLEARANCE_RANGE
            check_range("pins.groove_clearance", self.groove_clearance, *GROOVE_CLEARANCE_RANGE)
        elif self.groove == "conformal":
            raise RvtoolInputError("pins.groove_clearance is required for pins.groove = 'conformal' (the radial "
                                   "clearance of the pin in its groove [m], valid range [1e-07, 0.001])")


@dataclass(frozen=True, kw_only=True)
class Wheels:
    """Cycloid wheels.

    eccentricity: assembly eccentricity e of the journals [m] (the profile's generating
    eccentricity e_g is ``profile.generating_eccentricity``, a separate input). width: axial width
    of each wheel [m]. midplanes: axial midplanes of the wheels [m], one per wheel. phases:
    eccentric journal phases [rad] (file: ``phases_deg``), one per wheel. n_slices: slices across
    the face width [-]. samples_per_tooth: resolution of the wheel-profile table [-].
    clearance: uniform clearance at the pins [m]. n_teeth: z_g, the wheel's tooth count [-]
    (None: pins.n_pins - 1). search: the contact search ("discrete" table search or "analytic"
    closest point). body: the wheel body in the torque path, "rigid" (default) or "ported" (an elastic
    wheel through NGSolve, :mod:`rvtool.assembly.wheel_body`; RV topology). structure: the
    :class:`~rvtool.structure.wheel_body.WheelBodySpec` of a ported wheel (file:
    ``[wheels.structure]``; unused while the body is rigid). dynamics: the wheels as rigid or floating flexible
    bodies in driven and quasi-static runs (:class:`~rvtool.structure.floating_ports.FloatingDynamics`,
    sub-table ``[wheels.dynamics]``; rigid by default; cycloid and RV topologies).
    lobe_pitch_deviations: per wheel, the single pitch deviations f_pt,j [m] of its lobes (z_g entries per wheel,
    f_pt,j between lobe j-1 and lobe j, summing to zero: a closed circle, as ISO 1328-1 for a gear), on the wheel's
    reference circle of radius R_z z_g / z_b (the wheel as a gear of the pin ring's module 2 R_z / z_b); lobe j is
    turned about the wheel centre by its accumulated pitch deviation (:func:`rvtool.geometry.cycloid.lobe_pitch_rotations`;
    an empty list: every lobe at its nominal place)."""
    eccentricity: float
    width: float
    midplanes: tuple = (0.0,)
    phases: tuple = angle_field((0.0,))
    n_slices: int = 1
    samples_per_tooth: int = 120
    clearance: float = 0.0
    n_teeth: int | None = None
    search: str = "discrete"
    body: str = "rigid"
    structure: WheelBodySpec = field(default_factory=WheelBodySpec)
    dynamics: FloatingDynamics = field(default_factory=FloatingDynamics)
    lobe_pitch_deviations: tuple = ()

    def __post_init__(self):
        check_positive("wheels.eccentricity", self.eccentricity)
        if self.body not in ("rigid", "ported"):
            raise RvtoolInputError(f"wheels.body = {self.body!r}; valid choices are ['rigid', 'ported']")
        check_positive("wheels.width", self.width)
        if not all(isinstance(z, numbers.Real) and not isinstance(z, bool) for z in self.midplanes):
            # a nested list was refused only by the output pins' copy (output_pins.wheel_midplanes)
            shown = [list(z) if isinstance(z, tuple) else z for z in self.midplanes]     # as the file wrote it
            raise RvtoolInputError(f"wheels.midplanes = {shown!r}; valid: a list of numbers [m], one "
                                   "axial position per wheel")
        if len(self.midplanes) != len(self.phases):
            raise RvtoolInputError(f"wheels.midplanes ({len(self.midplanes)}) and wheels.phases_deg "
                                   f"({len(self.phases)}) must have one entry per wheel")
        if not 1 <= len(self.midplanes) <= 2:
            raise RvtoolInputError(f"wheels.midplanes has {len(self.midplanes)} entries, one per wheel; valid range "
                                   "[1, 2] wheels (n_wheels)")
        check_finite("wheels.phases", np.asarray(self.phases, float))
        # upper bounds: the largest resolutions the solvers are built and tested for (a fuzzed or mistyped
        # 1e6 would otherwise build for hours instead of failing with a named error)
        if isinstance(self.n_slices, bool) or not isinstance(self.n_slices, int) or not 1 <= self.n_slices <= 64:
            raise RvtoolInputError(f"wheels.n_slices = {self.n_slices!r} is outside the valid range [1, 64] (integer)")
        if (isinstance(self.samples_per_tooth, bool) or not isinstance(self.samples_per_tooth, int)
                or not 8 <= self.samples_per_tooth <= 20000):
            raise RvtoolInputError(f"wheels.samples_per_tooth = {self.samples_per_tooth!r} is outside the valid range "
                                   "[8, 20000] (integer)")
        if self.search not in ("discrete", "analytic"):
            raise RvtoolInputError(f"wheels.search = {self.search!r}; valid choices are ['discrete', 'analytic']")
        if self.lobe_pitch_deviations:
            rows = self.lobe_pitch_deviations
            if len(rows) != len(self.phases):
                raise RvtoolInputError(f"wheels.lobe_pitch_deviations has {len(rows)} rows; valid: 0 or one row per "
                                       f"wheel ({len(self.phases)}, wheels.phases_deg)")
            for j, f in enumerate(rows):
                f = np.asarray(f, float)
                if f.ndim != 1:
                    raise RvtoolInputError(f"wheels.lobe_pitch_deviations[{j}] must be a list of numbers [m], one per lobe")
                check_finite(f"wheels.lobe_pitch_deviations[{j}]", f)
                if abs(f.sum()) > 1e-9 * max(1e-6, np.abs(f).sum()):
                    raise RvtoolInputError(f"wheels.lobe_pitch_deviations[{j}] sum to {f.sum():.3g} m; valid: sum 0 "
                                           "(the pitches of a closed circle add up to its circumference)")

    def check_lobes(self, n_teeth):
        """Bad input named: every row of ``lobe_pitch_deviations`` has one entry per lobe (``n_teeth`` = z_g)."""
        for j, f in enumerate(self.lobe_pitch_deviations):
            if len(f) != n_teeth:
                raise RvtoolInputError(f"wheels.lobe_pitch_deviations[{j}] has {len(f)} entries; valid: one per lobe, "
                                       f"z_g = {n_teeth}")


@dataclass(frozen=True, kw_only=True)
class PinContact:
    """Cycloid--pin contact law.

    law: the normal law ("line", "power", "secant" or "palmgren"; "palmgren" is Palmgren's nonlinear
    steel line contact F = k delta^(10/9) over the wheel width,
    :func:`rvtool.contact.cycloid_set.palmgren_line_coefficient`: no stiffness, no reference load).
    stiffness: whole-contact stiffness [N/m] (0 with "line": the secant stiffness at reference_force).
    exponent: the power law's exponent [-]. reference_force: the calibration load of the secant [N]
    ("line" and "secant" only). damping: contact damping [N s/m]. mu: friction coefficient [-]
    (0 = no friction). friction_model: "regularized" (Eq. (friction) velocity law) or "anchor"
    (stick--slip anchors per slice). tangential_stiffness: whole-contact stiffness of the anchors
    [N/m] (0 = Mindlin's ratio 2(1 - nu)/(2 - nu) of the normal secant stiffness)."""
    law: str = "line"
    stiffness: float = 0.0
    exponent: float = 1.0
    reference_force: float = 500.0
    damping: float = 0.0
    mu: float = 0.0
    friction_model: str = "regularized"
    tangential_stiffness: float = 0.0

    def __post_init__(self):
        if self.law not in ("line", "power", "secant", "palmgren"):
            raise RvtoolInputError(f"pin_contact.law = {self.law!r}; valid choices are ['line', 'power', 'secant', "
                                   "'palmgren']")
        check_nonnegative("pin_contact.stiffness", self.stiffness)
        check_range("pin_contact.exponent", self.exponent, 1.0)
        check_positive("pin_contact.reference_force", self.reference_force)
        check_nonnegative("pin_contact.damping", self.damping)
        check_nonnegative("pin_contact.mu", self.mu)
        if self.friction_model not in ("regularized", "anchor"):
            raise RvtoolInputError(f"pin_contact.friction_model = {self.friction_model!r}; valid choices are "
                                   "['regularized', 'anchor']")
        check_nonnegative("pin_contact.tangential_stiffness", self.tangential_stiffness)


@dataclass(frozen=True, kw_only=True)
class Housing:
    """Housing carrying the ring pins.

    model: "rigid" (the pins are ground; ``structure`` unused) or "ports" (an elastic housing,
    NGSolve tetrahedra, reduced by Craig--Bampton and the port reduction of the structural
    section; one planar port (x, y) per ring pin at the pin's angle on the bore, at the
    structure's port height; the pin centres move with their ports).
    structure: the :class:`~rvtool.structure.AnnularHousingSpec` (file: ``[housing.structure]``
    with ``[housing.structure.material]`` and ``[housing.structure.damping]``; its ``n_ports`` is
    the ring's pin count and its material [material]'s unless given).
    n_fixed_interface_modes: Craig--Bampton modes of the parent [-]. n_modes: retained parent
    modes of the port reduction [-]. n_residual: residual attachment modes of the port reduction
    [-] (-1: one per port row, so that the static port compliance equals the parent's to round-off).
    """
    model: str = "rigid"
    structure: AnnularHousingSpec | None = None
    n_fixed_interface_modes: int = 20
    n_modes: int = 12
    n_residual: int = -1

    def __post_init__(self):
        if self.model not in ("rigid", "ports"):
            raise RvtoolInputError(f"housing.model = {self.model!r}; valid choices are ['rigid', 'ports']")
        if self.model == "ports" and not isinstance(self.structure, AnnularHousingSpec):
            raise RvtoolInputError("housing.model = 'ports' needs the table [housing.structure] (an AnnularHousingSpec)")
        # upper bounds of the mode counts: a cost limit (MAX_STRUCTURE_MODES); n_residual at most one residual
        # attachment mode per port row (x, y of at most MAX_PORTS ports; -1 takes exactly that)
        for nm, lo, hi in (("n_fixed_interface_modes", 0, MAX_STRUCTURE_MODES), ("n_modes", 0, MAX_STRUCTURE_MODES),
                           ("n_residual", -1, 2 * MAX_PORTS)):
            v = getattr(self, nm)
            if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
                raise RvtoolInputError(f"housing.{nm} = {v!r} is outside the valid range [{lo}, "
                                       f"{'inf)' if hi is None else str(hi) + ']'} (integer)")
        if self.n_residual != -1 and self.n_modes + self.n_residual < 1:
            raise RvtoolInputError("housing.n_modes + housing.n_residual = 0; valid range [1, inf)")

    def check_pin_ring(self, pins):
        """An elastic housing carrying the ring ``pins`` (a :class:`Pins` spec) at one port per pin:
        its bore clears the pins and it has one port per pin (cycloid and RV designs)."""
        if self.model != "ports":
            return
        r_pins = pins.pin_circle_radius + pins.pin_radius
        st = self.structure
        if st.inner_radius < r_pins - 1e-12:
            raise RvtoolInputError(f"housing.structure.inner_radius = {st.inner_radius} m cuts through the ring pins; "
                                   f"valid range [{r_pins:.6g}, outer_radius) m (pin circle radius + pin radius)")
        if st.n_ports != pins.n_pins:
            raise RvtoolInputError(f"housing.structure.n_ports = {st.n_ports}; valid value pins.n_pins = {pins.n_pins} "
                                   "(one port per ring pin; leave the key out to take it)")


@dataclass(frozen=True, kw_only=True)
class Bodies:
    """Retained planar coordinates per body and rigid-body data (the wheels' from their geometry).

    shaft, wheel, flange: the planar coordinates each body keeps (a subset of x, y, theta).
    shaft_mass: mass of the input shaft [kg]. shaft_inertia: polar inertia of the input shaft
    [kg m^2]. flange_mass: mass of the output flange [kg]. flange_inertia: polar inertia of the
    output flange [kg m^2].
    flange_coordinates: ``"planar"`` (default: the flange's axial translation and tilts held) or
    ``"spatial"`` (also z, gamma_x, gamma_y on the main-bearing rows, issue 32; needs rolling-element
    bearings, bearing_model "rolling" of :func:`rvtool.build`, ``rvtool analyze --bearing-model
    rolling``, and a ball main bearing).
    flange_tilt_inertia: transverse inertia [kg m^2] of the flange (dynamic runs of a spatial flange);
    None: half the polar inertia (a thin disc, assumed).
    wheel_coordinates: ``"planar"`` (default) or ``"spatial"``: each wheel also retains its axial
    translation and two tilts about its mid-plane; the ring-pin mesh, the output pins and the
    eccentric bearing on it are sliced across the wheel width with the relative tilt (Eq. (skew),
    :class:`rvtool.contact.skew.SkewSlices`; needs ``build(..., bearing_model="rolling")``,
    ``rvtool analyze --bearing-model rolling``).
    tilt_slices: width slices of every family on a spatial wheel [-]. wheel_tilt_inertia: transverse
    inertia [kg m^2] of a wheel (None: a thin disc, half its polar inertia, assumed)."""
    shaft: tuple = COORDS
    wheel: tuple = COORDS
    flange: tuple = COORDS
    shaft_mass: float = 0.3
    shaft_inertia: float = 2e-5
    flange_mass: float = 1.2
    flange_inertia: float = 1.5e-3
    flange_coordinates: str = "planar"
    flange_tilt_inertia: float | None = None
    wheel_coordinates: str = "planar"
    tilt_slices: int = 2
    wheel_tilt_inertia: float | None = None

    def __post_init__(self):
        for nm in ("shaft_mass", "shaft_inertia", "flange_mass", "flange_inertia"):
            check_positive(f"bodies.{nm}", getattr(self, nm))     # Exudyn's rigid body refuses <= 0 deep inside
        for nm in ("shaft", "wheel", "flange"):
            for c in getattr(self, nm):
                if c not in COORDS:
                    raise RvtoolInputError(f"bodies.{nm} contains {c!r}; valid coordinates are {list(COORDS)}")
        if self.flange_coordinates not in ("planar", "spatial"):
            raise RvtoolInputError(f"bodies.flange_coordinates = {self.flange_coordinates!r}; valid choices are "
                                   "['planar', 'spatial']")
        if self.flange_tilt_inertia is not None:
            check_positive("bodies.flange_tilt_inertia", self.flange_tilt_inertia)
        if self.wheel_coordinates not in ("planar", "spatial"):
            raise RvtoolInputError(f"bodies.wheel_coordinates = {self.wheel_coordinates!r}; valid choices are "
                                   "['planar', 'spatial']")
        if isinstance(self.tilt_slices, bool) or not isinstance(self.tilt_slices, int) or not 2 <= self.tilt_slices <= 32:
            raise RvtoolInputError(f"bodies.tilt_slices = {self.tilt_slices!r} is outside the valid range [2, 32] "
                                   "(integer)")
        if self.wheel_tilt_inertia is not None:
            check_positive("bodies.wheel_tilt_inertia", self.wheel_tilt_inertia)

    @property
    def spatial_wheels(self):
        """True where the wheels retain their axial and tilt coordinates."""
        return self.wheel_coordinates == "spatial"

    @property
    def spatial_flange(self):
        """True where the flange retains its axial and tilt coordinates."""
        return self.flange_coordinates == "spatial"

    @property
    def tilt_inertia(self):
        """Transverse inertia [kg m^2] of the flange (``flange_tilt_inertia`` or half the polar inertia)."""
        return self.flange_inertia / 2 if self.flange_tilt_inertia is None else self.flange_tilt_inertia


@dataclass(frozen=True, kw_only=True)
class BearingFriction:
    """Bearing friction torque as a loss on each bearing's relative rotation (optional section;
    model "none" = no element, no cost).

    model: "none" or "palmgren" (Palmgren's M = M0 + M1 of :mod:`rvtool.bearings.friction_torque`).
    kinematic_viscosity: nu of the lubricant [m^2/s]. f0_ball, f1_ball: Palmgren's factors of the
    main and input ball bearings [-]. f0_needle, f1_needle: Palmgren's factors of the eccentric
    needle bearings [-]. f0_tapered, f1_tapered: Palmgren's factors of the tapered roller rows [-]
    (chosen here, of the order of the roller values). regularization_speed: the speed that
    regularizes the sign of the torque [rad/s]. static_stiffness: k_phi of the static part
    [N m/rad] (> 0), or None (M0 + M1 on the speed law); with it, M1 acts as a Coulomb torque with
    an anchor on the bearing's relative rotation (:mod:`rvtool.bearings.friction_element`);
    switched off (None) it costs nothing. palmgren_load: the load P1 of M1 = f1 P1 d_m on the
    rolling-element bearing sets, "typed" (Palmgren's definition by bearing type, with the rows'
    declared axial preload: :mod:`rvtool.bearings.palmgren_load`) or "radial" (the mounting's
    radial resultant alone, the form before the correction); lumped bearings take their row's
    normal force either way.

    The defaults are chosen here, inside the ranges tabulated by Harris & Kotzalas (oil bath:
    f0 = 2 for angular-contact/deep-groove ball bearings, 4 for needle bearings; f1 = 7e-4 ball,
    5e-4 needle); ISO VG 32 at 40 degC."""
    model: str = "none"
    kinematic_viscosity: float = 3.2e-5
    f0_ball: float = 2.0
    f1_ball: float = 7e-4
    f0_needle: float = 4.0
    f1_needle: float = 5e-4
    f0_tapered: float = 6.0
    f1_tapered: float = 4e-4
    regularization_speed: float = 1e-2
    static_stiffness: float | None = None
    palmgren_load: str = "typed"

    def __post_init__(self):
        from ..bearings.palmgren_load import check_mode
        check_mode(self.palmgren_load, "bearing_friction.palmgren_load")
        if self.model not in ("none", "palmgren"):
            raise RvtoolInputError(f"bearing_friction.model = {self.model!r}; valid choices are ['none', 'palmgren']")
        check_positive("bearing_friction.kinematic_viscosity", self.kinematic_viscosity)
        check_positive("bearing_friction.f0_ball", self.f0_ball)
        check_nonnegative("bearing_friction.f1_ball", self.f1_ball)
        check_positive("bearing_friction.f0_needle", self.f0_needle)
        check_nonnegative("bearing_friction.f1_needle", self.f1_needle)
        check_positive("bearing_friction.regularization_speed", self.regularization_speed)
        check_positive("bearing_friction.f0_tapered", self.f0_tapered)
        check_nonnegative("bearing_friction.f1_tapered", self.f1_tapered)
        if self.static_stiffness is not None:
            check_finite("bearing_friction.static_stiffness", self.static_stiffness)
            check_positive("bearing_friction.static_stiffness", self.static_stiffness)


@dataclass(frozen=True, kw_only=True)
class CycloidDesign:
    """A single-stage cycloid drive with one or two wheels (see rvtool/designs/rd40.toml): the
    tree of component specs, one per section. ``main_bearing`` / ``input_bearing`` are None
    where the file says ``kind = "locked"`` (the body held on its axis, no bearing law).

    name: the design's label. n_wheels: number of cycloid wheels [-] (1 or 2). rated_torque: the
    rated output torque [N m]. input_speed_rpm: the rated input speed [rpm]."""
    name: str
    n_wheels: int
    rated_torque: float
    input_speed_rpm: float
    material: ElasticMaterial
    pins: Pins
    profile: CycloidProfile
    wheels: Wheels
    pin_contact: PinContact
    output_pins: OutputPinMechanism
    eccentric_bearing: NeedleBearing
    main_bearing: BallBearing | AngularContactPair | CrossedRollerBearing | None
    input_bearing: BallBearing | None
    bodies: Bodies = field(default_factory=Bodies)
    housing: Housing = field(default_factory=Housing)
    #: the file-form data this design was loaded from (what :func:`replace` changes and re-loads)
    source: dict | None = field(default=None, compare=False, hash=False, repr=False, metadata={"file": False})
    bearing_friction: BearingFriction = field(default_factory=BearingFriction)

    def __post_init__(self):
        check_integer("n_wheels", self.n_wheels, 1, 2)
        if self.n_wheels != len(self.wheels.midplanes):
            raise RvtoolInputError(f"n_wheels = {self.n_wheels} but wheels.midplanes has {len(self.wheels.midplanes)} "
                                   f"entries; valid: one entry per wheel in wheels.midplanes and wheels.phases_deg "
                                   f"(and in output_pins.wheel_midplanes, output_pins.gap_offsets where the file gives them)")
        check_positive("rated_torque", self.rated_torque)
        check_positive("input_speed_rpm", self.input_speed_rpm)
        zg = self.wheels.n_teeth if self.wheels.n_teeth is not None else self.pins.n_pins - 1
        if zg != self.pins.n_pins - 1:
            raise RvtoolInputError(f"wheels.n_teeth = {zg} with pins.n_pins = {self.pins.n_pins}: only Z_pins = Z_wheel + 1 "
                                   f"is supported (valid: wheels.n_teeth = {self.pins.n_pins - 1})")
        self.wheels.check_lobes(zg)
        # the profile is generated by the ring it meshes with (it may leave these keys out)
        for key in ("n_pins", "pin_circle_radius", "pin_radius"):
            if getattr(self.profile, key) != getattr(self.pins, key):
                raise RvtoolInputError(f"profile.{key} = {getattr(self.profile, key)!r} differs from pins.{key}; "
                                       f"valid value {getattr(self.pins, key)!r} (leave the key out to take it)")
        if self.output_pins.n_wheels != self.n_wheels:
            raise RvtoolInputError(f"output_pins.wheel_midplanes has {self.output_pins.n_wheels} entries; valid: one per "
                                   f"wheel ({self.n_wheels}; leave the key out to take wheels.midplanes)")
        needed = self.wheels.eccentricity + self.output_pins.pin_radius
        if self.output_pins.hole_radius < needed - 1e-4:
            raise RvtoolInputError(f"output_pins.hole_radius = {self.output_pins.hole_radius} m cannot pass the eccentric "
                                   f"motion; valid range [{needed:.6g}, inf) m (pin radius + eccentricity)")
        self.housing.check_pin_ring(self.pins)

    @property
    def ratio(self):
        """Signed nominal ratio i = omega_in / omega_out (fixed pins, output through the wheel): -z_g."""
        return -(self.pins.n_pins - 1)

    def replace(self, **sections):
        """A copy with sections replaced by dicts of changed fields (see :func:`replace`)."""
        return replace(self, **sections)

    def with_mesh_stiffness_factor(self, factor):
        """A copy whose pin-contact law is the line law at ``factor`` times the current stiffness
        (the secant stiffness at the reference force where none is given)."""
        from ..contact.cycloid_set import secant_line_stiffness
        pc = self.pin_contact
        k = pc.stiffness if pc.stiffness > 0 else secant_line_stiffness(pc.reference_force, self.wheels.width)
        return replace(self, pin_contact={"law": "line", "stiffness": factor * k})


#: Bearing sections: the ``kind`` key selects the component spec (None: the body is held, no bearing).
BEARING_KINDS = {"deep_groove": BallBearing, "angular_contact": BallBearing,
                 "angular_contact_pair": AngularContactPair, "locked": None}

#: The main bearing's kinds: the bearing kinds and a crossed-roller bearing (issue 32: one row of
#: rollers alternating +-alpha carries radial, axial and tilting load; :mod:`rvtool.bearings.spatial_set`)
MAIN_BEARING_KINDS = {**BEARING_KINDS, "crossed_roller": CrossedRollerBearing}

#: Sections of a cycloid design file and their component specs (bearing sections: by ``kind``), in
#: dependency order (a section's links read sections before it).
SECTIONS = {"material": ElasticMaterial, "pins": Pins, "wheels": Wheels, "profile": CycloidProfile,
            "pin_contact": PinContact, "output_pins": OutputPinMechanism, "eccentric_bearing": NeedleBearing,
            "main_bearing": MAIN_BEARING_KINDS, "input_bearing": BEARING_KINDS, "bodies": Bodies, "housing": Housing,
            "bearing_friction": BearingFriction}
OPTIONAL_SECTIONS = ("profile", "bodies", "housing", "bearing_friction")

_ELASTIC = {"youngs_modulus": "material.youngs_modulus", "poisson_ratio": "material.poisson_ratio"}

#: Keys a table may leave out because another section states the quantity: table path ->
#: {key: "section.key" it takes, or "section": that whole section's spec}. The file states each
#: quantity once; a key the table gives is kept. A link into the table's own section reads the
#: table's own key; a sub-table the file does not give takes no links.
LINKS = {
    # the wheel profile is generated by the ring it meshes with; e_g = e unless given separately
    "profile": {"n_pins": "pins.n_pins", "pin_circle_radius": "pins.pin_circle_radius",
                "pin_radius": "pins.pin_radius", "generating_eccentricity": "wheels.eccentricity"},
    # flange pins run in holes on their own pin circle, along the wheels' width, at the wheels' midplanes;
    # pins and flange of the design's material
    "output_pins": {"hole_circle_radius": "output_pins.pin_circle_radius", "contact_length": "wheels.width",
                    "wheel_midplanes": "wheels.midplanes", **_ELASTIC},
    # balls and rings of the design's material (a locked bearing takes nothing)
    "main_bearing": dict(_ELASTIC),
    "input_bearing": dict(_ELASTIC),
    # one housing port per ring pin; the housing of the design's material
    "housing.structure": {"n_ports": "pins.n_pins", "material": "material"},
}


#: Keys a section derives from its own (linked) keys where it leaves them out: section -> function
#: (table, sections built before) -> {key: value}. (An elastic output pin derives nothing: the
#: builder closes its beam per pin, :class:`~rvtool.contact.pin_closure.ElasticPinClosure`.)
DERIVED = {}


def _file_units(cls, section, data):
    """The one unit conversion of a design file: ``NAME_deg`` [deg] -> angle field NAME [rad] of ``cls``
    (a number or a list of numbers); every other key is SI already. An angle field is given in
    degrees only (:func:`rvtool.units.is_angle`): its name in radians is not a file key."""
    angles = {f.name: f for f in dataclasses.fields(cls) if is_angle(f)}
    out = {}
    for key, value in data.items():
        stem = key[:-4] if key.endswith("_deg") else None
        if key in angles:
            raise RvtoolInputError(f"{section}.{key}: a design file gives this angle in degrees as {key}_deg "
                                   f"(the spec holds it in rad)")
        if stem is not None and stem in angles:
            cols = angle_columns(angles[stem])
            try:
                if cols is not None:        # a table whose angle columns are in degrees, the others SI
                    out[stem] = tuple(tuple(float(np.deg2rad(x)) if j in cols else float(x) for j, x in enumerate(row))
                                      for row in value)
                else:
                    out[stem] = (tuple(float(np.deg2rad(v)) for v in value) if isinstance(value, (list, tuple))
                                 else float(np.deg2rad(value)))
            except (TypeError, ValueError):
                what = "a table of rows with its angle columns in degrees" if cols is not None else \
                    "a number of degrees (or a list)"
                raise RvtoolInputError(f"{section}.{key} = {value!r} must be {what}") from None
        else:
            out[key] = value
    return out


def _spec_class(f):
    """The component-spec class of dataclass field ``f`` (also inside ``X | None``), or None."""
    for t in (f.type, *typing.get_args(f.type)):
        if dataclasses.is_dataclass(t) and isinstance(t, type):
            return t
    return None


def _field_types(cls):
    import typing
    try:
        return typing.get_type_hints(cls)
    except Exception:  # an annotation that does not resolve: no type check for that spec
        return {}


_TOML_KINDS = {float: "a number", int: "an integer", str: "text", bool: "true or false", tuple: "a list"}


def _type_ok(value, tp):
    """Whether a design-file value fits the field annotation ``tp`` (bool is not a number; a list
    fits a tuple; a spec section fits its dataclass; Enum fields take their text value)."""
    import enum
    import types
    import typing
    if tp is None or tp is typing.Any or tp is object:
        return True
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return any(_type_ok(value, a) for a in typing.get_args(tp))
    if tp is type(None):
        return value is None
    if origin is not None:
        tp = origin
    if not isinstance(tp, type):
        return True
    if tp is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if tp is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if tp is bool:
        return isinstance(value, bool)
    if tp in (tuple, list):
        return isinstance(value, (list, tuple))
    if issubclass(tp, enum.Enum):
        return isinstance(value, (str, tp))
    if tp is str:
        return isinstance(value, str)
    return True


def _check_finite_numbers(key, value):
    """NaN and infinity are never design values (TOML can write them: ``nan``, ``inf``)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise RvtoolInputError(f"{key} = {value!r} must be finite (valid range: finite real numbers)")
    if isinstance(value, (list, tuple)):
        for v in value:
            _check_finite_numbers(key, v)


def _check_type(key, value, tp):
    _check_finite_numbers(key, value)
    if not _type_ok(value, tp):
        import typing
        args = [a for a in (typing.get_args(tp) or (tp,)) if a is not type(None)]
        want = " or ".join(dict.fromkeys(_TOML_KINDS.get(typing.get_origin(a) or a, getattr(a, "__name__", str(a)))
                                         for a in args))
        raise RvtoolInputError(f"{key} = {value!r} has the wrong type; valid: {want}")


def file_keys(cls):
    """The keys a design file may give in the table of spec ``cls``, sorted: its constructor's fields
    under their file names (an angle as ``NAME_deg``), not the loader's own (``source``)."""
    return sorted(file_key(f) for f in dataclasses.fields(cls) if f.init and f.metadata.get("file", True))


def _did_you_mean(unknown, valid, form="'{}'"):
    """`` (did you mean 'x'?)`` for the unknown names that are a misspelling of a valid one, else ""
    (``form``: how a name is written, e.g. ``"[{}]"`` for a section)."""
    import difflib
    close = {u: difflib.get_close_matches(u, valid, n=1) for u in sorted(unknown)}
    hints = [f"{form.format(u)} -> {form.format(m[0])}" for u, m in close.items() if m]
    return f" (did you mean {', '.join(hints)}?)" if hints else ""


def build_section(cls, section, data):
    """Construct the component spec ``cls`` from the design-file table ``data`` of ``[section]``:
    ``NAME_deg`` keys become the field NAME in radians (the one unit conversion), lists become
    tuples, a sub-table of a field whose type is a component spec is built the same way (key path
    ``section.field``), unknown keys and type errors are reported with the section name, and a
    component's own validation error is prefixed with the section so it names the key path
    (e.g. ``wheels.eccentricity``). Every topology's design loader uses this one function."""
    if not isinstance(data, dict):
        raise RvtoolInputError(f"[{section}] must be a table of keys; got {type(data).__name__} {data!r}")
    data = _file_units(cls, section, data)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = set(data) - set(fields)
    if section != "design":      # a section field the spec holds for the code only (e.g. profile.lobe_rotations)
        unknown |= {k for k in data if k in fields and fields[k].metadata.get("file", True) is False}
    if unknown:
        where = "the top level" if section == "design" else f"[{section}]"   # "design": the file's top level
        raise RvtoolInputError(f"{where} has unknown keys {sorted(unknown)}; valid keys are "
                               f"{file_keys(cls)}{_did_you_mean(unknown, file_keys(cls))}")
    hints = _field_types(cls)
    kw = {}
    for k, v in data.items():
        sub = _spec_class(fields[k])
        if isinstance(v, dict) and sub is not None:
            kw[k] = build_section(sub, f"{section}.{k}", v)
            continue
        key = file_key(fields[k])      # the file's name of the key (an angle's NAME_deg), not the field's
        _check_type(key if section == "design" else f"{section}.{key}", v, hints.get(k))
        kw[k] = tuple(tuple(e) if isinstance(e, list) else e for e in v) if isinstance(v, list) else v
    try:
        return cls(**kw)
    except TypeError as exc:
        raise RvtoolInputError(_missing_keys_message(cls, section, kw, exc)) from None
    except RvtoolInputError as exc:
        # a component spec validates its own fields; the design file's key path names the section. A spec
        # that names its own table (the rack's "rack.pressure_angle") is read in [sun_gear.rack] as
        # "sun_gear.rack.pressure_angle", not "sun_gear.rack.rack.pressure_angle"
        msg, own = str(exc), section.rpartition(".")[2] + "."
        if section != "design" and msg.startswith(own) and not msg.startswith(section + "."):
            msg = msg[len(own):]
        msg = _file_angle_message(msg, cls)
        raise RvtoolInputError(msg if msg.startswith(section + ".") or section == "design" else f"{section}.{msg}") from None


def _missing_keys_message(cls, section, kw, exc):
    """The message of a section that leaves out a required key: the key path in the file's terms and,
    where one key is missing, its valid range (as the template states it); ``exc``: the constructor's
    TypeError (said as it is where no required key is missing)."""
    missing = [f for f in dataclasses.fields(cls) if f.init and f.name not in kw
               and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if not missing:
        return f"[{section}]: {exc}"
    where, keys = ("the top level", "") if section == "design" else (f"[{section}]", f"{section}.")
    rng = ""
    sample = {int: 1, float: 1.0}.get(_field_types(cls).get(missing[0].name))
    if len(missing) == 1 and sample is not None:
        from ..designs.format import angle_range, valid_range   # the template's own range probe
        try:
            probe = angle_range if is_angle(missing[0]) else valid_range
            rng = probe(cls, {**kw, missing[0].name: sample}, missing[0].name)
        except (TypeError, ValueError, AttributeError):     # a range not probed here: the key is still named
            rng = ""
        rng = f" (valid: {rng}{' deg' if is_angle(missing[0]) else ''})" if rng and "constrained" not in rng else ""
    names = ", ".join(keys + file_key(f) for f in missing)
    hint = _MISSING_HINTS.get(section.partition(".")[0], "'rvtool new' writes every key with its unit and valid range")
    return f"{where} is missing the required key{'s' if len(missing) > 1 else ''} {names}{rng}; {hint}"


_MISSING_HINTS = {"allowables": "rvtool/designs/rd40_allowables.toml gives every key with its unit and source"}
"""Where the keys of a table that is not a design file's are listed (the design file's: its template)."""


_RANGE_MESSAGE = re.compile(r"^(\w+) = (.+?) is outside the valid range ([\[(])([^,]+), ([^\])]+)([\])])(.*)$", re.S)
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _file_angle_message(msg, cls):
    """A spec's range message about one of its angle fields [rad] in the design file's terms: the key
    ``NAME_deg``, the value and the valid range in degrees (every other message unchanged)."""
    m = _RANGE_MESSAGE.match(msg)
    angles = {f.name for f in dataclasses.fields(cls) if is_angle(f) and angle_columns(f) is None}
    if m is None or m.group(1) not in angles:
        return msg
    name, value, lb, low, high, hb, rest = m.groups()
    try:
        low_deg, high_deg = (f"{np.degrees(float(t)):.12g}" for t in (low, high))
    except ValueError:
        return msg
    value_deg = _NUMBER.sub(lambda n: f"{np.degrees(float(n.group(0))):.12g}", value)
    return f"{name}_deg = {value_deg} is outside the valid range {lb}{low_deg}, {high_deg}{hb} deg{rest}"


def check_pair_keys(section, data, pair_cls, row_cls, extra=()):
    """An unknown key of a bearing pair's table, whose file gives the pair's own keys and its identical
    rows' keys in one table, named with both sets and a "did you mean" (the row spec alone listed the
    row's keys: ``rowspacing`` was not answered with ``row_spacing``); ``extra``: sub-table keys."""
    valid = sorted((set(file_keys(pair_cls)) - {"rows"}) | set(file_keys(row_cls)) | set(extra))
    unknown = sorted(set(data) - set(valid))
    if unknown:
        raise RvtoolInputError(f"[{section}] has unknown keys {unknown}; valid keys are {valid}"
                               f"{_did_you_mean(unknown, valid)}")


def _bearing_kind(section, data, kinds=BEARING_KINDS):
    """The ``kind`` key of a bearing section (default "deep_groove"), checked against ``kinds``."""
    kind = data.get("kind", "deep_groove")
    if not isinstance(kind, str) or kind not in kinds:
        raise RvtoolInputError(f"{section}.kind = {kind!r}; valid choices are {list(kinds)}")
    return kind


def _bearing_section(section, data, kinds=BEARING_KINDS):
    """A bearing section: ``kind`` selects the spec of ``kinds``; a pair's keys that are not the
    pair's own are those of its two identical rows."""
    data = dict(data)
    kind = _bearing_kind(section, data, kinds)
    data.pop("kind", None)
    cls = kinds[kind]
    if cls is None:
        if data:
            raise RvtoolInputError(f"[{section}] is locked (no bearing): keys {sorted(data)} are not used")
        return None
    angle = _file_units(BallBearing, section, data).get("contact_angle", 0.0)
    if kind == "angular_contact" and not (isinstance(angle, (int, float)) and angle > 0):
        raise RvtoolInputError(f"{section}.contact_angle_deg = {angle!r} rad; valid range (0, 90) deg for "
                               "kind = 'angular_contact'")
    if cls is AngularContactPair:
        check_pair_keys(section, data, AngularContactPair, BallBearing)
        own = {f.name for f in dataclasses.fields(AngularContactPair)} - {"rows"}
        row = build_section(BallBearing, section, {k: v for k, v in data.items() if k not in own})
        return build_section(AngularContactPair, section, {**{k: v for k, v in data.items() if k in own},
                                                           "rows": (row, row)})
    return build_section(cls, section, data)


def _with_links(section, data, built, links=None):
    """``data`` with the keys it leaves out filled from ``links`` (default :data:`LINKS`; from the
    sections already built, or from the table's own keys)."""
    out = copy.deepcopy(data)
    for path, table_links in (LINKS if links is None else links).items():
        head, *rest = path.split(".")
        if head != section:
            continue
        table = out
        for part in rest:            # a sub-table the file does not give takes no links
            table = table.get(part) if isinstance(table.get(part), dict) else None
            if table is None:
                break
        if table is None:
            continue
        for key, src in table_links.items():
            if key in table or key + "_deg" in table:
                continue
            src_section, _, src_key = src.partition(".")
            if src_section == section and not rest:
                if src_key in table:
                    table[key] = table[src_key]
            else:               # a key of a section built before, or (no key) that whole section's spec
                table[key] = getattr(built[src_section], src_key) if src_key else built[src_section]
    return out


def load_sections(d, sections, *, optional=(), links=None, derived=None):
    """Build the component specs of ``sections`` ({section: spec class, or :data:`BEARING_KINDS`
    for a bearing section}, in dependency order) from the file-form table ``d``, popping each
    section from ``d``; ``links`` / ``derived``: a topology's :data:`LINKS` / :data:`DERIVED`
    (default the cycloid's). Returns {section: spec}. Every topology's loader uses this one loop."""
    links = LINKS if links is None else links
    derived = DERIVED if derived is None else derived
    built = {}
    for sec, cls in sections.items():       # in dependency order: a link reads a section built before
        if sec not in d and sec not in optional:
            raise RvtoolInputError(f"section [{sec}] is missing from the design")
        data = d.pop(sec, {})
        if not isinstance(data, dict):
            raise RvtoolInputError(f"[{sec}] must be a table of keys; got {data!r}")
        if cls is BEARING_KINDS or cls is MAIN_BEARING_KINDS:
            locked = cls[_bearing_kind(sec, data, cls)] is None
            built[sec] = _bearing_section(sec, data if locked else _with_links(sec, data, built, links), cls)
        else:
            data = _with_links(sec, data, built, links)
            if sec in derived:
                data = {**derived[sec](data, built), **data}
            built[sec] = build_section(cls, sec, data)
    return built


def design_from_dict(d):
    """A validated :class:`CycloidDesign` from file-form data (the parsed TOML of a design file;
    ``format_version``: :func:`rvtool.assembly.topologies.upgrade_table`)."""
    from .topologies import upgrade_table
    d = upgrade_table(d)
    source = copy.deepcopy(dict(d))
    d = dict(d)
    topology = d.pop("topology", "cycloid")   # the key of rvtool.assembly.topologies; this loader is the cycloid's
    if topology != "cycloid":
        raise RvtoolInputError(f"topology = {topology!r}: this is the cycloid loader; load the file with "
                               "rvtool.load_design (rvtool.assembly.topologies), which picks the topology's loader")
    built = load_sections(d, SECTIONS, optional=OPTIONAL_SECTIONS)
    return build_section(CycloidDesign, "design", {**d, **built, "source": source})


def load_design(path):
    """Load a design TOML file into its validated design: the file's ``topology`` key picks the
    topology's loader (:mod:`rvtool.assembly.topologies`; absent: "cycloid", :class:`CycloidDesign`)."""
    from . import topologies
    return topologies.design_from_table(topologies.read_table(path))


def _merge(table, changes):
    """``table`` with ``changes`` written in (sub-tables merged key by key); a key replaces its
    ``_deg`` form and vice versa."""
    out = dict(table)
    for key, value in changes.items():
        out.pop(key[:-4] if key.endswith("_deg") else key + "_deg", None)
        if isinstance(value, dict):
            out[key] = _merge(out.get(key, {}) if isinstance(out.get(key), dict) else {}, value)
        else:
            out[key] = [list(v) if isinstance(v, tuple) else v for v in value] if isinstance(value, tuple) else value
    return out


def replace(design, **sections):
    """A copy of ``design`` with sections replaced by dicts of changed keys (file keys: field names,
    or ``NAME_deg`` for an angle in degrees) and top-level values, e.g.
    ``replace(d, wheels={"n_slices": 4}, n_wheels=1)``. The changed file-form data is loaded
    again, so links follow (a new wheel width is the output pins' contact length)."""
    from . import topologies
    return topologies.design_from_table(replaced_source(design, **sections))


def replaced_source(design, **sections):
    """The file-form data :func:`replace` loads for ``replace(design, **sections)`` (the design's
    ``source`` with the sections written in), without loading it."""
    source = getattr(design, "source", None)
    if source is None:
        raise RvtoolInputError("replace needs a design loaded from file-form data (load_design / design_from_dict)")
    return _merge(copy.deepcopy(source), sections)
