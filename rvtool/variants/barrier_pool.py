"""Spawned process pools warmed on every worker exactly once: each warm-up task waits, after its
work, at a barrier of all the pool's workers.

Why the barrier: a pool warmed by mapping one warm-up job per worker can leave a slow-starting
worker cold. The worker that is up first finishes its job and takes a second one while another
still spawns; the cold one's first timed task then pays the imports' first use and the nominal
build (measured on cpu by ``cases/benchmarks/bench_device_mc.py``, 2 workers: both warm-up jobs
ran in one process, and the other's first timed task took 0.25-0.4 s instead of 0.03 s). A worker
waiting at the barrier cannot take a second job, so every worker runs exactly one.

* :func:`barrier_pool` starts the pool (``spawn``: fresh interpreters, no forked Warp/Exudyn
  state), each worker holding the pool's barrier (set by the pool's initializer);
* :func:`warm_every_worker` runs one warm-up job per worker on such a pool;
* :func:`warmed_pool` does both for a pool owned by the caller and returns the warm-up's wall time.

One mechanism, two callers whose figures of record (``bench_device_mc``, ``bench_multi_gpu``) were
measured with different settings; the parameters keep exactly these differences, so that each
caller behaves as when it was measured:

* ``one_blas_thread`` -- True for :func:`rvtool.variants.multi_device.helper_pool` (a GPU worker's
  helpers, the host's cores shared out between GPUs: the pool is started inside
  :func:`rvtool.variants.cluster.single_thread_env` and each helper runs
  :func:`rvtool.variants.montecarlo.init_helper`); False for ``bench_device_mc``'s pools (the
  Exudyn reference pool and the build pool keep the default BLAS threads of a plain
  ProcessPoolExecutor, the baseline its speed-ups were measured against). A spawn pool starts its
  processes at submits, and a worker's OpenBLAS takes its thread count from the environment its
  interpreter started with (numpy loads before any initializer runs). Session 6's pool was made
  inside :func:`~rvtool.variants.cluster.single_thread_env` but first submitted to after it closed,
  so its helpers kept the default OpenBLAS threads (probed on the 2-core CPU box through ctypes'
  ``scipy_openblas_get_num_threads64_``: 2, against 1 for a pool first submitted to inside the
  environment). True now starts every worker inside the environment at once (a start round at the
  barrier), which is what the helpers were meant to have: on a 16-core GPU host, 16 helpers of 16
  OpenBLAS threads each contended for the cores while they built the variants. The device figures of
  record (``bench_device_mc``, ``bench_multi_gpu``, session 6) were measured before this fix.
* ``timeout_s`` -- how long a warm-up task waits at the barrier for the others:
  ``multi_device.WARM_TIMEOUT_S`` (600 s: a whole pool's spawn and imports on a loaded GPU host)
  and ``bench_device_mc.WARM_TIMEOUT_S`` (120 s).
* ``on_missed`` -- "raise" (the library: a warm-up that did not reach every worker is an error; a
  warm-up that raises gives no barrier party, the others' waits break at the timeout and raise)
  or "warn" (the benchmark: the warm-up is best effort; a warm-up that raises still gives its
  barrier party, so that the others are not held for the timeout, and its error is raised; a
  barrier that times out is passed over and a pool that reached fewer workers than it has is
  reported on stderr and used).

Caching (the library keeps one pool per helper count for the process) and timing (the benchmark
times the warm-up of a pool of its own) stay with the caller: :func:`barrier_pool` /
:func:`warm_every_worker` for a kept pool, :func:`warmed_pool` for an owned, timed one.
"""
import multiprocessing
import numbers
import os
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor

ON_MISSED = ("raise", "warn")
"""What :func:`warm_every_worker` does where the warm-up did not reach every worker (module docstring)."""

_ENV_AT_START = os.environ.get("OPENBLAS_NUM_THREADS")
"""In a worker of :func:`barrier_pool`: OPENBLAS_NUM_THREADS as the worker's interpreter started (before any
initializer), which sets its OpenBLAS thread count (:func:`env_at_start`)."""

_BARRIER = None
"""In a worker of :func:`barrier_pool`: the barrier of all the pool's workers (set by the pool's
initializer), at which a warm-up task waits so that every worker runs exactly one."""


def _init_worker(barrier, one_blas_thread):
    """Initializer of a :func:`barrier_pool` worker: one BLAS/OpenMP thread where asked, the pool's barrier."""
    global _BARRIER
    if one_blas_thread:
        from .montecarlo import init_helper
        init_helper()
    _BARRIER = barrier


def barrier_pool(workers, *, one_blas_thread, start_timeout_s=600.0):
    """A ProcessPoolExecutor of ``workers`` spawned processes holding one barrier of all of them, for
    :func:`warm_every_worker`; ``one_blas_thread``: started in
    :func:`rvtool.variants.cluster.single_thread_env`, each worker running
    :func:`rvtool.variants.montecarlo.init_helper` (else the default BLAS threads); with
    ``one_blas_thread`` every worker is started at once inside that environment (a round at the barrier,
    each waiting at most ``start_timeout_s`` [s]; fewer started raises), so that none starts later
    outside it."""
    from ..errors import RvtoolInputError
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers < 1:
        raise RvtoolInputError(f"workers = {workers!r} is outside the valid range [1, inf) (integer)")
    workers = int(workers)
    ctx = multiprocessing.get_context("spawn")          # fresh interpreters: no forked Warp/Exudyn state
    kw = dict(max_workers=workers, mp_context=ctx, initializer=_init_worker,
              initargs=(ctx.Barrier(workers), bool(one_blas_thread)))
    if not one_blas_thread:
        return ProcessPoolExecutor(**kw)
    from .cluster import single_thread_env
    with single_thread_env():
        pool = ProcessPoolExecutor(**kw)
        try:
            # the processes spawn at these submits, inside the environment: one OpenBLAS thread each
            started = len(set(pool.map(_start_task, [float(start_timeout_s)] * workers)))
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    if started != workers:
        pool.shutdown(wait=False, cancel_futures=True)
        raise RuntimeError(f"barrier_pool: {started} of {workers} workers started within {start_timeout_s:g} s")
    return pool


def _start_task(timeout_s):
    """A worker's start round (:func:`barrier_pool`): wait for every worker to have started; its pid."""
    _BARRIER.wait(timeout_s)
    return os.getpid()


def env_at_start(_=None):
    """OPENBLAS_NUM_THREADS as this worker's interpreter started (None: unset)."""
    return _ENV_AT_START


def warm_every_worker(pool, workers, warm, jobs, *, timeout_s, on_missed):
    """``warm(job)`` for each of ``jobs`` (one per worker) on ``pool`` (a :func:`barrier_pool` of
    ``workers``), each task waiting at the pool's barrier (at most ``timeout_s`` [s]) after its warm-up
    so that every worker runs exactly one; returns the number of workers that ran one. ``on_missed``
    ("raise" / "warn", module docstring): what a warm-up that reached fewer workers does."""
    if on_missed not in ON_MISSED:
        from ..errors import RvtoolInputError
        raise RvtoolInputError(f"on_missed = {on_missed!r}; valid: {', '.join(ON_MISSED)}")
    task = (warm, float(timeout_s), on_missed == "raise")
    reached = len(set(pool.map(_warm_task, [task + (job,) for job in jobs])))
    if reached != int(workers):
        msg = f"the pool's warm-up reached {reached} of {workers} workers (barrier timeout {timeout_s:g} s)"
        if on_missed == "raise":
            raise RuntimeError(msg)
        print(f"warning: {msg}", file=sys.stderr)
    return reached


def warmed_pool(workers, warm, jobs, *, one_blas_thread, timeout_s, on_missed):
    """(:func:`barrier_pool` of ``workers``, warm-up wall time [s]): the pool warmed by
    :func:`warm_every_worker` (the time from the pool's start, its processes' spawn included, to the
    last warm-up); the caller owns the pool (a ``with`` block), shut down here where the warm-up raises."""
    ex = barrier_pool(workers, one_blas_thread=one_blas_thread)
    t = time.perf_counter()
    try:
        warm_every_worker(ex, workers, warm, jobs, timeout_s=timeout_s, on_missed=on_missed)
    except BaseException:
        ex.shutdown(wait=False, cancel_futures=True)
        raise
    return ex, time.perf_counter() - t


def _warm_task(task):
    """One worker's warm-up (:func:`warm_every_worker`): the warm-up, then the barrier; its pid."""
    warm, timeout_s, strict, job = task
    if strict:                      # "raise": no party where the warm-up raised; a broken barrier raises
        warm(job)
        _BARRIER.wait(timeout_s)
        return os.getpid()
    try:
        warm(job)
    finally:                        # "warn": the barrier gets its party even where the warm-up raised
        try:
            _BARRIER.wait(timeout_s)
        except threading.BrokenBarrierError:
            pass                    # a worker that did not arrive: warm_every_worker says so
    return os.getpid()
