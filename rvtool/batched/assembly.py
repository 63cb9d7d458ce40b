"""Builder: B manufacturing variants of one design -> ONE Exudyn system of B independent copies.

Layout per copy c (nb = n_wheels + 2 bodies): exactly the body layout, drive,
locks, regularization springs and output load of
:func:`rvtool.assembly.cycloid.build` (input shaft, wheels, flange as
``NodeRigidBody2D``), with the copy's own design from
:meth:`rvtool.variants.Variant.apply`. Each copy gets a
:class:`~rvtool.assembly.cycloid.CycloidModel` *view* on the shared system
(its own nodes, drive, load and springs), so that the per-copy controls and
the kinematic state are the builder's own methods, not re-implementations.

Contacts: one evaluator per family over all B nb bodies (one kernel launch per
family and evaluation for all copies): a :class:`CycloidPinSet` with the 2 B
wheel meshes, the output-pin kernel over the concatenated plain rows of all
copies, and one :class:`CircleContactSet` with the lumped bearings of all
copies. The contact definitions of one copy follow ``build`` line by line
(:func:`copy_contacts`); the per-variant equality test guards against drift.

Exudyn coupling (:mod:`exudyn_user_elements.batched_element`): one
``ObjectGenericODE2`` per copy (all three families of that copy in one 3 nb x 3 nb
element) whose callbacks share one batch evaluation per Newton state. Why this
choice: a single element over all copies would hand Exudyn a dense (3 nb B)^2
user Jacobian (1.1e8 entries at B = 1000), while per-copy elements give Exudyn's
sparse assembly (EigenSparse) B dense 12 x 12 blocks, i.e. the block-sparse
tangent, with no coupling entries at all.

Limits (raise :class:`RvtoolInputError`): lumped bearings and a rigid housing
only (rolling-bearing sets and housing ports are not batched), no anchor
friction (quasi-static protocols commit no history).
"""
from dataclasses import dataclass

import numpy as np
import exudyn as exu
from exudyn.itemInterface import (CoordinateConstraint, CoordinateSpringDamper, LoadCoordinate,
                                  MarkerNodeCoordinate, NodePointGround, NodeRigidBody2D, ObjectRigidBody2D)

from ..assembly.cycloid import SHAFT, CycloidModel, _mass_wheel, lumped_ball_law, lumped_needle_law
from ..assembly.spec import CycloidDesign
from ..contact.circle_set import GROUND, CircleContact, CircleContactSet, FrictionLaw, FrictionModel, NormalLaw
from ..contact.cycloid_set import CycloidPinSet, WheelPinMesh, secant_line_stiffness
from ..contact.evaluator import ContactSetEvaluator
from ..errors import RvtoolInputError
from ..geometry.cycloid import CycloidProfile
from ..output_pins.calibration import hertz_calibrated_coefficient
from ..output_pins.spec import OutputPinMechanism, PinMode
from ..validation import check_choice
from .evaluator import BatchContactEvaluator


def copy_contacts(design, build_kw, offset, n_total):
    """Contact definitions of one copy whose bodies start at global index ``offset``
    (the copy's bodies: shaft ``offset``, wheels ``offset + 1..n``, flange ``offset + n + 1``),
    as in :func:`rvtool.assembly.cycloid.build` with ``bearing_model="lumped"``.

    Returns (wheel meshes, bearing circle contacts, output-pin (fparams, iparams)).
    n_total: bodies of the whole batch (the kernels' ground row index).
    """
    d = design
    nw = d.n_wheels
    zg = d.pins.n_pins - 1
    pc = d.pin_contact
    width = d.wheels.width
    if pc.law == "power":
        law = NormalLaw(law="power", exponent=pc.exponent, stiffness=pc.stiffness or 1e9, damping=pc.damping)
    else:
        k_line = pc.stiffness if (pc.law == "line" and pc.stiffness > 0) else secant_line_stiffness(pc.reference_force, width)
        law = NormalLaw(law="line", stiffness=k_line, damping=pc.damping, ramp_depth=1e-6)
    friction = FrictionLaw(model=FrictionModel.REGULARIZED if pc.mu > 0 else FrictionModel.NONE, mu_kinetic=pc.mu)
    meshes = []
    for k in range(nw):
        phi = np.deg2rad(d.wheels.phases_deg[k])
        prof = CycloidProfile(pin_circle_radius=d.pins.pin_circle_radius, pin_radius=d.pins.pin_radius,
                              n_pins=d.pins.n_pins, generating_eccentricity=d.wheels.e_g,
                              equidistant_mod=d.wheels.equidistant_mod, offset_mod=d.wheels.offset_mod,
                              rotation_mod=d.wheels.rotation_mod - phi / zg)
        kw = dict(profile=prof, wheel_body=offset + 1 + k, pin_body=GROUND, face_width=width,
                  n_slices=d.wheels.n_slices, wheel_z=d.wheels.midplanes[k], clearance=d.wheels.clearance,
                  normal=law, friction=friction, name=f"copy{offset}/wheel{k}")
        kw.update(build_kw.get("pin_overrides") or {})
        meshes.append(WheelPinMesh(**kw))

    op = d.output_pins
    k_op = hertz_calibrated_coefficient(op.reference_force, op.pin_radius, op.hole_radius, width,
                                        d.material.youngs_modulus, d.material.poisson_ratio)
    mech = OutputPinMechanism(pin_circle_radius=op.pin_circle_radius, hole_circle_radius=op.pin_circle_radius,
                              n_pins=op.n_pins, phase=np.pi / 2, pin_radius=op.pin_radius, hole_radius=op.hole_radius,
                              coefficient=k_op, contact_length=width, n_slices=op.n_slices,
                              wheel_midplanes=tuple(d.wheels.midplanes), mode=PinMode.PLAIN)
    fp, ip = mech.packed(offset + nw + 1, tuple(range(offset + 1, offset + nw + 1)))

    eb = d.eccentric_bearing
    r_j = eb.journal_radius
    k_n, p_n = lumped_needle_law(d)
    contacts = []
    for k in range(nw):
        phi = np.deg2rad(d.wheels.phases_deg[k])
        contacts.append(CircleContact(
            body_a=offset + SHAFT, body_b=offset + 1 + k,
            centre_a=(-d.wheels.eccentricity * np.sin(phi), d.wheels.eccentricity * np.cos(phi)),
            centre_b=(0.0, 0.0), radius_a=r_j, radius_b=r_j + eb.radial_clearance + 1e-12, internal=True,
            normal=NormalLaw(law="power", stiffness=k_n, exponent=p_n, damping=50.0, ramp_depth=1e-6),
            name=f"copy{offset}/eccentric_bearing{k}"))
    main = d.main_bearing
    if main.kind != "locked":
        contacts.append(CircleContact(
            body_a=offset + nw + 1, body_b=GROUND, centre_a=(0.0, 0.0), centre_b=(0.0, 0.0),
            radius_a=0.5 * main.pitch_diameter, radius_b=0.5 * main.pitch_diameter + main.radial_clearance + 1e-12,
            internal=True, normal=NormalLaw(law="power", stiffness=lumped_ball_law(main)[0], exponent=1.5,
                                            damping=200.0, ramp_depth=1e-6),
            name=f"copy{offset}/main_bearing"))
    inp = d.input_bearing
    if inp.kind != "locked":
        contacts.append(CircleContact(
            body_a=offset + SHAFT, body_b=GROUND, centre_a=(0.0, 0.0), centre_b=(0.0, 0.0),
            radius_a=0.5 * inp.pitch_diameter, radius_b=0.5 * inp.pitch_diameter + inp.radial_clearance + 1e-12,
            internal=True, normal=NormalLaw(law="power", stiffness=2 * lumped_ball_law(inp)[0], exponent=1.5,
                                            damping=50.0, ramp_depth=1e-6),
            name=f"copy{offset}/input_bearing"))
    return meshes, contacts, (fp, ip, mech.stations)


def _add_copy_bodies(mbs, d, mg):
    """Nodes, locks, drive, regularization springs and load of one copy (as in ``build``)."""
    nw = d.n_wheels
    m_w, J_w = _mass_wheel(d)
    ref = np.zeros((nw + 2, 3))
    for k in range(nw):
        phi = np.deg2rad(d.wheels.phases_deg[k])
        ref[1 + k, :2] = (-d.wheels.eccentricity * np.sin(phi), d.wheels.eccentricity * np.cos(phi))
    masses = [(d.bodies.shaft_mass, d.bodies.shaft_inertia)] + [(m_w, J_w)] * nw + \
             [(d.bodies.flange_mass, d.bodies.flange_inertia)]
    nodes = []
    for b in range(nw + 2):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(ref[b])))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=masses[b][0], inertia=masses[b][1]))
        nodes.append(n)

    def marker(body, c):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[body], coordinate=c))

    locks = []
    retained = {SHAFT: d.bodies.shaft, nw + 1: d.bodies.flange}
    retained.update({1 + k: d.bodies.wheel for k in range(nw)})
    for body, coords in retained.items():
        for c, name in enumerate(("x", "y", "theta")):
            if body == SHAFT and c == 2:
                continue  # the drive prescribes the input angle
            if name not in coords:
                locks.append(mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(body, c)])))
    drive = mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(SHAFT, 2)], offset=0.0))
    return nodes, ref, locks, drive, marker


class _NumpyPlainPins:
    """The NumPy reference of the plain output-pin kernel behind the kernel's ``evaluate(pose)``."""

    def __init__(self, fparams, iparams, stations):
        self.fparams, self.iparams, self.stations = fparams, iparams, stations

    def evaluate(self, pose):
        from warp_contacts.output_pins_ref import evaluate_plain
        return evaluate_plain(pose, self.fparams, self.iparams, self.stations)


@dataclass
class BatchedCycloidModel:
    """B independent copies in one Exudyn system.

    copies[c]: :class:`CycloidModel` view of copy c (its nodes, drive, load, springs; its
    ``elements`` is empty: the contacts are batched). ltg: (B, 3 nb) global ODE2 indices
    of each copy's coordinates (copy-major). elements: the
    :class:`~exudyn_user_elements.batched_element.BatchedContactElements`.
    """
    design: CycloidDesign
    variants: list
    SC: object
    mbs: object
    copies: list
    evaluator: BatchContactEvaluator
    elements: object
    ltg: np.ndarray
    nb: int

    @property
    def n_copies(self):
        return len(self.copies)

    def set_input_angle(self, angle):
        """Prescribed input angle [rad] of every copy."""
        for m in self.copies:
            m.set_input_angle(angle)

    def set_output_torques(self, torques):
        """Output torque [N m] per copy (scalar: the same for all)."""
        t = np.broadcast_to(np.asarray(torques, float), (self.n_copies,))
        for m, ti in zip(self.copies, t):
            m.set_output_torque(float(ti))

    def kinematic_vectors(self, angle):
        """(B, 3 nb) kinematic displacement coordinates of every copy at input angle [rad]."""
        return np.array([(m.kinematic_state(angle) - m.reference).ravel() for m in self.copies])

    def to_global(self, qc, out=None):
        """Global ODE2 vector from per-copy coordinates (B, 3 nb)."""
        out = np.zeros(self.mbs.systemData.ODE2Size()) if out is None else out
        out[self.ltg] = qc
        return out


def build_batched(design: CycloidDesign, variants, *, bearing_model="lumped", backend="warp", precision="float64",
                  device="cpu", regularization=(100.0, 0.1)):
    """Assemble the variants of ``design`` into one Exudyn system; returns a :class:`BatchedCycloidModel`.

    variants: sequence of :class:`rvtool.variants.Variant` (B >= 1). device: "cpu" or
    "cuda:N" (Warp; the kernels keep their parameter arrays resident on the device and move
    only poses/velocities in and per-row forces/tangents out per evaluation).
    regularization: as in :func:`rvtool.assembly.cycloid.build`.
    """
    from exudyn_user_elements.batched_element import BatchedContactElements
    from warp_contacts.output_pins import OutputPinKernel

    check_choice("bearing_model", bearing_model, ("lumped",))
    check_choice("backend", backend, ("warp", "numpy"))
    variants = list(variants)
    if len(variants) < 1:
        raise RvtoolInputError("variants must contain at least one Variant (valid range of B: [1, inf))")
    if design.housing.model != "rigid":
        raise RvtoolInputError(f"housing.model = {design.housing.model!r}; the batched path supports ['rigid']")
    applied = [v.apply(design) for v in variants]
    B = len(variants)
    nw = design.n_wheels
    nb = nw + 2
    n_total = B * nb
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    k_reg_t, k_reg_r = regularization
    copies, meshes, contacts, op_f, op_i = [], [], [], [], []
    stations = None
    for c, (d_c, kw_c) in enumerate(applied):
        if d_c.n_wheels != nw:
            raise RvtoolInputError(f"variant {c} has n_wheels = {d_c.n_wheels}; all copies need {nw}")
        nodes, ref, locks, drive, marker = _add_copy_bodies(mbs, d_c, mg)
        reg_springs = []
        for body in range(nb):
            for cc in range(3):
                if body == SHAFT and cc == 2:
                    continue
                k_reg = k_reg_t if cc < 2 else k_reg_r
                if k_reg > 0:
                    reg_springs.append((body, cc, k_reg, mbs.AddObject(CoordinateSpringDamper(
                        markerNumbers=[mg, marker(body, cc)], stiffness=k_reg))))
        load = mbs.AddLoad(LoadCoordinate(markerNumber=marker(nw + 1, 2), load=0.0))
        copies.append(CycloidModel(design=d_c, SC=SC, mbs=mbs, nodes=nodes, elements={}, pin_set=None, drive=drive,
                                   load=load, n_wheels=nw, locks=locks, reg_springs=reg_springs, reference=ref))
        m_c, ct_c, (fp, ip, st) = copy_contacts(d_c, kw_c, c * nb, n_total)
        meshes += m_c
        contacts += ct_c
        op_f.append(fp)
        op_i.append(ip)
        stations = st
    pin_set = CycloidPinSet(meshes, n_total, samples_per_tooth=design.wheels.samples_per_tooth, backend=backend,
                            precision=precision, device=device, name="pins", search=design.wheels.search)
    bset = CircleContactSet(name="bearings", n_bodies=n_total, contacts=tuple(contacts))
    bearings = ContactSetEvaluator(bset, backend=backend, precision=precision, device=device)
    op_f, op_i = np.vstack(op_f), np.vstack(op_i)
    if backend == "warp":
        op_kernel = OutputPinKernel(op_f, op_i, stations, n_total + 1, PinMode.PLAIN.value, precision, device)
    else:
        op_kernel = _NumpyPlainPins(op_f, op_i, stations)
    evaluator = BatchContactEvaluator(pin_set, op_kernel, op_i[:, :2], bearings, nb, B)
    elements = BatchedContactElements(mbs, [m.nodes for m in copies], evaluator)
    mbs.Assemble()
    ltg = np.array([np.concatenate([np.asarray(mbs.systemData.GetNodeLTGODE2(n), int) for n in m.nodes])
                    for m in copies])
    model = BatchedCycloidModel(design=design, variants=variants, SC=SC, mbs=mbs, copies=copies, evaluator=evaluator,
                                elements=elements, ltg=ltg, nb=nb)
    elements.attach(ltg)
    return model
