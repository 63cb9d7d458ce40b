"""Precision protocol: transmission error under load at a declared speed,
quasi-static (sequence of equilibria at prescribed input angles) or dynamic
(driven rotation with the implicit integrator).

Transmission error, Eq. (obs_te): e_TE = [theta_out - theta_out,0]
- [theta_in - theta_in,0] / i with the signed nominal ratio i and unwrapped
angles; peak-to-peak and RMS over a declared interval (a full output
revolution for the reported figures) and the order spectrum in output-shaft
orders (spacing 1/N_r for N_r observed output revolutions).
"""
import numpy as np

from ..observe.transmission import transmission_error

__all__ = ["transmission_error", "te_metrics", "batch_te", "equilibria_te", "mesh_forces", "quasi_static_te", "dynamic_te",
           "DYNAMIC_SOLVERS"]


def peak_to_peak_sampling_error(fine):
    """Sampling error of a peak-to-peak read from every second point of ``fine`` (a TE over one mesh cycle at
    twice a run's points): ptp(fine) - ptp(fine[::2]) >= 0, the extrema the coarser grid misses between its
    points (the Richardson-type estimate of the run's own sampling error; ``rvtool analyze``'s te_pp error)."""
    fine = np.asarray(fine, float)
    return float(np.ptp(fine) - np.ptp(fine[::2]))


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


def batch_te(theta_in, theta_out, ratio, failed=None):
    """Eq. (obs_te) and its peak-to-peak and RMS for V histories at prescribed states (a batch of
    designs: theta_in, theta_out (V, A) [rad], integrated angles, not unwrapped); rows marked in
    ``failed`` (V,) are NaN. Returns {"te" (V, A) [rad], "pp_arcsec", "rms_arcsec" (V,)}; the TE
    of every backend's variant batches (the one TE computation beside :func:`quasi_static_te`)."""
    from ..units import ARCSEC_PER_RAD
    theta_in, theta_out = np.atleast_2d(theta_in), np.atleast_2d(theta_out)
    V = len(theta_in)
    failed = np.zeros(V, bool) if failed is None else np.asarray(failed, bool)
    te = np.full(theta_in.shape, np.nan)
    pp, rms = np.full(V, np.nan), np.full(V, np.nan)
    for c in np.flatnonzero(~failed):
        te[c] = transmission_error(theta_in[c], theta_out[c], ratio, unwrap=False)
        met = te_metrics(te[c])
        pp[c], rms[c] = met["pp"] * ARCSEC_PER_RAD, met["rms"] * ARCSEC_PER_RAD
    return {"te": te, "pp_arcsec": pp, "rms_arcsec": rms}


def mesh_forces(model, q):
    """Per member of the main mesh (a wheel), the normal force of each contact [N] (slices
    summed) at state q: (n_members, n_contacts)."""
    return np.array(list(model.observe(q, model.main_mesh).per_member().values()))


def quasi_static_te(model, *, torque, input_angles, solver=None, record=None, warm_start=True, backend="exudyn",
                    device="cpu"):
    """Sequence of equilibria at prescribed input angles under output torque ``torque`` [N m]
    (applied to resist the nominal output rotation), solved by ``backend`` (a name of
    :data:`rvtool.solver.backends.CHOICES` or a :class:`~rvtool.solver.backends.Backend`; the one
    TE loop of every backend). Returns angle histories, TE [rad], per-family peak loads over the
    sequence (``peak_loads``: largest row, a slice or lamina; ``peak_contact_loads``: largest
    physical contact, rows summed; empty where the backend reports none), solver statistics and
    ``backend``: {"requested", "ran", "not_taken": {name: reason}}.

    solver, record: the Exudyn backend's StaticSolver and per-point callback record(k, angle, q).
    device: the Warp device of the replica and device backends chosen by name or by auto.
    warm_start: start each point from the previous equilibrium (dense sequences); False
    starts every point with the solver's stiffness homotopy from the kinematic state, which
    is cheaper for points far apart (e.g. 53 points over an output revolution, 4.6 rad of
    input angle apart, where a warm start is no closer than the kinematic state)."""
    from ..solver.backends import EquilibriumBatch, ExudynBackend, choose
    if solver is not None:
        if backend not in ("exudyn",):
            from ..errors import RvtoolInputError
            raise RvtoolInputError(f"solver= is the Exudyn backend's StaticSolver; backend = {backend!r} (valid: 'exudyn')")
        backend = ExudynBackend(solver=solver)
    b, choice = choose(backend, model, "equilibria", n_states=len(input_angles), device=device)
    eq = b.solve_equilibria(model, EquilibriumBatch(input_angles=input_angles, torque=torque, warm_start=warm_start),
                            record=record)
    return equilibria_te(eq, model.ratio, choice)


def equilibria_te(eq, ratio, choice):
    """The quasi-static TE result (keys of :func:`quasi_static_te`) of a backend's
    :class:`~rvtool.solver.backends.Equilibria` at prescribed input angles, signed ratio ``ratio``;
    ``choice`` the backend record."""
    return {"theta_in": eq.theta_in, "theta_out": eq.theta_out,
            "te": transmission_error(eq.theta_in, eq.theta_out, ratio, unwrap=False),
            "peak_loads": eq.peak_loads, "peak_contact_loads": eq.peak_contact_loads, "stats": eq.stats,
            "wall_s": eq.wall_s, "regularization_max": eq.regularization_max, "backend": choice}


DYNAMIC_SOLVERS = ("exudyn", "fused", "device", "auto")
"""Backends of the driven run: Exudyn's generalized alpha with the contact elements, the fused
device stepper (:class:`rvtool.solver.backends.FusedBackend`, the same integrator in one Warp
launch per 64 steps; "device" names the same), or the fastest that supports the model ("auto")."""


def dynamic_te(model, *, torque, speed_rpm, duration, run_spec, observers=None, out_dir=None, on_start=None,
               solver="exudyn", device=None):
    """Driven rotation at constant input speed from the quasi-static loaded state at angle 0.

    Returns time, angle histories, TE [rad] on the accepted steps, the run record,
    the uniform-time resampled TE (for spectra), ``solver`` (the backend that ran) and
    ``backend`` ({"requested", "ran", "not_taken"}).

    solver: one of :data:`DYNAMIC_SOLVERS` or a :class:`~rvtool.solver.backends.Backend`.
    ``"fused"`` runs on the fused backend with the same RunSpec, on one of its two paths
    (:class:`~rvtool.solver.backends.FusedBackend`, recorded in ``stats["path"]``): the fused
    stepper for the built model's design (its eligibility, and that the model equals what the
    fused path rebuilds from ``model.design``, is
    :func:`rvtool.solver.device_dynamics.fused_support`; the result adds "torque_in" and
    "peak_loads"; the static start is the device Newton's, whose oracle is Exudyn's StaticSolver),
    else the row stepper (:func:`rvtool.solver.row_dynamics.row_driven_run`: RV and every model
    whose families have device rows; the result adds "torque_in"; the static start is Exudyn's
    StaticSolver); a model neither takes is a named RvtoolInputError. ``"auto"``: the fused
    stepper where eligible, else Exudyn with the reasons in "solver_reasons" (auto does not take
    the row stepper, :meth:`FusedBackend.auto_reason`). Observers need the Exudyn driver (auto
    runs Exudyn with them). device: the fused backend's Warp device (None: run_spec.device);
    the Exudyn path evaluates contacts on the device the model was built for.
    on_start: called just before the run (after the static start on the Exudyn path and the row
    stepper, before the device Newton's start on the fused stepper)."""
    from ..solver.backends import DrivenRun, choose
    from ..validation import check_choice
    if isinstance(solver, str):
        check_choice("solver", solver, DYNAMIC_SOLVERS)
    run = DrivenRun(torque=torque, speed_rpm=speed_rpm, duration=duration, run_spec=run_spec, observers=observers,
                    out_dir=out_dir, on_start=on_start, device=device)
    b, choice = choose(solver, model, "dynamic", run=run, device=device or run_spec.device)
    h = b.step_dynamic(model, run)
    te = transmission_error(h.theta_in, h.theta_out, model.ratio)
    n_uniform = max(16, int(round(duration / run_spec.step)))
    t_u = np.linspace(0.0, duration, n_uniform, endpoint=False)
    out = {"t": h.t, "theta_in": h.theta_in, "theta_out": h.theta_out, "te": te, "record": h.record,
           "t_uniform": t_u, "te_uniform": np.interp(t_u, h.t, te), "omega_in": h.omega_in, "solver": b.name,
           "backend": choice, **h.extras}
    if choice["requested"] == "auto" and b.name != "fused" and "fused" in choice["not_taken"]:
        out["solver_reasons"] = choice["not_taken"]["fused"].split("; ")
    return out
