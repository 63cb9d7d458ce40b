"""The one interface of the solver backends (issue 29): what a protocol hands a backend and what
it gets back, and how a backend says whether it can run a model.

A protocol (:mod:`rvtool.protocols.precision`) is written once against this interface; a
backend only knows states and residuals:

* :meth:`Backend.supports` ``(model, task, run=None) -> Support(ok, reasons)``: whether the backend can run
  ``task`` ("equilibria" or "dynamic") on the built :class:`~rvtool.model.ReducerModel`, and if
  not, every named reason (bodies, contact families, laws, options);
* :meth:`Backend.solve_equilibria` ``(model, EquilibriumBatch) -> Equilibria``: the static
  equilibria at a batch of drive/load states (input angles under one output torque);
* :meth:`Backend.step_dynamic` ``(model, DrivenRun) -> DrivenHistory``: a driven run (prescribed
  input speed, constant output torque) stepped to its end, the accepted steps committed to the
  returned histories (the backend owns the stepping and the commit of each accepted step; the
  protocol reads histories only);
* :meth:`Backend.torque_path` ``(model, input_angle=0, initial_torque=None) -> TorquePath``: the
  model's loading path at a fixed input angle (:class:`rvtool.solver.torque_path.TorquePath`:
  ``go_to(torque) -> output angle``, ``state()``, ``stats()``), the torque sequences of the
  stiffness, lost-motion and hysteresis protocols.
"""
from dataclasses import dataclass, field

import numpy as np

from ...errors import RvtoolInputError

TASKS = ("equilibria", "dynamic", "torque_path")
"""What a backend may be asked to do: static equilibria at drive/load states, driven runs, a
loading path under a changing output torque at a fixed input angle."""


@dataclass(frozen=True)
class Support:
    """Whether a backend runs a task on a model: ``ok``, else ``reasons`` (each a named reason)."""
    ok: bool
    reasons: tuple = ()

    @classmethod
    def of(cls, reasons):
        reasons = tuple(reasons)
        return cls(not reasons, reasons)


SPATIAL_BODIES_REASON = ("the model's carrier retains axial and tilt coordinates (bodies.carrier_coordinates, or "
                         "bodies.flange_coordinates of a cycloid drive, = 'spatial'): the device copies carry planar "
                         "bodies (x, y, theta) and the planar bearing kernels only, not the out-of-plane rows and the "
                         "spatial ball rows (rvtool.bearings.spatial_set; their Warp kernel, "
                         "warp_contacts.spatial_balls, runs inside the exudyn backend's merged element)")
"""The named reason a device backend gives for a model with spatial bodies (issue 32)."""


SPATIAL_WHEELS_REASON = ("the model's wheels, cranks or input shaft retain axial and tilt coordinates "
                         "(bodies.wheel_coordinates / crank_coordinates / input_coordinates = 'spatial'): their families "
                         "are sliced across the width with the tilts (rvtool.contact.skew.SkewSlices, whose stacked "
                         "slices the exudyn backend's merged element sums on the device through weighted maps; "
                         "rvtool.bearings.spatial_tapered on the host); the device copies carry planar bodies and the "
                         "planar kernels only")
"""The named reason a device backend gives for a model with tilting wheels or cranks (issue 32)."""


def spatial_body_reasons(model):
    """The named reasons (:data:`SPATIAL_BODIES_REASON` for a spatial carrier / flange,
    :data:`SPATIAL_WHEELS_REASON` for tilting wheels or cranks) where ``model`` has retained
    out-of-plane coordinates, else []."""
    out = [SPATIAL_BODIES_REASON] if getattr(model, "carrier_tilt", None) is not None else []
    tilts = getattr(model, "body_tilts", None)
    if tilts is not None and any(n.startswith(("wheel", "crank", "sun")) for n in tilts.names):
        out.append(SPATIAL_WHEELS_REASON)
    return out


FLEXIBLE_BODIES_REASON = ("the model has floating flexible bodies (wheels.dynamics.model = 'flexible'): the device "
                          "copies carry planar rigid bodies only, not the modal coordinates and port maps of "
                          "exudyn_user_elements.floating_ports")
"""The named reason a device backend gives for a model with flexible wheels or cranks (issue 33)."""


def flexible_body_reasons(model):
    """[FLEXIBLE_BODIES_REASON] where ``model`` has floating flexible bodies, else []."""
    return [FLEXIBLE_BODIES_REASON] if getattr(model, "flexible", None) is not None else []


@dataclass(frozen=True, kw_only=True)
class EquilibriumBatch:
    """Drive/load states of a quasi-static protocol: ``input_angles`` [rad] (prescribed input
    rotation) under the output torque ``torque`` [N m] resisting the nominal output rotation
    (applied as -sign(ratio) torque). warm_start: a backend that marches through the states may
    start each from the previous equilibrium (False: every state from the kinematic state)."""
    input_angles: tuple
    torque: float
    warm_start: bool = True

    def __post_init__(self):
        a = np.asarray(self.input_angles, float)
        if a.ndim != 1 or len(a) < 1 or not np.all(np.isfinite(a)):
            raise RvtoolInputError("input_angles must be a finite 1-D sequence of at least 1 angle [rad]")
        if not np.isfinite(self.torque):
            raise RvtoolInputError(f"torque = {self.torque!r} N m must be finite")
        object.__setattr__(self, "input_angles", tuple(float(x) for x in a))


@dataclass
class Equilibria:
    """Equilibria of an :class:`EquilibriumBatch`: ``theta_in`` (the solved input angles; a backend
    may shift a point off an activation kink by <= 1e-5 rad and records it), ``theta_out`` (the
    output rotation, reference included) [rad], per-family peak row loads and peak physical-contact
    loads over the batch [N], ``regularization_max`` (largest regularization-spring force at the
    last state [N or N m]), ``stats`` (solver statistics, backend-specific keys), ``wall_s`` and
    ``q`` (n_states, n) the equilibrium states in the model's coordinates (None: the backend keeps
    them on its copies)."""
    theta_in: np.ndarray
    theta_out: np.ndarray
    peak_loads: dict
    peak_contact_loads: dict
    regularization_max: float | None
    stats: dict = field(default_factory=dict)
    wall_s: float = 0.0
    q: np.ndarray | None = None


@dataclass(frozen=True, kw_only=True)
class DrivenRun:
    """A driven run: constant input speed ``speed_rpm`` [rpm] from the quasi-static loaded state at
    input angle 0 under the output torque ``torque`` [N m] (resisting the nominal rotation), for
    ``duration`` [s], with the integrator settings ``run_spec``
    (:class:`rvtool.solver.run_spec.RunSpec`). ``observers`` (Exudyn driver only), ``out_dir``
    (a failed run's saved state), ``on_start`` (called just before stepping), ``device`` (the
    Warp device of a device backend; None: run_spec.device)."""
    torque: float
    speed_rpm: float
    duration: float
    run_spec: object
    observers: object = None
    out_dir: str | None = None
    on_start: object = None
    device: str | None = None


@dataclass
class DrivenHistory:
    """Accepted-step histories of a driven run: t [s], theta_in, theta_out [rad] (t = 0 first),
    ``record`` (:class:`rvtool.solver.driver.RunRecord`), ``omega_in`` [rad/s] and ``extras``
    (backend-specific histories, e.g. the fused stepper's drive torque and peak loads)."""
    t: np.ndarray
    theta_in: np.ndarray
    theta_out: np.ndarray
    record: object
    omega_in: float
    extras: dict = field(default_factory=dict)


class Backend:
    """A solver backend (see the module docstring). ``name`` is its key in ``--backend``;
    ``tasks`` what it implements (auto's order: :func:`rvtool.solver.backends.auto_order`)."""
    name = ""
    tasks = ()

    def supports(self, model, task, run=None):
        """:class:`Support` of ``task`` on ``model`` (and of the :class:`DrivenRun` ``run``, when given)."""
        raise NotImplementedError

    def auto_reason(self, model, task):
        """Why ``auto`` does not take this backend although it supports ``task`` on ``model`` (a
        path without a measured place in auto's order), or None."""
        return None

    def solve_equilibria(self, model, batch: EquilibriumBatch, *, record=None) -> Equilibria:
        raise NotImplementedError(f"backend {self.name!r} solves no equilibria")

    def step_dynamic(self, model, run: DrivenRun) -> DrivenHistory:
        raise NotImplementedError(f"backend {self.name!r} steps no driven runs")

    def torque_path(self, model, *, input_angle=0.0, initial_torque=None):
        """The loading path (:class:`rvtool.solver.torque_path.TorquePath`) of ``model`` at
        ``input_angle`` [rad], started at ``initial_torque`` [N m] (None: at the first level)."""
        raise NotImplementedError(f"backend {self.name!r} runs no torque path")

    def _task(self, task):
        if task not in TASKS:
            raise RvtoolInputError(f"task = {task!r}; valid choices are {list(TASKS)}")
        return task in self.tasks
