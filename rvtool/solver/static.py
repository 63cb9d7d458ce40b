"""Quasi-static equilibria of an assembled model with Exudyn's static solver.

Each equilibrium is a Newton solve of the static residual (contact forces,
loads, constraints) at prescribed controls, warm-started from the previous
equilibrium shifted by the kinematic increment; loads are applied in full
(no load factor). If a warm start fails, the point is re-solved from the
previous equilibrium in angle sub-steps, then from the kinematic state by a homotopy in the regularization stiffness (stiff springs
first, then the model's own), then with the load ramped over ``ramp_steps``
steps, and last (models declaring ``guided_free_play``, or a solver built with
``guided_fallback=True``) by the guide-spring homotopy from the
kinematic state (:mod:`rvtool.solver.guide`: finer factor steps, bisected on failure; reached
only where everything before failed, so no point that solved before changes). A point that still fails raises :class:`SolverFailure` naming the
control values.
"""
import time
import warnings

import numpy as np
import exudyn as exu

from ..errors import SolverFailure
from .guide import guided_newton
from .stats import SolverStats


def static_settings(*, abs_tol, rel_tol, max_iterations, solver_type):
    """Exudyn settings of the static solver: Newton tolerances abs_tol [N] and rel_tol [-],
    iteration limit, linear solver, quiet and without a solution file."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ss = exu.SimulationSettings()
        ss.solutionSettings.writeSolutionToFile = False
    st = ss.staticSolver
    st.newton.absoluteTolerance = abs_tol
    st.newton.relativeTolerance = rel_tol
    st.newton.maxIterations = max_iterations
    st.verboseMode = 0
    ss.linearSolver.solverType = solver_type
    return ss


class StaticSolver:
    """Warm-started static solves of a :class:`~rvtool.model.ReducerModel` with its fallback ladder.

    abs_tol [N], rel_tol [-]: Newton tolerances on Exudyn's residual norm.
    max_translation [m], max_rotation [rad]: plausibility bounds of the elastic deviation of
    every body from its kinematic position (contact deformations are micrometres and
    arcminutes; a larger deviation is a spurious Newton solution).
    guided_fallback: run the guide-spring homotopy as the last fallback (default: the model's
    ``guided_free_play``).
    """

    def __init__(self, model, *, abs_tol=1e-6, rel_tol=1e-9, max_iterations=30, ramp_steps=20,
                 max_translation=5e-4, max_rotation=2e-2, guided_fallback=None):
        self.model = model
        #: the guide-spring homotopy as the last fallback: the model's ``guided_free_play`` unless set
        #: (a caller that only asks *whether* a state exists, such as the rated-state admissibility
        #: check, sets True; the protocols keep the model's choice, so their paths do not change)
        self.guided_fallback = (bool(getattr(model, "guided_free_play", False)) if guided_fallback is None
                                else bool(guided_fallback))
        self.max_translation = max_translation
        self.max_rotation = max_rotation
        self.stats = SolverStats()
        self.ramp_steps = ramp_steps
        n = model.mbs.systemData.ODE2Size()
        ss = static_settings(abs_tol=abs_tol, rel_tol=rel_tol, max_iterations=max_iterations,
                             solver_type=exu.LinearSolverType.EXUdense if n <= 30 else exu.LinearSolverType.EigenSparse)
        self.settings = ss
        self.q = None
        self.last_angle = None

    def newton(self, q_init, ramp=False):
        """One Newton solve from q_init (ramp: with Exudyn's load factor over ``ramp_steps``); (ok, q)."""
        mbs = self.model.mbs
        st = self.settings.staticSolver
        st.useLoadFactor = ramp
        st.numberOfLoadSteps = self.ramp_steps if ramp else 1
        st.adaptiveStep = ramp   # without a load factor a retry repeats the same Newton from the same start
        mbs.systemData.SetODE2Coordinates(q_init, configuration=exu.ConfigurationType.Initial)
        solver = exu.MainSolverStatic()
        try:
            ok = solver.SolveSystem(mbs, self.settings)
        except Exception:
            ok = False
        self.stats.newton_iterations += int(solver.it.newtonStepsCount)
        q = np.array(mbs.systemData.GetODE2Coordinates())
        return ok and np.all(np.isfinite(q)), q

    SHIFTS = (1e-7, -1e-7, 1e-6, -1e-6, 1e-5, -1e-5)

    def _shifted(self, previous_angle, input_angle):
        """Warm-started solves at input angles shifted by each of ``SHIFTS`` [rad]. Without a line
        search, Newton can cycle when the equilibrium lies on a contact activation kink (measured:
        RD-40 single wheel, a band of about +-1e-7 rad of input angle); a shifted point is an exact
        equilibrium at its own (recorded) angle, and a 1e-5 rad input shift moves the output-angle
        sample by 2.6e-7 rad / 39, far below the sampling step."""
        for da in self.SHIFTS:
            a = input_angle + da
            self.model.set_input_angle(a)
            ok, q = self.newton(self.q + self.kinematic_vector(a) - self.kinematic_vector(previous_angle), ramp=False)
            if ok and self.plausible(q, a):
                self.stats.shifted_points += 1
                return True, q, a
        self.model.set_input_angle(input_angle)
        return False, None, input_angle

    SUBSTEPS = (2, 8)

    def _substeps(self, previous_angle, input_angle):
        """Continuation in the input angle: reach ``input_angle`` from the last equilibrium in n
        warm-started sub-steps (each n of ``SUBSTEPS``). Newton can cycle at a contact activation
        kink (a rolling element or a pin entering) from one starting point and converge from a
        nearby one; the sub-step states are intermediate and not recorded."""
        for n in self.SUBSTEPS:
            q, a_prev, ok = self.q, previous_angle, True
            for a in previous_angle + (input_angle - previous_angle) * np.arange(1, n + 1) / n:
                self.model.set_input_angle(a)
                ok, q = self.newton(q + self.kinematic_vector(a) - self.kinematic_vector(a_prev), ramp=False)
                ok = ok and self.plausible(q, a)
                a_prev = a
                if not ok:
                    break
            if ok:
                self.stats.substep_restarts += 1
                return True, q
        self.model.set_input_angle(input_angle)
        return False, None

    STIFFENING = (1e6, 1e4, 1e2, 1.0)

    def stiffened_start(self, input_angle):
        """Homotopy in the regularization stiffness: solve from the kinematic state with the
        springs stiffened by each factor of ``STIFFENING`` in turn, warm-starting each solve
        from the last. Free play (clearances, output-pin backlash) leaves the kinematic state
        with almost no stiffness in some directions, where a full Newton step under load jumps
        to a far, periodic copy of the engagement; stiff springs keep the first steps local and
        the final solve (factor 1) is the unmodified problem."""
        springs = self.model.reg_springs
        if not springs:
            return False, None
        mbs = self.model.mbs
        q = self.kinematic_vector(input_angle)
        ok = False
        try:
            for f in self.STIFFENING:
                for _, _, k, obj in springs:
                    mbs.SetObjectParameter(obj, "stiffness", k * f)
                ok, q = self.newton(q, ramp=False)
                if not ok:
                    break
        finally:
            for _, _, k, obj in springs:
                mbs.SetObjectParameter(obj, "stiffness", k)
        return ok and self.plausible(q, input_angle), q

    def plausible(self, q, input_angle):
        """Every body within the plausibility bounds of its kinematic position."""
        if not np.all(np.isfinite(q)):
            return False
        dev = q - self.kinematic_vector(input_angle)
        m = self.model
        for node in m.nodes:
            ltg = np.asarray(m.mbs.systemData.GetNodeLTGODE2(node))
            if np.any(np.abs(dev[ltg[:2]]) > self.max_translation) or abs(dev[ltg[2]]) > self.max_rotation:
                return False
        return True

    def kinematic_vector(self, input_angle):
        """Kinematic state as displacement coordinates of the system's ODE2 vector."""
        m = self.model
        return m.body_vector(m.kinematic_state(input_angle).poses - m.reference)

    def solve(self, input_angle, previous_angle=None):
        """Equilibrium at ``input_angle`` with the model's current loads; returns q. The angle
        actually solved is ``self.last_angle`` (it differs from ``input_angle`` only for a point
        shifted off an activation kink, see :meth:`_shifted`)."""
        t0 = time.perf_counter()
        self.model.set_input_angle(input_angle)
        ok = False
        used = input_angle
        if self.q is not None and previous_angle is not None:
            guess = self.q + self.kinematic_vector(input_angle) - self.kinematic_vector(previous_angle)
            ok, q = self.newton(guess, ramp=False)
            ok = ok and self.plausible(q, input_angle)
            if not ok:
                ok, q = self._substeps(previous_angle, input_angle)
            if not ok:
                ok, q, used = self._shifted(previous_angle, input_angle)
        if not ok:
            if self.q is not None and previous_angle is not None:
                self.stats.ramped_restarts += 1
            ok, q = self.stiffened_start(input_angle)
        if not ok:
            ok, q = self.newton(self.kinematic_vector(input_angle), ramp=True)
            ok = ok and self.plausible(q, input_angle)
        if not ok:
            self.stats.ramped_restarts += 1
            steps = self.ramp_steps
            self.ramp_steps = 5 * steps
            try:
                ok, q = self.newton(self.kinematic_vector(input_angle), ramp=True)
            finally:
                self.ramp_steps = steps
            ok = ok and self.plausible(q, input_angle)
        if not ok and self.guided_fallback:
            # free play without contact stiffness (rv40e's needle clearance and backlash at zero load):
            # the coarse stiffening ladder and the load ramps jump; the guides release in decades
            ok, q, _ = guided_newton(self.model, lambda q0: self.newton(q0, ramp=False),
                                     self.kinematic_vector(input_angle))
            ok = ok and self.plausible(q, input_angle)
            self.stats.guided_levels += int(ok)
        self.stats.wall_s += time.perf_counter() - t0
        if not ok:
            raise SolverFailure(f"no plausible static equilibrium at input angle {input_angle:.6g} rad (warm start, "
                                f"a {self.ramp_steps}-step and a {5 * self.ramp_steps}-step load ramp failed or left a "
                                f"body more than {self.max_translation} m / {self.max_rotation} rad off its kinematic position; "
                                f"angle sub-steps and shifts of up to 1e-5 rad"
                                + (" and the guide-spring homotopy" if self.guided_fallback else "") + " failed too)")
        self.stats.points += 1
        self.q = q
        self.last_angle = used
        return q
