"""Lost motion on the device row Newton (:mod:`rvtool.solver.device_rows`): RV-40E and every other
topology the row Newton runs, one copy per variant model, all copies advancing together.

The Exudyn protocol (:func:`rvtool.protocols.lost_motion.lost_motion`) reaches the equilibria at
+f and -f (f = ``torque_level``) at one input angle by a spring-controlled march through the free
play; lost motion = theta_out(+f) - theta_out(-f). Here the same two equilibria are reached by the
load continuation of :mod:`rvtool.batched.device_lost_motion` (the cycloid device path's increment
control, :class:`~rvtool.batched.device_lost_motion.ContinuationSettings`), every round one row
Newton solve of the copies still running, each at its own next torque:

1. start: every copy at the first of :data:`rvtool.protocols.lost_motion.START_SCALES` x f that
   converges from its kinematic state (warm start, then the regularization homotopy);
2. levels (the start torque, +f, -f): copy c solves at its level if the rest fits in its
   increment, else at ``t_now + inc``; accepted if converged (plausibility bounds included) and
   max |q - q_prev| <= ``max_step``, then ``inc`` doubles while smaller than the rest; rejected:
   ``inc`` halves, below ``min_increment`` the copy has failed. Warm starts only (a restart from
   the kinematic state would leave the branch);
3. a copy that fails goes to the Exudyn protocol on its own model (counted in
   ``stats["exudyn_copies"]``; never hidden).

Where the equilibria at +-f are unique (RV-40E: the continuation and the march of the Exudyn
backend agree to 3e-11 arcmin, tests/golden/backends.json), both paths give the same figure.
"""
import time

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..protocols.lost_motion import START_SCALES
from ..solver.device_newton import DeviceNewtonSettings
from .device_lost_motion import ContinuationSettings

ROW_LOST_MOTION_NEWTON = DeviceNewtonSettings(max_step_rotation=1e-3)
"""Newton settings of the levels: the TE's with a rotation step limit of 1e-3 rad (as
:data:`rvtool.batched.device_lost_motion.LOST_MOTION_NEWTON`: below the free play a level step can cross)."""


def device_row_lost_motion(newton, torque_level, *, input_angle=0.0, settings=ROW_LOST_MOTION_NEWTON,
                           continuation=ContinuationSettings(), fallback=True):
    """Lost motion of every copy of ``newton`` (a :class:`~rvtool.solver.device_rows.DeviceRowNewton`:
    one copy per variant model, or one copy of one model) at ``input_angle`` [rad] between +-``torque_level``
    [N m] (module docstring). Returns {"lost_motion_rad" (P,), "theta_plus", "theta_minus" [rad]
    (output coordinate), "path" ("device" / "exudyn"), "status" ("ok" / "failed"), "error",
    "stats"} with P = the number of copies (variants) or 1 (one model)."""
    if not (np.isfinite(torque_level) and torque_level > 0):
        raise RvtoolInputError(f"torque_level = {torque_level!r} N m is outside the valid range (0, inf)")
    t0 = time.perf_counter()
    P = newton.B if newton.models is not None else 1
    f = float(torque_level)
    # the torque acts on the output coordinate as it is (lost_motion's Continuation / SpringControl: no sign flip)
    i_out = newton.output_local
    ang = np.full(P, float(input_angle))
    allc = np.arange(P)
    cp = lambda idx: idx if newton.models is not None else None
    q = newton.kinematic(ang, cp(allc))
    scale = np.full(P, np.nan)
    stats = {"rounds": 0, "copy_solves": 0, "newton_iterations": 0, "kernels_s": 0.0, "scatter_s": 0.0,
             "step_s": 0.0}

    def solve(idx, torque, q_start, homotopy):
        r = newton.solve(ang[idx], torque, q_start, copies=cp(idx), homotopy=homotopy, settings=settings)
        stats["copy_solves"] += len(idx)
        stats["newton_iterations"] += int(r.iterations.sum())
        stats["kernels_s"] += r.kernels_s
        stats["scatter_s"] += r.scatter_s
        stats["step_s"] += r.solve_s
        return r

    for sc in START_SCALES:
        todo = np.flatnonzero(np.isnan(scale))
        if not len(todo):
            break
        r = solve(todo, np.full(len(todo), sc * f), None, True)
        got = r.converged
        q[todo[got]] = r.q[got]
        scale[todo[got]] = sc
    ok = ~np.isnan(scale)
    failed = ~ok
    why = np.array(["" if o else f"no loaded start on the device at {', '.join(f'{s:g}' for s in START_SCALES)} x f"
                    for o in ok], dtype=object)
    lv = np.column_stack([np.where(ok, scale, 1.0) * f, np.full(P, f), np.full(P, -f)])
    k = np.where(scale == 1.0, 2, 1)
    theta_plus = np.where(scale == 1.0, q[:, i_out], np.nan)
    t_now = lv[:, 0].copy()
    inc = lv[allc, k] - t_now
    running = ok.copy()
    cs = continuation
    while np.any(running) and stats["rounds"] < cs.max_rounds:
        idx = np.flatnonzero(running)
        goal = lv[idx, k[idx]]
        target = np.where(np.abs(goal - t_now[idx]) <= np.abs(inc[idx]), goal, t_now[idx] + inc[idx])
        r = solve(idx, target, q[idx], False)
        stats["rounds"] += 1
        acc = r.converged & (np.max(np.abs(r.q - q[idx]), axis=1) <= cs.max_step)
        a, b = idx[acc], idx[~acc]
        q[a] = r.q[acc]
        t_now[a] = target[acc]
        rest = lv[a, k[a]] - t_now[a]
        inc[a] = np.where(np.abs(inc[a]) < np.abs(rest), 2 * inc[a], inc[a])
        done = a[t_now[a] == lv[a, k[a]]]
        plus = done[k[done] == 1]
        theta_plus[plus] = q[plus, i_out]
        k[done] += 1
        running[done[k[done] == 3]] = False
        nxt = done[k[done] < 3]
        inc[nxt] = lv[nxt, k[nxt]] - t_now[nxt]
        inc[b] *= 0.5
        stalled = b[np.abs(inc[b]) < cs.min_increment]
        running[stalled] = False
        failed[stalled] = True
        for c in stalled:
            why[c] = (f"device torque continuation stalled between {t_now[c]:.6g} and {lv[c, k[c]]:.6g} N m "
                      f"(increment below min_increment = {cs.min_increment:g})")
    for c in np.flatnonzero(running):
        failed[c] = True
        why[c] = f"device torque continuation not finished in max_rounds = {cs.max_rounds} rounds"
    stats["device_s"] = time.perf_counter() - t0
    th_p = np.where(failed, np.nan, theta_plus)
    th_m = np.where(failed, np.nan, q[:, i_out])
    path = ["device" if not x else None for x in failed]
    status = ["ok" if not x else None for x in failed]
    error = [None] * P
    from ..protocols.lost_motion import lost_motion
    for c in np.flatnonzero(failed):
        if not fallback:
            status[c], error[c] = "failed", str(why[c])
            continue
        model = (newton.models or [newton.model])[c]
        path[c] = "exudyn"
        try:
            lm = lost_motion(model, torque_level=f, input_angle=float(input_angle))
        except SolverFailure as exc:
            status[c], error[c] = "failed", f"{why[c]}; Exudyn protocol: {exc}"
            continue
        th_p[c], th_m[c] = lm["theta_plus"], lm["theta_minus"]
        status[c] = "ok"
    stats.update(copies=P, exudyn_copies=int(sum(p == "exudyn" for p in path)),
                 failed_copies=int(sum(s == "failed" for s in status)),
                 start_scales={f"{sc:g}": int(np.sum(scale == sc)) for sc in START_SCALES},
                 wall_s=time.perf_counter() - t0)
    return {"lost_motion_rad": th_p - th_m, "theta_plus": th_p, "theta_minus": th_m, "path": path, "status": status,
            "error": error, "stats": stats}


__all__ = ["ROW_LOST_MOTION_NEWTON", "device_row_lost_motion"]
