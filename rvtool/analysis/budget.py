"""The lost-motion budget of a design (one model per clearance state: the building is a
study's; the stiffness budget of one built model is :func:`rvtool.protocols.budget.stiffness_budget`),
and the ported carrier's share as a side figure of ``rvtool validate`` (issue 30)."""
import time

import numpy as np

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


QUICK_CARRIER_MESH = 0.008
"""--quick: the ported carrier's side figure meshed at 8 mm (the files give 4 mm)."""


def carrier_share_figure(design, T_R, *, quick=False):
    """The carrier's share of the output compliance at T_R (issue 30), a side figure where the design states a
    ``[carrier.structure]`` but keeps ``carrier.body = "rigid"`` (as the shipped files do): the design with
    the ported carrier, its tangent K_t [N m/arcmin] and budget shares (the carrier's under ``carrier``).
    None where the design has no carrier structure or already runs it ported (then the main budget holds
    it); an error is reported, not raised (a side figure)."""
    from ..assembly.spec import replace as replace_design
    from ..protocols.budget import stiffness_budget
    from ..solver.static import StaticSolver
    c = getattr(design, "carrier", None)
    if c is None or c.structure is None or c.body != "rigid":
        return None
    try:
        d = replace_design(design, carrier={"body": "ported", **({"structure": {"mesh_size": QUICK_CARRIER_MESH}}
                                                                 if quick else {})})
        model = build(d)
        model.set_output_torque(-np.sign(model.ratio) * T_R)
        b = stiffness_budget(model, StaticSolver(model).solve(0.0))
        return {"K_t_Nm_per_arcmin": b["K_t_Nm_per_arcmin"], "shares": b["shares"],
                "carrier_share": b["shares"]["carrier"], "mesh_size_m": d.carrier.structure.mesh_size,
                "note": "the design with carrier.body = 'ported' (its file keeps 'rigid')"}
    except Exception as exc:           # reported, not fatal
        return {"error": f"not computed: {type(exc).__name__}: {exc}"}
