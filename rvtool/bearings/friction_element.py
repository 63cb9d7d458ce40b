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

from ..contact.evaluator import Evaluation, all_finite
from ..errors import RvtoolInputError
from .friction_torque import PalmgrenFrictionTorque, friction_generalized_force

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
    """Committed load P1 [N] per bearing (of the last accepted state)."""

    def __init__(self, n):
        self.load = np.zeros(n)


class BearingFrictionEvaluator:
    """Palmgren friction torque of a reducer's bearings (module docstring).

    bearings: :class:`BearingLoss` per bearing; n_bodies: bodies of the element;
    load_source: the bearing set's evaluator (``evaluate(pose, vel, check=False).obs``) whose
    rows ``load_rows`` carry each bearing's radial load.
    """

    def __init__(self, bearings, n_bodies, load_source, *, name="bearing_friction"):
        if len(bearings) == 0:
            raise RvtoolInputError("bearings must contain at least one BearingLoss")
        for i, b in enumerate(bearings):
            for nm, body in (("body_a", b.body_a), ("body_b", b.body_b)):
                if not (body == GROUND or 0 <= body < n_bodies):
                    raise RvtoolInputError(f"bearings[{i}].{nm} = {body} is outside the valid range "
                                           f"[0, {n_bodies - 1}] or GROUND")
            if not isinstance(b.model, PalmgrenFrictionTorque):
                raise RvtoolInputError(f"bearings[{i}].model must be a PalmgrenFrictionTorque")
        self.bearings = tuple(bearings)
        self.name = name
        self.ids = tuple(f"{name}/{b.name}" for b in self.bearings)
        self.n_bodies = int(n_bodies)
        self.load_source = load_source
        self.history = BearingLoadHistory(len(self.bearings))
        self._radius = np.array([0.5 * b.model.pitch_diameter for b in self.bearings])

    def _omega(self, vel):
        v = np.vstack([np.asarray(vel, float), np.zeros((1, 3))])     # the ground row
        a = np.array([b.body_a for b in self.bearings])
        b = np.array([b.body_b for b in self.bearings])
        return v[a, 2] - v[b, 2]

    def evaluate(self, pose, vel, history=None, check=True):
        """:class:`Evaluation` at poses/velocities (nb, 3) with the committed loads."""
        if check:
            for nm, arr in (("pose", pose), ("vel", vel)):
                a = np.asarray(arr)
                if a.shape != (self.n_bodies, 3) or not np.all(np.isfinite(a)):
                    raise RvtoolInputError(f"{nm} must be a finite array of shape ({self.n_bodies}, 3); got {a.shape}")
        load = (history or self.history).load
        omega = self._omega(vel)
        n = 3 * self.n_bodies
        Q = np.zeros(n)
        dQdv = np.zeros((n, n))
        obs = np.zeros((len(self.bearings), cref.N_OBS))
        for k, b in enumerate(self.bearings):
            q, dq_dw, _ = friction_generalized_force(b.model, omega[k], load[k])
            rows = [(3 * body + 2, s) for body, s in ((b.body_a, 1.0), (b.body_b, -1.0)) if body != GROUND]
            for i, si in rows:
                Q[i] += si * q
                for j, sj in rows:
                    dQdv[i, j] += si * sj * dq_dw
            obs[k, cref.O_FN] = load[k]
            obs[k, cref.O_VT] = omega[k] * self._radius[k]
            obs[k, cref.O_FT] = q / self._radius[k]
        return Evaluation(Q, np.zeros((n, n)), dQdv, obs, (), all_finite(Q, dQdv))

    def commit(self, pose, vel, evaluation=None):
        """Observation rows at the accepted state (with the loads it was evaluated with), then
        commit that state's bearing loads for the next step."""
        obs = evaluation.obs if evaluation is not None else self.evaluate(pose, vel, check=False).obs
        src = self.load_source.evaluate(pose, vel, check=False).obs
        self.history.load = np.array([float(np.sum(src[list(b.load_rows), cref.O_FN])) for b in self.bearings])
        return np.array(obs, float)

    def energy_law(self):
        """:class:`rvtool.observe.energy.ContactEnergyLaw` of the rows: no potential, the loss as
        a regularized friction (dissipation -F_t v_t dt)."""
        from ..observe.energy import ContactEnergyLaw
        n = len(self.bearings)
        return ContactEnergyLaw(normal_stiffness=np.zeros(n), normal_exponent=np.ones(n),
                                tangential_stiffness=np.zeros(n),
                                friction_model=np.full(n, cref.FRICTION_REGULARIZED, np.int32))
