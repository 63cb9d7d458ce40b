"""The device Monte Carlo of a batch of variants on one device, the variants' builds pipelined with
the device solves: the one path of ``cases/benchmarks/bench_device_mc.py`` (one device, its own
build pool) and of every worker of :mod:`rvtool.variants.multi_device` (one per GPU, each with its
helper pool; ``cases/benchmarks/bench_multi_gpu.py``).

* **Chunks**: the variants are solved ``solve_chunk`` copies at a time (:func:`chunk_schedule`: the
  first solve of ``first_chunk`` copies, each next one twice the last up to ``solve_chunk``; None:
  all in one solve).
* **Builds** (sampling and snapshot: :func:`rvtool.variants.multi_device.variant_snapshots`) run on a
  process ``pool`` (a ``concurrent.futures`` executor of ``pool_workers`` processes), a group of
  variants per task (:func:`build_group_size`: about four tasks per pool process and chunk, at most
  64 variants; 100,000 single-variant tasks would cost the submitting process ~0.1 ms each). At most
  ``queued_chunks`` chunks of builds are queued ahead, so the pool builds the next chunks while the
  device solves this one (the snapshots of 100,000 RD-40 variants would not fit the host's memory at
  once). The pool's result thread receives and unpickles each group as it comes, so receiving
  overlaps the solves too. Without a pool the variants are built here, a chunk when it is taken.
* **Solves**: each chunk is one :func:`rvtool.batched.device_rows_variants.device_rows_variants`
  (TE over ``input_angles`` at ``torque``, lost motion at ``lost_motion_level``; points and copies
  the device does not converge run on Exudyn and are counted) with the row Newton's ``settings``
  (e.g. ``graph``: on CUDA the resident loop as one captured CUDA graph). A variant that cannot be
  built is a failed variant of the study (:func:`with_failed_builds`: figures NaN, its error kept).
* **Tables**: ``defer_tables`` leaves cycloid variants' profile tables to the device's process (the
  pool sends profiles, ~35 kB a snapshot instead of ~548 kB; a GPU computes the tables of a chunk in
  one batch inside the device setup, the cpu device where read); RV variants' tables are shared
  either way.

The copies are independent: the figures do not depend on the chunks or on the pool (equal bit for
bit on cpu, tests/test_multi_gpu.py).
"""
import contextlib
import functools
import time
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError


def chunk_schedule(n, solve_chunk, first_chunk=None):
    """Sizes of the device solves of ``n`` copies: ``first_chunk`` copies first (None:
    ``solve_chunk // 8``, at least 1), each next solve twice the last, up to ``solve_chunk``; so that
    the device starts after a few builds instead of a whole ``solve_chunk`` of them, and the helpers
    build the next (larger) chunk while it solves. The sizes sum to ``n``; equal to ``solve_chunk``
    throughout for ``first_chunk = solve_chunk``."""
    for name, v in (("solve_chunk", solve_chunk), ("first_chunk", first_chunk)):
        if v is None and name == "first_chunk":
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise RvtoolInputError(f"{name} = {v!r} is outside the valid range [1, inf) (integer)")
    solve_chunk = int(solve_chunk)
    size = max(1, solve_chunk // 8) if first_chunk is None else min(int(first_chunk), solve_chunk)
    sizes, left = [], int(n)
    while left > 0:
        sizes.append(min(size, left))
        left -= sizes[-1]
        size = min(2 * size, solve_chunk)
    return sizes


def solve_sizes(n, solve_chunk=None, first_chunk=None):
    """The device solves of ``n`` copies as the pipeline runs them: one solve of all for
    ``solve_chunk=None`` (``first_chunk`` ignored), else :func:`chunk_schedule`."""
    if solve_chunk is None:
        return [int(n)] if n > 0 else []
    return chunk_schedule(n, solve_chunk, first_chunk)


def build_group_size(n, pool_workers, cap=64):
    """Variants per build task of a chunk of ``n`` on a pool of ``pool_workers`` processes: about four
    tasks per process (the pool's load evens out), at most ``cap``, at least 1."""
    return max(1, min(int(cap), int(n) // (4 * max(1, int(pool_workers)))))


def merge_chunks(parts, n):
    """One :class:`~rvtool.batched.device_rows_variants.RowVariants` of ``n`` variants from its
    chunks' ``parts`` (in variant order): arrays and lists concatenated, counts, split and times summed
    (``wall_s``: the device's time, the chunks' sum), the stats of a single part kept as they are."""
    from ..batched.device_rows_variants import RowVariants
    cat = lambda nm: np.concatenate([getattr(p, nm) for p in parts])
    split = {k: sum(p.split[k] for p in parts) for k in parts[0].split}
    lm = [p.lost_motion_rad for p in parts]
    stats = parts[0].stats if len(parts) == 1 else {
        "variants": n, "points": parts[0].stats["points"], "te_order": parts[0].stats.get("te_order"),
        "chunks": len(parts),
        "sweeps": sum(p.stats["sweeps"] for p in parts),
        "newton_iterations": sum(p.stats["newton_iterations"] for p in parts),
        "device": parts[0].stats["device"], "device_sum": parts[0].stats["device_sum"],
        "lost_motion": [p.stats["lost_motion"] for p in parts],
        "setup_parts": [p.stats.get("setup_parts") for p in parts]}
    return RowVariants(te=cat("te"), theta_out=cat("theta_out"), lost_motion_rad=None if lm[0] is None
                       else np.concatenate(lm), status=sum((p.status for p in parts), []),
                       error=sum((p.error for p in parts), []),
                       exudyn_points=sum(p.exudyn_points for p in parts),
                       exudyn_copies=sum(p.exudyn_copies for p in parts), split=split,
                       te_s=sum(p.te_s for p in parts), lost_motion_s=sum(p.lost_motion_s for p in parts),
                       wall_s=sum(p.wall_s for p in parts), stats=stats)


def with_failed_builds(part, built, errors, n_points):
    """The RowVariants of a chunk whose variants ``built`` (bool per variant) were built and solved in
    ``part`` (None: none was), the others failed with their build ``errors`` (figures NaN)."""
    from ..batched.device_rows_variants import RowVariants
    built = np.asarray(built, bool)
    n = len(built)
    te, th, lm = np.full((n, n_points), np.nan), np.full((n, n_points), np.nan), np.full(n, np.nan)
    status, error = ["failed"] * n, [None] * n
    for i, e in zip(np.flatnonzero(~built), errors):
        error[i] = f"build: {e}"
    if part is None:
        zero = {"setup_s": 0.0, "kernels_s": 0.0, "scatter_s": 0.0, "step_s": 0.0, "fallback_s": 0.0, "rest_s": 0.0}
        return RowVariants(te=te, theta_out=th, lost_motion_rad=lm, status=status, error=error, exudyn_points=0,
                           exudyn_copies=0, split=zero, te_s=0.0, lost_motion_s=0.0, wall_s=0.0,
                           stats={"points": n_points, "te_order": None, "sweeps": 0, "newton_iterations": 0,
                                  "device": None, "device_sum": None, "lost_motion": {}})
    idx = np.flatnonzero(built)
    te[idx], th[idx], lm[idx] = part.te, part.theta_out, part.lost_motion_rad
    for j, i in enumerate(idx):
        status[i], error[i] = part.status[j], part.error[j]
    return RowVariants(te=te, theta_out=th, lost_motion_rad=lm, status=status, error=error,
                       exudyn_points=part.exudyn_points, exudyn_copies=part.exudyn_copies, split=part.split,
                       te_s=part.te_s, lost_motion_s=part.lost_motion_s, wall_s=part.wall_s, stats=part.stats)


@contextlib.contextmanager
def paused_collector():
    """Python's cyclic garbage collector paused inside (as it was on exit). A device Monte Carlo's process
    receives thousands of variant snapshots from its helpers (a few hundred long-lived objects each, unpickled
    by the pool's result thread) and copies them into its device rows; the collector's full passes over the
    growing heap then cost about twice the unpickling itself (measured on cpu: 1,005 RD-40 snapshots with
    deferred tables unpickled in 0.72-1.13 s with the collector running, 0.23-0.39 s paused; load ~4.4 on 2
    cores). Reference counting still frees what is dropped; objects in garbage cycles made inside are
    collected after the block."""
    import gc
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


@dataclass(frozen=True)
class PipelineRun:
    """What :func:`device_variants_pipelined` did: ``parts`` the RowVariants of each device solve (in
    variant order, failed builds included), ``indices`` the variants of each part, ``build_wait_s``
    per solve the time [s] the device's process waited for that chunk's builds (``build_wait_cpu_s`` its CPU
    time meanwhile: the pool's result thread unpickling the snapshots; near ``build_wait_s``, receiving
    bounds the wait), ``wall_s`` [s] from
    the first build submitted to the last chunk solved (builds, transfers, solves and fallbacks; the
    caller's ``after_chunk`` time excluded), ``first_device_start_s`` [s] from that start to the first
    device solve (None: nothing was built)."""
    parts: tuple
    indices: tuple
    build_wait_s: tuple
    build_wait_cpu_s: tuple
    wall_s: float
    first_device_start_s: float | None

    @property
    def sizes(self):
        """Copies of each device solve."""
        return [len(ix) for ix in self.indices]

    def merged(self):
        """The RowVariants of all variants (:func:`merge_chunks`)."""
        return merge_chunks(list(self.parts), sum(self.sizes))


def device_variants_pipelined(design, tolerances, seed, indices, *, build_kw, torque, input_angles,
                              lost_motion_level, device="cpu", settings=None, pool=None, pool_workers=1,
                              solve_chunk=None, first_chunk=None, defer_tables=False, queued_chunks=2,
                              after_chunk=None):
    """TE and lost motion of the variants ``indices`` of ``design`` (sampled from ``tolerances`` with
    ``seed``, built with ``build_kw``) on the device row Newton on ``device`` (module docstring).
    torque [N m], input_angles [rad], lost_motion_level [N m] or None: as
    :func:`~rvtool.batched.device_rows_variants.device_rows_variants`; settings: its
    :class:`~rvtool.solver.device_newton.DeviceNewtonSettings` (None: default); pool: the build
    executor (None: built here) of ``pool_workers`` processes; solve_chunk, first_chunk:
    :func:`solve_sizes`; defer_tables: cycloid profile tables computed by the device's process;
    queued_chunks: chunks of builds queued ahead (>= 1); after_chunk(models, part): called after
    each solve (e.g. bookkeeping of a report), its time excluded from ``wall_s``. Returns a
    :class:`PipelineRun`."""
    from ..batched.device_rows_variants import device_rows_variants
    from .multi_device import variant_snapshots
    if isinstance(queued_chunks, bool) or not isinstance(queued_chunks, (int, np.integer)) or queued_chunks < 1:
        raise RvtoolInputError(f"queued_chunks = {queued_chunks!r} is outside the valid range [1, inf) (integer)")
    indices = [int(k) for k in indices]
    sizes = solve_sizes(len(indices), solve_chunk, first_chunk)
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    chunks = [indices[starts[i]:starts[i + 1]] for i in range(len(sizes))]
    kw = dict(build_kw or {})
    task = functools.partial(variant_snapshots, defer_tables=bool(defer_tables))

    def submit(i):
        jobs = [(design, tolerances, seed, k, kw) for k in chunks[i]]
        if pool is None:
            return jobs
        g = build_group_size(len(jobs), pool_workers)
        return [pool.submit(task, jobs[j:j + g]) for j in range(0, len(jobs), g)]

    def take(queued):
        return task(queued) if pool is None else [x for f in queued for x in f.result()]

    parts, waits, wait_cpu, first_start = [], [], [], None
    with paused_collector():                  # this process receives every snapshot and solves (paused_collector)
        t0, aside = time.perf_counter(), 0.0
        queued = {i: submit(i) for i in range(min(int(queued_chunks), len(sizes)))}
        for i in range(len(sizes)):
            tw, cw = time.perf_counter(), time.process_time()
            got = take(queued.pop(i))
            waits.append(time.perf_counter() - tw)
            wait_cpu.append(time.process_time() - cw)
            if i + queued_chunks < len(sizes):
                queued[i + queued_chunks] = submit(i + queued_chunks)
            models = [m for _, m, _ in got if m is not None]
            bad = [(k, e) for k, m, e in got if m is None]
            if models and first_start is None:
                first_start = time.perf_counter() - t0 - aside
            part = device_rows_variants(models, torque=torque, input_angles=input_angles,
                                        lost_motion_level=lost_motion_level, device=device, settings=settings) \
                if models else None
            if after_chunk is not None:
                ta = time.perf_counter()
                after_chunk(models, part)
                aside += time.perf_counter() - ta
            if bad:                                   # a variant that cannot be built is a failed variant of the study
                part = with_failed_builds(part, [m is not None for _, m, _ in got], [e for _, _, e in bad],
                                          len(input_angles))
            parts.append(part)
        wall = time.perf_counter() - t0 - aside
    return PipelineRun(parts=tuple(parts), indices=tuple(tuple(c) for c in chunks), build_wait_s=tuple(waits),
                       build_wait_cpu_s=tuple(wait_cpu),
                       wall_s=wall, first_device_start_s=first_start)


__all__ = ["PipelineRun", "build_group_size", "chunk_schedule", "device_variants_pipelined", "merge_chunks",
           "paused_collector", "solve_sizes", "with_failed_builds"]
