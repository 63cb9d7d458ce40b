"""Precision protocol: transmission error under load at a declared speed,
quasi-static (sequence of equilibria at prescribed input angles) or dynamic
(driven rotation with the implicit integrator).

Transmission error, Eq. (obs_te): e_TE = [theta_out - theta_out,0]
- [theta_in - theta_in,0] / i with the signed nominal ratio i and unwrapped
angles; peak-to-peak and RMS over a declared interval (a full output
revolution for the reported figures) and the order spectrum in output-shaft
orders (spacing 1/N_r for N_r observed output revolutions).
"""
import time

import numpy as np

from .. import progress
from ..observe.transmission import transmission_error
from ..solver.static import StaticSolver

__all__ = ["transmission_error", "te_metrics", "mesh_forces", "quasi_static_te", "dynamic_te", "DYNAMIC_SOLVERS"]


def te_metrics(te, *, n_revolutions=1.0, n_peaks=10, remove_mean=True):
    """Peak-to-peak, RMS (after removing the mean, reported separately) and the order spectrum of
    TE samples uniform in output angle over ``n_revolutions`` output revolutions (endpoint excluded)."""
    te = np.asarray(te, float)
    mean = float(np.mean(te))
    x = te - mean if remove_mean else te
    spec = np.fft.rfft(x) / len(x)
    amp = 2 * np.abs(spec)
    amp[0] = abs(spec[0])
    orders = np.arange(len(amp)) / n_revolutions
    idx = np.argsort(amp[1:])[::-1][:n_peaks] + 1
    idx = idx[amp[idx] > 0]
    return {"pp": float(np.ptp(te)), "rms": float(np.sqrt(np.mean((te - mean) ** 2))), "mean": mean,
            "orders": orders, "amplitudes": amp, "peak_orders": orders[idx], "peak_amplitudes": amp[idx]}


def mesh_forces(model, q):
    """Per member of the main mesh (a wheel), the normal force of each contact [N] (slices
    summed) at state q: (n_members, n_contacts)."""
    return np.array(list(model.observe(q, model.main_mesh).per_member().values()))


def quasi_static_te(model, *, torque, input_angles, solver=None, record=None, warm_start=True):
    """Sequence of equilibria at prescribed input angles under output torque ``torque`` [N m]
    (applied to resist the nominal output rotation). Returns angle histories, TE [rad],
    per-family peak loads over the sequence (``peak_loads``: largest row, a slice or lamina;
    ``peak_contact_loads``: largest physical contact, rows summed) and solver statistics.

    warm_start: start each point from the previous equilibrium (dense sequences); False
    starts every point with the solver's stiffness homotopy from the kinematic state, which
    is cheaper for points far apart (e.g. 53 points over an output revolution, 4.6 rad of
    input angle apart, where a warm start is no closer than the kinematic state)."""
    ratio = model.ratio
    solver = solver or StaticSolver(model)
    model.set_output_torque(-np.sign(ratio) * torque)
    i_out = model.output_index
    ref_out = model.reference_value(model.output)
    th_in, th_out = [], []
    peaks, contact_peaks = {}, {}
    prev = None
    t0 = time.perf_counter()
    for k, a in enumerate(progress.track(input_angles, desc="quasi-static TE", unit="point")):
        q = solver.solve(a, prev if warm_start else None)
        a = solver.last_angle      # the solved angle (a kink shift of <= 1e-5 rad is recorded, not hidden)
        prev = a
        th_in.append(a)
        th_out.append(ref_out + q[i_out])
        for fam, f in model.family_peaks(q).items():
            peaks[fam] = max(peaks.get(fam, 0.0), f)
        for fam, f in model.family_contact_peaks(q).items():
            contact_peaks[fam] = max(contact_peaks.get(fam, 0.0), f)
        if record is not None:
            record(k, a, q)
    wall = time.perf_counter() - t0
    th_in, th_out = np.array(th_in), np.array(th_out)
    return {"theta_in": th_in, "theta_out": th_out, "te": transmission_error(th_in, th_out, ratio, unwrap=False),
            "peak_loads": peaks, "peak_contact_loads": contact_peaks, "stats": solver.stats.to_dict(), "wall_s": wall,
            "regularization_max": model.regularization_force(solver.q)}


DYNAMIC_SOLVERS = ("exudyn", "fused", "auto")
"""Solvers of the driven run: Exudyn's generalized alpha with the contact elements, the fused
device stepper (:func:`rvtool.solver.device_dynamics.dynamic_te_fused`, the same integrator in
one Warp launch per 64 steps), or the fused stepper where it supports the model, else Exudyn."""


def dynamic_te(model, *, torque, speed_rpm, duration, run_spec, observers=None, out_dir=None, on_start=None,
               solver="exudyn", device=None):
    """Driven rotation at constant input speed from the quasi-static loaded state at angle 0.

    Returns time, angle histories, TE [rad] on the accepted steps, the run record,
    the uniform-time resampled TE (for spectra) and ``solver``, the solver that ran.

    solver: one of :data:`DYNAMIC_SOLVERS`. ``"fused"`` runs the built model's design on the
    fused stepper with the same RunSpec (its eligibility, and that the model equals what the
    fused path rebuilds from ``model.design``, is
    :func:`rvtool.solver.device_dynamics.fused_support`; an ineligible model is a named
    RvtoolInputError); the result adds "torque_in" and "peak_loads"; the static start is the
    device Newton's (Exudyn's StaticSolver is its oracle). ``"auto"``: fused where eligible,
    else Exudyn with the reasons in "solver_reasons". Observers need the Exudyn driver (auto
    runs Exudyn with them). device: the fused stepper's Warp device (None: run_spec.device);
    the Exudyn path evaluates contacts on the device the model was built for.
    on_start: called just before the run (after the static start on the Exudyn path, before
    the device Newton's start on the fused path)."""
    from ..validation import check_choice
    check_choice("solver", solver, DYNAMIC_SOLVERS)
    if solver != "exudyn":
        from ..errors import RvtoolInputError
        from ..solver.device_dynamics import DeviceDynamicsSettings, dynamic_te_fused, fused_support
        sup = fused_support(model, run_spec)
        reasons = list(sup.reasons) + (["observers are recorded by the Exudyn driver only"] if observers else [])
        if solver == "fused" and reasons:
            raise RvtoolInputError(f"solver = 'fused' cannot run this model: {'; '.join(reasons)}. Valid choices: "
                                   f"{list(DYNAMIC_SOLVERS)} ('exudyn', or 'auto', which runs Exudyn here)")
        if not reasons:
            if on_start is not None:
                on_start()
            out = dynamic_te_fused(model.design, torque=torque, speed_rpm=speed_rpm, duration=duration,
                                   settings=DeviceDynamicsSettings.from_run_spec(run_spec),
                                   device=device or run_spec.device, out_dir=out_dir, params=sup.params)
            out["solver"] = "fused"
            return out
        out = _dynamic_te_exudyn(model, torque=torque, speed_rpm=speed_rpm, duration=duration, run_spec=run_spec,
                                 observers=observers, out_dir=out_dir, on_start=on_start)
        out["solver_reasons"] = reasons
        return out
    return _dynamic_te_exudyn(model, torque=torque, speed_rpm=speed_rpm, duration=duration, run_spec=run_spec,
                              observers=observers, out_dir=out_dir, on_start=on_start)


def _dynamic_te_exudyn(model, *, torque, speed_rpm, duration, run_spec, observers, out_dir, on_start):
    """The Exudyn path of :func:`dynamic_te`."""
    import exudyn as exu

    from ..solver import simulate
    omega = speed_rpm * 2 * np.pi / 60.0
    ratio = model.ratio
    solver = StaticSolver(model)
    model.set_output_torque(-np.sign(ratio) * torque)
    q0 = solver.solve(0.0)
    v0 = model.body_vector(model.kinematic_state(0.0, omega).velocities)
    mbs = model.mbs
    mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
    mbs.systemData.SetODE2Coordinates_t(v0, configuration=exu.ConfigurationType.Initial)
    model.set_input_speed(omega)
    mbs.Assemble()
    mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
    mbs.systemData.SetODE2Coordinates_t(v0, configuration=exu.ConfigurationType.Initial)
    i_out, i_in = model.output_index, model.input_index
    ref_out = model.reference_value(model.output)
    t_rec, th_in, th_out = [0.0], [q0[i_in]], [ref_out + q0[i_out]]

    import dataclasses
    spec = dataclasses.replace(run_spec, end_time=duration)
    if on_start is not None:
        on_start()
    with progress.task(duration, desc="dynamic TE run", unit="s") as advance:
        def record(t, q, v):
            t_rec.append(t)
            th_in.append(q[i_in])
            th_out.append(ref_out + q[i_out])
            advance(t)

        rec = simulate(mbs, spec, model.contact_elements(), observers, before_accept=record, out_dir=out_dir)
    t_rec, th_in, th_out = map(np.array, (t_rec, th_in, th_out))
    te = transmission_error(th_in, th_out, ratio)
    n_uniform = max(16, int(round(duration / run_spec.step)))
    t_u = np.linspace(0.0, duration, n_uniform, endpoint=False)
    return {"t": t_rec, "theta_in": th_in, "theta_out": th_out, "te": te, "record": rec,
            "t_uniform": t_u, "te_uniform": np.interp(t_u, t_rec, te), "omega_in": omega, "solver": "exudyn"}
