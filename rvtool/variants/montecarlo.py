"""Tolerance Monte Carlo protocol (issue 8): per-variant figures of sampled
manufacturing variants, resumable, with distributions and confidence intervals.

Variants k = 0 .. n-1 are drawn by :func:`rvtool.variants.tolerances.sample_variant` (each from
its own seeded generator) and run by the per-variant reference protocol
:func:`rvtool.variants.variant_figures` (quasi-static TE over one output revolution,
maximum pin force, lost motion), in one of three modes:

* ``"pool"``: one task per variant on a Dask cluster (:mod:`rvtool.variants.cluster`: the
  scheduler at ``settings.scheduler``, or a LocalCluster of spawned worker processes, default
  one per core, each limited to one BLAS/OpenMP thread, so that the workers do not
  oversubscribe the cores), or on any ``concurrent.futures.Executor`` passed in;
* ``"batched"``: one batch per chunk through ``rvtool.batched.batched_variant_figures``
  (all variants of a chunk in one Exudyn system), in this process (which holds the device),
  or one task per chunk on a given executor;
* ``"serial"``: in this process, one variant after the other;
* ``"device"``: as ``"batched"``, with the quasi-static TE and the lost motion of each chunk on
  the device Newton (:func:`rvtool.variants.device.device_variant_figures`: all (variant,
  angle) pairs of the chunk in one device loop, the lost-motion continuations of the chunk's
  variants side by side; failed copies on the per-variant Exudyn path), on ``device`` ("cpu": chunks side by side in the pool; "cuda:N": one chunk after
  another in this process);
* ``"auto"``: the fastest measured path for this protocol (TE and lost motion): ``"device"``
  (:func:`resolve_mode`, see there for the measurements).

Each record names its TE path (``te_path``) and the number of its TE points that fell back
from the device Newton to Exudyn (``te_fallback_points``; None for the Exudyn modes), the path
of its lost motion (``lost_motion_path``: the device Newton's, or "exudyn") and whether it fell
back from the device to Exudyn (``lost_motion_fallback``; None for the Exudyn modes).

Resumable: the variants are grouped in chunks of ``chunk_size`` consecutive indices; a
chunk's records are written as soon as its last variant finishes, to
``out_dir/chunk_NNNNN.json`` through a temporary file and ``os.replace`` (an atomic
rename: a chunk file is either complete or absent). Every file carries a fingerprint
of the design, tolerances, protocol, seed and chunk size; a restarted study loads the
chunks with a matching fingerprint and index range and runs only the others, so it
returns the same records as an uninterrupted run (all figures except the wall times
are deterministic functions of the variant). The fingerprint does not cover the code:
after a change of the solver or the builder, start in a fresh folder. A variant whose run raises (a
:class:`~rvtool.errors.SolverFailure`, or an invalid sampled variant) is recorded with
``status = "failed"`` and its error; it does not stop the study.

:func:`summarize` reports, per figure, over the successful variants: mean, std, p5, p50,
p95, a 95 % confidence interval of the mean (Student t, which is the normal interval for
large n) and a distribution-free 95 % order-statistic confidence interval of p95 (ranks
from the binomial distribution of the number of samples below the true quantile; a bound
that needs a rank outside 1..n is reported as None, e.g. the upper bound for n < 59).
"""
import concurrent.futures as cf
import contextlib
import hashlib
import json
import math
import multiprocessing
import os
import tempfile
import time
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from .cluster import THREAD_ENV, dask_client
from .cluster import single_thread_env as _single_thread_env
from .tolerances import sample_variant
from .variant import VariantProtocol, variant_figures

FIGURES = ("te_pp_arcsec", "te_rms_arcsec", "max_pin_force_N", "lost_motion_arcmin")
"""Figures of :func:`rvtool.variants.variant_figures` that the study reports distributions of."""


MODES = ("pool", "batched", "serial", "device", "auto")


def resolve_mode(mode, device):
    """(mode, device) that a study runs: ``"auto"`` -> the device Newton (TE and lost motion), on
    the first GPU if present (or on ``device`` if one is named), else on the CPU.

    Measured for the whole protocol (TE, max pin force, lost motion) on this 2-core machine,
    53 TE points, all modes on the same variants in one run, two pool processes each
    (README, "Lost motion on the device"): the device Newton on the CPU with lost motion as a batched load
    continuation (:func:`rvtool.batched.device_lost_motion.device_lost_motion`) ahead of batched
    Exudyn and of the per-variant pool. On the GPU the TE alone reached 2,000-2,800 variants/s
    on an H100 against 45.6 for a warmed 16-process pool (cases/benchmarks/bench_batched_te.py); before the
    lost motion ran on the device, the full study there took 292 s (3.4 variants/s) against
    20.7 for the pool and 17.1 for batched Exudyn, all of it in the per-variant lost motion,
    which the device path now batches as well (the full study on the GPU is the lead's
    measurement: README, "Lost motion on the device"). ``device="auto"`` with the other modes
    picks as :func:`warp_contacts.precision.resolve_device` for a large batch."""
    if mode != "auto" and device != "auto":
        return mode, device
    from warp_contacts.precision import resolve_device
    if mode == "auto":
        return "device", resolve_device("auto", n_contacts=10 ** 9) if device == "auto" else device
    return mode, resolve_device("auto", n_contacts=10 ** 9)


@dataclass(frozen=True, kw_only=True)
class MonteCarloSettings:
    """n_variants, seed (of :func:`numpy.random.default_rng` ([seed, k])), chunk_size (variants per
    result file and per batched task), mode ("pool", "batched" or "serial"), workers (pool processes;
    None = os.cpu_count()) and device (of the batched path: "cpu", "cuda:N" or "auto"). Batched
    mode on "cpu" with more than one worker runs one batch (chunk) per pool process; on a GPU,
    batches run one after another in the calling process, which holds the device.
    scheduler: the pool's Dask cluster: the address of an existing scheduler, or "" for a
    LocalCluster of ``workers`` processes started for the study (:mod:`rvtool.variants.cluster`).
    devices: the device mode over several devices of one host, e.g. ``("cuda:0", "cuda:1")`` or
    ``2`` (the first two GPUs): one Dask worker process per device, pinned to its GPU by
    ``CUDA_VISIBLE_DEVICES`` (:mod:`rvtool.variants.multi_device`), each free worker taking the
    next chunk; all cuda or all "cpu" (CI); None: one device (``device``)."""
    n_variants: int
    seed: int = 0
    chunk_size: int = 10
    mode: str = "pool"
    workers: int | None = None
    device: str = "cpu"
    scheduler: str = ""
    devices: object = None

    def __post_init__(self):
        for nm, lo in (("n_variants", 1), ("seed", 0), ("chunk_size", 1)):
            v = getattr(self, nm)
            if not isinstance(v, (int, np.integer)) or v < lo:
                raise RvtoolInputError(f"{nm} = {v!r} is outside the valid range [{lo}, inf) (integer)")
        if self.mode not in MODES:
            raise RvtoolInputError(f"mode = {self.mode!r}; valid choices are {list(MODES)}")
        if self.workers is not None and (not isinstance(self.workers, (int, np.integer)) or self.workers < 1):
            raise RvtoolInputError(f"workers = {self.workers!r} is outside the valid range [1, inf) (integer) or None")
        if self.devices is not None:
            from .multi_device import device_slots
            kinds = {s.device for s in device_slots(self.devices)}
            if len(kinds) != 1:
                raise RvtoolInputError(f"devices = {self.devices!r} mixes cpu and cuda workers; valid: all 'cuda:K' "
                                       f"or all 'cpu'")
            if self.mode not in ("device", "auto"):
                raise RvtoolInputError(f"devices = {self.devices!r} runs the device mode; mode = {self.mode!r} "
                                       f"(valid with devices: 'device', 'auto')")

    def chunks(self):
        """Index ranges (start, stop) of the chunks."""
        n, c = self.n_variants, self.chunk_size
        return [(s, min(s + c, n)) for s in range(0, n, c)]


def fingerprint(design, tolerances, protocol, seed, chunk_size, build_kw=None):
    """Hash of everything that determines a chunk's records (n_variants excluded: a study
    extended to more variants reuses the chunks it shares with the shorter one)."""
    text = json.dumps({"design": repr(design), "tolerances": tolerances.to_dict(), "protocol": repr(protocol),
                       "seed": int(seed), "chunk_size": int(chunk_size), "build_kw": repr(sorted((build_kw or {}).items()))},
                      sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def variant_parameters(variant):
    """Scalar description of a variant for tables: its scalar deviations [m] and the RMS and
    maximum magnitude of its pin-centre errors [m] (the full array is reproducible from the seed)."""
    out = {"index": int(variant.index)}
    for nm in ("eccentricity_error", "pin_radius_error", "equidistant_mod", "offset_mod", "pin_clearance",
               "bearing_clearance"):
        v = getattr(variant, nm)
        out[nm] = None if v is None else float(v)
    e = variant.pin_centre_errors
    if e is None:
        out["pin_centre_error_rms"] = out["pin_centre_error_max"] = 0.0
    else:
        r = np.hypot(*np.asarray(e, float).T)
        out["pin_centre_error_rms"] = float(np.sqrt(np.mean(r ** 2)))
        out["pin_centre_error_max"] = float(np.max(r))
    return out


def _record(variant, figures=None, error=None, wall_s=None):
    rec = variant_parameters(variant)
    for nm in FIGURES + ("newton_iterations",):
        v = None if figures is None else figures.get(nm)
        rec[nm] = None if v is None else (int(v) if nm == "newton_iterations" else float(v))
    rec["lost_motion_method"] = None if figures is None else figures.get("lost_motion_method")
    rec["wall_s"] = float(figures["wall_s"]) if figures is not None and "wall_s" in figures else wall_s
    rec["te_path"] = None if figures is None else figures.get("te_path", "exudyn")
    rec["te_fallback_points"] = None if figures is None else figures.get("te_fallback_points")
    rec["lost_motion_path"] = None if figures is None else figures.get("lost_motion_path", "exudyn")
    rec["lost_motion_fallback"] = None if figures is None else figures.get("lost_motion_fallback")
    rec["status"] = "ok" if error is None else "failed"
    rec["error"] = error
    return rec


def run_variant(design, variant, protocol, build_kw=None):
    """Record of one variant: its parameters, figures, wall time, status and error. Any exception
    of the run (SolverFailure, an impossible sampled variant) is recorded, not raised."""
    t0 = time.perf_counter()
    try:
        fig = variant_figures(design, variant, protocol, **(build_kw or {}))
    except Exception as exc:  # a failed variant is a result of the study, not its end
        return _record(variant, error=f"{type(exc).__name__}: {exc}", wall_s=time.perf_counter() - t0)
    return _record(variant, fig)


def _batched_function(build_kw=None):
    """rvtool.batched.batched_variant_figures, checked to accept the build options (the batched
    path builds its own system: options it does not take would silently model another reducer)."""
    import inspect
    try:
        from .batched import batched_variant_figures
    except ImportError as exc:
        raise RvtoolInputError(f"mode = 'batched' needs rvtool.batched.batched_variant_figures, which is not "
                               f"available ({exc}); valid modes here are ['pool', 'serial']") from None
    params = inspect.signature(batched_variant_figures).parameters
    if not any(p.kind == p.VAR_KEYWORD for p in params.values()):
        extra = sorted(set(build_kw or {}) - set(params))
        if extra:
            raise RvtoolInputError(f"build options {extra} are not accepted by the batched path "
                                   f"(rvtool.batched.batched_variant_figures); valid: none, or run mode 'pool'")
    return batched_variant_figures


def run_batch(design, variants, protocol, device="cpu", build_kw=None, mode="batched", helpers=None):
    """Records of variants run together: in one Exudyn system (mode "batched", rvtool.batched) or
    with the TE and lost motion on the device Newton (mode "device", :mod:`rvtool.variants.device`;
    ``helpers``: an executor for its host work, see there). If the run raises, every variant of
    the batch is recorded as failed with that error."""
    if mode == "device":
        from .device import device_variant_figures as batched_variant_figures
        extra = sorted(set(build_kw or {}) - {"regularization"})
        if extra:
            raise RvtoolInputError(f"build options {extra} are not accepted by the device path; valid: "
                                   f"['regularization']")
    else:
        batched_variant_figures = _batched_function(build_kw)
    t0 = time.perf_counter()
    try:
        extra_kw = {"executor": helpers} if helpers is not None else {}
        figs = batched_variant_figures(design, variants, protocol, device=device, **(build_kw or {}), **extra_kw)
    except Exception as exc:  # the whole batch shares one system: all its variants failed
        wall = (time.perf_counter() - t0) / max(len(variants), 1)
        return [_record(v, error=f"{type(exc).__name__}: {exc}", wall_s=wall) for v in variants]
    out = []
    for v, f in zip(variants, figs):
        err = f.get("error") if f.get("status", "ok") != "ok" else None
        rec = _record(v, None if err else f, error=err, wall_s=f.get("wall_s"))
        if err:   # a failed variant still names the paths it took (and whether its lost motion fell back)
            rec.update({k: f[k] for k in ("te_path", "te_fallback_points", "lost_motion_path", "lost_motion_fallback")
                        if k in f})
        out.append(rec)
    return out


def init_helper():
    """Initializer of a helper process of the device path's host work: one BLAS/OpenMP thread."""
    for nm in THREAD_ENV:
        os.environ[nm] = "1"



def chunk_path(out_dir, i):
    return os.path.join(out_dir, f"chunk_{i:05d}.json")


def write_chunk(out_dir, i, fp, indices, records):
    """Write chunk i atomically: a temporary file in the same folder, then os.replace."""
    fd, tmp = tempfile.mkstemp(dir=out_dir, prefix=f".chunk_{i:05d}", suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        json.dump({"fingerprint": fp, "chunk": i, "indices": list(indices), "records": records}, fh)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, chunk_path(out_dir, i))


def read_chunk(out_dir, i, fp, indices):
    """Records of chunk i if its file exists, is complete and matches ``fp`` and ``indices``; else None."""
    path = chunk_path(out_dir, i)
    if not os.path.isfile(path):
        return None
    try:
        with open(path) as fh:
            data = json.load(fh)
    except (OSError, ValueError):  # unreadable: run the chunk again
        return None
    if data.get("fingerprint") != fp or data.get("indices") != list(indices):
        return None
    return data["records"]


def run_monte_carlo(design, tolerances, protocol: VariantProtocol, settings: MonteCarloSettings, out_dir, *,
                    executor=None, on_chunk=None, progress=None, build_kw=None, rerun_failed=False):
    """Run (or resume) the study; returns ``{"records": [...] (by index), "summary": summarize(...),
    "chunks_loaded", "chunks_run", "wall_s", "fingerprint"}``.

    executor: a ``concurrent.futures.Executor`` to use instead of the built-in pool (pool and
    batched modes). on_chunk(i, records): called after chunk i is written (raising in it stops
    the study after that chunk, as an interruption would). progress(done, total): called after
    every finished variant. rerun_failed: run loaded chunks that hold failed variants again."""
    t0 = time.perf_counter()
    tolerances.check_design(design)
    os.makedirs(out_dir, exist_ok=True)
    fp = fingerprint(design, tolerances, protocol, settings.seed, settings.chunk_size, build_kw)
    chunks = settings.chunks()
    records, pending = {}, []
    for i, (a, b) in enumerate(chunks):
        recs = read_chunk(out_dir, i, fp, range(a, b))
        if recs is not None and not (rerun_failed and any(r["status"] != "ok" for r in recs)):
            records[i] = recs
        else:
            pending.append(i)
    n_loaded = len(records)
    total, done = settings.n_variants, sum(len(r) for r in records.values())
    if progress is not None:
        progress(done, total)

    def finish_chunk(i, recs):
        recs = sorted(recs, key=lambda r: r["index"])
        write_chunk(out_dir, i, fp, range(*chunks[i]), recs)
        records[i] = recs
        if on_chunk is not None:
            on_chunk(i, recs)

    def variants_of(i):
        return [sample_variant(tolerances, design, k, settings.seed) for k in range(*chunks[i])]

    mode, device = resolve_mode(settings.mode, settings.device)
    if mode == "batched":
        _batched_function(build_kw)   # fail early, in this process, when the batched path is missing
    chunked = mode in ("batched", "device")
    n_workers = settings.workers or os.cpu_count() or 1
    if settings.devices is not None and pending:
        if executor is not None:
            raise RvtoolInputError("settings.devices starts its own cluster (one worker per device); give no executor")
        device = _run_on_devices(settings.devices, pending, variants_of, design, protocol, build_kw, finish_chunk,
                                 progress, done, total)
    elif chunked and executor is None and (device != "cpu" or n_workers == 1):
        # one batched system at a time in this process: it is the one that holds the device
        # (on the CPU with several workers, batches run side by side in the pool below: one
        # batch of chunk_size copies per process: on 2 cores 3.3x the per-variant pool for TE alone,
        # 1.15x for the whole protocol with lost motion, cases/benchmarks/bench_batched_te.py and monte_carlo_te)
        with contextlib.ExitStack() as stack:
            helpers = None
            if mode == "device" and n_workers > 1 and pending:
                # the device mode's host work (per-copy parameters, Exudyn fallbacks) side by side
                # on the other cores while this process holds the device
                stack.enter_context(_single_thread_env())
                helpers = stack.enter_context(cf.ProcessPoolExecutor(
                    max_workers=n_workers, mp_context=multiprocessing.get_context("spawn"), initializer=init_helper))
            for i in pending:
                recs = run_batch(design, variants_of(i), protocol, device, build_kw, mode, helpers)
                done += len(recs)
                if progress is not None:
                    progress(done, total)
                finish_chunk(i, recs)
    elif mode == "serial":
        for i in pending:
            recs = []
            for v in variants_of(i):
                recs.append(run_variant(design, v, protocol, build_kw))
                done += 1
                if progress is not None:
                    progress(done, total)
            finish_chunk(i, recs)
    elif pending:
        with contextlib.ExitStack() as stack:
            if executor is None:
                # the pool is a Dask cluster: the scheduler's, or a LocalCluster of n_workers processes
                # started from a clean interpreter (one BLAS thread each, rvtool.variants.cluster)
                client = stack.enter_context(dask_client(settings.scheduler, n_workers=n_workers))
                executor = client.get_executor()
            try:
                futures, partial = {}, {}
                for i in pending:
                    vs = variants_of(i)
                    partial[i] = [len(vs), []]
                    if chunked:
                        futures[executor.submit(run_batch, design, vs, protocol, device, build_kw, mode)] = (
                            i, [v.index for v in vs])
                    else:
                        for v in vs:
                            futures[executor.submit(run_variant, design, v, protocol, build_kw)] = (i, [v.index])
                for fut in cf.as_completed(futures):
                    i, ks = futures[fut]
                    try:
                        res = fut.result()
                    except Exception as exc:  # the task itself died (e.g. a lost worker): its variants failed
                        err = f"{type(exc).__name__}: {exc}"
                        res = [_record(sample_variant(tolerances, design, k, settings.seed), error=err) for k in ks]
                    res = res if isinstance(res, list) else [res]
                    partial[i][1].extend(res)
                    done += len(res)
                    if progress is not None:
                        progress(done, total)
                    if len(partial[i][1]) == partial[i][0]:
                        finish_chunk(i, partial.pop(i)[1])
            finally:
                for fut in futures:      # after an interruption: nothing left running on the cluster
                    fut.cancel()
    recs = [r for i in sorted(records) for r in records[i]]
    return {"records": recs, "summary": summarize(recs), "chunks_loaded": n_loaded, "chunks_run": len(pending),
            "wall_s": time.perf_counter() - t0, "fingerprint": fp, "mode": mode, "device": device,
            "te_paths": sorted({r["te_path"] for r in recs if r.get("te_path")}),
            "te_fallback_points": sum(int(r.get("te_fallback_points") or 0) for r in recs),
            "lost_motion_paths": sorted({r["lost_motion_path"] for r in recs if r.get("lost_motion_path")}),
            "lost_motion_fallback_copies": sum(bool(r.get("lost_motion_fallback")) for r in recs)}


def _run_on_devices(devices, pending, variants_of, design, protocol, build_kw, finish_chunk, progress, done, total):
    """The device mode's chunks on one worker per device (:mod:`rvtool.variants.multi_device`):
    every free worker takes the next chunk (equal devices, one chunk at a time each), its host work
    on a helper pool of its share of the host's cores (GPUs; none on cpu workers); a chunk whose
    task dies has its variants failed. Returns the device string the workers ran on."""
    from dask.distributed import as_completed

    from .multi_device import default_host_workers, device_chunk, device_cluster
    with device_cluster(devices) as (client, slots):
        dev = slots[0].device
        hw = default_host_workers(slots)
        futures = {client.submit(device_chunk, design, variants_of(i), protocol, dev, build_kw, hw, pure=False): i
                   for i in pending}
        try:
            for fut in as_completed(list(futures)):
                i = futures[fut]
                try:
                    recs = fut.result()
                except Exception as exc:  # the task itself died (a lost worker, a device error)
                    recs = [_record(v, error=f"{type(exc).__name__}: {exc}") for v in variants_of(i)]
                done += len(recs)
                if progress is not None:
                    progress(done, total)
                finish_chunk(i, recs)
        finally:
            for fut in futures:
                fut.cancel()
    return f"{dev} x {len(slots)}"


def order_statistic_ci(x_sorted, p, level=0.95):
    """Distribution-free confidence interval of the p-quantile from order statistics: ranks
    l < u (1-based) with P(X_(l) <= x_p <= X_(u)) >= level, from the number of samples below
    x_p ~ Binomial(n, p). Returns (low, high); a bound whose rank falls outside 1..n is None."""
    from scipy.stats import binom
    n = len(x_sorted)
    a = (1 - level) / 2
    lo_rank = int(binom.ppf(a, n, p))           # P(B < lo_rank) <= a  -> X_(lo_rank) <= x_p
    hi_rank = int(binom.ppf(1 - a, n, p)) + 1   # P(B >= hi_rank) <= a -> X_(hi_rank) >= x_p
    low = float(x_sorted[lo_rank - 1]) if 1 <= lo_rank <= n else None
    high = float(x_sorted[hi_rank - 1]) if 1 <= hi_rank <= n else None
    return low, high


def summarize(records, figures=FIGURES, level=0.95):
    """Per figure over successful records: n, mean, std (ddof 1), p5, p50, p95 (linear
    interpolation), mean_ci (Student t), p95_ci (order statistics, see module docstring);
    plus n_ok and n_failed."""
    from scipy.stats import t as student_t
    ok = [r for r in records if r["status"] == "ok"]
    out = {"n_ok": len(ok), "n_failed": len(records) - len(ok),
           "ci_level": level, "mean_ci_method": "Student t interval of the mean (normal for large n)",
           "p95_ci_method": "distribution-free order-statistic interval (binomial ranks); None = rank outside 1..n"}
    for nm in figures:
        x = np.sort(np.array([r[nm] for r in ok if r.get(nm) is not None], float))
        n = len(x)
        if n == 0:
            out[nm] = {"n": 0}
            continue
        mean = float(np.mean(x))
        std = float(np.std(x, ddof=1)) if n > 1 else float("nan")
        half = float(student_t.ppf(0.5 + level / 2, n - 1) * std / math.sqrt(n)) if n > 1 else float("nan")
        p5, p50, p95 = (float(v) for v in np.percentile(x, [5, 50, 95]))
        out[nm] = {"n": n, "mean": mean, "std": std, "p5": p5, "p50": p50, "p95": p95,
                   "mean_ci": [mean - half, mean + half], "p95_ci": list(order_statistic_ci(x, 0.95, level)),
                   "min": float(x[0]), "max": float(x[-1])}
    return out
