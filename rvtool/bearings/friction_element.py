"""Bearing friction torque as a contact-identified loss element.

Every bearing of a reducer (one identity each: ``eccentric_bearing0``,
``main_bearing``, ...) carries Palmgren's friction moment M = M0 + M1
(:mod:`rvtool.bearings.friction_torque`) on its relative rotation
omega = omega_A - omega_B: the generalized force -M tanh(omega/omega_reg) on
body A and its reaction on body B. The load-dependent part M1 = f1 P1 d_m
takes P1 from the bearing's own contact rows (the radial load it carries), as
history: the load of the last accepted state, committed once per accepted
step like the friction anchors (a trial reads it, never changes it). The
moment therefore adds dQ/dv (through omega) and nothing to dQ/dq; the
one-step lag of P1 is the price of keeping the bearing force and its loss in
separate elements.

Load P1. Lumped bearings: the normal force of the bearing's own contact row
(:class:`RowLoads`). Rolling-element bearings (ball, needle, tapered:
:class:`ElementResultantLoads`): the radial resultant |sum_i Q_i n_i| of the
accepted element loads of the mounting (``resultants`` of the bearing set, the
force the elements carry between the rings), and from it Palmgren's P1 by bearing
type with the rows' declared axial preload (:mod:`rvtool.bearings.palmgren_load`;
``palmgren_load = "typed"``, the default) or the radial resultant alone
(``palmgren_load = "radial"``, the form before the correction).

Static part (``static_stiffness`` set, switchable): Palmgren's M1 is the load-
dependent part that the sources attribute to elastic hysteresis and sliding in
the contacts, present at rest; it then acts as a Coulomb torque with memory on
the relative angle phi (Jenkins element, the anchor model of Eq. (friction) in
rotation): T1 = -k_phi (phi - phi_a) while |k_phi (phi - phi_a)| <= M1 (stick),
-M1 sign(phi - phi_a) otherwise (slip), the anchor phi_a committed once per
accepted step and projected to phi -+ M1 / k_phi in slip; M0 keeps its speed law
-M0 tanh(omega/omega_reg). Without it (default) the whole M0 + M1 follows the
speed law as before, at the same cost.

The element follows the evaluator protocol of
:class:`exudyn_user_elements.contact_element.ContactElement`. Observation rows
(one per bearing, columns of :mod:`warp_contacts.circle_pairs_ref`): normal
force = P1, slip speed = omega d_m / 2, tangential force = Q / (d_m / 2), so
that the energy account's regularized-friction dissipation
-F_t v_t dt = -Q omega dt is the loss (:meth:`BearingFrictionEvaluator.energy_law`).
"""
from dataclasses import dataclass

import numpy as np

from warp_contacts import circle_pairs_ref as cref

from ..contact.evaluator import Evaluation, all_finite, check_finite_state
from ..errors import RvtoolInputError
from .friction_torque import PalmgrenFrictionTorque, friction_generalized_force, palmgren_torque
from .palmgren_load import check_mode, palmgren_load

GROUND = -1


@dataclass(frozen=True)
class BearingLoss:
    """One bearing: identity, bodies A (inner) and B (outer, or GROUND), Palmgren model and the
    rows of the bearing set's observations that carry its load."""
    name: str
    body_a: int
    body_b: int
    model: PalmgrenFrictionTorque
    load_rows: tuple


class BearingLoadHistory:
    """Committed load P1 [N] per bearing (of the last accepted state) and, with the static part,
    the anchor angle phi_a [rad] of the relative rotation."""

    def __init__(self, n, n_rows=None):
        self.load = np.zeros(n)
        self.anchor = np.zeros(n)
        # accumulated anchor travel |d phi_a| r per row [m] (static rows; the energy account's slip)
        self.slip_distance = np.zeros(n if n_rows is None else n_rows)


class RowLoads:
    """P1 of lumped bearings: the summed normal force of each bearing's ``load_rows`` in the
    observations of the bearing set ``source`` (``evaluate(pose, vel, check=False).obs``)."""

    def __init__(self, source, rows):
        self.source, self.rows = source, tuple(tuple(r) for r in rows)

    def __call__(self, pose, vel):
        src = self.source.evaluate(pose, vel, check=False).obs
        return np.array([float(np.sum(src[list(r), cref.O_FN])) for r in self.rows])


class ElementResultantLoads:
    """P1 of rolling-element bearings from the radial resultant |F_r| [N] of the element forces of each
    named mounting, ``source.resultants(pose, vel)[name].force`` (:class:`rvtool.bearings.set.BearingSet`,
    :class:`rvtool.bearings.tapered_set.TaperedBearingSet`). ``mode`` "radial": P1 = |F_r|; "typed" (needs
    ``bearings``, one per name): Palmgren's P1 by type with the rows' preload
    (:func:`rvtool.bearings.palmgren_load.palmgren_load`)."""

    def __init__(self, source, names, bearings=None, mode="radial"):
        self.source, self.names = source, tuple(names)
        self.mode = check_mode(mode)
        self.bearings = None if bearings is None else tuple(bearings)
        if mode == "typed" and (self.bearings is None or len(self.bearings) != len(self.names)):
            raise RvtoolInputError("mode = 'typed' needs one bearing per mounting name (bearings=)")

    def radial(self, pose, vel):
        """|F_r| [N] per named mounting."""
        res = self.source.resultants(pose, vel)
        return np.array([float(np.linalg.norm(res[n].force)) for n in self.names])

    def __call__(self, pose, vel):
        fr = self.radial(pose, vel)
        if self.mode == "radial":
            return fr
        return np.array([float(palmgren_load(b, f)) for b, f in zip(self.bearings, fr)])


class BearingFrictionEvaluator:
    """Palmgren friction torque of a reducer's bearings (module docstring).

    bearings: :class:`BearingLoss` per bearing; n_bodies: bodies of the element;
    load_source: the bearing set's evaluator (``evaluate(pose, vel, check=False).obs``) whose
    rows ``load_rows`` carry each bearing's radial load, or a callable (pose, vel) -> P1 per
    bearing [N] (:class:`ElementResultantLoads` for rolling-element sets).
    static_stiffness: None (M0 + M1 on the speed law), or k_phi [N m/rad] (> 0) of the static
    part's stick (module docstring).
    """

    def __init__(self, bearings, n_bodies, load_source, *, name="bearing_friction", static_stiffness=None):
        if len(bearings) == 0:
            raise RvtoolInputError("bearings must contain at least one BearingLoss")
        for i, b in enumerate(bearings):
            for nm, body in (("body_a", b.body_a), ("body_b", b.body_b)):
                if not (body == GROUND or 0 <= body < n_bodies):
                    raise RvtoolInputError(f"bearings[{i}].{nm} = {body} is outside the valid range "
                                           f"[0, {n_bodies - 1}] or GROUND")
            if not isinstance(b.model, PalmgrenFrictionTorque):
                raise RvtoolInputError(f"bearings[{i}].model must be a PalmgrenFrictionTorque")
        if static_stiffness is not None and not (np.isfinite(static_stiffness) and static_stiffness > 0):
            raise RvtoolInputError(f"static_stiffness = {static_stiffness!r} N m/rad is outside the valid range "
                                   "(0, inf) or None (no static part)")
        self.bearings = tuple(bearings)
        self.static_stiffness = None if static_stiffness is None else float(static_stiffness)
        self.loads = (RowLoads(load_source, [b.load_rows for b in self.bearings])
                      if callable(getattr(load_source, "evaluate", None)) else load_source)
        if not callable(self.loads):
            raise RvtoolInputError("load_source must be a bearing set (evaluate) or a callable (pose, vel) -> P1")
        self.name = name
        # with the static part each bearing has two rows, the speed law (M0) and the static torque (M1),
        # so that the energy account books the first as regularized friction and the second as an anchor
        self.ids = (tuple(f"{name}/{b.name}" for b in self.bearings) if self.static_stiffness is None else
                    tuple(f"{name}/{b.name}/{part}" for b in self.bearings for part in ("speed", "static")))
        self.n_bodies = int(n_bodies)
        self.load_source = load_source
        self.history = BearingLoadHistory(len(self.bearings), len(self.ids))
        self._radius = np.array([0.5 * b.model.pitch_diameter for b in self.bearings])

    def _omega(self, vel):
        v = np.vstack([np.asarray(vel, float), np.zeros((1, 3))])     # the ground row
        a = np.array([b.body_a for b in self.bearings])
        b = np.array([b.body_b for b in self.bearings])
        return v[a, 2] - v[b, 2]

    def _static(self, pose, hist):
        """Static part: (T1 [N m], dT1/dphi [N m/rad], slipping (bool), phi [rad]) per bearing."""
        phi = self._omega(pose)             # the same difference of the bodies' angles
        # M1 = f1 P1 d_m of Palmgren's law (its load derivative dM/dP1 times P1)
        M1 = np.array([float(palmgren_torque(b.model, 0.0, p)[2]) * p for b, p in zip(self.bearings, hist.load)])
        trial = -self.static_stiffness * (phi - hist.anchor)
        slip = np.abs(trial) > M1
        T1 = np.where(slip, -M1 * np.sign(phi - hist.anchor), trial)
        return T1, np.where(slip, 0.0, -self.static_stiffness), slip, phi

    def evaluate(self, pose, vel, history=None, check=True):
        """:class:`Evaluation` at poses/velocities (nb, 3) with the committed loads."""
        if check:
            check_finite_state(pose, vel, self.n_bodies)
        hist = history or self.history
        load = hist.load
        omega = self._omega(vel)
        n = 3 * self.n_bodies
        Q = np.zeros(n)
        dQdv = np.zeros((n, n))
        dQdq = np.zeros((n, n))
        obs = np.zeros((len(self.ids), cref.N_OBS))
        static = self.static_stiffness is not None
        if static:
            T1, dT1, _, _ = self._static(pose, hist)
            speed_load = np.zeros(len(self.bearings))      # M1 is the static part: the speed law carries M0
        else:
            speed_load = load
        for k, b in enumerate(self.bearings):
            q, dq_dw, _ = friction_generalized_force(b.model, omega[k], speed_load[k])
            rows = [(3 * body + 2, s) for body, s in ((b.body_a, 1.0), (b.body_b, -1.0)) if body != GROUND]
            t = T1[k] if static else 0.0
            for i, si in rows:
                Q[i] += si * (q + t)
                for j, sj in rows:
                    dQdv[i, j] += si * sj * dq_dw
                    if static:
                        dQdq[i, j] += si * sj * dT1[k]
            r = self._radius[k]
            for row, torque in (((2 * k, q), (2 * k + 1, t)) if static else ((k, q),)):
                obs[row, cref.O_FN] = load[k]
                obs[row, cref.O_VT] = omega[k] * r
                obs[row, cref.O_FT] = torque / r
        return Evaluation(Q, dQdq, dQdv, obs, (), all_finite(Q, dQdv))

    def commit(self, pose, vel, evaluation=None):
        """Observation rows at the accepted state (with the loads it was evaluated with), then
        commit that state's bearing loads for the next step."""
        obs = evaluation.obs if evaluation is not None else self.evaluate(pose, vel, check=False).obs
        if self.static_stiffness is not None:
            # anchor projection with the loads the state was evaluated with, then the new loads
            T1, _, slip, phi = self._static(pose, self.history)
            anchor = np.where(slip, phi + T1 / self.static_stiffness, self.history.anchor)
            self.history.slip_distance[1::2] += np.abs(anchor - self.history.anchor) * self._radius
            self.history.anchor = anchor
        self.history.load = np.asarray(self.loads(pose, vel), dtype=np.float64)
        return np.array(obs, float)

    def energy_law(self):
        """:class:`rvtool.observe.energy.ContactEnergyLaw` of the rows: no potential, the speed law's
        loss as a regularized friction (dissipation -F_t v_t dt); static rows as anchors at radius
        r = d_m / 2 (F_t = T1 / r, k_t = k_phi / r^2: storage T1^2 / (2 k_phi), dissipation
        |F_t| r |d phi_a| = M1 |d phi_a| in slip)."""
        from ..observe.energy import ContactEnergyLaw
        n = len(self.ids)
        model = np.full(n, cref.FRICTION_REGULARIZED, np.int32)
        kt = np.zeros(n)
        if self.static_stiffness is not None:
            model[1::2] = cref.FRICTION_ANCHOR
            kt[1::2] = self.static_stiffness / self._radius ** 2
        return ContactEnergyLaw(normal_stiffness=np.zeros(n), normal_exponent=np.ones(n), tangential_stiffness=kt,
                                friction_model=model)


def mounting_losses(mountings, factors):
    """:class:`BearingLoss` of every rolling-element mounting (``name``, ``bearing``, ``inner``, ``outer``
    of :class:`rvtool.bearings.set.Mounting` / :class:`rvtool.bearings.tapered_set.TaperedMounting`)
    with Palmgren's factors by bearing type from ``factors`` (the design's ``[bearing_friction]``:
    needle and cylindrical roller -> f0_needle, f1_needle; ball and angular-contact pair -> f0_ball,
    f1_ball; tapered row or pair -> f0_tapered, f1_tapered), d_m the bearing's (first row's)
    pitch diameter. The loads are those of :class:`ElementResultantLoads` (no rows)."""
    from .spec import AngularContactPair, BallBearing, CylindricalRollerBearing
    from .tapered import TaperedPair, TaperedRollerBearing
    out = []
    for m in mountings:
        b = m.bearing
        if isinstance(b, CylindricalRollerBearing):
            f0, f1, dm = factors.f0_needle, factors.f1_needle, b.pitch_diameter
        elif isinstance(b, (BallBearing, AngularContactPair)):
            f0, f1 = factors.f0_ball, factors.f1_ball
            dm = (b.rows[0] if isinstance(b, AngularContactPair) else b).pitch_diameter
        elif isinstance(b, (TaperedRollerBearing, TaperedPair)):
            f0, f1 = factors.f0_tapered, factors.f1_tapered
            dm = (b.rows[0] if isinstance(b, TaperedPair) else b).pitch_diameter
        else:
            raise RvtoolInputError(f"mounting {m.name!r}: bearing type {type(b).__name__} has no Palmgren factors; "
                                   "valid: needle/cylindrical roller, ball, angular-contact pair, tapered")
        model = PalmgrenFrictionTorque(f0=f0, f1=f1, pitch_diameter=dm, kinematic_viscosity=factors.kinematic_viscosity,
                                       regularization_speed=factors.regularization_speed)
        out.append(BearingLoss(m.name, m.inner, m.outer, model, ()))
    return out


def rolling_friction_evaluator(bearing_set, factors, *, name="bearing_friction"):
    """Palmgren friction of every mounting of a rolling-element set (:func:`mounting_losses`), P1 from
    the accepted element loads (:class:`ElementResultantLoads`, the form ``factors.palmgren_load``:
    "typed" or "radial"); ``factors.static_stiffness`` switches the static part."""
    losses = mounting_losses(bearing_set.mountings, factors)
    loads = ElementResultantLoads(bearing_set, [b.name for b in losses], [m.bearing for m in bearing_set.mountings],
                                  mode=factors.palmgren_load)
    return BearingFrictionEvaluator(losses, bearing_set.n_bodies, loads, name=name,
                                    static_stiffness=factors.static_stiffness)
