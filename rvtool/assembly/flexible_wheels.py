"""Flexible cycloid wheels as floating bodies (``[wheels.dynamics] model = "flexible"``, issue 33).

Each wheel keeps its planar rigid node as the floating frame and gains ``n_modes`` in-plane
free-free modes of its FE model (:mod:`rvtool.structure.floating_ports`); the modal coordinates
of all wheels form one :class:`~exudyn_user_elements.floating_ports.ModalCoordinates`
structure, and every contact family on a wheel acts on it through
:class:`~exudyn_user_elements.floating_ports.FloatingPorts`:

* ring pins: pin p at wheel k is a virtual body (index nw + 2 + k z_b + p) at minus the wheel's
  elastic displacement at the contact, interpolated between the profile stations at the polar
  angle (wheel frame) of the contact point C = P - r_p n, n the direction from the pitch point
  I = z_b e (O_w / |O_w|) to the pin centre P (the ideal cycloid's contact normal passes
  through the pitch point: a locator, exact for the unmodified profile; modifications move the
  contact by a fraction of a station);
* output pins: the flange's station body of pin p at wheel k (index nw + 2 + p nw + k, as for
  elastic output pins) is the flange shifted by minus the hole's displacement;
* eccentric bearings (lumped): wheel k's bore is a virtual body (index nw + 2 + k) at the wheel
  pose plus the bore's rigid-fit motion.

The frame carries the builder's rigid inertia (mass and polar inertia of the wheel annulus), so a
frozen flexible wheel (``frozen = true``, modal coordinates held) is the rigid wheel; the FE
mesh's own mass and inertia are reported beside it (``WheelModes.mesh_mass``).

Wheel geometry and ports: issue 30's wheel body (:mod:`rvtool.structure.wheel_body`) on the cycloid
wheel's geometry (:func:`wheel_geometry`: the turned profile, the central bore, the output-pin
holes); :func:`wheel_body_mesh`. Its profile ports spread a contact load along the flank and
through the width and measure the displacement at the contact datum depth, so the local
(Hertzian) compliance the pin law holds is not counted twice.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..structure.floating_ports import planar_modal_body

_CACHE = {}


@dataclass(frozen=True)
class WheelMesh:
    """A wheel's unsupported FE model (``model``) with its port operators (``operators``, a
    :class:`~rvtool.structure.floating_ports.PortOperators`), ``centre`` (the wheel centre in the
    mesh frame [m]) and ``source`` (a label). ``profile``, ``bore``, ``holes``: the nodal port
    groups the operators were made from (empty where the operators come from spread ports)."""
    model: object
    operators: object
    profile: tuple = ()
    bore: tuple = ()
    holes: tuple = ()
    centre: tuple = (0.0, 0.0)
    source: str = ""


def wheel_mesh_key(design, k):
    """Cache key of wheel k's mesh: everything the wheel body is built from."""
    d = design
    return repr(("mesh", k, d.pins, d.profile, d.wheels.eccentricity, d.wheels.width, d.wheels.phases,
                 d.wheels.structure, d.eccentric_bearing, d.output_pins, d.material))


def wheel_geometry(design, k=0, spec=None):
    """:class:`~rvtool.structure.wheel_body.WheelGeometry` of wheel k of a cycloid design: the
    design's profile turned to the wheel's assembly phase (as :func:`rvtool.assembly.cycloid.pin_meshes`
    turns it for the contact law), thickness ``wheels.width``, one central bore (the eccentric
    needle bearing's outer raceway, ``eccentric_bearing.inner_radius + roller_diameter``), the
    output-pin holes (``output_pins.hole_circle_radius``, ``hole_radius``, at the pins' angles) and
    the lightening holes and datum depth of ``[wheels.structure]`` (issue 30's wheel body; the RV
    wheel's is :func:`rvtool.assembly.wheel_body.wheel_geometry`)."""
    import dataclasses
    from .wheel_body import wheel_spec
    from ..structure.wheel_body import WheelGeometry
    d = design
    spec = wheel_spec(d) if spec is None else spec
    zg = d.pins.n_pins - 1
    prof = dataclasses.replace(d.profile, rotation_mod=d.profile.rotation_mod - d.wheels.phases[k] / zg)
    rb = d.eccentric_bearing.inner_radius + d.eccentric_bearing.roller_diameter
    op = d.output_pins
    holes = tuple((op.hole_circle_radius * math.cos(a), op.hole_circle_radius * math.sin(a), op.hole_radius)
                  for a in op.pin_angles())
    lightening = tuple((float(x), float(y), spec.lightening_holes.radius) for x, y in spec.lightening_holes.centres())
    depth = d.pins.pin_radius if spec.port_depth is None else spec.port_depth
    return WheelGeometry(profile=prof, thickness=d.wheels.width, bores=((0.0, 0.0, rb),), holes=holes,
                         lightening=lightening, port_depth=float(depth))


def wheel_body_mesh(design, k=0, mesh_size=None):
    """:class:`WheelMesh` of wheel k of a cycloid design: issue 30's wheel body
    (:func:`rvtool.structure.wheel_body.wheel_body` on :func:`wheel_geometry`, the spec of
    ``[wheels.structure]``, ``mesh_size`` [m] replacing its mesh size when given), with its
    profile ports (one per profile sample, loads spread along the flank and through the width,
    displacements measured at the contact datum depth), the bore and the holes as the port
    operators."""
    from .wheel_body import wheel_spec
    from ..structure.floating_ports import port_operators_from_rows
    from ..structure.wheel_body import wheel_body
    d = design
    spec = wheel_spec(d, mesh_size)
    if spec.elasticity != "solid":
        raise RvtoolInputError(f"wheels.structure.elasticity = {spec.elasticity!r} with flexible wheels is not "
                               "implemented (the floating frame needs the 3D solid); valid: "
                               "wheels.structure.elasticity = 'solid'")
    wb = wheel_body(wheel_geometry(d, k, spec), spec, spec.material or d.material)
    ops = port_operators_from_rows(wb.fe, measure=wb.measure_matrix, load=wb.load_matrix,
                                   profile_rows=wb.rows("profile"), profile_points=wb.profile_points,
                                   bore_rows=wb.rows("bore0"),
                                   hole_rows=[wb.rows(f"hole{p}") for p in range(d.output_pins.n_pins)])
    return WheelMesh(model=wb.fe, operators=ops, source=f"issue 30 wheel body ({spec.samples_per_tooth} profile ports "
                                                          f"per tooth, mesh size {spec.mesh_size} m, {spec.layers} layers)")


def wheel_modes(design, k=0, *, mesh_key=None, mesh_of=None):
    """(:class:`~rvtool.structure.floating_ports.PlanarModalBody`, :class:`WheelMesh`,
    :class:`~rvtool.structure.floating_ports.PortOperators`) of wheel k of the design, meshed and
    reduced once per geometry and modal settings (cached in the process; ``frozen`` shares them).
    mesh_key, mesh_of: the cache key and a no-argument builder of the :class:`WheelMesh` (default:
    the cycloid wheel, :func:`wheel_mesh_key`, :func:`wheel_body_mesh`; the RV wheel's come from
    :mod:`rvtool.assembly.rv.flexible_wheels`)."""
    import dataclasses
    d = design
    dyn = d.wheels.dynamics
    wm_key = wheel_mesh_key(d, k) if mesh_key is None else mesh_key
    mesh_of = (lambda: wheel_body_mesh(d, k)) if mesh_of is None else mesh_of
    key = repr((wm_key, dataclasses.replace(dyn, frozen=False)))
    if key not in _CACHE:
        wm = _CACHE.get(wm_key) or mesh_of()
        _CACHE[wm_key] = wm
        ops = wm.operators
        # the free-free candidates of this mesh, computed once for the largest basis asked so far
        n_cand = 3 * dyn.n_modes + 6
        ff = _CACHE.get(("free_free", wm_key))
        if ff is None or ff["matrix"].shape[1] < n_cand:
            from ..structure import floating_basis
            ff = floating_basis(wm.model, n_modes=n_cand)
            _CACHE[("free_free", wm_key)] = ff
        st = None
        if dyn.static_orders >= 0:
            st = _CACHE.get(("static", wm_key, dyn.static_orders))
            if st is None:
                from ..structure.floating_ports import static_responses
                st = _CACHE[("static", wm_key, dyn.static_orders)] = static_responses(wm.model, ops, dyn.static_orders)
        body = planar_modal_body(wm.model, n_modes=dyn.n_modes, profile=wm.profile, bore=wm.bore, holes=wm.holes,
                                 damping_ratio=dyn.damping_ratio, centre=wm.centre, operators=ops,
                                 static_orders=dyn.static_orders, free_free=ff, static=st)
        _CACHE[key] = (body, wm, ops)
    return _CACHE[key]


@dataclass(frozen=True)
class PortFamily:
    """The virtual bodies of one contact family on the flexible wheels: ``base`` (n_v,) rigid body
    index or -1, ``frame`` (n_v,) the wheel's rigid-body index, ``sign`` (n_v,), ``wheel`` (n_v,)
    the wheel index k, ``kind`` ("profile", "bore" or "holes": the port group the family meets),
    ``port`` (n_v,) the hole index of each virtual body (kind "holes"), and
    ``operator(pose, load=False)`` -> (n_v, 3, n_fe): each virtual body's body-frame displacement
    (x, y) and rotation rows as operators on its wheel's FE coordinates, where the port measures
    (or, ``load``, where its force acts), a list of (3, n_fe of its wheel) arrays; the modal map of
    virtual body v is ``operator(pose)[v] @ Phi_k``."""
    base: np.ndarray
    frame: np.ndarray
    sign: np.ndarray
    wheel: np.ndarray
    operator: object
    kind: str = "profile"
    port: np.ndarray = None


class FloatingWheels:
    """The flexible wheels of one build, whatever the topology: the modal coordinates of every
    wheel (one :class:`~exudyn_user_elements.floating_ports.ModalCoordinates`) and the port maps
    of the contact families on them (module docstring).

    mbs; design; ground_marker: a ground coordinate marker; got: per wheel k the
    :func:`wheel_modes` triple; frames: the wheels' rigid-body indices; n_rigid: the rigid bodies
    of the contact elements (the virtual bodies follow them); pins: (z_b, 2) [m] the ring-pin
    centres (the contact locator). ``bodies``, ``meshes``, ``operators``: per wheel k;
    ``families`` maps contact-element names to their :class:`PortFamily` (filled by the topology,
    :meth:`family`); coordinates: a :class:`~exudyn_user_elements.floating_ports.ModalCoordinates`
    shared with other flexible bodies (holding ``wheel{k}``), or None (the wheels' own)."""

    def __init__(self, mbs, design, ground_marker, got, frames, n_rigid, pins, coordinates=None):
        from exudyn_user_elements.floating_ports import ModalCoordinates
        d = design
        self.design = d
        self.frames = tuple(int(f) for f in frames)
        self.nw = len(self.frames)
        self.n_rigid = int(n_rigid)
        self.pins = np.asarray(pins, float)
        self.bodies = [g[0] for g in got]
        self.meshes = [g[1] for g in got]
        self.operators = [g[2] for g in got]
        # one modal structure per build: a shared one (coordinates: with other flexible bodies) or the wheels' own
        self.coordinates = coordinates or ModalCoordinates(mbs, {f"wheel{k}": b for k, b in enumerate(self.bodies)},
                                                           frozen=d.wheels.dynamics.frozen,
                                                           ground_marker=ground_marker)
        self.n_eta = self.coordinates.n
        self.families = {}

    def _columns(self, k):
        return self.coordinates.slice(f"wheel{k}")

    # -- families ------------------------------------------------------------------
    def family(self, kind, base, wheel, sign, port=None):
        """:class:`PortFamily` of virtual bodies on the wheels ``wheel`` (n_v,) (indices k), each
        at ``base`` (n_v,) (-1: ground) moved by ``sign`` (n_v,) times its wheel's displacement at
        the port group ``kind``: "profile" (the contact with the ring pins, z_b virtual bodies per
        wheel, wheel after wheel), "bore" (the central bore's rigid fit) or "holes" (hole
        ``port[v]``'s mean translation)."""
        wheel = np.asarray(wheel, int)
        port = None if port is None else np.asarray(port, int)
        ops = self.operators
        if kind == "profile":
            zb = len(self.pins)

            def operator(pose, load=False):
                psi = self.contact_angles(pose)
                return [a for k in range(self.nw) for a in
                        np.concatenate([ops[k].profile_at(psi[k], load), np.zeros((zb, 1, ops[k].n))], axis=1)]
        elif kind == "bore":
            def operator(pose, load=False):
                return [(ops[k].load("bore") if load else ops[k].bore).toarray() for k in wheel]
        elif kind == "holes":
            def operator(pose, load=False):
                return [np.vstack([(ops[k].load("holes") if load else ops[k].holes)[2 * p:2 * p + 2].toarray(),
                                   np.zeros((1, ops[k].n))]) for k, p in zip(wheel, port)]
        else:
            raise RvtoolInputError(f"port group {kind!r}; valid: 'profile', 'bore', 'holes'")
        return PortFamily(np.asarray(base, int), np.asarray([self.frames[k] for k in wheel], int),
                          np.asarray(sign, float), wheel, operator, kind, port)

    def ports(self, name):
        """:class:`~exudyn_user_elements.floating_ports.FloatingPorts` of contact element ``name``
        on the modal coordinates (the modal body's own tables: the family's operators times the
        retained modes)."""
        from exudyn_user_elements.floating_ports import FloatingPorts
        fam = self.families[name]
        nw = self.nw
        split = any(b.split for b in self.bodies)
        if fam.kind == "profile":
            zb = len(self.pins)

            def maps(pose, load=False):
                psi = self.contact_angles(pose)
                A = np.zeros((nw * zb, 3, self.n_eta))
                for k in range(nw):
                    A[k * zb:(k + 1) * zb, :2, self._columns(k)] = self.bodies[k].profile_map(psi[k], load)
                return A
            return FloatingPorts(self.coordinates, self.n_rigid, fam.base, fam.frame, fam.sign, maps,
                                 (lambda pose: maps(pose, True)) if split else None)

        return FloatingPorts(self.coordinates, self.n_rigid, fam.base, fam.frame, fam.sign, self.table(name),
                             self.table(name, True) if split else None)

    def table(self, name, load=False):
        """(n_v, 3, n_eta) the constant port maps of a bore or hole family ``name`` (measured, or ``load``)."""
        fam = self.families[name]
        A = np.zeros((len(fam.base), 3, self.n_eta))
        for v, k in enumerate(fam.wheel):
            b = self.bodies[k]
            A[v, :, self._columns(k)] = (b.map_of("bore", load) if fam.kind == "bore" else
                                         np.vstack([b.map_of("holes", load)[fam.port[v]], np.zeros(b.n_modes)]))
        return A

    # -- ring pins ---------------------------------------------------------------
    def pin_bodies(self, k):
        """Virtual pin-body indices of wheel k's mesh (after the rigid bodies, wheel after wheel)."""
        zb = len(self.pins)
        return tuple(self.n_rigid + k * zb + p for p in range(zb))

    @property
    def n_pin_bodies(self):
        return self.n_rigid + self.nw * len(self.pins)

    def contact_angles(self, pose):
        """(nw, z_b) polar angle [rad] in each wheel's frame of the contact point with every pin
        (the pitch-point locator of the module docstring)."""
        d = self.design
        P = self.pins
        out = np.zeros((self.nw, len(P)))
        for k, f in enumerate(self.frames):
            o = pose[f, :2]
            r = math.hypot(*o)
            u = o / r if r > 0 else np.array([math.cos(d.wheels.phases[k]), math.sin(d.wheels.phases[k])])
            pitch = d.pins.n_pins * d.wheels.eccentricity * u
            n = P - pitch
            n /= np.linalg.norm(n, axis=1)[:, None]
            C = P - d.pins.pin_radius * n - o
            th = pose[f, 2]
            c, s = math.cos(th), math.sin(th)
            out[k] = np.arctan2(-s * C[:, 0] + c * C[:, 1], c * C[:, 0] + s * C[:, 1])
        return out

    def summary(self):
        """Reported facts of the flexible wheels: source, mesh counts, retained frequencies [Hz] per wheel."""
        return {"source": self.meshes[0].source, "mesh": [m.model.counts() for m in self.meshes],
                "n_modes": self.design.wheels.dynamics.n_modes,
                "static_orders": self.design.wheels.dynamics.static_orders,
                "n_coordinates": [b.n_modes for b in self.bodies],
                "frequencies_hz": [b.frequencies_hz.tolist() for b in self.bodies],
                "in_plane_fraction": [b.in_plane.tolist() for b in self.bodies],
                "mesh_mass_kg": [b.mesh_mass for b in self.bodies],
                "mesh_inertia_kgm2": [b.mesh_inertia for b in self.bodies],
                "frozen": self.design.wheels.dynamics.frozen}


class FlexibleWheels(FloatingWheels):
    """The flexible wheels of one cycloid build (module docstring): wheel k is body 1 + k, the
    families "pins", "output_pins" and "bearings" (the contact-element names) on them."""

    def __init__(self, mbs, design, ground_marker):
        from ..geometry.cycloid import pin_centres
        d = design
        nw = d.n_wheels
        got = [wheel_modes(d, k) for k in range(nw)]
        for b, _, _ in got:
            if b.bore_map is None:
                raise RvtoolInputError("the wheel mesh has no bore ports; the eccentric bearing cannot couple")
            if len(b.hole_maps) != d.output_pins.n_pins:
                raise RvtoolInputError(f"the wheel mesh has {len(b.hole_maps)} hole port groups for "
                                       f"output_pins.n_pins = {d.output_pins.n_pins}; valid: one per pin")
        super().__init__(mbs, d, ground_marker, got, frames=[1 + k for k in range(nw)], n_rigid=nw + 2,
                         pins=pin_centres(d.profile))
        zb, npins = d.pins.n_pins, d.output_pins.n_pins
        wheel = np.arange(nw)
        # ring pins: pin p at wheel k is the virtual body nw + 2 + k z_b + p (ground less the wheel's displacement)
        pins_w = np.repeat(wheel, zb)
        # output pins: the flange's station body of (pin p, wheel k) is nw + 2 + p nw + k, the flange less hole p's
        out_w = np.tile(wheel, npins)
        self.families = {
            "pins": self.family("profile", np.full(nw * zb, -1), pins_w, np.full(nw * zb, -1.0)),
            "output_pins": self.family("holes", np.full(npins * nw, nw + 1), out_w, np.full(npins * nw, -1.0),
                                       port=np.repeat(np.arange(npins), nw)),
            # eccentric bearings (lumped): wheel k's bore is the virtual body nw + 2 + k, its pose plus the bore's fit
            "bearings": self.family("bore", 1 + wheel, wheel, np.ones(nw))}

    def output_pin_stations(self):
        """(n_pins, n_wheels) station-body offsets p nw + k: the flange's station body of (pin p,
        wheel k) is nw + 2 + p nw + k, the flange shifted by minus hole p's displacement."""
        return np.arange(self.design.output_pins.n_pins * self.nw).reshape(-1, self.nw)


def check_flexible_wheels(design, bearing_model, tilt):
    """Named refusals of the combinations flexible wheels do not implement (yet)."""
    d = design
    reasons = []
    if getattr(d.wheels, "body", "rigid") != "rigid":
        reasons.append(f"wheels.body = {d.wheels.body!r} (the wheel body's compliance would be counted twice: the "
                       "flexible wheel carries it; valid: 'rigid')")
    if d.housing.model != "rigid":
        reasons.append("housing.model = 'ports' (the merged element carries one structure; valid: 'rigid')")
    if d.pins.support.elastic or d.output_pins.support.elastic:
        reasons.append("elastic ring or output pins (pins.support / output_pins.support; valid: model = 'rigid')")
    if bearing_model != "lumped":
        reasons.append(f"bearing_model = {bearing_model!r} (the bore couples to the lumped eccentric bearing; valid: "
                       "build(..., bearing_model='lumped'))")
    if tilt:
        reasons.append("bodies.flange_coordinates or bodies.wheel_coordinates = 'spatial' (valid: 'planar')")
    if d.bearing_friction.model != "none":
        reasons.append(f"bearing_friction.model = {d.bearing_friction.model!r} (valid: 'none')")
    if reasons:
        raise RvtoolInputError("wheels.dynamics.model = 'flexible' is not implemented with " + "; ".join(reasons))
