"""Flexible RV crankshafts as floating bodies (``[cranks.dynamics] model = "flexible"``, issue 33).

Planar dynamics. Each crank keeps its planar rigid node (x, y, theta) as the floating frame (the
mean axis; its tilts held, as for the rigid crank) and gains the elastic basis of its free beam
(:mod:`rvtool.structure.crank_modes`: the ``[cranks.shaft]`` geometry, radius, tapered-row
positions and gear position, with the design's material; free-free modes plus the static
correction). The crank's stations are the two tapered rows (``cranks.shaft.supports``), the
eccentric journals (the wheel midplanes, the needles' length) and the spur gear
(``cranks.shaft.gear_position``, its face width). Every family on a crank couples through them
(:class:`~exudyn_user_elements.floating_ports.FloatingPorts`: virtual bodies after the rigid
bodies, each the crank's pose plus its station's deflection and twist):

* ``gears``: the sun--crank mesh k on the virtual body n_bodies + k (the gear station: the
  gear's deflection moves its centre, the twist turns its teeth);
* ``eccentric_bearings``: the needle row of crank k in wheel j (mounting i of
  :func:`rvtool.assembly.rv.builder.needle_mountings`) with its inner ring on the virtual body
  n_bodies + i (journal j's deflection; the twist turns the eccentric about the crank axis);
* ``crank_bearings``: the tapered pair of crank k (one planar contact) on the virtual body
  n_bodies + k at the mean of its two rows' stations (the pair's tilt is not a planar coordinate).

Frozen (``frozen = true``) the virtual bodies sit on the crank poses: the rigid crank. The frame
keeps the builder's crank mass and inertia (``cranks.mass``, ``cranks.inertia``); the beam's own
mass is reported beside it. Flexible cranks need rigid shaft closures (``cranks.shaft.model =
"rigid"``, ``torsion = "rigid"``: the beam would be counted twice), and are refused by key with
the combinations not implemented.
"""
import dataclasses

import numpy as np

from ...errors import RvtoolInputError

_CACHE = {}


def crank_stations(design):
    """The :class:`~rvtool.structure.crank_modes.CrankStation` s of an RV crank (module docstring)."""
    from ...structure.crank_modes import CrankStation
    d = design
    sh = d.cranks.shaft
    za, zb = sh.supports
    out = [CrankStation("support0", za, 0.0), CrankStation("support1", zb, 0.0),
           CrankStation("gear", sh.gear_position, d.crank_gear.face_width)]
    out += [CrankStation(f"journal{j}", z, d.eccentric_bearing.roller_length) for j, z in enumerate(d.wheels.midplanes)]
    return tuple(out)


def crank_body(design, full=False):
    """The :class:`~rvtool.structure.crank_modes.CrankModalBody` of the design's crank (every
    crank the same; cached per geometry and modal settings); ``full``: every elastic mode."""
    from ...structure.crank_modes import crank_beam_model, crank_modal_body
    d = design
    dyn = d.cranks.dynamics
    sh = d.cranks.shaft
    mat = d.material
    key = repr((crank_stations(d), sh.radius, mat, dataclasses.replace(dyn, frozen=False), full))
    if key not in _CACHE:
        beam = crank_beam_model(sh.radius, crank_stations(d), mat.youngs_modulus, mat.poisson_ratio, mat.density)
        _CACHE[key] = crank_modal_body(beam, n_modes=dyn.n_modes, damping_ratio=dyn.damping_ratio,
                                       static_orders=dyn.static_orders, full=full)
    return _CACHE[key]


def check_flexible_cranks(design):
    """Named refusals of the combinations flexible cranks do not implement (yet)."""
    d = design
    sh = d.cranks.shaft
    missing = [nm for nm in ("radius", "supports", "gear_position") if getattr(sh, nm) is None]
    if missing:
        raise RvtoolInputError("cranks.dynamics.model = 'flexible' needs the crank beam's geometry: "
                               + ", ".join(f"cranks.shaft.{nm}" for nm in missing)
                               + " (valid: see rvtool/designs/rv40e.toml [cranks.shaft])")
    others = {"wheels.body": (d.wheels.body, "rigid", "the needles sit inside the wheel closure"),
              "housing.model": (d.housing.model, "rigid", "the merged element carries one structure"),
              "carrier.body": (d.carrier.body, "rigid", "the tapered pairs sit inside the seat closure"),
              "cranks.shaft.model": (sh.model, "rigid", "the flexible crank carries the beam; counted twice"),
              "cranks.shaft.torsion": (sh.torsion, "rigid", "the flexible crank carries the twist; counted twice"),
              "bearing_friction.model": (d.bearing_friction.model, "none",
                                         "Palmgren's moment reads the crank bearings on the crank body"),
              "bodies.wheel_coordinates": (d.bodies.wheel_coordinates, "planar", "planar dynamics only"),
              "bodies.crank_coordinates": (d.bodies.crank_coordinates, "planar", "planar dynamics only"),
              "bodies.carrier_coordinates": (d.bodies.carrier_coordinates, "planar", "planar dynamics only"),
              "bodies.input_coordinates": (d.bodies.input_coordinates, "planar", "planar dynamics only")}
    bad = [f"{key} = {value!r} ({why}; valid: {valid!r})" for key, (value, valid, why) in others.items()
           if value != valid]
    if bad:
        raise RvtoolInputError("cranks.dynamics.model = 'flexible' is not implemented with " + "; ".join(bad))


@dataclasses.dataclass(frozen=True)
class CrankFamily:
    """The virtual bodies of one family on the flexible cranks: ``base`` = ``frame`` (n_v,) the
    crank's body index, ``crank`` (n_v,) its crank index k, ``station`` (n_v,) the station
    weights' names: each virtual body's displacement is the mean of these stations' maps."""
    frame: np.ndarray
    crank: np.ndarray
    stations: tuple

    @property
    def base(self):
        return self.frame

    @property
    def sign(self):
        return np.ones(len(self.frame))

    def operator(self, beam):
        """(n_v, 3, n_fe) the virtual bodies' x, y, phi rows on the beam's FE coordinates."""
        return np.array([np.mean([beam.station_operator(s) for s in st], axis=0) for st in self.stations])


class FlexibleCranks:
    """The flexible cranks of one RV build (module docstring). mbs; design; ground_marker; graph;
    layout. ``body`` (the :class:`~rvtool.structure.crank_modes.CrankModalBody` every crank
    shares), ``coordinates`` (one :class:`~exudyn_user_elements.floating_ports.ModalCoordinates`
    of all cranks: ``crank{k}``, or the shared one passed as ``coordinates``), ``families``
    {element name: :class:`CrankFamily`}."""

    def __init__(self, mbs, design, ground_marker, graph, layout, coordinates=None):
        from exudyn_user_elements.floating_ports import ModalCoordinates
        from .builder import needle_mountings
        check_flexible_cranks(design)
        d, L = design, layout
        self.design, self.graph, self.layout = d, graph, L
        self.body = crank_body(d)
        nc = L.n_cranks
        self.nc = nc
        self.frames = tuple(L.crank(k) for k in range(nc))
        self.n_rigid = L.n_bodies
        self.coordinates = coordinates or ModalCoordinates(mbs, {f"crank{k}": self.body for k in range(nc)},
                                                           frozen=d.cranks.dynamics.frozen,
                                                           ground_marker=ground_marker, name="flexible_cranks")
        self.n_eta = self.coordinates.n
        ks = np.arange(nc)
        mounts = needle_mountings(d, graph, L)
        mk = np.array([m.inner - L.crank0 for m in mounts])
        mj = [m.outer - L.wheel0 for m in mounts]
        self.families = {
            "gears": CrankFamily(np.array(self.frames), ks, (("gear",),) * nc),
            "eccentric_bearings": CrankFamily(np.array([L.crank(k) for k in mk]), mk,
                                              tuple((f"journal{j}",) for j in mj)),
            "crank_bearings": CrankFamily(np.array(self.frames), ks, (("support0", "support1"),) * nc)}

    def ports(self, name):
        """:class:`~exudyn_user_elements.floating_ports.FloatingPorts` of contact element ``name``."""
        from exudyn_user_elements.floating_ports import FloatingPorts
        fam = self.families[name]
        return FloatingPorts(self.coordinates, self.n_rigid, fam.base, fam.frame, fam.sign, self.table(name))

    def table(self, name):
        """(n_v, 3, n_eta) the constant port maps of family ``name``."""
        fam = self.families[name]
        A = np.zeros((len(fam.frame), 3, self.n_eta))
        for v, (k, st) in enumerate(zip(fam.crank, fam.stations)):
            A[v, :, self.coordinates.slice(f"crank{k}")] = np.mean([self.body.station_maps[s] for s in st], axis=0)
        return A

    def gears(self, meshes, opts):
        """The involute set with each sun--crank mesh on its crank's gear station body (the
        three-stage input mesh unchanged)."""
        from ...contact.involute_set import InvoluteContactSet
        of = {f: self.n_rigid + k for k, f in enumerate(self.frames)}
        meshes = [dataclasses.replace(m, body_b=of[m.body_b]) if m.body_b in of else m for m in meshes]
        return InvoluteContactSet(meshes, self.n_rigid + self.nc, name="gears", **opts)

    def needles(self, mounts, opts):
        """The needle set with every inner ring on its journal's virtual body."""
        from ...bearings.set import BearingSet
        mounts = [dataclasses.replace(m, inner=self.n_rigid + i) for i, m in enumerate(mounts)]
        return BearingSet(mounts, self.n_rigid + len(mounts), name="eccentric_bearings", **opts)

    def crank_bearings(self, mounts, opts):
        """The tapered pairs with each crank side on its pair's virtual body."""
        from ...bearings.tapered_set import TaperedBearingSet
        of = {f: self.n_rigid + k for k, f in enumerate(self.frames)}
        mounts = [dataclasses.replace(m, inner=of[m.inner]) for m in mounts]
        return TaperedBearingSet(mounts, self.n_rigid + self.nc, name="crank_bearings", **opts)

    def full_body(self):
        """The crank's :class:`~rvtool.structure.crank_modes.CrankModalBody` with every elastic
        mode of its beam FE (the full FE the reduction is compared with)."""
        return crank_body(self.design, full=True)

    def summary(self):
        """Reported facts of the flexible cranks: beam nodes and mass, retained frequencies [Hz]."""
        b = self.body
        return {"source": "free Timoshenko crank beam (rvtool.structure.crank_modes)",
                "beam_nodes": int(len(b.beam.nodes)), "beam_mass_kg": b.beam.total_mass,
                "frame_mass_kg": self.design.cranks.mass, "n_modes": self.design.cranks.dynamics.n_modes,
                "n_coordinates": b.n_modes, "frequencies_hz": b.frequencies_hz.tolist(),
                "frozen": self.design.cranks.dynamics.frozen}


class RvFloatingBodies:
    """The flexible bodies of one RV build, wheels and/or cranks, on one modal structure
    (``coordinates``: ``wheel{j}`` then ``crank{k}``; each switch's ``frozen`` holds its own
    bodies). ``wheels`` (:class:`~rvtool.assembly.rv.flexible_wheels.RvFlexibleWheels` or None),
    ``cranks`` (:class:`FlexibleCranks` or None). The needle rows sit between a crank and a wheel:
    with both flexible, mounting i's inner ring is the virtual body n_bodies + i (the crank's
    journal) and its outer ring n_bodies + n_m + i (the wheel's bore), one port map over both."""

    def __init__(self, mbs, design, ground_marker, graph, layout):
        from exudyn_user_elements.floating_ports import ModalCoordinates
        from .flexible_wheels import RvFlexibleWheels, check_rv_flexible_wheels, rv_wheel_modes
        d, L = design, layout
        self.design, self.graph, self.layout = d, graph, L
        self.n_rigid = L.n_bodies
        bodies, frozen = {}, []
        if d.wheels.dynamics.flexible:
            check_rv_flexible_wheels(d)
            for j in range(d.n_wheels):
                bodies[f"wheel{j}"] = rv_wheel_modes(d, j)[0]
                if d.wheels.dynamics.frozen:
                    frozen.append(f"wheel{j}")
        if d.cranks.dynamics.flexible:
            check_flexible_cranks(d)
            for k in range(L.n_cranks):
                bodies[f"crank{k}"] = crank_body(d)
                if d.cranks.dynamics.frozen:
                    frozen.append(f"crank{k}")
        self.coordinates = ModalCoordinates(mbs, bodies, frozen=frozen, ground_marker=ground_marker)
        c = self.coordinates
        self.wheels = RvFlexibleWheels(mbs, d, ground_marker, graph, L, c) if d.wheels.dynamics.flexible else None
        self.cranks = FlexibleCranks(mbs, d, ground_marker, graph, L, c) if d.cranks.dynamics.flexible else None
        self.families = {**(self.wheels.families if self.wheels else {}), **(self.cranks.families if self.cranks else {})}

    @property
    def both(self):
        return self.wheels is not None and self.cranks is not None

    def ports(self, name):
        """The port map of contact element ``name`` (the needle rows over both bodies where both are flexible)."""
        if not (self.both and name == "eccentric_bearings"):
            return (self.cranks if self.cranks is not None and name in self.cranks.families else self.wheels).ports(name)
        from exudyn_user_elements.floating_ports import FloatingPorts
        fc, fw = self.cranks.families[name], self.wheels.families[name]
        cat = np.concatenate
        split = any(b.split for b in self.wheels.bodies)
        A_c = self.cranks.table(name)
        return FloatingPorts(self.coordinates, self.n_rigid, cat([fc.base, fw.base]), cat([fc.frame, fw.frame]),
                             cat([fc.sign, fw.sign]), cat([A_c, self.wheels.table(name)]),
                             cat([A_c, self.wheels.table(name, True)]) if split else None)

    def needles(self, opts):
        """The needle set on the virtual bodies of the flexible side(s) (class docstring)."""
        from ...bearings.set import BearingSet
        from .builder import needle_mountings
        mounts = needle_mountings(self.design, self.graph, self.layout)
        if not self.both:
            return self.cranks.needles(mounts, opts) if self.cranks is not None else self.wheels.needles(opts)
        nm, first = len(mounts), self.n_rigid
        mounts = [dataclasses.replace(m, inner=first + i, outer=first + nm + i) for i, m in enumerate(mounts)]
        return BearingSet(mounts, first + 2 * nm, name="eccentric_bearings", **opts)
