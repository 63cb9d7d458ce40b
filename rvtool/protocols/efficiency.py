"""Efficiency by quasi-static energy accounting (issue 30, Deliver 2, first part): the power lost per
family at a loaded static state driven at a steady input speed.

At the frictionless static equilibrium q of the output torque T (input held at the angle), the
bodies move at their kinematic velocities v = (dq_kin/d theta_in) omega_in (the gear graph's rates;
the rate of the elastic deflection along the angle is neglected: a TE-order correction). The losses
are then, per family:

- **sliding contacts** (cycloid--pin meshes, involute meshes): sum over the contact rows of
  mu F_n |v_t|, the normal force at the static state (zero velocities: no contact damping) and the
  tangential relative speed the contact set observes at (q, v) (columns ``O_FN``, ``O_VT`` of :mod:`warp_contacts.circle_pairs_ref`); for the ring pins
  |v_t| is the wheel's sliding on a held pin, or equally the pin's turning in its groove at the
  same surface speed (the loss is mu F |v_t| at whichever interface slips, with its mu);
- **rolling bearings** (needle, tapered crank rows, main bearing): Palmgren's moment
  M(|omega_rel|, P1) |omega_rel| (:mod:`rvtool.bearings.friction_torque`, the design's
  ``[bearing_friction]`` factors whatever its ``model`` switch), P1 Palmgren's load by bearing type from
  the mounting's radial resultant at q and its rows' preload (``bearing_friction.palmgren_load``,
  :mod:`rvtool.bearings.palmgren_load`), omega_rel the relative rotation speed of its rings.

The output power is P_out = |T omega_out|, the input power P_in = P_out + sum of the losses, and the
efficiency eta = P_out / P_in (friction forces do not change the loads here: first order in mu).
The identity checked with the losses off: the frictionless input power (the drive's torque at q
times omega_in) equals P_out (:func:`power_balance_error`, the kinematic velocities and the static
state consistent) on the mean over a mesh period. At a single angle the two differ by the rate of
change of the stored elastic energy along the motion (the quasi-static torque ripple: 2e-5 to 4e-3
of P_out on rv40e at T_R), which is periodic and averages out over equally spaced angles of one
period (``input_angles``).

Not included (issue 30, item 2): seals and grease churning (the no-load running torque's
``assumed`` parts), the low-load and temperature corrections, the catalogue comparison, and the
friction forces' effect on the loads (the frictionless static state is used).
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_positive

SLIDING_ELEMENTS = ("pins", "gears")
ROLLING_ELEMENTS = ("eccentric_bearings", "crank_bearings", "main_bearings")


@dataclass(frozen=True, kw_only=True)
class SlidingFriction:
    """Sliding friction coefficients [-] per sliding family. Defaults ``assumed``: lubricated
    steel--steel in mixed lubrication, literature range 0.03-0.08 (the project's friction cases use
    0.05); not tuned to any catalogue efficiency."""
    pins: float = 0.05
    gears: float = 0.05

    def __post_init__(self):
        check_nonnegative("sliding_friction.pins", self.pins)
        check_nonnegative("sliding_friction.gears", self.gears)


def kinematic_velocity(model, input_angle, input_speed):
    """Global ODE2 velocity vector [m/s, rad/s] of the kinematic motion at ``input_speed`` [rad/s]."""
    return model.body_vector(model.kinematic_state(input_angle, input_speed).velocities)


def _element_state(el, q, v):
    return el.pose_velocity(el.local(q), el.local(v))


def sliding_losses(model, q, v, friction: SlidingFriction):
    """{element: mu sum |F_n| |v_t| [W]} of the sliding families at state q, velocities v."""
    out = {}
    for name in SLIDING_ELEMENTS:
        el = model.elements[name]
        pose, vel = _element_state(el, q, v)
        # the normal force of the static state (no contact damping from the approach rates), the
        # tangential speed of the motion
        fn = el.evaluator.evaluate(pose, 0 * vel, check=False).obs[:, 0]
        vt = el.evaluator.evaluate(pose, vel, check=False).obs[:, 1]
        out[name] = float(getattr(friction, name) * np.sum(np.abs(vt) * np.maximum(fn, 0.0)))
    return out


def rolling_losses(model, q, v):
    """{element: sum over its mountings of M |omega_rel| [W]} (Palmgren, module docstring)."""
    from ..bearings.friction_element import ElementResultantLoads, mounting_losses
    from ..bearings.friction_torque import palmgren_torque
    from ..bearings.set import BearingSet
    from ..bearings.tapered_set import TaperedBearingSet
    factors = model.design.bearing_friction
    out = {}
    for name in ROLLING_ELEMENTS:
        el = model.elements[name]
        bset = el.evaluator
        if not isinstance(bset, (BearingSet, TaperedBearingSet)):
            raise RvtoolInputError(f"efficiency: element {name!r} is not a plain rolling-bearing set (elastic crank "
                                   "bending or torsion on?); valid: cranks.shaft.model = 'rigid', torsion = 'rigid'")
        losses = mounting_losses(bset.mountings, factors)
        pose, vel = _element_state(el, q, v)
        P1 = ElementResultantLoads(bset, [b.name for b in losses], [mt.bearing for mt in bset.mountings],
                                   mode=factors.palmgren_load)(pose, vel)
        total = 0.0
        for b, p in zip(losses, P1):
            wa = vel[b.body_a, 2] if b.body_a >= 0 else 0.0
            wb = vel[b.body_b, 2] if b.body_b >= 0 else 0.0
            w = abs(wa - wb)
            M = float(palmgren_torque(b.model, w, p)[0])
            total += M * w
        out[name] = total
    return out


def power_balance_error(model, q, v):
    """(|P_in - P_out| / P_out, P_in, P_out) [W] of the frictionless state: the drive's power (its
    torque, minus the contacts' generalized force on the input, times omega_in) against the power
    delivered to the load (the contacts' generalized force on the output times omega_out). At an
    equilibrium the contacts do no net work along a rigid-body motion of the mechanism; what is left
    is the work of the regularization springs and the turn of the loaded contacts' lever arms with the
    elastic deflection (1e-5 relative on rv40e at T_R)."""
    i_in, i_out = model.input_index, model.output_index
    P_in = model.input_torque(q) * v[i_in]
    Q_out = sum(float(el.evaluation_at(q).Q[np.flatnonzero(el.coordinate_indices == i_out)[0]])
                for el in model.contact_elements() if np.any(el.coordinate_indices == i_out))
    P_out = Q_out * v[i_out]
    return abs(P_in - P_out) / abs(P_out), P_in, P_out


def efficiency(model, torque, input_speeds_rpm, *, friction=SlidingFriction(), input_angles=(0.0,)):
    """Efficiency over ``input_speeds_rpm`` at output torque ``torque`` [N m] (module docstring):
    per speed eta, P_in, P_out [W] and the loss per family, averaged over ``input_angles`` [rad]
    (static states solved once per angle)."""
    from ..solver.static import StaticSolver
    check_positive("torque", abs(torque))
    speeds = np.atleast_1d(np.asarray(input_speeds_rpm, float))
    for s in speeds:
        check_positive("input_speed_rpm", s)
    model.set_output_torque(-np.sign(model.ratio) * abs(torque))
    solver = StaticSolver(model)
    states = []
    prev = None
    for a in input_angles:
        q = solver.solve(float(a), previous_angle=prev)
        prev = float(a)
        states.append((float(a), q.copy()))
    rows = []
    for rpm in speeds:
        w_in = rpm * 2 * np.pi / 60.0
        fam, p_out, imbalance, worst = {}, 0.0, 0.0, 0.0
        for a, q in states:
            v = kinematic_velocity(model, a, w_in)
            err, P_in, P_out = power_balance_error(model, q, v)
            worst = max(worst, err)
            imbalance += (abs(P_in) - abs(P_out)) / len(states)
            p_out += abs(P_out) / len(states)
            for k, val in {**sliding_losses(model, q, v, friction), **rolling_losses(model, q, v)}.items():
                fam[k] = fam.get(k, 0.0) + val / len(states)
        loss = sum(fam.values())
        rows.append({"input_speed_rpm": float(rpm), "P_out_W": p_out, "P_loss_W": loss, "P_in_W": p_out + loss,
                     "efficiency": p_out / (p_out + loss), "loss_by_family_W": fam,
                     "frictionless_power_balance_rel_err": abs(imbalance) / p_out,
                     "frictionless_power_balance_worst_angle_rel_err": worst})
    return {"torque_Nm": abs(torque), "input_angles_rad": [a for a, _ in states], "sliding_friction":
            {"pins": friction.pins, "gears": friction.gears}, "points": rows}
