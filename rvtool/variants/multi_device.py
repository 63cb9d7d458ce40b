"""The device Monte Carlo over several devices of one host (issue 31, deliverable 2): one Dask
worker process per GPU, each pinned to its GPU, every worker running the device backend on its
batch of variants (scale-out delegated to Dask, :mod:`rvtool.variants.cluster`).

* :func:`device_slots` maps the devices asked for ("cuda:0", "cuda:1", ... or "cpu") to worker
  slots: a worker for ``cuda:k`` starts with ``CUDA_VISIBLE_DEVICES=k`` in its environment (set
  by its Nanny before the worker process runs any task, so before Warp initialises CUDA) and runs
  on ``cuda:0``, the one GPU it sees; a ``cpu`` worker starts with ``CUDA_VISIBLE_DEVICES=""``
  (it sees no GPU) and runs on Warp's ``cpu`` device (CI, and the equivalence test).
* :func:`device_cluster` starts a LocalCluster of one single-threaded worker process per slot
  (named ``device-k``) with each slot's environment, closed on exit.
* :func:`multi_device_monte_carlo` splits variants 0..n-1 into one contiguous batch per worker
  (:func:`split_indices`, :func:`plan`), runs each batch on its own worker (pinned to it: the
  batches are sized for equal devices; a batch may be cut into chunks run one after another there)
  and gathers the records in variant order. The per-batch task (``path``, :func:`batch_task`) is
  by default :func:`rows_batch` for every topology (RD-40 and rv40e alike), the path of
  ``cases/benchmarks/bench_device_mc.py``, one code path for both
  (:func:`rvtool.variants.device_pipeline.device_variants_pipelined`): the worker's helpers sample
  and build its variants as :class:`~rvtool.solver.model_snapshot.ModelSnapshot` (in groups, the
  next chunks while the device solves this one; ``tables="device"``: cycloid profile tables computed
  on the worker's device), the worker runs TE and lost motion of them on the device row Newton
  (:func:`rvtool.batched.device_rows_variants.device_rows_variants`, the lost motion on the device
  torque path; ``graph``: the captured resident loop), points and copies the device does not
  converge on Exudyn, counted. ``path="device_newton"`` (cycloid designs) runs the Monte Carlo's older device
  mode (:func:`cycloid_batch`: :func:`rvtool.variants.montecarlo.run_batch`, mode "device", its
  lost motion on per-copy Exudyn fallbacks). A variant whose run fails, and every variant of a
  batch whose task dies (a lost worker), is recorded ``status = "failed"`` with its error and
  counted; none is dropped.
* Host work: each GPU worker runs the device path's host work (the variants' builds; on
  "device_newton" per-copy parameters and Exudyn fallbacks) on a pool of helper processes of its
  own (:func:`helper_pool`; the workers are non-daemonic so that they may start it), the host's
  cores shared out between the GPUs (:func:`default_host_workers`); the pools end when the
  cluster closes.

Every figure of a variant depends on that variant alone (the device copies are independent), so
the records equal those of one worker (tests/test_multi_gpu.py: two cpu workers against one,
1e-12). :func:`warm_up` runs a small batch on every worker (imports, kernel compilation and
module loading on each device), so that a timed study measures the steady state.
"""
import contextlib
import copy
import time
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from .device_pipeline import chunk_schedule, paused_collector  # noqa: F401  (re-exported: the solves' schedule)


@dataclass(frozen=True)
class DeviceSlot:
    """One worker of :func:`device_cluster`: its Dask worker ``name``, the environment ``env`` its
    process starts with, and the Warp ``device`` it runs on inside that process."""
    name: str
    env: dict
    device: str


def device_slots(devices):
    """Worker slots (:class:`DeviceSlot`) of ``devices``: an int n (the first n GPUs, "cuda:0" ..
    "cuda:n-1") or a sequence of "cuda:k" / "cpu" (one worker each; a GPU at most once)."""
    if isinstance(devices, (int, np.integer)) and not isinstance(devices, bool):
        if devices < 1:
            raise RvtoolInputError(f"devices = {devices!r} is outside the valid range [1, inf) (number of GPUs)")
        devices = [f"cuda:{k}" for k in range(int(devices))]
    if isinstance(devices, str) or not hasattr(devices, "__iter__"):
        raise RvtoolInputError(f"devices = {devices!r}: give a number of GPUs or a list of 'cuda:K' / 'cpu'")
    devices = list(devices)
    if not devices:
        raise RvtoolInputError("devices = []: give at least one device ('cuda:K' or 'cpu')")
    slots, gpus = [], set()
    for k, d in enumerate(devices):
        d = str(d)
        if d == "cpu":
            slots.append(DeviceSlot(f"device-{k}", {"CUDA_VISIBLE_DEVICES": ""}, "cpu"))
            continue
        idx = d[5:] if d.startswith("cuda:") else None
        if idx is None or not idx.isdigit():
            raise RvtoolInputError(f"devices[{k}] = {d!r}; valid: 'cpu' or 'cuda:K' (K the host's GPU index)")
        if idx in gpus:
            raise RvtoolInputError(f"devices[{k}] = {d!r} is named twice: one worker per GPU")
        gpus.add(idx)
        slots.append(DeviceSlot(f"device-{k}", {"CUDA_VISIBLE_DEVICES": str(int(idx))}, "cuda:0"))
    return tuple(slots)


@contextlib.contextmanager
def device_cluster(devices):
    """(client, slots): a LocalCluster of one worker process per slot of ``devices``
    (:func:`device_slots`), one thread each, every worker started with its slot's environment
    (``CUDA_VISIBLE_DEVICES``) and one BLAS/OpenMP thread; closed on exit."""
    from dask.distributed import Client, LocalCluster

    from .cluster import single_thread_env
    import dask
    slots = device_slots(devices)
    # non-daemonic worker processes: a GPU worker runs its host work on a pool of its own
    # (host_workers, :func:`helper_pool`); daemonic processes may not start children
    stack = contextlib.ExitStack()
    stack.enter_context(dask.config.set({"distributed.worker.daemon": False}))
    with single_thread_env():
        cluster = LocalCluster(n_workers=0, threads_per_worker=1, processes=True, dashboard_address=None)
    stack.callback(cluster.close)
    try:
        # one worker spec per slot: the LocalCluster's own worker template with the slot's environment
        for s in slots:
            spec = copy.deepcopy(cluster.new_spec)
            spec["options"] = {**spec["options"], "env": dict(s.env)}
            cluster.worker_spec[s.name] = spec
        with single_thread_env():
            cluster.scale(len(slots))
        client = Client(cluster)
        try:
            client.wait_for_workers(len(slots))
            yield client, slots
        finally:
            try:
                # the workers' helper pools end with the study (a worker killed at close would orphan
                # them); a worker that is gone has none left to end
                client.run(shutdown_helper_pools, on_error="ignore")
            finally:
                client.close()
    finally:
        stack.close()


def worker_addresses(client, slots):
    """{slot name: worker address} of the workers of ``client``'s cluster named after ``slots``."""
    by_name = {w["name"]: a for a, w in client.scheduler_info()["workers"].items()}
    missing = [s.name for s in slots if s.name not in by_name]
    if missing:
        raise RvtoolInputError(f"the cluster has no worker named {missing} (start it with device_cluster)")
    return {s.name: by_name[s.name] for s in slots}


def split_indices(n, k):
    """Variants 0..n-1 in ``k`` contiguous batches whose sizes differ by at most one (first ones larger)."""
    if n < 1 or k < 1:
        raise RvtoolInputError(f"n = {n!r} variants and k = {k!r} batches: valid range [1, inf) each")
    bounds = np.linspace(0, n, min(k, n) + 1).round().astype(int)
    return [range(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


@dataclass(frozen=True, kw_only=True)
class RvVariantProtocol:
    """Per-variant workload of an RV design (the Exudyn reference run's,
    ``cases/rv/monte_carlo_rv.py``): quasi-static TE at ``te_torque_fraction`` x T_rated over one
    crank revolution at ``n_te_points`` points (warm-started march), and the lost motion at
    +-``lost_motion_fraction`` x T_rated at input angle 0."""
    n_te_points: int = 37
    te_torque_fraction: float = 1.0
    lost_motion_fraction: float = 0.03

    def __post_init__(self):
        from ..validation import check_range
        if isinstance(self.n_te_points, bool) or not isinstance(self.n_te_points, (int, np.integer)) \
                or self.n_te_points < 1:
            raise RvtoolInputError(f"n_te_points = {self.n_te_points!r} is outside the valid range [1, inf) (integer)")
        check_range("te_torque_fraction", self.te_torque_fraction, 0.0, 2.0)
        check_range("lost_motion_fraction", self.lost_motion_fraction, 0.0, 1.0, low_open=True)

    def input_angles(self, model):
        """Input angles [rad] over one crank revolution of ``model`` (endpoint excluded)."""
        crank_rev = 2 * np.pi / abs(model.graph.crank_rate)
        return np.arange(self.n_te_points) * crank_rev / self.n_te_points


def _is_cycloid(design):
    from ..assembly.spec import CycloidDesign
    return isinstance(design, CycloidDesign)


_POOLS = {}
WARM_TIMEOUT_S = 600.0
"""The longest a helper's warm-up task waits at the barrier for the pool's other helpers [s] (spawn and
imports of a whole pool on a loaded host)."""


def helper_pool(host_workers):
    """This process's pool of ``host_workers`` spawned processes (one BLAS thread each) for the
    device path's host work (the variants' builds; per-copy parameters, Exudyn fallbacks), started
    on first use and kept for the process's later tasks; None for 0. A
    :func:`rvtool.variants.barrier_pool.barrier_pool`, so that :func:`_on_every_helper` warms every
    helper exactly once."""
    if not host_workers:
        return None
    if host_workers not in _POOLS:
        import atexit

        from .barrier_pool import barrier_pool
        pool = barrier_pool(int(host_workers), one_blas_thread=True, start_timeout_s=WARM_TIMEOUT_S)
        atexit.register(pool.shutdown, wait=False, cancel_futures=True)
        _POOLS[host_workers] = pool
    return _POOLS[host_workers]


def _on_every_helper(pool, host_workers, fn, job):
    """``fn(job)`` run exactly once in every helper of ``pool``
    (:func:`rvtool.variants.barrier_pool.warm_every_worker`: each waits at the pool's barrier after
    it, so that no helper takes a second one while another has not started; a warm-up that does not
    reach every helper within :data:`WARM_TIMEOUT_S` raises); returns the helpers' count."""
    from .barrier_pool import warm_every_worker
    return warm_every_worker(pool, int(host_workers), fn, [job] * int(host_workers),
                             timeout_s=WARM_TIMEOUT_S, on_missed="raise")


def _import_device_path(_):
    """A helper's warm-up: the modules of the host work (building, Exudyn fallbacks) imported."""
    from . import device  # noqa: F401
    from ..assembly import build  # noqa: F401


def start_helper_pool(host_workers):
    """Start this process's :func:`helper_pool` and every helper in it (each imports the host
    work's modules, every helper once), so that a timed study does not pay for them; returns the
    helpers' count."""
    pool = helper_pool(host_workers)
    if pool is None:
        return 0
    return _on_every_helper(pool, host_workers, _import_device_path, None)


def nominal_snapshot(job):
    """A helper's warm-up: the task a timed study runs (:func:`variant_snapshot`) on the nominal
    ``design`` of job (design, build_kw, defer_tables): a cycloid design's nominal snapshot, into which
    this process writes its variants
    (:func:`rvtool.solver.variant_snapshots.cycloid_variant_snapshots`), its profile tables shared or
    deferred as the study's; an RV design's snapshot on shared tables. Every module the builds use is
    loaded and every memo filled (as ``bench_device_mc`` warms its build pool)."""
    design, build_kw, defer_tables = job
    if _is_cycloid(design):
        from ..solver.variant_snapshots import cycloid_variant_snapshots
        from .variant import Variant
        return cycloid_variant_snapshots(design, [Variant()], dict(build_kw), defer_tables=bool(defer_tables))[0]
    from ..solver.model_snapshot import build_snapshot
    return build_snapshot(design, dict(build_kw), shared_tables=True)


def _nominal_snapshot_only(job):
    nominal_snapshot(job)


def warm_helper_builds(design, build_kw, host_workers, defer_tables=False):
    """Every helper of this process's :func:`helper_pool` runs the study's build task once on the
    nominal ``design`` (:func:`nominal_snapshot`; ``defer_tables`` as the study's ``tables="device"``),
    exactly once each, so that a timed study's builds find their imports and memos; returns the
    helpers that built (0 without helpers)."""
    pool = helper_pool(host_workers)
    if pool is None:
        return 0
    return _on_every_helper(pool, host_workers, _nominal_snapshot_only, (design, dict(build_kw), bool(defer_tables)))


def shutdown_helper_pools():
    """End this process's helper pools (run on every worker when :func:`device_cluster` closes)."""
    while _POOLS:
        _POOLS.popitem()[1].shutdown(wait=True, cancel_futures=True)


def device_chunk(design, variants, protocol, device, build_kw=None, host_workers=0):
    """Records of cycloid ``variants`` on the device Newton on ``device``
    (:func:`rvtool.variants.montecarlo.run_batch`, mode "device"), the host work on this
    process's :func:`helper_pool` of ``host_workers`` processes (0: in this process)."""
    from .montecarlo import run_batch
    return run_batch(design, variants, protocol, device, build_kw, mode="device", helpers=helper_pool(host_workers))


def cycloid_batch(design, tolerances, protocol, seed, indices, device, host_workers=0):
    """Records of the cycloid variants ``indices`` (sampled from ``tolerances`` with ``seed``) on the
    device Newton on ``device`` (:func:`device_chunk`)."""
    from .tolerances import sample_variant
    variants = [sample_variant(tolerances, design, k, seed) for k in indices]
    return device_chunk(design, variants, protocol, device, host_workers=host_workers)


def variant_snapshot(job, defer_tables=False):
    """Helper task: (index, :class:`~rvtool.solver.model_snapshot.ModelSnapshot` of variant k or
    None, error or None) for job (design, tolerances, seed, k, build_kw): the variant sampled
    (cycloid: ``sample_variant``, written into this process's nominal snapshot by
    :func:`rvtool.solver.variant_snapshots.cycloid_variant_snapshots`; RV: ``sample_rv_design``, built
    by ``build_snapshot``) here, its cycloid pins on shared profile tables. The same snapshot as
    ``build_snapshot(variant design, build_kw, shared_tables=True)`` (tests/test_variant_snapshots.py).
    defer_tables: a cycloid variant's profile tables are left to the receiver (pickled as its profiles;
    :func:`rvtool.solver.variant_snapshots.cycloid_variant_snapshots`); default off."""
    from ..solver.model_snapshot import build_snapshot
    design, tolerances, seed, k, build_kw = job
    try:
        if _is_cycloid(design):
            from ..solver.variant_snapshots import cycloid_variant_snapshots
            from .tolerances import sample_variant
            return int(k), cycloid_variant_snapshots(design, [sample_variant(tolerances, design, k, seed)],
                                                     build_kw, defer_tables=defer_tables)[0], None
        return int(k), build_snapshot(rv_variant_design(tolerances, design, k, seed), build_kw,
                                      shared_tables=True), None
    except Exception as exc:  # an impossible sampled variant is a result of the study
        return int(k), None, f"{type(exc).__name__}: {exc}"


_LIGHT_RV = {}
"""id(design) -> (design, whether rvtool.assembly.rv.spec.light_replace gives its variants' loaded designs)."""


def rv_variant_design(tolerances, design, k, seed):
    """The design of RV variant k, ``sample_rv_design(tolerances, design, k, seed)[0]``, made by
    :func:`rvtool.assembly.rv.spec.light_replace` (the changed sections written in, not the whole file form
    loaded again: ~1/3 of a variant's build) where the first variant of ``design`` this process makes
    equals the loaded one (checked once per design, as the cycloid variants' light designs), else loaded."""
    from ..assembly.rv.spec import light_replace
    from .rv_tolerances import rv_design_changes
    changes, _ = rv_design_changes(tolerances, design, k, seed)
    hit = _LIGHT_RV.get(id(design))
    if hit is None or hit[0] is not design:
        light, loaded = light_replace(design, **changes), design.replace(**changes)
        try:
            ok = light is not None and bool(light == loaded and light.source == loaded.source)
        except (TypeError, ValueError):   # members that do not compare (arrays): load every variant
            ok = False
        if len(_LIGHT_RV) >= 8:
            _LIGHT_RV.pop(next(iter(_LIGHT_RV)))
        _LIGHT_RV[id(design)] = (design, ok)
        return loaded
    out = light_replace(design, **changes) if hit[1] else None
    return design.replace(**changes) if out is None else out


def variant_snapshots(jobs, defer_tables=False):
    """Helper task: [:func:`variant_snapshot` of each job] (one task for a group of variants)."""
    return [variant_snapshot(j, defer_tables) for j in jobs]


def default_build_kw(design, protocol):
    """Build options of the variants of the row path: a cycloid design's ``bearing_model`` from
    ``protocol``; none for an RV design. (A study passes its own, e.g. RD-40's regularization.)"""
    return {"bearing_model": protocol.bearing_model} if _is_cycloid(design) else {}


TABLES = ("helpers", "device")
"""Where cycloid variants' profile tables are computed on the "rows" path: by the build helpers (each
snapshot carries its tables) or by the device's process (the helpers send profiles; a GPU computes a
chunk's tables in one batch inside the device setup: ``bench_device_mc --tables device``)."""


def rows_batch(design, tolerances, protocol, seed, indices, device, host_workers=0, *, build_kw=None,
               solve_chunk=1024, first_chunk=None, tables="helpers", graph=True):
    """Records of the variants ``indices`` (sampled with ``seed``) on the device row Newton by the one
    path of ``cases/benchmarks/bench_device_mc.py``,
    :func:`rvtool.variants.device_pipeline.device_variants_pipelined`: the variants sampled and built
    as :class:`~rvtool.solver.model_snapshot.ModelSnapshot` on this process's :func:`helper_pool` of
    ``host_workers`` processes (0: here), in groups, at most two chunks of builds queued ahead of the
    device; TE and lost motion of up to ``solve_chunk`` copies at a time (None: all in one solve) on
    ``device`` (points and copies the device does not converge on Exudyn, counted), the first solve
    of ``first_chunk`` copies and the next ones doubling up to ``solve_chunk``
    (:func:`~rvtool.variants.device_pipeline.chunk_schedule`). tables: :data:`TABLES`; graph: on CUDA
    the row Newton's resident loop as a captured CUDA graph
    (:class:`~rvtool.solver.device_newton.DeviceNewtonSettings`). The TE at ``te_torque_fraction`` x
    T_rated over ``protocol.input_angles`` (RV: of the nominal model), the lost motion at
    +-``lost_motion_fraction`` x T_rated. A variant that cannot be built, or whose device and Exudyn
    runs fail, is failed with its error; every record carries index, figures, status, error and
    paths (None where failed); the first record of each solve its ``exudyn_points``, ``exudyn_copies``, ``device_s``
    (the device path's wall time) and ``build_wait_s`` (time spent waiting for that chunk's builds);
    the first record ``first_device_start_s`` (from the call to the first device solve). The records
    do not depend on the chunks (the copies are independent: equal bit for bit on cpu,
    tests/test_multi_gpu.py)."""
    from ..assembly import build
    from ..solver.device_newton import DeviceNewtonSettings
    from ..units import ARCMIN_PER_RAD, ARCSEC_PER_RAD
    from .device_pipeline import device_variants_pipelined
    if tables not in TABLES:
        raise RvtoolInputError(f"tables = {tables!r}; valid: {list(TABLES)}")
    t0 = time.perf_counter()
    kw = default_build_kw(design, protocol) if build_kw is None else dict(build_kw)
    angles = protocol.input_angles(design if _is_cycloid(design) else build(design, **kw))
    t_run = time.perf_counter()
    run = device_variants_pipelined(
        design, tolerances, seed, indices, build_kw=kw, torque=protocol.te_torque_fraction * design.rated_torque,
        input_angles=angles, lost_motion_level=protocol.lost_motion_fraction * design.rated_torque, device=device,
        settings=DeviceNewtonSettings(graph=bool(graph)), pool=helper_pool(host_workers), pool_workers=host_workers,
        solve_chunk=solve_chunk, first_chunk=first_chunk, defer_tables=tables == "device")
    path = f"device_rows:{device}"
    recs = []
    for ks, r, wait in zip(run.indices, run.parts, run.build_wait_s):
        chunk = []
        for c, k in enumerate(ks):
            ok = r.status[c] == "ok"
            te = r.te[c] - np.mean(r.te[c]) if ok else None
            chunk.append({"index": int(k),
                          "te_pp_arcsec": float(np.ptp(r.te[c]) * ARCSEC_PER_RAD) if ok else None,
                          "te_rms_arcsec": float(np.sqrt(np.mean(te ** 2)) * ARCSEC_PER_RAD) if ok else None,
                          "lost_motion_arcmin": float(r.lost_motion_rad[c] * ARCMIN_PER_RAD) if ok else None,
                          "status": r.status[c], "error": r.error[c],
                          "te_path": path if ok else None, "lost_motion_path": path if ok else None})
        chunk[0].update(build_wait_s=wait, exudyn_points=int(r.exudyn_points), exudyn_copies=int(r.exudyn_copies),
                        device_s=float(r.wall_s))
        recs.extend(chunk)
    wall = time.perf_counter() - t0
    for rec in recs:
        rec["wall_s"] = wall / len(recs)
    if recs:
        recs[0]["first_device_start_s"] = None if run.first_device_start_s is None \
            else run.first_device_start_s + (t_run - t0)
    return recs


PATHS = ("rows", "device_newton")
"""Per-batch paths: "rows" (:func:`rows_batch`, every topology: the device row Newton of
``bench_device_mc``) and "device_newton" (:func:`cycloid_batch`, cycloid designs only: the Monte
Carlo's older device mode, its lost motion on Exudyn fallbacks)."""


def batch_task(design, path="rows"):
    """The per-batch task of ``path`` (:data:`PATHS`) for ``design``."""
    if path not in PATHS:
        raise RvtoolInputError(f"path = {path!r}; valid: {list(PATHS)}")
    if path == "device_newton" and not _is_cycloid(design):
        raise RvtoolInputError("path = 'device_newton' runs cycloid designs only; valid for this design: 'rows'")
    return rows_batch if path == "rows" else cycloid_batch


def default_protocol(design):
    """The reference run's per-variant workload of ``design``'s topology: RD-40's
    ``cases/cycloid/monte_carlo_te.py`` (53 TE points over one output revolution, lost motion at
    +-3 % T_rated) or :class:`RvVariantProtocol` (37 points over one crank revolution)."""
    from .variant import VariantProtocol
    return VariantProtocol(n_te_points=53) if _is_cycloid(design) else RvVariantProtocol()


def _failed(index, error):
    return {"index": int(index), "te_pp_arcsec": None, "te_rms_arcsec": None, "lost_motion_arcmin": None,
            "status": "failed", "error": error, "wall_s": None}


def plan(n_variants, slots, chunk=None):
    """[(slot, indices)]: variants 0..n_variants-1 in one contiguous per-device batch per slot
    (:func:`split_indices`), each cut into chunks of at most ``chunk`` variants (None: the whole
    batch in one task) that run one after another on that slot's worker."""
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise RvtoolInputError(f"chunk = {chunk!r} is outside the valid range [1, inf) (integer) or None")
    out = []
    for s, b in zip(slots, split_indices(int(n_variants), len(slots))):
        step = len(b) if chunk is None else int(chunk)
        out.extend((s, b[i:i + step]) for i in range(0, len(b), step))
    return out


def run_batches(client, tasks, design, tolerances, protocol, seed, host_workers=0, *, path="rows", build_kw=None,
                solve_chunk=1024, first_chunk=None, tables="helpers", graph=True):
    """Records of ``tasks`` ([(slot, indices)], e.g. :func:`plan`), each on its slot's worker with
    that slot's device, gathered in task order; a task that raises has all its variants failed with
    that error; host_workers: each worker's helper pool (:func:`helper_pool`); path, build_kw,
    solve_chunk, first_chunk, tables, graph: see :func:`batch_task` and :func:`rows_batch` (all but
    path: "rows" only).
    Returns (records, per-task {worker, device, variants, wall_s (of the task, as the worker
    measured it)})."""
    addr = worker_addresses(client, list({s.name: s for s, _ in tasks}.values()))
    fn = batch_task(design, path)
    kw = {"build_kw": build_kw, "solve_chunk": solve_chunk, "first_chunk": first_chunk, "tables": tables,
          "graph": graph} if fn is rows_batch else {}
    futures = [(s, b, client.submit(_timed, fn, design, tolerances, protocol, seed, list(b), s.device, host_workers,
                                    workers=[addr[s.name]], allow_other_workers=False, pure=False, **kw))
               for s, b in tasks]
    records, info = [], []
    for s, b, fut in futures:
        try:
            recs, wall = fut.result()
        except Exception as exc:  # the task itself died (a lost worker, a device error): its variants failed
            recs, wall = [_failed(k, f"{type(exc).__name__}: {exc}") for k in b], None
        records.extend(recs)
        info.append({"worker": s.name, "device": s.device, "env": dict(s.env), "first": b[0], "variants": len(b),
                     "wall_s": wall})
    return records, info


def _timed(task, *args, **kw):
    t0 = time.perf_counter()
    out = task(*args, **kw)
    return out, time.perf_counter() - t0


def default_host_workers(slots):
    """Helper processes per worker: on GPUs the host's cores shared out (one left to each worker
    itself), on cpu slots none (the workers are the cores)."""
    import os
    if all(s.device == "cpu" for s in slots):
        return 0
    return max(0, (os.cpu_count() or 1) // len(slots) - 1)


def warm_up(client, slots, design, tolerances, protocol=None, seed=0, variants=1, host_workers=None, *,
            path="rows", build_kw=None, tables="helpers", graph=True):
    """Start every worker's helper pool (:func:`start_helper_pool`) and run ``variants`` variants on
    every worker once (imports, Warp kernel compilation and module loading on its device: with
    ``tables="device"`` the profile-table kernels too, with ``graph`` the captured loop), untimed by
    the study, on ``path`` with ``build_kw``, ``tables`` and ``graph`` (as the study; "rows": every
    helper first runs the build task on the nominal design once, :func:`warm_helper_builds`); returns the wall
    time [s]."""
    t0 = time.perf_counter()
    protocol = protocol or default_protocol(design)
    hw = default_host_workers(slots) if host_workers is None else host_workers
    addr = worker_addresses(client, slots)
    client.gather([client.submit(start_helper_pool, hw, workers=[addr[s.name]], allow_other_workers=False,
                                 pure=False) for s in slots])
    if path == "rows":                            # every helper builds the nominal design once
        kw = default_build_kw(design, protocol) if build_kw is None else build_kw
        client.gather([client.submit(warm_helper_builds, design, kw, hw, tables == "device",
                                     workers=[addr[s.name]], allow_other_workers=False, pure=False) for s in slots])
    run_batches(client, [(s, range(variants)) for s in slots], design, tolerances, protocol, seed, hw, path=path,
                build_kw=build_kw, **({"tables": tables, "graph": graph} if path == "rows" else {}))
    return time.perf_counter() - t0


def multi_device_monte_carlo(design, tolerances, n_variants, *, devices=None, protocol=None, seed=0, client=None,
                             slots=None, chunk=None, host_workers=None, path="rows", build_kw=None,
                             solve_chunk=1024, first_chunk=None, tables="helpers", graph=True):
    """The device Monte Carlo of variants 0..n_variants-1 of ``design`` over several devices
    (module docstring), each device's batch in chunks of at most ``chunk`` variants (:func:`plan`).
    Either ``devices`` (a cluster is started for the study and closed after it:
    see :func:`device_slots`) or ``client`` and ``slots`` of a running :func:`device_cluster`
    (e.g. warmed by :func:`warm_up`). protocol: the per-variant workload (default
    :func:`default_protocol`). Returns {"records" (by index), "failed" (count), "wall_s" (the
    study, on a running cluster), "batches" (per-batch worker, device, size, task wall time)}.
    host_workers: helper processes of each worker for the host work (None:
    :func:`default_host_workers`; the same count as the :func:`warm_up` that started the pools).
    path: "rows" (default, every topology: :func:`rows_batch`, the device row Newton with the
    variants' builds on the helper pools) or "device_newton" (cycloid designs: :func:`cycloid_batch`);
    build_kw: the variants' build options (None: :func:`default_build_kw`); solve_chunk: copies per
    device solve (None: a task's variants in one solve), first_chunk: copies of the first solve ("rows":
    :func:`chunk_schedule`); tables: :data:`TABLES` ("rows"); graph: on CUDA the captured resident loop
    ("rows"). One device and N devices run the same per-device path
    (:func:`rvtool.variants.device_pipeline.device_variants_pipelined`) with the same options."""
    if (client is None) == (devices is None):
        raise RvtoolInputError("give either devices (a cluster for this study) or client and slots (a running one)")
    if client is not None and not slots:
        raise RvtoolInputError("client needs the slots of its device_cluster")
    if isinstance(n_variants, bool) or not isinstance(n_variants, (int, np.integer)) or n_variants < 1:
        raise RvtoolInputError(f"n_variants = {n_variants!r} is outside the valid range [1, inf) (integer)")
    protocol = protocol or default_protocol(design)
    if client is None:
        with device_cluster(devices) as (client, slots):
            return multi_device_monte_carlo(design, tolerances, n_variants, protocol=protocol, seed=seed,
                                            client=client, slots=slots, chunk=chunk, host_workers=host_workers,
                                            path=path, build_kw=build_kw, solve_chunk=solve_chunk,
                                            first_chunk=first_chunk, tables=tables, graph=graph)
    t0 = time.perf_counter()
    hw = default_host_workers(slots) if host_workers is None else int(host_workers)
    batch_task(design, path)                      # a path the design cannot run is refused before any task
    records, info = run_batches(client, plan(n_variants, slots, chunk), design, tolerances, protocol, seed, hw,
                                path=path, build_kw=build_kw, solve_chunk=solve_chunk, first_chunk=first_chunk,
                                **({"tables": tables, "graph": graph} if path == "rows" else {}))
    return {"records": records, "failed": sum(r["status"] != "ok" for r in records),
            "wall_s": time.perf_counter() - t0, "batches": info, "devices": [s.device for s in slots],
            "host_workers": hw, "path": path}


__all__ = ["DeviceSlot", "PATHS", "RvVariantProtocol", "TABLES", "batch_task", "chunk_schedule", "cycloid_batch",
           "default_build_kw", "default_host_workers", "default_protocol", "device_chunk", "device_cluster",
           "device_slots", "helper_pool", "multi_device_monte_carlo", "nominal_snapshot", "paused_collector", "plan", "rows_batch",
           "run_batches", "shutdown_helper_pools", "split_indices", "start_helper_pool", "variant_snapshot",
           "warm_helper_builds", "warm_up", "worker_addresses"]
