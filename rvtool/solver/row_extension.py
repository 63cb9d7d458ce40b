"""Extra non-contact coordinates of the device row Newton (issue 31, Deliver 1): the elastic pin and
crank closures and the ported housing's port coordinates as extra unknowns with their constant
stiffness blocks.

The row Newton (:mod:`rvtool.solver.device_rows`) solves 3 nb body coordinates per copy from the
rows of contact sets whose bodies are the model's planar bodies. Two model members put contact
rows on *extended* bodies that are not model bodies:

* a series closure (:class:`rvtool.contact.pin_closure.ElasticPinClosure`: elastic ring or output
  pins, the RV crank's bending beam and its torsion) puts its inner set on *station bodies*: the
  station is its carrier's pose plus a deflection u on the closure's ``dofs``, closed by the
  beam's constant stiffness K_b (Q_u(q, u) - (K_b x I) u = 0);
* a contact element on a reduced structure (:class:`exudyn_user_elements.contact_element.PortBodies`,
  the ported housing carrying the ring pins) puts its rows on *port bodies* whose poses are P eta,
  eta the structure's coordinates with the constant stiffness diag(omega^2).

Both are linear elastic coordinates with constant stiffness blocks. Here they are **extra
unknowns of the row Newton with their constant block**, not condensed into the rows:

* condensing a closure statically (what ElasticPinClosure does on the host) needs an inner Newton
  per pin and evaluation (the contact rows depend on u) and then a per-copy Schur complement: a
  second solver loop inside every device iteration, with its own tolerance; condensing the housing
  needs a dense 80 x 80 inner solve coupling every pin (no locality to exploit);
* as unknowns, every contact row stays what it is (the same kernels, the same copiers), the
  station and port poses are *selections* of the unknowns, and the only new term is one constant
  linear family (:class:`StructureRows`: Q = -K_s x, dQ/dx = -K_s). The equations are the
  closures' own: with s = c + u (station displacement = carrier displacement + deflection) the
  change of variables [q; u] -> [q; s] is invertible and the station rows are R_u = 0, so the
  equilibria are the host closures' (and Exudyn's) to the Newton tolerance. The price is a larger
  dense block per copy (rv80e: 21 body coordinates + 18 crank stations + 80 housing ports = 119).

The unknowns are chosen so that every extended body's pose is a selection of the row coordinates
(no linear combinations in the pose gather or the row scatter):

* station of a closure with ``dofs`` on carrier c: its coordinates in ``dofs`` are new unknowns
  (the station's absolute displacement s = c + u; reference and kinematic state the carrier's),
  the others are the carrier's coordinates (or held at zero on the ground). Beam energy
  (1/2) (s - c)^T (K_b x I) (s - c): a constant block over the stations and their carriers.
* port body of a reduced structure: every nonzero row of P (the ports' x, y) is a new unknown w
  (the port displacement, reference 0); rows of zeros (a nodal port's rotation) are held at zero.
  Statics only see the port compliance C = P_w diag(omega^-2) P_w^T: eliminating eta at given w
  (its least energy) gives the constant block C^-1 over w, and back eta = omega^-2 P_w^T C^-1 w
  (:meth:`RowExtension.structure_states`: the model's coordinates of an equilibrium). Needs C
  regular (``housing.n_residual = -1`` or at least the ports' count: the exact static port
  compliance), else refused by name.

Not covered, refused by name (:func:`extension_reasons`): a closure with a nonlinear station law
(``pins.groove = 'conformal'``), state-dependent port maps (floating flexible bodies), port maps
whose compliance is singular, and everything :func:`rvtool.solver.replica.replica_reasons` names
besides elastic structures and extended bodies (anchors, shared output pins, ported carrier and
wheels).
"""
import dataclasses
from dataclasses import dataclass

import numpy as np

from ..contact.pin_closure import GROUND as CLOSURE_GROUND, ElasticPinClosure
from ..contact.stacked import StackedContactSet
from .copy_evaluator import CopyBlockAssembler, RowBlockAssembler
from ..errors import RvtoolInputError

PORT_CONDITION_LIMIT = 1e12
"""Largest condition number of a structure's port compliance C accepted (C^-1 is the block; beyond
this the ports are not independent: fewer structural coordinates than port coordinates)."""


@dataclass(frozen=True)
class Leaf:
    """A copyable contact set of the model on its extended bodies: ``element`` the contact element's
    name, ``set`` (a :data:`rvtool.solver.replica.COPIERS` type over ``len(body_map)`` bodies),
    ``body_map`` (nb_f, 3) the row coordinate of every body coordinate (-1: held at zero)."""
    element: str
    set: object
    body_map: np.ndarray


@dataclass(frozen=True)
class StructureBlock:
    """A constant stiffness block: ``stiffness`` (m, m) [N/m, N m/rad] over row coordinates
    ``coords`` (m,), Q -= stiffness @ x[coords] (x: displacements; the blocks annihilate the
    common reference: a station's reference is its carrier's)."""
    name: str
    coords: np.ndarray
    stiffness: np.ndarray


@dataclass(frozen=True)
class PortStructure:
    """A reduced structure's port unknowns: ``name``, ``coords`` (k,) their row coordinates,
    ``eta_of_ports`` (n_eta, k) the structure's coordinates at given port displacements
    (least energy, exact at an equilibrium) and ``structure`` (the model's structure object)."""
    name: str
    coords: np.ndarray
    eta_of_ports: np.ndarray
    structure: object


@dataclass(frozen=True)
class RowExtension:
    """The row coordinates of a model (module docstring): ``n_real`` = 3 nb body coordinates, then
    the extra unknowns; ``n`` in all; ``leaves`` the contact sets with their body maps; ``blocks``
    the constant stiffness blocks; ``source`` (n - n_real,) the row coordinate whose reference and
    kinematic displacement each extra unknown starts from (-1: zero); ``rot`` (n,) rotation
    coordinates; ``names`` of the extras; ``ports`` the reduced structures' port unknowns."""
    n_real: int
    n: int
    leaves: tuple
    blocks: tuple
    source: np.ndarray
    rot: np.ndarray
    names: tuple
    ports: tuple

    @property
    def trivial(self):
        """No extra unknown and every leaf on the model's bodies as they are (the row Newton's own path)."""
        ident = np.arange(self.n_real).reshape(-1, 3)
        return self.n == self.n_real and not self.blocks and all(
            lf.body_map.shape == ident.shape and np.array_equal(lf.body_map, ident) for lf in self.leaves)

    def extend(self, x):
        """(P, n) from body-coordinate values (P, n_real): each extra takes its source's value (0 without one)."""
        x = np.asarray(x, float)
        ext = np.where(self.source >= 0, x[..., np.maximum(self.source, 0)], 0.0)
        return np.concatenate([x, ext], axis=-1)

    def structure_states(self, q):
        """{structure name: eta (P, n_eta)} of row states q (P, n)."""
        q = np.atleast_2d(q)
        return {p.name: q[:, p.coords] @ p.eta_of_ports.T for p in self.ports}


def model_states(model, q, extension=None):
    """States (P, ODE2 size) in the coordinates of the built ``model`` (a ReducerModel) of row
    states q (P, n): the bodies' coordinates, and with an ``extension`` each reduced structure's
    coordinates from its port unknowns (:meth:`RowExtension.structure_states`; the closures'
    stations have no model coordinates: Exudyn condenses them)."""
    q = np.atleast_2d(np.asarray(q, float))
    idx = np.concatenate([np.asarray(model.mbs.systemData.GetNodeLTGODE2(n), int) for n in model.nodes])
    out = np.zeros((len(q), model.mbs.systemData.ODE2Size()))
    out[:, idx] = q[:, :len(idx)]
    if extension is not None:
        for name, eta in extension.structure_states(q).items():
            out[:, model.structures[name].coordinate_indices()] = eta
    return out


class _Builder:
    def __init__(self, model):
        self.model = model
        self.nb = len(model.body_names)
        self.n_real = 3 * self.nb
        self.extra_source, self.extra_rot, self.extra_names = [], [], []
        self.leaves, self.blocks, self.reasons = [], [], []
        self.port_rows = {}              # id(structure) -> (structure, name, {row bytes: (coord, row)})

    def new(self, name, source, rot):
        self.extra_source.append(int(source))
        self.extra_rot.append(bool(rot))
        self.extra_names.append(name)
        return self.n_real + len(self.extra_names) - 1

    def element(self, el):
        bmap = np.arange(self.n_real).reshape(self.nb, 3)
        ports = getattr(el, "ports", None)
        s = el.evaluator
        if ports is not None:
            if getattr(ports, "state_dependent", False):
                self.reasons.append(f"contact element {s.name!r} sits on floating flexible bodies (state-dependent "
                                    "port maps): the device row Newton takes constant port maps only")
                return
            bmap = np.vstack([bmap, self.port_map(ports)])
        self.walk(s, bmap, s.name)

    def structure_name(self, structure):
        for k, v in getattr(self.model, "structures", {}).items():
            if v is structure:
                return k
        return "structure"

    def port_map(self, ports):
        P = np.asarray(ports.P, float)
        key = id(ports.structure)
        if key not in self.port_rows:
            self.port_rows[key] = (ports.structure, self.structure_name(ports.structure), {})
        _, name, rows = self.port_rows[key]
        out = np.full(P.shape[0], -1)
        for i, row in enumerate(P):
            if not np.any(row):
                continue
            b = row.tobytes()
            if b not in rows:
                rows[b] = (self.new(f"{name}:port{len(rows)}", -1, i % 3 == 2), row)
            out[i] = rows[b][0]
        return out.reshape(-1, 3)

    def walk(self, s, bmap, element, closed=False):
        from .replica import COPIERS
        from ..output_pins.evaluator import OutputPinEvaluator
        from ..output_pins.spec import PinMode
        if isinstance(s, ElasticPinClosure):
            self.closure(s, bmap, element)
        elif isinstance(s, StackedContactSet):
            for part in s.parts:
                self.walk(part, bmap, element, closed)
        elif type(s) in COPIERS:
            if getattr(s, "anchor", False) and (closed or not history_capable(s)):
                self.reasons.append(f"contact element {s.name!r} has stick--slip anchors "
                                    + ("inside a series closure (its history is not committed there either)"
                                       if closed else f"on a {type(s).__name__}, whose history the device does not "
                                       "stage and commit") + ": the device row Newton takes anchors on the pair "
                                    "families (cycloid pins, involute pairs, circle pairs) on the model's bodies "
                                    "(valid: frictionless or regularized friction)")
            if isinstance(s, OutputPinEvaluator) and s.mode != PinMode.PLAIN:
                self.reasons.append(f"output_pins.mode = {s.mode.value!r}: the device row Newton copies plain "
                                    "output pins only (valid: 'plain')")
            if getattr(s, "n_bodies", len(bmap)) != len(bmap):
                self.reasons.append(f"contact set {s.name!r} spans {s.n_bodies} bodies where its element maps "
                                    f"{len(bmap)}")
                return
            self.leaves.append(Leaf(element, s, np.array(bmap, int)))
        else:
            self.reasons.append(f"contact element {element!r}: set {getattr(s, 'name', '?')!r} "
                                f"({type(s).__name__}) has no copier for the device row Newton; valid set types: "
                                f"{sorted(t.__name__ for t in COPIERS)}, ElasticPinClosure, StackedContactSet")

    def closure(self, s, bmap, element):
        if s.support is not None:
            self.reasons.append(f"contact element {element!r}: the closure {s.name!r} has a station law "
                                f"({type(s.support).__name__}: the nonlinear station law of pins.groove = "
                                "'conformal', or the carrier's turned seats of carrier.body = 'ported'): the device "
                                "row Newton takes linear closures with a constant beam stiffness only (valid: "
                                "pins.groove = 'rigid', carrier.body = 'rigid')")
            return
        if len(bmap) != s.n_bodies:
            self.reasons.append(f"contact element {element!r}: closure over {s.n_bodies} bodies where its element "
                                f"maps {len(bmap)}")
            return
        nbs, dofs = s.n_bodies, s.dofs
        car = np.asarray(s.carrier, int)
        car = (car if car.ndim == 2 else
               np.broadcast_to(np.broadcast_to(car, (s.n_pins,))[:, None], (s.n_pins, s.n_stations)))
        ext = np.vstack([bmap, np.full((s.station.size, 3), -1)])
        nd = len(dofs)
        for p in range(s.n_pins):
            st_coords, car_coords = [], []
            for j in range(s.n_stations):
                b, c = nbs + int(s.station[p, j]), int(car[p, j])
                for k in range(3):
                    src = -1 if c == CLOSURE_GROUND else int(bmap[c, k])
                    if k in dofs:
                        ext[b, k] = self.new(f"{s.name}:pin{p}:station{j}:{'xyt'[k]}", src, k == 2)
                        st_coords.append(int(ext[b, k]))
                        car_coords.append(src)
                    else:
                        ext[b, k] = src
            # u_(j, d) = s_(j, d) - c_(j, d): u = G x over the block's coordinates (the stations, then their carriers)
            coords = sorted(set(st_coords) | {c for c in car_coords if c >= 0})
            pos = {c: i for i, c in enumerate(coords)}
            G = np.zeros((len(st_coords), len(coords)))
            for i, (a, c) in enumerate(zip(st_coords, car_coords)):
                G[i, pos[a]] += 1.0
                if c >= 0:
                    G[i, pos[c]] -= 1.0
            Kb = np.kron(s.beam_stiffness, np.eye(nd))       # u ordered (station, dof), as the closure's
            self.blocks.append(StructureBlock(f"{s.name}:pin{p}", np.array(coords, int), G.T @ Kb @ G))
        self.walk(s.inner, ext, element, True)

    def structures(self):
        out = []
        for structure, name, rows in self.port_rows.values():
            coords = np.array([c for c, _ in rows.values()], int)
            Pw = np.array([r for _, r in rows.values()])
            red = getattr(structure, "reduced", None)
            omega2 = None if red is None else np.asarray(red.omega2, float)
            if omega2 is None or np.any(~np.isfinite(omega2)) or np.any(omega2 <= 0):
                self.reasons.append(f"structure {name!r} ({type(structure).__name__}): the device row Newton takes "
                                    "port bodies of a grounded reduced structure only (a ReducedStructure with "
                                    "positive stiffness diag(omega^2); not retained tilt rows or floating bodies)")
                continue
            C = (Pw / omega2) @ Pw.T
            C = 0.5 * (C + C.T)
            if len(coords) > len(omega2) or np.linalg.cond(C) > PORT_CONDITION_LIMIT:
                self.reasons.append(f"structure {name!r}: its port compliance ({len(coords)} port coordinates, "
                                    f"{len(omega2)} structural coordinates) is singular: the device row Newton takes "
                                    "the ports as unknowns (valid: housing.n_residual = -1, the exact static port "
                                    "compliance)")
                continue
            K = np.linalg.inv(C)
            K = 0.5 * (K + K.T)
            self.blocks.append(StructureBlock(name, coords, K))
            out.append(PortStructure(name, coords, (Pw.T / omega2[:, None]) @ K, structure))
        for k, v in getattr(self.model, "structures", {}).items():
            if not any(v is p.structure for p in out) and not any(k in r for r in self.reasons):
                self.reasons.append(f"the model has the elastic structure {k!r} without a contact element on its "
                                    "ports: the device row Newton takes structures through their port bodies only")
        return tuple(out)


def history_capable(s):
    """Whether contact set ``s``'s stick--slip anchors run on the device row Newton: a pair family
    whose kernel stages the committed history (``stages_history``) and whose ``commit`` takes the
    trial history of an evaluation at the accepted state (cycloid pins, involute pairs, circle pairs)."""
    from ..contact.cycloid_set import CycloidPinSet
    from ..contact.evaluator import ContactHistory, ContactSetEvaluator
    from ..contact.involute_set import InvoluteContactSet
    # the copiers of these types carry the anchor rows (rvtool.solver.replica.COPIERS; the plain output
    # pins' copier does not)
    return type(s) in (CycloidPinSet, InvoluteContactSet, ContactSetEvaluator) \
        and isinstance(getattr(s, "history", None), ContactHistory)


def _build(model):
    if hasattr(model, "row_extension_reasons"):            # a snapshot: the extension of the model it was taken of
        return model.row_extension, list(model.row_extension_reasons)
    b = _Builder(model)
    for el in model.contact_elements():
        b.element(el)
    ports = b.structures()
    n = b.n_real + len(b.extra_names)
    rot = np.concatenate([np.arange(b.n_real) % 3 == 2, np.array(b.extra_rot, bool)])
    ext = RowExtension(n_real=b.n_real, n=n, leaves=tuple(b.leaves), blocks=tuple(b.blocks),
                       source=np.array(b.extra_source, int), rot=rot, names=tuple(b.extra_names), ports=ports)
    return ext, b.reasons


def extension_reasons(model):
    """Every named reason why the row coordinates of ``model`` cannot be built (empty: they can)."""
    return _build(model)[1]


def snapshot_extension(model, strip):
    """(extension, reasons) of a built model for its picklable snapshot
    (:class:`rvtool.solver.model_snapshot.ModelSnapshot`): the :class:`RowExtension` with every
    leaf's set copied by ``strip`` (the snapshot's copy of a set without its device objects) and the
    structures' objects dropped, or None where the model needs none or cannot have one (then
    ``reasons`` names why)."""
    from .device_rows import needs_extension
    if not needs_extension(model):
        return None, []
    ext, reasons = _build(model)
    if reasons:
        return None, reasons
    return dataclasses.replace(
        ext, leaves=tuple(dataclasses.replace(lf, set=strip(lf.set)) for lf in ext.leaves),
        ports=tuple(dataclasses.replace(p, structure=None) for p in ext.ports)), []


def row_extension(model):
    """The :class:`RowExtension` of ``model`` (raises :class:`RvtoolInputError` with the reasons)."""
    ext, reasons = _build(model)
    if reasons:
        raise RvtoolInputError("; ".join(reasons))
    return ext


# -- copies -------------------------------------------------------------------------------------
class MappedAssembler(RowBlockAssembler):
    """Per-copy sums of rows whose entries are row coordinates: ``local`` (N, k) the coordinate of
    every entry within its copy (-1: dropped), ``row_copy`` (N,), ``n`` coordinates per copy (the
    sums of :class:`rvtool.solver.copy_evaluator.RowBlockAssembler`, which the device row sums read)."""

    @classmethod
    def of_bodies(cls, bodies, body_map, n, n_copies):
        """The rows of a copied set over n_copies x nb_f bodies (``bodies`` (N, m) per row, the ground
        at n_copies nb_f and beyond) through ``body_map`` (nb_f, 3): the copies' body assembler
        (:class:`rvtool.solver.copy_evaluator.CopyBlockAssembler`) with every body coordinate
        remapped to its row coordinate."""
        nb_f = len(body_map)
        a = CopyBlockAssembler(bodies, nb_f, n_copies)
        flat = np.asarray(body_map, np.int64).reshape(-1)
        local = np.where(a.local >= 0, flat[np.maximum(a.local, 0)], -1)
        return cls(local, a.row_copy, n, n_copies)


def pose_map(body_map, n, n_copies):
    """(B nb_f, 3) flat indices into the copies' row coordinates (B, n) of every copied body
    coordinate (-1: zero), copy c's bodies at c nb_f."""
    bm = np.asarray(body_map, np.int64)
    c = np.arange(n_copies)[:, None, None]
    return np.where(bm[None] >= 0, c * n + bm[None], -1).reshape(-1, 3)


def gather_poses(a, index):
    """Poses (len(index), 3) of absolute row coordinates ``a`` (B, n) at flat ``index`` (-1: 0)."""
    flat = np.asarray(a, float).reshape(-1)
    return np.where(index >= 0, flat[np.maximum(index, 0)], 0.0)


class StructureRows:
    """The constant blocks of B copies as one linear family (Q = -K_s x, dQ/dx = -K_s): one row per
    (copy, block) over the block's coordinates, x the copy's displacements read from absolute row
    coordinates through the pose gather (the blocks annihilate the common reference). Host rows
    (NumPy) and device rows (:mod:`warp_contacts.linear_rows`) from the same arrays.

    blocks: per copy the list of :class:`StructureBlock` (one topology: equal coordinates);
    n: row coordinates per copy; device: Warp device (None: host rows only)."""

    def __init__(self, blocks, n, device=None, precision="float64"):
        B, nk = len(blocks), len(blocks[0])
        m = max(len(b.coords) for b in blocks[0])
        self.name, self.B, self.n_blocks, self.m = "structure", B, nk, m
        coords = np.full((nk, m), -1, np.int64)
        for j, blk in enumerate(blocks[0]):
            coords[j, :len(blk.coords)] = blk.coords
        for c, bc in enumerate(blocks):
            if len(bc) != nk or any(not np.array_equal(x.coords, y.coords) for x, y in zip(bc, blocks[0])):
                raise RvtoolInputError(f"copy {c}'s structure blocks differ in their coordinates from copy 0's; the "
                                       "copies must be models of one topology")
        K = np.zeros((B * nk, m, m))
        for c, bc in enumerate(blocks):
            for j, blk in enumerate(bc):
                k = len(blk.coords)
                K[c * nk + j, :k, :k] = blk.stiffness
        self.K = K
        self.dqdq = np.ascontiguousarray(-K)
        self.local = np.tile(coords, (B, 1))
        self.row_copy = np.repeat(np.arange(B), nk)
        # the family's "bodies": every (copy, block) row reads its m coordinates as m / 3 pseudo-bodies
        self.nbp = -(-m // 3)
        idx = np.full((B * nk, 3 * self.nbp), -1, np.int64)
        idx[:, :m] = np.where(self.local >= 0, self.row_copy[:, None] * n + self.local, -1)
        self.index = idx.reshape(-1, 3)                          # pose_map of the (B nk nbp) pseudo-bodies
        self.ids = tuple(f"{b.name}" for b in blocks[0])
        self.device = device
        self.backend = "warp" if device is not None else "numpy"
        self._kernel = None
        if device is not None:
            from warp_contacts.linear_rows import LinearRows
            self._kernel = LinearRows(self.K, self.nbp, device)

    def raw(self, pose, vel=None):
        """(Q rows (N, m), dQ/dq rows (N, m, m), None, obs) at the pseudo-body poses (N nbp, 3)."""
        from warp_contacts.linear_rows_ref import linear_rows
        x = np.asarray(pose, float).reshape(len(self.K), -1)[:, :self.m]
        return linear_rows(self.K, x), self.dqdq, None, np.zeros((len(self.K), 8))

    @property
    def rows_on_device(self):
        return self._kernel is not None

    def device_pose_buffers(self):
        return self._kernel.pose, None

    def launch_device_rows(self):
        self._kernel.launch()
        return self._kernel.q, self._kernel.dqdq

    def device_rows(self, pose, vel=None):
        self._kernel.pose.assign(np.ascontiguousarray(np.vstack([pose, np.zeros((1, 3))]), np.float64))
        return self.launch_device_rows()


def copy_rows(models, copies, *, precision="float64", device="cpu", host_structure=False):
    """(families, extension) of B = ``copies`` copies (``models``: one model, or B models of one
    topology): every leaf of every copy's :class:`RowExtension` copied by its type's copier over
    B nb_f bodies with its rows mapped to the row coordinates (:class:`MappedAssembler`) and its
    pose gather (``FamilyCopies.pose_map``), and the constant blocks as one linear family
    (:class:`StructureRows`; its rows on the device unless ``host_structure``)."""
    from .replica import COPIERS, FamilyCopies
    models = list(models) if isinstance(models, (list, tuple)) else [models] * int(copies)
    B = len(models)
    if B != int(copies):
        raise RvtoolInputError(f"copies = {copies} but {B} models were given (one model per copy)")
    exts = [row_extension(models[0])] if len(set(map(id, models))) == 1 else [row_extension(m) for m in models]
    first = exts[0]
    for i, e in enumerate(exts):
        if e.n != first.n or len(e.leaves) != len(first.leaves) or not np.array_equal(e.source, first.source) or any(
                a.set.name != b.set.name or not np.array_equal(a.body_map, b.body_map)
                or len(a.set.ids) != len(b.set.ids) for a, b in zip(e.leaves, first.leaves)):
            raise RvtoolInputError(f"model {i} differs in its contact sets or extra coordinates from model 0; the "
                                   "copies must be models of one topology")
    per = exts if len(exts) == B else exts * B
    families = []
    for j, lf in enumerate(first.leaves):
        nb_f = len(lf.body_map)
        cs = COPIERS[type(lf.set)]([e.leaves[j].set for e in per], nb_f, precision, device)
        families.append(FamilyCopies(name=lf.set.name, set=cs,
                                     scatter=MappedAssembler.of_bodies(cs.assembler.bodies, lf.body_map, first.n, B),
                                     obs_rows=len(lf.set.ids), pose_map=pose_map(lf.body_map, first.n, B)))
    if first.blocks:
        sr = StructureRows([e.blocks for e in per], first.n, device=None if host_structure else device,
                           precision=precision)
        families.append(FamilyCopies(name="structure", set=sr,
                                     scatter=MappedAssembler(sr.local, sr.row_copy, first.n, B),
                                     obs_rows=sr.n_blocks, pose_map=sr.index))
    return families, first


__all__ = ["Leaf", "MappedAssembler", "PortStructure", "RowExtension", "StructureBlock", "StructureRows",
           "copy_rows", "extension_reasons", "gather_poses", "history_capable", "model_states", "pose_map", "row_extension",
           "snapshot_extension"]
