"""The device backend's row Newton: B independent equilibria of ANY replicable model (RV,
small-tooth-difference, cycloid) from the contact rows of its families, without an Exudyn system.

The fully device-resident Newton (:mod:`rvtool.solver.device_newton`) reads a cycloid design's
copy parameters (cycloid pins, plain output pins, lumped bearings: three families of two planar
bodies, the loop a CUDA graph). Other topologies have other families: RV-40E's merged element
holds cycloid pins, involute pairs, needle (eccentric) and ball (main) rolling elements and
tapered rollers (the crank bearings that carry the output carrier). This module solves those:

1. every contact element of the model is copied B times on the Warp device
   (:func:`rvtool.solver.replica.copy_families`, the copiers the replica backend uses: the same
   kernels, the same rows, no physics written again);
2. one Newton iteration of all B copies evaluates each family in one launch at the absolute
   poses reference + q of all copies, and sums its rows into per-copy residuals and dense tangent
   blocks (:class:`rvtool.solver.replica.ReplicaEvaluator`, the rows' block scatter);
3. the step of :mod:`warp_contacts.batched_newton_ref` (the reference of the device-resident
   kernel, the same bookkeeping) vectorized over the copies: regularization springs times the
   copy's homotopy factor, the output torque, the fixed coordinates (drive, coordinate locks,
   journal locks: identity rows at their prescribed values), a dense solve per copy, step
   limiting, plausibility bounds, warm start -> regularization homotopy -> failed.

Where it runs: the contact kernels on the Warp device (``cpu`` or ``cuda``); the block scatter,
the tapered rollers' planar mapping (NumPy in :class:`rvtool.bearings.tapered_set.TaperedBearingSet`)
and the per-copy dense solve on the host, one host round trip per iteration. It is therefore
not a CUDA graph like the cycloid path: that needs the tapered planar mapping and a family-generic
row sum as device kernels (issue 31, not done here).

Covered: every contact-set type of :data:`rvtool.solver.replica.COPIERS` (cycloid pins, involute
pairs external and internal, rolling-element bearings: needle, cylindrical, ball, tapered; circle
pairs, plain output pins). Not covered (named by :func:`row_reasons`): friction with stick--slip
anchors (history), elastic pin and crank closures (pin bodies), the ported housing's modal
coordinates (elastic structures), shared output pins.
"""
import time
from dataclasses import dataclass

import numpy as np

from warp_contacts.batched_newton_ref import ACTIVE, CONVERGED, FAILED, WARM

from ..errors import RvtoolInputError
from ..model.reducer import COORDINATES
from .device_newton import DeviceNewtonSettings


def row_reasons(model):
    """Every named reason why the row Newton cannot run ``model`` (empty: it can)."""
    from .replica import replica_reasons
    return [r.replace("the angle-batched path", "the device row Newton") for r in replica_reasons(model)]


@dataclass
class RowSolve:
    """Result of :meth:`DeviceRowNewton.solve` for P copies: q (P, 3 nb) displacement states [m,
    rad], status (P,) (CONVERGED / FAILED), the converged stage (-1 warm start, s homotopy stage),
    Newton iterations per copy, residual norms [N], sweeps (batch iterations) and the wall-time
    split [s]: ``kernels_s`` (the families' launches with their host transfers), ``scatter_s``
    (rows into per-copy blocks), ``solve_s`` (the host step), ``setup_s`` (copying the families)."""
    q: np.ndarray
    status: np.ndarray
    stage: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    sweeps: int
    kernels_s: float
    scatter_s: float
    solve_s: float
    setup_s: float

    @property
    def converged(self):
        return self.status == CONVERGED


class DeviceRowNewton:
    """Batched static Newton of B copies of ``model`` from its families' rows (module docstring).

    copies: B, the number of equilibria one launch evaluates (a larger request runs in chunks of
    B); device: Warp device of the contact kernels; settings: :class:`DeviceNewtonSettings` (the
    cycloid path's tolerances and bounds: abs_tol 1e-6 N as Exudyn's static solver)."""

    def __init__(self, model, copies, *, device="cpu", settings=None):
        from .replica import ReplicaEvaluator, copy_families, held_coordinates
        reasons = row_reasons(model)
        if reasons:
            raise RvtoolInputError("; ".join(reasons))
        if isinstance(copies, bool) or not isinstance(copies, (int, np.integer)) or copies < 1:
            raise RvtoolInputError(f"copies = {copies!r} is outside the valid range [1, inf) (integer)")
        t0 = time.perf_counter()
        self.model, self.B, self.device = model, int(copies), device
        self.settings = settings or DeviceNewtonSettings()
        self.nb = nb = len(model.body_names)
        self.n = n = 3 * nb
        self.evaluator = ReplicaEvaluator(copy_families(model, self.B, device=device), nb, self.B)
        self.evaluator.set_static(True)              # static residual: no velocity tangent
        self.input_local = 3 * model.body_index(model.input.body) + COORDINATES.index(model.input.coordinate)
        self.output_local = 3 * model.body_index(model.output.body) + COORDINATES.index(model.output.coordinate)
        free = np.ones(n, bool)
        self.held = np.zeros(n, bool)
        for b, k in held_coordinates(model):
            self.held[3 * b + k] = True
        self.journal = np.zeros(n, bool)
        for b, k, _ in model.journal_locks:
            self.journal[3 * b + k] = True
        free[self.held | self.journal] = False
        free[self.input_local] = False
        self.free = free
        self.spring_k = np.zeros(n)
        for b, k, kk, _ in model.reg_springs:
            self.spring_k[3 * b + k] += kk
        self.rot = np.arange(n) % 3 == 2
        self.reference = np.asarray(model.reference, float).reshape(-1)
        self.setup_s = time.perf_counter() - t0

    def kinematic(self, angles):
        """(P, 3 nb) kinematic displacement states at input angles (P,) [rad], with the values the
        model's constraints prescribe: drive = angle, coordinate locks 0, journal locks and springs
        at the kinematic positions (:meth:`ReducerModel.set_input_angle`)."""
        a = np.asarray(angles, float)
        kin = (self.model.kinematics.poses(a) - self.model.reference).reshape(len(a), -1)
        kin[:, self.held] = 0.0
        kin[:, self.input_local] = a
        return kin

    def solve(self, angles, torques, q_start=None):
        """Equilibria at input angles (P,) [rad] under output torques (P,) [N m] (on the output
        coordinate), from q_start (P, 3 nb) (None: the kinematic states). Returns a :class:`RowSolve`."""
        a = np.asarray(angles, float)
        P = len(a)
        tq = np.broadcast_to(np.asarray(torques, float), (P,)).copy()
        kin = self.kinematic(a)
        q = kin.copy() if q_start is None else np.array(q_start, float)
        if q.shape != (P, self.n) or not np.all(np.isfinite(q)):
            raise RvtoolInputError(f"q_start must be finite with shape ({P}, {self.n})")
        q[:, ~self.free] = kin[:, ~self.free]
        out = {"status": np.full(P, ACTIVE, np.int32), "stage": np.full(P, WARM, np.int32),
               "iters": np.zeros(P, np.int32), "total": np.zeros(P, np.int32), "residual": np.full(P, np.nan)}
        timing = {"kernels": 0.0, "scatter": 0.0, "solve": 0.0}
        sweeps = 0
        for s in range(0, P, self.B):
            sl = slice(s, min(P, s + self.B))
            sweeps += self._chunk(q[sl], kin[sl], tq[sl], {k: v[sl] for k, v in out.items()}, timing)
        return RowSolve(q=q, status=out["status"], stage=out["stage"], iterations=out["total"],
                        residual=out["residual"], sweeps=sweeps, kernels_s=timing["kernels"],
                        scatter_s=timing["scatter"], solve_s=timing["solve"], setup_s=self.setup_s)

    def _chunk(self, q, kin, tq, st, timing):
        """Iterate copies 0..m-1 of the evaluator (m <= B) until none is active; arrays in place."""
        m, B, n = len(q), self.B, self.n
        ev = self.evaluator
        ev.masked[:] = False
        ev.masked[m:] = True                         # padding copies of a last, smaller chunk
        pose_q = np.zeros((B, n))
        pad_kin = np.zeros((B, n))
        pad_kin[:m] = kin
        pad_kin[m:] = kin[0]
        vel = np.zeros((B * self.nb, 3))
        sweeps = 0
        while np.any(st["status"] == ACTIVE):
            pose_q[:m] = q
            pose_q[m:] = pad_kin[m:]
            k0, s0 = ev.timing["kernels"], ev.timing["scatter"]
            r = ev.evaluate((self.reference[None] + pose_q).reshape(B * self.nb, 3), vel)
            timing["kernels"] += ev.timing["kernels"] - k0
            timing["scatter"] += ev.timing["scatter"] - s0
            t0 = time.perf_counter()
            self._step(r.Q[:m], r.dQdq[:m], q, kin, tq, st)
            timing["solve"] += time.perf_counter() - t0
            sweeps += 1
        return sweeps

    def _step(self, Qc, Kc, q, kin, tq, st):
        """One step of every active copy: :func:`warp_contacts.batched_newton_ref.newton_step`
        vectorized over the copies (same order of operations per copy)."""
        cfg = self.settings
        status, stage, iters, total = st["status"], st["stage"], st["iters"], st["total"]
        act = np.flatnonzero(status == ACTIVE)
        stiff = np.asarray(cfg.stiffening, float)
        free, rot = self.free, self.rot
        total[act] += 1
        f = np.where(stage[act] == WARM, 1.0, stiff[np.maximum(stage[act], 0)])
        ks = f[:, None] * self.spring_k[None]
        r = Qc[act] - ks * (q[act] - kin[act])
        r[:, self.output_local] += tq[act]
        A = -Kc[act]
        A[:, np.arange(self.n), np.arange(self.n)] += ks
        r[:, ~free] = 0.0
        A[:, ~free, :] = 0.0
        A[:, :, ~free] = 0.0
        A[:, ~free, ~free] = 1.0
        ok = np.isfinite(r).all(axis=1) & np.isfinite(A).all(axis=(1, 2))
        norm = np.sqrt(np.sum(r * r, axis=1))
        st["residual"][act] = norm
        converged = ok & (norm <= cfg.abs_tol)
        dq = np.zeros_like(r)
        good = np.flatnonzero(ok)
        if len(good):
            try:
                dq[good] = np.linalg.solve(A[good], r[good][:, :, None])[:, :, 0]
            except np.linalg.LinAlgError:               # one singular block: solve them one by one
                for i in good:
                    try:
                        dq[i] = np.linalg.solve(A[i], r[i])
                    except np.linalg.LinAlgError:
                        ok[i] = False
        ok &= np.isfinite(dq).all(axis=1)
        mt = np.max(np.abs(dq[:, ~rot]), axis=1)
        mr = np.max(np.abs(dq[:, rot]), axis=1)
        scale = np.ones(len(act))
        lim_t = ~converged & (mt > cfg.max_step_translation)
        scale[lim_t] = cfg.max_step_translation / mt[lim_t]
        lim_r = ~converged & (mr * scale > cfg.max_step_rotation)
        scale[lim_r] = cfg.max_step_rotation / mr[lim_r]
        upd = act[ok]
        q[upd] += scale[ok, None] * dq[ok]
        iters[upd] += 1
        dev = np.abs(q[act] - kin[act])
        implausible = np.any(np.where(rot[None], dev > cfg.max_rotation, dev > cfg.max_translation), axis=1)
        ok &= ~implausible
        last = len(stiff) - 1
        done = ok & converged
        fin = done & ((stage[act] == WARM) | (stage[act] == last))
        status[act[fin]] = CONVERGED
        nxt = act[done & ~fin]
        stage[nxt] += 1
        iters[nxt] = 0
        bad = act[~done & (~ok | (iters[act] >= cfg.max_iterations))]
        to_h = bad[(stage[bad] == WARM) & bool(cfg.homotopy)]
        stage[to_h] = 0
        iters[to_h] = 0
        q[to_h] = kin[to_h]
        status[np.setdiff1d(bad, to_h)] = FAILED


__all__ = ["DeviceRowNewton", "RowSolve", "row_reasons"]
