"""TE and lost motion of many variant models of one topology (RV-40E Monte Carlo variants) on the
device row Newton: one copy per variant, every TE point one batch solve of all copies.

:func:`device_rows_variants` takes built models (e.g. ``rvtool.build(sample_rv_design(...))``
for k = 0..V-1) and runs the per-variant work of the Monte Carlo reference run
(``cases/rv/monte_carlo_rv.py``) on :class:`rvtool.solver.device_rows.DeviceRowNewton`:

* TE: the quasi-static equilibria at ``input_angles`` under ``torque`` (resisting the nominal
  output rotation, as :func:`rvtool.protocols.precision.quasi_static_te`), each point warm-started
  from the copy's previous equilibrium shifted by its kinematic increment (``warm_start``; the
  first point, and every point with ``warm_start=False``, from the kinematic state). The points are
  solved in the order of their crank phase (``te_order="phase"``, default): the input angle times the
  kinematics' ``crank_rate`` (the eccentric orbit per input radian: 1 for the cycloid and
  small-tooth-difference drives, whose input shaft carries the journals; RV-40E -0.322, its cranks
  turned by the spur stage) modulo 2 pi, in the direction of travel (|crank_rate|). The contacts of
  an eccentric drive repeat with the crank angle (up to which pin or tooth is engaged), so over an
  output revolution (RD-40: 53 points 0.74 crank revolutions apart) the previous point in crank phase
  is a closer start than the previous in time (~30 % fewer batch iterations, the same equilibria to
  the Newton tolerance); a TE over one crank revolution is in that order already (RV Monte Carlo:
  the order given). Kinematics without a ``crank_rate`` keep the order given (``te_order="given"``:
  as given). The order matters beyond the iteration count where a point has two equilibria: the
  involute mesh's force jumps where a contact passes from the flank to the rounded tip edge (the
  curvature, hence Weber's approach, changes there at a continuous gap: RV-40E Monte Carlo variant
  148 at TE point 18, an 8 % jump of one tooth's force, two equilibria 1.1e-8 rad of output apart,
  2.3e-3 arcsec), and the branch a warm start lands on is the one its path comes from; the Exudyn
  reference run marches the points as given, so the device takes the same path; a failed warm
  start runs the regularization homotopy from the kinematic state on the device; a point that
  still fails is solved by the Exudyn static solver on the variant's model and counted
  (``exudyn_points``);
* lost motion (``lost_motion_level`` [N m], optional): :func:`rvtool.batched.device_rows_lost_motion.device_row_lost_motion`
  on the same copies (its Exudyn fallbacks counted in ``exudyn_copies``).

A variant whose Exudyn fallback fails too is "failed" (its figures NaN), never dropped.
"""
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..solver.device_rows import DeviceRowNewton
from ..solver.model_snapshot import build_snapshot, real_model
from ..solver.static import StaticSolver
from .device_rows_lost_motion import device_row_lost_motion


@dataclass
class RowVariants:
    """Results of :func:`device_rows_variants` for V variants and N points: te (V, N) [rad],
    theta_out (V, N) [rad] (reference included), lost_motion_rad (V,) (None: not asked), status
    per variant ("ok" / "failed"), error per variant, exudyn_points (TE points solved by Exudyn),
    exudyn_copies (lost motions by Exudyn), split of the wall time [s] (``setup_s`` copying the
    families, ``kernels_s``, ``scatter_s``, ``step_s`` (the Newton step with its read-back), ``fallback_s``,
    ``rest_s``; the lost motion's Exudyn continuations, their models' builds included, are in
    ``fallback_s``, the setup of its compacted solves in ``setup_s``), te_s and lost_motion_s [s],
    wall_s [s], stats (sweeps, Newton iterations; ``lost_motion``: how its levels were reached,
    continuation rounds, copy solves, compactions, start scales)."""
    te: np.ndarray
    theta_out: np.ndarray
    lost_motion_rad: np.ndarray | None
    status: list
    error: list
    exudyn_points: int
    exudyn_copies: int
    split: dict
    te_s: float
    lost_motion_s: float
    wall_s: float
    stats: dict = field(default_factory=dict)


def device_rows_variants(models, *, torque, input_angles, lost_motion_level=None, device="cpu", settings=None,
                         device_sum=None, warm_start=True, device_step=None, te_order="phase"):
    """TE and lost motion of ``models`` (module docstring) on Warp ``device``. torque [N m]: the
    TE's output torque; input_angles [rad]; lost_motion_level [N m] or None; settings: the row
    Newton's :class:`~rvtool.solver.device_newton.DeviceNewtonSettings`; device_sum, device_step:
    see :class:`DeviceRowNewton`; te_order: "phase" or "given", the order the TE points are solved
    and warm-started in (module docstring; the figures are per angle either way). Returns a
    :class:`RowVariants`."""
    t0 = time.perf_counter()
    models = list(models)
    angles = np.asarray(input_angles, float)
    if angles.ndim != 1 or len(angles) < 1 or not np.all(np.isfinite(angles)):
        raise RvtoolInputError("input_angles must be a finite 1-D sequence of at least 1 angle [rad]")
    if not np.isfinite(torque):
        raise RvtoolInputError(f"torque = {torque!r} N m must be finite")
    if te_order not in ("phase", "given"):
        raise RvtoolInputError(f"te_order = {te_order!r}; valid: 'phase', 'given'")
    newton = DeviceRowNewton(models, device=device, settings=settings, device_sum=device_sum, device_step=device_step)
    V, N = len(models), len(angles)
    tq = np.full(V, -np.sign(models[0].ratio) * float(torque))
    q_out = np.zeros((V, N))
    split = {"setup_s": newton.setup_s, "kernels_s": 0.0, "scatter_s": 0.0, "step_s": 0.0, "fallback_s": 0.0}
    failed = np.zeros(V, bool)
    error = [None] * V
    exudyn_points = sweeps = iterations = 0
    t_te = time.perf_counter()
    newton.prime_kinematics(angles)               # every copy's kinematics once for all TE angles
    prev = None
    order = te_point_order(models, angles, te_order)
    for k in order:
        a = angles[k]
        kin = newton.kinematic(np.full(V, a))
        start = prev[0] + kin - prev[1] if (warm_start and prev is not None) else None
        r = newton.solve(np.full(V, a), tq, start)
        sweeps += r.sweeps
        iterations += int(r.iterations.sum())
        split["kernels_s"] += r.kernels_s
        split["scatter_s"] += r.scatter_s
        split["step_s"] += r.solve_s
        q_out[:, k] = r.q[:, newton.output_local]
        prev = (r.q, kin)
        tf = time.perf_counter()
        for c in np.flatnonzero(~r.converged):
            exudyn_points += 1
            r.q[c] = kin[c]                       # the next warm start: from the kinematic state
            m = real_model(models[c])
            m.set_output_torque(tq[c])
            try:
                q_out[c, k] = StaticSolver(m).solve(float(a))[m.output_index]
            except SolverFailure as exc:
                failed[c] = True
                q_out[c, k] = np.nan
                error[c] = f"TE point {k} (input angle {a:.9g} rad): device and Exudyn failed: {exc}"
        split["fallback_s"] += time.perf_counter() - tf
    te_s = time.perf_counter() - t_te
    lm, lm_s, exudyn_copies, lm_stats = None, 0.0, 0, {}
    if lost_motion_level is not None:
        t_lm = time.perf_counter()
        r = device_row_lost_motion(newton, lost_motion_level)
        lm_s = time.perf_counter() - t_lm
        for key in ("kernels_s", "scatter_s", "step_s"):
            split[key] += r["stats"][key]
        split["fallback_s"] += r["stats"]["exudyn_s"]      # the copies continued on Exudyn, their builds included
        split["setup_s"] += r["stats"]["compact_setup_s"]  # copying the few copies a compacted solve runs
        lm = r["lost_motion_rad"]
        exudyn_copies = r["stats"]["exudyn_copies"]
        for c, st in enumerate(r["status"]):
            if st == "failed":
                failed[c] = True
                error[c] = (error[c] + "; " if error[c] else "") + f"lost motion: {r['error'][c]}"
        sweeps += r["stats"]["rounds"]
        iterations += r["stats"]["newton_iterations"]
        lm_stats = {k: r["stats"][k] for k in ("levels_path", "rounds", "copy_solves", "compactions", "start_scales")}
    ref_out = newton.reference[:, newton.output_local]      # each copy's m.reference_value(m.output)
    theta_out = ref_out[:, None] + q_out
    # transmission_error(angles, theta_out[c], m.ratio, unwrap=False) of every copy at once (the same operations)
    ratios = np.array([float(m.ratio) for m in models])
    te = (theta_out - theta_out[:, :1]) - (angles - angles[0])[None, :] / ratios[:, None]
    te[failed] = np.nan
    wall = time.perf_counter() - t0
    split["rest_s"] = wall - sum(split.values())
    return RowVariants(te=te, theta_out=theta_out, lost_motion_rad=lm,
                       status=["failed" if f else "ok" for f in failed], error=error, exudyn_points=exudyn_points,
                       exudyn_copies=exudyn_copies, split=split, te_s=te_s, lost_motion_s=lm_s, wall_s=wall,
                       stats={"variants": V, "points": N, "te_order": te_order, "sweeps": sweeps,
                              "newton_iterations": iterations,
                              "device": str(device), "device_sum": newton.device_sum, "lost_motion": lm_stats,
                              "setup_parts": newton.setup_parts})


def te_point_order(models, angles, te_order="phase"):
    """The order (N,) in which :func:`device_rows_variants` solves the TE points at ``angles`` [rad]
    (module docstring): "phase" by crank phase mod(|crank_rate| angle, 2 pi) (stable: ties as given),
    where every model's kinematics has one and the same ``crank_rate``, else as given; "given" as given."""
    angles = np.asarray(angles, float)
    rates = {getattr(m.kinematics, "crank_rate", None) for m in models}
    if te_order != "phase" or len(rates) != 1 or None in rates:
        return np.arange(len(angles))
    rate = abs(float(rates.pop()))
    return np.argsort(np.mod(angles * rate, 2 * np.pi), kind="stable")


def _snapshot_of(job):
    """Pool task: the :class:`ModelSnapshot` of ``build(design, **build_kw)`` (picklable; built
    without device objects, :func:`~rvtool.solver.model_snapshot.build_snapshot`)."""
    design, build_kw, shared = job
    return build_snapshot(design, build_kw, shared_tables=shared)


def prepare_variant_models(designs, build_kw=None, *, workers=None, executor=None, shared_tables=True):
    """The variant models of ``designs`` for :func:`device_rows_variants`, built side by side in
    worker processes and returned as :class:`~rvtool.solver.model_snapshot.ModelSnapshot` (their
    rows, kinematics and constraints; a model itself is built here only where Exudyn takes over a
    point or copy). workers: processes (None: all cores; 1: build here, the models themselves);
    executor: a ``concurrent.futures`` executor to use instead (e.g. a warmed pool); build_kw: the
    build options of every variant; shared_tables: the snapshots' cycloid pin sets share one profile
    table per distinct wheel profile (:func:`~rvtool.solver.model_snapshot.build_snapshot`; False: one
    per variant as the full build; workers = 1 builds the full models either way)."""
    import concurrent.futures as cf
    import multiprocessing
    import os
    from ..assembly import build
    designs = list(designs)
    build_kw = dict(build_kw or {})
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1):
        raise RvtoolInputError(f"workers = {workers!r} is outside the valid range [1, inf) (integer; None: all cores)")
    jobs = [(d, build_kw, bool(shared_tables)) for d in designs]
    if executor is not None:
        return list(executor.map(_snapshot_of, jobs, chunksize=max(1, len(jobs) // 64)))
    n = workers or os.cpu_count() or 1
    if n == 1 or len(designs) < 2:
        return [build(d, **build_kw) for d in designs]
    ctx = multiprocessing.get_context("spawn")          # fresh interpreters: no forked Warp/Exudyn state
    with cf.ProcessPoolExecutor(max_workers=min(n, len(designs)), mp_context=ctx) as ex:
        return list(ex.map(_snapshot_of, jobs, chunksize=max(1, len(jobs) // (4 * n))))


__all__ = ["RowVariants", "device_rows_variants", "prepare_variant_models", "te_point_order"]
