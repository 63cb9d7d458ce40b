"""Rolling-element bearings of a cycloid reducer design (the ``bearing_model="rolling"`` path)."""
import math

from ..contact.circle_set import GROUND
from .set import BearingSet, Mounting
from .spec import AngularContactPair, BallBearing, RollerBearing


def preload_axial_force(row, offset):
    """Axial force [N] of ``row`` at zero radial displacement and axial approach ``offset`` [m]:
    Z K delta^(3/2) a_z / |a| with a = (A cos alpha_0, A sin alpha_0 + s_a), Eq. (ball_bearing)."""
    A, al = row.groove_centre_distance, row.contact_angle
    ar, az = A * math.cos(al), A * math.sin(al) + offset
    L = math.hypot(ar, az)
    delta = max(L - A - row.radial_clearance, 0.0)
    return row.n_balls * row.stiffness * delta ** 1.5 * az / L


def preload_offset(row, axial_preload):
    """Axial approach s_a [m] at which ``row`` carries ``axial_preload`` [N] (solved exactly with
    the working contact angle)."""
    if axial_preload <= 0 or row.contact_angle <= 0:
        return 0.0
    from scipy.optimize import brentq
    hi = 1e-6
    while preload_axial_force(row, hi) < axial_preload:
        hi *= 2
    return brentq(lambda s: preload_axial_force(row, s) - axial_preload, 0.0, hi, xtol=1e-15, rtol=1e-13)


def rolling_bearing_sets(design, n_wheels, *, backend="warp", precision="float64", device="cpu"):
    """{"bearings": BearingSet} with the eccentric needle bearings (shaft journal -> wheel bore),
    the main angular-contact pair (flange -> housing) and the two input ball bearings
    (shaft -> housing), body indices as in :mod:`rvtool.assembly.cycloid`."""
    d = design
    eb = d.eccentric_bearing
    needle = RollerBearing(inner_radius=eb.journal_radius, roller_diameter=eb.roller_diameter,
                           roller_length=eb.roller_length, n_rollers=eb.n_rollers, radial_clearance=eb.radial_clearance,
                           n_slices=eb.n_slices)
    mounts = []
    for k in range(n_wheels):
        phi = math.radians(d.wheels.phases_deg[k])
        e = d.wheels.eccentricity
        mounts.append(Mounting(name=f"eccentric_bearing{k}", bearing=needle, inner=0, outer=1 + k,
                               inner_centre=(-e * math.sin(phi), e * math.cos(phi))))
    mb = d.main_bearing
    if mb.kind != "locked":
        row = BallBearing(n_balls=mb.n_balls, ball_diameter=mb.ball_diameter, pitch_diameter=mb.pitch_diameter,
                          contact_angle=math.radians(mb.contact_angle_deg), inner_curvature=mb.groove_curvature_ratio,
                          outer_curvature=mb.groove_curvature_ratio, radial_clearance=mb.radial_clearance)
        if mb.kind == "angular_contact_pair":
            import dataclasses
            row = dataclasses.replace(row, axial_preload_offset=preload_offset(row, mb.axial_preload))
            bearing = AngularContactPair(row=row, row_spacing=mb.row_spacing)
        else:
            bearing = row
        mounts.append(Mounting(name="main_bearing", bearing=bearing, inner=n_wheels + 1, outer=GROUND))
    ib = d.input_bearing
    if ib.kind != "locked":
        row = BallBearing(n_balls=ib.n_balls, ball_diameter=ib.ball_diameter, pitch_diameter=ib.pitch_diameter,
                          contact_angle=math.radians(ib.contact_angle_deg), inner_curvature=ib.groove_curvature_ratio,
                          outer_curvature=ib.groove_curvature_ratio, radial_clearance=ib.radial_clearance)
        for k in range(2):
            mounts.append(Mounting(name=f"input_bearing{k}", bearing=row, inner=0, outer=GROUND,
                                   cage_phase=k * math.pi / row.n_balls))
    return {"bearings": BearingSet(mounts, n_wheels + 2, name="bearings", backend=backend, precision=precision,
                                   device=device)}
