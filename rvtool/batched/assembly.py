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
copies. The bodies and contact definitions of one copy come from the builder's own
pieces (:func:`~rvtool.assembly.cycloid.add_bodies`, :func:`copy_contacts`).

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
from exudyn.itemInterface import MarkerNodeCoordinate, NodePointGround

from warp_contacts import output_pins_ref as ref

from ..assembly.copies import copy_contacts
from ..assembly.cycloid import CycloidKinematics, CycloidModel, add_bodies, body_names, kinematic_poses
from ..assembly.spec import CycloidDesign
from ..contact.circle_set import CircleContactSet
from ..contact.cycloid_set import CycloidPinSet
from ..contact.evaluator import ContactSetEvaluator
from ..errors import RvtoolInputError
from ..model import BodyCoordinate
from ..output_pins.spec import PinMode
from ..validation import check_choice
from ..solver.copy_evaluator import BatchContactEvaluator


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

    def __post_init__(self):
        # copies grouped by equal design (kinematic poses vectorized per group), and the
        # offset-carrying objects of every copy: (object, copy, body, coordinate)
        groups = {}
        for c, m in enumerate(self.copies):
            groups.setdefault(m.design, []).append(c)
        self._groups = [(d, np.array(cs)) for d, cs in groups.items()]
        self._reference = np.array([m.reference for m in self.copies])
        self._offset_objects = [(obj, c, b, k) for c, m in enumerate(self.copies)
                                for b, k, obj in m.journal_locks] + \
                               [(obj, c, b, k) for c, m in enumerate(self.copies) for b, k, _, obj in m.reg_springs]
        self._kin_key = None

    def _kinematic(self, angle):
        """(B, nb, 3) kinematic poses at input angle(s) [rad], cached for the last angles."""
        a = np.broadcast_to(np.asarray(angle, float), (self.n_copies,))
        if self._kin_key is None or not np.array_equal(self._kin_key, a):
            kin = np.zeros_like(self._reference)
            for d, cs in self._groups:
                kin[cs] = kinematic_poses(d, a[cs])
            self._kin_key, self._kin = a.copy(), kin
        return self._kin

    def set_input_angle(self, angle):
        """Prescribed input angle [rad]: a scalar for every copy or one per copy (B,) (what
        :meth:`CycloidModel.set_input_angle` does per copy, with the poses vectorized)."""
        a = np.broadcast_to(np.asarray(angle, float), (self.n_copies,))
        dev = self._kinematic(a) - self._reference
        mbs = self.mbs
        for m, ai in zip(self.copies, a):
            mbs.SetObjectParameter(m.drive, "offset", float(ai))
        for obj, c, b, k in self._offset_objects:
            mbs.SetObjectParameter(obj, "offset", float(dev[c, b, k]))

    def set_output_torques(self, torques):
        """Output torque [N m] per copy (scalar: the same for all)."""
        t = np.broadcast_to(np.asarray(torques, float), (self.n_copies,))
        for m, ti in zip(self.copies, t):
            m.set_output_torque(float(ti))

    def kinematic_vectors(self, angle):
        """(B, 3 nb) kinematic displacement coordinates of every copy at input angle [rad]
        (a scalar or one per copy)."""
        return (self._kinematic(angle) - self._reference).reshape(self.n_copies, -1)

    @property
    def input_local(self):
        """Index of the driven shaft rotation within a copy's 3 nb coordinates."""
        return 2

    @property
    def output_local(self):
        """Index of the loaded flange rotation within a copy's 3 nb coordinates."""
        return 3 * (self.nb - 1) + 2

    def copy_model(self, c, build_kw=None):
        """Copy c as its own model (the batch solver's per-copy fallback): the variant's design
        built with lumped bearings and ``build_kw``."""
        from ..assembly.cycloid import build
        return build(self.variants[c].apply(self.design), bearing_model="lumped", **(build_kw or {}))

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
    copies, meshes, contacts, op_f, op_i = [], [], [], [], []
    stations = None
    for c, d_c in enumerate(applied):
        if d_c.n_wheels != nw:
            raise RvtoolInputError(f"variant {c} has n_wheels = {d_c.n_wheels}; all copies need {nw}")
        b = add_bodies(mbs, d_c, mg, regularization=regularization)
        copies.append(CycloidModel(design=d_c, SC=SC, mbs=mbs, body_names=body_names(nw), nodes=b["nodes"], elements={},
                                   families={}, input=BodyCoordinate("shaft", "theta"),
                                   output=BodyCoordinate("flange", "theta"), ratio=d_c.ratio,
                                   kinematics=CycloidKinematics(d_c), drive=b["drive"], load=b["load"],
                                   reference=b["reference"], locks=b["locks"], reg_springs=b["reg_springs"],
                                   journal_locks=b["journal_locks"], mesh_period=2 * np.pi / d_c.pins.n_pins, n_wheels=nw))
        m_c, ct_c, (fp, ip, st) = copy_contacts(d_c, c * nb)
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
    evaluator = BatchContactEvaluator(pin_set, op_kernel, op_i[:, [ref.J_FLANGE, ref.J_WHEEL]], bearings, nb, B)
    elements = BatchedContactElements(mbs, [m.nodes for m in copies], evaluator)
    mbs.Assemble()
    ltg = np.array([np.concatenate([np.asarray(mbs.systemData.GetNodeLTGODE2(n), int) for n in m.nodes])
                    for m in copies])
    model = BatchedCycloidModel(design=design, variants=variants, SC=SC, mbs=mbs, copies=copies, evaluator=evaluator,
                                elements=elements, ltg=ltg, nb=nb)
    elements.attach(ltg)
    return model
