"""The precision study shared by the cycloid cases: rated-state loads, quasi-static
TE over a declared interval, its refinement error, and a driven dynamic run."""
import time

import numpy as np

from warp_contacts.circle_pairs_ref import O_FN, O_NX, O_NY, O_PX, O_PY

from ..assembly.cycloid import build
from ..assembly.spec import replace
from ..solver import RunSpec
from .equilibrium import StaticSolver
from .precision import ARCSEC, dynamic_te, family_peaks, pin_forces, quasi_static_te, te_metrics


def precision_study(design, *, quick, out_dir, bearing_model="rolling", points_per_mesh=None,
                    output_revolutions=None, dynamic_duration=None, dynamic_step=2e-5):
    """Run the precision protocol on ``design``; returns the results dict (issue 5 keys)."""
    from .. import casekit
    t_all = time.perf_counter()
    zb, zg = design.pins.n_pins, design.pins.n_pins - 1
    ratio = design.ratio
    T = design.rated_torque
    ppm = points_per_mesh or (4 if quick else 40)
    revs = output_revolutions or ((1.0 / zg) if quick else 1.0)   # quick: one input revolution
    n_pts = int(round(revs * zg * zb * ppm))
    angles = np.arange(n_pts) * (2 * np.pi / zb) / ppm
    model = build(design, bearing_model=bearing_model)

    # rated state at zero input angle
    solver = StaticSolver(model)
    model.set_output_torque(-np.sign(ratio) * T)
    q_rated = solver.solve(0.0)
    F_rated = pin_forces(model, q_rated)
    peaks_rated = family_peaks(model, q_rated)

    # quasi-static TE over the interval
    qs = quasi_static_te(model, torque=T, input_angles=angles)
    met = te_metrics(qs["te"], n_revolutions=revs)

    # refinement reference: one mesh cycle with twice the profile samples and points
    fine = replace(design, wheels={"samples_per_tooth": 2 * design.wheels.samples_per_tooth})
    window = np.arange(2 * ppm + 1) * (2 * np.pi / zb) / (2 * ppm)
    coarse_win = quasi_static_te(build(design, bearing_model=bearing_model), torque=T, input_angles=window[::2])
    fine_win = quasi_static_te(build(fine, bearing_model=bearing_model), torque=T, input_angles=window)
    pp_c, pp_f = np.ptp(coarse_win["te"]), np.ptp(fine_win["te"])
    te_diff = float(np.max(np.abs(coarse_win["te"] - fine_win["te"][::2])))

    # dynamic path
    dur = dynamic_duration or ((4 * 2 * np.pi / zb) / (design.input_speed_rpm * np.pi / 30) if quick
                               else abs(ratio) * 60.0 / design.input_speed_rpm)
    dyn_model = build(design, bearing_model=bearing_model)
    spec = RunSpec(end_time=dur, step=dynamic_step, abs_tol=1e-6, rel_tol=1e-8)
    from ..observe import ObserverRegistry, WholeRun
    observers = ObserverRegistry()
    whole = WholeRun()
    observers.register("whole_run", whole)
    dyn = dynamic_te(dyn_model, torque=T, speed_rpm=design.input_speed_rpm, duration=dur, run_spec=spec,
                     out_dir=out_dir, observers=observers)
    acc = whole.accumulator
    dyn_peaks = {}
    for fam, prefix in (("pins", "wheel"), ("output_pins", "output_pins"), ("eccentric_bearings", "eccentric_bearing"),
                        ("main_bearings", "main_bearing"), ("input_bearings", "input_bearing")):
        sel = [i for i, cid in enumerate(acc.ids) if cid.startswith(prefix)]
        if sel:
            dyn_peaks[fam] = float(np.max(acc.F_pk[sel]))
    rec = dyn["record"]
    dyn_met = te_metrics(dyn["te_uniform"], n_revolutions=dur * design.input_speed_rpm / 60.0 / abs(ratio))

    results = {
        "ratio_nominal": float(ratio),
        "te_pp_arcsec": met["pp"] * ARCSEC,
        "te_rms_arcsec": met["rms"] * ARCSEC,
        "te_mean_offset_arcsec": met["mean"] * ARCSEC,
        "te_orders": met["peak_orders"],
        "te_order_amplitudes_arcsec": met["peak_amplitudes"] * ARCSEC,
        "te_interval": {"output_revolutions": revs, "points": n_pts, "points_per_mesh_cycle": ppm,
                        "mesh_cycle": "2 pi / z_b of input rotation"},
        "pin_forces_at_rated_N": F_rated,
        "peak_loads_N": {"pins": qs["peak_loads"].get("pins"),
                         "eccentric_bearings": qs["peak_loads"].get("eccentric_bearings"),
                         "main_bearings": qs["peak_loads"].get("main_bearings"),
                         "output_pins": qs["peak_loads"].get("output_pins"),
                         "input_bearings": qs["peak_loads"].get("input_bearings")},
        "peak_loads_at_rated_N": peaks_rated,
        "n_active_pins": (F_rated > 1e-6 * max(F_rated.max(), 1.0)).sum(axis=1),
        "wall_s": time.perf_counter() - t_all,
        "wall_s_quasistatic": qs["wall_s"],
        "ms_per_quasistatic_point": 1e3 * qs["wall_s"] / n_pts,
        "quasistatic_newton_iterations": qs["stats"]["newton_iterations"],
        "regularization_max_N": qs["regularization_max"],
        "te_refinement": {"te_pp_window_arcsec": pp_c * ARCSEC, "te_pp_window_refined_arcsec": pp_f * ARCSEC,
                          "te_max_abs_diff_arcsec": te_diff * ARCSEC,
                          "reference": "one mesh cycle with 2x profile samples per tooth and 2x points"},
        "steps": rec.accepted_steps,
        "newton_iterations": rec.newton_iterations,
        "rejected_steps": rec.rejected_steps,
        "dynamic": {"duration_s": dur, "step_s": dynamic_step, "wall_s": rec.wall_s,
                    "us_per_step": 1e6 * rec.wall_s / max(rec.accepted_steps, 1),
                    "te_pp_arcsec": float(np.ptp(dyn["te"]) * ARCSEC), "te_rms_arcsec": dyn_met["rms"] * ARCSEC,
                    "te_orders": dyn_met["peak_orders"], "te_order_amplitudes_arcsec": dyn_met["peak_amplitudes"] * ARCSEC,
                    "max_residual": rec.max_residual, "min_step_s": rec.to_dict()["min_step_s"],
                    "peak_loads_N": dyn_peaks,
                    "peak_loads_source": "accepted-step observers (WholeRun F_pk per contact identity)"},
        "width_moments_at_rated_Nm": model.pin_set.width_moments(
            model.elements["pins"].evaluate(0.0, model.elements["pins"].local(q_rated),
                                            np.zeros(len(model.elements["pins"].local(q_rated)))).obs),
    }
    _plots(model, q_rated, F_rated, qs, met, dyn, out_dir, revs)
    settings = {"design": design.name, "bearing_model": bearing_model, "run_spec_dynamic": spec.to_dict(),
                "samples_per_tooth": design.wheels.samples_per_tooth, "n_slices": design.wheels.n_slices,
                "search_window": model.pin_set.window, "quick": quick}
    return results, settings


def _plots(model, q, F, qs, met, dyn, out_dir, revs):
    import matplotlib.pyplot as plt

    from .. import casekit
    d = model.design
    # profile with pins and contact normals at the rated state
    fig, ax = plt.subplots(figsize=(6, 6))
    el = model.elements["pins"]
    ev = el.evaluate(0.0, el.local(q), np.zeros(len(el.local(q))))
    for k, prof in enumerate(model.profiles):
        node = model.nodes[1 + k]
        ref = np.asarray(model.mbs.GetNodeParameter(node, "referenceCoordinates"))
        x = ref + q[np.asarray(model.mbs.systemData.GetNodeLTGODE2(node))]
        pts = prof.points(np.linspace(0, 2 * np.pi, 4000))
        c, s = np.cos(x[2]), np.sin(x[2])
        ax.plot(x[0] + c * pts[:, 0] - s * pts[:, 1], x[1] + s * pts[:, 0] + c * pts[:, 1], lw=0.8, label=f"wheel {k}")
    from ..geometry.cycloid import pin_centres
    for p in pin_centres(model.profiles[0]):
        ax.add_patch(plt.Circle(p, d.pins.pin_radius, fill=False, color="k", lw=0.6))
    on = ev.obs[:, O_FN] > 0
    scale = 0.01 / max(ev.obs[:, O_FN].max(), 1e-9)
    ax.quiver(ev.obs[on, O_PX], ev.obs[on, O_PY], -ev.obs[on, O_NX] * ev.obs[on, O_FN] * scale,
              -ev.obs[on, O_NY] * ev.obs[on, O_FN] * scale, angles="xy", scale_units="xy", scale=1, color="r", width=0.003)
    ax.set_aspect("equal")
    ax.set(title=f"{d.name}: profiles, pins and contact forces at {d.rated_torque} N m", xlabel="x [m]", ylabel="y [m]")
    ax.legend(fontsize=8)
    casekit.save_figure(fig, out_dir, "profile_contacts")
    # TE and spectrum
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    out_deg = np.rad2deg(qs["theta_in"] / abs(model.design.ratio))
    ax[0].plot(out_deg, (qs["te"] - np.mean(qs["te"])) * ARCSEC, lw=0.8, label="quasi-static")
    out_dyn = np.rad2deg(dyn["theta_in"] - dyn["theta_in"][0]) / abs(model.design.ratio)
    ax[0].plot(out_dyn, (dyn["te"] - np.mean(dyn["te"])) * ARCSEC, lw=0.8, label="dynamic")
    ax[0].set(xlabel="output angle [deg]", ylabel="TE - mean [arcsec]")
    ax[0].legend(fontsize=8)
    o, a = met["orders"], met["amplitudes"] * ARCSEC
    ax[1].semilogy(o[1:], np.maximum(a[1:], 1e-8), lw=0.8)
    ax[1].set(xlabel="output-shaft order", ylabel="amplitude [arcsec]", title=f"order spectrum ({revs:.3g} output rev)")
    casekit.save_figure(fig, out_dir, "transmission_error")
    # pin-force distribution
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for k in range(F.shape[0]):
        ax.bar(np.arange(F.shape[1]) + 0.4 * k, F[k], width=0.4, label=f"wheel {k}")
    ax.set(xlabel="pin index (clockwise from +y)", ylabel="normal force [N]", title="pin forces at the rated state")
    ax.legend(fontsize=8)
    casekit.save_figure(fig, out_dir, "pin_forces")
