"""Builder: a :class:`~rvtool.assembly.spec.CycloidDesign` -> an Exudyn system.

Bodies (planar rigid, x, y, theta): 0 the input eccentric shaft, 1..n the
wheels, n+1 the output flange. The housing with the ring pins is the ground
(``housing.model = "rigid"``) or an elastic housing represented through ports
(``"ports"``, :mod:`rvtool.assembly.housing`): its structural coordinates eta
form one more node, and each ring pin k is a port body of the pin-mesh element
whose pose is the port displacement H_k eta (Eq. port_runtime_transform).
Assembly phase: the journal of wheel k sits at angle phi_k on the shaft
(opposed journals for two wheels) and the wheel's profile is turned by
-phi_k / z_g, the conjugate tooth phase, so every wheel starts in mesh.
Contact sets (each one Exudyn contact element, one kernel launch per
evaluation):

* ``pins``: cycloid--pin meshes of all wheels (slices, deviations),
* ``output_pins``: flange pins in wheel holes (plain rigid pins, 10/9 law
  calibrated from a Hertz reference load),
* bearings: ``eccentric_bearings`` (journal--wheel bore), ``main_bearing``
  (flange--housing), ``input_bearing`` (shaft--housing), either from rolling
  elements (``bearing_model="rolling"``, :mod:`rvtool.bearings`) or as one
  lumped internal circle contact per bearing (``"lumped"``, a radial power law
  from Palmgren's element approach and Stribeck's load sharing) for studies that
  isolate the gearing.

The input rotation is prescribed through a coordinate constraint (an angle
for quasi-static sequences, a speed for driven runs); the output load is a
torque on the flange rotation.
"""
import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import exudyn as exu
from exudyn.itemInterface import (CoordinateConstraint, LoadCoordinate, MarkerNodeCoordinate, NodePointGround,
                                  NodeRigidBody2D, ObjectRigidBody2D)

from exudyn_user_elements.contact_element import PortBodies

from ..bearings.reducer import ball_rows
from ..bearings.spec import AngularContactPair, BallBearing, CrossedRollerBearing, NeedleBearing
from ..contact.circle_set import GROUND, CircleContact, CircleContactSet, FrictionLaw, FrictionModel, NormalLaw
from ..contact.cycloid_set import (PALMGREN_EXPONENT, CycloidPinSet, WheelPinMesh, palmgren_line_coefficient,
                                     secant_line_stiffness)
from ..bearings.influence import LUMPED_IN_ANALYZE, check_lumped
from ..errors import RvtoolInputError
from ..geometry.cycloid import lobe_pitch_rotations
from ..geometry.eccentric import journal_centre, journal_velocity
from ..output_pins.calibration import mindlin_tangential_ratio  # noqa: F401 (public here too)
from ..model import BodyCoordinate, ClearanceVariant, Family, ReducerModel, SeriesBeam
from .contact_layout import CONTACT_ELEMENTS, ContactElements, contact_element_mode  # noqa: F401 (public here too)
from .spec import CycloidDesign, replace

SHAFT = 0


class CycloidKinematics:
    """Rigid, clearance-free kinematics of a cycloid drive (fixed pins, output through the
    wheels): body 0 the shaft at the input angle a, wheel k on the journal of phase phi_k
    (:mod:`rvtool.geometry.eccentric`), wheels and flange turned by -a / z_g."""

    def __init__(self, design):
        self.eccentricity = design.wheels.eccentricity
        self.phases = np.asarray(design.wheels.phases[:design.n_wheels], float)
        self.z_g = design.pins.n_pins - 1
        self.n_wheels = design.n_wheels

    @property
    def crank_rate(self):
        """omega_crank / omega_in: the eccentric orbit per input radian (1: the input shaft carries
        the journals), the period 2 pi / |crank_rate| [rad of input] with which the contacts repeat."""
        return 1.0

    def poses(self, input_angles):
        """(n, nb, 3) poses at input angles (n,) [rad]."""
        a = np.asarray(input_angles, float)
        nw = self.n_wheels
        q = np.zeros((len(a), nw + 2, 3))
        q[:, SHAFT, 2] = a
        q[:, 1:nw + 1, 0], q[:, 1:nw + 1, 1] = journal_centre(self.eccentricity, self.phases[None, :], a[:, None])
        q[:, 1:, 2] = -a[:, None] / self.z_g
        return q

    @staticmethod
    def stacked_poses(kinematics, input_angles):
        """(B, n, nb, 3) poses of B :class:`CycloidKinematics` at input angles (n,) [rad] in one evaluation
        (Monte Carlo variants: their eccentricities differ), each equal to its :meth:`poses` bit for bit
        (the same operations per element), or None where their phases, tooth or wheel counts differ."""
        k0 = kinematics[0]
        if any(not isinstance(k, CycloidKinematics) or k.n_wheels != k0.n_wheels or k.z_g != k0.z_g
               or not np.array_equal(k.phases, k0.phases) for k in kinematics):
            return None
        a = np.asarray(input_angles, float)
        nw = k0.n_wheels
        e = np.array([k.eccentricity for k in kinematics], float)[:, None, None]
        q = np.zeros((len(kinematics), len(a), nw + 2, 3))
        q[:, :, SHAFT, 2] = a
        q[:, :, 1:nw + 1, 0], q[:, :, 1:nw + 1, 1] = journal_centre(e, k0.phases[None, None, :], a[None, :, None])
        q[:, :, 1:, 2] = -a[None, :, None] / k0.z_g
        return q

    def velocities(self, input_angle, omega_in):
        """(nb, 3) velocities at input angle [rad] and input speed omega_in [rad/s]."""
        nw = self.n_wheels
        v = np.zeros((nw + 2, 3))
        v[SHAFT, 2] = omega_in
        for k in range(nw):
            vx, vy = journal_velocity(self.eccentricity, self.phases[k], input_angle, omega_in)
            v[1 + k] = (vx, vy, -omega_in / self.z_g)
        v[nw + 1, 2] = -omega_in / self.z_g
        return v


def kinematic_poses(design, input_angles):
    """(n, nb, 3) rigid, clearance-free poses of shaft, wheels and flange at input angles (n,) [rad]."""
    return CycloidKinematics(design).poses(input_angles)


@dataclass
class CycloidModel(ReducerModel):
    """An assembled cycloid reducer: the :class:`~rvtool.model.ReducerModel` plus the
    cycloid's own handles (pin set, wheel profiles, wheel count, housing)."""
    pin_set: CycloidPinSet = None
    profiles: list = field(default_factory=list)
    n_wheels: int = 1
    housing: object = None          # ReducedStructure of an elastic housing, or None (rigid)
    flexible: object = None         # FlexibleWheels (wheels.dynamics.model = 'flexible'), or None (rigid)

    @property
    def flange(self):
        return self.n_wheels + 1

    def pin_forces(self, q):
        """Per wheel, per pin normal force [N] (slices summed) at the static state q: (n_wheels, z_b)."""
        return self.pin_set.pin_forces(self.elements["pins"].evaluation_at(q).obs)

    def mesh_width_moments(self, q):
        return self.pin_set.width_moments(self.elements["pins"].evaluation_at(q).obs)

    def refined_design(self):
        """Twice the profile samples per tooth."""
        return replace(self.design, wheels={"samples_per_tooth": 2 * self.design.wheels.samples_per_tooth})

    def resolution_settings(self):
        w = self.design.wheels
        return {"samples_per_tooth": w.samples_per_tooth, "n_slices": w.n_slices, "search_window": self.pin_set.window}

    def series_compliance(self, family):
        """Elastic pins (``pins.support``, ``output_pins.support``): the beam of every pin with its
        station compliance over the wheel stations, closed exactly per pin
        (:mod:`rvtool.contact.pin_closure`; the observed approach excludes the deflection)."""
        fam = Family(family)
        if fam not in (Family.PINS, Family.OUTPUT_PINS):
            return None
        C = pin_station_compliance(self.design, fam)
        if C is None:
            return None
        return SeriesBeam.of_closure("ring_pin_bending" if fam == Family.PINS else "output_pin_bending", fam, C,
                                     self.elements["pins" if fam == Family.PINS else "output_pins"])

    def pin_station_rows(self, family):
        """(pin (rows,), station (rows,)) of every observation row of the ring pins
        (``wheel{k}/pin{p}/s{i}``) or the output pins (``output_pins/pin{p}/wheel{k}/slice{i}``):
        the station of a row is its wheel."""
        fam = Family(family)
        name, rows = self.families[fam]
        parts = [self.elements[name].ids[i].split("/") for i in rows]
        if fam == Family.PINS:
            return np.array([int(x[1][3:]) for x in parts]), np.array([int(x[0][5:]) for x in parts])
        if fam == Family.OUTPUT_PINS:
            return np.array([int(x[1][3:]) for x in parts]), np.array([int(x[2][5:]) for x in parts])
        raise RvtoolInputError(f"family = {fam.value!r} has no pins; valid: 'pins', 'output_pins'")

    def pin_station_loads(self, q, family):
        """Vector resultant (n_pins, n_wheels, 2) [N] of the contact forces on every ring pin or
        output pin at each wheel station, static state q (the force on a pin points along the
        profile normal of its cycloid contact and against the wheel-force direction of an
        output-pin contact)."""
        fam = Family(family)
        pin, station = self.pin_station_rows(fam)
        ob = self.observe(q, fam)
        sign = 1.0 if fam == Family.PINS else -1.0
        n_pins = self.design.pins.n_pins if fam == Family.PINS else self.design.output_pins.n_pins
        f = np.zeros((n_pins, self.n_wheels, 2))
        np.add.at(f, (pin, station), sign * ob.normal_force[:, None] * ob.normal)
        return f

    def pin_bending(self, q, family, support=None):
        """Largest bending and shear stress of the ring pins (``"pins"``) or output pins from their
        station loads (:meth:`pin_station_loads`) on the declared support (``pins.support`` /
        ``output_pins.support``), or on ``support`` (:class:`~rvtool.structure.pin_beam.PinSupport`)
        where the design's pins are rigid (an assumption the caller names). q: one static state,
        or a sequence of states (e.g. the points of a TE sequence over a mesh cycle: the pin
        loads move from pin to pin, and the largest stress need not occur at one angle).
        Returns a dict (``sigma_max_Pa``, ``tau_max_Pa`` (the largest over the states), ``pin``,
        ``z_m``, ``state`` (index of the state of sigma_max; 0 for one state), ``support``,
        ``support_source``) or None (rigid pins and no support given)."""
        from ..structure.pin_beam import PinBeam
        fam = Family(family)
        spec = self.design.pins if fam == Family.PINS else self.design.output_pins
        source = "declared"
        sup = spec.support
        if not sup.elastic:
            if support is None:
                return None
            sup, source = support, "assumed (the design's pins are rigid)"
        beam = PinBeam(sup, spec.pin_radius, self.design.material.youngs_modulus, self.design.material.poisson_ratio)
        stress_map = beam.station_stress_map(self.design.wheels.midplanes, self.design.wheels.width)
        states = [q] if np.ndim(q) == 1 else q
        best, tau = {"sigma_max_Pa": 0.0, "pin": None, "z_m": None, "state": None}, 0.0
        for k, qk in enumerate(states):
            loads = self.pin_station_loads(qk, fam)
            for p in np.flatnonzero(np.any(loads != 0.0, axis=(1, 2))):
                s, t, z = stress_map.stresses(loads[p])
                tau = max(tau, t)
                if s > best["sigma_max_Pa"]:
                    best = {"sigma_max_Pa": s, "pin": int(p), "z_m": z, "state": k}
        best.update(tau_max_Pa=tau, support={"model": sup.model.value, "ends": list(sup.ends), "shear": sup.shear},
                    support_source=source)
        return best

    def hertz_peaks(self, q):
        """Largest Hertz line-contact peak p0 [Pa] of the loaded ring-pin, output-pin and needle
        contacts (both races) of every wheel (:func:`rvtool.pressure.state.candidates`)."""
        from ..pressure.state import candidates
        out = {}
        for fam, races in (("pins", (None,)), ("output_pins", (None,)), ("needles", ("journal", "bore"))):
            p = [c.hertz_peak for w in range(self.n_wheels) for r in races
                 for c in (candidates(self, q, fam, w) if r is None else candidates(self, q, fam, w, race=r))]
            if p:
                out[fam] = max(p)
        return out

    def clearance_variants(self):
        """Output-pin hole clearance c_h = R_h - r_p - e (estimate 2 c_h / R_op: one pin at right
        angles to the eccentricity closes it by a rotation c_h / R_op of the flange relative to the
        wheel, each way), eccentric-bearing clearance c_b (estimate 2 c_b / (e z_c): a wheel shift
        c_b across the journal turns the wheel by c_b / (e z_c) through the pin mesh, each way),
        input-bearing clearance (estimate 2 c / (e z_c) for one wheel; 0 for opposed wheels, whose
        tangential shifts cancel), main-bearing clearance (estimate 0: the flange centre shift does
        not turn it), the uniform profile clearance c_w and the equidistant, offset and rotation
        modifications (``wheels.clearance``, ``equidistant_mod``, ``offset_mod``, ``rotation_mod``;
        each one's estimate is the wheels' free play it causes alone,
        :func:`rvtool.geometry.cycloid.modification_play`: about 2 c / (e z_c) for c_w and
        delta_eq, 0 for a rotation, which only shifts the phase). Clearances and modifications the
        design does not have are left out."""
        d = self.design
        e, zc, zb = d.wheels.eccentricity, d.pins.n_pins - 1, d.pins.n_pins
        op = d.output_pins
        out = []
        c_h = op.hole_radius - op.pin_radius - e
        if c_h > 0:
            out.append(ClearanceVariant(
                "output_pin_holes", c_h, 2 * c_h / op.pin_circle_radius,
                lambda x: replace(x, output_pins={"hole_radius": x.output_pins.pin_radius + x.wheels.eccentricity}),
                lambda x, o: replace(x, output_pins={"hole_radius": o.output_pins.hole_radius})))
        sections = (("eccentric_bearings", "eccentric_bearing", 2 / (e * zc)),
                    ("input_bearing", "input_bearing", 2 / (e * zc) if d.n_wheels == 1 else 0.0),
                    ("main_bearing", "main_bearing", 0.0))
        for name, sec, factor in sections:
            c = _radial_clearance(getattr(d, sec))
            if c is not None and c > 0:
                # a bearing section's radial_clearance key (a pair's: that of its rows)
                out.append(ClearanceVariant(name, c, factor * c,
                                            lambda x, s=sec: replace(x, **{s: {"radial_clearance": 0.0}}),
                                            lambda x, o, s=sec: replace(x, **{s: {"radial_clearance":
                                                                                  _radial_clearance(getattr(o, s))}})))
        # the uniform profile clearance and the profile modifications: the wheels' free play against
        # the pins from the normal gaps and lever arms at each pin (geometry.cycloid.modification_play)
        from ..geometry.cycloid import modification_play
        centres = journal_centre(e, np.asarray(d.wheels.phases[:d.n_wheels], float), 0.0)
        centres = np.column_stack(centres)
        for sec, key, name in (("wheels", "clearance", "profile_clearance"), ("profile", "equidistant_mod", "equidistant_mod"),
                               ("profile", "offset_mod", "offset_mod"), ("profile", "rotation_mod", "rotation_mod")):
            v = getattr(getattr(d, sec), key)
            if v != 0.0:
                est = modification_play(d.pins.pin_circle_radius, zb, e, centres, **{key: v})[0]
                # the design-file key (an angle in degrees: rotation_mod_deg) and its value in the file's unit
                fk, to_file = (key + "_deg", math.degrees) if key == "rotation_mod" else (key, float)
                out.append(ClearanceVariant(name, v, est, lambda x, s=sec, k=fk: replace(x, **{s: {k: 0.0}}),
                                            lambda x, o, s=sec, k=key, f=fk, c=to_file:
                                            replace(x, **{s: {f: c(getattr(getattr(o, s), k))}})))
        return out

    def marker_frequencies(self, speed_rpm):
        """Mesh and bearing marker frequencies [Hz] at input speed [rpm] (:func:`eccentric_drive_markers`,
        a mesh per pin); with flexible wheels also ``wheel_modes_hz``, the retained in-plane modes of
        the free wheel."""
        out = eccentric_drive_markers(self.design, speed_rpm, self.design.pins.n_pins)
        if self.flexible is not None:
            # the flexible wheels' retained in-plane free-free modes (body modes beside the mesh and bearings)
            out["wheel_modes_hz"] = sorted({float(f) for b in self.flexible.bodies for f in b.frequencies_hz})
        return out

    def draw_section(self, ax, q):
        """Wheel profiles at their state-q poses, the ring pins and the contact forces."""
        import matplotlib.pyplot as plt

        from ..geometry.cycloid import pin_centres
        for k, prof in enumerate(self.profiles):
            x = self.body_pose(q, 1 + k)
            pts = prof.points(np.linspace(0, 2 * np.pi, 4000))
            c, s = np.cos(x[2]), np.sin(x[2])
            ax.plot(x[0] + c * pts[:, 0] - s * pts[:, 1], x[1] + s * pts[:, 0] + c * pts[:, 1], lw=0.8,
                    label=f"wheel {k}")
        for p in pin_centres(self.profiles[0]):
            ax.add_patch(plt.Circle(p, self.design.pins.pin_radius, fill=False, color="k", lw=0.6))
        super().draw_section(ax, q)


def eccentric_drive_markers(design, speed_rpm, mesh_teeth):
    """Mesh and bearing marker frequencies [Hz] at input speed [rpm] of a single-stage drive whose
    wheels ride eccentric journals of the input shaft in a fixed ring and turn the output (the cycloid
    drive, the small-tooth-difference involute reducer): input, output (f_in / |ratio|), mesh
    (``mesh_teeth`` ring pins or teeth passed per input revolution), and the eccentric, main and input
    bearings' (:func:`rvtool.bearings.frequencies.bearing_frequencies`)."""
    from ..bearings.frequencies import bearing_frequencies
    f_in = speed_rpm / 60.0
    f_out = f_in / abs(design.ratio)
    eb, mb, ib = design.eccentric_bearing, design.main_bearing, design.input_bearing
    out = {
        "input_hz": f_in, "output_hz": f_out, "mesh_hz": mesh_teeth * f_in,
        # eccentric needle bearing: journal (input) against the wheel bore (wheel speed -f_out)
        "eccentric_bearing": bearing_frequencies(f_in + f_out, eb.n_rollers, eb.roller_diameter,
                                                 2 * eb.inner_radius + eb.roller_diameter),
    }
    if isinstance(mb, CrossedRollerBearing):
        out["main_bearing"] = bearing_frequencies(f_out, mb.n_rollers, mb.roller_diameter, mb.pitch_diameter,
                                                  mb.contact_angle)
        mb = None
    for name, spec, f_ring in (("main_bearing", mb, f_out), ("input_bearing", ib, f_in)):
        if spec is not None:
            row = ball_rows(spec)[0]
            out[name] = bearing_frequencies(f_ring, row.n_balls, row.ball_diameter, row.pitch_diameter,
                                            row.contact_angle)
    return out


def _mass_wheel(design):
    d = design
    r_o = d.pins.pin_circle_radius - d.pins.pin_radius
    r_i = d.eccentric_bearing.inner_radius + d.eccentric_bearing.roller_diameter
    m = np.pi * (r_o ** 2 - r_i ** 2) * d.wheels.width * d.material.density
    return m, 0.5 * m * (r_o ** 2 + r_i ** 2)


def body_masses(design, *, wheel_mass=None):
    """[(mass [kg], polar inertia [kg m^2])] of the bodies of :func:`add_bodies` in its order:
    shaft, the wheels, flange (wheel_mass: as there)."""
    d = design
    m_w, J_w = _mass_wheel(d) if wheel_mass is None else wheel_mass
    return [(d.bodies.shaft_mass, d.bodies.shaft_inertia)] + [(m_w, J_w)] * d.n_wheels + \
        [(d.bodies.flange_mass, d.bodies.flange_inertia)]


def _radial_clearance(spec):
    """Radial clearance [m] of a bearing spec (a pair: its first row's), None for a locked bearing."""
    if spec is None:
        return None
    return spec.radial_clearance if isinstance(spec, NeedleBearing) else ball_rows(spec)[0].radial_clearance


def lumped_needle_law(design):
    """Lumped radial law F_r = K delta_r^(10/9) of the eccentric needle bearing: Palmgren's roller
    approach delta = 3.84e-5 Q^0.9 / L^0.8 [mm, N] per race contact (two in series), and
    Stribeck's line-contact sharing F_r = Z Q_max / 4.08. Returns (K [N m^-10/9], 10/9)."""
    b = design.eccentric_bearing
    L = b.roller_length * 1e3
    k_mm = (1.0 / (2 * 3.84e-5 * L ** -0.8)) ** (1 / 0.9)      # Q = k_mm delta^(1/0.9), N and mm
    return b.n_rollers / 4.08 * k_mm * 1e3 ** (1 / 0.9), 1 / 0.9


def lumped_ball_law(spec):
    """Lumped radial law F_r = K delta_r^(3/2) of a ball bearing (row or pair): Palmgren's ball
    approach delta = 4.36e-4 Q^(2/3) / D^(1/3) [mm, N] for both race contacts together and
    Stribeck's F_r = Z Q_max cos(alpha) / 4.37 with delta_max = delta_r cos(alpha) per row; the
    rows of a pair carry the radial load side by side (their K add).
    Returns (K [N m^-3/2], 3/2)."""
    K = 0.0
    for row in ball_rows(spec):
        ca = np.cos(row.contact_angle)
        D = row.ball_diameter * 1e3
        k_mm = (1.0 / (4.36e-4 * D ** (-1 / 3))) ** 1.5             # Q = k_mm delta^1.5, N and mm
        K += row.n_balls * ca ** 2.5 / 4.37 * k_mm * 1e3 ** 1.5
    return K, 1.5


def add_bodies(mbs, design, mg, *, rigid_supports=False, regularization=(100.0, 0.1), wheel_mass=None):
    """Bodies of one reducer in ``mbs``: shaft, wheels and flange (``NodeRigidBody2D`` at their
    reference poses), the coordinate locks of undeclared coordinates, the input drive, the
    regularization springs and the output load (see :func:`build` for the options). ``mg`` is a
    ground coordinate marker. wheel_mass: (mass [kg], polar inertia [kg m^2]) of each wheel
    (default: the cycloid wheel's annulus; other eccentric-wheel topologies pass their own).
    Returns a dict with nodes, reference (nb, 3), locks, journal_locks, drive, reg_springs and load."""
    d = design
    nw = d.n_wheels
    ref = np.zeros((nw + 2, 3))
    for k in range(nw):
        ref[1 + k, :2] = journal_centre(d.wheels.eccentricity, d.wheels.phases[k])
    masses = body_masses(d, wheel_mass=wheel_mass)
    nodes = []
    for b in range(nw + 2):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(ref[b])))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=masses[b][0], inertia=masses[b][1]))
        nodes.append(n)

    def marker(body, c):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[body], coordinate=c))

    locks, journal_locks = [], []
    retained = {SHAFT: d.bodies.shaft, nw + 1: d.bodies.flange}
    retained.update({1 + k: d.bodies.wheel for k in range(nw)})
    for body, coords in retained.items():
        for c, name in enumerate(("x", "y", "theta")):
            if (body == SHAFT and c == 2):
                continue  # the drive prescribes the input angle
            if rigid_supports and 1 <= body <= nw and c < 2:
                journal_locks.append((body, c, mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(body, c)]))))
            elif name not in coords or (rigid_supports and body in (SHAFT, nw + 1) and c < 2):
                locks.append(mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(body, c)])))
    drive = mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(SHAFT, 2)], offset=0.0))
    k_reg_t, k_reg_r = regularization
    reg_springs = []
    if k_reg_t > 0 or k_reg_r > 0:
        from exudyn.itemInterface import CoordinateSpringDamper
        for body in range(nw + 2):
            for c in range(3):
                if body == SHAFT and c == 2:
                    continue
                k_reg = k_reg_t if c < 2 else k_reg_r
                if k_reg > 0:
                    reg_springs.append((body, c, k_reg, mbs.AddObject(CoordinateSpringDamper(
                        markerNumbers=[mg, marker(body, c)], stiffness=k_reg))))
    load = mbs.AddLoad(LoadCoordinate(markerNumber=marker(nw + 1, 2), load=0.0))
    return {"nodes": nodes, "reference": ref, "locks": locks, "journal_locks": journal_locks, "drive": drive,
            "reg_springs": reg_springs, "load": load}


def wheel_profile(design, k):
    """The profile of wheel k of a cycloid or RV design as its contact with the pins sees it: the design's
    profile turned to the wheel's assembly phase (the conjugate tooth phase of a journal at phi_k: every wheel
    starts in mesh) and, where ``wheels.lobe_pitch_deviations`` gives them, its lobes turned by their
    accumulated pitch deviations (:func:`rvtool.geometry.cycloid.lobe_pitch_rotations`)."""
    d = design
    zg = d.pins.n_pins - 1
    prof = dataclasses.replace(d.profile, rotation_mod=d.profile.rotation_mod - d.wheels.phases[k] / zg)
    if d.wheels.lobe_pitch_deviations:
        prof = dataclasses.replace(prof, lobe_rotations=lobe_pitch_rotations(prof, d.wheels.lobe_pitch_deviations[k]))
    return prof


def pin_meshes(design, *, offset=0, prefix=""):
    """(profiles, :class:`WheelPinMesh` per wheel) of one reducer whose bodies start at index
    ``offset`` (wheel k is body offset + 1 + k): the design's profile turned to wheel k's
    assembly phase (:func:`wheel_profile`, lobe deviations included), pins on ground with the design's pin
    deviations; names ``prefix + "wheel{k}"``."""
    d = design
    pc = d.pin_contact
    width = d.wheels.width
    if pc.law == "power":
        law = NormalLaw(law="power", exponent=pc.exponent, stiffness=pc.stiffness or 1e9, damping=pc.damping)
    elif pc.law == "palmgren":
        law = NormalLaw(law="power", exponent=PALMGREN_EXPONENT, stiffness=palmgren_line_coefficient(width),
                        damping=pc.damping)
    else:
        k_line = pc.stiffness if (pc.law == "line" and pc.stiffness > 0) else secant_line_stiffness(pc.reference_force, width)
        law = NormalLaw(law="line", stiffness=k_line, damping=pc.damping, ramp_depth=1e-6)
    friction = pin_friction_law(design, law.stiffness)
    profiles, meshes = [], []
    for k in range(d.n_wheels):
        prof = wheel_profile(d, k)
        profiles.append(prof)
        kw = dict(profile=prof, wheel_body=offset + 1 + k, pin_body=GROUND, face_width=width, n_slices=d.wheels.n_slices,
                  wheel_z=d.wheels.midplanes[k], clearance=d.wheels.clearance, normal=law, friction=friction,
                  name=f"{prefix}wheel{k}")
        if d.pins.centre_errors is not None:
            kw["pin_centre_errors"] = np.asarray(d.pins.centre_errors, float)
        if d.pins.radius_error != 0.0:
            kw["pin_radius"] = d.pins.pin_radius + d.pins.radius_error
        meshes.append(WheelPinMesh(**kw))
    return profiles, meshes


def pin_station_compliance(design, family):
    """Beam station compliance C (n_wheels, n_wheels) [m/N] of one ring pin (``Family.PINS``) or
    output pin (``Family.OUTPUT_PINS``) at the wheel stations (midplanes, contact width = wheel
    width; :meth:`rvtool.structure.pin_beam.PinBeam.station_compliance`), or None for a rigid pin."""
    from ..structure.pin_beam import pin_beam
    d = design
    spec, section = (d.pins, "pins") if Family(family) == Family.PINS else (d.output_pins, "output_pins")
    beam = pin_beam(spec.support, spec.pin_radius, d.material)
    if beam is None:
        return None
    try:
        return beam.station_compliance(d.wheels.midplanes, d.wheels.width)
    except RvtoolInputError as exc:
        raise RvtoolInputError(f"{section}.{exc}") from None


def pin_friction_law(design, normal_stiffness):
    """FrictionLaw of the cycloid--pin contact from ``[pin_contact]``: none for mu = 0, the
    regularized law of Eq. (friction) or the anchor model (k_t from the design, else Mindlin's
    ratio of ``normal_stiffness`` [N/m], the whole contact's line stiffness)."""
    pc = design.pin_contact
    if pc.mu == 0.0:
        return FrictionLaw()
    if pc.friction_model == "regularized":
        return FrictionLaw(model=FrictionModel.REGULARIZED, mu_kinetic=pc.mu)
    if pc.tangential_stiffness == 0.0 and (pc.law == "palmgren" or (pc.law == "power" and pc.exponent != 1.0)):
        raise RvtoolInputError("pin_contact.tangential_stiffness must be given (> 0 N/m) for the anchor model with "
                               "a power law of exponent != 1 or the palmgren law (no secant stiffness in N/m to derive it from)")
    kt = pc.tangential_stiffness or mindlin_tangential_ratio(design.material.poisson_ratio) * normal_stiffness
    return FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=pc.mu, tangential_stiffness=kt)


def elastic_pin_stations(design, n_pins):
    """(n_pins, n_wheels) station-body index of pin p at wheel k's station: p n_wheels + k."""
    return np.arange(n_pins * design.n_wheels).reshape(n_pins, design.n_wheels)


def lumped_bearing_contacts(design, *, offset=0, prefix=""):
    """Lumped bearings of one reducer whose bodies start at ``offset``: one internal circle contact
    per eccentric bearing (needle law), the main bearing (flange--ground) and the two input
    bearings (shaft--ground) unless locked; names ``prefix + family``."""
    d = design
    nw = d.n_wheels
    eb = d.eccentric_bearing
    r_j = eb.inner_radius
    k_n, p_n = lumped_needle_law(d)
    contacts = []
    for k in range(nw):
        contacts.append(CircleContact(
            body_a=offset + SHAFT, body_b=offset + 1 + k,
            centre_a=journal_centre(d.wheels.eccentricity, d.wheels.phases[k]),
            centre_b=(0.0, 0.0), radius_a=r_j, radius_b=r_j + eb.radial_clearance + 1e-12, internal=True,
            normal=NormalLaw(law="power", stiffness=k_n, exponent=p_n, damping=50.0, ramp_depth=1e-6),
            name=f"{prefix}eccentric_bearing{k}"))
    main = d.main_bearing
    if main is not None:
        row = ball_rows(main)[0]       # the lumped circle of a pair: its first row's pitch circle and clearance
        contacts.append(CircleContact(
            body_a=offset + nw + 1, body_b=GROUND, centre_a=(0.0, 0.0), centre_b=(0.0, 0.0),
            radius_a=0.5 * row.pitch_diameter, radius_b=0.5 * row.pitch_diameter + row.radial_clearance + 1e-12,
            internal=True, normal=NormalLaw(law="power", stiffness=lumped_ball_law(main)[0], exponent=1.5,
                                            damping=200.0, ramp_depth=1e-6),
            name=f"{prefix}main_bearing"))
    inp = d.input_bearing
    if inp is not None:
        row = ball_rows(inp)[0]
        contacts.append(CircleContact(
            body_a=offset + SHAFT, body_b=GROUND, centre_a=(0.0, 0.0), centre_b=(0.0, 0.0),
            radius_a=0.5 * row.pitch_diameter, radius_b=0.5 * row.pitch_diameter + row.radial_clearance + 1e-12,
            # two input bearings share the radial load
            internal=True, normal=NormalLaw(law="power", stiffness=2 * lumped_ball_law(inp)[0], exponent=1.5,
                                            damping=50.0, ramp_depth=1e-6),
            name=f"{prefix}input_bearing"))
    return contacts


def build(design: CycloidDesign, *, bearing_model="lumped", backend="warp", precision="float64", device="cpu",
          rigid_supports=False, regularization=(100.0, 0.1), contact_element=None, guided_free_play=False):
    """Assemble ``design`` into an Exudyn system; returns a :class:`CycloidModel`.

    rigid_supports: shaft and flange centres held on the axis and the wheel
    centres held on their journals (translation constraints that follow the
    input angle): the rigid-body idealization of the classical load-sharing
    analysis. The bearings then carry no load.
    regularization: (k_translation [N/m], k_rotation [N m/rad]) of weak springs from
    every free coordinate to its reference (a numerical setting: free play in
    clearances leaves equilibrium directions without stiffness at zero load; at
    100 N/m and 10 um they carry 1e-3 N against contact loads of 1e2-1e3 N; the
    forces they carry are reported by the protocols). (0, 0) removes them.
    contact_element: ``"per_family"`` (one Exudyn element per contact family, each with its own
    callbacks) or ``"merged"`` (:class:`~exudyn_user_elements.merged_element.MergedContactElement`:
    every family in one element, rows summed on the device, per-attempt controls); None reads
    ``RVTOOL_CONTACT_ELEMENT`` (default ``"merged"``). Same families, ids and physics.
    guided_free_play: the model's :attr:`~rvtool.model.ReducerModel.guided_free_play` (default off: the
    paths of every shipped figure; ``rvtool analyze`` retries a protocol whose solver failed with it on).
    """
    mode = contact_element_mode(contact_element)
    if bearing_model not in ("lumped", "rolling"):
        raise RvtoolInputError(f"bearing_model = {bearing_model!r}; valid choices are ['lumped', 'rolling']")
    check_lumped(design, bearing_model)
    if design.wheels.body != "rigid" and design.wheels.dynamics.model == "rigid":   # flexible: its own refusal
        raise RvtoolInputError(f"wheels.body = {design.wheels.body!r} is implemented for the RV topology only (the "
                               "output pins of a cycloid drive are not ported yet); valid: wheels.body = 'rigid'")
    if isinstance(design.main_bearing, CrossedRollerBearing) and bearing_model != "rolling":
        raise RvtoolInputError("main_bearing.kind = 'crossed_roller' with bearing_model = 'lumped': the lumped circle "
                               f"contact is a ball law; valid: build(..., bearing_model='rolling'){LUMPED_IN_ANALYZE}")
    d = design
    nw = d.n_wheels
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    bodies = add_bodies(mbs, d, mg, rigid_supports=rigid_supports, regularization=regularization)
    nodes = bodies["nodes"]

    # -- ring pins ---------------------------------------------------------------
    profiles, meshes = pin_meshes(d)
    housing, ports, n_pin_bodies = None, None, nw + 2
    if d.housing.model == "ports":
        from exudyn_user_elements.reduced_structure import ReducedStructure
        from .housing import housing_ports
        reduced, _, _ = housing_ports(d)
        housing = ReducedStructure(mbs, reduced, name="housing")
        zb = d.pins.n_pins
        ports = PortBodies(housing, np.array([reduced.port_rows[k][:2] for k in range(zb)]))
        n_pin_bodies = nw + 2 + zb
        meshes = [dataclasses.replace(m, pin_bodies=tuple(range(nw + 2, nw + 2 + zb))) for m in meshes]
    if d.pins.groove != "rigid":
        raise RvtoolInputError(f"pins.groove = {d.pins.groove!r} is implemented for the RV topology only; valid for a "
                               "cycloid drive: 'rigid'")
    C_ring = pin_station_compliance(d, Family.PINS)
    if C_ring is not None:
        # elastic ring pins: wheel k meets pin p on the station body nw + 2 + p nw + k (Eq. series_contact)
        if ports is not None:
            raise RvtoolInputError("pins.support.model = "
                                   f"{d.pins.support.model.value!r} with housing.model = 'ports': elastic ring pins on "
                                   "an elastic housing are not implemented; valid: one of them rigid")
        st = elastic_pin_stations(d, d.pins.n_pins)
        meshes = [dataclasses.replace(m, pin_bodies=tuple(int(b) for b in nw + 2 + st[:, k]))
                  for k, m in enumerate(meshes)]
        n_pin_bodies = nw + 2 + st.size
    flex = None
    if d.wheels.dynamics.flexible:
        # floating flexible wheels (issue 33): pin p at wheel k on the virtual body nw + 2 + k z_b + p
        from .flexible_wheels import FlexibleWheels, check_flexible_wheels
        check_flexible_wheels(d, bearing_model, d.bodies.spatial_flange or d.bodies.spatial_wheels)
        flex = FlexibleWheels(mbs, d, mg)
        meshes = [dataclasses.replace(m, pin_bodies=flex.pin_bodies(k)) for k, m in enumerate(meshes)]
        n_pin_bodies = flex.n_pin_bodies
    pin_set = CycloidPinSet(meshes, n_pin_bodies, samples_per_tooth=d.wheels.samples_per_tooth, backend=backend,
                            precision=precision, device=device, name="pins", search=d.wheels.search)
    tilt, rows = spatial_flange(mbs, d, bearing_model, housing, regularization)
    structure = housing if tilt is None else tilt
    stack = None
    if housing is not None and tilt is not None and flex is None and contact_element_mode(mode) == "merged":
        # the ported housing and the flange's out-of-plane coordinates both behind the merged element
        from exudyn_user_elements.stacked_structure import StackedStructure
        structure = stack = StackedStructure((housing, tilt))

    def on_stack(p):
        return p if stack is None or p is None else stack.ports(p)
    element = ContactElements(mbs, nodes, mode, structure=structure if flex is None else flex.coordinates)
    host = element.host

    pin_eval = pin_set
    if C_ring is not None:
        from ..contact.pin_closure import ElasticPinClosure
        pin_eval = ElasticPinClosure(pin_set, n_bodies=nw + 2, carrier=GROUND, station_compliance=C_ring, station=st)
    if d.bodies.spatial_wheels:
        pin_eval = skewed(pin_eval, d, tilt, rows)
    if flex is not None:
        pin_ports = flex.ports("pins")
    else:
        pin_ports = on_stack(ports) if housing is not None or tilt is None else (
            tilt if pin_eval.n_bodies > nw + 2 else None)
    elements = {"pins": element(pin_eval, ports=pin_ports)}

    # -- output pins (plain rigid pins in the wheel holes) -------------------------
    from ..output_pins.evaluator import OutputPinEvaluator
    C_out = pin_station_compliance(d, Family.OUTPUT_PINS)
    if flex is not None:
        # the flange's station body of (pin p, wheel k): the flange shifted by minus hole p's displacement
        st = flex.output_pin_stations()
        op_eval = OutputPinEvaluator(d.output_pins, name="output_pins", flange=nw + 1,
                                     wheels=tuple(range(1, nw + 1)), n_bodies=nw + 2 + st.size, backend=backend,
                                     precision=precision, device=device, flange_bodies=nw + 2 + st.ravel())
    elif C_out is None:
        op_eval = OutputPinEvaluator(d.output_pins, name="output_pins", flange=nw + 1,
                                     wheels=tuple(range(1, nw + 1)), n_bodies=nw + 2, backend=backend,
                                     precision=precision, device=device)
    else:
        # elastic output pins: the (pin p, wheel k) contact acts on the station body nw + 2 + p nw + k,
        # the flange translated by the deflection (rvtool.contact.pin_closure)
        from ..contact.pin_closure import ElasticPinClosure
        st = elastic_pin_stations(d, d.output_pins.n_pins)
        inner = OutputPinEvaluator(d.output_pins, name="output_pins", flange=nw + 1,
                                   wheels=tuple(range(1, nw + 1)), n_bodies=nw + 2 + st.size, backend=backend,
                                   precision=precision, device=device, flange_bodies=nw + 2 + st.ravel())
        op_eval = ElasticPinClosure(inner, n_bodies=nw + 2, carrier=nw + 1, station_compliance=C_out, station=st)
    if d.bodies.spatial_wheels:
        op_eval = skewed(op_eval, d, tilt, rows)
    elements["output_pins"] = element(op_eval, ports=flex.ports("output_pins") if flex is not None else
                                      (on_stack(tilt) if op_eval.n_bodies > nw + 2 else None))

    # -- bearings -----------------------------------------------------------------
    if bearing_model == "rolling":
        from ..bearings.reducer import main_bearing_mounting, rolling_bearing_sets
        for name, ev in rolling_bearing_sets(d, nw, backend=backend, precision=precision, device=device,
                                             main=not d.bodies.spatial_flange).items():
            if d.bodies.spatial_wheels:
                # the eccentric bearings (on the wheels) sliced with the tilts, an element of their own; the
                # input (and planar main) bearings stay one planar set
                from ..bearings.set import BearingSet
                ecc = [mt for mt in ev.mountings if mt.outer in rows]
                rest = [mt for mt in ev.mountings if mt.outer not in rows]
                opts = dict(backend=backend, precision=precision, device=device)
                elements["eccentric_bearings"] = element(skewed(BearingSet(ecc, nw + 2, name="eccentric_bearings", **opts),
                                                                d, tilt, rows), ports=on_stack(tilt))
                if rest:
                    elements[name] = element(BearingSet(rest, nw + 2, name=name, **opts))
                continue
            elements[name] = element(ev)
        if d.bodies.spatial_flange:
            # the main bearing on the flange's retained axial and tilt coordinates (pose row nw + 2 + its row)
            from ..bearings.spatial_set import SpatialBearingSet
            elements["main_bearing"] = element(SpatialBearingSet([main_bearing_mounting(d, nw)], nw + 2 + tilt.n_virtual,
                                                                 {nw + 1: nw + 2 + rows[nw + 1]}, name="main_bearing",
                                                                 backend=backend, precision=precision, device=device),
                                               ports=on_stack(tilt))
    else:
        contacts = tuple(lumped_bearing_contacts(d))
        if flex is None:
            bset = CircleContactSet(name="bearings", n_bodies=nw + 2, contacts=contacts)
            elements["bearings"] = element(bset, backend=backend, precision=precision, device=device)
        else:
            # wheel k's bore: the virtual body nw + 2 + k (the wheel pose plus the bore's rigid-fit motion)
            contacts = tuple(dataclasses.replace(c, body_b=nw + 2 + k) if k < nw else c for k, c in enumerate(contacts))
            bset = CircleContactSet(name="bearings", n_bodies=2 * nw + 2, contacts=contacts)
            elements["bearings"] = element(bset, backend=backend, precision=precision, device=device,
                                           ports=flex.ports("bearings"))
    if d.bearing_friction.model != "none":
        # the friction torque of every bearing, a loss element of its own (switched off: absent); rolling
        # elements: P1 from the accepted element loads of each mounting
        if bearing_model == "rolling":
            from ..bearings.friction_element import rolling_friction_evaluator
            elements["bearing_friction"] = element(rolling_friction_evaluator(elements["bearings"].evaluator,
                                                                              d.bearing_friction))
        else:
            elements["bearing_friction"] = element(bearing_friction_evaluator(d, bset, elements["bearings"].evaluator))
    mbs.Assemble()
    return CycloidModel(design=d, SC=SC, mbs=mbs, body_names=body_names(nw), nodes=nodes, elements=elements,
                        guided_free_play=bool(guided_free_play),
                        families=contact_families(elements), input=BodyCoordinate("shaft", "theta"),
                        output=BodyCoordinate("flange", "theta"), ratio=d.ratio, kinematics=CycloidKinematics(d),
                        drive=bodies["drive"], load=bodies["load"], reference=bodies["reference"],
                        locks=bodies["locks"] + ([] if flex is None else flex.coordinates.locks),
                        reg_springs=bodies["reg_springs"], journal_locks=bodies["journal_locks"],
                        structures=({} if housing is None else {"housing": housing}) if flex is None
                        else {"wheels": flex.coordinates},
                        mesh_period=2 * np.pi / d.pins.n_pins, pin_set=pin_set, profiles=profiles, n_wheels=nw,
                        housing=housing, contact_host=host, family_specs=family_specs(d, meshes),
                        material=d.material, carrier_tilt=tilt if d.bodies.spatial_flange else None,
                        body_tilts=tilt, flexible=flex)


#: main bearings whose rows resolve a spatial flange (:mod:`rvtool.bearings.spatial_set`)
SPATIAL_MAIN_BEARINGS = (BallBearing, AngularContactPair, CrossedRollerBearing)


def spatial_flange(mbs, design, bearing_model, housing, regularization):
    """The retained axial and tilt coordinates of the spatial bodies (issue 32): the flange
    (``bodies.flange_coordinates = "spatial"``) and the wheels (``bodies.wheel_coordinates``), in that
    order, as one :class:`~exudyn_user_elements.out_of_plane.RetainedTilt` (masses, transverse
    inertias, the builder's regularization springs), after checking what they need. Returns
    (RetainedTilt or None, {body index: row})."""
    from exudyn_user_elements.out_of_plane import RetainedTilt
    d = design
    b, nw = d.bodies, d.n_wheels
    bodies = []
    if b.spatial_flange:
        bodies.append(("flange", nw + 1, b.flange_mass, b.tilt_inertia))
    if b.spatial_wheels:
        m_w, J_w = _mass_wheel(d)
        J_t = J_w / 2 if b.wheel_tilt_inertia is None else b.wheel_tilt_inertia
        bodies += [(f"wheel{k}", 1 + k, m_w, J_t) for k in range(nw)]
    if not bodies:
        return None, {}
    said = " / ".join(f"bodies.{k} = 'spatial'" for k, on in (("flange_coordinates", b.spatial_flange),
                                                             ("wheel_coordinates", b.spatial_wheels)) if on)
    if bearing_model != "rolling":
        raise RvtoolInputError(f"{said} with bearing_model = {bearing_model!r}: the lumped bearings have no rows; "
                               f"valid: build(..., bearing_model='rolling'){LUMPED_IN_ANALYZE}")
    if b.spatial_flange and not isinstance(d.main_bearing, SPATIAL_MAIN_BEARINGS):
        raise RvtoolInputError("bodies.flange_coordinates = 'spatial' needs a ball or crossed-roller main bearing; "
                               "valid: main_bearing.kind = 'angular_contact_pair', 'angular_contact', 'deep_groove' "
                               "or 'crossed_roller'")
    if housing is not None and b.spatial_wheels:
        raise RvtoolInputError(f"{said} with housing.model = 'ports' is not implemented (the ring pins on the "
                               "housing's port bodies are not sliced with the wheels' tilts); valid: "
                               "housing.model = 'rigid' or bodies.wheel_coordinates = 'planar'")
    if d.bearing_friction.model != "none":
        raise RvtoolInputError(f"{said} with bearing_friction.model = {d.bearing_friction.model!r} is not "
                               "implemented; valid: 'none'")
    names = tuple(n for n, *_ in bodies)
    tilt = RetainedTilt(mbs, [m for *_, m, _ in bodies], [J for *_, J in bodies], regularization,
                        name="flange_tilt" if names == ("flange",) else "body_tilt", names=names)
    return tilt, {i: r for r, (_, i, _, _) in enumerate(bodies)}


def skewed(family, design, tilt, rows):
    """``family`` (a planar evaluator over the bodies) across the wheel width with the tilts of the
    spatial wheels (:class:`~rvtool.contact.skew.SkewSlices`, Eq. (skew): ``bodies.tilt_slices``
    equal slices, each wheel's arm the slice's station about its mid-plane); unchanged without
    spatial wheels."""
    from ..contact.skew import SkewSlices, slice_stations
    tilted = {i: r for i, r in rows.items() if 1 <= i <= design.n_wheels}
    if not tilted:
        return family
    z, w = slice_stations(design.wheels.width, design.bodies.tilt_slices)
    arms = np.zeros((len(w), family.n_bodies))
    arms[:, list(tilted)] = z[:, None]
    return SkewSlices(family, tilt.n_virtual, tilted, arms, w, name=family.name)


def family_specs(design, meshes):
    """{Family: component spec} of the families present: the wheel--pin meshes (one per wheel), the
    output-pin mechanism and each bearing section's spec."""
    specs = {Family.PINS: tuple(meshes), Family.OUTPUT_PINS: design.output_pins,
             Family.ECCENTRIC_BEARINGS: design.eccentric_bearing}
    for fam, spec in ((Family.MAIN_BEARINGS, design.main_bearing), (Family.INPUT_BEARINGS, design.input_bearing)):
        if spec is not None:
            specs[fam] = spec
    return specs


def bearing_friction_evaluator(design, bearing_set, load_source):
    """Palmgren friction torque on every lumped bearing of ``bearing_set`` (identity = the bearing's
    contact name; needle law for the eccentric bearings, ball law for the main and input bearings,
    pitch diameters from the design)."""
    from ..bearings.friction_element import BearingFrictionEvaluator, BearingLoss
    from ..bearings.friction_torque import PalmgrenFrictionTorque
    d, bf = design, design.bearing_friction
    eb = d.eccentric_bearing
    losses = []
    for row, c in enumerate(bearing_set.contacts):
        if c.name.startswith("eccentric_bearing"):
            f0, f1, dm = bf.f0_needle, bf.f1_needle, 2 * eb.inner_radius + eb.roller_diameter
        elif c.name == "main_bearing":
            f0, f1, dm = bf.f0_ball, bf.f1_ball, ball_rows(d.main_bearing)[0].pitch_diameter
        else:
            f0, f1, dm = bf.f0_ball, bf.f1_ball, d.input_bearing.pitch_diameter
        model = PalmgrenFrictionTorque(f0=f0, f1=f1, pitch_diameter=dm, kinematic_viscosity=bf.kinematic_viscosity,
                                       regularization_speed=bf.regularization_speed)
        losses.append(BearingLoss(c.name, c.body_a, c.body_b, model, (row,)))
    return BearingFrictionEvaluator(losses, bearing_set.n_bodies, load_source, static_stiffness=bf.static_stiffness)


def body_names(n_wheels):
    """Body names in node order: the shaft, the wheels, the flange."""
    return ("shaft",) + tuple(f"wheel{k}" for k in range(n_wheels)) + ("flange",)


BEARING_FAMILIES = {"eccentric_bearing": Family.ECCENTRIC_BEARINGS, "main_bearing": Family.MAIN_BEARINGS,
                    "input_bearing": Family.INPUT_BEARINGS}


def contact_families(elements, mesh=("pins", Family.PINS)):
    """{Family: (element name, rows)}: the reducing mesh (``mesh`` = (element name, family); the pin
    mesh here) and the output pins are one element each; the bearings element's rows split by
    mounting name. Shared by the eccentric-wheel topologies."""
    name, family = mesh
    fams = {family: (name, np.arange(len(elements[name].ids))),
            Family.OUTPUT_PINS: ("output_pins", np.arange(len(elements["output_pins"].ids)))}
    ids = elements["bearings"].ids if "bearings" in elements else ()
    for prefix, fam in BEARING_FAMILIES.items():
        rows = np.array([i for i, cid in enumerate(ids) if cid.startswith(prefix)], dtype=int)
        if len(rows):
            fams[fam] = ("bearings", rows)
    if "eccentric_bearings" in elements:    # spatial wheels: the eccentric bearings sliced, an element of their own
        fams[Family.ECCENTRIC_BEARINGS] = ("eccentric_bearings", np.arange(len(elements["eccentric_bearings"].ids)))
    if "main_bearing" in elements:          # a spatial flange's main bearing, an element of its own
        fams[Family.MAIN_BEARINGS] = ("main_bearing", np.arange(len(elements["main_bearing"].ids)))
    return fams
