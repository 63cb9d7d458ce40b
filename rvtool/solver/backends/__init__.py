"""Solver backends behind one interface (:mod:`rvtool.solver.backends.base`), and ``auto``.

=========  ==========================================  ==========================================
name       equilibria (quasi-static protocols)         driven runs (dynamic protocols)
=========  ==========================================  ==========================================
exudyn     StaticSolver with its ladder (the oracle)   Exudyn generalized alpha (the oracle)
replica    B copies in one Exudyn system               --
device     device Newton (Warp, cpu or cuda): the      --
           cycloid CUDA-graph path or the row Newton
           (every replicable topology, e.g. RV)
fused      --                                          fused stepper (Warp, cpu or cuda; the
                                                       cycloid copy-parameter set), else the row
                                                       stepper (Exudyn's step on the device rows:
                                                       RV and every model with device rows)
=========  ==========================================  ==========================================

Torque paths (task ``"torque_path"``, :meth:`Backend.torque_path`; the stiffness, lost-motion and
hysteresis sequences): ``exudyn`` (the load continuation, the oracle) and ``device`` (the row Newton's
:class:`~rvtool.solver.device_torque_path.DeviceTorquePath`).

``--backend device`` asks for the device family: the device Newton for equilibria and the fused
backend for driven runs. :func:`choose` resolves a requested name for a task on a model: a named
backend that cannot run the model is a :class:`RvtoolInputError` naming every reason (no silent
fallback); ``auto`` takes the first supporting backend in the measured order (:func:`auto_order`,
docs/api/backends.md) and returns, for every other backend, the named reason it was not taken.
"""
from ...errors import RvtoolInputError
from .base import TASKS, Backend, DrivenHistory, DrivenRun, Equilibria, EquilibriumBatch, Support
from .device import DeviceBackend, FusedBackend
from .exudyn import ExudynBackend
from .replica import ReplicaBackend

CHOICES = ("auto", "exudyn", "replica", "device", "fused")
"""Values of ``--backend`` / ``backend=``."""

__all__ = ["Backend", "CHOICES", "DeviceBackend", "DrivenHistory", "DrivenRun", "Equilibria", "EquilibriumBatch",
           "ExudynBackend", "FusedBackend", "REPLICA_MIN_STATES", "TORQUE_PATH_ORDER", "ReplicaBackend", "Support", "TASKS", "auto_order",
           "backends", "choose", "get"]


def backends(device="cpu"):
    """Every backend, one instance each, on Warp ``device`` where it has one."""
    return [ExudynBackend(), ReplicaBackend(device=device), DeviceBackend(device=device), FusedBackend(device=device)]


def get(name, device="cpu"):
    """The backend called ``name`` (a :class:`Backend` instance is returned as it is)."""
    if isinstance(name, Backend):
        return name
    for b in backends(device):
        if b.name == name:
            return b
    raise RvtoolInputError(f"backend = {name!r}; valid choices are {list(CHOICES)}")


REPLICA_MIN_STATES = 500
"""From this many equilibria on, the replica backend is faster than Exudyn's sequential march on
a CPU. Measured on the 2-core development machine (2026-11-27, tests/test_backends_golden.py's
designs): the replica pays ~0.35 s (RD-40) to ~1.1 s (RV-40E) to copy the model and then
0.8-1.5 ms per state, Exudyn 1.5-2.5 ms (RD-40) and 5.5-8.7 ms (RV-40E) per state: RD-40 160
states 0.25 s Exudyn against 0.48 s replica, 2,000 states 4.9 s against 1.9 s; RV-40E 52 states
0.45 s against 1.44 s, 600 states 3.3 s against 2.0 s. The crossover lies at 200-500 states."""


TORQUE_PATH_ORDER = {"cpu": ("device", "exudyn"), "cuda": ("exudyn", "device")}
"""auto's order of the torque path (the stiffness / lost-motion / hysteresis sequences of one
model) per Warp device kind. Measured on the 2-core development machine (2026-11-27, the quick
``rvtool analyze DESIGN --protocols stiffness`` sequence of 22 levels, warm, 3 repeats): on a CPU
the device row Newton's torque path is faster on every non-cycloid shipped design (RV-40E 0.17 s
against Exudyn's 0.60 s, the whole protocol 0.41 s against 1.11 s; the standard involute 0.055 s
against 0.081 s; the three-stage RV 0.14 s against 0.16-0.18 s) and slower on the cycloid (RD-40
0.079-0.11 s against 0.048-0.15 s), which :meth:`DeviceBackend.auto_reason` names (auto keeps
Exudyn there). On CUDA not measured: the oracle first."""


def auto_order(task, *, n_states=None, device="cpu"):
    """auto's order of the backends for ``task`` (fastest first), measured (see
    :data:`REPLICA_MIN_STATES`): equilibria on a CUDA device: device Newton, replica, Exudyn; on a
    CPU: Exudyn, then replica, below REPLICA_MIN_STATES states, replica first from there on, and the
    device Newton last (from the kinematic state at every point, 1.9-2.2 ms per RD-40 state on one
    CPU core: no faster than Exudyn's warm-started march). Driven runs: the fused stepper, then
    Exudyn (RD-40, 1,000 steps on a CPU: 0.9-1.2 s against 1.0-1.1 s; on a GPU the fused stepper
    runs many copies at once); the fused backend's row stepper is not taken by auto
    (:meth:`FusedBackend.auto_reason`: measured on rv40e only). Torque paths: :data:`TORQUE_PATH_ORDER`."""
    if task == "dynamic":
        return ["fused", "exudyn"]
    if task == "torque_path":
        return list(TORQUE_PATH_ORDER["cuda" if str(device).startswith("cuda") else "cpu"])
    if str(device).startswith("cuda"):
        return ["device", "replica", "exudyn"]
    if n_states is not None and n_states >= REPLICA_MIN_STATES:
        return ["replica", "exudyn", "device"]
    return ["exudyn", "replica", "device"]


def choose(requested, model, task, *, run=None, n_states=None, device="cpu"):
    """(backend, choice) for ``task`` on ``model``: ``requested`` is a name of :data:`CHOICES` or a
    :class:`Backend`; n_states: the number of equilibria asked for (auto's order depends on it);
    device: the Warp device of the device backends. choice = {"requested", "ran", "not_taken":
    {name: reason}} (for results.json).

    A named backend that does not implement the task is mapped within its family ("device" runs
    driven runs on "fused", "fused" runs equilibria on "device"); one that cannot run the model
    raises :class:`RvtoolInputError` with every reason."""
    if task not in TASKS:
        raise RvtoolInputError(f"task = {task!r}; valid choices are {list(TASKS)}")
    if isinstance(requested, Backend):
        sup = requested.supports(model, task, run)
        if not sup.ok:
            raise RvtoolInputError(f"backend {requested.name!r} cannot run {task} on this model: "
                                   f"{'; '.join(sup.reasons)}")
        return requested, {"requested": requested.name, "ran": requested.name, "not_taken": {}}
    if requested not in CHOICES:
        raise RvtoolInputError(f"backend = {requested!r}; valid choices are {list(CHOICES)}")
    every = [b for b in backends(device) if task in b.tasks]
    order = auto_order(task, n_states=n_states, device=device)
    if requested != "auto":
        family = {"device": ("device", "fused"), "fused": ("fused", "device")}.get(requested, (requested,))
        named = [b for b in every if b.name in family]
        if not named:
            raise RvtoolInputError(f"backend {requested!r} does not run {task}; for {task} valid choices are "
                                   f"{['auto'] + [b.name for b in every]}")
        b = named[0]
        sup = b.supports(model, task, run)
        if not sup.ok:
            raise RvtoolInputError(f"backend = {requested!r} ({b.name}) cannot run {task} on this model: "
                                   f"{'; '.join(sup.reasons)}. Valid choices: 'exudyn' (every model) or 'auto'")
        return b, {"requested": requested, "ran": b.name,
                   "not_taken": {o.name: f"not requested (--backend {requested})" for o in every if o is not b}}
    not_taken, chosen = {}, None
    size = f"{n_states} states" if n_states is not None else task
    for b in sorted(every, key=lambda b: order.index(b.name)):
        if chosen is not None:
            # not asked whether it supports the model (a device backend's check builds its copies)
            not_taken[b.name] = (f"comes after {chosen.name!r} in auto's measured order for {size} on {device} "
                                 "(rvtool.solver.backends.auto_order)")
            continue
        sup = b.supports(model, task, run)
        why = b.auto_reason(model, task) if sup.ok else None
        if sup.ok and why is None:
            chosen = b
        else:
            not_taken[b.name] = why or "; ".join(sup.reasons)
    return chosen, {"requested": "auto", "ran": chosen.name, "not_taken": not_taken}
