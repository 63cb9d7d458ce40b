"""Alternation of mechanical windows and slow updates on separate time scales.

Three clocks are kept apart (appendix "Slow-process models and feedback
protocols"): the mechanical window tau_w (accepted duration of the exposure
window a model run returns), the thermal interval Delta tau_T (implicit steps
of Eq. (obs_thermal)) and the represented service interval Delta tau_service
(the service time one update stands for, s = Delta tau_service / tau_w in
Eq. (obs_wear) and Eq. (obs_damage)). One update:

1. after the previous update's offsets were written, ``settling_windows``
   mechanical windows are run and discarded (a geometry-update transient is
   not a stationary load spectrum);
2. one exposure window at the current slow state gives I_s, I_m, I_F;
3. lubrication (if configured) evaluates eta(T), h_min, lambda and mu at the
   temperatures at the start of the update;
4. wear of Eq. (obs_wear) with k_w(lambda), limited on its largest contact
   increment; the limiter factor scales the represented service interval,
   and every other process advances over the same scaled interval (one
   common service-time account);
5. the thermal network is marched over that interval in steps Delta tau_T
   with the window's mean sources mu I_s / tau_w (mu: the coefficient the
   window ran with);
6. fatigue damage of Eq. (obs_damage) accumulates over the interval
   (downstream only);
7. thermal gap offsets, the wear offsets and (coupled lubrication) mu per
   contact are written for the next window through ``apply_offsets``.

The mechanical model is anything implementing :class:`MechanicalWindows`,
so the reducer model plugs in where the tests use a stand-in.
"""
import math
from dataclasses import dataclass, field
from enum import Enum
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_positive
from .exposure import WindowExposure
from .fatigue import ForceLifeLaw
from .lubrication import Lubrication
from .offsets import GapOffsets
from .thermal import SlidingLossSources, ThermalNetwork, thermal_gap_offsets
from .wear import SurfaceWear, WearModel, limit_single_channel

#: Relative tolerance at which the represented service time counts as reached (round-off of the interval sums).
SERVICE_TIME_REL_TOL = 1e-12


@dataclass(frozen=True, kw_only=True, eq=False)
class SlowState:
    """What a mechanical window runs at.

    update: index of the coming update. service_time: represented service
    time so far [s]. temperature: node -> T [K] (empty without a thermal
    model). offsets: gap offsets in force [m]. friction: id -> mu written by
    coupled lubrication, or None (declared friction).
    """
    update: int
    service_time: float
    temperature: dict
    offsets: GapOffsets
    friction: dict | None


@runtime_checkable
class MechanicalWindows(Protocol):
    """The mechanical model as the orchestrator sees it."""

    def run_window(self, state: SlowState) -> WindowExposure:
        """Run one mechanical window at ``state`` and return its accepted-step exposure."""
        ...

    def apply_offsets(self, offsets: GapOffsets, friction: dict | None) -> None:
        """Write the gap offsets [m] (totals per channel, not increments) and, where given, mu per
        contact for the next contact evaluation."""
        ...


class LubricationMode(str, Enum):
    OBSERVE = "observe"   # h_min, lambda, mu are outputs only (k_w(lambda) still uses lambda)
    COUPLED = "coupled"   # mu per contact is written for the next window


@dataclass(frozen=True, kw_only=True)
class SlowSchedule:
    """Time scales and limits of the slow loop.

    service_time: represented service time to cover [s] (> 0).
    service_interval: Delta tau_service per update before limiting [s] (> 0).
    thermal_interval: Delta tau_T [s] (> 0).
    max_wear_increment: single-channel limit on the largest contact wear
    increment [m] (> 0), or None (no limiter).
    settling_windows: windows discarded after each offset update (>= 0).
    max_updates: refuse to run more updates than this (a limiter set too tight).
    """
    service_time: float
    service_interval: float
    thermal_interval: float
    max_wear_increment: float | None = None
    settling_windows: int = 1
    max_updates: int = 10_000

    def __post_init__(self):
        for name in ("service_time", "service_interval", "thermal_interval"):
            check_finite(name, getattr(self, name))
            check_positive(name, getattr(self, name))
        if self.max_wear_increment is not None:
            check_finite("max_wear_increment", self.max_wear_increment)
            check_positive("max_wear_increment", self.max_wear_increment)
        for name, low in (("settling_windows", 0), ("max_updates", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                raise RvtoolInputError(f"{name} = {v!r} is outside the valid range: integers in [{low}, inf)")


@dataclass(frozen=True, kw_only=True, eq=False)
class ThermalCoupling:
    """network, its sliding-loss sources, the gap channels and the initial temperatures [K] (node -> T)."""
    network: ThermalNetwork
    sources: SlidingLossSources
    channels: tuple = ()
    initial_temperature: dict = field(default_factory=dict)

    def initial(self) -> np.ndarray:
        T = np.full(len(self.network.nodes), self.network.ambient_temperature)
        for node, value in self.initial_temperature.items():
            T[self.network.index(node)] = value
        check_finite("initial_temperature", T)
        check_positive("initial_temperature", T)
        return T


@dataclass(frozen=True, kw_only=True, eq=False)
class FatigueCoupling:
    """Force--life law and the stress-cycle rate nu_c [1/s] (one value or one per contact id, in window order)."""
    law: ForceLifeLaw
    cycle_rate: object


@dataclass(frozen=True, kw_only=True, eq=False)
class UpdateRecord:
    """One slow update: represented service interval [s] and its limiter factor, largest contact wear
    increment [m], temperatures [K], largest accumulated damage [-], windows discarded as settling."""
    update: int
    service_time_start: float
    service_interval: float
    limiter_factor: float
    max_wear_increment: float
    temperature: dict
    max_damage: float
    settling_windows: int


@dataclass(frozen=True, kw_only=True, eq=False)
class SlowRunResult:
    """service_time [s]; records: per update; wear_depth: bin -> depth [m]; contact_wear: id -> gap offset
    of the wear channel [m]; damage: id -> D [-]; temperature: node -> T [K]; offsets: the last written;
    friction: the last written mu (coupled lubrication) or None; film: the last FilmState or None;
    limiter_steps: updates whose interval the limiter shortened; windows_run, windows_discarded."""
    service_time: float
    records: tuple
    wear_depth: dict
    contact_wear: dict
    damage: dict
    temperature: dict
    offsets: GapOffsets
    friction: dict | None
    film: object
    limiter_steps: int
    windows_run: int
    windows_discarded: int


class SlowOrchestrator:
    """Runs :class:`SlowSchedule` on a :class:`MechanicalWindows` model with the configured processes.

    wear: :class:`rvtool.slow.wear.WearModel` or None. thermal:
    :class:`ThermalCoupling` or None. lubrication: :class:`Lubrication` or
    None, with ``lubrication_mode``. fatigue: :class:`FatigueCoupling` or None.
    """

    def __init__(self, model, schedule: SlowSchedule, *, wear: WearModel | None = None,
                 thermal: ThermalCoupling | None = None, lubrication: Lubrication | None = None,
                 lubrication_mode: LubricationMode = LubricationMode.OBSERVE, fatigue: FatigueCoupling | None = None):
        if not isinstance(model, MechanicalWindows):
            raise RvtoolInputError(f"model must implement run_window(state) and apply_offsets(offsets, friction); "
                                   f"got {type(model).__name__}")
        if not isinstance(schedule, SlowSchedule):
            raise RvtoolInputError(f"schedule must be a SlowSchedule; got {type(schedule).__name__}")
        if lubrication is not None and thermal is None:
            raise RvtoolInputError("lubrication needs a thermal model for eta(T); valid: thermal=ThermalCoupling(...)")
        if lubrication is not None:
            missing = lubrication.nodes() - set(thermal.network.nodes)
            if missing:
                raise RvtoolInputError(f"lubrication contacts name thermal nodes {sorted(missing)} that the network "
                                       f"lacks; valid: {list(thermal.network.nodes)}")
        try:
            lubrication_mode = LubricationMode(lubrication_mode)
        except ValueError:
            raise RvtoolInputError(f"lubrication_mode = {lubrication_mode!r} is not one of the valid choices "
                                   f"{[m.value for m in LubricationMode]}") from None
        self.model, self.schedule = model, schedule
        self.wear, self.thermal, self.lubrication, self.fatigue = wear, thermal, lubrication, fatigue
        self.lubrication_mode = lubrication_mode

    def _exposure(self, state):
        x = self.model.run_window(state)
        if not isinstance(x, WindowExposure):
            raise RvtoolInputError(f"run_window must return a WindowExposure; got {type(x).__name__}")
        return x

    def run(self) -> SlowRunResult:
        sch = self.schedule
        surface = SurfaceWear()
        T = self.thermal.initial() if self.thermal is not None else None
        nodes = self.thermal.network.nodes if self.thermal is not None else ()
        damage, records = {}, []
        offsets, friction, film = GapOffsets.none(), None, None
        service, runs, discarded, written = 0.0, 0, 0, False
        target = sch.service_time
        while service < target * (1.0 - SERVICE_TIME_REL_TOL):
            k = len(records)
            if k >= sch.max_updates:
                raise RvtoolInputError(f"max_updates = {sch.max_updates} reached at service time {service:.6g} s of "
                                       f"{target:.6g} s; valid: a larger max_updates or max_wear_increment")
            temps = {} if T is None else dict(zip(nodes, T.tolist()))
            state = SlowState(update=k, service_time=service, temperature=temps, offsets=offsets, friction=friction)
            settle = sch.settling_windows if written else 0
            for _ in range(settle):
                self._exposure(state)
            exposure = self._exposure(state)
            runs += settle + 1
            discarded += settle
            interval = min(sch.service_interval, target - service)
            factor, max_inc = 1.0, 0.0
            if self.lubrication is not None:
                film = self.lubrication.evaluate(exposure, temps)
            if self.wear is not None:
                inc = self.wear.increment(exposure, interval, None if film is None else film.lambdas())
                if sch.max_wear_increment is not None:
                    inc = limit_single_channel(inc, sch.max_wear_increment)
                factor, interval, max_inc = inc.factor, inc.service_interval, inc.max_increment
                surface.apply(inc)
            if self.thermal is not None:
                th = self.thermal
                Q = th.sources.node_sources(exposure, th.network, friction)
                T = th.network.march(T, Q, interval, sch.thermal_interval)
            if self.fatigue is not None:
                dD = self.fatigue.law.damage_increment(exposure, self.fatigue.cycle_rate, interval)
                for cid, d in zip(exposure.ids, dD):
                    damage[cid] = damage.get(cid, 0.0) + float(d)
            records.append(UpdateRecord(update=k, service_time_start=service, service_interval=interval,
                                        limiter_factor=factor, max_wear_increment=max_inc,
                                        temperature={} if T is None else dict(zip(nodes, T.tolist())),
                                        max_damage=max(damage.values(), default=0.0), settling_windows=settle))
            service += interval
            offsets = GapOffsets.none()
            if self.thermal is not None and self.thermal.channels:
                offsets = offsets.merged(thermal_gap_offsets(self.thermal.channels, self.thermal.network, T))
            if self.wear is not None:
                offsets = offsets.merged(surface.offsets())
            if film is not None and self.lubrication_mode is LubricationMode.COUPLED:
                friction = film.friction()
            self.model.apply_offsets(offsets, friction)
            written = True
        return SlowRunResult(service_time=service, records=tuple(records), wear_depth=dict(surface.depth),
                             contact_wear={c: v for c, v in surface.offsets().by_channel.get("wear", {}).items()},
                             damage=damage, temperature={} if T is None else dict(zip(nodes, T.tolist())),
                             offsets=offsets, friction=friction, film=film,
                             limiter_steps=sum(r.limiter_factor < 1.0 for r in records), windows_run=runs,
                             windows_discarded=discarded)


def represented_service_time(records) -> float:
    """Sum of the represented service intervals of ``records`` [s] (the limiter's conserved account)."""
    return math.fsum(r.service_interval for r in records)
