"""Accepted-step records and the observer registry.

The driver hands every observer one :class:`AcceptedStep` per accepted step,
carrying the contact snapshots evaluated at the accepted evaluation state and
the accepted duration dt_acc (Section "Observation and computational
execution"). Observers never see trial evaluations, Newton iterations or
rejected attempts: the registry has no interface for them, so repeated residual
evaluations cannot add physical exposure (Eq. (obs_statistics)).
"""
import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_range


def _bad_entries(ids, mask, limit=4):
    """Contact identities (or positions) where ``mask`` holds, for error messages."""
    where = np.flatnonzero(mask)
    names = [ids[i] if i < len(ids) else str(i) for i in where[:limit]]
    return names + (["..."] if where.size > limit else [])


def _vector(name, value, n, ids):
    """(n,) finite real array (dtype kept, so that float32 kernels are not copied)."""
    arr = np.asarray(value)
    if arr.shape != (n,):
        raise RvtoolInputError(f"{name} must have shape ({n},), one value per contact id; got shape {arr.shape}")
    if arr.dtype.kind not in "fiu":
        raise RvtoolInputError(f"{name} must be a real array; got dtype {arr.dtype}")
    finite = np.isfinite(arr)
    if not finite.all():
        raise RvtoolInputError(f"{name} must be finite (valid range: finite real numbers); non-finite at contacts "
                               f"{_bad_entries(ids, ~finite)}")
    return arr


def _rows(name, value, n, ids, dims=(2, 3)):
    """(n, d) finite real array with d in ``dims``."""
    arr = np.asarray(value)
    if arr.ndim != 2 or arr.shape[0] != n or arr.shape[1] not in dims:
        raise RvtoolInputError(f"{name} must have shape ({n}, 2) or ({n}, 3), one row per contact id; "
                               f"got shape {arr.shape}")
    if arr.dtype.kind not in "fiu":
        raise RvtoolInputError(f"{name} must be a real array; got dtype {arr.dtype}")
    finite = np.isfinite(arr).all(axis=1)
    if not finite.all():
        raise RvtoolInputError(f"{name} must be finite (valid range: finite real numbers); non-finite at contacts "
                               f"{_bad_entries(ids, ~finite)}")
    return arr


@dataclass(frozen=True, kw_only=True, eq=False)
class ContactSnapshot:
    """One contact set's values at an accepted evaluation state.

    ids: stable contact identities, unique within the snapshot (e.g. ``"pins/17"``).
    normal_force: F_{c,n} of Eq. (obs_statistics), shape (N,) [N], >= 0.
    slip_speed: v_{s,c,n}, shape (N,) [m/s] (its magnitude is used), or None
    where the contact family provides no sliding speed: then only the load
    statistics are accumulated.
    position: contact location in the global frame, shape (N, 2) or (N, 3) [m].
    normal: unit contact normal, same shape as ``position`` [-], or None.

    Arrays keep their dtype (float32 kernels are not copied here); accumulators
    convert to double precision.
    """
    ids: tuple
    normal_force: np.ndarray
    slip_speed: np.ndarray | None
    position: np.ndarray
    normal: np.ndarray | None = None

    def __post_init__(self):
        ids = self.ids
        if isinstance(ids, str) or not all(isinstance(i, str) for i in ids):
            raise RvtoolInputError(f"ids must be a sequence of str contact identities; got {ids!r:.200}")
        ids = tuple(ids)
        n = len(ids)
        if len(set(ids)) != n:
            seen, dup = set(), []
            for i in ids:
                if i in seen:
                    dup.append(i)
                seen.add(i)
            raise RvtoolInputError(f"ids must be unique within a snapshot; repeated: {dup[:4]}")
        object.__setattr__(self, "ids", ids)
        f = _vector("normal_force", self.normal_force, n, ids)
        negative = f < 0
        if negative.any():
            raise RvtoolInputError(f"normal_force = {f[negative][:4].tolist()} at contacts "
                                   f"{_bad_entries(ids, negative)} is outside the valid range [0, inf) N")
        object.__setattr__(self, "normal_force", f)
        if self.slip_speed is not None:
            object.__setattr__(self, "slip_speed", _vector("slip_speed", self.slip_speed, n, ids))
        pos = _rows("position", self.position, n, ids)
        object.__setattr__(self, "position", pos)
        if self.normal is not None:
            nrm = _rows("normal", self.normal, n, ids, dims=(pos.shape[1],))
            object.__setattr__(self, "normal", nrm)

    def __len__(self):
        return len(self.ids)


@dataclass(frozen=True, kw_only=True, eq=False)
class AcceptedStep:
    """One accepted step, as the driver hands it to the observers.

    index: accepted-step counter (0, 1, 2, ...; strictly increasing).
    t_start: time at the start of the step [s].
    dt: accepted duration Delta t_n^a [s] (>= 0); the physical clock advances by it.
    q_start, q_end: global ODE2 coordinates at the start and end of the step
    [m, rad].
    snapshots: contact-set name -> :class:`ContactSnapshot` at the accepted
    evaluation state.
    """
    index: int
    t_start: float
    dt: float
    q_start: np.ndarray
    q_end: np.ndarray
    snapshots: dict

    def __post_init__(self):
        if isinstance(self.index, (bool, np.bool_)) or not isinstance(self.index, (int, np.integer)) or self.index < 0:
            raise RvtoolInputError(f"index = {self.index!r} is outside the valid range: integers in [0, inf)")
        t_start, dt = float(self.t_start), float(self.dt)
        if not (math.isfinite(t_start) and 0.0 <= dt < math.inf):  # plain floats: this runs every step
            check_finite("t_start", self.t_start)
            check_finite("dt", self.dt)
            check_range("dt", self.dt, 0.0)
        object.__setattr__(self, "index", int(self.index))
        object.__setattr__(self, "t_start", t_start)
        object.__setattr__(self, "dt", dt)
        q0 = np.asarray(self.q_start, dtype=np.float64)
        q1 = np.asarray(self.q_end, dtype=np.float64)
        if q0.ndim != 1 or q1.shape != q0.shape:
            raise RvtoolInputError(f"q_start and q_end must be 1-D arrays of equal length (the ODE2 coordinates); "
                                   f"got shapes {q0.shape} and {q1.shape}")
        for name, q in (("q_start", q0), ("q_end", q1)):
            if not math.isfinite(q.sum()) and not np.isfinite(q).all():
                raise RvtoolInputError(f"{name} must be finite (valid range: finite real numbers); non-finite at "
                                       f"coordinates {np.flatnonzero(~np.isfinite(q))[:4].tolist()}")
        object.__setattr__(self, "q_start", q0)
        object.__setattr__(self, "q_end", q1)
        snaps = dict(self.snapshots)
        for name, snap in snaps.items():
            if not isinstance(name, str) or not isinstance(snap, ContactSnapshot):
                raise RvtoolInputError(f"snapshots must map contact-set names (str) to ContactSnapshot; got "
                                       f"{name!r}: {type(snap).__name__}")
        object.__setattr__(self, "snapshots", snaps)

    @property
    def t_end(self):
        """t_start + dt [s]."""
        return self.t_start + self.dt


@runtime_checkable
class Observer(Protocol):
    """What the registry calls: ``on_accepted`` once per accepted step, ``results`` at the end."""

    def on_accepted(self, step: AcceptedStep) -> None: ...

    def results(self) -> dict: ...


class ObserverRegistry:
    """Named observers, each called once per accepted step in registration order.

    There is deliberately no interface for trial evaluations or rejected
    attempts: an observer's result is a function of the accepted sequence only.
    """

    def __init__(self):
        self._observers = {}
        self._last_index = None

    def register(self, name: str, observer) -> None:
        """Add ``observer`` under ``name`` (non-empty str, not yet registered)."""
        if not isinstance(name, str) or not name:
            raise RvtoolInputError(f"name = {name!r} must be a non-empty str")
        if name in self._observers:
            raise RvtoolInputError(f"name = {name!r} is already registered; valid: a name not in "
                                   f"{list(self._observers)}")
        if not (callable(getattr(observer, "on_accepted", None)) and callable(getattr(observer, "results", None))):
            raise RvtoolInputError(f"observer {name!r} ({type(observer).__name__}) must provide on_accepted(step) "
                                   "and results()")
        self._observers[name] = observer

    def on_accepted(self, step: AcceptedStep) -> None:
        """Hand one accepted step to every observer (registration order, exactly once)."""
        if not isinstance(step, AcceptedStep):
            raise RvtoolInputError(f"step must be an AcceptedStep; got {type(step).__name__}")
        if self._last_index is not None and step.index <= self._last_index:
            # the same accepted step delivered twice would double its exposure
            raise RvtoolInputError(f"step.index = {step.index} is outside the valid range "
                                   f"[{self._last_index + 1}, inf): accepted steps are delivered once, in order")
        self._last_index = step.index
        for observer in self._observers.values():
            observer.on_accepted(step)

    def results(self) -> dict:
        """name -> observer.results()."""
        return {name: obs.results() for name, obs in self._observers.items()}

    def __getitem__(self, name):
        try:
            return self._observers[name]
        except KeyError:
            raise KeyError(f"no observer named {name!r}; registered: {list(self._observers)}") from None

    def __contains__(self, name):
        return name in self._observers

    def __iter__(self):
        return iter(self._observers)

    def __len__(self):
        return len(self._observers)
