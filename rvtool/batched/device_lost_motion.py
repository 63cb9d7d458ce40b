"""Lost motion of many variants with the device Newton: the load continuation of all copies at once.

The per-variant lost motion (:func:`rvtool.variants.variant_lost_motion`) is a load
continuation at input angle 0 (:class:`rvtool.solver.continuation.Continuation`): the
equilibrium at +f (f = ``protocol.lost_motion_fraction`` x T_rated) from the kinematic state,
then the levels ``protocol.lost_motion_torques`` down to -f, each reached from the previous
equilibrium by warm-started Newton solves whose torque increment is halved when Newton fails
or a step moves a coordinate by more than ``max_step`` (in the free play a full Newton step
can land in a far, spurious equilibrium), doubled again after a success; lost motion =
theta_out(+f) - theta_out(-f). The free play (output-pin hole clearance, pin clearance) is
crossed exactly as there: by the continuation through the
levels, each warm-started from the copy's previous equilibrium, with the same increment
control and the same acceptance test.

Here every variant is one copy of :class:`rvtool.solver.device_newton.DeviceNewton` at input
angle 0, and the copies advance TOGETHER: every round is one device Newton solve of all copies
still running, each at its own next torque (its increment state is its own; a copy's
arithmetic does not depend on the others, so a copy's result does not depend on which others
run beside it). The batch is over variants only: a copy's levels are a chain (each starts from
the equilibrium before it, which is how the free play is crossed), not independent solves:

1. start: all copies at +f from their kinematic state; a failed warm start runs the
   regularization homotopy on the device (per copy), as ``Continuation``'s start falls back to
   the static solver's ladder. Copies without a start there try the larger start torques of
   :data:`rvtool.protocols.lost_motion.START_SCALES` x f in turn (the spring-controlled
   fallback's ladder: a loaded start can fail inside the free play and succeed at a larger
   torque) and come down to +f by the continuation below (measured on the Monte Carlo's first
   64 RD-40 variants: 6 without a start at +f, all found at 2.5 f);
2. rounds: copy c at level k solves at ``target = levels[k]`` if the rest fits in its
   increment, else at ``t_now + inc``; accepted if converged (plausibility bounds included)
   and max |q - q_prev| <= ``max_step``, then ``inc`` doubles while smaller than the rest; on
   rejection ``inc`` halves, and below ``min_increment`` the copy has failed. Warm-started
   solves only (no homotopy: a restart from the kinematic state would leave the branch, as
   ``Continuation`` does not restart for the cycloid models);
3. copies that fail (start, stall, or ``max_rounds`` exhausted) go to the per-variant Exudyn
   path (:func:`variant_lost_motion` on the variant's own build: load continuation, then
   spring control), counted in ``fallback_copies``; if that fails too the copy's figure is NaN
   and its status "failed".
"""
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..solver.device_newton import DeviceNewton, DeviceNewtonSettings
from ..units import ARCMIN_PER_RAD
from ..variants.variant import Variant, VariantProtocol
from ..solver.device_copies import copy_parameters
from ..solver.torque_path import START_SCALES, ContinuationSettings  # noqa: F401  (re-exported)


@dataclass
class DeviceLostMotion:
    """Per-variant results of :func:`device_lost_motion` (V variants): lost motion [arcmin] (V,)
    (NaN: failed), flange displacement coordinates at +f and -f [rad] (V,) (NaN where the Exudyn
    fallback gave the figure), the path that produced each
    ("device" or "exudyn") and its method ("load" on the device; "load"/"spring" on the
    Exudyn fallback), status ("ok"/"failed"), error (None or the message), Newton iterations
    per variant (device iterations of all its rounds, plus the fallback's), and ``stats``
    (rounds, copy solves, device loop wall, fallback and failed copies, the loop path)."""
    lost_motion_arcmin: np.ndarray
    theta_plus: np.ndarray
    theta_minus: np.ndarray
    path: list
    method: list
    status: list
    error: list
    iterations: np.ndarray
    stats: dict = field(default_factory=dict)


def _exudyn_lost_motion(design, variant, protocol, regularization):
    """The per-variant Exudyn path: (lost motion [arcmin], method, Newton iterations)."""
    from ..assembly.cycloid import build
    from ..variants.variant import variant_lost_motion
    d = variant.apply(design)
    lm = variant_lost_motion(build(d, bearing_model="lumped", regularization=regularization), d, protocol)
    return lm["lost_motion_arcmin"], lm["method"], int(lm["newton_iterations"])


LOST_MOTION_NEWTON = DeviceNewtonSettings(max_step_rotation=1e-3)
"""Device Newton settings of the lost motion: the TE's, with a rotation step limit of 1e-3 rad
(below the ~1.5e-3 rad of output-pin free play that a level step can cross; measured on the
Monte Carlo's first 16 RD-40 variants: 3,880 copy iterations against 5,194 at the TE's 4e-3 rad,
4e-4 rad: 5,112 and one more fallback; the same figures)."""


def device_lost_motion(design, variants, protocol: VariantProtocol = VariantProtocol(), *, regularization=(100.0, 0.1),
                       device="cpu", settings: DeviceNewtonSettings = LOST_MOTION_NEWTON,
                       continuation: ContinuationSettings = ContinuationSettings(), params=None, fallback=True,
                       copies=None, executor=None):
    """Lost motion of ``variants`` of ``design`` under ``protocol`` with the device Newton on
    ``device`` (see the module docstring). params: :class:`CopyParameters` of
    ``[Variant()] + variants`` (with the same ``regularization``) to reuse (e.g. from the TE);
    built here if None. copies: indices into ``variants`` to run (default all; the others
    are reported as not run, status "skipped"). fallback: send failed copies to the Exudyn
    path; executor: a ``concurrent.futures.Executor`` that runs those fallbacks side by side
    (on a GPU host the process holding the device would otherwise run them one after another).
    Returns a :class:`DeviceLostMotion`."""
    t0 = time.perf_counter()
    variants = list(variants)
    V = len(variants)
    if V < 1:
        raise RvtoolInputError("device_lost_motion needs at least one variant (valid range of V: [1, inf))")
    if protocol.bearing_model != "lumped":
        raise RvtoolInputError(f"protocol.bearing_model = {protocol.bearing_model!r}; the device Newton supports "
                               f"['lumped']")
    if params is None:
        params = copy_parameters(design, [Variant()] + variants, regularization=regularization)
    elif len(params.variants) != V + 1:
        raise RvtoolInputError(f"params must hold [Variant()] + variants ({V + 1} copies); got {len(params.variants)}")
    run = np.arange(V) if copies is None else np.asarray(copies, np.int64)
    # the start as Continuation's (warm start, then the ladder: here the device homotopy); the
    # levels warm-started only (Continuation._try: ramp=False, no restart)
    start_newton = DeviceNewton(params, device=device, settings=replace(settings, homotopy=True))
    step_newton = DeviceNewton(params, device=device, settings=replace(settings, homotopy=False))
    levels = protocol.lost_motion_torques(design)
    i_out = params.output_index
    P = len(run)
    vi = 1 + run
    zero = np.zeros(P)
    setup_s = time.perf_counter() - t0

    # the start: the load-controlled equilibrium at the first of START_SCALES x (+f) found
    # (lost_motion's ladder: a loaded start can fail at a small torque inside the free play and
    # succeed at a larger one, from where the continuation comes down to +f)
    q = params.kinematic(vi, zero)
    iters = np.zeros(P, np.int64)
    scale = np.full(P, np.nan)
    loop_s, copy_solves = 0.0, 0
    for sc in START_SCALES:
        todo = np.flatnonzero(np.isnan(scale))
        if not len(todo):
            break
        st = start_newton.solve(vi[todo], zero[todo], np.full(len(todo), sc * levels[0]),
                                params.kinematic(vi[todo], zero[todo]))
        loop_s += st.loop_s
        copy_solves += len(todo)
        iters[todo] += st.iterations
        got = todo[st.converged]
        q[got] = st.q[st.converged]
        scale[got] = sc
    ok = ~np.isnan(scale)
    failed = ~ok                                  # fell out of the device continuation
    why = np.array(["no loaded start at +f on the device (warm start and homotopy at "
                    f"{', '.join(f'{s:g}' for s in START_SCALES)} x f)" if not o else "" for o in ok], dtype=object)
    # per copy: its levels (its start torque, then the protocol's), the next one and its increment
    lv = np.tile(np.concatenate([[levels[0]], levels]), (P, 1))
    lv[:, 0] = np.where(ok, scale, 1.0) * levels[0]
    k = np.where(scale == 1.0, 2, 1)             # a start at +f itself is the first level
    theta_plus = np.where(scale == 1.0, q[:, i_out], np.nan)
    t_now = lv[:, 0].copy()
    inc = lv[np.arange(P), k] - t_now
    rounds = 0
    cs = continuation
    running = ok.copy()
    n_lv = lv.shape[1]
    while np.any(running) and rounds < cs.max_rounds:
        idx = np.flatnonzero(running)
        goal = lv[idx, k[idx]]
        rest = goal - t_now[idx]
        target = np.where(np.abs(rest) <= np.abs(inc[idx]), goal, t_now[idx] + inc[idx])
        r = step_newton.solve(vi[idx], zero[idx], target, q[idx])
        rounds += 1
        copy_solves += len(idx)
        loop_s += r.loop_s
        iters[idx] += r.iterations
        acc = r.converged & (np.max(np.abs(r.q - q[idx]), axis=1) <= cs.max_step)
        a, b = idx[acc], idx[~acc]
        # accepted: Continuation.go_to's doubling rule, then the next level
        q[a] = r.q[acc]
        t_now[a] = target[acc]
        rest_a = lv[a, k[a]] - t_now[a]
        inc[a] = np.where(np.abs(inc[a]) < np.abs(rest_a), 2 * inc[a], inc[a])
        done = a[t_now[a] == lv[a, k[a]]]
        plus = done[k[done] == 1]                          # +f reached from a larger start torque
        theta_plus[plus] = q[plus, i_out]
        k[done] += 1
        running[done[k[done] == n_lv]] = False
        nxt = done[k[done] < n_lv]
        inc[nxt] = lv[nxt, k[nxt]] - t_now[nxt]            # a new go_to: the whole step first
        # rejected: halve; below min_increment the copy has stalled
        inc[b] *= 0.5
        stalled = b[np.abs(inc[b]) < cs.min_increment]
        running[stalled] = False
        failed[stalled] = True
        for c in stalled:
            why[c] = (f"device torque continuation stalled between {t_now[c]:.6g} and {lv[c, k[c]]:.6g} N m: "
                      f"increment {abs(inc[c]):.3g} N m below min_increment = {cs.min_increment:g}")
    for c in np.flatnonzero(running):
        failed[c] = True
        why[c] = f"device torque continuation not finished in max_rounds = {cs.max_rounds} rounds"
    device_s = time.perf_counter() - t0

    lm = np.full(V, np.nan)
    th_p, th_m = np.full(V, np.nan), np.full(V, np.nan)
    path, method, status, error = [None] * V, [None] * V, ["skipped"] * V, [None] * V
    n_iter = np.zeros(V, np.int64)
    for j, c in enumerate(run):
        n_iter[c] = iters[j]
        if not failed[j]:
            th_p[c], th_m[c] = theta_plus[j], q[j, i_out]
            lm[c] = (th_p[c] - th_m[c]) * ARCMIN_PER_RAD
            path[c], method[c], status[c] = "device", "load", "ok"
    n_fallback = int(failed.sum())
    n_failed = 0
    jobs = {}
    for j in np.flatnonzero(failed):
        c = run[j]
        if not fallback:
            status[c], error[c], n_failed = "failed", str(why[j]), n_failed + 1
        elif executor is not None:
            jobs[j] = executor.submit(_exudyn_lost_motion, design, variants[c], protocol, regularization)
        else:
            jobs[j] = None
    for j, fut in jobs.items():
        c = run[j]
        path[c] = "exudyn"
        try:
            lm[c], method[c], it = (fut.result() if fut is not None else
                                    _exudyn_lost_motion(design, variants[c], protocol, regularization))
        except SolverFailure as exc:
            status[c], error[c], n_failed = "failed", f"{why[j]}; Exudyn path: {exc}", n_failed + 1
            continue
        n_iter[c] += it
        status[c] = "ok"
    stats = {"copies": P, "rounds": rounds,
             "start_scales": {f"{sc:g}": int(np.sum(scale == sc)) for sc in START_SCALES},
             "copy_solves": int(copy_solves), "device_loop_s": loop_s,
             "newton_iterations_per_copy": float(iters.mean()) if P else 0.0,
             "fallback_copies": n_fallback, "failed_copies": n_failed, "path": step_newton.last_path,
             "device": step_newton.device, "setup_s": setup_s, "device_s": device_s,
             "wall_s": time.perf_counter() - t0}
    return DeviceLostMotion(lost_motion_arcmin=lm, theta_plus=th_p, theta_minus=th_m, path=path, method=method,
                            status=status, error=error, iterations=n_iter, stats=stats)
