"""Guide-spring homotopy: an equilibrium under changed loads reached from a previous one
through free play.

Where free play (bearing clearances, gear backlash) leaves some coordinates of a state held
only by the weak regularization springs, the tangent there is nearly singular in those
directions (measured on rv40e with 3 um needle clearance and a 10 um tooth thickness
allowance: the six smallest eigenvalues of the free stiffness at zero load are the
regularization stiffnesses 0.1-0.5 N m/rad, against 8e9 at the top), and a full Newton step
to a loaded level moves a crank by hundreds of radians; halving the load increment does not
help because any nonzero increment is carried by the same near-null directions.

The homotopy adds guide springs g_i = f k_i in parallel with every regularization spring k_i,
centred on the previous equilibrium q_0, and solves at the new load for f descending from
:data:`FACTORS` (1e6 down to 0): the first solves are local (the guides hold every coordinate
near q_0 while the contacts engage), each next solve starts from the last, and the final
solve (f = 0) is the unmodified problem, so the accepted equilibrium carries no guide force
at all. Two parallel linear springs are exactly one (stiffness k + g, stiffness-weighted
offset), so nothing is added to the Exudyn system and the springs are restored afterwards.
The guides start from the previous equilibrium, not from the kinematic state, so the
committed contact history (friction anchors) and the branch are those of the continuation.
"""
import math

import numpy as np

FACTORS = (1e6, 1e5, 1e4, 1e3, 1e2, 1e1, 1.0, 0.1, 0.0)
"""Guide stiffness factors (multiples of each regularization spring's build stiffness) in order."""

MIN_RATIO = 1.5
"""A failed stage is bisected (geometric mean, or a tenth towards 0) until two adjacent
factors differ by less than this ratio; then the homotopy fails."""


class GuideSprings:
    """Guide springs centred on ``anchor`` (a state vector) in parallel with ``model``'s
    regularization springs (:mod:`rvtool.solver.guide`); a context manager restoring the springs."""

    def __init__(self, model, anchor):
        self.model = model
        mbs = model.mbs
        self.rows = [(model.coordinate_index(body, c), k_build, obj, float(mbs.GetObjectParameter(obj, "stiffness")),
                      float(mbs.GetObjectParameter(obj, "offset"))) for body, c, k_build, obj in model.reg_springs]
        self.anchor = np.asarray(anchor, float).copy()
        self.factor = 0.0

    def apply(self, factor):
        """Guides of stiffness ``factor`` x the build stiffness of each regularization spring."""
        mbs = self.model.mbs
        for i, k_build, obj, k, off in self.rows:
            g = factor * k_build
            mbs.SetObjectParameter(obj, "stiffness", k + g)
            mbs.SetObjectParameter(obj, "offset", (k * off + g * self.anchor[i]) / (k + g))
        self.factor = factor

    def force(self, q):
        """Largest force [N] or moment [N m] the guides carry at state q."""
        return max((abs(self.factor * k_build * (q[i] - self.anchor[i])) for i, k_build, *_ in self.rows), default=0.0)

    def restore(self):
        self.apply(0.0)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.restore()


def guided_newton(model, newton, anchor, *, factors=FACTORS, min_ratio=MIN_RATIO):
    """Equilibrium of ``model`` under its current loads and controls by the guide homotopy from
    ``anchor`` (module docstring). ``newton(q_start)`` -> (ok, q) is one warm-started Newton
    solve. Returns (ok, q, report); report: ``stages`` (solves), ``factors`` (the accepted
    factors in order), ``guide_force_last`` (largest guide force at the last guided stage
    before the release, [N or N m]); the accepted state (factor 0) carries no guide force."""
    if not model.reg_springs:
        return False, None, {"stages": 0, "factors": [], "guide_force_last": None}
    todo = list(factors)
    if todo[-1] != 0.0:
        todo.append(0.0)
    done, q, stages, last_force = [], np.asarray(anchor, float).copy(), 0, 0.0
    with GuideSprings(model, anchor) as guide:
        while todo:
            f = todo[0]
            guide.apply(f)
            ok, q_new = newton(q)
            stages += 1
            if ok:
                if f > 0.0:
                    last_force = guide.force(q_new)
                q = q_new
                done.append(todo.pop(0))
                continue
            if not done:
                # the stiffest stage failed: stiffen further (the guides then hold q near the anchor)
                f_new = 10.0 * f
                if f_new > 1e12:
                    break
                todo.insert(0, f_new)
                continue
            f_prev = done[-1]
            f_mid = f_prev / 10.0 if f == 0.0 else math.sqrt(f_prev * f)
            if f == 0.0 and f_mid < 1e-3:
                break
            if f > 0.0 and f_prev / f < min_ratio:
                break
            todo.insert(0, f_mid)
        else:
            return True, q, {"stages": stages, "factors": done, "guide_force_last": last_force}
    return False, None, {"stages": stages, "factors": done, "guide_force_last": last_force}
