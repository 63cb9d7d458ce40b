"""RV reducer specification: plain data (TOML) loaded into frozen dataclasses. Every
design section IS a component spec (:func:`rvtool.assembly.spec.build_section`): the
cycloid stage reuses the cycloid sections (``pins``, ``wheels``, ``pin_contact``), the
gears are :class:`~rvtool.geometry.involute.InvoluteGear`, the bearings are the bearing
specs (:class:`~rvtool.bearings.spec.NeedleBearing`, :class:`~rvtool.bearings.tapered.TaperedPair`,
:class:`~rvtool.bearings.spec.AngularContactPair` with its ``row`` subtable). Only the
RV-specific parts (crank count and crank manufacturing deviations, the involute-stage
numerics, the rigid-body data, the three-stage input) are defined here.

Topology keys (``topology``): ``"rv2"`` (input sun -> cranks) and
``"rv3"`` (offset input pinion -> compound gear carrying the sun -> cranks).
"""
import copy
import dataclasses
import math
import tomllib
from dataclasses import dataclass, field

import numpy as np

from ...bearings.spec import AngularContactPair, BallBearing, NeedleBearing
from ...bearings.tapered import TaperedPair, TaperedRollerBearing
from ...errors import RvtoolInputError
from ...units import angle_field
from ...geometry.involute import BasicRack, FlankModification, InvoluteGear, InvolutePair
from ...validation import check_finite, check_positive, check_range
from ...geometry.cycloid import CycloidProfile
from ...structure import ElasticMaterial
from ...structure.carrier import CarrierStructure
from ...structure.crank_beam import CrankShaft
from ...structure.floating_ports import FloatingDynamics
from ..spec import (LINKS, BearingFriction, Housing, PinContact, Pins, Wheels, build_section, check_pair_keys,
                    load_sections)

TOPOLOGIES = ("rv2", "rv3")


@dataclass(frozen=True, kw_only=True)
class Cranks:
    """The floating crankshafts and their manufacturing deviations (a variant is a design).

    count: N_c, the number of cranks [-] (2 or 3, equally spaced on the crank circle, whose radius
    is the sun--crank-gear centre distance). mass: mass of each crank [kg]. inertia: polar inertia
    of each crank [kg m^2].
    phase_errors: the eccentric phase of crank k off its nominal by this angle [rad], one per crank,
    on both journals (an empty list: none) (file: ``phase_errors_deg``); eccentricity_errors: e_k - e
    [m] per crank, each greater than -wheels.eccentricity (an empty list: none);
    gear_pitch_deviations: per crank, the single pitch deviations f_pt,j [m] of its spur gear
    (``crank_gear.n_teeth`` entries summing to zero, as ``InvoluteGear.single_pitch_deviations``; an
    empty list: every crank gear as ``crank_gear``).
    wheel_bore_errors: per crank k, per wheel j, the (x, y) position error [m] of crank k's bore in
    wheel j (the needle row's outer ring centre), in the wheel's frame, off the crank circle (an
    empty list: every bore at its true position; a position tolerance of ISO 1101).
    carrier_bore_errors: per crank k, the (x, y) position error [m] of crank k's bearing seat in the
    carrier (the tapered pair's cup centre), in the carrier's frame (an empty list: none).
    shaft: the crankshaft as a beam between its tapered rows
    (:class:`~rvtool.structure.crank_beam.CrankShaft`, sub-table ``[cranks.shaft]``; rigid by
    default, the "nothing" variant).
    dynamics: the cranks as rigid or floating flexible bodies in driven and quasi-static runs
    (:class:`~rvtool.structure.floating_ports.FloatingDynamics`, sub-table ``[cranks.dynamics]``;
    rigid by default; the beam of ``[cranks.shaft]``'s geometry, :mod:`rvtool.assembly.rv.flexible_cranks`)."""
    count: int
    mass: float = 0.25
    inertia: float = 2.0e-5
    phase_errors: tuple = angle_field(())
    eccentricity_errors: tuple = ()
    gear_pitch_deviations: tuple = ()
    wheel_bore_errors: tuple = ()
    carrier_bore_errors: tuple = ()
    shaft: CrankShaft = field(default_factory=CrankShaft)
    dynamics: FloatingDynamics = field(default_factory=FloatingDynamics)

    def __post_init__(self):
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count not in (2, 3):
            raise RvtoolInputError(f"cranks.count = {self.count!r} is outside the valid range [2, 3] (integer): "
                                   "an RV stage carries 2 or 3 floating crankshafts")
        check_positive("cranks.mass", self.mass)
        check_positive("cranks.inertia", self.inertia)
        for nm, key in (("phase_errors", "phase_errors_deg"), ("eccentricity_errors", "eccentricity_errors")):
            v = getattr(self, nm)     # key: the design file's name (the phase errors are given in degrees)
            if len(v) not in (0, self.count):
                raise RvtoolInputError(f"cranks.{key} has {len(v)} entries; valid: 0 or cranks.count = {self.count}")
            check_finite(f"cranks.{key}", v)
        if len(self.gear_pitch_deviations) not in (0, self.count):
            raise RvtoolInputError(f"cranks.gear_pitch_deviations has {len(self.gear_pitch_deviations)} entries; "
                                   f"valid: 0 or cranks.count = {self.count} (one list of pitch deviations per crank)")
        for k, f in enumerate(self.gear_pitch_deviations):
            check_finite(f"cranks.gear_pitch_deviations[{k}]", f)
        if self.carrier_bore_errors:
            e = np.asarray(self.carrier_bore_errors, float)
            if e.shape != (self.count, 2):
                raise RvtoolInputError(f"cranks.carrier_bore_errors must have shape ({self.count}, 2) (one (x, y) per "
                                       f"crank) or be empty; got {e.shape}")
            check_finite("cranks.carrier_bore_errors", e)
        if self.wheel_bore_errors:
            e = np.asarray(self.wheel_bore_errors, float)
            if e.ndim != 3 or e.shape[0] != self.count or e.shape[2] != 2:
                raise RvtoolInputError(f"cranks.wheel_bore_errors must have shape ({self.count}, n_wheels, 2) (per "
                                       f"crank, one (x, y) per wheel) or be empty; got {e.shape}")
            check_finite("cranks.wheel_bore_errors", e)

    def phase_error(self, k):
        """Eccentric phase error of crank k [rad]."""
        return float(self.phase_errors[k]) if self.phase_errors else 0.0

    def eccentricity_error(self, k):
        return float(self.eccentricity_errors[k]) if self.eccentricity_errors else 0.0

    def wheel_bore_error(self, k, j):
        """(x, y) position error [m] of crank k's bore in wheel j (wheel frame)."""
        if not self.wheel_bore_errors:
            return 0.0, 0.0
        e = self.wheel_bore_errors[k][j]
        return float(e[0]), float(e[1])

    def carrier_bore_error(self, k):
        """(x, y) position error [m] of crank k's seat in the carrier (carrier frame)."""
        if not self.carrier_bore_errors:
            return 0.0, 0.0
        e = self.carrier_bore_errors[k]
        return float(e[0]), float(e[1])


@dataclass(frozen=True, kw_only=True)
class InvoluteStage:
    """Numerics and friction of the involute meshes (each mesh a
    :class:`~rvtool.contact.involute_set.GearMesh`).

    n_slices: slices across the face width [-]. window: teeth either side of the pitch point [-]
    (None: from the contact ratio). damping: contact damping per mesh [N s/m]. ramp_depth: depth
    of the damping ramp [m]. mu: friction coefficient [-] (0 = no friction: the frictionless code
    path). friction_model: "regularized" (Eq. (friction) velocity law) or "anchor" (stick--slip
    anchors per row, as ``pin_contact``). tangential_stiffness: stiffness of the anchors per tooth
    pair over the face width [N/m] (0 = Mindlin's ratio 2(1 - nu)/(2 - nu) of the pair's normal
    secant stiffness of Eq. (series_contact) at reference_force, mid path of contact).
    reference_force: the tooth-pair load [N] at which that normal secant stiffness is taken."""
    n_slices: int = 1
    window: int | None = None
    damping: float = 0.0
    ramp_depth: float = 1e-6
    mu: float = 0.0
    friction_model: str = "regularized"
    tangential_stiffness: float = 0.0
    reference_force: float = 1000.0

    def __post_init__(self):
        # upper bound: the wheels' (rvtool.assembly.spec.Wheels, 64: the largest resolution the solvers are built
        # and tested for); a mistyped 1e6 built for minutes instead of failing
        if isinstance(self.n_slices, bool) or not isinstance(self.n_slices, int) or not 1 <= self.n_slices <= 64:
            raise RvtoolInputError(f"involute_stage.n_slices = {self.n_slices!r} is outside the valid range [1, 64] "
                                   "(integer)")
        check_range("involute_stage.damping", self.damping, 0.0)
        check_positive("involute_stage.ramp_depth", self.ramp_depth)
        check_range("involute_stage.mu", self.mu, 0.0)
        if self.friction_model not in ("regularized", "anchor"):
            raise RvtoolInputError(f"involute_stage.friction_model = {self.friction_model!r}; valid choices are "
                                   "['regularized', 'anchor']")
        check_range("involute_stage.tangential_stiffness", self.tangential_stiffness, 0.0)
        check_positive("involute_stage.reference_force", self.reference_force)


#: retained coordinates of the carrier / output flange (``bodies.carrier_coordinates``), of the
#: wheels (``bodies.wheel_coordinates``) and of the cranks (``bodies.crank_coordinates``)
CARRIER_COORDINATES = ("planar", "spatial")

#: valid range of ``bodies.tilt_slices`` (width slices of the families on tilting wheels / cranks)
TILT_SLICES = (2, 32)


@dataclass(frozen=True, kw_only=True)
class RvBodies:
    """Rigid-body data of the RV bodies.

    input: the planar coordinates the input body (the sun, or the three-stage pinion) keeps (its
    theta is driven; x, y listed = floating, else held by its bearings as rigid). sun_mass: mass
    of the sun (or the compound gear) [kg]. sun_inertia: its polar inertia [kg m^2]. pinion_mass:
    mass of the three-stage input pinion [kg]. pinion_inertia: its polar inertia [kg m^2].
    carrier_mass: mass of the carrier, both halves joined rigidly [kg]. carrier_inertia: its polar
    inertia [kg m^2].
    carrier_coordinates: the coordinates the carrier / output flange retains (issue 32):
    ``"planar"`` (x, y, theta; its axial translation and tilts held, the main bearing's axial force
    and tilting moment observations -- the default, today's figures) or ``"spatial"`` (also z,
    gamma_x, gamma_y on the main-bearing rows: :class:`rvtool.bearings.spatial_set.SpatialBearingSet`).
    carrier_tilt_inertia: transverse inertia [kg m^2] of the carrier about a diameter through the
    mounting centre (dynamic runs of a spatial carrier only); None: half the polar inertia (a thin
    disc, assumed).
    wheel_coordinates: ``"planar"`` (default) or ``"spatial"``: each cycloid wheel also retains its
    axial translation and two tilts about its mid-plane; the ring-pin mesh and the needle rows on it
    are sliced across the wheel width with the relative tilt (Eq. (skew),
    :class:`rvtool.contact.skew.SkewSlices`). crank_coordinates: likewise for the crankshafts
    (tilts about the centre of their tapered pair; the tapered rows on the 5-DOF roller law, the
    needle rows sliced with the crank's arm to each wheel). tilt_slices: width slices of every
    family on a spatial wheel or crank [-] (:data:`TILT_SLICES`). wheel_tilt_inertia: transverse
    inertia [kg m^2] of a wheel (None: a thin disc, half its polar inertia, assumed).
    input_coordinates: ``"planar"`` (default) or ``"spatial"``: the two-stage input shaft (the sun)
    also retains its axial translation and two tilts about the sun gear's mid-face (at the crank gears'
    station), and the sun--crank meshes are sliced across the face with its tilt. Only a floating sun
    (``input`` lists x and y) has a tilt to retain: a sun whose x, y are held by its bearings as rigid
    has its tilt held by the same bearings (spatial would equal planar), refused by name. Its
    transverse inertia is half the polar one (a thin disc, assumed; dynamic runs only)."""
    input: tuple = ("theta",)
    sun_mass: float = 0.15
    sun_inertia: float = 1.0e-5
    pinion_mass: float = 0.1
    pinion_inertia: float = 5.0e-6
    carrier_mass: float = 3.0
    carrier_inertia: float = 6.0e-3
    carrier_coordinates: str = "planar"
    carrier_tilt_inertia: float | None = None
    wheel_coordinates: str = "planar"
    crank_coordinates: str = "planar"
    tilt_slices: int = 2
    wheel_tilt_inertia: float | None = None
    input_coordinates: str = "planar"

    def __post_init__(self):
        for c in self.input:
            if c not in ("x", "y", "theta"):
                raise RvtoolInputError(f"bodies.input contains {c!r}; valid coordinates are ['x', 'y', 'theta']")
        if "theta" not in self.input:
            raise RvtoolInputError("bodies.input must contain 'theta' (the driven input rotation)")
        for nm in ("sun_mass", "sun_inertia", "pinion_mass", "pinion_inertia", "carrier_mass", "carrier_inertia"):
            check_positive(f"bodies.{nm}", getattr(self, nm))
        if self.carrier_coordinates not in CARRIER_COORDINATES:
            raise RvtoolInputError(f"bodies.carrier_coordinates = {self.carrier_coordinates!r}; valid choices are "
                                   f"{list(CARRIER_COORDINATES)}")
        if self.carrier_tilt_inertia is not None:
            check_positive("bodies.carrier_tilt_inertia", self.carrier_tilt_inertia)
        for nm in ("wheel_coordinates", "crank_coordinates", "input_coordinates"):
            if getattr(self, nm) not in CARRIER_COORDINATES:
                raise RvtoolInputError(f"bodies.{nm} = {getattr(self, nm)!r}; valid choices are {list(CARRIER_COORDINATES)}")
        lo, hi = TILT_SLICES
        if isinstance(self.tilt_slices, bool) or not isinstance(self.tilt_slices, int) or not lo <= self.tilt_slices <= hi:
            raise RvtoolInputError(f"bodies.tilt_slices = {self.tilt_slices!r} is outside the valid range [{lo}, {hi}] "
                                   "(integer)")
        if self.wheel_tilt_inertia is not None:
            check_positive("bodies.wheel_tilt_inertia", self.wheel_tilt_inertia)
        if self.spatial_input and not {"x", "y"} <= set(self.input):
            raise RvtoolInputError(f"bodies.input_coordinates = 'spatial' with bodies.input = {list(self.input)}: the "
                                   "input shaft's x, y are held by its bearings as rigid, and so is its tilt (spatial "
                                   "would equal planar); valid: bodies.input = ['x', 'y', 'theta'] (a floating sun) "
                                   "or input_coordinates = 'planar'")

    @property
    def spatial_input(self):
        """True where the input shaft (the two-stage sun) retains its axial and tilt coordinates."""
        return self.input_coordinates == "spatial"

    @property
    def spatial_wheels(self):
        """True where the wheels retain their axial and tilt coordinates."""
        return self.wheel_coordinates == "spatial"

    @property
    def spatial_cranks(self):
        """True where the cranks retain their axial and tilt coordinates."""
        return self.crank_coordinates == "spatial"

    @property
    def spatial_carrier(self):
        """True where the carrier retains its axial and tilt coordinates."""
        return self.carrier_coordinates == "spatial"

    @property
    def tilt_inertia(self):
        """Transverse inertia [kg m^2] of the carrier (``carrier_tilt_inertia`` or half the polar inertia)."""
        return self.carrier_inertia / 2 if self.carrier_tilt_inertia is None else self.carrier_tilt_inertia


#: the carrier's body models (``carrier.body``)
CARRIER_BODIES = ("rigid", "ported")


@dataclass(frozen=True, kw_only=True)
class Carrier:
    """The carrier (output flange, pillars, end plate) that carries the crank bearings and sits in the main
    bearings (issue 30).

    body: ``"rigid"`` (today's model: the crank-bearing cups sit on the rigid carrier body; ``structure`` is
    unused) or ``"ported"`` (the carrier as a reduced structure, :mod:`rvtool.structure.carrier`: each crank's
    tapered pair acts on a seat that moves relative to the output face by the carrier's static seat
    compliance, :mod:`rvtool.assembly.carrier`). structure: the
    :class:`~rvtool.structure.carrier.CarrierStructure` (file: ``[carrier.structure]``; needed for
    ``"ported"``)."""
    body: str = "rigid"
    structure: CarrierStructure | None = None

    def __post_init__(self):
        if self.body not in CARRIER_BODIES:
            raise RvtoolInputError(f"carrier.body = {self.body!r}; valid choices are {list(CARRIER_BODIES)}")
        if self.body == "ported" and not isinstance(self.structure, CarrierStructure):
            raise RvtoolInputError("carrier.body = 'ported' needs the table [carrier.structure] (a CarrierStructure)")

    @property
    def ported(self):
        """True where the carrier is the reduced structure."""
        return self.body == "ported"


@dataclass(frozen=True, kw_only=True)
class InputStage:
    """Three-stage only: the offset input pinion meshing the compound gear's large gear.
    direction: the angle of the pinion axis seen from the reducer axis [rad] (file: ``direction_deg``)."""
    direction: float = angle_field(math.radians(60.0))

    def __post_init__(self):
        check_finite("input_stage.direction", self.direction)


@dataclass(frozen=True, kw_only=True)
class RVDesign:
    """An RV reducer (see rvtool/designs/rv40e.toml).

    name: the design's label. topology: "rv2" or "rv3". rated_torque: the rated output torque
    [N m]. input_speed_rpm: the rated input speed [rpm]. ratio_target: the declared nominal ratio
    [-] (catalogue), checked against the gear graph (None: not declared)."""
    name: str
    topology: str
    rated_torque: float
    input_speed_rpm: float
    ratio_target: float | None = None
    material: ElasticMaterial
    pins: Pins
    profile: CycloidProfile
    wheels: Wheels
    pin_contact: PinContact
    sun_gear: InvoluteGear
    crank_gear: InvoluteGear
    involute_stage: InvoluteStage = field(default_factory=InvoluteStage)
    cranks: Cranks
    eccentric_bearing: NeedleBearing
    crank_bearing: TaperedPair
    main_bearing: AngularContactPair
    bodies: RvBodies = field(default_factory=RvBodies)
    input_pinion: InvoluteGear | None = None
    compound_gear: InvoluteGear | None = None
    input_stage: InputStage = field(default_factory=InputStage)
    housing: Housing = field(default_factory=Housing)
    #: the carrier as a rigid body (default) or a reduced structure (issue 30; optional section)
    carrier: Carrier = field(default_factory=Carrier)
    #: Palmgren friction torque of the tapered crank bearings and the main bearings (issue 17; optional
    #: section, model "none" = no element, no cost)
    bearing_friction: BearingFriction = field(default_factory=BearingFriction)
    #: the file-form data this design was loaded from (what :func:`replace` changes and re-loads)
    source: dict | None = field(default=None, compare=False, hash=False, repr=False, metadata={"file": False})

    def __post_init__(self):
        if self.topology not in TOPOLOGIES:
            raise RvtoolInputError(f"topology = {self.topology!r}; valid choices are {list(TOPOLOGIES)}")
        check_positive("rated_torque", self.rated_torque)
        check_positive("input_speed_rpm", self.input_speed_rpm)
        if len(self.wheels.midplanes) != 2:
            raise RvtoolInputError(f"wheels.midplanes has {len(self.wheels.midplanes)} entries; an RV stage has two "
                                   "cycloid wheels (valid: 2 entries, phases 180 deg apart)")
        dphi = math.degrees(self.wheels.phases[1] - self.wheels.phases[0]) % 360.0
        if abs(dphi - 180.0) > 1e-9:
            raise RvtoolInputError(f"wheels.phases_deg = {[math.degrees(p) for p in self.wheels.phases]}: the two "
                                   "eccentric journals of "
                                   "a crank are 180 deg apart (valid: phases differing by 180)")
        zg = self.wheels.n_teeth if self.wheels.n_teeth is not None else self.pins.n_pins - 1
        if zg != self.pins.n_pins - 1:
            raise RvtoolInputError(f"wheels.n_teeth = {zg} with pins.n_pins = {self.pins.n_pins}: only Z_pins = "
                                   f"Z_wheel + 1 is supported (valid: wheels.n_teeth = {self.pins.n_pins - 1})")
        self.wheels.check_lobes(zg)
        if self.ratio_target is not None:
            check_positive("ratio_target", abs(self.ratio_target))
        self.housing.check_pin_ring(self.pins)
        if self.topology == "rv3" and (self.input_pinion is None or self.compound_gear is None):
            missing = [s for s in ("input_pinion", "compound_gear") if getattr(self, s) is None]
            raise RvtoolInputError(f"topology = 'rv3' needs the sections {missing}")
        if self.topology == "rv2" and (self.input_pinion is not None or self.compound_gear is not None):
            raise RvtoolInputError("topology = 'rv2' has no input_pinion / compound_gear sections; valid: "
                                   "remove them or set topology = 'rv3'")
        if self.cranks.wheel_bore_errors:
            nw = np.asarray(self.cranks.wheel_bore_errors, float).shape[1]
            if nw != self.n_wheels:
                raise RvtoolInputError(f"cranks.wheel_bore_errors has {nw} entries per crank; valid: one (x, y) per "
                                       f"wheel, {self.n_wheels} (wheels.midplanes)")
            if self.wheels.body == "ported":
                raise RvtoolInputError("cranks.wheel_bore_errors with wheels.body = 'ported' is not implemented (the "
                                       "ported wheel's FE bores sit at their true positions); valid: wheels.body = "
                                       "'rigid' or no cranks.wheel_bore_errors")
        e = self.wheels.eccentricity
        for k, de in enumerate(self.cranks.eccentricity_errors):
            if not e + de > 0:      # crank k's eccentric would sit on (or across) its axis
                raise RvtoolInputError(f"cranks.eccentricity_errors[{k}] = {de:.6g} m leaves crank {k} the eccentricity "
                                       f"{e + de:.6g} m; valid range ({-e:.6g}, inf) m (-wheels.eccentricity: e_k = e + "
                                       "error > 0)")
        z = self.crank_gear.n_teeth
        for k, f in enumerate(self.cranks.gear_pitch_deviations):
            f = tuple(float(x) for x in f)
            if len(f) != z:
                raise RvtoolInputError(f"cranks.gear_pitch_deviations[{k}] has {len(f)} entries; valid: "
                                       f"crank_gear.n_teeth = {z}")
            if abs(sum(f)) > 1e-9 * max(1.0, sum(abs(x) for x in f)) + 1e-15:
                raise RvtoolInputError(f"cranks.gear_pitch_deviations[{k}] sum to {sum(f):.3g} m; valid: sum 0 "
                                       "(the pitches of a closed circle add up to its circumference)")

    def crank_gear_of(self, k):
        """The spur gear of crank k: ``crank_gear`` with crank k's single pitch deviations
        (``cranks.gear_pitch_deviations``), or ``crank_gear`` itself when none are declared."""
        if not self.cranks.gear_pitch_deviations:
            return self.crank_gear
        return dataclasses.replace(self.crank_gear, single_pitch_deviations=tuple(
            float(x) for x in self.cranks.gear_pitch_deviations[k]))

    @property
    def n_wheels(self):
        return 2

    @property
    def ratio(self):
        """Signed nominal ratio from the gear graph (:mod:`rvtool.assembly.rv.gear_graph`)."""
        from .gear_graph import GearGraph
        return GearGraph.of(self).ratio

    def replace(self, **sections):
        """A copy with sections replaced by dicts of changed fields (``rvtool.assembly.spec.replace``)."""
        from ..spec import replace
        return replace(self, **sections)

    def with_mesh_stiffness_factor(self, factor):
        """A copy whose pin-contact law is the line law at ``factor`` times the current stiffness (as
        :meth:`rvtool.assembly.spec.CycloidDesign.with_mesh_stiffness_factor`)."""
        from ...contact.cycloid_set import secant_line_stiffness
        from ..spec import replace
        pc = self.pin_contact
        k = pc.stiffness if pc.stiffness > 0 else secant_line_stiffness(pc.reference_force, self.wheels.width)
        return replace(self, pin_contact={"law": "line", "stiffness": factor * k})

    def refined(self):
        """The design at refined numerical resolution: twice the wheel-profile samples and the involute
        slices (the reference of resolution error statements)."""
        w = dataclasses.replace(self.wheels, samples_per_tooth=2 * self.wheels.samples_per_tooth)
        st = dataclasses.replace(self.involute_stage, n_slices=2 * self.involute_stage.n_slices)
        return dataclasses.replace(self, wheels=w, involute_stage=st)

    def resolution_reference(self):
        """:meth:`refined` with the analytic closest-point search of the wheel profile: the reference
        of the quasi-static TE resolution error (rvtool.protocols.resolution; the discrete table
        search is the one resolution whose error is not negligible, cases/benchmarks/work_precision_rv.py)."""
        # through replace (the file-form data), not dataclasses.replace: a later replace re-loads the source
        return self.replace(wheels={"samples_per_tooth": 2 * self.wheels.samples_per_tooth, "search": "analytic"},
                            involute_stage={"n_slices": 2 * self.involute_stage.n_slices})


def _gear(section, data):
    """An InvoluteGear from its table; the optional sub-tables ``rack`` (BasicRack) and
    ``modification`` (FlankModification) are component specs too. The gear's name is the section
    (its validation errors then name the key path)."""
    data = _table(section, data)
    for key, cls in (("rack", BasicRack), ("modification", FlankModification)):
        if key in data:
            data[key] = build_section(cls, f"{section}.{key}", _table(f"{section}.{key}", data[key]))
    data["name"] = section
    return build_section(InvoluteGear, section, data)


def _table(section, data):
    """``data`` as a dict, or an error naming the section when the file holds something else there."""
    if not isinstance(data, dict):
        raise RvtoolInputError(f"[{section}] must be a table of keys; got {type(data).__name__} {data!r}")
    return dict(data)


def _flat_rows(cls, data):
    """A pair's table whose identical rows' keys sit in the pair's own table (the loader's flat
    rule, :func:`rvtool.assembly.spec._bearing_section`; what ``rvtool new`` writes): those keys
    become one ``row`` table. A table with ``rows`` or ``row`` is returned unchanged."""
    if "rows" in data or "row" in data:
        return data
    own = {f.name for f in dataclasses.fields(cls)}
    row = {k: v for k, v in data.items() if k not in own}
    return {**{k: v for k, v in data.items() if k in own}, **({"row": row} if row else {})}


def _main_bearing(data):
    """The AngularContactPair from ``[main_bearing]`` with its two rows as ``[[main_bearing.rows]]``
    tables (each a BallBearing spec), one ``[main_bearing.row]`` table for both, or the rows' keys
    in the pair's table (:func:`_flat_rows`)."""
    table = _table("main_bearing", data)
    check_pair_keys("main_bearing", table, AngularContactPair, BallBearing, extra=("row", "rows"))
    data = _flat_rows(AngularContactPair, table)
    if "row" in data:
        # an error names the key where the file gives it: the pair's own table (flat rule) or its row table
        name = "main_bearing" if "row" not in table else "main_bearing.row"
        row = build_section(BallBearing, name, _table(name, data.pop("row")))
        data["rows"] = (row, row)
    rows = data.get("rows")
    if not (isinstance(rows, (list, tuple)) and len(rows) == 2):
        raise RvtoolInputError(f"main_bearing.rows must hold 2 row tables (BallBearing specs); got {rows!r}")
    data["rows"] = tuple(r if isinstance(r, BallBearing) else
                         build_section(BallBearing, f"main_bearing.rows[{k}]", _table(f"main_bearing.rows[{k}]", r))
                         for k, r in enumerate(rows))
    return build_section(AngularContactPair, "main_bearing", data)


def _crank_bearing(data):
    """The TaperedPair from ``[crank_bearing]`` with ``[[crank_bearing.rows]]`` (or one ``row``) tables,
    or the rows' keys in the pair's table (:func:`_flat_rows`)."""
    table = _table("crank_bearing", data)
    check_pair_keys("crank_bearing", table, TaperedPair, TaperedRollerBearing, extra=("row", "rows"))
    data = _flat_rows(TaperedPair, table)
    if "row" in data:
        # an error names the key where the file gives it: the pair's own table (flat rule) or its row table
        name = "crank_bearing" if "row" not in table else "crank_bearing.row"
        row = TaperedRollerBearing.from_mapping(_table(name, data.pop("row")), name)
        data["rows"] = (row, row)
    if isinstance(data.get("rows"), (list, tuple)):
        data["rows"] = [r if not isinstance(r, dict) else _table(f"crank_bearing.rows[{k}]", r)
                        for k, r in enumerate(data["rows"])]
    return TaperedPair.from_mapping(data, "crank_bearing")


#: The cycloid stage's sections, the cycloid design's specs (the wheel profile generated by the ring,
#: :data:`rvtool.assembly.spec.LINKS`), in dependency order.
_CYCLOID_SECTIONS = {"material": ElasticMaterial, "pins": Pins, "wheels": Wheels, "profile": CycloidProfile,
                     "pin_contact": PinContact, "housing": Housing}
#: the cycloid links the RV's cycloid stage takes: the profile generated by the ring, one housing
#: port per ring pin and the housing of the design's material
_CYCLOID_LINKS = {k: LINKS[k] for k in ("profile", "housing.structure")}
_SECTIONS = {"sun_gear": lambda d: _gear("sun_gear", d),
             "crank_gear": lambda d: _gear("crank_gear", d),
             "involute_stage": lambda d: build_section(InvoluteStage, "involute_stage", d),
             "cranks": lambda d: build_section(Cranks, "cranks", d),
             "eccentric_bearing": lambda d: build_section(NeedleBearing, "eccentric_bearing", d),
             "crank_bearing": _crank_bearing,
             "main_bearing": _main_bearing,
             "bodies": lambda d: build_section(RvBodies, "bodies", d),
             "input_pinion": lambda d: _gear("input_pinion", d),
             "compound_gear": lambda d: _gear("compound_gear", d),
             "input_stage": lambda d: build_section(InputStage, "input_stage", d),
             "bearing_friction": lambda d: build_section(BearingFriction, "bearing_friction", d),
             "carrier": lambda d: build_section(Carrier, "carrier", d)}
_OPTIONAL = ("involute_stage", "bodies", "input_pinion", "compound_gear", "input_stage", "bearing_friction", "carrier")
#: Fields of a table the design sets, not the file (a gear is named after its table): not file keys,
#: so the templates and the format documentation leave them out.
SET_BY_DESIGN = {g: ("name",) for g in ("sun_gear", "crank_gear", "input_pinion", "compound_gear")}


def _checked_pair(a_key, gear_a, b_key, gear_b):
    """Raise the zero-backlash pair's input errors of two design gears (e.g. no working pressure angle
    for the profile shifts) in the design file's key paths, not the pair's gear_a / gear_b."""
    try:
        InvolutePair(gear_a=gear_a, gear_b=gear_b).a
    except RvtoolInputError as exc:
        msg = str(exc)
        for old, new in (("gear_a's", f"{a_key}'s"), ("gear_b's", f"{b_key}'s"), ("gear_a.", f"{a_key}."),
                         ("gear_b.", f"{b_key}.")):
            msg = msg.replace(old, new)
        raise RvtoolInputError(msg) from None


def design_from_dict(d):
    """A validated :class:`RVDesign` from a design mapping (a parsed TOML file)."""
    from ..topologies import upgrade_table
    d = upgrade_table(_table("design", d))
    source = copy.deepcopy(dict(d))
    kw = load_sections(d, _CYCLOID_SECTIONS, optional=("profile", "housing"), links=_CYCLOID_LINKS, derived={})
    for sec, make in _SECTIONS.items():
        if sec not in d:
            if sec in _OPTIONAL:
                continue
            raise RvtoolInputError(f"section [{sec}] is missing from the design")
        kw[sec] = make(d.pop(sec))
    design = build_section(RVDesign, "design", {**d, **kw, "source": source})
    _checked_pair("sun_gear", design.sun_gear, "crank_gear", design.crank_gear)
    if design.input_pinion is not None and design.compound_gear is not None:
        _checked_pair("input_pinion", design.input_pinion, "compound_gear", design.compound_gear)
    from .gear_graph import GearGraph
    graph = GearGraph.of(design)  # topology errors (spacing, crank count, declared ratio) at load
    from ..carrier import check_carrier
    check_carrier(design, graph)  # a ported carrier fits the cranks and the bearing rows
    return design


#: sections :func:`light_replace` writes with their loader's builder (the ones a tolerance draw changes that
#: no link of the file form reads: pins feed the profile only through n_pins, pin_circle_radius, pin_radius)
_LIGHT = {"cranks": lambda d: build_section(Cranks, "cranks", d),
          "eccentric_bearing": lambda d: build_section(NeedleBearing, "eccentric_bearing", d),
          "sun_gear": lambda d: _gear("sun_gear", d),
          "crank_gear": lambda d: _gear("crank_gear", d),
          "pins": lambda d: build_section(Pins, "pins", d)}
_LIGHT_PIN_KEYS = {"radius_error", "centre_errors"}


def light_replace(design, **sections):
    """``design.replace(**sections)`` without loading the whole file form again: each changed section built
    from its merged table by the loader's own builder, the design by ``dataclasses.replace`` (its
    validation runs), its ``source`` the replaced file form, and the loader's graph and carrier checks;
    or None where a change is outside what this writes (another section, a top-level key, a pin key that
    a link reads): then ``replace``. Equal to ``replace``'s design where no link follows the changed keys
    (a caller checks that once per design, :func:`rvtool.variants.multi_device.variant_snapshot`)."""
    from ..spec import _merge, replaced_source
    src = getattr(design, "source", None)
    if src is None or any(k not in _LIGHT or not isinstance(v, dict) for k, v in sections.items()):
        return None
    if "pins" in sections and not set(sections["pins"]) <= _LIGHT_PIN_KEYS:
        return None
    new = {}
    for sec, changes in sections.items():
        base = src.get(sec)
        if not isinstance(base, dict):
            return None
        new[sec] = _LIGHT[sec](_merge(copy.deepcopy(base), changes))
    out = dataclasses.replace(design, **new, source=replaced_source(design, **sections))
    from ..carrier import check_carrier
    from .gear_graph import GearGraph
    check_carrier(out, GearGraph.of(out))
    return out


def load_design(path):
    """Load an RV design TOML file into a validated :class:`RVDesign`."""
    with open(path, "rb") as fh:
        return design_from_dict(tomllib.load(fh))
