"""Load continuation: equilibria at a fixed input angle under a changing output torque.

Each level is reached from the previous equilibrium by warm-started Newton solves; the
torque increment is halved when Newton fails or jumps (a step larger than ``max_step``
is rejected: in the backlash at zero load Newton can land in a far, spurious
equilibrium). Contact history (friction anchors) is committed once per converged level.
Where the increments stall (free play whose only stiffness is the weak regularization: the
tangent is nearly singular there and every nonzero increment is carried by the near-null
directions), a model declaring ``guided_free_play`` reaches the level by the guide-spring
homotopy from the previous equilibrium
(:mod:`rvtool.solver.guide`; counted in ``guided_levels``, the last guide force in
``guide_force_max``); the accepted state carries no guide force.
"""
import time

import numpy as np

from ..errors import SolverFailure
from .guide import guided_newton
from .static import StaticSolver
from .stats import SolverStats


class Continuation:
    """Equilibria of ``model`` at fixed input angle under a changing output torque.

    max_step: largest accepted coordinate change per increment [m or rad] (a larger
    Newton step is treated as a failure and the increment halved).
    min_increment: smallest torque increment [N m] before :class:`SolverFailure`.
    initial_torque: output torque [N m] of the first equilibrium (found by a load ramp).
    abs_tol [N], rel_tol [-]: the static solver's Newton tolerances (:class:`StaticSolver`'s
    defaults; a tighter abs_tol converges each level further, e.g. to compare with another solver
    at equal tolerance).
    """

    def __init__(self, model, *, input_angle=0.0, max_step=2e-3, min_increment=1e-4, initial_torque=0.0,
                 abs_tol=1e-6, rel_tol=1e-9):
        self.model = model
        self.static = StaticSolver(model, abs_tol=abs_tol, rel_tol=rel_tol)
        self.input_angle = input_angle
        self.max_step = max_step
        self.min_increment = min_increment
        self.stats = SolverStats()
        self.restarts = bool(getattr(model, "continuation_restarts", False))
        self.guided_free_play = bool(getattr(model, "guided_free_play", False))
        self.guide_force_max = 0.0    # largest guide force [N or N m] at a last guided stage (before release)
        model.set_input_angle(input_angle)
        # a loaded start is regular even where free play leaves the zero-load state ill-posed
        model.set_output_torque(float(initial_torque))
        self.torque = float(initial_torque)
        self.q = self._start()

    def _start(self):
        """First equilibrium: Newton from the kinematic state, else the static solver's load
        ramps; both only accept states within its plausibility bounds (a full Newton step at
        load can land in a far, periodic copy of the output-pin engagement)."""
        s = self.static
        ok, q = s.newton(s.kinematic_vector(self.input_angle), ramp=False)
        if ok and s.plausible(q, self.input_angle):
            return q
        try:
            return s.solve(self.input_angle)
        except SolverFailure:
            raise SolverFailure(f"no equilibrium at input angle {self.input_angle:.6g} rad and output torque "
                                f"{self.torque:.6g} N m") from None

    def _try(self, torque):
        self.model.set_output_torque(torque)
        it0 = self.static.stats.newton_iterations
        ok, q = self.static.newton(self.q, ramp=False)
        self.stats.newton_iterations += self.static.stats.newton_iterations - it0
        self.stats.solves += 1
        return ok and np.max(np.abs(q - self.q)) <= self.max_step, q

    def go_to(self, torque):
        """Continue to output torque [N m]; returns the equilibrium q."""
        t0 = time.perf_counter()
        t_now = self.torque
        inc = torque - t_now
        while t_now != torque:
            target = torque if abs(torque - t_now) <= abs(inc) else t_now + inc
            ok, q = self._try(target)
            if ok:
                self.q, t_now = q, target
                inc *= 2 if abs(inc) < abs(torque - t_now) else 1
            else:
                self.stats.rejected_steps += 1
                inc *= 0.5
                if abs(inc) < self.min_increment:
                    # a model declaring restarts keeps its restart first (its figures are unchanged)
                    restarted = self._restart(t_now, torque) if self.restarts else None
                    if restarted is None and self.guided_free_play:
                        restarted = self.guided(t_now, torque)
                    if restarted is None:
                        self.model.set_output_torque(t_now)
                        raise SolverFailure(f"torque continuation stalled between {t_now:.6g} and {torque:.6g} N m: "
                                            f"increment {abs(inc):.3g} N m below min_increment = {self.min_increment:g}"
                                            + ("; the restarts from the kinematic state failed too" if self.restarts else "")
                                            + ("; the guide-spring homotopy from the last equilibrium failed too"
                                               if self.guided_free_play else ""))
                    self.q, t_now = restarted
                    inc = torque - t_now
        self.torque = torque
        self._commit()
        self.stats.levels += 1
        self.stats.wall_s += time.perf_counter() - t0
        return self.q

    def guided(self, t_now, torque):
        """(q, level) of a level between ``t_now`` and ``torque`` [N m] (fractions
        :data:`RESTART_FRACTIONS` of the step, tried in turn) by the guide-spring homotopy from
        the current equilibrium (:func:`rvtool.solver.guide.guided_newton`), or None. Unlike
        :meth:`_restart` it starts from the previous equilibrium: the committed contact history
        and the branch are kept. The level must pass the static solver's plausibility bounds."""
        def newton(q0):
            it0 = self.static.stats.newton_iterations
            ok, q = self.static.newton(q0, ramp=False)
            self.stats.newton_iterations += self.static.stats.newton_iterations - it0
            self.stats.solves += 1
            return ok, q

        for f in self.RESTART_FRACTIONS:
            target = t_now + f * (torque - t_now)
            self.model.set_output_torque(target)
            ok, q, rep = guided_newton(self.model, newton, self.q)
            if ok and self.static.plausible(q, self.input_angle):
                self.stats.guided_levels += 1
                self.guide_force_max = max(self.guide_force_max, rep["guide_force_last"])
                return q, target
        return None

    RESTART_FRACTIONS = (1.0, 0.5, 0.1)
    """Targets of a restart as fractions of the remaining torque step, tried in turn."""

    def _restart(self, t_now, torque):
        """(q, level) of a level between ``t_now`` and ``torque`` [N m] (fractions
        :data:`RESTART_FRACTIONS` of the step, tried in turn) solved afresh by the static solver's
        ladder (homotopy in the regularization stiffness from the kinematic state, then load
        ramps), or None; only for models that declare ``continuation_restarts`` (existing models
        keep their behaviour). Used only where the increments have stalled: in free play whose
        only stiffness is the weak regularization (a mesh with backlash and a force law without
        stiffness at zero approach, e.g. an involute mesh), Newton from the previous equilibrium
        cycles between contact states at any increment, while the homotopy reaches a loaded level
        (a smaller one where the full level is too far from the kinematic state); the continuation
        goes on from there. A frictionless model's level is path-independent; a model with history
        gets the state of a fresh loading, so the restart is counted (``ramped_restarts``)."""
        for f in self.RESTART_FRACTIONS:
            target = t_now + f * (torque - t_now)
            self.model.set_output_torque(target)
            try:
                q = self.static.solve(self.input_angle)
            except SolverFailure:
                continue
            self.stats.ramped_restarts += 1
            return q, target
        return None

    def _commit(self):
        """Commit the contact history (friction anchors) at the converged level."""
        self.model.commit_contacts(self.q)
