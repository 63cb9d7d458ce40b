"""Quasi-static equilibria of an involute gear pair (:class:`rvtool.assembly.gear_pair.GearPairModel`)
with Exudyn's static solver: the pair's own small solver (two bodies, dense tangent), kept
beside :class:`rvtool.solver.static.StaticSolver` because the pair is not a ReducerModel."""
import numpy as np
import exudyn as exu

from ..assembly.gear_pair import GearPairModel
from ..errors import SolverFailure
from .static import static_settings


class GearPairStatics:
    """Warm-started static equilibria of a :class:`GearPairModel` (Exudyn's static solver with the
    contact element's analytic tangent). abs_tol [N], rel_tol [-]: Newton tolerances."""

    def __init__(self, model: GearPairModel, *, abs_tol=1e-8, rel_tol=1e-12, max_iterations=40):
        self.model = model
        self.settings = static_settings(abs_tol=abs_tol, rel_tol=rel_tol, max_iterations=max_iterations,
                                        solver_type=exu.LinearSolverType.EXUdense)
        self.newton_iterations = 0
        model.contact_set.set_velocity_tangent(False)

    def solve(self, theta_a, theta_b_guess):
        """Equilibrium at input angle theta_a from the guess of gear B's angle; returns theta_B.
        A failed Newton solve is retried from :meth:`GearPairModel.loaded_guess` at the current
        load, then with Exudyn's load ramp. Raises :class:`SolverFailure` naming the angle."""
        m = self.model
        m.set_input_angle(theta_a)
        torque = float(m.mbs.GetLoadParameter(m.load, "load"))
        line_load = -torque / (m.pair.eps * m.pair.gear_a.face_width * m.pair.gear_b.base_radius)
        for guess, ramp in ((theta_b_guess, False), (m.loaded_guess(theta_a, line_load), False),
                            (m.loaded_guess(theta_a, line_load), True)):
            q0 = m.state_vector(theta_a, guess) - m.state_vector(0.0, m.phase)
            st = self.settings.staticSolver
            st.useLoadFactor = ramp
            st.numberOfLoadSteps = 20 if ramp else 1
            st.adaptiveStep = ramp
            m.mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
            solver = exu.MainSolverStatic()
            try:
                ok = solver.SolveSystem(m.mbs, self.settings)
            except Exception:  # Exudyn raises on a singular tangent: the next start is tried
                ok = False
            self.newton_iterations += int(solver.it.newtonStepsCount)
            q = np.array(m.mbs.systemData.GetODE2Coordinates())
            if ok and np.all(np.isfinite(q)):
                return m.angles(q)[1] + m.phase
        raise SolverFailure(f"no static equilibrium of the gear pair at theta_A = {theta_a:.9g} rad")

    def observations(self, theta_a, theta_b):
        """The contact set's per-row observations at the given angles (bodies at rest)."""
        m = self.model
        return m.contact_set.evaluate(m.pose(theta_a, theta_b), np.zeros((2, 3))).obs
