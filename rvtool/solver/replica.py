"""B copies of any reducer model in ONE Exudyn system, built through the model interface.

The angle-batched quasi-static sequence (:mod:`rvtool.batched.sequence`) marches B copies of
one reducer through B segments of input angles side by side. :func:`replicate` builds those
copies from an assembled :class:`~rvtool.model.ReducerModel` of any topology, reading only what
the model interface declares:

* bodies: ``body_names``, ``reference`` and the rigid-body data of ``nodes`` (planar rigid
  bodies), the held coordinates of ``locks``, the journal locks and regularization springs
  (``journal_locks``, ``reg_springs``), the drive on ``input`` and the load on ``output``;
* kinematics: ``kinematics.poses(angles)`` (all copies' angles in one call);
* contacts: every element of ``contact_elements()``; each family's set is copied B times by
  :data:`COPIERS` (one rule per contact-set type: the set's own constructor with the bodies of
  copy c offset by c nb, or its kernel rows with offset body columns), so one kernel launch per
  family evaluates every contact of every copy, and per-row body indices
  (``assembler.bodies``) scatter the rows into per-copy blocks
  (:class:`~rvtool.solver.copy_evaluator.CopyBlockAssembler`: the batch tangent is block diagonal).

Nothing here names a topology: a new topology whose contact sets are of the types of
:data:`COPIERS` runs the angle-batched path unchanged. Refused with a named error: elastic
structures (housing ports), contact sets with stick--slip anchors (quasi-static sequences commit
no history), shared-mode output pins, and set types without a copier (e.g. elastic-pin closures).
"""
import dataclasses
import time
from dataclasses import dataclass

import numpy as np
import exudyn as exu
from exudyn.itemInterface import (CoordinateConstraint, CoordinateSpringDamper, LoadCoordinate, MarkerNodeCoordinate,
                                  NodePointGround, NodeRigidBody2D, ObjectRigidBody2D)

from warp_contacts import output_pins_ref as oref
from warp_contacts.circle_pairs_ref import O_FN
from warp_contacts.tapered_rollers_ref import LAM_F

from ..bearings.set import BearingSet, InfluenceBearingSet
from ..bearings.tapered_set import TaperedBearingSet
from ..contact.circle_set import GROUND, CircleContactSet
from ..contact.cycloid_set import CycloidPinSet
from ..contact.evaluator import ContactSetEvaluator
from ..contact.involute_set import InvoluteContactSet
from ..contact.wheel_closure import WheelBodyClosure
from ..errors import RvtoolInputError
from ..model.reducer import COORDINATES
from ..output_pins.evaluator import OutputPinEvaluator
from ..output_pins.spec import PinMode
from .copy_evaluator import BatchEvaluation, CopyBlockAssembler, RowBlockAssembler


def _shift(body, offset):
    return body if body == GROUND else int(body) + offset


def _renamed(item, c, **bodies):
    # names stay unique over the copies ("/" separates id components, so not in a name)
    return dataclasses.replace(item, name=f"copy{c}_{item.name}", **bodies)


# -- one copier per contact-set type: (per-copy sets [B], bodies per copy nb, precision, device) -> set over B nb ----
# copy c takes its rows from sets[c] (one model's set B times, or the sets of B variant models of one topology);
# the set-wide options (samples, backend, search) are the first set's
def _copy_pins(sets, nb, precision, device):
    # the copies' rows and profile tables as built (sampling a variant's profile again costs ~40 ms per copy)
    return CycloidPinSet.concatenated(sets, nb, names=[[f"copy{c}_{m.name}" for m in sc.meshes]
                                                       for c, sc in enumerate(sets)], precision=precision,
                                      device=device)


def _copy_gears(sets, nb, precision, device):
    # the copies' rows, tooth-angle tables and tooth compliances as built
    return InvoluteContactSet.concatenated(sets, nb, names=[[f"copy{c}_{m.name}" for m in sc.meshes]
                                                            for c, sc in enumerate(sets)], precision=precision,
                                           device=device)


def _copy_bearings(sets, nb, precision, device):
    s, B = sets[0], len(sets)
    if type(s) in (BearingSet, TaperedBearingSet):      # the built rows side by side (no mounting packed again)
        return type(s).concatenated(sets, nb, names=[[f"copy{c}_{m.name}" for m in sc.mountings]
                                                        for c, sc in enumerate(sets)],
                                       precision=precision, device=device)
    mounts = [_renamed(m, c, inner=_shift(m.inner, c * nb), outer=_shift(m.outer, c * nb))
              for c, sc in enumerate(sets) for m in sc.mountings]
    return type(s)(mounts, B * nb, name=s.name, backend=s.backend, precision=precision, device=device)


def _copy_circles(sets, nb, precision, device):
    # the built contacts moved without validating them again (moved_member) and the built rows with their
    # body columns moved (what packing the moved contacts gives; ~0.1 ms a contact less, 4 per RD-40 copy)
    from ..contact.evaluator import moved_member
    from warp_contacts.circle_pairs_ref import I_BODY_A, I_BODY_B
    s, B = sets[0], len(sets)
    contacts = tuple(moved_member(ct, name=f"copy{c}_{ct.name}", body_a=_shift(ct.body_a, c * nb),
                                  body_b=_shift(ct.body_b, c * nb))
                     for c, sc in enumerate(sets) for ct in sc.set.contacts)
    ip = np.concatenate([sc.iparams for sc in sets])
    off = np.concatenate([np.full(len(sc.iparams), c * nb) for c, sc in enumerate(sets)])[:, None]
    cols = [I_BODY_A, I_BODY_B]
    ip[:, cols] = np.where(ip[:, cols] >= s.n_bodies, B * nb, ip[:, cols] + off)
    return ContactSetEvaluator(CircleContactSet(name=s.name, n_bodies=B * nb, contacts=contacts), backend=s.backend,
                               precision=precision, device=device,
                               packed=(np.concatenate([sc.fparams for sc in sets]), ip.astype(np.int32)))


class PlainPinCopies:
    """The plain output-pin rows of B copies behind one launch (kernel or NumPy reference):
    the evaluator's own rows with the flange and wheel columns offset per copy. The
    ``assembler.bodies`` are the (flange, wheel) of each (pin, wheel) row."""

    def __init__(self, sets, nb, precision, device):
        s, B = sets[0], len(sets)
        if any(sc.mode != PinMode.PLAIN for sc in sets):
            raise RvtoolInputError(f"output_pins.mode = {s.mode.value!r}: the angle-batched path copies plain "
                                   "output pins only (valid: 'plain')")
        if any(not np.array_equal(sc.stations, s.stations) for sc in sets):
            raise RvtoolInputError("the copies' output pins have different stations; copies must share them")
        cols = [oref.J_FLANGE, oref.J_WHEEL]
        ip = np.concatenate([sc.iparams for sc in sets])
        off = np.concatenate([np.full(len(sc.iparams), c * nb) for c, sc in enumerate(sets)])[:, None]
        ip[:, cols] = np.where(ip[:, cols] >= s.n_bodies, B * nb, ip[:, cols] + off)
        self.fparams, self.iparams, self.stations = np.concatenate([sc.fparams for sc in sets]), ip, s.stations
        self.name, self.n_bodies, self.backend = s.name, B * nb, s.backend
        self.assembler = dataclasses.make_dataclass("Rows", ["bodies"])(ip[:, cols].astype(np.int64))
        self._pose = np.zeros((B * nb + 1, 3))
        if s.backend == "warp":
            from warp_contacts.output_pins import OutputPinKernel
            self._kernel = OutputPinKernel(self.fparams, ip, self.stations, B * nb + 1, PinMode.PLAIN.value,
                                           precision, device)

    def raw(self, pose):
        self._pose[:-1] = pose
        if self.backend == "warp":
            return self._kernel.evaluate(self._pose)
        return oref.evaluate_plain(self._pose, self.fparams, self.iparams, self.stations)

    @property
    def rows_on_device(self):
        """Whether :meth:`device_rows` / :meth:`launch_device_rows` are available (backend "warp")."""
        return self.backend == "warp"

    def device_pose_buffers(self):
        """(pose, None): the kernel's pose input ((B nb + 1, 3), the ground's row last; no velocities)."""
        return self._kernel.device_array("pose"), None

    def launch_device_rows(self):
        """The rows Q (N, 6), dQ/dq (N, 6, 6) as device arrays at the poses in :meth:`device_pose_buffers`."""
        self._kernel.launch_recorded()
        return self._kernel.device_array("q"), self._kernel.device_array("dqdq")

    def device_rows(self, pose, vel=None):
        """:meth:`launch_device_rows` at host poses (B nb, 3) (uploaded)."""
        self._pose[:-1] = pose
        self._kernel.device_array("pose").assign(self._pose)
        return self.launch_device_rows()


#: contact-set type -> copier (see the module docstring)
COPIERS = {CycloidPinSet: _copy_pins, InvoluteContactSet: _copy_gears, BearingSet: _copy_bearings,
           InfluenceBearingSet: _copy_bearings, TaperedBearingSet: _copy_bearings, ContactSetEvaluator: _copy_circles, OutputPinEvaluator: PlainPinCopies}


def family_rows(s, pose, vel):
    """(Q rows, dQ/dq rows, dQ/dv rows or None, normal force per observation row [N]) of a copied set."""
    if isinstance(s, PlainPinCopies):
        r = s.raw(pose)
        return r["Q"], r["dQdq"], None, np.asarray(r["slices"])[..., oref.S_FORCE].reshape(-1)
    if isinstance(s, TaperedBearingSet):
        Q, K, D, (_, _, lam), _ = s.raw(pose, vel)
        return Q, K, D, np.asarray(lam)[:, LAM_F]
    r = s.raw(pose, vel)
    return r[0], r[1], r[2], np.asarray(r[3])[:, O_FN]


@dataclass
class FamilyCopies:
    """One contact element's set copied B times: its name, the copied set, the per-copy block
    scatter of its rows and the number of observation rows per copy (the element's ids)."""
    name: str
    set: object
    scatter: RowBlockAssembler
    obs_rows: int
    #: (B nb_f, 3) flat indices into the copies' row coordinates (B, n) of the set's body coordinates
    #: (-1: zero), for a set on extended bodies (:mod:`rvtool.solver.row_extension`); None: the set's
    #: bodies are the copies' bodies and it takes the poses (B nb, 3) as they are
    pose_map: np.ndarray | None = None

    def poses(self, pose, vel):
        """(pose, vel) of the set's bodies: as given, or gathered from absolute row coordinates
        ``pose`` (B, n) through :attr:`pose_map` (static: zero velocities)."""
        if self.pose_map is None:
            return pose, vel
        from .row_extension import gather_poses
        return gather_poses(pose, self.pose_map), np.zeros(self.pose_map.shape)


class ReplicaEvaluator:
    """Every family of B copies at global body poses/velocities (B nb, 3): one launch per family,
    the rows scattered into per-copy blocks (the interface of
    :class:`~rvtool.solver.copy_evaluator.BatchContactEvaluator` that the batch element and
    :class:`~rvtool.solver.batched.BatchedStaticSolver` use). ``timing`` as there."""

    def __init__(self, families, nb, n_copies):
        self.families, self.nb, self.n_copies = families, nb, n_copies
        self.timing = {"kernels": 0.0, "scatter": 0.0, "launches": 0}
        self.masked = np.zeros(n_copies, bool)
        self.n_evaluations = 0
        self.device_scatter = False

    def set_static(self, on):
        """Static mode: the pair families skip their velocity tangent (dQ/dv is then not available)."""
        for f in self.families:
            if callable(getattr(f.set, "set_velocity_tangent", None)):
                f.set.set_velocity_tangent(not on)

    def evaluate(self, pose, vel):
        t0 = time.perf_counter()
        rows = [family_rows(f.set, *f.poses(pose, vel)) for f in self.families]
        t1 = time.perf_counter()
        Q = sum(f.scatter.vector(np.asarray(r[0], np.float64)) for f, r in zip(self.families, rows))
        K = sum(f.scatter.blocks(np.asarray(r[1], np.float64)) for f, r in zip(self.families, rows))
        finite = np.isfinite(Q.sum(axis=1) + K.sum(axis=(1, 2)))
        masked = self.masked.copy()
        if any(r[2] is None and callable(getattr(f.set, "set_velocity_tangent", None))
               for f, r in zip(self.families, rows)):
            # static mode: the bearing families' dQ/dv rows are not read (no copy of them)
            def damping():
                raise RuntimeError("dQ/dv was not computed: the evaluator is in static mode")
        else:
            damp = [(f, None if r[2] is None else np.array(r[2], np.float64)) for f, r in zip(self.families, rows)]
            for f, d in damp:
                if d is not None:
                    bad = ~np.isfinite(d.reshape(len(d), -1).sum(axis=1))
                    finite[f.scatter.row_copy[bad]] = False

            def damping():
                D = sum(f.scatter.blocks(d) for f, d in damp if d is not None)
                D[masked] = 0.0
                return D
        if np.any(masked):
            Q[masked], K[masked], finite[masked] = 0.0, 0.0, True
        self.n_evaluations += 1
        self.timing["kernels"] += t1 - t0
        self.timing["scatter"] += time.perf_counter() - t1
        self.timing["launches"] += len(self.families)
        forces = {f.name: np.asarray(r[3], np.float64).reshape(self.n_copies, f.obs_rows)
                  for f, r in zip(self.families, rows)}
        return BatchEvaluation(Q, K, damping, finite, None, forces)


@dataclass
class CopyView:
    """The Exudyn items of one copy: nodes, held-coordinate locks, journal locks
    [(body, coordinate, object)], regularization springs [(body, coordinate, k, object)],
    drive and load."""
    nodes: list
    locks: list
    journal_locks: list
    reg_springs: list
    drive: int
    load: int


def _held(model):
    """[(body, coordinate)] held by the model's locks."""
    mbs, out = model.mbs, []
    for obj in model.locks:
        mk = mbs.GetObjectParameter(obj, "markerNumbers")[1]
        out.append(([int(n) for n in model.nodes].index(int(mbs.GetMarkerParameter(mk, "nodeNumber"))),
                    mbs.GetMarkerParameter(mk, "coordinate")))
    return out


def _rigid_body_data(model):
    """{node: (mass [kg], inertia [kg m^2])} of the model's planar rigid bodies."""
    mbs, out = model.mbs, {}
    for i in range(mbs.systemData.NumberOfObjects()):
        o = mbs.GetObject(i)
        if o["objectType"] == "RigidBody2D":
            out[int(o["nodeNumber"])] = (o["mass"], o["inertia"])
    return out


@dataclass
class ReplicatedModel:
    """B copies of ``source`` (a :class:`~rvtool.model.ReducerModel`) in one Exudyn system
    (the batch interface of :class:`~rvtool.batched.assembly.BatchedCycloidModel`).

    copies[c]: :class:`CopyView`; ltg (B, 3 nb): global ODE2 indices of each copy's coordinates;
    input_local / output_local: the driven and loaded coordinate within a copy's 3 nb;
    families: {Family value: (element name, observation rows)} of the source."""
    source: object
    SC: object
    mbs: object
    copies: list
    evaluator: ReplicaEvaluator
    elements: object
    ltg: np.ndarray
    nb: int
    build_kw: dict

    @property
    def n_copies(self):
        return len(self.copies)

    @property
    def design(self):
        return self.source.design

    @property
    def input_local(self):
        return 3 * self.source.body_index(self.source.input.body) + COORDINATES.index(self.source.input.coordinate)

    @property
    def output_local(self):
        return 3 * self.source.body_index(self.source.output.body) + COORDINATES.index(self.source.output.coordinate)

    def kinematic_vectors(self, angle):
        """(B, 3 nb) kinematic displacement of every copy at input angle(s) [rad] (scalar or (B,))."""
        a = np.broadcast_to(np.asarray(angle, float), (self.n_copies,))
        return (self.source.kinematics.poses(a) - self.source.reference).reshape(self.n_copies, -1)

    def set_input_angle(self, angle):
        """Prescribed input angle [rad] per copy (scalar or (B,)); journal locks and regularization
        springs follow each copy's kinematic positions (what ``ReducerModel.set_input_angle`` does)."""
        a = np.broadcast_to(np.asarray(angle, float), (self.n_copies,))
        dev = self.kinematic_vectors(a)
        mbs = self.mbs
        for c, (m, ai) in enumerate(zip(self.copies, a)):
            mbs.SetObjectParameter(m.drive, "offset", float(ai))
            for b, k, obj in m.journal_locks:
                mbs.SetObjectParameter(obj, "offset", float(dev[c, 3 * b + k]))
            for b, k, _, obj in m.reg_springs:
                mbs.SetObjectParameter(obj, "offset", float(dev[c, 3 * b + k]))

    def set_output_torques(self, torques):
        t = np.broadcast_to(np.asarray(torques, float), (self.n_copies,))
        for m, ti in zip(self.copies, t):
            self.mbs.SetLoadParameter(m.load, "load", float(ti))

    def to_global(self, qc, out=None):
        out = np.zeros(self.mbs.systemData.ODE2Size()) if out is None else out
        out[self.ltg] = qc
        return out

    def copy_model(self, c, build_kw=None):
        """A separate model of copy c (the per-copy fallback of the batch solver): the source's
        design rebuilt by its topology's builder with the build options of the source."""
        from ..assembly import build
        return build(self.source.design, **self.build_kw)

    def family_peaks(self, ev):
        """{family value: (B,) largest row normal force [N]} of a batch evaluation (the rows of
        ``ReducerModel.family_peaks``)."""
        out = {}
        for fam, (name, rows) in self.source.families.items():
            out[fam.value] = ev.normal_forces[name][:, rows].max(axis=1)
        return out


def replica_reasons(model):
    """Every named reason why :func:`replicate` cannot copy ``model`` (empty: it can)."""
    from .backends.base import flexible_body_reasons
    reasons = flexible_body_reasons(model)
    if model.structures:
        reasons.append(f"the model has elastic structures {sorted(model.structures)}: the angle-batched path "
                       "copies planar rigid bodies only (valid: housing.model = 'rigid')")
    carrier = getattr(getattr(model, "design", None), "carrier", None)
    if carrier is not None and carrier.body != "rigid":
        reasons.append(f"carrier.body = {carrier.body!r}: the carrier's crank seats are closed by its reduced seat "
                       "compliance (rvtool.assembly.carrier), which the angle-batched path does not copy (valid: "
                       "carrier.body = 'rigid')")
    nb = len(model.body_names)
    for el in model.contact_elements():
        s = el.evaluator
        if isinstance(s, WheelBodyClosure):
            reasons.append("wheels.body = 'ported': the elastic wheels' closure (WheelBodyClosure, the wheels' "
                           "station compliance) has no device copy (valid: wheels.body = 'rigid', or backend "
                           "'exudyn')")
            continue
        if type(s) not in COPIERS:
            reasons.append(f"contact element {el.evaluator.name!r} ({type(s).__name__}) has no copier for the "
                           f"angle-batched path; valid set types: {sorted(t.__name__ for t in COPIERS)}")
        if getattr(s, "anchor", False):
            reasons.append(f"contact element {s.name!r} has stick--slip anchors: the angle-batched path takes "
                           "history-free contacts (valid: frictionless or regularized friction)")
        if getattr(s, "n_bodies", nb) != nb:
            reasons.append(f"contact element {s.name!r} spans {s.n_bodies} bodies (port or pin bodies); the "
                           f"angle-batched path copies the {nb} rigid bodies only")
        if isinstance(s, OutputPinEvaluator) and s.mode != PinMode.PLAIN:
            reasons.append(f"output_pins.mode = {s.mode.value!r}: the angle-batched path copies plain "
                           "output pins only (valid: 'plain')")
    return reasons


def copy_families(model, copies, *, precision="float64", device="cpu"):
    """[:class:`FamilyCopies`] of every contact element of ``model`` copied ``copies`` times
    (:data:`COPIERS`; copy c owns bodies c nb .. c nb + nb - 1): what :func:`replicate` puts into
    its Exudyn system and what the device backend's row Newton
    (:mod:`rvtool.solver.device_rows`) evaluates without one. ``model`` may also be a list of
    ``copies`` models of one topology (e.g. Monte Carlo variants): copy c then takes its rows
    from ``model[c]`` (same elements, same bodies, same rows per copy; checked). The caller
    checks :func:`replica_reasons` of each model first."""
    models = list(model) if isinstance(model, (list, tuple)) else [model] * int(copies)
    B, nb = len(models), len(models[0].body_names)
    if B != int(copies):
        raise RvtoolInputError(f"copies = {copies} but {B} models were given (one model per copy)")
    per_model = [m.contact_elements() for m in models]
    first = per_model[0]
    for i, els in enumerate(per_model):
        if len(models[i].body_names) != nb or [e.evaluator.name for e in els] != [e.evaluator.name for e in first] \
                or [len(e.ids) for e in els] != [len(e.ids) for e in first]:
            raise RvtoolInputError(f"model {i} differs in bodies, contact elements or their rows from model 0; the "
                                   "copies must be models of one topology")
    families = [None] * len(first)
    # the cycloid pin sets last: their profile tables may still be computed on the device (launched without
    # waiting, rvtool.solver.device_rows.provide_profile_tables), the other families are copied meanwhile
    for j in sorted(range(len(first)), key=lambda j: isinstance(first[j].evaluator, CycloidPinSet)):
        s = first[j].evaluator
        cs = COPIERS[type(s)]([els[j].evaluator for els in per_model], nb, precision, device)
        families[j] = FamilyCopies(name=s.name, set=cs, scatter=CopyBlockAssembler(cs.assembler.bodies, nb, B),
                                   obs_rows=len(first[j].ids))
    return families


def held_coordinates(model):
    """[(body index, coordinate)] held at zero by the model's coordinate locks (a
    :class:`~rvtool.solver.model_snapshot.ModelSnapshot` carries them)."""
    from .model_snapshot import ModelSnapshot
    if isinstance(model, ModelSnapshot):
        return list(model.held_coordinates)
    return _held(model)


def replicate(model, copies, *, precision="float64", device="cpu", build_kw=None):
    """:class:`ReplicatedModel` of ``copies`` copies of ``model`` (see the module docstring).
    build_kw: the build options ``model`` was built with (the per-copy fallback rebuilds with them)."""
    from exudyn_user_elements.batched_element import BatchedContactElements

    if isinstance(copies, bool) or not isinstance(copies, (int, np.integer)) or copies < 1:
        raise RvtoolInputError(f"copies = {copies!r} is outside the valid range [1, inf) (integer)")
    reasons = replica_reasons(model)
    if reasons:
        raise RvtoolInputError("; ".join(reasons))
    B, nb = int(copies), len(model.body_names)
    families = copy_families(model, B, precision=precision, device=device)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    body_data = _rigid_body_data(model)
    held = _held(model)
    i_in = (model.body_index(model.input.body), COORDINATES.index(model.input.coordinate))
    i_out = (model.body_index(model.output.body), COORDINATES.index(model.output.coordinate))
    views = []
    for c in range(B):
        nodes = []
        for b, node in enumerate(model.nodes):
            n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(model.reference[b])))
            m, J = body_data[int(node)]
            mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=m, inertia=J))
            nodes.append(int(n))         # plain ints: the batch solver looks nodes up by number

        def marker(b, k):
            return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[b], coordinate=k))
        locks = [mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(b, k)])) for b, k in held]
        jl = [(b, k, mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(b, k)], offset=0.0)))
              for b, k, _ in model.journal_locks]
        springs = [(b, k, kk, mbs.AddObject(CoordinateSpringDamper(markerNumbers=[mg, marker(b, k)], stiffness=kk)))
                   for b, k, kk, _ in model.reg_springs]
        drive = mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(*i_in)], offset=0.0))
        load = mbs.AddLoad(LoadCoordinate(markerNumber=marker(*i_out), load=0.0))
        views.append(CopyView(nodes=nodes, locks=locks, journal_locks=jl, reg_springs=springs, drive=drive, load=load))
    evaluator = ReplicaEvaluator(families, nb, B)
    elements = BatchedContactElements(mbs, [v.nodes for v in views], evaluator)
    mbs.Assemble()
    ltg = np.array([np.concatenate([np.asarray(mbs.systemData.GetNodeLTGODE2(n), int) for n in v.nodes])
                    for v in views])
    elements.attach(ltg)
    return ReplicatedModel(source=model, SC=SC, mbs=mbs, copies=views, evaluator=evaluator, elements=elements,
                           ltg=ltg, nb=nb, build_kw=dict(build_kw or {}))
