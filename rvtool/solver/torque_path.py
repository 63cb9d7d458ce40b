"""Torque paths: a reducer model's loading path at a fixed input angle (issue 29, the torque
sequences of the stiffness, lost-motion and hysteresis protocols written once over any backend).

A torque path is the task ``"torque_path"`` of the backend interface
(:meth:`rvtool.solver.backends.Backend.torque_path`): ``go_to(torque)`` moves the model to the
output torque [N m] (on the output coordinate, as :meth:`ReducerModel.set_output_torque`) from
the equilibrium before it and returns the output angle from its kinematic position [rad];
``state()`` the equilibrium in the model's coordinates; ``stats()`` the solver statistics. The
path keeps its own history (the branch, the committed contact history), so a sequence of levels
is a chain, which is how the free play is crossed.

* :class:`ContinuationPath` -- Exudyn's static solver (:class:`rvtool.solver.continuation.Continuation`),
  the contact history committed once per level (the oracle);
* :class:`rvtool.solver.device_torque_path.DeviceTorquePath` -- the device row Newton
  (:mod:`rvtool.solver.device_rows`), the same increment control.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError

START_SCALES = (1.0, 2.5, 6.0, 15.0)
"""Start torques of a loaded start as multiples of the level, tried in turn: a loaded start by
Newton and load ramps can fail at a small torque inside the free play (measured on Monte Carlo
variants of RD-40 at 3 % of T_rated) and succeed at a larger one, from where the path comes down
to the level (:func:`rvtool.protocols.lost_motion.lost_motion`, the device torque paths)."""


@dataclass(frozen=True, kw_only=True)
class ContinuationSettings:
    """The increment control of :class:`rvtool.solver.continuation.Continuation` (its defaults):
    max_step [m or rad]: largest accepted coordinate change per increment; min_increment [N m]:
    smallest torque increment before the copy fails; max_rounds: device solves after which the
    copies still running fail (a bound the sequential path does not need: it bounds the batch's
    wall time by its slowest copy; 400 rounds allow every level of the 7 to halve 14 times down
    to 1e-4 N m from 1.4 N m and climb back twice)."""
    max_step: float = 2e-3
    min_increment: float = 1e-4
    max_rounds: int = 400

    def __post_init__(self):
        for nm in ("max_step", "min_increment"):
            v = getattr(self, nm)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise RvtoolInputError(f"lost_motion.{nm} = {v!r} is outside the valid range (0, inf)")
        if not (isinstance(self.max_rounds, (int, np.integer)) and self.max_rounds >= 1):
            raise RvtoolInputError(f"lost_motion.max_rounds = {self.max_rounds!r} is outside the valid range "
                                   f"[1, inf) (integer)")


def stateful_reasons(model):
    """Every named reason why a torque path may leave state in ``model`` that a later path on it
    would start from (empty: none). The contact sets the replica copies with history-free laws
    (:func:`rvtool.solver.replica.replica_reasons` empty: planar rigid bodies, no stick--slip
    anchors, no elastic pin or crank closures with their warm-started inner deflections, no port
    bodies) make a model whose residual is a function of the state, the output torque and the
    input angle only; a path sets both anew at its start (:class:`Continuation` from the kinematic
    state, the device copies from the model's parameters), so a second path on the model is the
    path on a fresh build (tests/test_torque_path.py holds it bit for bit on RD-40, RV-40E, the standard involute and the three-stage RV)."""
    from .replica import replica_reasons
    return replica_reasons(model)


class TorquePath:
    """The interface of a torque path (module docstring)."""

    def go_to(self, torque):
        """Output angle from the kinematic position [rad] at the equilibrium under ``torque`` [N m]."""
        raise NotImplementedError

    def state(self):
        """The last equilibrium in the model's coordinates (n,)."""
        raise NotImplementedError

    def stats(self):
        """Solver statistics (backend-specific keys; ``rejected_steps`` etc. where it has them)."""
        raise NotImplementedError


class ContinuationPath(TorquePath):
    """Loading path of a :class:`~rvtool.model.ReducerModel` at a fixed input angle: equilibria by
    :class:`rvtool.solver.continuation.Continuation`, the contact history committed once per level;
    ``go_to(torque)`` returns the output angle [rad] from its kinematic position. The continuation
    starts at ``initial_torque`` [N m], by default (None) at the first torque asked for (a loaded
    start is regular where free play leaves the zero-load state ill-posed: measured on rv80e
    variants, whose start at zero torque failed). ``continuation``: the Continuation (None before
    the first level)."""

    def __init__(self, model, *, input_angle=0.0, initial_torque=None):
        self.model = model
        self.input_angle = input_angle
        self.initial_torque = initial_torque
        self.continuation = None
        self._i_out = model.output_index
        self._th_kin = model.kinematic_output(input_angle)

    def go_to(self, torque):
        if self.continuation is None:
            from .continuation import Continuation
            start = float(torque) if self.initial_torque is None else float(self.initial_torque)
            self.continuation = Continuation(self.model, input_angle=self.input_angle, initial_torque=start)
        return float(self.continuation.go_to(float(torque))[self._i_out] - self._th_kin)

    def state(self):
        if self.continuation is None:
            raise RvtoolInputError("the torque path has no state before its first go_to(torque)")
        return self.continuation.q

    def stats(self):
        return {} if self.continuation is None else self.continuation.stats.to_dict()


__all__ = ["ContinuationPath", "ContinuationSettings", "START_SCALES", "TorquePath", "stateful_reasons"]
