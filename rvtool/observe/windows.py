"""Sampling windows over the accepted steps, and the whole-run and per-step observers.

A window belongs to the consuming process (Section "Contact histories and
process-specific exposure"): a time window, or a phase window over a declared
combination of shaft coordinates (e.g. one mesh period of input minus output
angle). Each window holds one :class:`ExposureAccumulator` of Eq.
(obs_statistics). A step that crosses a window boundary is apportioned: the
progress variable (time, or phase interpolated linearly in time between
q_start and q_end) gives the fraction of the accepted duration on each side,
each part is integrated with the same accepted-state snapshot, and the peak
enters every window the step touches ("the sampled peak remains a maximum").
"""
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_positive
from .registry import AcceptedStep
from .statistics import ExposureAccumulator

# Boundary snapping: a progress value within this many ulps of a window
# boundary lies on it. Successive accepted steps meet at t_start + dt, which
# the driver recomputes as a difference of times; without snapping, a 1-ulp
# mismatch would open a window for a 1e-17 s sliver of the next step.
_SNAP_ULPS = 64


def _contact_sets(contact_sets):
    if contact_sets is None:
        return None
    if isinstance(contact_sets, str):
        contact_sets = (contact_sets,)
    sets = tuple(contact_sets)
    if not all(isinstance(s, str) and s for s in sets):
        raise RvtoolInputError(f"contact_sets = {contact_sets!r} must be None (all) or a sequence of set names (str)")
    return sets


def _select(step: AcceptedStep, contact_sets):
    """Snapshots of the recorded contact sets, in a fixed order."""
    if contact_sets is None:
        return tuple(step.snapshots.values())
    try:
        return tuple(step.snapshots[name] for name in contact_sets)
    except KeyError:
        missing = [n for n in contact_sets if n not in step.snapshots]
        raise RvtoolInputError(f"contact_sets = {list(contact_sets)} names sets {missing} that the accepted step "
                               f"does not carry; valid: {sorted(step.snapshots)}") from None


def _check_step(step):
    if not isinstance(step, AcceptedStep):
        raise RvtoolInputError(f"step must be an AcceptedStep; got {type(step).__name__}")


@dataclass(kw_only=True, eq=False)
class Window:
    """One visit of the progress variable to window ``index`` = [lower, upper).

    lower, upper: window bounds in the progress variable (time [s] or phase [rad]).
    t_start, t_end: time at which the visit began and of its last accepted
    state so far [s] (boundary crossings interpolated within the step).
    v_start, v_end: progress variable at those times; v_min, v_max: its range
    over the visit.
    accumulator: Eq. (obs_statistics) over the visit; ``accumulator.duration``
    is the apportioned accepted duration [s].
    closed: the progress variable has left the window.
    """
    index: int
    lower: float
    upper: float
    t_start: float
    t_end: float
    v_start: float
    v_end: float
    v_min: float
    v_max: float
    accumulator: ExposureAccumulator
    closed: bool = False

    @property
    def duration(self) -> float:
        """Accepted duration apportioned to this window [s]."""
        return self.accumulator.duration

    @property
    def complete(self) -> bool:
        """The visit covered the whole window (from one bound to the other)."""
        return self.v_min <= self.lower and self.v_max >= self.upper

    def to_dict(self, variable="t"):
        d = {"index": self.index, "lower": self.lower, "upper": self.upper, "t_start": self.t_start,
             "t_end": self.t_end, "duration": self.duration, "complete": self.complete, "closed": self.closed}
        if variable != "t":
            d[f"{variable}_start"] = self.v_start
            d[f"{variable}_end"] = self.v_end
        d["exposure"] = self.accumulator.to_dict()
        return d


class _SamplingWindows:
    """Consecutive windows [offset + k L, offset + (k+1) L) of a progress variable."""

    variable = "t"

    def __init__(self, length, offset, contact_sets, m):
        self._length = float(length)
        self._offset = float(offset)
        self.contact_sets = _contact_sets(contact_sets)
        ExposureAccumulator(m)  # validates m before any step arrives
        self.m = float(m)
        self._closed = []
        self._open = None
        self._last_direction = 1

    def _progress(self, step):  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def closed(self) -> list:
        """Windows the progress variable has left, in time order."""
        return list(self._closed)

    @property
    def open(self):
        """The window of the last accepted state (None before the first step)."""
        return self._open

    @property
    def windows(self) -> list:
        """All windows in time order (closed ones, then the open one)."""
        return self._closed + ([self._open] if self._open is not None else [])

    def _bound(self, j):
        return self._offset + j * self._length

    def _on_boundary(self, v, tol):
        j = round((v - self._offset) / self._length)
        return j if abs(self._bound(j) - v) <= tol else None

    def _enter(self, k, t, v):
        w = self._open
        if w is not None and w.index == k:
            return w
        if w is not None:
            w.closed = True
            self._closed.append(w)
        w = Window(index=k, lower=self._bound(k), upper=self._bound(k + 1), t_start=t, t_end=t, v_start=v, v_end=v,
                   v_min=v, v_max=v, accumulator=ExposureAccumulator(self.m))
        self._open = w
        return w

    def on_accepted(self, step: AcceptedStep) -> None:
        _check_step(step)
        snaps = _select(step, self.contact_sets)
        v0, v1 = self._progress(step)
        t0, dt = step.t_start, step.dt
        L, o = self._length, self._offset
        d = v1 - v0
        direction = (d > 0) - (d < 0)
        tol = _SNAP_ULPS * math.ulp(max(abs(v0), abs(v1), abs(o), L))
        j0, j1 = self._on_boundary(v0, tol), self._on_boundary(v1, tol)
        v0s = v0 if j0 is None else self._bound(j0)
        v1s = v1 if j1 is None else self._bound(j1)
        if j0 is None:
            k_first = math.floor((v0 - o) / L)
        elif direction > 0:
            k_first = j0
        elif direction < 0:
            k_first = j0 - 1
        else:  # at rest on a boundary: stay in the window already open there
            k_first = self._open.index if self._open is not None and self._open.index in (j0 - 1, j0) else j0
        if direction == 0:
            k_last = k_first
        elif j1 is None:
            k_last = math.floor((v1 - o) / L)
        else:
            k_last = j1 - 1 if direction > 0 else j1
        if (k_last - k_first) * direction < 0:  # moved less than the snapping tolerance
            k_last = k_first
        ks = range(k_first, k_last + direction, direction) if direction else (k_first,)
        # time fraction of the step at each crossed boundary (progress linear in time within the
        # step, |v_b - v0| / |v1 - v0| in either direction); plain floats: most steps cross nothing
        crossings = [self._bound(k + 1 if direction > 0 else k) for k in ks[:-1]]
        frac = [0.0]
        for b in crossings:
            frac.append(min(1.0, max(frac[-1], (b - v0) / d)))
        frac.append(1.0)
        single = len(ks) == 1
        for i, k in enumerate(ks):
            v_in = v0s if i == 0 else crossings[i - 1]
            v_out = v1s if i == len(ks) - 1 else crossings[i]
            w = self._enter(k, t0 + frac[i] * dt, v_in)
            part = dt * (frac[i + 1] - frac[i])
            if single or part > 0.0:
                w.accumulator.add(part, *snaps)
                w.accumulator.peak(*snaps)
            w.t_end = t0 + dt if i == len(ks) - 1 else t0 + frac[i + 1] * dt
            w.v_end = v_out
            w.v_min = min(w.v_min, v_in, v_out)
            w.v_max = max(w.v_max, v_in, v_out)

    def results(self) -> dict:
        """Closed windows and the open one (``Window.to_dict``), with the window definition."""
        return {"closed": [w.to_dict(self.variable) for w in self._closed],
                "open": None if self._open is None else self._open.to_dict(self.variable),
                "m": self.m, "contact_sets": None if self.contact_sets is None else list(self.contact_sets)}


class TimeWindows(_SamplingWindows):
    """Time windows [k L, (k+1) L) of the accepted-step clock.

    length_s: window length L [s] (> 0). contact_sets: names of the snapshots
    to record (None: all). m: exponent of I_m (> 0).

    A step straddling a boundary gives the part of its accepted duration
    before the boundary to the current window and the rest to the next (a
    step may span several windows); every part uses the step's accepted-state
    snapshot, and the peak enters every window the step touches.
    """

    variable = "t"

    def __init__(self, length_s: float, *, contact_sets=None, m: float = 3.0):
        check_finite("length_s", length_s)
        check_positive("length_s", length_s)
        super().__init__(length_s, 0.0, contact_sets, m)
        self.length_s = float(length_s)

    def _progress(self, step):
        return step.t_start, step.t_start + step.dt

    def results(self) -> dict:
        return {"kind": "time", "length_s": self.length_s, **super().results()}


class PhaseWindows(_SamplingWindows):
    """Phase windows [offset + k P, offset + (k+1) P) of phi = coefficients . q.

    coefficients: weights over the global ODE2 coordinates forming the declared
    phase, e.g. +1 at the input angle and -i at the output angle [rad per
    coordinate unit]. period_rad: window period P [rad] (> 0), e.g. one mesh
    period. offset_rad: phase of a window boundary [rad]. contact_sets, m: as
    for :class:`TimeWindows`.

    Within a step phi is interpolated linearly in time between q_start and
    q_end; the time fraction at a boundary phi_b is |phi_b - phi_0| / |phi_1 -
    phi_0|, so reverse rotation (decreasing phi) enters a window at its upper
    bound and leaves at its lower one. A step without phase change stays in
    its window. A visit ends when phi leaves the window; phi returning into a
    window it has left (oscillation) starts a new visit.
    """

    variable = "phase"

    def __init__(self, coefficients, period_rad: float, offset_rad: float = 0.0, *, contact_sets=None,
                 m: float = 3.0):
        c = np.array(coefficients, dtype=np.float64)
        if c.ndim != 1 or c.size == 0:
            raise RvtoolInputError(f"coefficients must be a 1-D array over the ODE2 coordinates; got shape {c.shape}")
        check_finite("coefficients", c)
        if not np.any(c):
            raise RvtoolInputError("coefficients are all zero; valid: at least one non-zero weight "
                                   "(a phase that moves)")
        check_finite("period_rad", period_rad)
        check_positive("period_rad", period_rad)
        check_finite("offset_rad", offset_rad)
        super().__init__(period_rad, offset_rad, contact_sets, m)
        c.flags.writeable = False
        self.coefficients = c
        self.period_rad = float(period_rad)
        self.offset_rad = float(offset_rad)

    def phase(self, q) -> float:
        """phi = coefficients . q [rad]."""
        q = np.asarray(q, dtype=np.float64)
        if q.shape != self.coefficients.shape:
            raise RvtoolInputError(f"coefficients has length {self.coefficients.size}, but the step carries "
                                   f"{q.size} ODE2 coordinates; valid: one coefficient per coordinate")
        return float(self.coefficients @ q)

    def _progress(self, step):
        return self.phase(step.q_start), self.phase(step.q_end)

    def results(self) -> dict:
        return {"kind": "phase", "period_rad": self.period_rad, "offset_rad": self.offset_rad,
                "coefficients": self.coefficients.tolist(), **super().results()}


class WholeRun:
    """One accumulator of Eq. (obs_statistics) over every accepted step.

    contact_sets: names of the snapshots to record (None: all). m: exponent of I_m (> 0).
    """

    def __init__(self, *, contact_sets=None, m: float = 3.0):
        self.contact_sets = _contact_sets(contact_sets)
        self.accumulator = ExposureAccumulator(m)

    def on_accepted(self, step: AcceptedStep) -> None:
        _check_step(step)
        snaps = _select(step, self.contact_sets)
        self.accumulator.add(step.dt, *snaps)
        self.accumulator.peak(*snaps)

    def results(self) -> dict:
        return self.accumulator.to_dict()


@dataclass(eq=False)
class _SetRecord:
    ids: dict = field(default_factory=dict)        # id -> column
    rows: list = field(default_factory=list)       # (step row, columns, force, slip)


class StepRecorder:
    """Per accepted step: t_end, dt and, for the chosen sets, each contact's normal force and slip speed.

    contact_sets: names of the snapshots to record (None: all that appear).
    Meant for plots and tests; memory grows with steps x contacts.
    """

    def __init__(self, *, contact_sets=None):
        self.contact_sets = _contact_sets(contact_sets)
        self._index, self._t_end, self._dt = [], [], []
        self._sets = {}

    def on_accepted(self, step: AcceptedStep) -> None:
        _check_step(step)
        names = tuple(step.snapshots) if self.contact_sets is None else self.contact_sets
        snaps = dict(zip(names, _select(step, self.contact_sets)))
        row = len(self._t_end)
        self._index.append(step.index)
        self._t_end.append(step.t_start + step.dt)
        self._dt.append(step.dt)
        for name, s in snaps.items():
            rec = self._sets.setdefault(name, _SetRecord())
            cols = np.fromiter((rec.ids.setdefault(i, len(rec.ids)) for i in s.ids), dtype=np.intp, count=len(s))
            slip = None if s.slip_speed is None else np.array(s.slip_speed, dtype=np.float64)
            rec.rows.append((row, cols, np.array(s.normal_force, dtype=np.float64), slip))

    def as_arrays(self) -> dict:
        """``index``, ``t_end`` [s], ``dt`` [s] of shape (n_steps,), and per set name a dict with
        ``ids`` and ``normal_force`` [N], ``slip_speed`` [m/s] of shape (n_steps, n_ids)
        (NaN where an id was absent or no slip speed was given)."""
        n = len(self._t_end)
        out = {"index": np.array(self._index, dtype=np.int64), "t_end": np.array(self._t_end, dtype=np.float64),
               "dt": np.array(self._dt, dtype=np.float64), "sets": {}}
        for name, rec in self._sets.items():
            fn = np.full((n, len(rec.ids)), np.nan)
            vs = np.full((n, len(rec.ids)), np.nan)
            for row, cols, f, v in rec.rows:
                fn[row, cols] = f
                if v is not None:
                    vs[row, cols] = v
            out["sets"][name] = {"ids": list(rec.ids), "normal_force": fn, "slip_speed": vs}
        return out

    def results(self) -> dict:
        return self.as_arrays()
