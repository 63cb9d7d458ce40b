"""Rolling-element bearings of a cycloid reducer design (the ``bearing_model="rolling"`` path)."""
import math

from ..contact.circle_set import GROUND
from ..geometry.eccentric import journal_centre
from .set import BearingSet, Mounting
from .spec import AngularContactPair


def ball_rows(spec):
    """The rows of a ball-bearing spec: a pair's two rows, or the one row."""
    return spec.rows if isinstance(spec, AngularContactPair) else (spec,)


def main_bearing_mounting(design, n_wheels):
    """The main bearing (flange -> housing) of a cycloid design, or None."""
    if design.main_bearing is None:
        return None
    return Mounting(name="main_bearing", bearing=design.main_bearing, inner=n_wheels + 1, outer=GROUND)


def rolling_bearing_sets(design, n_wheels, *, backend="warp", precision="float64", device="cpu", main=True):
    """{"bearings": BearingSet} with the eccentric needle bearings (shaft journal -> wheel bore),
    the main angular-contact pair (flange -> housing, back to back; left out with ``main=False``:
    a spatial flange carries it in its own element) and the two input ball bearings
    (shaft -> housing), body indices as in :mod:`rvtool.assembly.cycloid`
    (0 shaft, 1..n_wheels wheels, n_wheels + 1 flange)."""
    d = design
    needle = d.eccentric_bearing            # each bearing section of the design is its component spec
    mounts = []
    for k in range(n_wheels):
        centre = journal_centre(d.wheels.eccentricity, d.wheels.phases[k])
        mounts.append(Mounting(name=f"eccentric_bearing{k}", bearing=needle, inner=0, outer=1 + k,
                               inner_centre=tuple(float(c) for c in centre)))
    if main and d.main_bearing is not None:
        mounts.append(main_bearing_mounting(d, n_wheels))
    ib = d.input_bearing
    if ib is not None:
        n_balls = ball_rows(ib)[0].n_balls
        for k in range(2):
            mounts.append(Mounting(name=f"input_bearing{k}", bearing=ib, inner=0, outer=GROUND,
                                   cage_phase=k * math.pi / n_balls))
    return {"bearings": BearingSet(mounts, n_wheels + 2, name="bearings", backend=backend, precision=precision,
                                   device=device)}
