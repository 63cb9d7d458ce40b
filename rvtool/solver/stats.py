"""One statistics type for every static solver (equilibrium ladder, load continuation,
spring-controlled march, batched copies)."""
from dataclasses import dataclass


@dataclass
class SolverStats:
    """Counters of a solver's work.

    points: equilibria returned at prescribed input angles; levels: load levels reached;
    solves: Newton solves started; newton_iterations: Newton iterations (Exudyn's count);
    rejected_steps: load or target increments rejected and halved; ramped_restarts: points
    re-solved from the kinematic state (homotopy, load ramps); substep_restarts: points
    reached by angle sub-steps; shifted_points: points shifted off an activation kink;
    guided_levels: load levels (static points) reached by the guide-spring homotopy from the previous
    equilibrium (:meth:`rvtool.solver.continuation.Continuation.guided`); wall_s: wall time [s].
    """
    points: int = 0
    levels: int = 0
    solves: int = 0
    newton_iterations: int = 0
    rejected_steps: int = 0
    ramped_restarts: int = 0
    substep_restarts: int = 0
    shifted_points: int = 0
    guided_levels: int = 0
    wall_s: float = 0.0

    def to_dict(self):
        return dict(self.__dict__)
