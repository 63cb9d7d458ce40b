"""The elastic cycloid wheels (``wheels.body = "ported"``) of an RV design combined with the other
elastic members of the torque path (issue 30): the ported housing (``housing.model = "ports"``), the
ring pins' conformal grooves (``pins.groove = "conformal"``), the elastic crankshafts (bending,
``cranks.shaft.model``, and torsion, ``cranks.shaft.torsion``). The ported carrier closes the crank
bearings, a contact element of its own (:func:`rvtool.assembly.rv.builder.ported_carrier`), and
combines without anything here.

Every member is a series closure (:class:`~rvtool.contact.pin_closure.ElasticPinClosure`) over
station bodies; the members that share contacts are nested, outermost first:

    crank bending (stations: 3 per crank)  >  crank torsion (one per crank and wheel)
        >  wheel bodies (z_b pin and n_c bore stations per wheel)  >  pin grooves (one per pin and wheel)
            >  the contacts: the wheel--pin meshes, the needle bearings (and, with crank bending, the
               involute meshes on the cranks' gear stations)

A station body of an inner member rides on its carrier in the outer one (station translations and
the torsion's rotation add, so the order of the translations is free): the needles sit on the
twisting journal (or the bending station, or the crank) and on the wheel's bore station; a wheel--pin
contact sees the ring pin at its port body (ported housing, else the ground), moved by minus the
wheel's elastic displacement at the contact (the wheel's pin station) and by the pin's approach in
its groove (the groove station). Each inner closure is solved exactly for every evaluation of the
outer one and returns its exact condensed tangent, so the top closure's tangent is the exact tangent
of the whole series network. The order is chosen so that the groove and wheel closures stay block
diagonal per pin and per wheel; the crank closures see the cranks coupled through the wheels and
solve their station systems in full (``coupled``).

Budget paths (:class:`NestedSeries`): ``cranks``, ``crank_torsion`` (family eccentric bearings),
``wheel_bodies``, ``pin_grooves`` (family pins): each member's station energy along the mode, and
its stiffened tangent through the nesting (:meth:`ElasticPinClosure.stiffened_view`).
"""
import dataclasses

import numpy as np

from ...bearings.set import BearingSet
from ...contact.cycloid_set import CycloidPinSet
from ...contact.involute_set import InvoluteContactSet
from ...contact.pin_closure import GROUND, ElasticPinClosure
from ...contact.stacked import StackedContactSet
from ...errors import RvtoolInputError
from ...model import Family

NESTED_SOLVES = ("joint", "nested")
"""How the nested closures are solved: ``"joint"`` (the default), every closure of the nesting solves
the stations below it as one network (:class:`~rvtool.contact.pin_closure.JointNetwork`: one Newton
over all stations, the contacts evaluated once per iterate); ``"nested"``, each inner closure solved to
convergence at every iterate of the one outside it (the former solve, kept selectable to measure the
difference). Same equations, same solution within the closures' tolerance (tests/test_joint_network.py;
cases/benchmarks/bench_nested_wheels.py measures both)."""

ENVIRONMENT_VARIABLE = "RVTOOL_NESTED_SOLVE"


def nested_solve_mode(value=None):
    """``value``, else the environment variable ``RVTOOL_NESTED_SOLVE``, else ``"joint"`` (checked
    against :data:`NESTED_SOLVES`)."""
    import os
    mode = value if value is not None else os.environ.get(ENVIRONMENT_VARIABLE, "joint")
    if mode not in NESTED_SOLVES:
        raise RvtoolInputError(f"nested solve = {mode!r}; valid choices are {list(NESTED_SOLVES)} (environment "
                               f"variable {ENVIRONMENT_VARIABLE})")
    return mode

#: budget path -> contact family of the nested members (outermost first)
PATH_FAMILY = {"cranks": Family.ECCENTRIC_BEARINGS, "crank_torsion": Family.ECCENTRIC_BEARINGS,
               "wheel_bodies": Family.PINS, "pin_grooves": Family.PINS}


@dataclasses.dataclass(frozen=True)
class WheelPath:
    """The nested closures of the elastic wheels: ``evaluator`` (the top closure, element
    ``"wheel_bodies"``), ``paths`` (budget path -> depth in the chain of closures, 0 the top),
    ``gears_inside`` (the involute meshes are inside: crank bending on)."""
    evaluator: object
    paths: dict
    gears_inside: bool


def refuse_unsupported(design):
    """Refuse, by key, the combinations with the elastic wheels that are not implemented."""
    d = design
    others = {"bodies.wheel_coordinates": (d.bodies.wheel_coordinates, "planar"),
              "bodies.crank_coordinates": (d.bodies.crank_coordinates, "planar"),
              "pin_contact.friction_model (with mu > 0)": (
                  d.pin_contact.friction_model if d.pin_contact.mu > 0 else "regularized", "regularized")}
    for key, (value, valid) in others.items():
        if value != valid:
            raise RvtoolInputError(f"wheels.body = 'ported' with {key} = {value!r} is not implemented (the wheels' "
                                   f"closure carries planar stations); valid: {key} = {valid!r} or wheels.body = "
                                   "'rigid'")


def wheel_path(design, graph, layout, meshes, opts, *, ports=None, crank=None, torsion=None):
    """The nested closures (module docstring) as a :class:`WheelPath`, or None for rigid wheels.

    meshes: the wheel--pin meshes (on the ground's pins or, ``ports`` given, the housing's port
    bodies n_bodies + p); crank: the station compliance (3, 3) of the bending cranks or None;
    torsion: the torsion compliance (n_w, n_w) or None."""
    from ...contact.groove import GrooveSupport, groove_law
    from ...contact.wheel_closure import WheelBodyClosure
    from ...geometry.cycloid import pin_centres
    from ..wheel_body import wheel_model
    from .builder import gear_meshes, needle_mountings
    d = design
    if d.wheels.body != "ported":
        return None
    refuse_unsupported(d)
    joint = nested_solve_mode() == "joint"
    # a network that does not converge answers a non-finite trial (the outer solver rejects it) instead of
    # the nested solve, whose inner networks fail at the same far trial state and cascade (minutes per
    # evaluation, rv40e's Latin-hypercube samples): :meth:`ElasticPinClosure.solve`
    fallback = "reject"
    nc, nw, zb = layout.n_cranks, d.n_wheels, d.pins.n_pins
    n_real = layout.n_bodies + (0 if ports is None else ports.n_virtual)
    n = n_real
    bend = None
    if crank is not None:
        bend = n + np.arange(3 * nc).reshape(nc, 3)            # journal of wheel 0, of wheel 1, gear
        n += bend.size
    n_bend = n
    twist = None
    if torsion is not None:
        twist = n + np.arange(nc * nw).reshape(nc, nw)
        n += twist.size
    n_twist = n
    wheel = n + np.arange(nw * (zb + nc)).reshape(nw, zb + nc)     # wheel j: z_b pin stations, n_c bores
    n += wheel.size
    n_wheel = n
    law = groove_law(d)
    groove = None
    if law is not None:
        groove = n + np.arange(zb * nw).reshape(zb, nw)
        n += groove.size

    def journal(k, j):
        if twist is not None:
            return int(twist[k, j])
        return int(bend[k, j]) if bend is not None else layout.crank(k)
    pin_of = groove.T if groove is not None else wheel[:, :zb]         # (n_w, z_b) pin bodies per wheel
    pin_meshes = [dataclasses.replace(m, pin_bodies=tuple(int(b) for b in pin_of[j])) for j, m in enumerate(meshes)]
    parts = [CycloidPinSet(pin_meshes, n, samples_per_tooth=d.wheels.samples_per_tooth, name="pins",
                           search=d.wheels.search, **opts)]
    mounts = []
    for m in needle_mountings(d, graph, layout):
        j, k = m.outer - layout.wheel0, m.inner - layout.crank0
        mounts.append(dataclasses.replace(m, inner=journal(k, j), outer=int(wheel[j, zb + k])))
    parts.append(BearingSet(mounts, n, name="eccentric_bearings", **opts))
    if bend is not None:
        crank_of = {layout.crank(k): k for k in range(nc)}
        gm = [dataclasses.replace(m, body_b=int(bend[crank_of[m.body_b], 2])) if m.body_b in crank_of else m
              for m in gear_meshes(d, graph, layout)]
        parts.append(InvoluteContactSet(gm, n, name="gears", **opts))
    closure = StackedContactSet(parts, name="wheel_bodies")
    chain = []
    if groove is not None:
        closure = ElasticPinClosure(closure, n_bodies=n_wheel, carrier=wheel[:, :zb].T, station_compliance=None,
                                    station=groove - n_wheel, support=GrooveSupport(law), joint=joint,
                                    fallback=fallback)
        chain.append("pin_grooves")
    pin_carrier = GROUND if ports is None else [layout.n_bodies + p for p in range(zb)]
    centres = pin_centres(d.profile, None if d.pins.centre_errors is None else np.asarray(d.pins.centre_errors, float))
    closure = WheelBodyClosure(closure, n_bodies=n_twist, wheels=[layout.wheel(j) for j in range(nw)],
                               bodies=[wheel_model(d, j) for j in range(nw)], pin_centres=centres,
                               station=wheel - n_twist, pin_carrier=pin_carrier, joint=joint,
                               fallback=fallback)
    chain.append("wheel_bodies")
    if twist is not None:
        carrier = bend[:, :nw] if bend is not None else [layout.crank(k) for k in range(nc)]
        closure = ElasticPinClosure(closure, n_bodies=n_bend, carrier=carrier, station_compliance=torsion,
                                    station=twist - n_bend, dofs=(2,), coupled=True, joint=joint,
                                    fallback=fallback)
        chain.append("crank_torsion")
    if bend is not None:
        closure = ElasticPinClosure(closure, n_bodies=n_real, carrier=[layout.crank(k) for k in range(nc)],
                                    station_compliance=crank, station=bend - n_real, coupled=True, joint=joint,
                                    fallback=fallback)
        chain.append("cranks")
    chain.reverse()
    return WheelPath(closure, {p: k for k, p in enumerate(chain)}, bend is not None)


def chain_of(evaluator):
    """The closures nested in ``evaluator`` (top first; an :class:`ElasticPinClosure` whose inner
    set is another closure continues the chain) and the innermost contact set."""
    chain = []
    e = evaluator
    while isinstance(e, ElasticPinClosure):
        chain.append(e)
        e = e.inner
    return chain, e


def contact_evaluations(evaluator):
    """Evaluations of the innermost contact set made so far through the closures nested in ``evaluator``
    (:attr:`~rvtool.contact.pin_closure.ElasticPinClosure.inner_evaluations` of the innermost closure): the cost
    counter of the nesting (cases/benchmarks/bench_nested_wheels.py)."""
    chain, _ = chain_of(evaluator)
    return chain[-1].inner_evaluations if chain else 0


def network_counters(model):
    """{"solves", "continued", "failures", "fallbacks"} summed over the joint networks of every element of
    ``model`` whose evaluator is a closure (:class:`~rvtool.contact.pin_closure.JointNetwork`'s counters; the
    closures' :attr:`~rvtool.contact.pin_closure.ElasticPinClosure.fallbacks`): how often the networks did
    not converge at an outer solver's trial states."""
    out = {"solves": 0, "continued": 0, "failures": 0, "fallbacks": 0}
    for el in model.elements.values():
        for c in chain_of(getattr(el, "evaluator", None))[0]:
            out["fallbacks"] += c.fallbacks
            net = c.network
            if net is not None and net.chain[0] is c:
                for k in ("solves", "continued", "failures"):
                    out[k] += getattr(net, k)
    return out


def inner_pose(chain, depth, pose):
    """Poses of the bodies closure ``chain[depth]`` is evaluated on, from the top element's static
    poses ``pose``: every outer closure's extended pose at its solved deflections."""
    for c in chain[:depth]:
        pose = c.extended_pose(pose)
    return pose


def leaf_rows(evaluator):
    """{part name: rows} of the innermost stacked set of ``evaluator`` (closures pass their inner
    set's observation rows through unchanged)."""
    _, leaf = chain_of(evaluator)
    return leaf.rows


def leaf_state(evaluator, pose, part):
    """(the innermost set's part ``part``, the poses it is evaluated at) at the top element's
    static poses ``pose``."""
    chain, leaf = chain_of(evaluator)
    return leaf.part(part), inner_pose(chain, len(chain), pose)


class NestedSeries:
    """A member of the nested closures for the stiffness budget (the interface of
    :class:`rvtool.model.SeriesBeam`): ``path``, ``family``; ``energy(q, dq)`` the member's station
    energy du^T (ds/du) du along dq (du by central differences of its solved deflections);
    ``stiffened(q, factor)`` the element's tangent with the member's station stiffness times
    ``factor`` (the member's condensation in the nesting, every state unchanged)."""

    def __init__(self, path, element, depth):
        self.path = path
        self.family = PATH_FAMILY[path]
        self.element = element
        self.depth = int(depth)
        self.chain = chain_of(element.evaluator)[0]
        self.closure = self.chain[self.depth]

    @staticmethod
    def family_of(path):
        """The contact family of budget path ``path``."""
        return PATH_FAMILY[path]

    def _pose(self, q):
        ql = self.element.local(q)
        return self.element.pose_velocity(ql, 0 * ql)[0]

    def deflections(self, q):
        return self.closure.deflections(inner_pose(self.chain, self.depth, self._pose(q)))

    def energy(self, q, dq, step=1e-9):
        h = step / max(float(np.abs(dq).max()), 1e-300)
        du = (self.deflections(q + h * dq) - self.deflections(q - h * dq)) / (2 * h)
        pose = inner_pose(self.chain, self.depth, self._pose(q))
        u = self.closure.solve(pose, np.zeros_like(pose))[0]          # (the wheels' blocks back at q)
        return self.closure.station_energy(du, u)

    def stiffened(self, q, factor):
        pose = self._pose(q)
        top = self.chain[0]
        u, _, red, _ = top.solve(pose, np.zeros_like(pose))
        if self.depth == 0:
            return self.element.coordinate_indices, self.element.element_tangent(top.condense(red, beam_factor=factor, u=u)[1])
        with self.closure.stiffened_view(factor):
            _, _, red, ok = top.solve(pose, np.zeros_like(pose), u0=u)
        if not ok:
            raise RvtoolInputError(f"budget path {self.path!r}: the nested closures did not converge at the state")
        return self.element.coordinate_indices, self.element.element_tangent(top.condense(red)[1])
