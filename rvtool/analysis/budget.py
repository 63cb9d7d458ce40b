"""The lost-motion budget of a design (one model per clearance state: the building is a
study's; the stiffness budget of one built model is :func:`rvtool.protocols.budget.stiffness_budget`)."""
import time

from ..assembly import build
from ..protocols.lost_motion import lost_motion
from ..units import RAD_PER_ARCMIN


def lost_motion_budget(design, *, fraction=0.03, bearing_model="rolling", input_angle=0.0):
    """Lost motion [arcmin] at +-fraction T_rated split into ``elastic`` and one contribution per
    clearance of the model (module docstring); ``estimates_arcmin`` are the closed forms."""
    t0 = time.perf_counter()
    model = build(design, bearing_model=bearing_model)
    variants = model.clearance_variants()
    level = fraction * design.rated_torque
    # elastic: every clearance removed; then restored one at a time in the declared order
    current = design
    for v in variants:
        current = v.remove(current)
    lm = [lost_motion(build(current, bearing_model=bearing_model), torque_level=level,
                      input_angle=input_angle)["lost_motion_rad"]]
    for v in variants:
        current = v.restore(current, design)
        lm.append(lost_motion(build(current, bearing_model=bearing_model), torque_level=level,
                              input_angle=input_angle)["lost_motion_rad"])
    out = {"elastic": lm[0] / RAD_PER_ARCMIN}
    for k, v in enumerate(variants):
        out[v.name] = (lm[k + 1] - lm[k]) / RAD_PER_ARCMIN
    return {"budget_arcmin": out, "total_arcmin": lm[-1] / RAD_PER_ARCMIN,
            "estimates_arcmin": {v.name: v.estimate_rad / RAD_PER_ARCMIN for v in variants},
            "clearances_m": {v.name: v.value for v in variants}, "torque_level_Nm": level,
            "wall_s": time.perf_counter() - t0}
