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

from ..errors import RvtoolInputError
from ..structure.wheel_body import WheelBodySpec, WheelGeometry, wheel_body


def wheel_spec(design, mesh_size=None):
    """The design's :class:`WheelBodySpec` (``[wheels.structure]`` or the defaults), with
    ``mesh_size`` [m] replaced when given."""
    spec = design.wheels.structure or WheelBodySpec()
    return spec if mesh_size is None else dataclasses.replace(spec, mesh_size=float(mesh_size))


def circles(hs):
    """((x, y, r), ...) [m] of a :class:`~rvtool.structure.wheel_body.HoleSet`."""
    return tuple((float(x), float(y), hs.radius) for x, y in hs.centres())


def port_depth_limit(design, spec=None):
    """(crank-bore limit, rim limit) [m] of ``wheels.structure.port_depth`` for the design's geometry (the checks of
    :func:`wheel_geometry`): a depth must lie below half the ligament between root circle and crank bore (strictly)
    and leave the pillar and lightening holes inside root radius less depth (up to 1e-9 m). Both follow from the
    drawn pins, eccentricity, crank radius and eccentric bearing (inner radius + roller diameter = bore radius)."""
    from .rv.gear_graph import GearGraph
    spec = wheel_spec(design) if spec is None else spec
    g = GearGraph.of(design)
    rb = design.eccentric_bearing.inner_radius + design.eccentric_bearing.roller_diameter
    root = design.pins.pin_circle_radius - design.pins.pin_radius - design.wheels.eccentricity
    rim = math.inf
    for hs in (spec.pillar_holes, spec.lightening_holes):
        for x, y, r in circles(hs):
            rim = min(rim, root - math.hypot(x, y) - r - 1e-9)
    return 0.5 * (root - g.crank_radius - rb), rim


def wheel_geometry(design, wheel=0, spec=None):
    """:class:`WheelGeometry` of wheel ``wheel`` of an RV design (module docstring)."""
    from .rv.gear_graph import GearGraph
    spec = wheel_spec(design) if spec is None else spec
    g = GearGraph.of(design)
    zg = design.pins.n_pins - 1
    prof = dataclasses.replace(design.profile, rotation_mod=design.profile.rotation_mod - design.wheels.phases[wheel] / zg)
    rb = design.eccentric_bearing.inner_radius + design.eccentric_bearing.roller_diameter
    bores = tuple((g.crank_radius * math.cos(b), g.crank_radius * math.sin(b), rb) for b in g.crank_angles)

    depth = design.pins.pin_radius if spec.port_depth is None else spec.port_depth
    root = design.pins.pin_circle_radius - design.pins.pin_radius - design.wheels.eccentricity
    if depth >= port_depth_limit(design, spec)[0]:
        raise RvtoolInputError(f"wheels.structure.port_depth = {depth} m reaches the crank bores; valid range [0, "
                               f"{0.5 * (root - g.crank_radius - rb):.4g}) m")
    circles_all = list(bores)
    for key, hs in (("pillar_holes", spec.pillar_holes), ("lightening_holes", spec.lightening_holes)):
        for x, y, r in circles(hs):
            if math.hypot(x, y) + r > root - depth - 1e-9:
                raise RvtoolInputError(f"wheels.structure.{key}: a hole of radius {r} m on circle_radius "
                                       f"{hs.circle_radius} m reaches the rim (root radius {root:.4g} m less "
                                       f"port_depth); valid: circle_radius + radius < {root - depth:.4g} m")
            for xo, yo, ro in circles_all:
                if math.hypot(x - xo, y - yo) < r + ro + 1e-9:
                    raise RvtoolInputError(f"wheels.structure.{key}: a hole at ({x:.4g}, {y:.4g}) m cuts another "
                                           "hole or a crank bore; valid: disjoint holes (change angle_deg, "
                                           "circle_radius or radius)")
            circles_all.append((x, y, r))
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
