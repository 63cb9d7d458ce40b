"""Cycloid reducer specification: plain data (TOML) loaded into frozen
dataclasses and validated on load; errors name the parameter (with its
section) and its valid range."""
import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..bearings.spec import NeedleBearing
from ..errors import RvtoolInputError
from ..structure.pin_beam import PinSupport
from ..validation import check_finite, check_nonnegative, check_positive, check_range

COORDS = ("x", "y", "theta")


@dataclass(frozen=True, kw_only=True)
class Material:
    """youngs_modulus [Pa], poisson_ratio [-], density [kg/m^3]."""
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3
    density: float = 7850.0

    def __post_init__(self):
        check_positive("material.youngs_modulus", self.youngs_modulus)
        check_range("material.poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        check_positive("material.density", self.density)


def _support(section, value):
    """A :class:`PinSupport` from a design sub-table (dict) or an instance; errors name
    ``section.support.<key>``."""
    if isinstance(value, PinSupport):
        return value
    if not isinstance(value, dict):
        raise RvtoolInputError(f"{section}.support = {value!r} must be a table (model, ends, shear, shear_coefficient)")
    return build_section(PinSupport, f"{section}.support", value)


@dataclass(frozen=True, kw_only=True)
class Pins:
    """Ring pins: n_pins (z_b), pin_circle_radius R_z [m], pin_radius r_p [m] (the generating
    radius of the wheel profile). Manufacturing deviations (part of the design, so a variant is
    a design): radius_error [m], the actual pin radius minus r_p; centre_errors: None or
    (z_b, 2) pin-centre errors [m] in the housing frame. support: the pin as a beam
    (:class:`~rvtool.structure.pin_beam.PinSupport`, sub-table ``[pins.support]``; rigid by default)."""
    n_pins: int
    pin_circle_radius: float
    pin_radius: float
    radius_error: float = 0.0
    centre_errors: tuple | None = None
    support: PinSupport = field(default_factory=PinSupport)

    def __post_init__(self):
        object.__setattr__(self, "support", _support("pins", self.support))
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


@dataclass(frozen=True, kw_only=True)
class Wheels:
    """Cycloid wheels: assembly eccentricity e [m] and nominal generating eccentricity e_g [m]
    (separate inputs), width [m], axial midplanes [m], eccentric phases [deg], face-width slices,
    profile table resolution, profile modifications [m, rad], uniform clearance [m] and the
    contact search ("discrete" table search or "analytic" closest point)."""
    eccentricity: float
    generating_eccentricity: float | None = None
    width: float
    midplanes: tuple = (0.0,)
    phases_deg: tuple = (0.0,)
    n_slices: int = 1
    samples_per_tooth: int = 120
    equidistant_mod: float = 0.0
    offset_mod: float = 0.0
    rotation_mod: float = 0.0
    clearance: float = 0.0
    n_teeth: int | None = None
    search: str = "discrete"

    def __post_init__(self):
        check_positive("wheels.eccentricity", self.eccentricity)
        check_positive("wheels.width", self.width)
        if len(self.midplanes) != len(self.phases_deg):
            raise RvtoolInputError(f"wheels.midplanes ({len(self.midplanes)}) and wheels.phases_deg "
                                   f"({len(self.phases_deg)}) must have one entry per wheel")
        if not 1 <= len(self.midplanes) <= 2:
            raise RvtoolInputError(f"wheels: {len(self.midplanes)} wheels; valid range [1, 2]")
        if not isinstance(self.n_slices, int) or self.n_slices < 1:
            raise RvtoolInputError(f"wheels.n_slices = {self.n_slices!r} is outside the valid range [1, inf)")
        if self.search not in ("discrete", "analytic"):
            raise RvtoolInputError(f"wheels.search = {self.search!r}; valid choices are ['discrete', 'analytic']")

    @property
    def e_g(self):
        return self.eccentricity if self.generating_eccentricity is None else self.generating_eccentricity


@dataclass(frozen=True, kw_only=True)
class PinContact:
    """Cycloid--pin contact law: law ("line", "power", "secant"), stiffness [N/m] (whole contact;
    0 with "line" = secant stiffness at reference_force), exponent (power law), reference_force [N],
    damping [N s/m], mu [-] (0 = no friction), friction_model ("regularized": Eq. (friction)
    velocity law; "anchor": stick--slip anchors per slice), tangential_stiffness [N/m] of the
    anchors (whole contact; 0 = Mindlin's ratio 2(1 - nu)/(2 - nu) of the normal secant stiffness)."""
    law: str = "line"
    stiffness: float = 0.0
    exponent: float = 1.0
    reference_force: float = 500.0
    damping: float = 0.0
    mu: float = 0.0
    friction_model: str = "regularized"
    tangential_stiffness: float = 0.0

    def __post_init__(self):
        if self.law not in ("line", "power", "secant"):
            raise RvtoolInputError(f"pin_contact.law = {self.law!r}; valid choices are ['line', 'power', 'secant']")
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
class OutputPins:
    """Flange pins in wheel holes: n_pins, pin_circle_radius [m], pin_radius [m], hole_radius [m],
    reference_force [N] of the Hertz calibration of the 10/9 law, n_slices; support: the pin as a
    beam (sub-table ``[output_pins.support]``; rigid by default); mu [-] of the anchor (stick--slip)
    friction per slice (0 = none), tangential_stiffness [N/m] of the anchors (whole contact; 0 =
    Mindlin's ratio 2(1 - nu)/(2 - nu) of the 10/9 law's secant at reference_force)."""
    n_pins: int
    pin_circle_radius: float
    pin_radius: float
    hole_radius: float
    reference_force: float = 1000.0
    n_slices: int = 4
    support: PinSupport = field(default_factory=PinSupport)
    mu: float = 0.0
    tangential_stiffness: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "support", _support("output_pins", self.support))
        check_positive("output_pins.pin_circle_radius", self.pin_circle_radius)
        check_positive("output_pins.pin_radius", self.pin_radius)
        check_range("output_pins.hole_radius", self.hole_radius, self.pin_radius, math.inf, low_open=True)
        check_nonnegative("output_pins.mu", self.mu)
        check_nonnegative("output_pins.tangential_stiffness", self.tangential_stiffness)


@dataclass(frozen=True, kw_only=True)
class BallBearingSpec:
    """Ball bearing (row or back-to-back pair): kind ("deep_groove" | "angular_contact_pair"),
    n_balls, ball_diameter [m], pitch_diameter [m], contact_angle_deg, groove_curvature_ratio,
    radial_clearance [m], axial_preload [N], row_spacing [m]."""
    kind: str = "deep_groove"
    n_balls: int
    ball_diameter: float
    pitch_diameter: float
    contact_angle_deg: float = 0.0
    groove_curvature_ratio: float = 0.52
    radial_clearance: float = 0.0
    axial_preload: float = 0.0
    row_spacing: float = 0.0

    def __post_init__(self):
        if self.kind not in ("deep_groove", "angular_contact_pair", "locked"):
            raise RvtoolInputError(f"bearing kind = {self.kind!r}; valid: ['deep_groove', 'angular_contact_pair', 'locked']")
        check_positive("ball_diameter", self.ball_diameter)
        check_positive("pitch_diameter", self.pitch_diameter)
        check_range("groove_curvature_ratio", self.groove_curvature_ratio, 0.5, 1.0, low_open=True)


@dataclass(frozen=True, kw_only=True)
class Housing:
    """Housing carrying the ring pins.

    model: "rigid" (the pins are ground) or "ports" (an elastic annular housing, NGSolve
    tetrahedra, reduced by Craig--Bampton and the port reduction of the structural
    section; one planar port (x, y) per ring pin at the pin's angle on the bore, at
    mid-height; the pin centres move with their ports).
    inner_radius, outer_radius, height [m]; mesh_size [m] (nominal tetrahedron size);
    n_mounts: translational mount springs at equal angles on the lower face, at
    mount_radius [m] (0 = midway between the radii), each mount_stiffness [N/m] per direction;
    n_fixed_interface_modes: Craig--Bampton modes of the parent; n_modes, n_residual:
    retained parent modes and residual attachment modes of the port reduction (n_residual = -1:
    one per port row, so that the static port compliance equals the parent's to round-off);
    damping_ratio [-] (Rayleigh, calibrated at 500 and 5000 Hz);
    youngs_modulus [Pa], poisson_ratio [-], density [kg/m^3]: the housing material (None: the
    design's [material], e.g. set them for an aluminium housing).
    """
    model: str = "rigid"
    youngs_modulus: float | None = None
    poisson_ratio: float | None = None
    density: float | None = None
    inner_radius: float = 0.0545
    outer_radius: float = 0.075
    height: float = 0.030
    mesh_size: float = 0.004
    n_mounts: int = 12
    mount_radius: float = 0.0
    mount_stiffness: float = 2e8
    n_fixed_interface_modes: int = 20
    n_modes: int = 12
    n_residual: int = -1
    damping_ratio: float = 0.02

    def __post_init__(self):
        if self.model not in ("rigid", "ports"):
            raise RvtoolInputError(f"housing.model = {self.model!r}; valid choices are ['rigid', 'ports']")
        check_positive("housing.inner_radius", self.inner_radius)
        check_range("housing.outer_radius", self.outer_radius, self.inner_radius, math.inf, low_open=True)
        check_positive("housing.height", self.height)
        check_range("housing.mesh_size", self.mesh_size, 0.0, self.height, low_open=True)
        for nm, lo in (("n_mounts", 1), ("n_fixed_interface_modes", 0), ("n_modes", 0), ("n_residual", -1)):
            v = getattr(self, nm)
            if not isinstance(v, int) or v < lo:
                raise RvtoolInputError(f"housing.{nm} = {v!r} is outside the valid range [{lo}, inf) (integer)")
        if self.n_residual != -1 and self.n_modes + self.n_residual < 1:
            raise RvtoolInputError("housing.n_modes + housing.n_residual = 0; valid range [1, inf)")
        if self.mount_radius != 0.0:
            check_range("housing.mount_radius", self.mount_radius, self.inner_radius, self.outer_radius)
        check_positive("housing.mount_stiffness", self.mount_stiffness)
        check_range("housing.damping_ratio", self.damping_ratio, 0.0, 1.0, high_open=True)
        if self.youngs_modulus is not None:
            check_positive("housing.youngs_modulus", self.youngs_modulus)
        if self.poisson_ratio is not None:
            check_range("housing.poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        if self.density is not None:
            check_positive("housing.density", self.density)


@dataclass(frozen=True, kw_only=True)
class Bodies:
    """Retained planar coordinates per body (subset of x, y, theta) and rigid-body data
    (shaft and flange masses [kg] and polar inertias [kg m^2]; wheels from their geometry)."""
    shaft: tuple = COORDS
    wheel: tuple = COORDS
    flange: tuple = COORDS
    shaft_mass: float = 0.3
    shaft_inertia: float = 2e-5
    flange_mass: float = 1.2
    flange_inertia: float = 1.5e-3

    def __post_init__(self):
        for nm in ("shaft", "wheel", "flange"):
            for c in getattr(self, nm):
                if c not in COORDS:
                    raise RvtoolInputError(f"bodies.{nm} contains {c!r}; valid coordinates are {list(COORDS)}")


@dataclass(frozen=True, kw_only=True)
class BearingFriction:
    """Bearing friction torque as a loss on each bearing's relative rotation (optional section;
    model "none" = no element, no cost): model ("none" | "palmgren", Palmgren's M = M0 + M1 of
    :mod:`rvtool.bearings.friction_torque`), kinematic_viscosity nu [m^2/s] of the lubricant,
    f0_ball, f1_ball (main and input ball bearings) and f0_needle, f1_needle (eccentric needle
    bearings) [-], regularization_speed [rad/s] of the sign. The defaults are chosen here, inside the
    ranges tabulated by Harris & Kotzalas (oil bath: f0 = 2 for angular-contact/deep-groove ball
    bearings, 4 for needle bearings; f1 = 7e-4 ball, 5e-4 needle); ISO VG 32 at 40 degC."""
    model: str = "none"
    kinematic_viscosity: float = 3.2e-5
    f0_ball: float = 2.0
    f1_ball: float = 7e-4
    f0_needle: float = 4.0
    f1_needle: float = 5e-4
    regularization_speed: float = 1e-2

    def __post_init__(self):
        if self.model not in ("none", "palmgren"):
            raise RvtoolInputError(f"bearing_friction.model = {self.model!r}; valid choices are ['none', 'palmgren']")
        check_positive("bearing_friction.kinematic_viscosity", self.kinematic_viscosity)
        check_positive("bearing_friction.f0_ball", self.f0_ball)
        check_nonnegative("bearing_friction.f1_ball", self.f1_ball)
        check_positive("bearing_friction.f0_needle", self.f0_needle)
        check_nonnegative("bearing_friction.f1_needle", self.f1_needle)
        check_positive("bearing_friction.regularization_speed", self.regularization_speed)


@dataclass(frozen=True, kw_only=True)
class CycloidDesign:
    """A single-stage cycloid drive with one or two wheels (see rvtool/designs/rd40.toml)."""
    name: str
    n_wheels: int
    rated_torque: float
    input_speed_rpm: float
    material: Material
    pins: Pins
    wheels: Wheels
    pin_contact: PinContact
    output_pins: OutputPins
    eccentric_bearing: NeedleBearing
    main_bearing: BallBearingSpec
    input_bearing: BallBearingSpec
    bodies: Bodies = field(default_factory=Bodies)
    housing: Housing = field(default_factory=Housing)
    bearing_friction: BearingFriction = field(default_factory=BearingFriction)

    def __post_init__(self):
        if self.n_wheels != len(self.wheels.midplanes):
            raise RvtoolInputError(f"n_wheels = {self.n_wheels} but wheels.midplanes has {len(self.wheels.midplanes)} entries")
        check_positive("rated_torque", self.rated_torque)
        check_positive("input_speed_rpm", self.input_speed_rpm)
        zg = self.wheels.n_teeth if self.wheels.n_teeth is not None else self.pins.n_pins - 1
        if zg != self.pins.n_pins - 1:
            raise RvtoolInputError(f"wheels.n_teeth = {zg} with pins.n_pins = {self.pins.n_pins}: only Z_pins = Z_wheel + 1 "
                                   f"is supported (valid: wheels.n_teeth = {self.pins.n_pins - 1})")
        needed = self.wheels.eccentricity + self.output_pins.pin_radius
        if self.output_pins.hole_radius < needed - 1e-4:
            raise RvtoolInputError(f"output_pins.hole_radius = {self.output_pins.hole_radius} m cannot pass the eccentric "
                                   f"motion; valid range [{needed:.6g}, inf) m (pin radius + eccentricity)")
        r_pins = self.pins.pin_circle_radius + self.pins.pin_radius
        if self.housing.model == "ports" and self.housing.inner_radius < r_pins - 1e-12:
            raise RvtoolInputError(f"housing.inner_radius = {self.housing.inner_radius} m cuts through the ring pins; "
                                   f"valid range [{r_pins:.6g}, outer_radius) m (pin circle radius + pin radius)")

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


_SECTIONS = {"material": Material, "pins": Pins, "wheels": Wheels, "pin_contact": PinContact,
             "output_pins": OutputPins, "eccentric_bearing": NeedleBearing, "main_bearing": BallBearingSpec,
             "input_bearing": BallBearingSpec, "bodies": Bodies, "housing": Housing,
             "bearing_friction": BearingFriction}


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


def build_section(cls, section, data):
    """Construct the component spec ``cls`` from the design-file table ``data`` of ``[section]``:
    lists become tuples, unknown keys and type errors are reported with the section name, and a
    component's own validation error is prefixed with the section so it names the key path
    (e.g. ``wheels.eccentricity``). Every topology's design loader uses this one function."""
    if not isinstance(data, dict):
        raise RvtoolInputError(f"[{section}] must be a table of keys; got {type(data).__name__} {data!r}")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = set(data) - names
    if unknown:
        raise RvtoolInputError(f"[{section}] has unknown keys {sorted(unknown)}; valid keys are {sorted(names)}")
    hints = _field_types(cls)
    for k, v in data.items():
        _check_type(k if section == "design" else f"{section}.{k}", v, hints.get(k))
    kw = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
    try:
        return cls(**kw)
    except TypeError as exc:
        raise RvtoolInputError(f"[{section}]: {exc}") from None
    except RvtoolInputError as exc:
        # a component spec validates its own fields; the design file's key path names the section
        msg = str(exc)
        raise RvtoolInputError(msg if msg.startswith(section + ".") or section == "design" else f"{section}.{msg}") from None


def design_from_dict(d):
    d = dict(d)
    topology = d.pop("topology", "cycloid")   # the key of rvtool.assembly.topologies; this loader is the cycloid's
    if topology != "cycloid":
        raise RvtoolInputError(f"topology = {topology!r}: this is the cycloid loader; load the file with "
                               "rvtool.load_design (rvtool.assembly.topologies), which picks the topology's loader")
    kw = {}
    for sec, cls in _SECTIONS.items():
        if sec not in d and sec not in ("bodies", "housing", "bearing_friction"):
            raise RvtoolInputError(f"section [{sec}] is missing from the design")
        kw[sec] = build_section(cls, sec, d.pop(sec, {}))
    return build_section(CycloidDesign, "design", {**d, **kw})


def load_design(path):
    """Load a design TOML file into its validated design: the file's ``topology`` key picks the
    topology's loader (:mod:`rvtool.assembly.topologies`; absent: "cycloid", :class:`CycloidDesign`)."""
    from . import topologies
    return topologies.design_from_table(topologies.read_table(path))


def replace(design, **sections):
    """A copy of ``design`` with sections replaced by dicts of changed fields, e.g.
    ``replace(d, wheels={"n_slices": 4}, n_wheels=1)``."""
    kw = {}
    for k, v in sections.items():
        cur = getattr(design, k)
        kw[k] = dataclasses.replace(cur, **v) if isinstance(v, dict) else v
    return dataclasses.replace(design, **kw)
