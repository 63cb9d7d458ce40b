"""Quasi-static TE with many input angles per Newton solve (angle-batched sequence).

The quasi-static TE of :func:`rvtool.protocols.precision.quasi_static_te` is a
sequence of N equilibria at prescribed input angles, each warm-started from the
previous one. Solved one at a time, every Newton iteration pays the fixed costs of
a solve (Exudyn's solver set-up, one Python round trip and one kernel launch per
contact family) for one reducer's ~100 contact rows, which is what limits the
sequential path on a CPU (2.6 ms per equilibrium on RD-40, launch and Python
overhead dominating).

Here the N angles are cut into B contiguous segments, and B copies of the same
reducer (one Exudyn system, :func:`rvtool.batched.assembly.build_batched` with B
nominal variants) march through their segments side by side: step k solves the
k-th angle of every segment in ONE batch Newton solve (one launch per family for
all B copies, block-diagonal tangent). Copies are independent, so each copy's
equilibrium is exactly the one the sequential path finds at that angle (the same
residual, tolerances and plausibility bounds); only the start of each segment is a
cold start (the stiffness homotopy of :class:`BatchedStaticSolver`) instead of a
warm start. Each copy's warm start extrapolates its elastic deviation from its two
previous points (``predictor="secant"``).

``workers`` > 1 splits the segments over that many processes (each builds its own
batched system): on a CPU the kernels of one process run on one core.
"""
import os
import time
from concurrent.futures import ProcessPoolExecutor
import multiprocessing

import numpy as np

from ..errors import RvtoolInputError
from ..protocols.precision import transmission_error
from ..validation import check_choice


def _segments(n, copies):
    """(B, L) index array of B contiguous segments covering 0..n-1; the last segment is padded
    by repeating its final index (padded entries are dropped from the results)."""
    L = -(-n // copies)
    idx = np.arange(copies * L).reshape(copies, L)
    return np.minimum(idx, n - 1), idx < n


def _single_thread():
    # one core per worker: the workers already use every core
    os.environ.setdefault("OMP_NUM_THREADS", "1")


def _run(design, angles, torque, build_kw, device, predictor, abs_tol):
    """One process: all segments of ``angles`` (B, L) side by side. Returns per-point arrays
    (B, L): solved input angles, output angles, and per-copy family peaks, stats, and the
    split of the wall time (Exudyn's solves, callbacks, kernel launches with scatter)."""
    from ..assembly import build
    from .replica import replicate
    from ..solver.batched import BatchedStaticSolver

    t0 = time.perf_counter()
    B, L = angles.shape
    kw = dict(build_kw, device=device)
    source = build(design, **kw)
    model = replicate(source, B, device=device, build_kw=kw)
    solver = BatchedStaticSolver(model, build_kw=kw, abs_tol=abs_tol)
    build_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    solver.set_torques(-np.sign(source.ratio) * torque)
    i_out = model.output_local
    ref_out = source.reference.reshape(-1)[i_out]
    th_in, th_out = np.zeros((B, L)), np.zeros((B, L))
    peaks = {}
    prev = None
    peak_s = 0.0
    for k in range(L):
        q = solver.solve(angles[:, k], prev, predictor=predictor)
        if np.any(solver.dead):
            bad = np.flatnonzero(solver.dead)
            from ..errors import SolverFailure
            raise SolverFailure(f"no plausible static equilibrium at input angles "
                                f"{angles[bad, k].tolist()} rad (batch warm start, homotopy and the per-variant "
                                f"ladder failed)")
        prev = angles[:, k]
        th_in[:, k] = solver.solved_angles
        th_out[:, k] = ref_out + q[:, i_out]
        tp = time.perf_counter()
        ev = model.elements.evaluation(model.to_global(q), np.zeros(model.mbs.systemData.ODE2Size()))
        for fam, f in model.family_peaks(ev).items():
            peaks.setdefault(fam, np.zeros((B, L)))[:, k] = f
        peak_s += time.perf_counter() - tp
    st = solver.stats
    split = {"solve_s": time.perf_counter() - t1, "exudyn_s": st.solve_s - st.callback_s,
             "callbacks_s": st.callback_s - st.kernel_s, "kernels_s": model.evaluator.timing["kernels"],
             "scatter_s": model.evaluator.timing["scatter"], "peaks_s": peak_s}
    return {"theta_in": th_in, "theta_out": th_out, "peaks": peaks, "stats": st.to_dict(), "split": split,
            "build_s": build_s, "wall_s": time.perf_counter() - t0}


def batched_quasi_static_te(design, *, torque, input_angles, copies=None, workers=1, device="cpu", build_kw=None,
                            predictor="secant", abs_tol=1e-4):
    """Quasi-static TE of ``design`` (any topology: its builder, then :func:`~rvtool.batched.replica.replicate`) at ``input_angles`` [rad]
    under output torque ``torque`` [N m], solved as B = ``copies`` angle segments side by side
    (see the module docstring) in ``workers`` processes. copies: default min(64, number of
    angles) (RD-40 on 2 CPU cores: 16 -> 64 copies cut a revolution from ~16 to ~11 s, 128 and
    256 were slower again: the kernels' working set outgrows the cache).

    Returns the keys of :func:`rvtool.protocols.precision.quasi_static_te` (``theta_in`` are
    the solved angles, ``te`` [rad], ``peak_loads`` per family [N], ``stats``, ``wall_s``)
    plus ``copies``, ``workers``, ``build_s`` (largest per-process build time [s]).
    build_kw: options of :func:`rvtool.assembly.cycloid.build` the batched builder takes
    (``regularization``). abs_tol: Newton tolerance on the static residual [N]; the
    sequential path's 1e-6 N corresponds to 1e-14 m at the pin contact stiffness, far below
    any figure: 1e-4 N saves a quarter of the Newton iterations and moved the RD-40 TE by
    2.6e-7 arcsec (measured against 1e-6 N; ``cases/bench_cycloid.py`` reports it).
    """
    angles = np.asarray(input_angles, float)
    if angles.ndim != 1 or len(angles) < 2 or not np.all(np.isfinite(angles)):
        raise RvtoolInputError("input_angles must be a finite 1-D sequence of at least 2 angles [rad]")
    if copies is None:
        copies = min(64, len(angles))
    if not isinstance(copies, (int, np.integer)) or not 1 <= copies <= len(angles):
        raise RvtoolInputError(f"copies = {copies!r} is outside the valid range [1, {len(angles)}] (integer, at most "
                               f"the number of input angles)")
    if not isinstance(workers, (int, np.integer)) or not 1 <= workers <= copies:
        raise RvtoolInputError(f"workers = {workers!r} is outside the valid range [1, copies = {copies}] (integer)")
    check_choice("predictor", predictor, ("constant", "secant"))
    if not (np.isfinite(abs_tol) and abs_tol > 0):
        raise RvtoolInputError(f"abs_tol = {abs_tol!r} is outside the valid range (0, inf) N")
    build_kw = dict(build_kw or {})
    t0 = time.perf_counter()
    idx, real = _segments(len(angles), copies)
    blocks = np.array_split(np.arange(copies), workers)
    args = [(design, angles[idx[b]], torque, build_kw, device, predictor, abs_tol) for b in blocks]
    if workers == 1:
        parts = [_run(*args[0])]
    else:
        ctx = multiprocessing.get_context("spawn")   # a fresh interpreter: no forked Warp/Exudyn state
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_single_thread) as ex:
            parts = list(ex.map(_run, *zip(*args)))
    th_in = np.concatenate([p["theta_in"] for p in parts])[real]
    th_out = np.concatenate([p["theta_out"] for p in parts])[real]
    peaks = {fam: float(np.max(np.concatenate([p["peaks"][fam] for p in parts])[real])) for fam in parts[0]["peaks"]}
    stats = {k: sum(p["stats"][k] for p in parts) for k in parts[0]["stats"]}
    split = {k: max(p["split"][k] for p in parts) for k in parts[0]["split"]}
    stats["points"] = len(angles)
    stats["batch_solves_per_process"] = [p["stats"]["solves"] for p in parts]
    return {"theta_in": th_in, "theta_out": th_out, "te": transmission_error(th_in, th_out, design.ratio, unwrap=False),
            "peak_loads": peaks, "stats": stats, "wall_s": time.perf_counter() - t0, "copies": copies,
            "workers": workers, "build_s": max(p["build_s"] for p in parts), "split": split}
