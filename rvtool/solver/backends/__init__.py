"""Solver backends behind one interface (:mod:`rvtool.solver.backends.base`), and ``auto``.

=========  ==========================================  ==========================================
name       equilibria (quasi-static protocols)         driven runs (dynamic protocols)
=========  ==========================================  ==========================================
exudyn     StaticSolver with its ladder (the oracle)   Exudyn generalized alpha (the oracle)
replica    B copies in one Exudyn system               --
device     device Newton (Warp, cpu or cuda)           --
fused      --                                          fused stepper (Warp, cpu or cuda)
=========  ==========================================  ==========================================

``--backend device`` asks for the device family: the device Newton for equilibria and the fused
stepper for driven runs. :func:`choose` resolves a requested name for a task on a model: a named
backend that cannot run the model is a :class:`RvtoolInputError` naming every reason (no silent
fallback); ``auto`` takes the first supporting backend in the measured order (``Backend.rank``,
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
           "ExudynBackend", "FusedBackend", "ReplicaBackend", "Support", "TASKS", "backends", "choose", "get"]


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


def choose(requested, model, task, *, run=None, device="cpu"):
    """(backend, choice) for ``task`` on ``model``: ``requested`` is a name of :data:`CHOICES` or a
    :class:`Backend`. choice = {"requested", "ran", "not_taken": {name: reason}} (for results.json).

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
    for b in sorted(every, key=lambda b: b.rank[task]):
        if chosen is not None:
            not_taken[b.name] = f"slower in auto's order than {chosen.name!r}"
            continue
        sup = b.supports(model, task, run)
        if sup.ok:
            chosen = b
        else:
            not_taken[b.name] = "; ".join(sup.reasons)
    return chosen, {"requested": "auto", "ran": chosen.name, "not_taken": not_taken}
