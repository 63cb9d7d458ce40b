"""The batched-replica backend: B copies of the model in ONE Exudyn system
(:func:`rvtool.solver.replica.replicate`, any topology), the states cut into B contiguous
segments marched side by side, one batch Newton solve (:class:`rvtool.solver.batched.BatchedStaticSolver`,
one kernel launch per family for all copies, block-diagonal tangent) per step.

Copies are independent, so each copy's equilibrium is the one the Exudyn backend finds at that
angle (the same residual and plausibility bounds); only each segment's start is a cold start
(the stiffness homotopy) instead of a warm start, and each copy's warm start extrapolates its
elastic deviation from its two previous points (``predictor="secant"``). On a CPU this amortizes
the fixed cost of a solve (set-up, Python round trip, one launch per family) over B copies.
``workers`` > 1 splits the segments over that many processes, each building the model from
``model.design`` with ``build_kw`` (a process has no copy of an Exudyn system).
"""
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from ...errors import RvtoolInputError, SolverFailure
from ...validation import check_choice
from .base import Backend, Equilibria, Support, spatial_body_reasons


def segments(n, copies):
    """(B, L) index array of B contiguous segments covering 0..n-1; the last segment is padded
    by repeating its final index (padded entries are dropped from the results)."""
    L = -(-n // copies)
    idx = np.arange(copies * L).reshape(copies, L)
    return np.minimum(idx, n - 1), idx < n


def _single_thread():
    # one core per worker: the workers already use every core
    os.environ.setdefault("OMP_NUM_THREADS", "1")


def _march(source, angles, torque, build_kw, device, predictor, abs_tol):
    """One process: all segments of ``angles`` (B, L) side by side on copies of ``source`` (a built
    model, or a design built here with build_kw). Returns per-point arrays (B, L): solved input
    angles, output angles, per-family peaks, stats and the split of the wall time."""
    from .. import replica
    from ..batched import BatchedStaticSolver

    t0 = time.perf_counter()
    B, L = angles.shape
    kw = dict(build_kw, device=device)
    if not hasattr(source, "mbs"):
        from ...assembly import build      # a worker process: the design's model
        source = build(source, **kw)
    model = replica.replicate(source, B, device=device, build_kw=kw)
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


class ReplicaBackend(Backend):
    """Batched replica (module docstring). copies: B (default min(64, number of states); RD-40 on
    2 CPU cores: 16 -> 64 copies cut a revolution from ~16 to ~11 s, 128 and 256 were slower);
    workers: processes; build_kw: the builder options ``model`` was built with (the per-copy
    fallback and the worker processes rebuild from ``model.design`` with them); abs_tol: Newton
    tolerance on the static residual [N] (1e-4 N moved the RD-40 TE by 2.6e-7 arcsec against
    1e-6 N and saves a quarter of the iterations)."""
    name = "replica"
    tasks = ("equilibria",)

    def __init__(self, *, copies=None, workers=1, build_kw=None, device="cpu", predictor="secant", abs_tol=1e-4):
        check_choice("predictor", predictor, ("constant", "secant"))
        if not (np.isfinite(abs_tol) and abs_tol > 0):
            raise RvtoolInputError(f"abs_tol = {abs_tol!r} is outside the valid range (0, inf) N")
        self.copies, self.workers, self.build_kw = copies, workers, dict(build_kw or {})
        self.device, self.predictor, self.abs_tol = device, predictor, abs_tol

    def supports(self, model, task, run=None):
        if not self._task(task):
            return Support.of([f"replica does not implement {task!r} (equilibria only)"])
        from ..replica import replica_reasons
        # spatial bodies first, by name (issue 32); the set types without a copier follow
        return Support.of(spatial_body_reasons(model) + list(replica_reasons(model)))

    def solve_equilibria(self, model, batch, *, record=None):
        if record is not None:
            raise RvtoolInputError("the replica backend returns no per-point states (record=None; valid: the "
                                   "exudyn backend)")
        return self.solve_design(model.design, batch, model=model)

    def solve_design(self, design, batch, *, model=None):
        """:meth:`solve_equilibria` from ``design`` (built in each worker process with ``build_kw``;
        with one worker, ``model`` is copied if given, else the design is built here)."""
        angles = np.asarray(batch.input_angles)
        n = len(angles)
        if n < 2:
            raise RvtoolInputError("the replica backend needs at least 2 input angles")
        copies = min(64, n) if self.copies is None else self.copies
        if not isinstance(copies, (int, np.integer)) or not 1 <= copies <= n:
            raise RvtoolInputError(f"copies = {copies!r} is outside the valid range [1, {n}] (integer, at most "
                                   f"the number of input angles)")
        workers = self.workers
        if not isinstance(workers, (int, np.integer)) or not 1 <= workers <= copies:
            raise RvtoolInputError(f"workers = {workers!r} is outside the valid range [1, copies = {copies}] (integer)")
        t0 = time.perf_counter()
        idx, real = segments(n, copies)
        blocks = np.array_split(np.arange(copies), workers)
        args = [(design, angles[idx[b]], batch.torque, self.build_kw, self.device, self.predictor,
                 self.abs_tol) for b in blocks]
        if workers == 1:
            parts = [_march(model if model is not None else design, *args[0][1:])]
        else:
            ctx = multiprocessing.get_context("spawn")   # a fresh interpreter: no forked Warp/Exudyn state
            with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_single_thread) as ex:
                parts = list(ex.map(_march, *zip(*args)))
        th_in = np.concatenate([p["theta_in"] for p in parts])[real]
        th_out = np.concatenate([p["theta_out"] for p in parts])[real]
        peaks = {fam: float(np.max(np.concatenate([p["peaks"][fam] for p in parts])[real])) for fam in parts[0]["peaks"]}
        stats = {k: sum(p["stats"][k] for p in parts) for k in parts[0]["stats"]}
        stats["points"] = n
        stats["batch_solves_per_process"] = [p["stats"]["solves"] for p in parts]
        stats.update(copies=copies, workers=workers, build_s=max(p["build_s"] for p in parts),
                     split={k: max(p["split"][k] for p in parts) for k in parts[0]["split"]})
        return Equilibria(theta_in=th_in, theta_out=th_out, peak_loads=peaks, peak_contact_loads={},
                          regularization_max=None, stats=stats, wall_s=time.perf_counter() - t0)
