"""Builder: an :class:`~rvtool.assembly.rv.spec.RVDesign` -> an :class:`RvModel` (a
:class:`~rvtool.model.ReducerModel`), paper Fig. load_paths (b): "preliminary gearing drives
multiple floating cranks sharing the wheels and carrier"; "crank translations and the selected
axial and tilt coordinates are determined through bearing forces".

Bodies (planar rigid, x, y, theta; node order = ``body_names``):

* ``sun`` (two-stage: the input shaft with the sun gear; theta driven, x and y held unless
  ``bodies.input`` frees them) -- three-stage: ``pinion`` (the driven offset input pinion,
  centre held) and ``sun`` (the compound gear carrying the sun, on the axis, x and y held);
* ``crank0..``: the floating crankshafts (x, y, theta all free), each with its spur gear
  (centre at the body origin, tooth 0 on the body's x axis) and two eccentric journals;
* ``wheel0``, ``wheel1``: the cycloid wheels (free), each bored for every crank's journal;
* ``carrier``: the output (both halves joined rigidly; free, on the main bearings). With
  ``bodies.carrier_coordinates = "spatial"`` it also retains its axial translation and two tilts
  (:func:`spatial_bodies`: an Exudyn node of three coordinates per spatial body, the main bearing on
  them through :class:`~rvtool.bearings.spatial_set.SpatialBearingSet`, NumPy whatever ``backend``).
  With ``bodies.wheel_coordinates`` / ``crank_coordinates = "spatial"`` the wheels / cranks retain
  them too: the families on them are sliced across the wheel width with their tilts
  (:func:`skewed`, :class:`~rvtool.contact.skew.SkewSlices`; the needles per wheel with spatial
  cranks, :func:`spatial_needles`) and the tapered crank pairs take the 5-DOF roller law
  (:class:`~rvtool.bearings.spatial_tapered.SpatialTaperedSet`).

Contact elements (each one kernel launch per evaluation): ``pins`` (cycloid--pin meshes of
both wheels, pins on the ground), ``gears`` (involute pairs sun--crank gear k, and the
three-stage pinion--compound pair), ``eccentric_bearings`` (needle rollers, crank journal ->
wheel bore), ``crank_bearings`` (tapered-roller pairs, crank -> carrier, planar use: radial
load through the rollers, the pair's axial force and tilting moment as observations -- the
axial and tilt coordinates of the cranks are held, declared), ``main_bearings``
(angular-contact pair, carrier -> housing). There are no output pins: the wheels drive the
carrier through the cranks. With ``[bearing_friction] model = "palmgren"`` (issue 17) two loss
elements follow, ``crank_bearing_friction`` and ``main_bearing_friction``
(:func:`rvtool.bearings.friction_element.rolling_friction_evaluator`: Palmgren's moment on each
bearing's relative rotation, P1 from its accepted element loads); "none" (default) builds neither.

Kinematics (:class:`RvKinematics`): the gear graph's rates (:mod:`.gear_graph`); the crank
gears start conjugate to the sun (mid-backlash), the journals at the wheels' absolute phases.
"""
import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import exudyn as exu
from exudyn.itemInterface import (CoordinateConstraint, CoordinateSpringDamper, LoadCoordinate,
                                  MarkerNodeCoordinate, NodePointGround, NodeRigidBody2D, ObjectRigidBody2D)

from ...bearings.set import BearingSet, Mounting
from ...bearings.tapered_set import TaperedBearingSet, TaperedMounting
from ...contact.circle_set import GROUND, FrictionLaw, FrictionModel
from ...contact.cycloid_set import CycloidPinSet
from ...contact.involute_set import GearMesh, InvoluteContactSet, pair_secant_stiffness
from ...contact.skew import planar_view
from ...errors import RvtoolInputError
from ...geometry.eccentric import journal_centre, journal_velocity
from ...model import BodyCoordinate, Family, ReducerModel
from ...model import SeriesBeam as SeriesBeamBase
from ...output_pins.calibration import mindlin_tangential_ratio
from ..contact_layout import ContactElements, contact_element_mode
from ..cycloid import pin_meshes
from .gear_graph import GearGraph
from .spec import RVDesign
from .wheel_path import NestedSeries, leaf_rows, leaf_state, wheel_path


class Layout:
    """Body indices of an RV design: input body 0, the sun (0 or 1), cranks, wheels, carrier."""

    def __init__(self, design):
        self.three_stage = design.topology == "rv3"
        self.n_cranks = design.cranks.count
        self.sun = 1 if self.three_stage else 0
        self.crank0 = self.sun + 1
        self.wheel0 = self.crank0 + self.n_cranks
        self.carrier = self.wheel0 + 2
        self.n_bodies = self.carrier + 1

    def names(self):
        pre = ("pinion", "sun") if self.three_stage else ("sun",)
        return pre + tuple(f"crank{k}" for k in range(self.n_cranks)) + ("wheel0", "wheel1", "carrier")

    def crank(self, k):
        return self.crank0 + k

    def wheel(self, j):
        return self.wheel0 + j


class RvKinematics:
    """Rigid, clearance-free kinematics of an RV reducer (module docstring): at input angle s
    the carrier is at s / i, every crank turns by omega_k / omega_in s about its carrier-borne
    axis, wheel j sits on the journals at the absolute eccentric angle and turns with the carrier."""

    def __init__(self, design, graph, layout):
        self.g, self.L = graph, layout
        self.e = design.wheels.eccentricity
        self.phases = np.asarray(design.wheels.phases, float)
        self.reference = reference_poses(design, graph, layout)

    @property
    def crank_rate(self):
        """omega_crank / omega_in: the eccentric orbit per input radian (the gear graph's), the period
        2 pi / |crank_rate| [rad of input] with which the wheels' contacts repeat."""
        return float(self.g.crank_rate)

    def poses(self, input_angles):
        """(n, nb, 3) poses at input angles (n,) [rad]."""
        s = np.asarray(input_angles, float)
        g, L = self.g, self.L
        r = g.rates
        phi_c = r["carrier"] * s
        a = r["crank"] * s
        q = np.repeat(self.reference[None], len(s), axis=0)
        q[:, 0, 2] += s
        if L.three_stage:
            q[:, L.sun, 2] += r["sun"] * s
        for k, b in enumerate(g.crank_angles):
            i = L.crank(k)
            q[:, i, 0] = g.crank_radius * np.cos(b + phi_c)
            q[:, i, 1] = g.crank_radius * np.sin(b + phi_c)
            q[:, i, 2] += a
        for j in range(2):
            i = L.wheel(j)
            q[:, i, 0], q[:, i, 1] = journal_centre(self.e, self.phases[j], a)
            q[:, i, 2] = phi_c
        q[:, L.carrier, 2] = phi_c
        return q

    @staticmethod
    def stacked_poses(kinematics, input_angles):
        """(B, n, nb, 3) poses of B :class:`RvKinematics` at input angles (n,) [rad] in one evaluation
        (Monte Carlo variants: their references, crank circles, eccentricities and phases may differ),
        each equal to its :meth:`poses` bit for bit (the same operations per element), or None where
        their layouts, stage rates or crank counts differ (then each is evaluated alone)."""
        k0 = kinematics[0]
        L = k0.L
        lay = lambda x: (x.three_stage, x.n_cranks, x.n_bodies)
        rates = lambda k: tuple(k.g.rates[nm] for nm in ("carrier", "crank", "sun"))
        if any(not isinstance(k, RvKinematics) or lay(k.L) != lay(L) or rates(k) != rates(k0)
               or len(k.g.crank_angles) != len(k0.g.crank_angles) or len(k.phases) != len(k0.phases)
               for k in kinematics):
            return None
        s = np.asarray(input_angles, float)
        r = k0.g.rates
        phi_c = r["carrier"] * s
        a = r["crank"] * s
        q = np.repeat(np.array([k.reference for k in kinematics], float)[:, None], len(s), axis=1)
        q[:, :, 0, 2] += s
        if L.three_stage:
            q[:, :, L.sun, 2] += r["sun"] * s
        radius = np.array([k.g.crank_radius for k in kinematics], float)[:, None]
        for j, i in enumerate(L.crank(k) for k in range(L.n_cranks)):
            b = np.array([k.g.crank_angles[j] for k in kinematics], float)[:, None]
            q[:, :, i, 0] = radius * np.cos(b + phi_c[None, :])
            q[:, :, i, 1] = radius * np.sin(b + phi_c[None, :])
            q[:, :, i, 2] += a
        e = np.array([k.e for k in kinematics], float)[:, None]
        for j in range(2):
            i = L.wheel(j)
            ph = np.array([k.phases[j] for k in kinematics], float)[:, None]
            q[:, :, i, 0], q[:, :, i, 1] = journal_centre(e, ph, a[None, :])
            q[:, :, i, 2] = phi_c
        q[:, :, L.carrier, 2] = phi_c
        return q

    def velocities(self, input_angle, omega_in):
        """(nb, 3) velocities at input angle [rad] and input speed [rad/s]."""
        g, L = self.g, self.L
        r = g.rates
        s = float(input_angle)
        phi_c, a = r["carrier"] * s, r["crank"] * s
        wc, wa = r["carrier"] * omega_in, r["crank"] * omega_in
        v = np.zeros((L.n_bodies, 3))
        v[0, 2] = omega_in
        if L.three_stage:
            v[L.sun, 2] = r["sun"] * omega_in
        for k, b in enumerate(g.crank_angles):
            v[L.crank(k)] = (-g.crank_radius * np.sin(b + phi_c) * wc, g.crank_radius * np.cos(b + phi_c) * wc, wa)
        for j in range(2):
            vx, vy = journal_velocity(self.e, self.phases[j], a, wa)
            v[L.wheel(j)] = (vx, vy, wc)
        v[L.carrier, 2] = wc
        return v


def reference_poses(design, graph, layout):
    """(nb, 3) poses at input angle 0: crank k at beta_k on the crank circle, turned to its gear's
    conjugate angle; wheels on the journals; carrier and sun at zero (three-stage: the pinion at
    its offset centre, the compound gear conjugate to it)."""
    g, L = graph, layout
    ref = np.zeros((L.n_bodies, 3))
    if L.three_stage:
        ref[0, :2] = g.input_centre
        ref[L.sun, 2] = g.sun_angle0
    for k, b in enumerate(g.crank_angles):
        ref[L.crank(k)] = (g.crank_radius * math.cos(b), g.crank_radius * math.sin(b), g.crank_gear_angles0[k])
    for j, ph in enumerate(design.wheels.phases):
        ref[L.wheel(j), :2] = journal_centre(design.wheels.eccentricity, ph)
    return ref


def wheel_mass(design, graph):
    """(m [kg], J [kg m^2]) of one wheel: an annulus between the root circle and the bore, less the crank bores."""
    d = design
    r_o = d.pins.pin_circle_radius - d.pins.pin_radius - d.wheels.eccentricity
    r_b = d.eccentric_bearing.inner_radius + d.eccentric_bearing.roller_diameter
    rc, n = graph.crank_radius, d.cranks.count
    rho_t = d.material.density * d.wheels.width
    m = rho_t * math.pi * (r_o ** 2 - n * r_b ** 2)
    J = rho_t * math.pi * (0.5 * r_o ** 4 - n * (0.5 * r_b ** 4 + r_b ** 2 * rc ** 2))
    return m, J


def involute_friction_law(design, pair):
    """FrictionLaw of the involute meshes of ``pair`` from ``[involute_stage]``: none for mu = 0,
    the regularized law of Eq. (friction) or the anchor model (k_t from the design, else Mindlin's
    ratio of the pair's normal secant stiffness at ``involute_stage.reference_force``)."""
    st = design.involute_stage
    if st.mu == 0.0:
        return FrictionLaw()
    if st.friction_model == "regularized":
        return FrictionLaw(model=FrictionModel.REGULARIZED, mu_kinetic=st.mu)
    kt = st.tangential_stiffness or (mindlin_tangential_ratio(pair.gear_a.poisson_ratio)
                                     * pair_secant_stiffness(pair, st.reference_force))
    return FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=st.mu, tangential_stiffness=kt)


def gear_meshes(design, graph, layout):
    """The involute meshes: sun (gear A) -- crank gear k (gear B), and the three-stage pinion -- compound gear."""
    st = design.involute_stage
    kw = dict(n_slices=st.n_slices, window=st.window, damping=st.damping, ramp_depth=st.ramp_depth)
    # crank k's own gear (its pitch deviations, cranks.gear_pitch_deviations); the nominal pair otherwise
    pairs = [graph.sun_pair if design.crank_gear_of(k) is design.crank_gear
             else dataclasses.replace(graph.sun_pair, gear_b=design.crank_gear_of(k)) for k in range(layout.n_cranks)]
    # one friction law for all sun meshes: the anchor stiffness from the nominal pair (pitch deviations
    # turn teeth rigidly and leave the pair's secant stiffness unchanged)
    sun = involute_friction_law(design, graph.sun_pair)
    meshes = [GearMesh(pair=pairs[k], body_a=layout.sun, body_b=layout.crank(k), name=f"crank_gear{k}",
                       friction=sun, **kw) for k in range(layout.n_cranks)]
    if layout.three_stage:
        meshes.append(GearMesh(pair=graph.input_pair, body_a=0, body_b=layout.sun, name="input_stage",
                               friction=involute_friction_law(design, graph.input_pair), **kw))
    return meshes


def needle_mountings(design, graph, layout):
    """Needle bearing of journal j of crank k into wheel j's bore k: the journal centre in the crank's
    frame at the wheel's absolute phase (plus the crank's declared phase error), the bore on the crank circle
    (plus its declared position error ``cranks.wheel_bore_errors``, in the wheel's frame)."""
    d = design
    out = []
    for k, b in enumerate(graph.crank_angles):
        e_k = d.wheels.eccentricity + d.cranks.eccentricity_error(k)
        for j, ph in enumerate(d.wheels.phases):
            phase = ph + d.cranks.phase_error(k) - graph.crank_gear_angles0[k]
            jc = journal_centre(e_k, phase)
            oc = (graph.crank_radius * math.cos(b), graph.crank_radius * math.sin(b))
            if d.cranks.wheel_bore_errors:                      # absent: the nominal centre, bit-identical
                dx, dy = d.cranks.wheel_bore_error(k, j)
                oc = (oc[0] + dx, oc[1] + dy)
            out.append(Mounting(name=f"eccentric_bearing_c{k}w{j}", bearing=d.eccentric_bearing, inner=layout.crank(k),
                                outer=layout.wheel(j), inner_centre=(float(jc[0]), float(jc[1])), outer_centre=oc))
    return out


def crank_mountings(design, graph, layout, seats=False):
    """Tapered pair of crank k in the carrier, cup centred on the crank circle; ``seats``: the cup on crank k's
    seat body n_bodies + k of the ported carrier (:func:`ported_carrier`) instead of the carrier body; the cup
    off the crank circle by its declared seat position error (``cranks.carrier_bore_errors``, carrier frame)."""
    out = []
    for k, b in enumerate(graph.crank_angles):
        oc = (graph.crank_radius * math.cos(b), graph.crank_radius * math.sin(b))
        if design.cranks.carrier_bore_errors:                   # absent: the nominal centre, bit-identical
            dx, dy = design.cranks.carrier_bore_error(k)
            oc = (oc[0] + dx, oc[1] + dy)
        out.append(TaperedMounting(name=f"crank_bearing{k}", bearing=design.crank_bearing, inner=layout.crank(k),
                                   outer=layout.n_bodies + k if seats else layout.carrier, outer_centre=oc))
    return out


def ported_carrier(design, graph, layout, rigid, opts):
    """The crank bearings on the ported carrier (``carrier.body = "ported"``, :mod:`rvtool.assembly.carrier`):
    the tapered pairs on one seat body per crank (n_bodies + k), closed by the carrier's seat compliance
    (:class:`~rvtool.assembly.carrier.CarrierSeatClosure`); ``rigid``, the rigid carrier's set, otherwise
    (unchanged: the default costs nothing)."""
    if not design.carrier.ported:
        return rigid
    from ..carrier import CarrierSeatClosure, seat_compliance
    if design.bodies.spatial_cranks or type(rigid) is not TaperedBearingSet:
        raise RvtoolInputError("carrier.body = 'ported' with bodies.crank_coordinates = 'spatial' is not implemented "
                               f"(the crank bearings are a {type(rigid).__name__}; the seats are planar ports); "
                               "valid: bodies.crank_coordinates = 'planar' or carrier.body = 'rigid'")
    if design.bearing_friction.model != "none":
        raise RvtoolInputError(f"carrier.body = 'ported' with bearing_friction.model = "
                               f"{design.bearing_friction.model!r} is not implemented (Palmgren's moment reads the "
                               "crank bearings on the rigid carrier); valid: bearing_friction.model = 'none' or "
                               "carrier.body = 'rigid'")
    nc = layout.n_cranks
    inner = TaperedBearingSet(crank_mountings(design, graph, layout, seats=True), layout.n_bodies + nc,
                              name="crank_bearings", **opts)
    return CarrierSeatClosure(inner, n_bodies=layout.n_bodies, carrier=layout.carrier,
                              compliance=seat_compliance(design, graph))


@dataclass
class RvModel(ReducerModel):
    """An assembled RV reducer: the :class:`~rvtool.model.ReducerModel` plus its gear graph,
    layout, wheel profiles and the per-crank load observations."""
    graph: GearGraph = None
    layout: Layout = None
    profiles: list = field(default_factory=list)
    #: station compliance (3, 3) [m/N] of one elastic crank (journal of wheel 0, of wheel 1, gear;
    #: :func:`crank_station_compliance`), or None (rigid cranks)
    crank_compliance: np.ndarray = None
    torsion_compliance: np.ndarray = None
    #: ReducedStructure of the elastic housing carrying the ring pins, or None (rigid ring)
    housing: object = None
    #: free play (needle clearance, backlash) leaves the cranks without contact stiffness at zero load
    guided_free_play: bool = True
    #: RvFlexibleWheels (wheels.dynamics.model = "flexible", :mod:`.flexible_wheels`), or None (rigid wheels)
    flexible: object = None
    #: FlexibleCranks (cranks.dynamics.model = "flexible", :mod:`.flexible_cranks`), or None (rigid cranks)
    flexible_cranks: object = None
    #: budget path -> depth of its closure in the elastic wheels' nested element ``"wheel_bodies"``
    #: (:mod:`rvtool.assembly.rv.wheel_path`); empty without elastic wheels
    series_paths: dict = field(default_factory=dict)

    def _pose(self, name, q):
        el = self.elements[name]
        ql = el.local(q)
        return el.pose_velocity(ql, np.zeros_like(ql))[0]

    def crank_bearing_forces(self, q):
        """(N_c, 2) force [N] of each crank's tapered pair on the carrier, and (N_c, 2) its point of
        action (the cup centre, world) at the static state q."""
        el = self.elements["crank_bearings"]
        pose = self._pose("crank_bearings", q)
        if self.design.carrier.ported:
            pose = el.evaluator.extended_pose(pose)            # the seat bodies at the solved seat displacements
        res = el.evaluator.resultants(pose)
        forces, points = [], []
        for k, m in enumerate(el.evaluator.mountings):
            forces.append(-np.asarray(res[m.name].force))      # the rollers push the cone; the cup gets the reaction
            th = pose[m.outer, 2]
            c, s = math.cos(th), math.sin(th)
            oc = np.asarray(m.outer_centre)
            points.append(pose[m.outer, :2] + np.array([c * oc[0] - s * oc[1], s * oc[0] + c * oc[1]]))
        return np.array(forces), np.array(points)

    def crank_torques(self, q):
        """(N_c,) torque [N m] of each crank's bearing force on the carrier about the carrier axis."""
        F, P = self.crank_bearing_forces(q)
        c = self._pose("crank_bearings", q)[self.layout.carrier, :2]
        r = P - c
        return r[:, 0] * F[:, 1] - r[:, 1] * F[:, 0]

    def crank_load_share(self, q):
        """(N_c,) fraction of the summed crank torque about the carrier axis carried by each crank."""
        t = self.crank_torques(q)
        return t / np.sum(t)

    def eccentric_bearing_resultants(self, q):
        """{mounting name: |resultant| [N]} of every needle bearing (crank k, wheel j) at q."""
        needles, pose = self.needle_state(q)
        res = needles.resultants(pose)
        return {name: float(np.hypot(*r.force)) for name, r in res.items()}

    def needle_state(self, q):
        """(the needle bearing set, the poses it is evaluated at) at the static state q: the
        element's bodies, and with elastic cranks the journal stations at the solved deflections."""
        if "wheel_bodies" in self.elements:
            return leaf_state(self.elements["wheel_bodies"].evaluator, self._pose("wheel_bodies", q),
                              "eccentric_bearings")
        if self.crank_compliance is None:
            return self.elements["eccentric_bearings"].evaluator, self._pose("eccentric_bearings", q)
        closure, pose = planar_view(self.elements["cranks"].evaluator, self._pose("cranks", q))
        pose = closure.extended_pose(pose)
        if self.torsion_compliance is not None:
            pose = closure.inner.extended_pose(pose)       # the twisting journals inside the beam's closure
        return closure.inner.part("eccentric_bearings"), pose

    def crank_deflections(self, q):
        """(N_c, 3, 2) bending deflections [m] of every elastic crank at its stations (journal of
        wheel 0, of wheel 1, gear; x, y) relative to its support line at the static state q, or
        None (rigid cranks)."""
        if self.crank_compliance is None:
            return None
        if "wheel_bodies" in self.elements:
            return NestedSeries("cranks", self.elements["wheel_bodies"], self.series_paths["cranks"]).deflections(q)
        closure, pose = planar_view(self.elements["cranks"].evaluator, self._pose("cranks", q))
        return closure.deflections(pose)

    def series_compliance(self, family):
        """Elastic cranks (``cranks.shaft``): the beam of every crank with its station compliance
        over the two journals and the gear, closed per crank (:mod:`rvtool.contact.pin_closure`),
        reported once, with the eccentric bearings (budget path ``"cranks"``); crank torsion likewise
        (path ``"crank_torsion"``; with the beam on, the torsion's closure nested inside the beam's,
        :class:`~rvtool.assembly.rv.wheel_path.NestedSeries`); with elastic wheels every member nested in
        their element (paths ``"wheel_bodies"``, ``"pin_grooves"``, ``"cranks"``, ``"crank_torsion"``,
        :mod:`rvtool.assembly.rv.wheel_path`); the ring pins'
        conformal grooves with the pins (path ``"pin_grooves"``, :class:`GrooveSeries`); the ported carrier's
        crank seats with the crank bearings (path ``"carrier"``, :mod:`rvtool.assembly.carrier`)."""
        from ...model import SeriesBeam
        fam = Family(family)
        tilting = self.body_tilts is not None and any(n.startswith(("wheel", "crank")) for n in self.body_tilts.names)
        if tilting and (self.crank_compliance is not None or self.torsion_compliance is not None
                        or self.design.pins.groove != "rigid"):
            raise RvtoolInputError("the series members (elastic cranks, pin grooves) of a model with tilting wheels or "
                                   "cranks are closed inside the width slices; their budget paths are not implemented; "
                                   "valid: bodies.wheel_coordinates / crank_coordinates = 'planar'")
        if "wheel_bodies" in self.elements and fam in (Family.PINS, Family.ECCENTRIC_BEARINGS):
            # the nested members of the elastic wheels' element (rvtool.assembly.rv.wheel_path)
            return tuple(NestedSeries(p, self.elements["wheel_bodies"], k) for p, k in self.series_paths.items()
                         if NestedSeries.family_of(p) == fam) or None
        if fam == Family.CRANK_BEARINGS and self.design.carrier.ported:
            return GrooveSeries.of_groove(self.elements["crank_bearings"], "carrier", Family.CRANK_BEARINGS)
        if fam == Family.PINS and self.design.pins.groove != "rigid":
            return GrooveSeries.of_groove(self.elements["pins"])
        if fam != Family.ECCENTRIC_BEARINGS:
            return None
        if self.torsion_compliance is not None and self.crank_compliance is None:
            return SeriesBeam.of_closure("crank_torsion", Family.ECCENTRIC_BEARINGS, self.torsion_compliance,
                                         self.elements["eccentric_bearings"])
        if self.crank_compliance is None:
            return None
        beam = SeriesBeam.of_closure("cranks", Family.ECCENTRIC_BEARINGS, self.crank_compliance, self.elements["cranks"])
        if self.torsion_compliance is None:
            return beam
        return beam, NestedSeries("crank_torsion", self.elements["cranks"], 1)      # the torsion inside the beam's

    def input_torque(self, q):
        """Torque [N m] the drive applies to the input rotation at the static state q: minus the
        contact elements' generalized force on it (frictionless statics)."""
        i = self.input_index
        t = 0.0
        for el in self.elements.values():
            ltg = el.coordinate_indices
            hit = np.flatnonzero(ltg == i)
            if len(hit):
                t -= float(el.evaluation_at(q).Q[hit[0]])
        return t

    def marker_frequencies(self, speed_rpm):
        """Mesh and bearing marker frequencies [Hz] at input speed [rpm] (rates from the gear graph):
        input, output, crank (absolute and relative to the carrier), the cycloid mesh z_b f_crank, the
        involute mesh(es) z f_relative, and the needle, tapered and main bearings at their relative
        ring speeds."""
        from ...bearings.frequencies import bearing_frequencies
        d, r = self.design, self.graph.rates
        f_in = speed_rpm / 60.0
        f_c, f_k, f_s = r["carrier"] * f_in, r["crank"] * f_in, r["sun"] * f_in
        f_rel = f_k - f_c                      # crank relative to the carrier and to the wheels
        nb, tp, mb = d.eccentric_bearing, d.crank_bearing.rows[0], d.main_bearing.rows[0]
        out = {"input_hz": f_in, "output_hz": abs(f_c), "crank_hz": abs(f_k), "crank_relative_hz": abs(f_rel),
               "mesh_hz": d.pins.n_pins * abs(f_k), "involute_mesh_hz": d.sun_gear.n_teeth * abs(f_s - f_c),
               "eccentric_bearing": bearing_frequencies(f_rel, nb.n_rollers, nb.roller_diameter, nb.pitch_diameter),
               "crank_bearing": bearing_frequencies(f_rel, tp.n_rollers, tp.roller_diameter, tp.pitch_diameter,
                                                    tp.cup_angle),
               "main_bearing": bearing_frequencies(f_c, mb.n_balls, mb.ball_diameter, mb.pitch_diameter,
                                                   mb.contact_angle)}
        if self.layout.three_stage:
            out["input_stage_mesh_hz"] = d.input_pinion.n_teeth * f_in
        if self.flexible is not None:
            # the flexible wheels' retained in-plane free-free modes (body modes beside the mesh and bearings)
            out["wheel_modes_hz"] = sorted({float(f) for b in self.flexible.bodies for f in b.frequencies_hz})
        if self.flexible_cranks is not None:
            # the flexible cranks' retained modes (free-free bending and torsion, then the static Ritz vectors)
            out["crank_modes_hz"] = sorted({float(f) for f in self.flexible_cranks.body.frequencies_hz})
        return out

    def refined_design(self):
        return self.design.refined()

    def resolution_settings(self):
        d = self.design
        return {"samples_per_tooth": d.wheels.samples_per_tooth, "wheel_slices": d.wheels.n_slices,
                "involute_slices": d.involute_stage.n_slices, "needle_slices": d.eccentric_bearing.n_slices,
                "tapered_slices": d.crank_bearing.rows[0].n_slices}

    def draw_section(self, ax, q):
        import matplotlib.pyplot as plt
        from ...geometry.cycloid import pin_centres
        pose = self._pose("pins", q)
        for j in range(2):
            x = pose[self.layout.wheel(j)]
            pts = self.profiles[j].points(np.linspace(0, 2 * np.pi, 4000))
            c, s = np.cos(x[2]), np.sin(x[2])
            ax.plot(x[0] + c * pts[:, 0] - s * pts[:, 1], x[1] + s * pts[:, 0] + c * pts[:, 1], lw=0.6,
                    label=f"wheel {j}")
        for p in pin_centres(self.profiles[0]):
            ax.add_patch(plt.Circle(p, self.design.pins.pin_radius, fill=False, color="k", lw=0.5))
        g = self.graph
        for k in range(self.layout.n_cranks):
            x = pose[self.layout.crank(k)]
            ax.add_patch(plt.Circle(x[:2], g.sun_pair.gear_b.reference_radius, fill=False, color="g", lw=0.5))
        ax.add_patch(plt.Circle(pose[self.layout.sun, :2], g.sun_pair.gear_a.reference_radius, fill=False, color="g",
                                lw=0.5, label="input stage, reference circles"))
        super().draw_section(ax, q)


@dataclass(frozen=True)
class GrooveSeries(SeriesBeamBase):
    """The ring pins' grooves (``pins.groove = "conformal"``) for the stiffness budget (path
    ``"pin_grooves"``): the station law is nonlinear, so its energy along a mode is du^T G du with
    G = ds/du, the law's tangent at the solved deflections, and its stiffened view scales G
    (:meth:`rvtool.contact.pin_closure.ElasticPinClosure.condense` with ``u``)."""
    closure: object = None
    pose: object = None

    def energy(self, q, dq, step=1e-9):
        h = step / max(float(np.abs(dq).max()), 1e-300)
        du = (self.deflections(q + h * dq) - self.deflections(q - h * dq)) / (2 * h)
        u = self.closure.solve(*self.pose(q))[0]
        return float(du.ravel() @ self.closure.support_tangent(u) @ du.ravel())

    @classmethod
    def of_groove(cls, element, path="pin_grooves", family=Family.PINS):
        """The station law of ``element``'s closure as the budget path ``path`` of ``family`` (the ring pins'
        grooves; the carrier's crank seats, path ``"carrier"`` of the crank bearings)."""
        closure = element.evaluator

        def pose(q):
            ql = element.local(q)
            return element.pose_velocity(ql, 0 * ql)

        def stiffened(q, factor):
            u, _, red, _ = closure.solve(*pose(q))
            # the closure's tangent is on its bodies (the port bodies of a ported housing): into the
            # element's coordinates (the housing's eta) as the element's own evaluation
            return element.coordinate_indices, element.element_tangent(closure.condense(red, beam_factor=factor, u=u)[1])
        return cls(path, family, closure.compliance, lambda q: closure.deflections(pose(q)[0]),
                   stiffened, closure, pose)


FAMILY_ELEMENTS = {Family.PINS: "pins", Family.INVOLUTE_STAGE: "gears", Family.ECCENTRIC_BEARINGS: "eccentric_bearings",
                   Family.CRANK_BEARINGS: "crank_bearings", Family.MAIN_BEARINGS: "main_bearings"}

#: the stations of an elastic crank, in the order of its station compliance
CRANK_STATIONS = ("journal_wheel0", "journal_wheel1", "gear")


def crank_station_compliance(design):
    """Station compliance C (3, 3) [m/N] of one crank (:data:`CRANK_STATIONS`: the journals at the
    wheel midplanes over the needle rollers' length, the gear at ``cranks.shaft.gear_position``
    over its face width; :class:`~rvtool.structure.crank_beam.CrankBeam`), or None for rigid cranks."""
    from ...structure.crank_beam import CrankBeam
    sh = design.cranks.shaft
    if not sh.elastic:
        return None
    beam = CrankBeam(sh.radius, sh.supports, design.material.youngs_modulus, design.material.poisson_ratio,
                     shear=sh.shear, shear_coefficient=sh.shear_coefficient)
    w = design.eccentric_bearing.roller_length
    centres = np.array([*design.wheels.midplanes, sh.gear_position])
    C = beam.station_compliance(centres, (w, w, design.crank_gear.face_width))
    if sh.tilt:
        # the crank tilting on its pair about the pair's centre: a station at z from it moves by
        # z gamma under gamma = M / K_gamma (the tilting mode; the planar law carries the translation)
        z = centres - 0.5 * sum(sh.supports)
        C = C + np.outer(z, z) / crank_pair_tilt_stiffness(design, rated_crank_bearing_load(design))
    return C


def rated_crank_bearing_load(design):
    """Radial load [N] of one crank's pair at rated torque by statics: the cranks carry the output
    torque to the carrier on the crank circle, F = T_rated / (N_c r_c) (equal shares)."""
    from .gear_graph import GearGraph
    return design.rated_torque / (design.cranks.count * GearGraph.of(design).crank_radius)


def crank_pair_tilt_stiffness(design, radial_load=0.0):
    """Tilting stiffness K_gamma [N m/rad] of a crank's tapered pair (``crank_bearing``): the mean
    of the moment--tilt diagonal of the pair's 5-DOF tangent (:meth:`rvtool.bearings.tapered_set.
    TaperedBearingSet.relative`) at the radial displacement that carries ``radial_load`` [N]
    (Newton on the pair's radial force; 0: the preload only). The tilting stiffness of a
    preloaded back-to-back pair falls as the radial load unloads one side (rv40e: 1.11e6 N m/rad
    at the preload, 0.76e6 at the rated 3.8 kN), so the tilt is linearized at the rated load."""
    from ...bearings.tapered_set import TaperedBearingSet, TaperedMounting
    s = TaperedBearingSet([TaperedMounting(name="crank_pair", bearing=design.crank_bearing, inner=0, outer=1)], 2,
                          backend="numpy")
    q = np.zeros((1, 5))
    for _ in range(50):
        r = s.relative(q)
        res = -r.wrench[0, 0] - radial_load          # the wrench is the force on the cone: -F_x carries the load
        if abs(res) <= 1e-9 * max(radial_load, 1.0):
            break
        q[0, 0] -= res / -r.stiffness[0, 0, 0]
    else:
        raise RvtoolInputError(f"crank_bearing: no radial displacement carries {radial_load:.6g} N (pair unstable)")
    K = s.relative(q).stiffness[0]
    return float(-0.5 * (K[3, 3] + K[4, 4]))      # the tangent is dF/dq of the wrench on the cone


def crank_torsion_compliance(design):
    """Torsion compliance C (n_wheels, n_wheels) [rad/(N m)] of one crank between its gear and its
    journals (``cranks.shaft.torsion = "elastic"``, :mod:`rvtool.structure.crank_torsion`), or None."""
    from ...structure.crank_torsion import torsion_compliance
    sh = design.cranks.shaft
    if sh.torsion == "rigid":
        return None
    m = design.material
    return torsion_compliance(sh.radius, m.youngs_modulus, m.poisson_ratio, sh.gear_position, design.wheels.midplanes)


def station_skew(family, design, layout, tilt, rows, stations, width, *, wheels=True):
    """A family on crank station bodies (a series closure's journals or gear station) across ``width``
    with the tilts of the spatial cranks and wheels (:class:`~rvtool.contact.skew.SkewSlices`, the
    out-of-plane rows carried as the closure's pass-through bodies n_bodies ... n_bodies + n_virtual - 1):
    ``stations`` {station body: (crank k, axial station of the contact plane [m])}; a station's arm is
    its station about the crank's centre plus the slice's, a spatial wheel's the slice's."""
    from ...contact.skew import SkewSlices, slice_stations
    z, w = slice_stations(width, design.bodies.tilt_slices)
    arms = np.zeros((len(w), family.n_bodies))
    tilted = {}
    z_c = crank_centre(design)
    for i, (k, z_k) in stations.items():
        if layout.crank(k) in rows:
            arms[:, i], tilted[i] = z_k - z_c + z, rows[layout.crank(k)]
    for j in range(2 if wheels else 0):
        i = layout.wheel(j)
        if i in rows:
            arms[:, i], tilted[i] = z, rows[i]
    return SkewSlices(family, tilt.n_virtual, tilted, arms, w, name=family.name, tilt_offset=layout.n_bodies)


def torsion_crank_path(design, graph, layout, compliance, opts, tilt=None, rows=None):
    """The needle bearings on twisting cranks: one station body per (crank k, wheel j) at index
    n_bodies + n_wheels k + j, the crank rotated about its axis by the journal's twist relative to
    the gear (the crank body's rotation is the gear's), closed per crank by Eq. (2) of
    :mod:`rvtool.structure.crank_torsion` (:class:`~rvtool.contact.pin_closure.ElasticPinClosure`
    with ``dofs = (2,)``). The gears and the tapered rows stay on the crank body. With spatial cranks (``tilt``, ``rows``
    of :func:`spatial_bodies`) the out-of-plane rows ride along as pass-through bodies n_bodies ...
    and the needles are sliced with the cranks' tilts at their journal stations (:func:`station_skew`)."""
    from ...contact.pin_closure import ElasticPinClosure
    nc, nw = layout.n_cranks, design.n_wheels
    nb = layout.n_bodies + (tilt.n_virtual if design.bodies.spatial_cranks else 0)
    station = nb + np.arange(nc * nw).reshape(nc, nw)
    crank_of = {layout.crank(k): k for k in range(nc)}
    mounts = [dataclasses.replace(m, inner=int(station[crank_of[m.inner], m.outer - layout.wheel0]))
              for m in needle_mountings(design, graph, layout)]
    needles = BearingSet(mounts, nb + station.size, name="eccentric_bearings", **opts)
    if design.bodies.spatial_cranks:
        needles = station_skew(needles, design, layout, tilt, rows,
                               {int(station[k, j]): (k, design.wheels.midplanes[j]) for k in range(nc) for j in range(nw)},
                               design.wheels.width)
    return ElasticPinClosure(needles, n_bodies=nb, carrier=[layout.crank(k) for k in range(nc)],
                             station_compliance=compliance, station=station - nb, dofs=(2,))


def groove_pins(design, layout, pin_set_of, meshes, ports=None):
    """The ring pins in conformal grooves (``pins.groove = "conformal"``, :mod:`rvtool.contact.groove`):
    one station body per (pin p, wheel j) after the bodies (and the port bodies of a ported ring),
    at n + n_wheels p + j: pin p's groove (the ground, or its port body on the elastic housing)
    translated by the pin centre's displacement under wheel j in its groove; the wheel--pin meshes
    on them, closed per pin by the groove law (:class:`~rvtool.contact.pin_closure.ElasticPinClosure`
    with ``support``). ``pin_set_of(meshes, n_bodies)`` builds the contact set. Returns the closure,
    or None for rigid grooves."""
    from ...contact.groove import GrooveSupport, groove_law
    from ...contact.pin_closure import GROUND as PIN_GROUND, ElasticPinClosure
    law = groove_law(design)
    if law is None:
        return None
    zb, nw = design.pins.n_pins, design.n_wheels
    n = layout.n_bodies + (0 if ports is None else ports.n_virtual)
    # ported ring: pin p's port body is n_bodies + p (:func:`ported_ring`); the stations ride on it
    carrier = PIN_GROUND if ports is None else [layout.n_bodies + p for p in range(zb)]
    st = np.arange(zb * nw).reshape(zb, nw)
    meshes = [dataclasses.replace(m, pin_bodies=tuple(int(b) for b in n + st[:, k])) for k, m in enumerate(meshes)]
    return ElasticPinClosure(pin_set_of(meshes, n + st.size), n_bodies=n, carrier=carrier,
                             station_compliance=None, station=st, support=GrooveSupport(law))


def elastic_crank_path(design, graph, layout, compliance, opts, torsion=None, tilt=None, rows=None):
    """The contact set of the crank path with elastic cranks: the involute meshes and the needle
    bearings stacked (:class:`~rvtool.contact.stacked.StackedContactSet`, element ``"cranks"``) over
    the bodies plus one station body per (crank k, station s) at index n_bodies + 3 k + s (the
    crank translated by its deflection there; :data:`CRANK_STATIONS`), closed per crank by its beam
    (:class:`~rvtool.contact.pin_closure.ElasticPinClosure`, Eq. (series_contact)). The crank
    bearings stay on the crank body: the beam is held at its supports.

    torsion: the torsion compliance (n_wheels, n_wheels) of :func:`crank_torsion_compliance`, or
    None. With it the needles sit on one more station body per (crank k, wheel j) at n_bodies +
    3 n_cranks + n_wheels k + j, journal j's bending station rotated by the twist (an inner closure,
    ``dofs = (2,)``, carried per station), and the beam closes that closure: bending and torsion
    in series, each solved exactly.

    With spatial cranks (``tilt``, ``rows`` of :func:`spatial_bodies`) the out-of-plane rows ride
    along as pass-through bodies n_bodies ... n_bodies + n_virtual - 1 (the stations after them), and
    the meshes and needles are sliced with the cranks' tilts at their stations (:func:`station_skew`:
    the gear at ``cranks.shaft.gear_position``, the journals at the wheel mid-planes): the beam carries
    the in-plane bending, the tilt rows the crank's rigid tilt."""
    import dataclasses
    from ...contact.pin_closure import ElasticPinClosure
    from ...contact.stacked import StackedContactSet
    nc, nw = layout.n_cranks, design.n_wheels
    spatial = design.bodies.spatial_cranks
    nb = layout.n_bodies + (tilt.n_virtual if spatial else 0)
    station = nb + np.arange(3 * nc).reshape(nc, 3)
    crank_of = {layout.crank(k): k for k in range(nc)}
    meshes = [dataclasses.replace(m, body_b=int(station[crank_of[m.body_b], 2])) if m.body_b in crank_of else m
              for m in gear_meshes(design, graph, layout)]
    journal = station if torsion is None else nb + station.size + np.arange(nc * nw).reshape(nc, nw)
    mounts = [dataclasses.replace(m, inner=int(journal[crank_of[m.inner], m.outer - layout.wheel0]))
              for m in needle_mountings(design, graph, layout)]
    n_ext = nb + station.size + (0 if torsion is None else journal.size)
    gears = InvoluteContactSet(meshes, n_ext, name="gears", **opts)
    needles = BearingSet(mounts, n_ext, name="eccentric_bearings", **opts)
    if spatial:
        gear_z = design.cranks.shaft.gear_position
        gears = station_skew(gears, design, layout, tilt, rows, {int(station[k, 2]): (k, gear_z) for k in range(nc)},
                             design.crank_gear.face_width, wheels=False)
        needles = station_skew(needles, design, layout, tilt, rows,
                               {int(journal[k, j]): (k, design.wheels.midplanes[j]) for k in range(nc) for j in range(nw)},
                               design.wheels.width)
    stacked = StackedContactSet((gears, needles), name="cranks")
    inner = stacked
    if torsion is not None:
        inner = ElasticPinClosure(stacked, n_bodies=nb + station.size, carrier=station[:, :nw],
                                  station_compliance=torsion, station=journal - nb - station.size, dofs=(2,))
    return ElasticPinClosure(inner, n_bodies=nb, carrier=[layout.crank(k) for k in range(nc)],
                             station_compliance=compliance, station=station - nb)


def ported_ring(mbs, design, layout, meshes):
    """The ring pins on the elastic housing (``housing.model = "ports"``; the cycloid's housing
    machinery, :func:`rvtool.assembly.housing.housing_ports`): the reduced housing as an Exudyn
    structure, one port body per ring pin after the bodies (index n_bodies + k carries pin k, its
    centre moving with the port, Eq. port_runtime_transform), the wheel--pin meshes on those port
    bodies. Returns (ReducedStructure, PortBodies, meshes); (None, None, meshes) for a rigid ring.
    The main bearings stay grounded (their seats are not ported), as in the cycloid drive."""
    import dataclasses
    if design.housing.model != "ports":
        return None, None, meshes
    from exudyn_user_elements.contact_element import PortBodies
    from exudyn_user_elements.reduced_structure import ReducedStructure
    from ..housing import housing_ports
    reduced, _, _ = housing_ports(design)
    housing = ReducedStructure(mbs, reduced, name="housing")
    zb = design.pins.n_pins
    ports = PortBodies(housing, np.array([reduced.port_rows[k][:2] for k in range(zb)]))
    pin_bodies = tuple(range(layout.n_bodies, layout.n_bodies + zb))
    return housing, ports, [dataclasses.replace(m, pin_bodies=pin_bodies) for m in meshes]


def spatial_bodies(mbs, design, layout, wheel_mass, housing, regularization):
    """The retained axial and tilt coordinates of the spatial bodies (issue 32): the carrier
    (``bodies.carrier_coordinates``), the wheels (``bodies.wheel_coordinates``) and the cranks
    (``bodies.crank_coordinates``), in that order, as one
    :class:`~exudyn_user_elements.out_of_plane.RetainedTilt` (mass, transverse inertia, the builder's
    regularization springs; the element's pose rows n_bodies + row). Returns (RetainedTilt or None,
    {body index: row}). The housing stays rigid out of plane."""
    from exudyn_user_elements.out_of_plane import RetainedTilt
    b, L = design.bodies, layout
    bodies = []
    # a ported carrier's face and main seats: two rows closed by its out-of-plane seat compliance (the seats'
    # row last; mass and tilt inertia split equally between them, assumed: dynamic runs only)
    seats = b.spatial_carrier and design.carrier.ported
    if b.spatial_carrier:
        bodies.append(("carrier", L.carrier, b.carrier_mass / (1 + seats), b.tilt_inertia / (1 + seats)))
    if b.spatial_wheels:
        m_w, J_w = wheel_mass
        J_t = J_w / 2 if b.wheel_tilt_inertia is None else b.wheel_tilt_inertia
        bodies += [(f"wheel{j}", L.wheel(j), m_w, J_t) for j in range(2)]
    if b.spatial_cranks:
        # a crankshaft's transverse inertia about its bearing centre: a slender shaft over the wheel pitch
        # (assumed; dynamic runs only)
        span = max(abs(design.wheels.midplanes[-1] - design.wheels.midplanes[0]), design.wheels.width)
        J_c = design.cranks.inertia / 2 + design.cranks.mass * span ** 2 / 12
        bodies += [(f"crank{k}", L.crank(k), design.cranks.mass, J_c) for k in range(L.n_cranks)]
    if b.spatial_input:
        # the floating sun (last: the rows of the other bodies as without it); transverse inertia half the
        # polar one (a thin disc, assumed; dynamic runs only)
        if L.three_stage:
            raise RvtoolInputError("bodies.input_coordinates = 'spatial' is for the two-stage RV (its floating sun); "
                                   "the three-stage input body is the offset pinion and its compound gear is held on "
                                   "the axis; valid: input_coordinates = 'planar'")
        sh = design.cranks.shaft
        if sh.elastic or sh.torsion != "rigid":
            raise RvtoolInputError("bodies.input_coordinates = 'spatial' with elastic crankshafts (cranks.shaft.model / "
                                   "torsion) is not implemented (the sun-crank meshes are closed inside the crank "
                                   "closures); valid: rigid crankshafts or input_coordinates = 'planar'")
        bodies.append(("sun", L.sun, b.sun_mass, b.sun_inertia / 2))
    if not bodies:
        return None, {}
    keys = [k for k, on in (("carrier_coordinates", b.spatial_carrier), ("wheel_coordinates", b.spatial_wheels),
                            ("crank_coordinates", b.spatial_cranks), ("input_coordinates", b.spatial_input)) if on]
    said = " / ".join(f"bodies.{k} = 'spatial'" for k in keys)
    if housing is not None and b.spatial_wheels:
        raise RvtoolInputError(f"{said} with housing.model = 'ports' is not implemented (the ring pins on the "
                               "housing's port bodies are not sliced with the wheels' tilts); valid: "
                               "housing.model = 'rigid' or bodies.wheel_coordinates = 'planar'")
    if design.bearing_friction.model != "none" and (b.spatial_carrier or b.spatial_cranks):
        raise RvtoolInputError(f"{said} with bearing_friction.model = {design.bearing_friction.model!r} is not "
                               "implemented (Palmgren's moment reads the planar bearing sets); valid: "
                               "bearing_friction.model = 'none' or planar carrier and cranks")
    k_t, k_r = regularization
    rows = {i: r for r, (_, i, _, _) in enumerate(bodies)}
    if seats:
        bodies.append(("carrier_seats", L.carrier, b.carrier_mass / 2, b.tilt_inertia / 2))
    names = tuple(n for n, *_ in bodies)
    tilt = RetainedTilt(mbs, [m for *_, m, _ in bodies], [J for *_, J in bodies], (k_t, k_r),
                        name="carrier_tilt" if names[0] == "carrier" and len(rows) == 1 else "body_tilt", names=names)
    return tilt, rows


def spatial_needles(design, graph, layout, tilt, rows, opts):
    """The needle rows with spatial cranks: one bearing set per wheel (a crank's arm differs between
    its two journals), each across the wheel width with the crank's and (if spatial) the wheel's
    tilt (:func:`skewed`), stacked (:class:`~rvtool.contact.stacked.StackedContactSet`, element
    ``"eccentric_bearings"``; rows wheel after wheel)."""
    from ...contact.stacked import StackedContactSet
    mounts = needle_mountings(design, graph, layout)
    z_c = crank_centre(design)
    parts = []
    for j in range(2):
        sel = [m for m in mounts if m.outer == layout.wheel(j)]
        part = BearingSet(sel, layout.n_bodies, name=f"eccentric_bearings_w{j}", **opts)
        parts.append(skewed(part, design, layout, tilt, rows, wheel=j, crank_arm=design.wheels.midplanes[j] - z_c))
    return StackedContactSet(parts, name="eccentric_bearings")


def crank_centre(design):
    """Axial station [m] of every crank's tilt centre: the centre of its tapered pair, taken midway
    between the wheel mid-planes (the pair straddles the wheels symmetrically; assumed)."""
    return 0.5 * (design.wheels.midplanes[0] + design.wheels.midplanes[-1])


def skewed(family, design, layout, tilt, rows, *, wheel=None, crank_arm=None, width=None, wheels=True, sun=False):
    """``family`` (a planar evaluator over the bodies) across the wheel width with the tilts of its
    spatial bodies (:class:`~rvtool.contact.skew.SkewSlices`, Eq. (skew)): ``bodies.tilt_slices``
    equal slices of the wheel width; a spatial wheel's arm is the slice's station about its
    mid-plane; a spatial crank's arm (where ``crank_arm`` is given: the station of the family's contact
    plane about the crank's centre) that station plus the slice's. ``width``: the face width sliced
    (default the wheel width); ``wheels=False``: the family touches no wheel; ``sun``: a spatial sun
    tilts about the sun gear's mid-face (its arm is the slice's station). ``family`` unchanged if
    none of its bodies is spatial."""
    from ...contact.skew import SkewSlices, slice_stations
    z, w = slice_stations(design.wheels.width if width is None else width, design.bodies.tilt_slices)
    arms = np.zeros((len(w), family.n_bodies))
    tilted = {}
    for j in range(2 if wheels else 0):
        i = layout.wheel(j)
        if i in rows and (wheel is None or wheel == j):
            arms[:, i], tilted[i] = z, rows[i]
    for k in range(layout.n_cranks):
        i = layout.crank(k)
        if i in rows and crank_arm is not None:
            arms[:, i], tilted[i] = crank_arm + z, rows[i]
    if sun and layout.sun in rows:
        arms[:, layout.sun], tilted[layout.sun] = z, rows[layout.sun]
    if not tilted:
        return family
    return SkewSlices(family, tilt.n_virtual, tilted, arms, w, name=family.name)


def build(design: RVDesign, *, backend="warp", precision="float64", device="cpu", regularization=(100.0, 0.1),
          contact_element=None):
    """Assemble ``design`` into an Exudyn system; returns an :class:`RvModel`.

    regularization: (k_translation [N/m], k_rotation [N m/rad]) of weak springs from every free
    coordinate to its kinematic position (a numerical setting for the free play of the
    backlash and bearing clearances at zero load, as in the cycloid builder; the force they
    carry is reported by the protocols). (0, 0) removes them.
    contact_element: ``"merged"`` (every family in one Exudyn element, the ported ring's
    contraction on the pins in contact) or ``"per_family"`` (one element per family); None reads
    ``RVTOOL_CONTACT_ELEMENT`` (default ``"merged"``; :mod:`rvtool.assembly.contact_layout`).
    """
    if not isinstance(design, RVDesign):
        raise RvtoolInputError(f"design must be an RVDesign; got {type(design).__name__}")
    d = design
    graph = GearGraph.of(d)
    L = Layout(d)
    kin = RvKinematics(d, graph, L)
    ref = kin.reference
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    m_w, J_w = wheel_mass(d, graph)
    b = d.bodies
    masses = ([(b.pinion_mass, b.pinion_inertia)] if L.three_stage else []) + [(b.sun_mass, b.sun_inertia)] + \
        [(d.cranks.mass, d.cranks.inertia)] * L.n_cranks + [(m_w, J_w)] * 2 + [(b.carrier_mass, b.carrier_inertia)]
    nodes = []
    for k in range(L.n_bodies):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(ref[k])))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=masses[k][0], inertia=masses[k][1]))
        nodes.append(n)

    def marker(body, c):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[body], coordinate=c))

    # held coordinates: the input's undeclared x, y; the three-stage compound gear's centre
    held = [(0, c) for c, nm in enumerate(("x", "y")) if nm not in b.input]
    if L.three_stage:
        held += [(L.sun, 0), (L.sun, 1)]
    locks = [mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(body, c)])) for body, c in held]
    drive = mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(0, 2)], offset=0.0))
    k_t, k_r = regularization
    reg_springs = []
    for body in range(L.n_bodies):
        for c in range(3):
            if (body, c) in held or (body == 0 and c == 2):
                continue
            k = k_t if c < 2 else k_r
            if k > 0:
                reg_springs.append((body, c, k, mbs.AddObject(CoordinateSpringDamper(
                    markerNumbers=[mg, marker(body, c)], stiffness=k))))
    load = mbs.AddLoad(LoadCoordinate(markerNumber=marker(L.carrier, 2), load=0.0))

    opts = dict(backend=backend, precision=precision, device=device)
    if d.pins.support.elastic:
        raise RvtoolInputError(f"pins.support.model = {d.pins.support.model.value!r}: elastic ring pins are not "
                               "implemented for the RV topology; valid: 'rigid'")
    profiles, meshes = pin_meshes(d, offset=L.wheel0 - 1)
    housing, ports, meshes = ported_ring(mbs, d, L, meshes)
    flex = fcr = floating = None
    if d.wheels.dynamics.flexible or d.cranks.dynamics.flexible:
        # floating flexible wheels and/or cranks (issue 33), one modal structure: the pins, needles, gears and
        # tapered pairs on the bodies' port bodies
        from .flexible_cranks import RvFloatingBodies
        floating = RvFloatingBodies(mbs, d, mg, graph, L)
        flex, fcr = floating.wheels, floating.cranks
        if flex is not None:
            meshes = flex.pin_meshes(meshes)
    C_crank = crank_station_compliance(d)
    C_torsion = crank_torsion_compliance(d)
    # the elastic wheels with the other members nested (rvtool.assembly.rv.wheel_path), or None
    wheels = wheel_path(d, graph, L, meshes, opts, ports=ports, crank=C_crank, torsion=C_torsion)

    def pin_set_of(meshes, n_bodies):
        return CycloidPinSet(meshes, n_bodies, samples_per_tooth=d.wheels.samples_per_tooth, name="pins",
                             search=d.wheels.search, **opts)
    pin_set = groove_pins(d, L, pin_set_of, meshes, ports) if wheels is None else wheels.evaluator
    if pin_set is None:
        pin_set = pin_set_of(meshes, L.n_bodies + (0 if ports is None else ports.n_virtual) if flex is None
                             else flex.n_pin_bodies)
    tilt, rows = spatial_bodies(mbs, d, L, (m_w, J_w), housing, regularization)
    main_mounting = Mounting(name="main_bearing", bearing=d.main_bearing, inner=L.carrier, outer=GROUND)
    if b.spatial_carrier:
        from ...bearings.spatial_set import SpatialBearingSet
        seat_row = tilt.row("carrier_seats") if d.carrier.ported else rows[L.carrier]    # the main bearing's seats
        main = SpatialBearingSet([main_mounting], L.n_bodies + tilt.n_virtual, {L.carrier: L.n_bodies + seat_row},
                                 name="main_bearings", **opts)
    else:
        main = BearingSet([main_mounting], L.n_bodies, name="main_bearings", **opts)
    if b.spatial_cranks:
        from ...bearings.spatial_tapered import SpatialTaperedSet
        cranks = SpatialTaperedSet(TaperedBearingSet(crank_mountings(d, graph, L), L.n_bodies, name="crank_bearings",
                                                     **opts), tilt.n_virtual, rows)
    else:
        cranks = TaperedBearingSet(crank_mountings(d, graph, L), L.n_bodies, name="crank_bearings", **opts)
        if fcr is not None:
            cranks = fcr.crank_bearings(crank_mountings(d, graph, L), opts)
    cranks = ported_carrier(d, graph, L, cranks, opts)     # the rigid carrier's set unless carrier.body = "ported"
    if C_crank is None:
        gears = InvoluteContactSet(gear_meshes(d, graph, L), L.n_bodies, name="gears", **opts)
        if fcr is not None:
            gears = fcr.gears(gear_meshes(d, graph, L), opts)
        if C_torsion is None:
            needles = BearingSet(needle_mountings(d, graph, L), L.n_bodies, name="eccentric_bearings", **opts)
            if b.spatial_cranks:
                needles = spatial_needles(d, graph, L, tilt, rows, opts)
            if floating is not None:
                needles = floating.needles(opts)
        else:
            needles = torsion_crank_path(d, graph, L, C_torsion, opts, tilt, rows)
        crank_path = (("gears", gears), ("eccentric_bearings", needles))
    else:
        crank_path = (("cranks", elastic_crank_path(d, graph, L, C_crank, opts, torsion=C_torsion, tilt=tilt,
                                                    rows=rows)),)
    gear_z = d.cranks.shaft.gear_position
    if b.spatial_cranks and gear_z is not None or b.spatial_input:
        # the sun--crank meshes across the crank gear's face with the crank's tilt (the sun planar unless
        # bodies.input_coordinates = "spatial": then with the sun's tilt too); without a declared gear
        # position (cranks.shaft.gear_position) the cranks' tilts do not enter the meshes
        arm = None if gear_z is None or not b.spatial_cranks else gear_z - crank_centre(d)
        crank_path = tuple((nm, skewed(f, d, L, tilt, rows, crank_arm=arm, width=d.crank_gear.face_width,
                                       wheels=False, sun=b.spatial_input) if nm == "gears" else f)
                           for nm, f in crank_path)
    if tilt is not None and b.spatial_wheels:
        # every family on a wheel across its width with the wheels' tilts (Eq. skew); the pins on the ground
        pin_set = skewed(pin_set, d, L, tilt, rows)
        crank_path = tuple((nm, f if nm == "gears" or f.n_bodies != L.n_bodies else skewed(f, d, L, tilt, rows))
                           for nm, f in crank_path)
    # the ported housing and the retained out-of-plane coordinates both behind the merged element: stacked
    stack = None
    if housing is not None and tilt is not None and contact_element_mode(contact_element) == "merged":
        from exudyn_user_elements.stacked_structure import StackedStructure
        stack = StackedStructure((housing, tilt))
    element = ContactElements(mbs, nodes, contact_element, structure=(stack or (housing if tilt is None else tilt))
                              if floating is None else floating.coordinates)

    def on_stack(p):
        return p if stack is None or p is None else stack.ports(p)

    def on_tilts(f, name=None):
        if floating is not None and name in floating.families:
            return floating.ports(name)       # flexible wheels / cranks (refused with a ported housing or tilts)
        return on_stack(tilt) if tilt is not None and f.n_bodies > L.n_bodies else None
    if wheels is None:
        elements = {"pins": element(pin_set, ports=on_stack(ports) if housing is not None else
                                         on_tilts(pin_set, "pins"))}
    else:
        # the elastic wheels: pins and needles (and the gears on bending cranks) in one nested closure
        elements = {"wheel_bodies": element(wheels.evaluator, ports=on_stack(ports) if housing is not None else None)}
        crank_path = () if wheels.gears_inside else (("gears", InvoluteContactSet(gear_meshes(d, graph, L),
                                                                                   L.n_bodies, name="gears", **opts)),)
    elements.update((name, element(s, ports=on_tilts(s, name))) for name, s in (*crank_path, ("crank_bearings", cranks)))
    elements["main_bearings"] = element(main, ports=on_tilts(main))
    if b.spatial_carrier and d.carrier.ported:
        from ..carrier import CarrierTiltSeats, tilt_seat_compliance
        elements["carrier_seats"] = element(CarrierTiltSeats(
            tilt_seat_compliance(d, graph), n_bodies=L.n_bodies + tilt.n_virtual, carrier=L.carrier,
            face=L.n_bodies + rows[L.carrier], seat=L.n_bodies + tilt.row("carrier_seats")), ports=on_stack(tilt))
    if d.bearing_friction.model != "none":
        # Palmgren's moment on each tapered crank pair (crank -> carrier) and on the main bearing pair
        # (carrier -> ground), P1 from the accepted element loads of each mounting; a loss element of its
        # own per bearing set (switched off: absent, no cost). The needles (inside the elastic-crank
        # element when the cranks bend) carry none here.
        from ...bearings.friction_element import rolling_friction_evaluator
        for name, bset in (("crank_bearing_friction", cranks), ("main_bearing_friction", main)):
            elements[name] = element(rolling_friction_evaluator(bset, d.bearing_friction, name=name))
    mbs.Assemble()
    if wheels is not None:
        rows = leaf_rows(elements["wheel_bodies"].evaluator)
        families = {fam: (name, np.arange(len(elements[name].ids))) if name in elements else
                    ("wheel_bodies", rows[name]) for fam, name in FAMILY_ELEMENTS.items()}
    elif C_crank is None:
        families = {fam: (name, np.arange(len(elements[name].ids))) for fam, name in FAMILY_ELEMENTS.items()}
    else:
        # the involute stage and the needles are one element, their rows contiguous ranges of it
        rows = planar_view(elements["cranks"].evaluator)[0].inner.rows
        families = {fam: (name, np.arange(len(elements[name].ids))) if name in elements else ("cranks", rows[name])
                    for fam, name in FAMILY_ELEMENTS.items()}
    return RvModel(design=d, SC=SC, mbs=mbs, body_names=L.names(), nodes=nodes, elements=elements, families=families,
                   input=BodyCoordinate(L.names()[0], "theta"), output=BodyCoordinate("carrier", "theta"),
                   ratio=graph.ratio, kinematics=kin, drive=drive, load=load, reference=ref,
                   locks=locks + ([] if floating is None else floating.coordinates.locks),
                   reg_springs=reg_springs, main_mesh=Family.PINS, material=d.material,
                   family_specs={Family.PINS: tuple(meshes), Family.ECCENTRIC_BEARINGS: d.eccentric_bearing,
                                 Family.MAIN_BEARINGS: d.main_bearing},
                   mesh_period=abs(2 * math.pi / d.pins.n_pins / graph.crank_rate),
                   structures=({} if housing is None else {"housing": housing}) if floating is None
                   else {"cranks" if flex is None else "wheels" if fcr is None else "flexible_bodies":
                         floating.coordinates},
                   graph=graph, layout=L, profiles=profiles, crank_compliance=C_crank, torsion_compliance=C_torsion,
                   housing=housing, contact_host=element.host, carrier_tilt=tilt if b.spatial_carrier else None,
                   body_tilts=tilt, flexible=flex, flexible_cranks=fcr,
                   series_paths={} if wheels is None else wheels.paths)
