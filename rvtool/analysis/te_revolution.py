"""TE over the measurement's own window, the output revolution (issue 30, Deliver 3): resumable units of
quasi-static TE spread over a process pool.

Yang et al. (Mech. Mach. Theory 163 (2021) 104384, Eq. (38)) measure the rotational TE over one revolution of the
output. The long-period errors (the accumulated pitch of the housing's pins and of the wheels' lobes, the bore
positions) have periods of up to one output revolution, so the sun/crank-gear window of
:func:`rvtool.analysis.validate_te.te_window` (19 of rv80e's 153 input revolutions) gives a lower bound only. Here
each TE run ("job": the nominal design, tolerance variant k, field f's one-at-a-time draw k, at a resolution of
``points_per_mesh``) is cut into chunks of about :data:`CHUNK_POINTS` consecutive points of one angle grid
(``i * mesh_period / points_per_mesh``); a chunk ("unit") is solved on its own (its first point by the static
solver's cold start, the rest warm-started), and a job's TE is formed from the concatenated input and output
angles, exactly as one run would (:func:`rvtool.observe.transmission.transmission_error`: the equilibrium is unique
under the load, a cold start meets the warm-started sequence to solver tolerance; tests/test_te_revolution.py).

A unit is keyed by the SHA-256 of its inputs: the drawn design (every field of the design dataclass), the torque,
the angle step and the chunk's index range, so that a result kept in a folder serves any later run that asks for
the same unit (``resume``), whatever its position in that run. The units run through
:class:`rvtool.analysis.workunits.UnitRunner` (the process pool, the store ``<out>/units/<key>.pkl`` written as each
unit finishes, the resume folders, and the deadline: no unit is started once the time left is below the longest
unit seen so far).
"""
import dataclasses
import hashlib
import math
import os
import time

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..units import ARCSEC_PER_RAD

CHUNK_POINTS = 800
"""Largest number of TE points of one unit: about 20 s of one core unloaded (measured 0.023 s per warm-started
point of rv80e, 2 points per mesh, plus 3 s to build the variant and a cold start), so that 16 workers share a few
hundred units evenly and a resumed run loses at most one unit per worker."""

PORTABLE_DIGITS = 12
"""Significant digits of every float in a TE job's digest (:func:`design_digest`). The job's inputs are computed
floats (the angle step from the mesh period, a variant's pin centres from its draws), whose last bits differ
between machines (libm / SIMD transcendental functions): the GPU host's step was 0.3081177410251525 where the
development machine's is 0.30811774102515266 at the same commit, so every unit solved there had another key and no
run could resume the other's units. Twelve digits are far below any physical difference of two jobs (a tolerance
draw of ~1e-6 m resolved to ~1e-18 m) and far above the last-bit noise (~1e-16 relative)."""


def _portable(obj):
    """``obj`` with every float (NumPy's too, arrays through ``tolist()``) rounded to :data:`PORTABLE_DIGITS`
    significant digits; dicts, lists and tuples walked."""
    if isinstance(obj, dict):
        return {k: _portable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_portable(v) for v in obj]
    if hasattr(obj, "tolist") and not isinstance(obj, (bool, int)):
        return _portable(obj.tolist())
    if isinstance(obj, float):
        return float(f"{obj:.{PORTABLE_DIGITS}g}")
    return obj


def design_digest(design, *, torque, step):
    """SHA-256 (hex) of what a TE job solves (:func:`rvtool.analysis.workunits.json_sha256`): every field of the
    design dataclass, the output torque [N m] and the angle step [rad], each float at :data:`PORTABLE_DIGITS`
    significant digits, so that a unit solved on one machine is found by a run on another."""
    from .workunits import json_sha256
    return json_sha256(_portable({"design": dataclasses.asdict(design), "torque": float(torque),
                                  "step": float(step), "protocol": "quasi_static_te"}))


def unit_key(job_digest, i0, i1):
    """Key of the unit of points [i0, i1) of a job: the SHA-256 of the text ``"<job digest>:<i0>:<i1>"``. Not
    :func:`~rvtool.analysis.workunits.json_sha256` (the JSON of that text is quoted, another hash): the
    unit keys pinned in tests/test_te_revolution.py are of this text."""
    return hashlib.sha256(f"{job_digest}:{int(i0)}:{int(i1)}".encode()).hexdigest()


def chunks(n, size=CHUNK_POINTS):
    """[(i0, i1)] splitting range(n) into ceil(n / size) nearly equal consecutive parts."""
    k = max(1, math.ceil(n / size))
    edges = np.linspace(0, n, k + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def grid_points(input_revolutions, mesh_period, points_per_mesh):
    """Number of grid points of ``input_revolutions`` at ``points_per_mesh`` points per mesh cycle."""
    return int(round(input_revolutions * 2 * np.pi / mesh_period * points_per_mesh))


def make_job(name, design, *, torque, mesh_period, points_per_mesh, input_revolutions, meta=None,
             chunk_points=CHUNK_POINTS):
    """A TE job: ``{"name", "digest", "design", "torque", "step", "n", "units": [(key, i0, i1)], "meta"}``."""
    step = float(mesh_period) / points_per_mesh
    n = grid_points(input_revolutions, mesh_period, points_per_mesh)
    dg = design_digest(design, torque=torque, step=step)
    return {"name": name, "digest": dg, "design": design, "torque": float(torque), "step": step, "n": n,
            "points_per_mesh": points_per_mesh, "input_revolutions": float(input_revolutions),
            "units": [(unit_key(dg, a, b), a, b) for a, b in chunks(n, chunk_points)], "meta": dict(meta or {})}


def solve_unit(task):
    """One unit (a spawn-pool task; ``task`` = (key, design, torque, step, i0, i1)): the quasi-static TE's input
    and output angles at grid points i0 .. i1-1; a solver failure or bad input is recorded, never raised."""
    key, design, torque, step, i0, i1 = task
    from ..assembly import build
    from ..protocols.precision import quasi_static_te
    t0 = time.perf_counter()
    out = {"key": key, "i0": i0, "i1": i1, "status": "ok", "error": None, "theta_in": None, "theta_out": None}
    try:
        model = build(design)
        out["build_s"] = time.perf_counter() - t0
        qs = quasi_static_te(model, torque=torque, input_angles=np.arange(i0, i1) * step)
        th_in, th_out = np.asarray(qs["theta_in"], float), np.asarray(qs["theta_out"], float)
        if not (np.all(np.isfinite(th_in)) and np.all(np.isfinite(th_out))):
            raise RvtoolInputError("TE angles are not finite")
        out.update(theta_in=th_in.tolist(), theta_out=th_out.tolist(), ratio=float(model.ratio),
                   stats={k: v for k, v in qs["stats"].items() if isinstance(v, (int, float))})
    except (SolverFailure, RvtoolInputError) as exc:        # recorded, never dropped silently
        out.update(status="failed", error=f"{type(exc).__name__}: {exc}")
    out["wall_s"] = time.perf_counter() - t0
    out["pid"] = os.getpid()
    return out


def stored(runner, key):
    """A finished unit's result from the runner's store or resume folders (or from a dict {key: result}, the
    results :func:`submit_units` waited for), else None."""
    if isinstance(runner, dict):
        return runner.get(key)
    hit, res = runner.lookup(key)
    return res if hit else None


def submit_units(jobs, runner):
    """Submit every unit of ``jobs`` to ``runner`` (a :class:`rvtool.analysis.workunits.UnitRunner` shared with
    other work, as ``rvtool validate``'s; a unit already stored is taken from there) and return a callable that
    waits for them and returns ``{key: result}`` for :func:`assemble`. A unit refused by the runner's deadline
    raises :class:`rvtool.analysis.workunits.DeadlineReached` out of the callable (the finished units are stored,
    a ``--resume`` completes the run)."""
    futures = {}
    for j in jobs:
        for key, i0, i1 in j["units"]:
            if key not in futures:
                futures[key] = runner.submit(solve_unit, (key, j["design"], j["torque"], j["step"], i0, i1),
                                             key=key, kind="te_unit")

    def finish():
        return {key: f.result() for key, f in futures.items()}
    return finish


def output_revolutions(model):
    """Input revolutions of one output revolution: |ratio| (rounded where it is an integer to 1e-6)."""
    revs = abs(float(model.ratio))
    return float(round(revs)) if abs(revs - round(revs)) < 1e-6 else revs


def revolution_inputs_digest(design_name, design, rated_torque, *, variants, input_revolutions=None, model=None):
    """The inputs digest (:func:`rvtool.analysis.validate_te.te_inputs_digest`) of the TE comparison over the
    output revolution (or over ``input_revolutions``, a smoke run's shortened grid) with ``variants`` tolerance
    variants at :data:`RESOLUTION_PPM` [0]: recorded in te_measured_rv80e's full results and checked by
    ``rvtool validate`` before it takes them (the resolution check and the sensitivity do not enter its rows)."""
    from .. import designs
    from ..assembly import build
    from . import validate_te as VT
    tol_name, meas_name = designs.tolerances_of(design_name), designs.measured_of(design_name)
    if tol_name is None:
        raise RvtoolInputError(f"design {design_name!r} ships no tolerance file (<design>_tolerances.toml)")
    revs = output_revolutions(model if model is not None else build(design))
    revs = revs if input_revolutions is None else float(input_revolutions)
    return VT.te_inputs_digest(design, designs.path(tol_name), None if meas_name is None else designs.path(meas_name),
                               n=variants, points_per_mesh=RESOLUTION_PPM[0],
                               torque=VT.TE_TORQUE_FRACTION * rated_torque, input_revolutions=revs)


def run_units(jobs, runner, *, log=print, on_progress=None, progress_every_s=30.0):
    """Solve every unit of ``jobs`` through ``runner`` (:func:`rvtool.analysis.workunits.folder_runner`; a unit already stored is kept), in
    the order of ``jobs`` (the plan's order of priority); the runner starts no unit once the time left before its
    deadline is below the longest unit seen so far. ``on_progress()`` is called at most every ``progress_every_s``
    while units finish. Returns ``{"total", "kept", "solved", "failed", "not_started", "unit_wall_s": [...] (the
    units solved here), "all_unit_wall_s": [...] (every finished unit, kept ones at the wall time of the call that
    solved them),
    "stopped_by_deadline", "crashed": [errors]}`` (a crashed unit is not stored: its job stays missing, the run
    incomplete, a resume retries it)."""
    from concurrent.futures import as_completed

    from .workunits import DeadlineReached
    stats = {"total": 0, "kept": 0, "solved": 0, "failed": 0, "not_started": 0, "unit_wall_s": [],
             "all_unit_wall_s": [],
             "stopped_by_deadline": False, "crashed": []}
    last = [time.time()]

    def progress():
        if on_progress is not None and time.time() - last[0] > progress_every_s:
            last[0] = time.time()
            on_progress()

    def finished(fut, kept):
        try:
            res = fut.result()
        except DeadlineReached:
            stats["not_started"] += 1
            stats["stopped_by_deadline"] = True
            return
        except Exception as exc:       # a crashed worker: logged, the unit not stored (a resume retries it)
            stats["crashed"].append(f"{type(exc).__name__}: {exc}")
            log(f"  a unit crashed: {type(exc).__name__}: {exc}")
            return
        stats["all_unit_wall_s"].append(res["wall_s"])
        if kept:
            stats["kept"] += 1
            return
        stats["solved"] += 1
        stats["failed"] += res["status"] != "ok"
        stats["unit_wall_s"].append(res["wall_s"])
        log(f"  unit {stats['solved'] + stats['kept']}/{stats['total']}: {res['i1'] - res['i0']} points, "
            f"{res['wall_s']:.1f} s" + ("" if res["status"] == "ok" else f", {res['error']}"))
        progress()

    units = [(key, (key, j["design"], j["torque"], j["step"], i0, i1)) for j in jobs for key, i0, i1 in j["units"]]
    stats["total"] = len(units)
    kept = {key for key, _ in units if stored(runner, key) is not None}
    log(f"TE units: {len(units)} ({len(kept)} kept from earlier runs, {len(units) - len(kept)} to solve on "
        f"{runner.workers} worker(s))")
    futures = {}
    for key, task in units:
        fut = runner.submit(solve_unit, task, key=key, kind="te_unit")
        if runner.workers <= 1:       # the serial runner has solved it at submission
            finished(fut, key in kept)
        else:
            futures[fut] = key
    for fut in as_completed(futures):
        finished(fut, futures[fut] in kept)
    if stats["stopped_by_deadline"]:
        log(f"deadline: {stats['not_started']} unit(s) not started (resume with --resume on this --out)")
    return stats


def job_te(job, store):
    """A job's TE from its units stored in ``store`` (a :func:`rvtool.analysis.workunits.folder_runner`): ``{"status": "ok"|"failed"|"missing", "error", "te_arcsec" (array over
    the job's grid, zero at its first point), "pp_arcsec", "wall_s"}``."""
    from ..observe.transmission import transmission_error
    parts, errors, wall = [], [], 0.0
    for key, _i0, _i1 in job["units"]:
        r = stored(store, key)
        if r is None:
            return {"status": "missing", "error": None, "te_arcsec": None, "pp_arcsec": None, "wall_s": None}
        wall += r["wall_s"]
        if r["status"] != "ok":
            errors.append(f"points {r['i0']}..{r['i1'] - 1}: {r['error']}")
        parts.append(r)
    if errors:
        return {"status": "failed", "error": "; ".join(errors), "te_arcsec": None, "pp_arcsec": None, "wall_s": wall}
    th_in = np.concatenate([p["theta_in"] for p in parts])
    th_out = np.concatenate([p["theta_out"] for p in parts])
    te = transmission_error(th_in, th_out, parts[0]["ratio"], unwrap=False) * ARCSEC_PER_RAD
    return {"status": "ok", "error": None, "te_arcsec": te, "pp_arcsec": float(np.ptp(te)), "wall_s": wall}


def orders(te_arcsec, top=4):
    """Harmonic content of a TE curve sampled evenly over one period (the output revolution): the amplitude
    [arcsec] of order 1 (once per period) and the ``top`` orders of largest amplitude, [[order, amplitude]]."""
    x = np.asarray(te_arcsec, float)
    amp = 2.0 * np.abs(np.fft.rfft(x - x.mean())) / len(x)
    amp[0] = 0.0
    best = np.argsort(amp)[::-1][:top]
    return {"order1_arcsec": float(amp[1]) if len(amp) > 1 else None,
            "top_orders": [[int(k), float(amp[k])] for k in best]}


def window_pps(te_arcsec, n_window):
    """Peak-to-peak [arcsec] of each consecutive whole window of ``n_window`` points."""
    te = np.asarray(te_arcsec)
    return [float(np.ptp(te[i:i + n_window])) for i in range(0, len(te) - n_window + 1, n_window)]


# -- the TE comparison over the output revolution (the full mode of cases/rv/te_measured_rv80e.py) -----------------

RESOLUTION_PPM = (2, 4)
"""Points per mesh cycle of the principal runs and of the resolution check (variant 0 again at the second)."""


def _dist(values):
    x = np.sort([v for v in values if v is not None])
    if not len(x):
        return None
    return {"n": int(len(x)), "min": float(x[0]), "p5": float(np.percentile(x, 5)), "median": float(np.median(x)),
            "p95": float(np.percentile(x, 95)), "max": float(x[-1])}


def plan_revolution(design_name, design, rated_torque, *, variants=16, draws=1, resolution=True,
                    chunk_points=CHUNK_POINTS, input_revolutions=None):
    """The jobs of the comparison over one output revolution (|ratio| input revolutions): the nominal design,
    tolerance variants 0 .. variants-1 (``sample_rv_design`` of the design's tolerance file, seed
    :data:`rvtool.analysis.validate_te.SEED`), each field of the tolerance file alone for ``draws`` draws (the
    one-at-a-time sensitivity), all at :data:`RESOLUTION_PPM` [0] points per mesh cycle, and variant 0 again at
    :data:`RESOLUTION_PPM` [1] (``resolution``). ``input_revolutions`` (None: the output revolution) shortens the
    runs for a smoke test only. Returns ``{"jobs", "settings", ...}`` for :func:`assemble`."""
    from dataclasses import fields as dc_fields

    from .. import designs
    from ..assembly import build
    from ..variants.rv_tolerances import RvToleranceSpec, load_rv_tolerances, sample_rv_design
    from . import validate_te as VT
    tol_name = designs.tolerances_of(design_name)
    if tol_name is None:
        raise RvtoolInputError(f"design {design_name!r} ships no tolerance file (<design>_tolerances.toml)")
    spec = load_rv_tolerances(designs.path(tol_name))
    from ..protocols.precision import quasi_static_te
    model = build(design)
    # one point here compiles the Warp kernels into the on-disk cache once, before the pool's workers would each
    # compile them at the same time on a fresh host
    quasi_static_te(model, torque=VT.TE_TORQUE_FRACTION * rated_torque, input_angles=[0.0])
    mesh = float(model.mesh_period)
    revs = out_rev = output_revolutions(model)       # input revolutions of one output revolution
    if input_revolutions is not None:
        revs = float(input_revolutions)
    torque = VT.TE_TORQUE_FRACTION * rated_torque
    ppm, ppm_fine = RESOLUTION_PPM
    kw = dict(torque=torque, mesh_period=mesh, input_revolutions=revs, chunk_points=chunk_points)
    # in the order of priority (a deadline cuts the run at the end): the principal comparison, the resolution, the
    # one-at-a-time sensitivity
    jobs = [make_job("nominal", design, points_per_mesh=ppm, meta={"group": "nominal"}, **kw)]
    fine = None
    for k in range(int(variants)):
        dv, drawn = sample_rv_design(spec, design, k, VT.SEED)
        dev = {f: float(np.max(np.abs(np.asarray(v, float)))) for f, v in drawn.items()}
        jobs.append(make_job(f"variant {k}", dv, points_per_mesh=ppm,
                             meta={"group": "variants", "index": k, "deviations": dev}, **kw))
        if k == 0 and resolution:
            fine = make_job(f"variant {k} at {ppm_fine} points per mesh", dv, points_per_mesh=ppm_fine,
                            meta={"group": "resolution", "index": k}, **kw)
    if fine is not None:
        jobs.append(fine)
    for f in dc_fields(spec):
        dist = getattr(spec, f.name)
        if dist is None:
            continue
        one = RvToleranceSpec(**{f.name: dist})
        for k in range(int(draws)):
            dv, drawn = sample_rv_design(one, design, k, VT.SEED)
            jobs.append(make_job(f"{f.name} draw {k}", dv, points_per_mesh=ppm,
                                 meta={"group": "sensitivity", "field": f.name, "index": k,
                                       "deviation": float(np.max(np.abs(np.asarray(drawn[f.name], float))))}, **kw))
    n_win = grid_points(VT.te_window(design), mesh, ppm)
    settings = {"tolerances": f"{tol_name}.toml", "variants": int(variants), "sensitivity_draws": int(draws),
                "seed": VT.SEED, "torque_fraction": VT.TE_TORQUE_FRACTION, "torque_Nm": torque,
                "input_revolutions": revs, "window_input_revolutions": VT.te_window(design),
                "points_per_mesh": ppm, "resolution_points_per_mesh": ppm_fine if resolution else None,
                "n_points": grid_points(revs, mesh, ppm), "window_points": n_win, "chunk_points": chunk_points,
                "jobs": len(jobs), "units": sum(len(j["units"]) for j in jobs),
                "inputs_digest": revolution_inputs_digest(design_name, design, rated_torque, variants=variants,
                                                          input_revolutions=revs, model=model)}
    return {"design_name": design_name, "jobs": jobs, "settings": settings, "mesh_period": mesh,
            "ratio": out_rev}


def assemble(plan, store, measured_name=None):
    """The results of a (possibly partial) run: ``rows`` (validate's table, over the output revolution),
    ``distribution`` (the variants' output-revolution peak-to-peak), ``distribution_window`` (their first
    19-revolution window, the quick mode's figure on the same grid), ``records``, ``nominal_pp_arcsec``,
    ``resolution``, ``sensitivity`` (one at a time, over the revolution and the window), ``complete`` and
    ``jobs_done`` / ``jobs_total``; the TE curves of the nominal design and variant 0 under ``curves``."""
    from .. import designs
    from ..designs.measured import load_measured
    from . import validate_te as VT
    te = {j["name"]: job_te(j, store) for j in plan["jobs"]}
    for j in plan["jobs"]:
        r = te[j["name"]]
        nw = grid_points(plan["settings"]["window_input_revolutions"], plan["mesh_period"], j["points_per_mesh"])
        r["windows_pp_arcsec"] = None if r["te_arcsec"] is None else window_pps(r["te_arcsec"], nw)
    nom = te["nominal"]
    nominal_pp = nom["pp_arcsec"]
    records = []
    for j in plan["jobs"]:
        if j["meta"]["group"] != "variants":
            continue
        r = te[j["name"]]
        w = r["windows_pp_arcsec"]
        records.append({"index": j["meta"]["index"], "status": r["status"], "error": r["error"],
                        "te_pp_arcsec": r["pp_arcsec"], "window_pp_arcsec": w[0] if w else None,
                        "windows_pp_arcsec": w, "window_to_revolution_max": (max(w) / r["pp_arcsec"]) if w else None,
                        **(orders(r["te_arcsec"]) if r["te_arcsec"] is not None else
                           {"order1_arcsec": None, "top_orders": None}),
                        "deviations": j["meta"]["deviations"], "wall_s": r["wall_s"]})
    dist = _dist([r["te_pp_arcsec"] for r in records])
    # orders are per output revolution where the runs cover it (a shortened smoke run: per run length)
    out = {"mode": "output_revolution", "distribution": dist, "orders_per": (
               "output revolution" if abs(plan["settings"]["input_revolutions"] - plan["ratio"]) < 1e-9 else
               f"run of {plan['settings']['input_revolutions']:g} input revolutions"),
           "order1_distribution": _dist([r["order1_arcsec"] for r in records]),
           "nominal_orders": orders(nom["te_arcsec"]) if nom["te_arcsec"] is not None else None,
           "distribution_window": _dist([r["window_pp_arcsec"] for r in records]),
           "nominal_pp_arcsec": nominal_pp, "records": records,
           "n_failed": sum(r["status"] == "failed" for r in records),
           "n_missing": sum(r["status"] == "missing" for r in records)}
    # resolution: variant 0 at the two resolutions
    res = [j for j in plan["jobs"] if j["meta"]["group"] == "resolution"]
    if res:
        fine, coarse = te[res[0]["name"]], te["variant 0"]
        err = None if fine["pp_arcsec"] is None or coarse["pp_arcsec"] is None else fine["pp_arcsec"] - coarse[
            "pp_arcsec"]
        out["resolution"] = {"variant": 0, "points_per_mesh": list(RESOLUTION_PPM),
                             "pp_arcsec": [coarse["pp_arcsec"], fine["pp_arcsec"]], "resolution_error_arcsec": err,
                             "resolution_error_relative": None if err is None else err / fine["pp_arcsec"],
                             "status": fine["status"], "error": fine["error"]}
    # one at a time
    fields = {}
    for j in plan["jobs"]:
        if j["meta"]["group"] != "sensitivity":
            continue
        f = fields.setdefault(j["meta"]["field"], {"te_pp_arcsec": [], "window_pp_arcsec": [], "errors": [],
                                                   "deviation": 0.0})
        r = te[j["name"]]
        f["te_pp_arcsec"].append(r["pp_arcsec"])
        f["window_pp_arcsec"].append(r["windows_pp_arcsec"][0] if r["windows_pp_arcsec"] else None)
        f["errors"].append(r["error"] if r["status"] != "missing" else "not run (deadline)")
        f["deviation"] = max(f["deviation"], j["meta"]["deviation"])
    nom_win = nom["windows_pp_arcsec"][0] if nom["windows_pp_arcsec"] else None
    for f in fields.values():
        ok = [x for x in f["te_pp_arcsec"] if x is not None]
        okw = [x for x in f["window_pp_arcsec"] if x is not None]
        f["median_arcsec"] = float(np.median(ok)) if ok else None
        f["excess_arcsec"] = None if not ok or nominal_pp is None else f["median_arcsec"] - nominal_pp
        f["window_median_arcsec"] = float(np.median(okw)) if okw else None
        f["window_excess_arcsec"] = None if not okw or nom_win is None else f["window_median_arcsec"] - nom_win
    if fields:
        def rank(key):
            r = sorted(((v[key], k) for k, v in fields.items() if v[key] is not None), reverse=True)
            return [k for _, k in r]
        out["sensitivity"] = {"nominal_pp_arcsec": nominal_pp, "nominal_window_pp_arcsec": nom_win,
                              "draws": plan["settings"]["sensitivity_draws"],
                              "points_per_mesh": RESOLUTION_PPM[0], "over": "output revolution", "fields": fields,
                              "ranking": rank("excess_arcsec"), "ranking_window": rank("window_excess_arcsec")}
        out["sensitivity"]["dominant"] = (out["sensitivity"]["ranking"] or [None])[0]
        out["sensitivity"]["dominant_window"] = (out["sensitivity"]["ranking_window"] or [None])[0]
    # the comparison rows (the same schema as the quick mode's, over the output revolution)
    meas_name = measured_name or designs.measured_of(plan["design_name"])
    measured = load_measured(meas_name)
    s = plan["settings"]
    note = (f"{len(records)} variants ({s['tolerances']}), seed {s['seed']}; quasi-static TE at "
            f"{s['torque_fraction']:g} T_R over one output revolution ({s['input_revolutions']:g} input revolutions, "
            f"the measured definition, Yang et al. Eq. (38)), {s['points_per_mesh']} points per mesh cycle"
            + ("" if dist is None or dist["n"] == len(records) else
               f"; {len(records) - dist['n']} variant(s) not finished or failed"))
    recs_rad = [{"te_pp_rad": None if r["te_pp_arcsec"] is None else r["te_pp_arcsec"] / ARCSEC_PER_RAD}
                for r in records]
    over = ("one output revolution, the measured definition" if out["orders_per"] == "output revolution" else
            f"{s['input_revolutions']:g} input revolutions (a shortened smoke run)")
    out["rows"] = VT.te_rows(measured, VT.te_distribution(recs_rad), note, over=over)
    out["measured"] = VT.measured_summary(measured)
    jobs_done = sum(te[j["name"]]["status"] != "missing" for j in plan["jobs"])
    out.update(complete=jobs_done == len(plan["jobs"]), jobs_done=jobs_done, jobs_total=len(plan["jobs"]))
    out["settings"] = {**s, "measured": f"{meas_name}.toml", "tolerances_commit": measured.tolerances_commit}
    # curves for the plot (not in results.json: large)
    out["curves"] = {"nominal": nom["te_arcsec"], "variant 0": te["variant 0"]["te_arcsec"] if records else None,
                     "fine": te[res[0]["name"]]["te_arcsec"] if res else None}
    return out


def revolution_plots(r, out_dir):
    """te_revolution.png (the nominal design's and variant 0's TE over the output revolution, variant 0 at both
    resolutions) and te_sensitivity.png (each field's excess over the window and over the revolution); returns the
    file names written."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = []
    c = r.get("curves") or {}
    if any(v is not None for v in c.values()):
        fig, ax = plt.subplots(figsize=(7, 3.6))
        for key, style in (("variant 0", dict(color="C0", lw=0.8)), ("fine", dict(color="C3", lw=0.5, ls="--")),
                           ("nominal", dict(color="k", lw=0.8))):
            y = c.get(key)
            if y is None:
                continue
            y = np.asarray(y)
            lab = {"variant 0": f"variant 0, {RESOLUTION_PPM[0]} points/mesh",
                   "fine": f"variant 0, {RESOLUTION_PPM[1]} points/mesh", "nominal": "nominal design"}[key]
            ax.plot(np.linspace(0, 360, len(y), endpoint=False), y - y.mean(), label=lab, **style)
        ax.set(xlabel="output angle [deg]", ylabel="TE minus its mean [arcsec]",
               title="quasi-static TE over one output revolution")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, "te_revolution.png"), dpi=110)
        plt.close(fig)
        names.append("te_revolution.png")
    s = r.get("sensitivity")
    if s:
        keys = list(s["fields"])
        rev = [s["fields"][k]["excess_arcsec"] or 0.0 for k in keys]
        win = [s["fields"][k]["window_excess_arcsec"] or 0.0 for k in keys]
        fig, ax = plt.subplots(figsize=(7, 4))
        yy = np.arange(len(keys))
        ax.barh(yy - 0.2, win, height=0.4, color="0.6", label="19-revolution window")
        ax.barh(yy + 0.2, rev, height=0.4, color="C0", label="output revolution")
        ax.set_yticks(yy, keys, fontsize=7)
        ax.set(xlabel="median TE peak-to-peak minus the nominal design's [arcsec]", title="one source at a time")
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, "te_sensitivity.png"), dpi=110)
        plt.close(fig)
        names.append("te_sensitivity.png")
    return names
