"""Parameter studies and the tolerance Monte Carlo on a Dask cluster (issue 8): ``rvtool sweep SPEC``.

Every task is one Exudyn run of :func:`rvtool.variants.variant_figures` (one parameter
point or one sampled variant) or, in batched Monte Carlo mode, one batch of variants.
Tasks run on a ``dask.distributed.LocalCluster`` (default) or on an existing cluster
whose scheduler address is given. A plain text progress bar on stderr advances as tasks
complete; a task that fails (its run raises, or the task itself is lost) is reported in
its row with ``status = "failed"`` and the error, and the sweep goes on. The results table
is tidy, one row per run: the parameters, the figures (te_pp_arcsec, te_rms_arcsec,
max_pin_force_N, lost_motion_arcmin, newton_iterations), wall_s, status and error; it is
written as ``results.csv`` and ``results.json`` in the output folder (the Monte Carlo also
keeps its resumable chunk files in ``chunks/`` there, see :mod:`rvtool.variants.montecarlo`).

SPEC format (TOML; relative paths in it are relative to the SPEC file)::

    design = "rd40.toml"            # design file (rvtool.assembly.spec.load_design)
    study = "grid"                  # "grid" (cartesian product of [parameters]) or "monte_carlo"
    output_dir = "../../results/sweep_rd40"   # results folder (the --out option overrides it)

    [protocol]                      # fields of rvtool.variants.VariantProtocol
    n_te_points = 23
    bearing_model = "lumped"

    [build]                         # keyword arguments of rvtool.assembly.cycloid.build (optional)
    regularization = [1000.0, 10.0] # [N/m, N m/rad]

    [parameters]                    # study = "grid": name = list of values (SI units)
    eccentricity_error = [-4e-6, -2e-6, 0.0, 2e-6, 4e-6]   # a Variant field ...
    "wheels.clearance" = [0.0, 2e-6]                        # ... or "section.field" of the design

    [monte_carlo]                   # study = "monte_carlo"
    tolerances = "rd40_tolerances.toml"   # file with a [tolerances] table (rvtool.variants.tolerances)
    n_variants = 100
    seed = 0
    chunk_size = 10                 # variants per result file (and per task when batched)
    batched = false                 # true: one task per chunk through rvtool.batched
    mode = "auto"                   # optional, overrides batched: pool, batched, device or auto
                                    # (device: TE of a chunk on the device Newton; auto: the fastest)
    device = "cpu"                  # device of the batched / device path ("auto": a GPU if present)

    [grid]                          # optional, study = "grid"
    mode = "point"                  # point: one Exudyn run per point; device: the TE of all points
                                    # sharing a design in one device Newton batch, lost motion per point
    device = "cpu"                  # device of grid.mode = "device" ("auto": a GPU if present)

    [cluster]                       # LocalCluster settings (ignored with a scheduler address)
    scheduler = ""                  # address of an existing scheduler; "" = start a LocalCluster
    n_workers = 2
    threads_per_worker = 1
    processes = true

Grid parameters that are Variant fields (eccentricity_error, pin_radius_error,
equidistant_mod, offset_mod, pin_clearance, bearing_clearance) become a
:class:`~rvtool.variants.Variant` of the design; ``section.field`` names change the
design itself (:func:`rvtool.assembly.spec.replace`).
"""
import csv
import dataclasses
import itertools
import json
import os
import sys
import threading
import time
import tomllib
from dataclasses import dataclass, field

from ..errors import RvtoolInputError
from .. import progress as progress_display
from .cluster import dask_client
from .montecarlo import FIGURES, MonteCarloSettings, run_monte_carlo
from .variant import Variant, VariantProtocol, variant_figures

VARIANT_PARAMETERS = ("eccentricity_error", "pin_radius_error", "equidistant_mod", "offset_mod", "pin_clearance",
                      "bearing_clearance")
"""Scalar Variant fields that a grid may sweep."""

STUDIES = ("grid", "monte_carlo")
GRID_MODES = ("point", "device")
"""Grid execution: one Exudyn run per point, or the TE of the points that share a design in one
device Newton batch (rvtool.solver.device_newton)."""

ROW_TAIL = FIGURES + ("te_path", "te_fallback_points", "newton_iterations", "wall_s", "status", "error")
"""Columns after the parameters in every row."""


@dataclass(frozen=True, kw_only=True)
class ClusterSettings:
    """scheduler: address of an existing Dask scheduler ("" = start a LocalCluster with
    n_workers workers of threads_per_worker threads, as processes or threads)."""
    scheduler: str = ""
    n_workers: int = 2
    threads_per_worker: int = 1
    processes: bool = True

    def __post_init__(self):
        for nm in ("n_workers", "threads_per_worker"):
            v = getattr(self, nm)
            if not isinstance(v, int) or v < 1:
                raise RvtoolInputError(f"cluster.{nm} = {v!r} is outside the valid range [1, inf) (integer)")


@dataclass(frozen=True, kw_only=True)
class SweepSpec:
    """A sweep specification (module docstring); paths are absolute."""
    design_path: str
    study: str = "grid"
    output_dir: str = "results/sweep"
    protocol: VariantProtocol = field(default_factory=VariantProtocol)
    build: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    monte_carlo: dict = field(default_factory=dict)
    cluster: ClusterSettings = field(default_factory=ClusterSettings)
    grid: dict = field(default_factory=dict)

    def __post_init__(self):
        if set(self.grid) - {"mode", "device"}:
            raise RvtoolInputError(f"[grid] has unknown keys {sorted(set(self.grid) - {'mode', 'device'})}; valid keys "
                                   f"are ['device', 'mode']")
        if self.grid.get("mode", "point") not in GRID_MODES:
            raise RvtoolInputError(f"grid.mode = {self.grid['mode']!r}; valid choices are {list(GRID_MODES)}")
        if self.study not in STUDIES:
            raise RvtoolInputError(f"study = {self.study!r}; valid choices are {list(STUDIES)}")
        if self.study == "grid" and not self.parameters:
            raise RvtoolInputError("study = 'grid' needs a non-empty [parameters] table (name = [values])")
        for nm, vals in self.parameters.items():
            if not isinstance(vals, (list, tuple)) or not vals:
                raise RvtoolInputError(f"parameters.{nm} = {vals!r}; valid: a non-empty list of values")

    def points(self, design):
        """Grid points: dicts name -> value in the order of the cartesian product (last name fastest)."""
        names = list(self.parameters)
        for nm in names:
            _check_parameter_name(nm, design)
        return [dict(zip(names, vals)) for vals in itertools.product(*(self.parameters[n] for n in names))]


def _check_parameter_name(name, design):
    if name in VARIANT_PARAMETERS:
        return
    sec, _, fld = name.partition(".")
    sub = getattr(design, sec, None) if fld else None
    if sub is None or not dataclasses.is_dataclass(sub) or fld not in {f.name for f in dataclasses.fields(sub)}:
        raise RvtoolInputError(f"parameters.{name}: not a sweepable parameter; valid names are {list(VARIANT_PARAMETERS)} "
                               f"or 'section.field' of the design (e.g. 'wheels.clearance')")


def load_sweep_spec(path):
    """SweepSpec from a TOML file; unknown keys and tables are errors naming them."""
    path = os.path.abspath(path)
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    base = os.path.dirname(path)
    valid = {"design", "study", "output_dir", "protocol", "build", "parameters", "monte_carlo", "cluster", "grid"}
    unknown = set(data) - valid
    if unknown:
        raise RvtoolInputError(f"sweep spec {path} has unknown keys {sorted(unknown)}; valid keys are {sorted(valid)}")
    if "design" not in data:
        raise RvtoolInputError(f"sweep spec {path} has no 'design' (path of the design TOML file)")
    try:
        protocol = VariantProtocol(**data.get("protocol", {}))
    except RvtoolInputError as exc:     # the spec's key path: a value of [protocol] is protocol.NAME
        msg = str(exc)
        raise RvtoolInputError(msg if msg.startswith("protocol.") else f"protocol.{msg}") from None
    except TypeError as exc:
        raise RvtoolInputError(f"sweep spec [protocol]: {exc}") from None
    try:
        cluster = ClusterSettings(**data.get("cluster", {}))
    except TypeError as exc:
        raise RvtoolInputError(f"sweep spec [cluster]: {exc}") from None
    build = {k: tuple(v) if isinstance(v, list) else v for k, v in data.get("build", {}).items()}
    mc = dict(data.get("monte_carlo", {}))
    mc_valid = {"tolerances", "n_variants", "seed", "chunk_size", "batched", "device", "mode"}
    if set(mc) - mc_valid:
        raise RvtoolInputError(f"[monte_carlo] has unknown keys {sorted(set(mc) - mc_valid)}; valid keys are {sorted(mc_valid)}")
    if "tolerances" in mc:
        mc["tolerances"] = os.path.join(base, mc["tolerances"])
    study = data.get("study", "grid")
    if study == "monte_carlo" and ("tolerances" not in mc or "n_variants" not in mc):
        raise RvtoolInputError("study = 'monte_carlo' needs monte_carlo.tolerances and monte_carlo.n_variants")
    return SweepSpec(design_path=os.path.join(base, data["design"]), study=study,
                     output_dir=os.path.join(base, data.get("output_dir", "sweep_results")),
                     protocol=protocol, build=build, parameters=dict(data.get("parameters", {})), monte_carlo=mc,
                     cluster=cluster, grid=dict(data.get("grid", {})))


def point_model(design, params):
    """(design', Variant) of one grid point."""
    from ..assembly.spec import replace
    vkw, sections = {}, {}
    for nm, v in params.items():
        if nm in VARIANT_PARAMETERS:
            vkw[nm] = v
        else:
            sec, _, fld = nm.partition(".")
            sections.setdefault(sec, {})[fld] = tuple(v) if isinstance(v, list) else v
    return (replace(design, **sections) if sections else design), Variant(**vkw)


def run_point(design, params, protocol, build_kw=None):
    """One row: the point's parameters, figures, wall time, status and error (a failed run is a
    row with status "failed", not an exception)."""
    t0 = time.perf_counter()
    row = dict(params)
    try:
        d, v = point_model(design, params)
        fig = variant_figures(d, v, protocol, **(build_kw or {}))
    except Exception as exc:  # reported in the row: one failed point must not stop the sweep
        row.update({nm: None for nm in FIGURES + ("newton_iterations",)})
        row.update(wall_s=time.perf_counter() - t0, status="failed", error=f"{type(exc).__name__}: {exc}")
        return row
    row.update({nm: fig[nm] for nm in FIGURES + ("newton_iterations",)})
    row.update(wall_s=fig["wall_s"], status="ok", error=None)
    return row


def run_device_group(design, points, protocol, build_kw=None, device="cpu"):
    """Rows of grid points that share one design (their other parameters are Variant fields):
    the TE and the lost motion of all points in one device Newton batch
    (:func:`rvtool.variants.device.device_variant_figures`). A failed point is a row with status "failed"."""
    from .device import device_variant_figures
    t0 = time.perf_counter()
    try:
        variants = [point_model(design, p)[1] for p in points]
        extra = sorted(set(build_kw or {}) - {"regularization"})
        if extra:
            raise RvtoolInputError(f"build options {extra} are not accepted by grid.mode = 'device'; valid: "
                                   f"['regularization']")
        figs = device_variant_figures(design, variants, protocol, device=device, **(build_kw or {}))
    except Exception as exc:  # the group shares one batch: all its points failed
        err = f"{type(exc).__name__}: {exc}"
        wall = (time.perf_counter() - t0) / max(len(points), 1)
        return [{**p, **{nm: None for nm in FIGURES + ("newton_iterations",)}, "wall_s": wall, "status": "failed",
                 "error": err} for p in points]
    rows = []
    for p, f in zip(points, figs):
        row = dict(p)
        ok = f["status"] == "ok"
        row.update({nm: (f[nm] if ok else None) for nm in FIGURES + ("newton_iterations",)})
        row.update(te_path=f["te_path"], te_fallback_points=f["te_fallback_points"], wall_s=f["wall_s"],
                   status=f["status"], error=f["error"])
        rows.append(row)
    return rows


def write_table(rows, out_dir, name="results"):
    """Write the rows as ``name.csv`` and ``name.json`` (each atomically); returns the two paths."""
    os.makedirs(out_dir, exist_ok=True)
    cols = []
    for r in rows:
        cols += [k for k in r if k not in cols and k not in ROW_TAIL]
    cols += [c for c in ROW_TAIL if any(c in r for r in rows)]
    paths = []
    for ext in ("csv", "json"):
        # a temporary name of this process and thread, opened as any file (mode 0666 less the umask,
        # not tempfile.mkstemp's 0600: the table is the user's result)
        tmp = os.path.join(out_dir, f".{name}.{os.getpid()}.{threading.get_ident()}.{ext}")
        with open(tmp, "w", newline="") as fh:
            if ext == "csv":
                w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
                w.writeheader()
                for r in rows:
                    w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in cols})
            else:
                json.dump([{k: r.get(k) for k in cols} for r in rows], fh, indent=1)
        path = os.path.join(out_dir, f"{name}.{ext}")
        os.replace(tmp, path)
        paths.append(path)
    return paths


def run_grid(client, design, spec, progress=None):
    """Rows of a grid study in grid order: one Dask task per point (grid.mode "point"), or one
    task per group of points that share a design, their TE on the device Newton (grid.mode
    "device", on grid.device; "auto": a GPU if present)."""
    from dask.distributed import as_completed
    points = spec.points(design)
    if spec.grid.get("mode", "point") == "device":
        return _run_grid_device(client, design, spec, points, progress)
    futs = [client.submit(run_point, design, p, spec.protocol, spec.build, pure=False) for p in points]
    index = {f.key: i for i, f in enumerate(futs)}
    rows = [None] * len(points)
    done = 0
    if progress is not None:
        progress(0, len(points))
    for fut in as_completed(futs):
        i = index[fut.key]
        if fut.status == "finished":
            rows[i] = fut.result()
        else:  # the task itself failed (e.g. its worker died): reported in its row
            exc = fut.exception()
            rows[i] = {**points[i], **{nm: None for nm in FIGURES + ("newton_iterations",)},
                       "wall_s": None, "status": "failed", "error": f"{type(exc).__name__}: {exc}"}
        done += 1
        if progress is not None:
            progress(done, len(points))
    return [{"point": i, **r} for i, r in enumerate(rows)]


def _run_grid_device(client, design, spec, points, progress):
    from dask.distributed import wait
    from warp_contacts.precision import resolve_device
    device = spec.grid.get("device", "cpu")
    if device == "auto":
        device = resolve_device("auto", n_contacts=10 ** 9)
    groups = {}
    for i, p in enumerate(points):
        d, _ = point_model(design, {k: v for k, v in p.items() if k not in VARIANT_PARAMETERS})
        groups.setdefault(repr(d), (d, []))[1].append(i)
    futs = [(idx, client.submit(run_device_group, d, [points[i] for i in idx], spec.protocol, spec.build, device,
                                pure=False)) for d, idx in groups.values()]
    wait([f for _, f in futs])
    rows = [None] * len(points)
    for idx, fut in futs:
        res = fut.result() if fut.status == "finished" else [
            {**points[i], **{nm: None for nm in FIGURES + ("newton_iterations",)}, "wall_s": None, "status": "failed",
             "error": f"{type(fut.exception()).__name__}: {fut.exception()}"} for i in idx]
        for i, r in zip(idx, res):
            rows[i] = r
    if progress is not None:
        progress(len(points), len(points))
    return [{"point": i, **r} for i, r in enumerate(rows)]


def run_sweep(spec: SweepSpec, *, scheduler=None, out_dir=None, progress=True, client=None):
    """Run a sweep; returns ``{"rows", "failed", "wall_s", "table": [csv, json], "out_dir"}`` (plus
    ``summary`` for the Monte Carlo). ``client``: an existing dask.distributed.Client to use.
    progress: True (shown by the active :func:`rvtool.progress.reporting` context, silent
    without one), False, or a ``progress(done, total)`` callback."""
    from ..assembly.spec import load_design
    t0 = time.perf_counter()
    out_dir = out_dir or spec.output_dir
    design = load_design(spec.design_path)
    prog = progress_display.callback("sweep", unit="run") if progress is True else (progress or None)
    summary = None
    c = spec.cluster
    with (_nullcontext(client) if client is not None else
          dask_client(scheduler or c.scheduler, n_workers=c.n_workers, threads_per_worker=c.threads_per_worker,
                      processes=c.processes)) as cl:
        if spec.study == "grid":
            rows = run_grid(cl, design, spec, prog)
        else:
            from .tolerances import load_tolerances
            mc = spec.monte_carlo
            tol = load_tolerances(mc["tolerances"])
            settings = MonteCarloSettings(n_variants=int(mc["n_variants"]), seed=int(mc.get("seed", 0)),
                                          chunk_size=int(mc.get("chunk_size", 10)),
                                          mode=mc.get("mode", "batched" if mc.get("batched", False) else "pool"),
                                          device=mc.get("device", "cpu"))
            res = run_monte_carlo(design, tol, spec.protocol, settings, os.path.join(out_dir, "chunks"),
                                  executor=cl.get_executor(pure=False), progress=prog, build_kw=spec.build)
            rows, summary = res["records"], res["summary"]
    table = write_table(rows, out_dir)
    out = {"rows": rows, "failed": sum(r["status"] != "ok" for r in rows), "wall_s": time.perf_counter() - t0,
           "table": table, "out_dir": out_dir}
    if summary is not None:
        out["summary"] = summary
        # which TE path ran and how many TE points fell back from the device Newton to Exudyn
        out.update({k: res[k] for k in ("mode", "device", "te_paths", "te_fallback_points")})
    return out


class _nullcontext:
    def __init__(self, value):
        self.value = value

    def __enter__(self):
        return self.value

    def __exit__(self, *exc):
        return False


def main_sweep(spec_path, scheduler=None, out_dir=None, quiet=False):
    """CLI entry: run the sweep of ``spec_path``; print a summary line; exit status 0 (failed rows
    are results, reported in the table and on stderr)."""
    spec = load_sweep_spec(spec_path)
    with progress_display.reporting("quiet" if quiet else "auto"):
        res = run_sweep(spec, scheduler=scheduler, out_dir=out_dir, progress=True)
    n = len(res["rows"])
    print(f"sweep: {n} runs, {res['failed']} failed, {res['wall_s']:.1f} s; table: {', '.join(res['table'])}")
    for r in res["rows"]:
        if r["status"] != "ok":
            print(f"  failed: {({k: r[k] for k in r if k not in ROW_TAIL})}: {r['error']}", file=sys.stderr)
    return res
