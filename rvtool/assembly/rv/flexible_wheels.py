"""Flexible RV wheels as floating bodies (``[wheels.dynamics] model = "flexible"`` on an RV design, issue 33).

The RV counterpart of :mod:`rvtool.assembly.flexible_wheels` (the formulation, the modal
coordinates and the ports are the same; planar dynamics). Each wheel j keeps its planar rigid
node (body ``Layout.wheel(j)``) as the floating frame and gains ``n_modes`` in-plane free-free
modes plus the static correction of issue 30's RV wheel body (:func:`rvtool.assembly.wheel_body.wheel_model`:
the profile turned to the wheel's assembly phase, the crank bores on the crank circle, its
profile ports on the profile samples and one port group per crank bore). The families on a wheel
couple through the ports:

* ring pins: pin p at wheel j is the virtual body n_bodies + j z_b + p, at minus the wheel's
  elastic displacement at the contact (the profile ports interpolated at the pitch-point
  locator's polar angle, as for the cycloid drive);
* needle (eccentric) bearings: the bearing of crank k in wheel j's bore k has its outer ring on
  the virtual body n_bodies + n_w z_b + i (i the mounting's index in
  :func:`rvtool.assembly.rv.builder.needle_mountings`, crank after crank): wheel j's pose plus
  bore k's mean translation (the bore is carried as a rigid ring; its ovalization is not passed
  to the needle row, and the bore's rotation row is zero, as in issue 30's closure).

The crank bores are the wheel body's holes (``PortOperators.holes``; the RV wheel has no central
bore), so the static correction adds unit x, y loads at every crank bore. The frame carries the
builder's rigid mass and inertia (:func:`rvtool.assembly.rv.builder.wheel_mass`): frozen
flexible wheels are the rigid wheels bit for bit.
"""
import dataclasses

import numpy as np

from ...errors import RvtoolInputError
from ..flexible_wheels import FloatingWheels, WheelMesh, wheel_modes


def wheel_mesh(design, j):
    """:class:`~rvtool.assembly.flexible_wheels.WheelMesh` of RV wheel j: issue 30's wheel body
    with its profile ports and the crank bores as hole ports (module docstring)."""
    from ...structure.floating_ports import port_operators_from_rows
    from ..wheel_body import wheel_model, wheel_spec
    d = design
    spec = wheel_spec(d)
    if spec.bore_ports:
        raise RvtoolInputError(f"wheels.structure.bore_ports = {spec.bore_ports} with wheels.dynamics.model = "
                               "'flexible' is not implemented (the floating wheel's crank bores are mean-motion hole "
                               "ports); valid: wheels.structure.bore_ports = 0 for flexible wheels")
    if spec.elasticity != "solid":
        raise RvtoolInputError(f"wheels.structure.elasticity = {spec.elasticity!r} with wheels.dynamics.model = "
                               "'flexible' is not implemented (the floating frame needs the 3D solid); valid: "
                               "wheels.structure.elasticity = 'solid' for flexible wheels")
    wb = wheel_model(d, j)
    holes = [wb.rows(f"bore{k}") for k in range(d.cranks.count)]
    ops = port_operators_from_rows(wb.fe, measure=wb.measure_matrix, load=wb.load_matrix,
                                   profile_rows=wb.rows("profile"), profile_points=wb.profile_points, hole_rows=holes)
    return WheelMesh(model=wb.fe, operators=ops,
                     source=f"issue 30 RV wheel body ({spec.samples_per_tooth} profile ports per tooth, mesh size "
                            f"{spec.mesh_size} m, {spec.layers} layers; crank bores as hole ports)")


def rv_wheel_modes(design, j):
    """:func:`~rvtool.assembly.flexible_wheels.wheel_modes` of RV wheel j (cached per geometry)."""
    from ..wheel_body import wheel_geometry, wheel_spec
    d = design
    spec = wheel_spec(d)
    key = repr(("rv_mesh", wheel_geometry(d, j, spec), spec, spec.material or d.material, d.cranks.count))
    return wheel_modes(d, j, mesh_key=key, mesh_of=lambda: wheel_mesh(d, j))


def check_rv_flexible_wheels(design):
    """Named refusals of the RV combinations flexible wheels do not implement (yet)."""
    d = design
    others = {"wheels.body": (d.wheels.body, "rigid", "the flexible wheel carries the wheel body's compliance; "
                                                      "counted twice"),
              "housing.model": (d.housing.model, "rigid", "the merged element carries one structure"),
              "pins.groove": (d.pins.groove, "rigid", "the groove stations would sit on the pins' port bodies"),
              "cranks.shaft.model": (d.cranks.shaft.model, "rigid", "the needles sit inside the crank closure"),
              "cranks.shaft.torsion": (d.cranks.shaft.torsion, "rigid", "the needles sit inside the crank closure"),
              "bodies.wheel_coordinates": (d.bodies.wheel_coordinates, "planar", "planar dynamics only"),
              "bodies.crank_coordinates": (d.bodies.crank_coordinates, "planar", "planar dynamics only"),
              "bodies.carrier_coordinates": (d.bodies.carrier_coordinates, "planar", "planar dynamics only"),
              "bodies.input_coordinates": (d.bodies.input_coordinates, "planar", "planar dynamics only")}
    bad = [f"{key} = {value!r} ({why}; valid: {valid!r})" for key, (value, valid, why) in others.items()
           if value != valid]
    if bad:
        raise RvtoolInputError("wheels.dynamics.model = 'flexible' on an RV design is not implemented with "
                               + "; ".join(bad))


class RvFlexibleWheels(FloatingWheels):
    """The flexible wheels of one RV build (module docstring): families "pins" and
    "eccentric_bearings" (the contact-element names). mbs; design; ground_marker; graph: the
    :class:`~rvtool.assembly.rv.gear_graph.GearGraph`; layout: the builder's ``Layout``; coordinates:
    a shared modal structure (:class:`rvtool.assembly.rv.flexible_cranks.RvFloatingBodies`) or None."""

    def __init__(self, mbs, design, ground_marker, graph, layout, coordinates=None):
        from ...geometry.cycloid import pin_centres
        check_rv_flexible_wheels(design)
        d, L = design, layout
        nw = d.n_wheels
        got = [rv_wheel_modes(d, j) for j in range(nw)]
        for b, _, _ in got:
            if len(b.hole_maps) != L.n_cranks:
                raise RvtoolInputError(f"the wheel mesh has {len(b.hole_maps)} crank-bore port groups for "
                                       f"cranks.count = {L.n_cranks}; valid: one per crank")
        errors = None if d.pins.centre_errors is None else np.asarray(d.pins.centre_errors, float)
        super().__init__(mbs, d, ground_marker, got, frames=[L.wheel(j) for j in range(nw)], n_rigid=L.n_bodies,
                         pins=pin_centres(d.profile, errors), coordinates=coordinates)
        self.graph, self.layout = graph, L
        zb = d.pins.n_pins
        wheel = np.arange(nw)
        from .builder import needle_mountings
        mounts = needle_mountings(d, graph, L)
        mw = np.array([m.outer - L.wheel0 for m in mounts])
        mk = np.array([m.inner - L.crank0 for m in mounts])
        self.families = {
            "pins": self.family("profile", np.full(nw * zb, -1), np.repeat(wheel, zb), np.full(nw * zb, -1.0)),
            "eccentric_bearings": self.family("holes", [L.wheel(j) for j in mw], mw, np.ones(len(mounts)), port=mk)}

    def pin_meshes(self, meshes):
        """The builder's wheel--pin meshes with the pins on their virtual bodies."""
        return [dataclasses.replace(m, pin_bodies=self.pin_bodies(j)) for j, m in enumerate(meshes)]

    def needles(self, opts):
        """The needle :class:`~rvtool.bearings.set.BearingSet` with every outer ring on its bore's
        virtual body (module docstring); ``opts``: the builder's backend options."""
        from ...bearings.set import BearingSet
        from .builder import needle_mountings
        mounts = needle_mountings(self.design, self.graph, self.layout)
        first = self.n_rigid
        mounts = [dataclasses.replace(m, outer=first + i) for i, m in enumerate(mounts)]
        return BearingSet(mounts, first + len(mounts), name="eccentric_bearings", **opts)
