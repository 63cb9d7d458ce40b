"""Lost motion under mixed (spring) control, continuous through the free play: the
protocol around :class:`rvtool.solver.spring_march.SpringControl` (see there for the method)."""
from ..errors import SolverFailure
from ..solver.spring_march import SpringControl
from ..solver.torque_path import START_SCALES  # noqa: F401  (the start torques, defined with the torque paths)
from ..validation import check_positive


def lost_motion(model, *, torque_level, input_angle=0.0, k_s=None, **kw):
    """Lost motion [rad] = theta_out(+torque_level) - theta_out(-torque_level) at ``input_angle``
    under spring control (module docstring). k_s [N m/rad]: control spring; default 1e5 N m/rad
    (measured on the Monte Carlo's RD-40 variants: 1e4, of the order of the reducer's secant
    stiffness across the free play, left Newton stalling where the output pins change flanks;
    1e5 holds the flange firmly enough). The march starts at the load-controlled equilibrium at
    the first of :data:`START_SCALES` x torque_level that is found. Returns a dict with
    ``lost_motion_rad``, ``theta_plus``, ``theta_minus`` (flange coordinates [rad]), the states
    ``q_plus``/``q_minus``, ``start_torque`` [N m], ``stats`` and ``control_stiffness`` (k_s at
    the end [N m/rad]: stiffer than asked where the march met a snap-through, see
    :mod:`rvtool.solver.spring_march`; ``max_k_s`` in ``kw`` bounds it). The flange spring and the
    output torque (zero) are restored afterwards."""
    check_positive("torque_level", torque_level)
    level = float(torque_level)
    errors = []
    for scale in START_SCALES:
        try:
            ctl = SpringControl(model, k_s=1e5 if k_s is None else k_s, input_angle=input_angle,
                                start_torque=scale * level, **kw)
            break
        except SolverFailure as e:
            errors.append(str(e))
            model.set_output_torque(0.0)
    else:
        raise SolverFailure("no loaded start for spring-controlled lost motion: " + "; ".join(errors))
    try:
        qp = (ctl.go_to(level) if scale != 1.0 else ctl.q).copy()
        qm = ctl.go_to(-level).copy()
    finally:
        ctl.restore()
        model.set_output_torque(0.0)
    i = ctl.i_out
    return {"lost_motion_rad": float(qp[i] - qm[i]), "theta_plus": float(qp[i]), "theta_minus": float(qm[i]),
            "q_plus": qp, "q_minus": qm, "start_torque": scale * level, "stats": ctl.stats.to_dict(),
            "control_stiffness": ctl.k_s}
