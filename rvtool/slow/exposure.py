"""Slow-process exposures of Eq. (supp_slow_exposure) over consumer-owned windows.

For each contact identity c over one window of accepted duration tau_w,

    I_s,c = sum_n F_c,n |v_s,c,n| dt_n^a,     I_m,c = sum_n F_c,n^m dt_n^a,

summed over accepted steps only. The window belongs to the consuming process
(a mesh period for tooth heat, a cage cycle for a rolling element): the
consumer builds the :class:`rvtool.observe.TimeWindows` or
:class:`rvtool.observe.PhaseWindows` it needs, and :class:`ExposureObserver`
registers it with the :class:`rvtool.observe.ObserverRegistry` that the
driver (``rvtool.solver.simulate``) calls once per accepted step. Neither the
registry nor this observer has an interface for trial evaluations or
rejected attempts, so retries cannot add exposure.

Mechanical settling after a slow update is excluded (Section "Slow feedback
through shared mechanical channels"): :meth:`ExposureObserver.exclude_until`
drops accepted steps that start before the end of settling, and only
*complete* windows (the progress variable crossed the whole window) are
handed to the consumer.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..observe.registry import AcceptedStep
from ..observe.windows import PhaseWindows, TimeWindows
from ..validation import check_finite, check_positive, check_range


def _per_id(name, value, n):
    arr = np.array(value, dtype=np.float64)
    if arr.shape != (n,):
        raise RvtoolInputError(f"{name} must have shape ({n},), one value per contact id; got {arr.shape}")
    check_finite(name, arr)
    check_range(name, arr, 0.0)
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, kw_only=True, eq=False)
class WindowExposure:
    """Eq. (supp_slow_exposure) of one window, per contact identity.

    ids: contact identities (unique str). tau_w: accepted duration of the
    window [s] (> 0). m: exponent of I_m, set by the consuming life law [-] (> 0).
    I_s: sliding exposure sum F |v_s| dt [N m]. I_m: load moment sum F^m dt
    [N^m s]. I_F: sum F dt [N s] (mean load I_F / tau_w, used by the film
    thickness and the mean-load comparison of fatigue). F_pk: sampled load
    maximum [N]. position: load-weighted contact position sum(F x dt)/sum(F dt)
    [m], shape (N, 3) (2-D positions padded with z = 0; zeros where a contact
    carried no load, which then has I_s = 0 and receives no wear).
    All arrays are read-only float64 with entries >= 0 (position: finite).
    """
    ids: tuple
    tau_w: float
    m: float
    I_s: np.ndarray
    I_m: np.ndarray
    I_F: np.ndarray
    F_pk: np.ndarray
    position: np.ndarray

    def __post_init__(self):
        ids = tuple(self.ids)
        if not all(isinstance(i, str) and i for i in ids) or len(set(ids)) != len(ids):
            raise RvtoolInputError(f"ids must be unique non-empty str contact identities; got {ids!r:.200}")
        object.__setattr__(self, "ids", ids)
        check_finite("tau_w", self.tau_w)
        check_positive("tau_w", self.tau_w)
        check_finite("m", self.m)
        check_positive("m", self.m)
        object.__setattr__(self, "tau_w", float(self.tau_w))
        object.__setattr__(self, "m", float(self.m))
        n = len(ids)
        for name in ("I_s", "I_m", "I_F", "F_pk"):
            object.__setattr__(self, name, _per_id(name, getattr(self, name), n))
        pos = np.array(self.position, dtype=np.float64)
        if pos.shape != (n, 3):
            raise RvtoolInputError(f"position must have shape ({n}, 3); got {pos.shape}")
        check_finite("position", pos)
        pos.flags.writeable = False
        object.__setattr__(self, "position", pos)

    def __len__(self):
        return len(self.ids)

    def index(self, contact_id: str) -> int:
        """Row of ``contact_id``."""
        try:
            return self.ids.index(contact_id)
        except ValueError:
            raise KeyError(f"contact id {contact_id!r} is not in this window ({len(self.ids)} ids)") from None

    @property
    def mean_force(self) -> np.ndarray:
        """I_F / tau_w per id [N]."""
        return self.I_F / self.tau_w

    @classmethod
    def from_accumulator(cls, accumulator, tau_w: float | None = None):
        """From an :class:`rvtool.observe.ExposureAccumulator`; tau_w defaults to its accepted duration."""
        n = len(accumulator)
        pos = np.zeros((n, 3))
        for i, p in enumerate(accumulator.load_weighted_position().values()):
            if p is not None:
                pos[i, :p.size] = p
        return cls(ids=accumulator.ids, tau_w=accumulator.duration if tau_w is None else tau_w, m=accumulator.m,
                   I_s=accumulator.I_s, I_m=accumulator.I_m, I_F=accumulator.I_F, F_pk=accumulator.F_pk,
                   position=pos)

    @classmethod
    def combine(cls, windows, weights):
        """Phase samples sharing one slow state, combined with ``weights`` (>= 0, sum > 0).

        The rates I/tau_w of the result are the weighted means of the samples'
        rates (an id absent from a sample contributes 0 there), and its tau_w
        is the weighted mean window length, so mean source mu I_s / tau_w
        combines the samples' sources before the common thermal solve. F_pk
        is the maximum over the samples, position the I_F-rate-weighted mean.
        """
        windows = tuple(windows)
        w = np.array(weights, dtype=np.float64)
        if not windows or w.shape != (len(windows),):
            raise RvtoolInputError(f"weights must have one entry per window ({len(windows)}); got shape {w.shape}")
        check_finite("weights", w)
        check_range("weights", w, 0.0)
        if not w.sum() > 0.0:
            raise RvtoolInputError(f"weights = {w.tolist()} must have a positive sum")
        ms = {x.m for x in windows}
        if len(ms) != 1:
            raise RvtoolInputError(f"windows carry different exponents m = {sorted(ms)}; valid: one consumer's m")
        w = w / w.sum()
        ids = tuple(dict.fromkeys(i for x in windows for i in x.ids))
        row = {i: k for k, i in enumerate(ids)}
        n = len(ids)
        rates = {name: np.zeros(n) for name in ("I_s", "I_m", "I_F")}
        peak, pos_num = np.zeros(n), np.zeros((n, 3))
        for wk, x in zip(w, windows):
            r = np.fromiter((row[i] for i in x.ids), dtype=np.intp, count=len(x))
            for name in rates:
                rates[name][r] += wk * getattr(x, name) / x.tau_w
            peak[r] = np.maximum(peak[r], x.F_pk)
            pos_num[r] += (wk * x.I_F / x.tau_w)[:, None] * x.position
        tau = float(sum(wk * x.tau_w for wk, x in zip(w, windows)))
        loaded = rates["I_F"] > 0.0
        pos = np.zeros((n, 3))
        pos[loaded] = pos_num[loaded] / rates["I_F"][loaded, None]
        return cls(ids=ids, tau_w=tau, m=windows[0].m, I_s=rates["I_s"] * tau, I_m=rates["I_m"] * tau,
                   I_F=rates["I_F"] * tau, F_pk=peak, position=pos)

    def to_dict(self) -> dict:
        return {"ids": list(self.ids), "tau_w": self.tau_w, "m": self.m, "I_s": self.I_s.tolist(),
                "I_m": self.I_m.tolist(), "I_F": self.I_F.tolist(), "F_pk": self.F_pk.tolist(),
                "position": self.position.tolist()}


class ExposureObserver:
    """Registry observer: Eq. (supp_slow_exposure) over the consumer's windows, accepted steps only.

    windows: the consumer's :class:`rvtool.observe.TimeWindows` or
    :class:`rvtool.observe.PhaseWindows` (fresh, not registered elsewhere);
    its exponent m is the consuming life law's.

    :meth:`completed` gives one :class:`WindowExposure` per closed, complete
    window, with tau_w = the accepted duration apportioned to it.
    """

    def __init__(self, windows):
        if not isinstance(windows, (TimeWindows, PhaseWindows)):
            raise RvtoolInputError(f"windows must be a TimeWindows or PhaseWindows (the consumer's window); got "
                                   f"{type(windows).__name__}")
        if windows.windows:
            raise RvtoolInputError("windows has already received accepted steps; valid: a fresh window object")
        self.windows = windows
        self._exclude_until = -math.inf
        self._excluded_steps = 0
        self._excluded_time = 0.0
        self._accepted_steps = 0

    def exclude_until(self, t_end_of_settling: float) -> None:
        """Drop accepted steps that start before ``t_end_of_settling`` [s] (mechanical settling)."""
        check_finite("t_end_of_settling", t_end_of_settling)
        self._exclude_until = float(t_end_of_settling)

    def on_accepted(self, step: AcceptedStep) -> None:
        if not isinstance(step, AcceptedStep):
            raise RvtoolInputError(f"step must be an AcceptedStep; got {type(step).__name__}")
        if step.t_start < self._exclude_until:
            self._excluded_steps += 1
            self._excluded_time += step.dt
            return
        self._accepted_steps += 1
        self.windows.on_accepted(step)

    @property
    def accepted_steps(self) -> int:
        """Accepted steps that entered the windows."""
        return self._accepted_steps

    @property
    def excluded_time(self) -> float:
        """Accepted duration dropped as settling [s]."""
        return self._excluded_time

    def completed(self) -> list:
        """:class:`WindowExposure` of every closed, complete window, in time order."""
        return [WindowExposure.from_accumulator(w.accumulator) for w in self.windows.closed
                if w.complete and w.duration > 0.0]

    def results(self) -> dict:
        return {"windows": [x.to_dict() for x in self.completed()], "accepted_steps": self._accepted_steps,
                "excluded_steps": self._excluded_steps, "excluded_time": self._excluded_time}
