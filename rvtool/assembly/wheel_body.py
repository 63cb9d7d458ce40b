"""The cycloid wheel body of an RV design as an elastic member of the torque path (issue 30).

Public API (also used by the flexible wheels of dynamic runs, issue 33):

* :func:`wheel_geometry` (design, wheel) -> :class:`~rvtool.structure.wheel_body.WheelGeometry`:
  wheel ``wheel``'s profile as its contact law sees it (the design's profile turned to the wheel's
  assembly phase, :func:`rvtool.assembly.cycloid.pin_meshes`), thickness ``wheels.width``, the
  crank bores (on the crank circle at the cranks' angles, radius = the needle set's outer raceway
  ``eccentric_bearing.inner_radius + roller_diameter``), the pillar and lightening holes of
  ``[wheels.structure]``, the profile ports' datum depth;
* :func:`wheel_model` (design, wheel=0, mesh_size=None) -> :class:`~rvtool.structure.wheel_body.WheelBody`:
  the free FE wheel with named port groups ``profile``, ``bore{k}`` (crank k), ``hole{k}``; cached
  per (geometry, spec, material) within a process (it costs seconds).

The wheel frame is the wheel body's frame of the RV model: origin at the wheel centre, turning
with the carrier (:class:`rvtool.assembly.rv.builder.RvKinematics`).
"""
import dataclasses
import functools
import math

from ..structure.wheel_body import WheelBodySpec, WheelGeometry, wheel_body


def wheel_spec(design, mesh_size=None):
    """The design's :class:`WheelBodySpec` (``[wheels.structure]`` or the defaults), with
    ``mesh_size`` [m] replaced when given."""
    spec = design.wheels.structure or WheelBodySpec()
    return spec if mesh_size is None else dataclasses.replace(spec, mesh_size=float(mesh_size))


def wheel_geometry(design, wheel=0, spec=None):
    """:class:`WheelGeometry` of wheel ``wheel`` of an RV design (module docstring)."""
    from .rv.gear_graph import GearGraph
    spec = wheel_spec(design) if spec is None else spec
    g = GearGraph.of(design)
    zg = design.pins.n_pins - 1
    prof = dataclasses.replace(design.profile, rotation_mod=design.profile.rotation_mod - design.wheels.phases[wheel] / zg)
    rb = design.eccentric_bearing.inner_radius + design.eccentric_bearing.roller_diameter
    bores = tuple((g.crank_radius * math.cos(b), g.crank_radius * math.sin(b), rb) for b in g.crank_angles)

    def circles(hs):
        return tuple((float(x), float(y), hs.radius) for x, y in hs.centres())
    depth = design.pins.pin_radius if spec.port_depth is None else spec.port_depth
    return WheelGeometry(profile=prof, thickness=design.wheels.width, bores=bores, holes=circles(spec.pillar_holes),
                         lightening=circles(spec.lightening_holes), port_depth=float(depth))


@functools.lru_cache(maxsize=8)
def _model(geometry, spec, material):
    return wheel_body(geometry, spec, material)


def wheel_model(design, wheel=0, mesh_size=None):
    """The free FE wheel ``wheel`` of ``design`` with its port groups (module docstring); the
    material is ``[wheels.structure.material]`` or the design's ``[material]``."""
    spec = wheel_spec(design, mesh_size)
    material = spec.material or design.material
    return _model(wheel_geometry(design, wheel, spec), spec, material)
