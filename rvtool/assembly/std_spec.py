"""Small-tooth-difference involute reducer specification (topology ``"std-involute"``): plain
data (TOML) loaded into frozen dataclasses and validated on load.

Sections are component specs built by :func:`rvtool.assembly.spec.build_section`:
``[wheel]`` and ``[ring]`` are :class:`~rvtool.geometry.involute.InvoluteGear` (nested
``[wheel.rack]`` / ``[wheel.modification]`` tables are its :class:`BasicRack` and
:class:`FlankModification`), ``[wheels]`` the arrangement of the eccentric wheels
(:class:`WheelSet`), ``[mesh]`` the contact settings of the wheel--ring meshes
(:class:`MeshSettings`), and the bearing, output-pin, material, body and housing sections the
same specs as the cycloid design. Two fields of the gear sections follow from the design and
are not written in the file: each gear's ``name`` (its section, so that its errors name the
key path, e.g. ``wheel.profile_shift``), ``ring.internal = true``, and the wheel's face
width, which is ``wheels.width``.

Feasibility (paper: internal gearing with a small tooth-number difference): the tooth
difference z_ring - z_wheel in [1, 4]; the internal pair at centre distance
a = ``wheels.eccentricity`` (the eccentricity IS the working centre distance) is checked by
:class:`~rvtool.geometry.involute.InvolutePair` for involute, trochoid (tip) and, with
``mesh.radial_assembly = true``, tip-to-tip interference in radial assembly; a non-negative
backlash; output holes that pass the eccentric motion and lie inside the wheel's root circle;
an elastic housing (``housing.model = "ports"``) whose bore clears the ring's root circle.
Errors name the design key (``wheel.*``, ``ring.*``, ``wheels.eccentricity``).
"""
import copy
import tomllib
from dataclasses import dataclass, field

import numpy as np

from ..bearings.spec import AngularContactPair, BallBearing, NeedleBearing
from ..errors import RvtoolInputError
from ..units import angle_field
from ..geometry.involute import BasicRack, FlankModification, InvoluteGear, InvolutePair, line_gap
from ..validation import check_finite, check_integer, check_nonnegative, check_positive
from ..output_pins.spec import OutputPinMechanism
from ..structure import ElasticMaterial
from .spec import BEARING_KINDS, Bodies, Housing, build_section, load_sections, replace

TOPOLOGY = "std-involute"
TOOTH_DIFFERENCES = (1, 4)
"""Valid range of z_ring - z_wheel (the paper's small tooth-number difference)."""


@dataclass(frozen=True, kw_only=True)
class WheelSet:
    """The external involute wheels on the eccentric journals.

    eccentricity: e [m], the working centre distance of the wheel--ring pair. width: face width of
    each wheel [m]. midplanes: axial midplanes of the wheels relative to the flange [m], one per
    wheel. phases: eccentric phases of the journals [rad] (file: ``phases_deg``; opposed journals
    for two wheels)."""
    eccentricity: float
    width: float
    midplanes: tuple = (0.0,)
    phases: tuple = angle_field((0.0,))

    def __post_init__(self):
        check_positive("eccentricity", self.eccentricity)
        check_positive("width", self.width)
        if len(self.midplanes) != len(self.phases):
            raise RvtoolInputError(f"midplanes ({len(self.midplanes)}) and phases_deg ({len(self.phases)}) must "
                                   "have one entry per wheel")
        check_finite("phases", np.asarray(self.phases, float))
        if not 1 <= len(self.midplanes) <= 2:
            raise RvtoolInputError(f"midplanes has {len(self.midplanes)} entries, one per wheel; valid range [1, 2] "
                                   "wheels (n_wheels)")


@dataclass(frozen=True, kw_only=True)
class MeshSettings:
    """Contact settings of each wheel--ring mesh (:class:`~rvtool.contact.involute_set.GearMesh`).

    n_slices: slices across the face width [-]. window: teeth of the wheel evaluated on each side
    of the one at the pitch point [-] (None: ceil(epsilon_alpha / 2) + 1). clearance: uniform
    clearance of the flanks [m]. damping: contact damping of the whole mesh [N s/m]. ramp_depth:
    depth of the damping ramp [m]. mu: friction coefficient [-] (regularized friction; 0 = none).
    radial_assembly: check tip-to-tip interference when the wheel is moved radially into the ring
    (false: the wheels are assembled axially)."""
    n_slices: int = 1
    window: int | None = None
    clearance: float = 0.0
    damping: float = 0.0
    ramp_depth: float = 1e-6
    mu: float = 0.0
    radial_assembly: bool = False

    def __post_init__(self):
        # upper bound: the wheels' slices (rvtool.assembly.spec.Wheels, 64: the largest resolution the solvers are
        # built and tested for); a mistyped 1e6 built for minutes instead of failing
        check_integer("n_slices", self.n_slices, 1, 64)
        if self.window is not None:
            check_integer("window", self.window, 0)
        check_nonnegative("clearance", self.clearance)
        check_nonnegative("damping", self.damping)
        check_positive("ramp_depth", self.ramp_depth)
        check_nonnegative("mu", self.mu)


_PAIR_KEYS = (("gear_a's", "the wheel's"), ("gear_b's", "the ring's"), ("gear_a.", "wheel."), ("gear_b.", "ring."),
              ("check_radial_assembly = False", "mesh.radial_assembly = false"),
              ("centre_distance", "wheels.eccentricity"))


def internal_pair(wheel, ring, eccentricity, radial_assembly):
    """The wheel--ring :class:`InvolutePair` at centre distance ``eccentricity`` [m]; its
    feasibility errors are re-worded with the design's key paths."""
    try:
        return InvolutePair(gear_a=wheel, gear_b=ring, centre_distance=eccentricity,
                            check_radial_assembly=radial_assembly)
    except RvtoolInputError as exc:
        msg = str(exc)
        for old, new in _PAIR_KEYS:
            msg = msg.replace(old, new)
        raise RvtoolInputError(msg) from None


@dataclass(frozen=True, kw_only=True)
class StdInvoluteDesign:
    """A small-tooth-difference involute reducer with one or two wheels (see
    rvtool/designs/std_involute.toml): the wheels on the eccentric input shaft mesh a fixed
    internal ring gear; the output flange takes the wheels' rotation through pins in holes.

    name: the design's label. n_wheels: number of wheels [-] (1 or 2). rated_torque: the rated
    output torque [N m]. input_speed_rpm: the rated input speed [rpm]."""
    name: str
    n_wheels: int
    rated_torque: float
    input_speed_rpm: float
    material: ElasticMaterial
    wheels: WheelSet
    wheel: InvoluteGear
    ring: InvoluteGear
    mesh: MeshSettings
    output_pins: OutputPinMechanism
    eccentric_bearing: NeedleBearing
    main_bearing: BallBearing | AngularContactPair | None
    input_bearing: BallBearing | None
    bodies: Bodies = field(default_factory=Bodies)
    housing: Housing = field(default_factory=Housing)
    #: the file-form data this design was loaded from (what :func:`replace` changes and re-loads)
    source: dict | None = field(default=None, compare=False, hash=False, repr=False, metadata={"file": False})
    pair: InvolutePair = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        check_integer("n_wheels", self.n_wheels, 1, 2)
        if self.n_wheels != len(self.wheels.midplanes):
            raise RvtoolInputError(f"n_wheels = {self.n_wheels} but wheels.midplanes has {len(self.wheels.midplanes)} "
                                   "entries; valid: one entry per wheel in wheels.midplanes and wheels.phases_deg "
                                   "(and in output_pins.wheel_midplanes, output_pins.gap_offsets where the file gives them)")
        check_positive("rated_torque", self.rated_torque)
        check_positive("input_speed_rpm", self.input_speed_rpm)
        W, R = self.wheel, self.ring
        if W.internal:
            raise RvtoolInputError("wheel.internal = True; valid: false (the wheels are external gears)")
        if not R.internal:
            raise RvtoolInputError("ring.internal = False; valid: true (the ring is an internal gear)")
        if W.face_width != self.wheels.width:
            raise RvtoolInputError(f"wheel.face_width = {W.face_width} m differs from wheels.width = {self.wheels.width} m; "
                                   "valid: equal (the wheel's face width is wheels.width)")
        # the window's 2 window + 1 teeth of the wheel around the pitch point: beyond the wheel's teeth a tooth
        # would be evaluated twice (and the rows grow with the window: a mistyped 1e6 built for minutes)
        w_max = (W.n_teeth - 1) // 2
        if self.mesh.window is not None and self.mesh.window > w_max:
            raise RvtoolInputError(f"mesh.window = {self.mesh.window} is outside the valid range [0, {w_max}] (integer; "
                                   f"at most (wheel.n_teeth - 1) // 2 teeth on each side of the pitch point, "
                                   f"wheel.n_teeth = {W.n_teeth})")
        dz = R.n_teeth - W.n_teeth
        lo, hi = TOOTH_DIFFERENCES
        if not lo <= dz <= hi:
            raise RvtoolInputError(f"ring.n_teeth - wheel.n_teeth = {R.n_teeth} - {W.n_teeth} = {dz} is outside the "
                                   f"valid range [{lo}, {hi}] (small tooth-number difference)")
        span = max(self.wheels.midplanes) - min(self.wheels.midplanes) + self.wheels.width
        if R.face_width < span - 1e-12:
            raise RvtoolInputError(f"ring.face_width = {R.face_width} m does not cover the wheels; valid range "
                                   f"[{span:.6g}, inf) m (midplane span + wheels.width)")
        if self.housing.model == "ports" and self.housing.structure.inner_radius < R.root_radius - 1e-12:
            raise RvtoolInputError(f"housing.structure.inner_radius = {self.housing.structure.inner_radius} m cuts "
                                   "through the ring's teeth; "
                                   f"valid range [{R.root_radius:.6g}, outer_radius) m (the ring's root radius)")
        e = self.wheels.eccentricity
        op = self.output_pins
        needed = e + op.pin_radius
        if op.hole_radius < needed:
            raise RvtoolInputError(f"output_pins.hole_radius = {op.hole_radius} m cannot pass the eccentric motion; "
                                   f"valid range [{needed:.6g}, inf) m (output_pins.pin_radius + wheels.eccentricity)")
        outer = op.pin_circle_radius + op.hole_radius
        if outer >= W.root_radius:
            raise RvtoolInputError(f"output_pins.pin_circle_radius = {op.pin_circle_radius} m puts the holes (radius "
                                   f"{op.hole_radius} m) through the wheel's root circle (radius {W.root_radius:.6g} m); "
                                   f"valid range (0, {W.root_radius - op.hole_radius:.6g}) m")
        pair = internal_pair(W, R, e, self.mesh.radial_assembly)
        # backlash: with the drive flanks (line 0) touching, the coast flanks (line 1) must not overlap
        gap, _ = line_gap(pair, 0.0, pair.mesh_phase(0), 1)
        if gap < -1e-12:
            raise RvtoolInputError(f"wheels.eccentricity = {e} m leaves negative backlash ({gap:.3g} m along the line of "
                                   f"action) with wheel.profile_shift = {W.profile_shift}, ring.profile_shift = "
                                   f"{R.profile_shift} and the thickness allowances; valid: backlash >= 0 (a larger "
                                   "eccentricity or larger thickness allowances)")
        object.__setattr__(self, "pair", pair)

    @property
    def tooth_difference(self):
        return self.ring.n_teeth - self.wheel.n_teeth

    @property
    def ratio(self):
        """Signed nominal ratio i = omega_in / omega_out (fixed ring, output through the wheels'
        rotation): i = -z_wheel / (z_ring - z_wheel)."""
        return -self.wheel.n_teeth / self.tooth_difference

    def replace(self, **sections):
        """A copy with sections replaced by dicts of changed fields (:func:`rvtool.assembly.spec.replace`)."""
        return replace(self, **sections)


_SECTIONS = {"material": ElasticMaterial, "wheels": WheelSet, "mesh": MeshSettings, "output_pins": OutputPinMechanism,
             "eccentric_bearing": NeedleBearing, "main_bearing": BEARING_KINDS, "input_bearing": BEARING_KINDS,
             "bodies": Bodies, "housing": Housing}
_ELASTIC = {"youngs_modulus": "material.youngs_modulus", "poisson_ratio": "material.poisson_ratio"}
#: Keys a table may leave out (as :data:`rvtool.assembly.spec.LINKS`): the output pins as the
#: cycloid's (hole circle = pin circle, contact length = wheel width, the wheels' midplanes), the
#: bearings and the housing annulus of the design's material.
LINKS = {
    "output_pins": {"hole_circle_radius": "output_pins.pin_circle_radius", "contact_length": "wheels.width",
                    "wheel_midplanes": "wheels.midplanes", **_ELASTIC},
    "main_bearing": dict(_ELASTIC),
    "input_bearing": dict(_ELASTIC),
    "housing.structure": {"material": "material"},
}
_OPTIONAL = ("bodies", "housing", "mesh")
#: Fields of a table the design sets, not the file (the wheel's face width is [wheels] width, the
#: ring is internal, a gear is named after its table): not file keys, so the templates and the
#: format documentation leave them out.
SET_BY_DESIGN = {"wheel": ("face_width", "internal", "name"), "ring": ("internal", "name")}


def gear_section(section, data, **derived):
    """An :class:`InvoluteGear` from the design table ``[section]``: nested ``rack`` and
    ``modification`` tables are built as their own specs; ``derived`` fields (set by the design,
    not the file) must not be written in the table."""
    if not isinstance(data, dict):
        raise RvtoolInputError(f"[{section}] must be a table of keys (an InvoluteGear spec); got {type(data).__name__}")
    data = dict(data)
    if "name" in data:
        raise RvtoolInputError(f"{section}.name is set by the design (the gear is named {section!r}); remove it "
                               f"from [{section}]")
    for k in derived:
        if k in data:
            raise RvtoolInputError(f"{section}.{k} is set by the design ({derived[k]!r}); remove it from [{section}]")
    if "rack" in data:
        data["rack"] = build_section(BasicRack, f"{section}.rack", data["rack"])
    if "modification" in data:
        data["modification"] = build_section(FlankModification, f"{section}.modification", data["modification"])
    return build_section(InvoluteGear, section, {**data, **derived, "name": section})


def design_from_dict(d):
    """A validated :class:`StdInvoluteDesign` from the parsed design file (without its topology key)."""
    from .topologies import upgrade_table
    d = upgrade_table(d)
    source = {"topology": "std-involute", **copy.deepcopy(dict(d))}
    d = dict(d)
    kw = load_sections(d, _SECTIONS, optional=_OPTIONAL, links=LINKS, derived={})
    for sec in ("wheel", "ring"):
        if sec not in d:
            raise RvtoolInputError(f"section [{sec}] is missing from the design")
    kw["wheel"] = gear_section("wheel", d.pop("wheel"), face_width=kw["wheels"].width, internal=False)
    kw["ring"] = gear_section("ring", d.pop("ring"), internal=True)
    return build_section(StdInvoluteDesign, "design", {**d, **kw, "source": source})


def load_design(path):
    """Load a ``topology = "std-involute"`` design TOML file into a validated :class:`StdInvoluteDesign`."""
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    topology = data.pop("topology", None)
    if topology != TOPOLOGY:
        raise RvtoolInputError(f"topology = {topology!r}; valid: {TOPOLOGY!r} for this loader")
    return design_from_dict(data)
