"""Accepted-step driver around Exudyn's implicit generalized-alpha solver.

Ownership of state follows Fig. (accepted_state):

* trial evaluations (every residual and Jacobian callback of every Newton
  iteration and retry) read only the committed contact history z_n;
* an attempt is accepted by Exudyn's Newton convergence plus the gate in the
  post-Newton hook (finite state and forces, optional strict residual bound
  of Eq. (acceptance), injected test rejections); a rejected attempt restores
  the start-of-step state (Exudyn) and, because nothing was committed, all
  history; the step is retried with a smaller increment down to ``min_step``;
* after acceptance the post-step hook evaluates each contact set once at the
  accepted evaluation state from z_n and commits z_{n+1}; observers then
  consume that snapshot with the accepted duration dt_acc, so the physical
  clock and all exposure advance only by accepted steps.

Exudyn's generalized-alpha is the Arnold--Bruels form: the equations of
motion are enforced at the step end, so the accepted evaluation state is
(q_{n+1}, v_{n+1}); the algorithmic accelerations carry the alpha weighting.
"""
import os
import time
from dataclasses import dataclass, field

import numpy as np
import exudyn as exu

from ..errors import SolverFailure
from ..observe.registry import AcceptedStep, ObserverRegistry
from .run_spec import DENSE_MAX_COORDINATES, RunSpec


@dataclass
class RunRecord:
    """Step statistics of a finished run."""
    accepted_steps: int = 0
    attempts: int = 0
    rejected_steps: int = 0
    newton_iterations: int = 0
    jacobian_updates: int = 0
    min_step_s: float = np.inf
    max_step_s: float = 0.0
    max_residual: float = 0.0
    end_time: float = 0.0
    wall_s: float = 0.0
    cpu_s: float = 0.0      # this process's CPU time in SolveSystem [s] (one core: the machine's load does not count)
    reject_reasons: dict = field(default_factory=dict)
    times: list = field(default_factory=list)
    energy: dict | None = None  # EnergyAccount.results() when the run kept an energy account

    def to_dict(self):
        d = dict(self.__dict__)
        d.pop("times")
        d["min_step_s"] = None if not np.isfinite(self.min_step_s) else self.min_step_s
        return d


def simulation_settings(spec: RunSpec, n_coordinates):
    """Exudyn ``SimulationSettings`` of :func:`simulate` for ``spec`` on a system of ``n_coordinates``
    ODE2 coordinates (benchmarks time the bare Exudyn step with exactly these)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return _settings(spec, n_coordinates)


def _settings(spec: RunSpec, n_coordinates):
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.endTime = spec.end_time
    ti.numberOfSteps = int(np.ceil(spec.end_time / spec.step - 1e-9))
    ti.generalizedAlpha.spectralRadius = spec.spectral_radius
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.useModifiedNewton = spec.newton_mode != "full"
    ti.newton.modifiedNewtonJacUpdatePerStep = spec.newton_mode == "per_step"
    ti.newton.maxIterations = spec.max_newton_iterations
    ti.newton.absoluteTolerance = spec.abs_tol
    ti.newton.relativeTolerance = spec.rel_tol
    ti.adaptiveStep = spec.adaptive
    ti.minimumStepSize = spec.minimum_step
    ti.verboseMode = 0
    # the post-Newton hook is the acceptance gate: one pass, a non-zero error rejects
    ti.discontinuous.maxIterations = 1
    ti.discontinuous.ignoreMaxIterations = False
    ti.discontinuous.iterationTolerance = 0.5
    dense = spec.linear_solver == "dense" or (spec.linear_solver == "auto" and n_coordinates <= DENSE_MAX_COORDINATES)
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense if dense else exu.LinearSolverType.EigenSparse
    ss.parallel.numberOfThreads = 1       # Exudyn's default, stated: one thread (benchmarks compare one core)
    ss.solutionSettings.writeSolutionToFile = False
    ss.solutionSettings.sensorsWritePeriod = 1e30
    ss.displayStatistics = False
    ss.displayComputationTime = False
    return ss


def simulate(mbs, spec: RunSpec, elements=(), observers: ObserverRegistry | None = None, *,
             rotational=None, out_dir=None, reject_attempts=(), before_accept=None, energy=None):
    """Run ``mbs`` (assembled, or assembled here) over ``spec.end_time``.

    elements: contact elements (:class:`exudyn_user_elements.ContactElement`).
    observers: registry receiving one :class:`AcceptedStep` per accepted step.
    rotational: boolean mask over ODE2 coordinates for the W scaling.
    out_dir: where the last accepted state is saved if the run fails.
    reject_attempts: attempt numbers (1-based) to reject by force (tests).
    energy: an :class:`rvtool.observe.energy.EnergyAccount` of ``mbs`` and
    ``elements``, sampled at t_0 and at every accepted state after its history
    commit; its balance is returned in ``RunRecord.energy``. None (default):
    nothing is sampled.
    Returns a :class:`RunRecord`; raises :class:`SolverFailure` on failure.
    """
    import warnings
    try:
        n_coordinates = mbs.systemData.ODE2Size()
    except Exception:
        mbs.Assemble()
        n_coordinates = mbs.systemData.ODE2Size()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ss = _settings(spec, n_coordinates)
    solver = exu.MainSolverImplicitSecondOrder()
    rec = RunRecord()
    reject_attempts = set(reject_attempts)
    state = {"t_prev": 0.0, "q_prev": None, "last_reason": None}

    def weighted_residual():
        r = np.asarray(solver.GetSystemResidual(), dtype=float)
        if spec.reference_length is not None and rotational is not None:
            r = np.where(rotational, r / spec.reference_length, r)
        return float(np.linalg.norm(r))

    def reject(reason):
        rec.reject_reasons[reason] = rec.reject_reasons.get(reason, 0) + 1
        state["last_reason"] = reason
        state["open"] = False

    def close_failed_attempt():
        # an attempt that reached neither the gate nor acceptance failed inside Newton
        if state.get("open"):
            reject("non-finite contact force in a trial evaluation" if any(e.nonfinite for e in elements)
                   else "Newton did not converge")

    # one contact element per system (exudyn_user_elements.merged_element): the hosts set the
    # per-attempt controls in the pre-step hook and the accepted step is committed in the
    # post-Newton hook, so an accepted step crosses into Python for the hooks twice, not three times
    hosts = [h for h in (getattr(e, "host", None) for e in elements) if h is not None]
    hosts = list({id(h): h for h in hosts + list(mbs.variables.get("rvtool.contact_hosts", ()))}.values())
    merged = bool(elements) and all(getattr(e, "host", None) is not None for e in elements)

    def pre_step(mbs_, t):
        close_failed_attempt()
        rec.attempts += 1
        state["open"] = True
        for e in elements:
            e.nonfinite = False
        for h in hosts:
            h.begin_attempt(t)
        return True

    def post_newton(mbs_, t):
        reason = None
        q = mbs_.systemData.GetODE2Coordinates()
        v = mbs_.systemData.GetODE2Coordinates_t()
        if any(e.nonfinite for e in elements):
            reason = "non-finite contact force in a trial evaluation"
        elif not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
            reason = "non-finite state"
        elif rec.attempts in reject_attempts:
            reason = "forced rejection (test)"
        else:
            res = weighted_residual()
            if not np.isfinite(res):
                reason = "non-finite residual"
            elif spec.strict_abs_tol is not None and res > spec.strict_abs_tol:
                reason = f"residual {res:.3e} above strict_abs_tol"
            else:
                state["residual"] = res
        if reason is not None:
            reject(reason)
            return [1.0, -1.0]
        if merged:
            accept(t, np.array(q), np.array(v))
        return [0.0, -1.0]

    def post_step(mbs_, t):
        if not state.get("started"):
            # Exudyn's initial FinishStep (t = t_0) is not an accepted step
            state["started"] = True
            if energy is not None:
                energy.start(t, mbs_.systemData.GetODE2Coordinates(), mbs_.systemData.GetODE2Coordinates_t())
            return True
        if merged:
            return True     # committed in the post-Newton hook
        accept(t, np.array(mbs_.systemData.GetODE2Coordinates()), np.array(mbs_.systemData.GetODE2Coordinates_t()))
        return True

    def accept(t, q, v):
        """The accepted step ending at t with state (q, v): history commit, observers, statistics."""
        state["open"] = False
        dt = t - state["t_prev"]
        if merged and observers is None:
            for e in elements:
                e.commit(q, v, t, snapshot=False)   # no observer: history only, no snapshot
            snaps = None
        else:
            snaps = {e.name: e.commit(q, v, t) for e in elements}
        if energy is not None:
            energy.accept(t, q, v)
        if observers is not None:
            observers.on_accepted(AcceptedStep(index=rec.accepted_steps, t_start=state["t_prev"], dt=dt,
                                               q_start=state["q_prev"], q_end=q, snapshots=snaps))
        rec.accepted_steps += 1
        rec.newton_iterations += solver.it.newtonSteps
        rec.min_step_s = min(rec.min_step_s, dt)
        rec.max_step_s = max(rec.max_step_s, dt)
        rec.max_residual = max(rec.max_residual, state.get("residual", 0.0))
        rec.times.append(t)
        state["t_prev"], state["q_prev"] = t, q
        state["v_prev"] = v
        if before_accept is not None:
            before_accept(t, q, v)

    mbs.SetPreStepUserFunction(pre_step)
    mbs.SetPostNewtonUserFunction(post_newton)
    # merged: the post-step hook only samples the energy account's initial state
    mbs.SetPostStepUserFunction(post_step if not merged or energy is not None else 0)
    for h in hosts:
        h.set_controls(0.0)
    state["q_prev"] = np.array(mbs.systemData.GetODE2Coordinates())
    state["v_prev"] = np.array(mbs.systemData.GetODE2Coordinates_t())
    t0, c0 = time.perf_counter(), time.process_time()
    error = None
    try:
        ok = solver.SolveSystem(mbs, ss)
    except Exception as exc:  # a failing user function ends the run: report it with the saved state
        ok, error = False, exc
    rec.wall_s = time.perf_counter() - t0
    rec.cpu_s = time.process_time() - c0
    # the hooks commit accepted steps (and, merged, set the hosts' controls): left installed, they
    # would fire in later static solves of the same system (history commits at Newton states, a
    # driven input angle over the static one), in either layout
    mbs.SetPreStepUserFunction(0)
    mbs.SetPostNewtonUserFunction(0)
    mbs.SetPostStepUserFunction(0)
    close_failed_attempt()
    rec.rejected_steps = rec.attempts - rec.accepted_steps
    rec.end_time = state["t_prev"]
    rec.jacobian_updates = int(solver.it.newtonJacobiCount)
    if not ok or rec.end_time < spec.end_time * (1 - 1e-9) - 1e-12:
        path = _save_state(out_dir, state, elements, rec, spec)
        msg = (f"solver failed at t = {rec.end_time:.6g} s of {spec.end_time:.6g} s after {rec.accepted_steps} accepted "
               f"and {rec.rejected_steps} rejected steps; last rejection: {state['last_reason'] or 'Newton did not converge'}; "
               f"minimum step {spec.minimum_step:.3g} s reached or retries exhausted")
        if error is not None:
            msg += f"; exception: {error}"
        raise SolverFailure(msg, path)
    if energy is not None:
        rec.energy = energy.results()
    return rec


def _save_state(out_dir, state, elements, rec, spec):
    if out_dir is None:
        return None
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "failed_state.npz")
    arrays = {"t": rec.end_time, "q": state["q_prev"], "v": state.get("v_prev")}
    for e in elements:
        for k, v in e.history_state().items():
            arrays[f"{e.name}.{k}"] = v
    tmp = path + ".tmp.npz"
    np.savez(tmp, **{k: np.asarray(v) for k, v in arrays.items() if v is not None})
    os.replace(tmp, path)
    return path
