"""Quasi-static solves of all copies of a :class:`~rvtool.batched.assembly.BatchedCycloidModel`.

:class:`BatchedStaticSolver` mirrors :class:`rvtool.solver.static.StaticSolver`
on all copies at once: the same Exudyn static-solver settings (EigenSparse), the
same warm start (previous equilibrium shifted by each copy's kinematic increment),
the same regularization-stiffness homotopy (``StaticSolver.STIFFENING``) and the
same plausibility bounds, judged per copy:

* Exudyn's Newton converges only when every copy does. After a failed batch solve
  each copy is judged on its own: its static residual over its free coordinates
  (contact forces + regularization springs + output torque, constraint rows excluded)
  must be below ``abs_tol`` and its state finite and plausible. Copies are independent,
  so a converged copy is a valid equilibrium whatever the others did.
* Copies that failed the warm start go through the stiffness homotopy together, the
  accepted copies riding along from their solution with their own springs (their
  accepted states are kept); copies that still fail are solved by the per-variant
  path (:class:`StaticSolver` on the batch model's ``copy_model(c)``: that copy's own model,
  warm-started from the copy's previous state) and counted in ``stats.fallbacks``.
  A copy that fails there too is marked failed (its figures NaN, ``status="failed"``);
  it is parked at its kinematic state on stiff springs so that it cannot disturb the
  Newton solves of the others.
"""
import time
from dataclasses import dataclass

import numpy as np
import exudyn as exu

from ..errors import SolverFailure
from .static import StaticSolver, static_settings


@dataclass
class BatchStats:
    """Counters of a batch run: batch Newton solves and iterations, copies sent through
    the batched homotopy, per-copy fallbacks to the per-variant path, failed copies, and
    the wall times [s] of the Exudyn solves (``solve_s``), of the Python callbacks inside
    them (``callback_s``) and of the kernel launches with block scatter (``kernel_s``)."""
    solves: int = 0
    newton_iterations: int = 0
    homotopy_copies: int = 0
    fallbacks: int = 0
    failed_copies: int = 0
    solve_s: float = 0.0
    callback_s: float = 0.0
    kernel_s: float = 0.0

    def to_dict(self):
        return dict(self.__dict__)


class BatchedStaticSolver:
    """Warm-started static solves of all copies of a :class:`BatchedCycloidModel` or a
    :class:`~rvtool.solver.replica.ReplicatedModel`
    (tolerances and bounds as :class:`StaticSolver`, see the module docstring)."""

    STIFFENING = StaticSolver.STIFFENING

    def __init__(self, model, *, abs_tol=1e-6, rel_tol=1e-9, max_iterations=30, ramp_steps=20,
                 max_translation=5e-4, max_rotation=2e-2, build_kw=None):
        self.model = model
        self.abs_tol = abs_tol
        self.opts = dict(abs_tol=abs_tol, rel_tol=rel_tol, max_iterations=max_iterations, ramp_steps=ramp_steps,
                         max_translation=max_translation, max_rotation=max_rotation)
        self.build_kw = build_kw or {}
        self.stats = BatchStats()
        ss = static_settings(abs_tol=abs_tol, rel_tol=rel_tol, max_iterations=max_iterations,
                             solver_type=exu.LinearSolverType.EigenSparse)
        st = ss.staticSolver
        st.useLoadFactor = False
        st.numberOfLoadSteps = 1
        # without a load factor the loads do not depend on the pseudo-time, so Exudyn's adaptive
        # step would only repeat a failed Newton from the same start; a failure goes to the
        # homotopy / bisection / per-variant ladder at once instead
        st.adaptiveStep = False
        self.settings = ss
        model.evaluator.set_static(True)        # static residual: no velocity tangent needed
        B, nb = model.n_copies, model.nb
        n = 3 * nb
        # per-copy bounds and free coordinates (all but the drive and the locks)
        self.is_rot = np.tile(np.arange(n) % 3 == 2, (B, 1))
        self.free = np.ones((B, n), bool)
        self.free[:, model.input_local] = False        # the driven input rotation
        for c, m in enumerate(model.copies):
            for obj in m.locks:
                mk = model.mbs.GetObjectParameter(obj, "markerNumbers")[1]
                b = [int(n) for n in m.nodes].index(int(model.mbs.GetMarkerParameter(mk, "nodeNumber")))
                self.free[c, 3 * b + model.mbs.GetMarkerParameter(mk, "coordinate")] = False
        # regularization springs: (B, n_s) local coordinate index, stiffness and object
        self.spring_idx = np.array([[3 * b + cc for b, cc, _, _ in m.reg_springs] for m in model.copies], int)
        self.spring_k = np.array([[k for _, _, k, _ in m.reg_springs] for m in model.copies], float).reshape(B, -1)
        self.spring_obj = [[o for _, _, _, o in m.reg_springs] for m in model.copies]
        self.factor = np.ones(B)
        self.torque = np.zeros(B)
        self.angle = None
        self.angles = self.solved_angles = None     # (B,) prescribed and solved input angles [rad]
        self._history = []                          # [(angles, deviation from kinematic)] of the last accepted solves
        self.dead = np.zeros(B, bool)
        self.qc = None                                 # (B, 3 nb) accepted states
        self._pv = {}

    # -- controls ---------------------------------------------------------------
    def set_torques(self, torques):
        self.torque = np.broadcast_to(np.asarray(torques, float), (self.model.n_copies,)).copy()
        self.model.set_output_torques(self.torque)

    def set_angle(self, angle):
        """Input angle [rad]: a scalar (every copy; ``self.angle`` a float) or one per copy (B,)."""
        a = np.asarray(angle, float)
        self.angles = np.broadcast_to(a, (self.model.n_copies,)).copy()
        self.angle = float(a) if a.ndim == 0 else self.angles
        self.solved_angles = self.angles.copy()
        self.model.set_input_angle(self.angles)
        self.kin = self.model.kinematic_vectors(self.angles)

    def _set_factors(self, factors):
        mbs = self.model.mbs
        for c in np.flatnonzero(factors != self.factor):
            for obj, k in zip(self.spring_obj[c], self.spring_k[c]):
                mbs.SetObjectParameter(obj, "stiffness", float(k * factors[c]))
        self.factor = np.array(factors, float)

    def park(self, copies):
        """Switch off the contact forces of ``copies`` (B,) bool (None: only the failed copies)
        for the next solves: their results are ignored, and a copy whose contacts fail (NaN)
        cannot then make the batch Newton fail for the others."""
        ev = self.model.evaluator
        ev.masked = self.dead.copy() if copies is None else (np.asarray(copies, bool) | self.dead)
        self.model.elements.invalidate()

    # -- one batch Newton solve ----------------------------------------------------
    def newton(self, qc):
        m = self.model
        mbs = m.mbs
        el = m.elements
        mbs.systemData.SetODE2Coordinates(m.to_global(qc), configuration=exu.ConfigurationType.Initial)
        cb0, k0 = el.timing["callbacks"], m.evaluator.timing["kernels"] + m.evaluator.timing["scatter"]
        t0 = time.perf_counter()
        solver = exu.MainSolverStatic()
        try:
            ok = solver.SolveSystem(mbs, self.settings)
        except Exception:
            ok = False
        self.stats.solve_s += time.perf_counter() - t0
        self.stats.callback_s += el.timing["callbacks"] - cb0
        self.stats.kernel_s += m.evaluator.timing["kernels"] + m.evaluator.timing["scatter"] - k0
        self.stats.solves += 1
        self.stats.newton_iterations += int(solver.it.newtonStepsCount)
        q = np.array(mbs.systemData.GetODE2Coordinates())[m.ltg]
        return bool(ok), q

    def residuals(self, qc):
        """Per-copy static residual norm [N, N m] over the free coordinates at states (B, 3 nb):
        contact forces + regularization springs + output torque (Eq. (contact_mapping))."""
        m = self.model
        ev = m.elements.evaluate_state(qc, np.zeros_like(qc))
        R = ev.Q.copy()
        B = m.n_copies
        rows = np.arange(B)[:, None]
        off = self.kin[rows, self.spring_idx]
        R[rows, self.spring_idx] -= self.spring_k * self.factor[:, None] * (qc[rows, self.spring_idx] - off)
        R[:, m.output_local] += self.torque
        R = np.where(self.free, R, 0.0)
        out = np.sqrt(np.sum(R * R, axis=1))
        return np.where(ev.finite, out, np.inf)

    def plausible(self, qc):
        """(B,) every body of the copy within the bounds of its kinematic position."""
        dev = np.abs(qc - self.kin)
        bad = np.where(self.is_rot, dev > self.opts["max_rotation"], dev > self.opts["max_translation"])
        return np.all(np.isfinite(qc), axis=1) & ~np.any(bad, axis=1)

    def converged(self, ok, qc):
        """(B,) per-copy convergence of the last batch solve (all, if Exudyn's Newton converged)."""
        if ok:
            return np.all(np.isfinite(qc), axis=1)
        return self.residuals(qc) <= self.abs_tol

    # -- equilibria ---------------------------------------------------------------------
    def solve(self, angle, previous_angle=None, predictor="constant"):
        """Equilibria of all copies at ``angle`` [rad] (scalar or (B,)) with the current torques;
        returns (B, 3 nb). Failed copies (see module docstring) hold NaN rows and are listed in
        ``dead``; ``solved_angles`` holds the angle actually solved per copy (it differs from
        the prescribed one only for a copy solved by the per-variant path off an activation kink).

        predictor: warm start from the previous equilibrium (``previous_angle`` given):
        "constant" keeps each copy's elastic deviation from its kinematic state; "secant"
        extrapolates it linearly in the input angle from the last two accepted solves of a
        sequence (measured on RD-40: 2.0 instead of 3.0 Newton iterations per point).
        """
        if predictor not in ("constant", "secant"):
            from ..errors import RvtoolInputError
            raise RvtoolInputError(f"predictor = {predictor!r}; valid choices are ['constant', 'secant']")
        warm = self.qc is not None and previous_angle is not None
        kin_prev = self.kin if warm else None
        self.set_angle(angle)
        B = self.model.n_copies
        q = self.kin.copy()
        good = np.zeros(B, bool)
        if not warm:
            self._history = []
        if warm:
            dev = self.qc - kin_prev
            h = self._history
            if predictor == "secant" and len(h) == 2 and np.array_equal(h[1][0], np.broadcast_to(previous_angle, (B,))):
                span = h[1][0] - h[0][0]
                ratio = np.divide(self.angles - h[1][0], span, out=np.zeros(B), where=span != 0.0)
                dev = dev + ratio[:, None] * (h[1][1] - h[0][1])
            guess = np.where(self.dead[:, None], self.kin, self.kin + dev)
            ok, qn = self.newton(guess)
            good = self.converged(ok, qn) & self.plausible(qn) & ~self.dead
            q[good] = qn[good]
        q, good = self.complete(q, good, previous_angle)
        self.qc = q
        self._history = (self._history + [(self.angles.copy(), q - self.kin)])[-2:]
        return np.where(self.dead[:, None], np.nan, q)

    def complete(self, q, good, previous_angle):
        """Homotopy and per-variant fallback for the copies not ``good`` (see module docstring)."""
        todo = ~good & ~self.dead
        if np.any(todo):
            self.stats.homotopy_copies += int(todo.sum())
            start = np.where(todo[:, None], self.kin, q)
            alive = todo.copy()
            try:
                for f in self.STIFFENING:
                    # parked (dead) copies stay on stiff springs at their kinematic state
                    self._set_factors(np.where(self.dead, 1e6, np.where(alive, f, 1.0)))
                    ok, qn = self.newton(start)
                    conv = self.converged(ok, qn)
                    alive &= conv
                    start = np.where(alive[:, None], qn, np.where(todo[:, None] | self.dead[:, None], self.kin, q))
            finally:
                self._set_factors(np.where(self.dead, 1e6, 1.0))
            won = alive & self.plausible(start)
            q[won] = start[won]
            good = good | won
        for c in np.flatnonzero(~good & ~self.dead):
            qc = self._per_variant(c, None if previous_angle is None else
                                   float(np.broadcast_to(previous_angle, (len(good),))[c]))
            if qc is None:
                self.dead[c] = True
                self.stats.failed_copies += 1
                self._set_factors(np.where(self.dead, 1e6, 1.0))
                self.park(None)
                q[c] = self.kin[c]
            else:
                q[c] = qc
                good[c] = True
        return q, good

    def _per_variant_model(self, c):
        if c not in self._pv:
            pm = self.model.copy_model(c, self.build_kw)
            idx = np.concatenate([np.asarray(pm.mbs.systemData.GetNodeLTGODE2(n), int) for n in pm.nodes])
            o = self.opts
            self._pv[c] = (pm, StaticSolver(pm, abs_tol=o["abs_tol"], rel_tol=o["rel_tol"],
                                            max_iterations=o["max_iterations"], ramp_steps=o["ramp_steps"],
                                            max_translation=o["max_translation"], max_rotation=o["max_rotation"]), idx)
        return self._pv[c]

    def _per_variant(self, c, previous_angle):
        """Equilibrium of copy c by the per-variant path (StaticSolver ladder); None if it fails."""
        self.stats.fallbacks += 1
        pm, s, idx = self._per_variant_model(c)
        pm.set_output_torque(float(self.torque[c]))
        n = pm.mbs.systemData.ODE2Size()
        if self.qc is not None and previous_angle is not None and not self.dead[c]:
            s.q = np.zeros(n)
            s.q[idx] = self.qc[c]
        else:
            s.q, previous_angle = None, None
        try:
            qv = s.solve(float(self.angles[c]), previous_angle)
        except SolverFailure:
            return None
        self.solved_angles[c] = s.last_angle
        return qv[idx]

    def pin_forces(self, qc):
        """(B,) maximum pin normal force [N] per copy at states (B, 3 nb), zero velocity."""
        m = self.model
        ev = m.elements.evaluation(m.to_global(np.nan_to_num(qc)), np.zeros(m.mbs.systemData.ODE2Size()))
        return m.evaluator.pin_forces(ev.pin_obs).reshape(m.n_copies, -1).max(axis=1)
