"""Rolling-element bearings of a cycloid reducer design (the ``bearing_model="rolling"`` path)."""
import math

from ..contact.circle_set import GROUND
from ..geometry.eccentric import journal_centre
from .set import BearingSet, Mounting
from .spec import AngularContactPair, BallBearing


def _ball_row(spec, material):
    return BallBearing(n_balls=spec.n_balls, ball_diameter=spec.ball_diameter, pitch_diameter=spec.pitch_diameter,
                       contact_angle=math.radians(spec.contact_angle_deg), inner_curvature=spec.groove_curvature_ratio,
                       outer_curvature=spec.groove_curvature_ratio, youngs_modulus=material.youngs_modulus,
                       poisson_ratio=material.poisson_ratio, radial_clearance=spec.radial_clearance,
                       axial_preload=spec.axial_preload)


def rolling_bearing_sets(design, n_wheels, *, backend="warp", precision="float64", device="cpu"):
    """{"bearings": BearingSet} with the eccentric needle bearings (shaft journal -> wheel bore),
    the main angular-contact pair (flange -> housing, back to back) and the two input ball
    bearings (shaft -> housing), body indices as in :mod:`rvtool.assembly.cycloid`
    (0 shaft, 1..n_wheels wheels, n_wheels + 1 flange)."""
    d = design
    needle = d.eccentric_bearing            # the design section is the component spec
    mounts = []
    for k in range(n_wheels):
        centre = journal_centre(d.wheels.eccentricity, math.radians(d.wheels.phases_deg[k]))
        mounts.append(Mounting(name=f"eccentric_bearing{k}", bearing=needle, inner=0, outer=1 + k,
                               inner_centre=tuple(float(c) for c in centre)))
    mb = d.main_bearing
    if mb.kind != "locked":
        row = _ball_row(mb, d.material)
        bearing = AngularContactPair(rows=(row, row), row_spacing=mb.row_spacing) if mb.kind == "angular_contact_pair" \
            else row
        mounts.append(Mounting(name="main_bearing", bearing=bearing, inner=n_wheels + 1, outer=GROUND))
    ib = d.input_bearing
    if ib.kind != "locked":
        row = _ball_row(ib, d.material)
        for k in range(2):
            mounts.append(Mounting(name=f"input_bearing{k}", bearing=row, inner=0, outer=GROUND,
                                   cage_phase=k * math.pi / row.n_balls))
    return {"bearings": BearingSet(mounts, n_wheels + 2, name="bearings", backend=backend, precision=precision,
                                   device=device)}
