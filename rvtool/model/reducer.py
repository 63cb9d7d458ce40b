"""The topology-neutral reducer model: what every topology builder returns and the
only view of a reducer that solvers, protocols and cases use.

Contract (paper: "Transmission topology and reaction-force closure",
"Coordinates and motion of the load-carrying bodies"):

* **Bodies.** ``body_names`` lists the load-carrying bodies in node order
  (planar rigid bodies, retained coordinates x, y, theta; a coordinate the
  design locks is held by a constraint and stays in the vector at zero).
  Elastic structures (a ported housing) are ``structures``; their coordinates
  follow the bodies'. ``reference`` (nb, 3) holds the bodies' reference poses;
  the state q is the displacement from them.
* **Input and output.** ``input`` and ``output`` are :class:`BodyCoordinate`
  (body name, coordinate) of the driven and the loaded rotation; ``ratio`` is
  the signed nominal ratio i = omega_in / omega_out that the builder derives
  from the topology (gear graph, tooth counts), never typed in.
* **Kinematics.** ``kinematic_state(input_angle, input_speed)`` gives the
  rigid, clearance-free poses and velocities of every body from the topology's
  one kinematics definition (initial guesses, plausibility bounds, TE
  reference, initial velocities of driven runs).
* **Controls.** ``set_input_angle`` (quasi-static), ``set_input_speed`` and
  ``set_input_motion`` (driven runs: the static regularization is switched off),
  ``set_output_torque`` and ``set_output_torque_function`` on the output
  coordinate. The output torque acts on the output rotation, positive
  counter-clockwise; protocols resist the nominal output rotation with
  ``-sign(ratio) T``.
* **Contacts.** ``elements`` are the Exudyn contact elements (each one kernel
  launch per evaluation); contact families are addressed by :class:`Family`
  and observed at a static state with ``observe(q, family)``: per row (slice,
  lamina, ball) the normal force, position, normal and identity, and per
  physical contact (a pin, a roller, a tooth pair: slices summed) through
  :meth:`FamilyObservation.per_contact`.
  ``family_spec(family)`` is the component spec the family's contacts were built
  from (contact geometry for local studies such as the pressure resolution), and
  ``material`` the elastic constants (``youngs_modulus``, ``poisson_ratio``) of the
  load-carrying bodies.
* **Continuation restarts.** ``continuation_restarts`` lets a stalled load continuation
  re-solve the level from the kinematic state (free play without stiffness at zero load).
  ``guided_free_play`` lets a stalled continuation (and the static solver's last fallback)
  reach the level by the guide-spring homotopy of :mod:`rvtool.solver.guide`.
* **Regularization.** Weak springs from free coordinates to their kinematic
  positions (a numerical setting for free play at zero load);
  ``regularization_force(q)`` reports the largest force they carry and
  ``regularization_stiffness()`` their diagonal stiffness.

A new topology subclasses :class:`ReducerModel` (or instantiates it) with its own
body list, kinematics object (``poses(angles) -> (n, nb, 3)`` and
``velocities(angle, omega) -> (nb, 3)``) and family map; nothing in the solvers or
protocols changes.
"""
import functools
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from warp_contacts.circle_pairs_ref import O_FN, O_NX, O_NY, O_PX, O_PY

from ..errors import RvtoolInputError

COORDINATES = ("x", "y", "theta")


class Family(str, Enum):
    """Contact families of a reducer; the values are the keys of reported figures."""
    PINS = "pins"                              # cycloid wheel -- ring pin
    OUTPUT_PINS = "output_pins"                # flange pin -- wheel hole
    ECCENTRIC_BEARINGS = "eccentric_bearings"  # journal -- wheel bore
    MAIN_BEARINGS = "main_bearings"            # output -- housing
    INPUT_BEARINGS = "input_bearings"          # input shaft -- housing
    INVOLUTE_STAGE = "involute_stage"          # involute tooth pairs (preliminary stage, small-tooth-difference mesh)
    CRANK_BEARINGS = "crank_bearings"          # crankshaft -- carrier (RV)


FAMILY_ARROW_WORDS = {
    Family.PINS: "ring pins",
    Family.OUTPUT_PINS: "output pins",
    Family.ECCENTRIC_BEARINGS: "eccentric bearings",
    Family.MAIN_BEARINGS: "main bearings",
    Family.INPUT_BEARINGS: "input bearings",
    Family.INVOLUTE_STAGE: "involute mesh",
    Family.CRANK_BEARINGS: "crank bearings",
}
"""Contact families in words on the section plot's legend."""

FAMILY_ARROW_COLOURS = ("tab:red", "tab:purple", "tab:brown", "tab:cyan", "tab:olive", "tab:pink", "tab:gray")
"""Arrow colours by :class:`Family` order (the outlines use C0/C1 for the wheels, black and green)."""


def family_colour(family):
    """The arrow colour of ``family`` on the section plot (fixed per family across topologies)."""
    return FAMILY_ARROW_COLOURS[list(Family).index(Family(family)) % len(FAMILY_ARROW_COLOURS)]


SMALL_FAMILY_FLOOR = 0.1
"""Smallest reference force of a family's arrow scale in the section plot, as a fraction of the largest
family's largest force (:meth:`ReducerModel.draw_section`)."""


def section_arrow_length(ax, fraction=0.1, default=0.01):
    """Drawn length [m] of each family's largest force on a section plot: ``fraction`` of the
    larger side of what ``ax`` holds so far (the topology's outlines), rounded down to 1, 2 or
    5 x 10^k m so that the key reads plainly; ``default`` where nothing is drawn yet."""
    lim = ax.dataLim
    extent = max(lim.width, lim.height) if np.all(np.isfinite(lim.bounds)) else 0.0
    if not extent > 0:
        return default
    target = fraction * extent
    decade = 10.0 ** np.floor(np.log10(target))
    return float(max(m for m in (1.0, 2.0, 5.0) if m * decade <= target * (1 + 1e-12)) * decade)


@dataclass(frozen=True)
class BodyCoordinate:
    """One coordinate of one body: body name and coordinate name ("x", "y", "theta")."""
    body: str
    coordinate: str

    def __post_init__(self):
        if self.coordinate not in COORDINATES:
            raise RvtoolInputError(f"coordinate = {self.coordinate!r}; valid choices are {list(COORDINATES)}")


@dataclass(frozen=True)
class KinematicState:
    """Rigid kinematic poses (nb, 3) [m, rad] and velocities (nb, 3) [m/s, rad/s] of every body."""
    poses: np.ndarray
    velocities: np.ndarray


def physical_contact(row_id):
    """Identity of the physical contact of an observation row: the row id without its
    slice or lamina component (``wheel0/pin3/s1`` -> ``wheel0/pin3``,
    ``eccentric_bearing0/roller2/slice0`` -> ``eccentric_bearing0/roller2``)."""
    head, _, last = row_id.rpartition("/")
    if head and (last.startswith("slice") or (last.startswith("s") and last[1:].isdigit())):
        return head
    return row_id


@functools.lru_cache(maxsize=64)
def contact_groups(row_ids):
    """(physical contact ids in order of first appearance, contact index of every row) of a
    tuple of row ids; cached because a study observes the same rows at every point."""
    contact = [physical_contact(r) for r in row_ids]
    names = tuple(dict.fromkeys(contact))
    index = {c: k for k, c in enumerate(names)}
    rows = np.fromiter((index[c] for c in contact), int, len(contact))
    rows.flags.writeable = False
    return names, rows


@dataclass(frozen=True)
class FamilyObservation:
    """A contact family at one state: per row (slice, lamina or whole contact) the identity,
    normal force [N], contact position [m] and unit normal, all rows of the element's
    observation columns (:mod:`warp_contacts.circle_pairs_ref`) in ``obs``."""
    family: Family
    ids: tuple
    obs: np.ndarray

    @property
    def normal_force(self):
        return self.obs[:, O_FN]

    @property
    def position(self):
        return self.obs[:, O_PX:O_PY + 1]

    @property
    def normal(self):
        return self.obs[:, O_NX:O_NY + 1]

    @property
    def peak(self):
        """Largest row normal force [N]."""
        return float(np.max(self.obs[:, O_FN]))

    def per_contact(self):
        """(contact ids, normal force per physical contact [N]): rows summed per contact
        (Eq. width_resultant's force part), contacts in order of first appearance."""
        names, rows = contact_groups(self.ids)
        out = np.zeros(len(names))
        np.add.at(out, rows, self.obs[:, O_FN])
        return names, out

    def per_member(self):
        """{member: per-contact normal forces [N]}: the physical contacts grouped by the first
        component of their identity (a wheel of a pin mesh, a mounting of a bearing family)."""
        names, forces = self.per_contact()
        out = {}
        for name, f in zip(names, forces):
            out.setdefault(name.split("/")[0], []).append(f)
        return {k: np.array(v) for k, v in out.items()}


@dataclass(frozen=True)
class SeriesBeam:
    """The beams of a family's pins (elastic pins), for the stiffness budget.

    path: budget entry name (e.g. ``"ring_pin_bending"``); family: the contact family;
    compliance: station compliance C (n_s, n_s) [m/N] of one pin (the same for every pin);
    deflections: ``deflections(q)`` -> (n_pins, n_s, 2) station deflections [m] at state q;
    stiffened: ``stiffened(q, factor)`` -> (global coordinate indices, dQ/dq of the family's
    element with the beams' stiffness times ``factor``, everything else at state q).
    The observed approach of a row excludes the beam's deflection (the contact approach)."""
    path: str
    family: Family
    compliance: np.ndarray
    deflections: object
    stiffened: object

    def energy(self, q, dq, step=1e-9):
        """sum over pins of du^T K_b du [m/N x N^2 per unit^2] with K_b = C^-1: the beams' strain
        energy (x2) along the state increment dq (n,), du by central differences of the station
        deflections over +-step [m] of the largest entry of dq (the closure is solved to 1e-16 m
        of deflection, 1e-7 of such a step)."""
        h = step / max(float(np.abs(dq).max()), 1e-300)
        du = (self.deflections(q + h * dq) - self.deflections(q - h * dq)) / (2 * h)
        return float(np.einsum("pkx,kl,plx->", du, np.linalg.inv(self.compliance), du))

    @classmethod
    def of_closure(cls, path, family, compliance, element):
        """The beams closed by ``element``'s elastic closure (its evaluator:
        :class:`~rvtool.contact.pin_closure.ElasticPinClosure`): deflections and the stiffened
        tangent at the static pose of a state q (zero velocities)."""
        closure = element.evaluator

        def pose(q):
            ql = element.local(q)
            return element.pose_velocity(ql, 0 * ql)

        def stiffened(q, factor):
            _, _, red, _ = closure.solve(*pose(q))
            return element.coordinate_indices, element.element_tangent(closure.condense(red, beam_factor=factor)[1])
        return cls(path, family, compliance, lambda q: closure.deflections(pose(q)[0]), stiffened)


@dataclass(frozen=True)
class ClearanceVariant:
    """One clearance of a design for the lost-motion budget: name, its value [m], the closed-form
    kinematic estimate of its lost motion [rad] (output angle), ``remove(design)`` -> the design
    without it and ``restore(design, original)`` -> ``design`` with the original's value back."""
    name: str
    value: float
    estimate_rad: float
    remove: object
    restore: object


def body_index(body_names, body):
    """Index of ``body`` (a name in ``body_names`` or an index); an unknown name names the valid ones."""
    if isinstance(body, str):
        try:
            return list(body_names).index(body)
        except ValueError:
            raise RvtoolInputError(f"body = {body!r}; valid bodies are {list(body_names)}") from None
    return int(body)


@dataclass
class ReducerModel:
    """An assembled reducer (see the module docstring for the contract).

    Builders fill the fields; ``families`` maps each :class:`Family` present to
    (element name, row indices of that element's observation rows); ``main_mesh`` is
    the family of the reducing mesh whose per-member loads the protocols report.
    """
    design: object
    SC: object
    mbs: object
    body_names: tuple
    nodes: list
    elements: dict
    families: dict
    input: BodyCoordinate
    output: BodyCoordinate
    ratio: float
    kinematics: object
    drive: int
    load: int
    reference: np.ndarray
    locks: list = field(default_factory=list)
    reg_springs: list = field(default_factory=list)
    journal_locks: list = field(default_factory=list)
    structures: dict = field(default_factory=dict)
    main_mesh: Family = Family.PINS
    family_specs: dict = field(default_factory=dict)   # Family -> component spec(s) of its contacts
    material: object = None         # youngs_modulus [Pa], poisson_ratio [-] of the load-carrying bodies
    mesh_period: float = None       # input angle [rad] of one mesh cycle of the main mesh
    #: a load continuation whose increments stall may restart the level from the static solver's
    #: ladder (:meth:`rvtool.solver.continuation.Continuation.go_to`): set by topologies whose
    #: zero-load state is free play without contact stiffness (a backlashed involute mesh)
    continuation_restarts: bool = False
    #: a stalled load continuation, and a static point every other fallback missed, are reached by
    #: the guide-spring homotopy (:mod:`rvtool.solver.guide`): set by topologies whose free play
    #: leaves crank-like coordinates without contact stiffness at zero load (RV with needle
    #: clearance and backlash; the small-tooth-difference reducer's backlashed mesh at light load);
    #: off elsewhere, so no existing model's path or failure changes
    guided_free_play: bool = False
    contact_host: object = None     # MergedContactElement carrying every family (one element per system), or None
    #: retained axial and tilt coordinates of the output body on its main bearing
    #: (:class:`~exudyn_user_elements.out_of_plane.RetainedTilt`; issue 32), or None (planar output)
    carrier_tilt: object = None
    #: retained axial and tilt coordinates of every spatial body (carrier / flange, wheels, cranks) in
    #: one :class:`~exudyn_user_elements.out_of_plane.RetainedTilt` (its ``names``), or None (all planar);
    #: the carrier's is also ``carrier_tilt``
    body_tilts: object = None

    # -- coordinates -------------------------------------------------------
    def body_index(self, body):
        """Index of a body given by name or index."""
        return body_index(self.body_names, body)

    def coordinate_index(self, body, coord):
        """Global ODE2 index of coordinate ``coord`` (0/"x", 1/"y", 2/"theta") of ``body`` (name or index)."""
        c = COORDINATES.index(coord) if isinstance(coord, str) else int(coord)
        return int(self.mbs.systemData.GetNodeLTGODE2(self.nodes[self.body_index(body)])[c])

    @property
    def input_index(self):
        return self.coordinate_index(self.input.body, self.input.coordinate)

    @property
    def output_index(self):
        return self.coordinate_index(self.output.body, self.output.coordinate)

    def reference_value(self, bc):
        """Reference value of a :class:`BodyCoordinate` (the state is measured from it)."""
        return float(self.reference[self.body_index(bc.body), COORDINATES.index(bc.coordinate)])

    def fixed_coordinates(self):
        """Global indices held by the drive and the coordinate locks."""
        mbs = self.mbs
        fixed = {self.input_index}
        for obj in self.locks:
            marker = mbs.GetObjectParameter(obj, "markerNumbers")[1]
            node = mbs.GetMarkerParameter(marker, "nodeNumber")
            c = mbs.GetMarkerParameter(marker, "coordinate")
            fixed.add(int(mbs.systemData.GetNodeLTGODE2(node)[c]))
        return fixed

    def body_pose(self, q, body):
        """Pose (x, y, theta) [m, rad] of ``body`` (name or index) at the state q: reference + displacement."""
        b = self.body_index(body)
        return self.reference[b] + q[[self.coordinate_index(b, c) for c in range(3)]]

    def body_vector(self, per_body):
        """A global ODE2 vector from per-body rows (nb, 3) (structural coordinates zero)."""
        v = np.zeros(self.mbs.systemData.ODE2Size())
        for b, node in enumerate(self.nodes):
            v[np.asarray(self.mbs.systemData.GetNodeLTGODE2(node))] = per_body[b]
        return v

    # -- kinematics ----------------------------------------------------------
    def kinematic_state(self, input_angle, input_speed=0.0):
        """:class:`KinematicState` at ``input_angle`` [rad] and ``input_speed`` [rad/s]."""
        poses = self.kinematics.poses(np.asarray([float(input_angle)]))[0]
        return KinematicState(poses, self.kinematics.velocities(float(input_angle), float(input_speed)))

    def kinematic_output(self, input_angle):
        """Kinematic output coordinate [rad or m] measured from its reference."""
        kin = self.kinematic_state(input_angle).poses
        b, c = self.body_index(self.output.body), COORDINATES.index(self.output.coordinate)
        return kin[b, c] - self.reference[b, c]

    # -- controls --------------------------------------------------------------
    def set_input_angle(self, angle):
        """Prescribed input angle [rad] (quasi-static sequences); journal locks and
        regularization springs follow the kinematic positions so they carry no load."""
        self.mbs.SetObjectParameter(self.drive, "offset", float(angle))
        if self.journal_locks or self.reg_springs:
            kin = self.kinematic_state(angle).poses
            for body, c, obj in self.journal_locks:
                self.mbs.SetObjectParameter(obj, "offset", float(kin[body, c] - self.reference[body, c]))
            for body, c, _, obj in self.reg_springs:
                self.mbs.SetObjectParameter(obj, "offset", float(kin[body, c] - self.reference[body, c]))

    def set_input_motion(self, angle_of_time):
        """Prescribed input angle [rad] as a function of time [s] (driven runs). The static
        regularization springs are switched off: inertia makes the dynamic problem regular."""
        if self.contact_host is not None:
            # one contact element per system: the host sets the offset once per step attempt
            self.contact_host.set_drive(self.drive, angle_of_time)
        else:
            self.mbs.SetObjectParameter(self.drive, "offsetUserFunction",
                                        lambda mbs, t, itemNumber, lOffset: angle_of_time(t))
        for _, _, _, obj in self.reg_springs:
            self.mbs.SetObjectParameter(obj, "stiffness", 0.0)

    def set_input_speed(self, omega, angle0=0.0):
        """Prescribed constant input speed omega [rad/s] from angle0 at t = 0."""
        self.set_input_motion(lambda t: angle0 + omega * t)

    def set_output_torque(self, torque):
        """Torque on the output rotation [N m] (positive counter-clockwise)."""
        self.mbs.SetLoadParameter(self.load, "load", float(torque))

    def set_output_torque_function(self, torque_of_time):
        """Output torque [N m] as a function of time [s]; None removes it (the constant load applies)."""
        if self.contact_host is not None:
            # one contact element per system: the host sets the load once per step attempt
            self.contact_host.set_load_function(self.load, torque_of_time)
            return
        fn = 0 if torque_of_time is None else (lambda mbs, t, load: torque_of_time(t))
        self.mbs.SetLoadParameter(self.load, "loadUserFunction", fn)

    # -- regularization ------------------------------------------------------------
    def regularization_force(self, q):
        """Largest force [N] (or moment [N m]) carried by the regularization springs at q."""
        out = 0.0
        for body, c, k, obj in self.reg_springs:
            k_now = self.mbs.GetObjectParameter(obj, "stiffness")
            off = self.mbs.GetObjectParameter(obj, "offset")
            out = max(out, abs(k_now * (q[self.coordinate_index(body, c)] - off)))
        return out

    def regularization_stiffness(self):
        """[(global index, stiffness)] of the regularization springs as they are now, and those of the
        retained axial and tilt coordinates of spatial bodies (issue 32: a tilting wheel's axial
        translation has no other stiffness)."""
        out = [(self.coordinate_index(body, c), self.mbs.GetObjectParameter(obj, "stiffness"))
               for body, c, _, obj in self.reg_springs]
        t = self.body_tilts if self.body_tilts is not None else self.carrier_tilt
        if t is not None:
            out += [(int(i), float(k)) for i, k in zip(t.coordinate_indices, t.stiffness_diagonal) if k > 0]
        return out

    def regularization_spring(self, bc):
        """(Exudyn object, stiffness at build) of the regularization spring on a
        :class:`BodyCoordinate`, or None where it has none."""
        b, c = self.body_index(bc.body), COORDINATES.index(bc.coordinate)
        for body, cc, k, obj in self.reg_springs:
            if body == b and cc == c and k > 0:
                return obj, k
        return None

    # -- the output flange on its main bearing (issue 32) ---------------------------
    def _retained_tilt(self):
        if self.carrier_tilt is None:
            raise RvtoolInputError("the output body is planar (its axial and tilt coordinates are held); valid: "
                                   "bodies.carrier_coordinates (RV) or bodies.flange_coordinates (cycloid) = "
                                   "'spatial' in the design file")
        return self.carrier_tilt

    def set_flange_load(self, axial_force=0.0, moment=(0.0, 0.0)):
        """External axial force [N] and tilting moment (M_x, M_y) [N m] on the output flange at the
        main bearing's axial centre (spatial output body only)."""
        from ..validation import check_finite
        check_finite("axial_force", axial_force)
        check_finite("moment", moment)
        if np.shape(moment) != (2,):
            raise RvtoolInputError(f"moment must hold (M_x, M_y) [N m]; got {moment!r}")
        self._retained_tilt().set_load(axial_force, moment)

    def flange_displacement(self, q):
        """(z [m], gamma_x, gamma_y [rad]) of the output flange at the state q (spatial output body only)."""
        return self._retained_tilt().coordinates(q)

    def tilts(self, q):
        """{body name: (z [m], gamma_x, gamma_y [rad])} of every body that retains its out-of-plane
        coordinates at the state q (empty for a planar model)."""
        t = self.body_tilts if self.body_tilts is not None else self.carrier_tilt
        if t is None:
            return {}
        return {nm: t.coordinates(q, r) for r, nm in enumerate(t.names)}

    def set_body_load(self, body, axial_force=0.0, moment=(0.0, 0.0)):
        """External axial force [N] and tilting moment (M_x, M_y) [N m] on a spatial body (name) at its
        centre."""
        from ..validation import check_finite
        check_finite("axial_force", axial_force)
        check_finite("moment", moment)
        t = self.body_tilts if self.body_tilts is not None else self.carrier_tilt
        if t is None:
            raise RvtoolInputError(f"body {body!r} is planar (its axial and tilt coordinates are held); valid: "
                                   "bodies.*_coordinates = 'spatial' in the design file")
        t.set_load(axial_force, moment, body=body)

    def main_bearing_state(self, q):
        """(the main bearing's evaluator, the poses it is evaluated at) at the static state q."""
        if Family.MAIN_BEARINGS not in self.families:
            raise RvtoolInputError("the model has no main-bearing family")
        el = self.elements[self.families[Family.MAIN_BEARINGS][0]]
        ql = el.local(q)
        return el.evaluator, el.pose_velocity(ql, np.zeros_like(ql))[0]

    def main_bearing_loads(self, q):
        """:class:`~rvtool.bearings.set.BearingLoads` of the mounting ``main_bearing`` on the output body
        at the static state q: radial force, axial force, tilting moment and the axial force of each
        row (fed back with a spatial output body, observations with a planar one; rolling-element
        main bearings only)."""
        ev, pose = self.main_bearing_state(q)
        if not callable(getattr(ev, "resultants", None)):
            raise RvtoolInputError(f"the main bearing is a {type(ev).__name__} without resultants; valid: "
                                   "rolling-element bearings (cycloid: build(..., bearing_model='rolling'), "
                                   "rvtool analyze --bearing-model rolling)")
        return ev.resultants(pose)["main_bearing"]

    # -- contacts ----------------------------------------------------------------
    def observe(self, q, family):
        """:class:`FamilyObservation` of ``family`` at the static state q (zero velocity)."""
        el, rows = self.family_rows(family)
        obs = el.evaluation_at(q).obs
        return FamilyObservation(Family(family), tuple(el.ids[i] for i in rows), obs[rows])

    def family_peaks(self, q):
        """{family value: largest row normal force [N]} (one slice or lamina) at the static state q;
        :meth:`family_contact_peaks` gives the per-contact figure."""
        out = {}
        for fam, (name, rows) in self.families.items():
            out[fam.value] = float(np.max(self.elements[name].evaluation_at(q).obs[rows, O_FN]))
        return out

    def family_contact_peaks(self, q):
        """{family value: largest normal force of one physical contact [N]} at the static state
        q: the rows (slices, laminae) of each contact summed first (:meth:`FamilyObservation.per_contact`),
        the load a pin, a roller or a ball carries. :meth:`family_peaks` gives the largest row."""
        return {fam.value: float(np.max(self.observe(q, fam).per_contact()[1])) for fam in self.families}

    def series_compliance(self, family):
        """The :class:`SeriesBeam` in series with ``family``'s contacts (elastic pins), or None
        (rigid pins, the "nothing" variant)."""
        return None

    def pin_bending(self, q, family, support=None):
        """Largest bending stress of the pins of ``family`` at state q, or over a sequence of states
        q (dict, see the topology), or None where the topology has no pins of that family or
        they are rigid and no ``support`` is assumed."""
        return None

    def hertz_peaks(self, q):
        """{family group: largest Hertz peak pressure [Pa]} of the loaded contacts at state q, where
        the topology provides the local contact geometry; {} otherwise."""
        return {}

    def clearance_variants(self):
        """[:class:`ClearanceVariant`]: the design's clearances in the lost-motion budget's order."""
        return []

    def mesh_width_moments(self, q):
        """Eq. (width_resultant) moments of the main mesh per member, where the topology
        slices its mesh across the face width; None otherwise."""
        return None

    def refined_design(self):
        """The design at the topology's refined numerical resolution (the reference of the
        resolution error statements)."""
        raise NotImplementedError(f"{type(self).__name__} declares no refined resolution")

    def resolution_settings(self):
        """The numerical resolution settings of the model (reported with its figures)."""
        return {}

    def draw_section(self, ax, q):
        """Transverse section at state q: the contact forces of every family (arrows along the
        normals at the contact points) and the legend. Each family has its own colour and its own
        arrow scale: its largest force is drawn :func:`section_arrow_length` long (a tenth of the
        outlines' extent, rounded down to 1, 2 or 5 x 10^k m; the key arrow in the corner), and its
        legend entry names the force that length stands for, so a 200 N ring-pin load stays visible
        beside a 2 kN bearing load (lengths compare within a family, not across families). A family
        whose largest force is below :data:`SMALL_FAMILY_FLOOR` of the largest family's takes that
        fraction of it as its reference force instead (its arrows stay short: a negligible load is not
        drawn as long as the main ones).
        Topologies draw (and label) their outlines first."""
        length = section_arrow_length(ax)
        peaks = self.family_peaks(q)
        largest = max((peaks[f.value] for f in self.families), default=0.0)
        key = None
        for fam in self.families:
            ob = self.observe(q, fam)
            on = ob.normal_force > 0
            f = ob.normal_force[on, None] * ob.normal[on]
            # a family far below the largest is not blown up to the key length (rv40e's 22 N main bearings
            # would read like its 493 N pins): its reference force is at least SMALL_FAMILY_FLOOR of the largest
            ref = max(peaks[fam.value], SMALL_FAMILY_FLOOR * largest)
            scale = length / ref if ref > 0 else 0.0
            label = (f"{FAMILY_ARROW_WORDS.get(fam, fam.value)}: {ref:.4g} N per {length * 1e3:.3g} mm" if ref > 0
                     else f"{FAMILY_ARROW_WORDS.get(fam, fam.value)}: no load")
            peak = peaks[fam.value]
            arrows = ax.quiver(ob.position[on, 0], ob.position[on, 1], -f[:, 0] * scale, -f[:, 1] * scale,
                               angles="xy", scale_units="xy", scale=1, width=0.003, color=family_colour(fam),
                               label=label)
            key = arrows if peak > 0 else key
        if key is not None:     # the reference length, in the empty corner outside the section's circle
            ax.quiverkey(key, 0.04, 0.96, length, f"{length * 1e3:.3g} mm",
                         labelpos="E", coordinates="axes", color="k", fontproperties={"size": 8})
        ax.set_aspect("equal")
        ax.set(xlabel="x [m]", ylabel="y [m]")
        # outlines (labelled by the topology) and arrows, below the section where they hide nothing
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)

    def family_spec(self, family):
        """The component spec the contacts of ``family`` were built from (per topology: e.g. the
        wheel--pin meshes of a cycloid stage, an output-pin mechanism, a bearing spec)."""
        try:
            return self.family_specs[Family(family)]
        except (KeyError, ValueError):
            raise RvtoolInputError(f"family = {getattr(family, 'value', family)!r} declares no component spec in this "
                                   f"model; valid: {[f.value for f in self.family_specs]}") from None

    def set_gap_offsets(self, family, offsets):
        """Slow-state gap offsets [m] of ``family``: ``offsets`` maps physical contact ids (those of
        :meth:`FamilyObservation.per_contact`) to an offset (positive opens the gap; unnamed
        contacts 0), written into the family's contact element for the next contact evaluation.
        Absolute, not increments; all zeros restore the built element bit for bit. A family whose
        evaluator names its own offset identities (``gap_offset_ids``: the tooth flanks of an
        involute mesh, whose rows are window slots) takes offsets keyed by those."""
        el, rows = self.family_rows(family)
        own = getattr(el.evaluator, "gap_offset_ids", None)
        if own is not None:     # offsets that follow the evaluator's identities (involute: tooth flanks)
            unknown = sorted(set(offsets) - set(own))
            if unknown:
                raise RvtoolInputError(f"gap offsets name contacts {unknown[:4]} that family {Family(family).value!r} "
                                       f"lacks; valid: tooth flanks {list(own)[:2]} ...")
            el.set_gap_offsets([float(offsets.get(c, 0.0)) for c in own])
            return
        contact = [physical_contact(el.ids[i]) for i in rows]
        unknown = sorted(set(offsets) - set(contact))
        if unknown:
            raise RvtoolInputError(f"gap offsets name contacts {unknown[:4]} that family {Family(family).value!r} "
                                   f"lacks; valid: {list(dict.fromkeys(contact))[:4]} ...")
        full = np.array(el.gap_offsets, dtype=np.float64)
        full[rows] = [float(offsets.get(c, 0.0)) for c in contact]
        el.set_gap_offsets(full)

    def gap_offsets(self, family):
        """{physical contact id: gap offset [m]} in force for ``family`` (first row of each contact;
        involute meshes: per tooth flank)."""
        el, rows = self.family_rows(family)
        if getattr(el.evaluator, "gap_offset_ids", None) is not None:
            return el.evaluator.tooth_gap_offsets()
        out = {}
        for i in rows:
            out.setdefault(physical_contact(el.ids[i]), float(el.gap_offsets[i]))
        return out

    def set_friction(self, family, mu):
        """Slow-state friction coefficients [-] of ``family`` (coupled lubrication): ``mu`` maps
        physical contact ids to mu (unnamed contacts keep their built coefficient), or None restores
        the built coefficients. Written into the contact law of Eq. (friction) of the family's rows
        built with friction (cycloid pins with ``pin_contact.mu`` > 0; other families: named error)."""
        el, rows = self.family_rows(family)
        if mu is None:
            el.set_friction_coefficients(None)
            return
        contact = [physical_contact(el.ids[i]) for i in rows]
        unknown = sorted(set(mu) - set(contact))
        if unknown:
            raise RvtoolInputError(f"friction names contacts {unknown[:4]} that family {Family(family).value!r} "
                                   f"lacks; valid: {list(dict.fromkeys(contact))[:4]} ...")
        if not callable(getattr(el.evaluator, "set_friction_coefficients", None)):
            raise RvtoolInputError(f"family {Family(family).value!r} has no friction coefficient to write; valid: "
                                   "cycloid pins")
        built = el.evaluator.built_friction() if callable(getattr(el.evaluator, "built_friction", None)) else None
        full = np.array(built if built is not None else np.zeros(len(el.ids)), dtype=np.float64)
        full[rows] = [float(mu.get(c, full[i])) for c, i in zip(contact, rows)]
        el.set_friction_coefficients(full)

    def set_prescribed_velocity(self, v):
        """Velocity (global ODE2 vector [m/s, rad/s]) at which every contact element evaluates in the
        following static solves, or None (zero velocity, the default). Quasi-static windows at input
        speed prescribe ``body_vector(kinematic_state(a, omega).velocities)`` so that velocity
        dependent laws (regularized friction, Eq. (friction)) see the steady sliding speed."""
        if v is not None:
            v = np.asarray(v, dtype=np.float64)
            n = self.mbs.systemData.ODE2Size()
            if v.shape != (n,):
                raise RvtoolInputError(f"prescribed velocity must have shape ({n},) (the ODE2 vector); got {v.shape}")
        for el in self.elements.values():
            el.set_prescribed_velocity(v)

    def family_rows(self, family):
        """(contact element, row indices) of ``family`` in that element; a family this model lacks
        is a named input error."""
        try:
            name, rows = self.families[Family(family)]
        except (KeyError, ValueError):
            raise RvtoolInputError(f"family = {getattr(family, 'value', family)!r} is not in this model; valid: "
                                   f"{[f.value for f in self.families]}") from None
        return self.elements[name], rows

    def family_element(self, family):
        """The contact element that carries ``family`` (fault injection, per-step sums)."""
        return self.family_rows(family)[0]

    def contact_elements(self):
        """The contact elements (solvers and the driver evaluate and commit them)."""
        return list(self.elements.values())

    def commit_contacts(self, q, v=None):
        """Commit every element's contact history at an accepted static state."""
        v = np.zeros_like(q) if v is None else v
        for el in self.elements.values():
            el.commit(q, v)
