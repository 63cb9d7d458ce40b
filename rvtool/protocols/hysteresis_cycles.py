"""Hysteresis protocol with friction: repeated signed torque cycles until the loop closes and repeats.

Paper, Section "Observation": "∮T dθ is interpreted as cycle dissipation only
after closure and repeatability have been established". The protocol is data
(:class:`CycleSequence`): a virgin preload from zero to -T_rated, then
``n_cycles`` identical cycles -T_rated -> +T_rated -> -T_rated whose levels are
symmetric about zero torque (the same fractions on every branch, the +-3 %
lost-motion levels included, and no level at exactly zero torque: there the
clearances are free play and the static regularization springs, a numerical
setting, centre the output; the loop's zero-torque width is extrapolated along
each unloading branch from its own side, :mod:`rvtool.protocols.catalogue`). After the virgin preload every
reversal starts from a reversal point, so a rate-independent friction loop
(Masing) repeats from the first cycle on; the second cycle is compared with the
first.

Path (b), :func:`quasi_static_cycles`: one equilibrium continuation
(:class:`rvtool.solver.continuation.Continuation`) through all levels, the
contact history committed once per converged level, and the energy account
(:class:`rvtool.observe.energy.EnergyAccount`) sampled at every committed
level, so friction dissipation per family comes from the committed anchors
only.

Post-processing (:func:`catalogue_figures`): the catalogue figures of a
precision reducer from one closed cycle -- hysteresis loss (loop width at zero
torque along the unloading branches, :func:`rvtool.protocols.catalogue.hysteresis_loss`), lost motion
(the catalogue's midpoint definition: the angle between the midpoints of the
loop's width at +3 % and at -3 % of rated torque), the four branch fits of
Eq. (stiffness_fit) over 50-100 % of rated torque and ∮T dθ.
"""
import time
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..solver.continuation import Continuation
from ..units import RAD_PER_ARCMIN
from ..validation import check_positive, check_range
from . import hysteresis as H
from . import stiffness as S


@dataclass(frozen=True, kw_only=True)
class CycleSequence:
    """Signed torque cycles of the hysteresis protocol.

    rated_torque: T_rated [N m]. step: level spacing on every branch [fraction of
    T_rated]. fine_levels: extra low-torque levels on every branch [fraction]
    (default the +-3 % lost-motion level; levels near zero resolve the free-play
    crossing, where the loop's trapezoidal ∮T dθ has its largest quadrature error).
    n_cycles: cycles after the preload (>= 2: the last is compared with the one before).
    ramp_steps, dwell_steps, reset_interval, tail_fraction, settle_span_arcmin: the
    time-domain settings of path (a), as in
    :class:`rvtool.protocols.stiffness.TorqueSequence` (the sequence runs through
    :func:`rvtool.protocols.stiffness.dynamic_stiffness` unchanged).
    """
    rated_torque: float
    step: float = 0.0625
    fine_levels: tuple = (0.03,)
    n_cycles: int = 2
    ramp_steps: int = 10
    dwell_steps: int = 50
    reset_interval: int = 25
    tail_fraction: float = 0.25
    settle_span_arcmin: float = 0.5

    def __post_init__(self):
        check_positive("rated_torque", self.rated_torque)
        check_range("step", self.step, 0.0, 1.0, low_open=True)
        for f in self.fine_levels:
            check_range("fine_levels", f, 0.0, 1.0, low_open=True, high_open=True)
        if not isinstance(self.n_cycles, (int, np.integer)) or self.n_cycles < 2:
            raise RvtoolInputError(f"n_cycles = {self.n_cycles!r} is outside the valid range [2, inf) (an integer): "
                                   "repeatability compares a cycle with its predecessor")
        check_range("tail_fraction", self.tail_fraction, 0.0, 1.0, low_open=True)
        check_positive("settle_span_arcmin", self.settle_span_arcmin)
        if self.ramp_steps < 1 or self.dwell_steps < 1 or self.reset_interval < 1:
            raise RvtoolInputError(f"ramp_steps = {self.ramp_steps}, dwell_steps = {self.dwell_steps}, "
                                   f"reset_interval = {self.reset_interval}; each must be >= 1")

    def fractions(self):
        """Positive level fractions in increasing order (no zero, 1 included)."""
        f = set(np.round(np.arange(self.step, 1.0 + 1e-9, self.step), 10)) | set(self.fine_levels) | {1.0}
        return np.array(sorted(f))

    def cycle(self):
        """(fractions, branch labels) of one cycle from -1 to -1: negative unloading, positive
        loading, positive unloading, negative loading (the closing -1 ends it)."""
        f = self.fractions()
        neg_unl = list(-f[::-1])                         # -1 ... -f_min
        pos_load = list(f)                               # f_min ... 1
        pos_unl = list(f[::-1][1:])                      # 1 - step ... f_min
        neg_load = list(-f)                              # -f_min ... -1
        levels = neg_unl + pos_load + pos_unl + neg_load
        labels = (["neg_unloading"] * len(neg_unl) + ["pos_loading"] * len(pos_load) +
                  ["pos_unloading"] * len(pos_unl) + ["neg_loading"] * len(neg_load))
        return np.array(levels), labels

    def preload(self):
        """Virgin preload fractions from zero to -1 (the first reversal point)."""
        return np.concatenate([[0.0], -self.fractions()])

    def levels(self):
        """(torques [N m], labels) of the whole protocol: the preload (label "preload") and the
        cycles, the interface of :func:`rvtool.protocols.stiffness.dynamic_stiffness`."""
        fr, labels = self.cycle()
        pre = self.preload()
        f = np.concatenate([pre] + [fr] * self.n_cycles)
        return f * self.rated_torque, ["preload"] * len(pre) + labels * self.n_cycles

    def split(self, values):
        """Per-level values of :meth:`levels` (e.g. angles of a path) -> one array per cycle."""
        n_pre, n_cyc = len(self.preload()), len(self.cycle()[0])
        values = np.asarray(values)
        return [values[n_pre + c * n_cyc:n_pre + (c + 1) * n_cyc] for c in range(self.n_cycles)]


@dataclass(frozen=True)
class CatalogueFigures:
    """Catalogue figures of one closed cycle: hysteresis loss and lost motion [arcmin], branch
    fits (:func:`rvtool.protocols.stiffness.branch_fits`) and ∮T dθ [J]."""
    hysteresis_loss_arcmin: float
    lost_motion_arcmin: float
    branch_fits: dict
    loop_integral_J: float


def midpoint_lost_motion(torque, angle, labels, rated_torque, fraction=0.03):
    """Lost motion [angle units]: the catalogue's definition,
    :func:`rvtool.protocols.catalogue.lost_motion` (the angle between the mid-points of the loop's
    width at +fraction and at -fraction of T_rated)."""
    from . import catalogue as C
    try:
        return C.lost_motion(torque, angle, labels, rated_torque=rated_torque, fraction=fraction)
    except RvtoolInputError as exc:
        raise RvtoolInputError(f"lost motion needs a loading and an unloading level at +-{fraction:g} T_rated: "
                               f"{exc}") from None


def catalogue_figures(torque, angle_rad, labels, rated_torque):
    """:class:`CatalogueFigures` of one cycle (torque [N m], output angle [rad], branch labels): the
    hysteresis loss and lost motion by the catalogue's definitions (:mod:`rvtool.protocols.catalogue`:
    the zero-torque width along the unloading branches, each extrapolated from its own side, the
    clearance included; never interpolated across the free play)."""
    from . import catalogue as C
    cyc = H.Cycle(torque=np.asarray(torque, float), angle=np.asarray(angle_rad, float))
    arcmin = cyc.angle / RAD_PER_ARCMIN
    return CatalogueFigures(C.hysteresis_loss(cyc.torque, cyc.angle, labels).value / RAD_PER_ARCMIN,
                            midpoint_lost_motion(cyc.torque, arcmin, labels, rated_torque),
                            S.branch_fits(cyc.torque, arcmin, labels, rated_torque), H.loop_integral(cyc))


def loop_quadrature_bound(cycle):
    """Error bound [J] of the trapezoidal ∮T dθ of a :class:`rvtool.protocols.hysteresis.Cycle`
    on its levels: on every interval that crosses zero torque the free play leaves T(θ)
    unresolved, and the exact work lies within max(|T_a|, |T_b|) |Δθ| of the trapezoid; on the
    loaded branches the trapezoid's error is estimated from the same loop on every second level
    (|L_h - L_2h|, three times the O(h^2) error of L_h)."""
    T, th = cycle.torque, cycle.angle
    T2, th2 = np.append(T, T[0]), np.append(th, th[0])
    cross = T2[:-1] * T2[1:] < 0
    crossing = float(np.sum(np.maximum(np.abs(T2[:-1]), np.abs(T2[1:]))[cross] * np.abs(np.diff(th2))[cross]))
    coarse = H.Cycle(torque=T[::2], angle=th[::2])
    return crossing + abs(H.loop_integral(cycle) - H.loop_integral(coarse))


def energy_laws(model):
    """{element name: ContactEnergyLaw} of the model's contact families that declare one
    (circle-pair sets are read by the account itself)."""
    return {el.name: el.evaluator.energy_law() for el in model.contact_elements()
            if hasattr(el.evaluator, "energy_law")}


def quasi_static_cycles(model, sequence: CycleSequence, *, input_angle=0.0, energy=True):
    """Path (b): the preload and the cycles as one equilibrium continuation with per-level
    history commits. Returns a dict: per cycle the torque [N m], output angle [rad] (from its
    kinematic position) and labels; the energy account's results and its friction dissipation
    per family accumulated over each cycle [J]; continuation statistics and wall time [s]."""
    from ..observe.energy import EnergyAccount
    t0 = time.perf_counter()
    rated = sequence.rated_torque
    cont = Continuation(model, input_angle=input_angle)
    i_out = model.output_index
    th_kin = model.kinematic_output(input_angle)
    account = EnergyAccount(model.mbs, model.contact_elements(), laws=energy_laws(model)) if energy else None

    def level(torque, first=False):
        q = cont.go_to(float(torque))
        if account is not None:
            v = np.zeros_like(q)
            (account.start if first else account.accept)(0.0, q, v)
        return (q[i_out] - th_kin)

    for k, f in enumerate(sequence.preload()):
        level(f * rated, first=(k == 0))
    fr, labels = sequence.cycle()
    cycles = []
    for c in range(sequence.n_cycles):
        d0 = dict(account.friction) if account is not None else {}
        angles = [level(f * rated) for f in fr]
        d1 = dict(account.friction) if account is not None else {}
        cycles.append({"torque_Nm": fr * rated, "angle_rad": np.array(angles), "labels": labels,
                       "friction_dissipation_J": {k: d1[k] - d0.get(k, 0.0) for k in d1}})
    return {"cycles": cycles, "energy": account.results() if account is not None else None,
            "stats": cont.stats.to_dict(), "q_final": cont.q, "wall_s": time.perf_counter() - t0}


def closed_cycle(previous, cycle, *, angle_tolerance, torque_tolerance=1e-9):
    """:func:`rvtool.protocols.hysteresis.cycle_dissipation` of two consecutive cycles (dicts of
    :func:`quasi_static_cycles`): ∮T dθ admitted as dissipation once the cycle closes and repeats
    its predecessor within ``angle_tolerance`` [rad]."""
    a = H.Cycle(torque=previous["torque_Nm"], angle=previous["angle_rad"])
    b = H.Cycle(torque=cycle["torque_Nm"], angle=cycle["angle_rad"])
    return H.cycle_dissipation(a, b, angle_tolerance=angle_tolerance, torque_tolerance=torque_tolerance)
