"""The precision study: rated-state loads, quasi-static TE over a declared interval, its
refinement error (the topology's own refined resolution), and a driven dynamic run.
Topology-neutral: the model supplies its ratio, mesh period, families and section plot."""
import time

import numpy as np

from ..assembly import build
from ..solver import RunSpec
from ..solver.static import StaticSolver
from ..units import ARCSEC_PER_RAD
from ..protocols.precision import dynamic_te, mesh_forces, quasi_static_te, te_metrics


FAMILIES = ("pins", "eccentric_bearings", "main_bearings", "output_pins", "input_bearings")


def precision_study(design, *, quick, out_dir, bearing_model="rolling", points_per_mesh=None,
                    output_revolutions=None, dynamic_duration=None, dynamic_step=2e-5, allowables=None):
    """Run the precision protocol on ``design``; returns the results dict (issue 5 keys, and issue 21's
    ``peak_slice_loads_N``, ``stiffness_budget``, ``lost_motion_budget_arcmin`` and ``datasheet``;
    allowables: :class:`~rvtool.designs.allowables.Allowables`, default RD-40's declared table)."""
    t_all = time.perf_counter()
    model = build(design, bearing_model=bearing_model)
    ratio = model.ratio
    T = design.rated_torque
    mesh = model.mesh_period                        # input angle of one mesh cycle [rad]
    ppm = points_per_mesh or (4 if quick else 40)
    revs = output_revolutions or ((1.0 / abs(ratio)) if quick else 1.0)   # quick: one input revolution
    n_pts = int(round(revs * abs(ratio) * (2 * np.pi / mesh) * ppm))
    angles = np.arange(n_pts) * mesh / ppm

    # rated state at zero input angle
    solver = StaticSolver(model)
    model.set_output_torque(-np.sign(ratio) * T)
    q_rated = solver.solve(0.0)
    F_rated = mesh_forces(model, q_rated)
    peaks_rated = model.family_contact_peaks(q_rated)

    # quasi-static TE over the interval; its states are kept (12-odd coordinates each) for the
    # datasheet's pin bending stress and bearing loads over the mesh cycles
    te_states = []
    qs = quasi_static_te(model, torque=T, input_angles=angles, record=lambda k, a, q: te_states.append(np.array(q)))
    met = te_metrics(qs["te"], n_revolutions=revs)

    # refinement reference: one mesh cycle with twice the profile samples and points
    fine = model.refined_design()
    window = np.arange(2 * ppm + 1) * mesh / (2 * ppm)
    coarse_win = quasi_static_te(build(design, bearing_model=bearing_model), torque=T, input_angles=window[::2])
    fine_win = quasi_static_te(build(fine, bearing_model=bearing_model), torque=T, input_angles=window)
    pp_c, pp_f = np.ptp(coarse_win["te"]), np.ptp(fine_win["te"])
    te_diff = float(np.max(np.abs(coarse_win["te"] - fine_win["te"][::2])))

    # dynamic path
    dur = dynamic_duration or ((4 * mesh) / (design.input_speed_rpm * np.pi / 30) if quick
                               else abs(ratio) * 60.0 / design.input_speed_rpm)
    dyn_model = build(design, bearing_model=bearing_model)
    spec = RunSpec(end_time=dur, step=dynamic_step, abs_tol=1e-6, rel_tol=1e-8)
    from ..observe import ContactPeaks, ObserverRegistry, WholeRun
    observers = ObserverRegistry()
    whole = WholeRun()
    observers.register("whole_run", whole)
    contact_peaks = ContactPeaks()
    observers.register("contact_peaks", contact_peaks)
    dyn = dynamic_te(dyn_model, torque=T, speed_rpm=design.input_speed_rpm, duration=dur, run_spec=spec,
                     out_dir=out_dir, observers=observers)
    acc = whole.accumulator
    dyn_peaks, dyn_slice_peaks = {}, {}
    for fam, prefix in (("pins", "wheel"), ("output_pins", "output_pins"), ("eccentric_bearings", "eccentric_bearing"),
                        ("main_bearings", "main_bearing"), ("input_bearings", "input_bearing")):
        sel = [i for i, cid in enumerate(acc.ids) if cid.startswith(prefix)]
        if sel:
            dyn_slice_peaks[fam] = float(np.max(acc.F_pk[sel]))
            dyn_peaks[fam] = contact_peaks.peak(prefix)
    rec = dyn["record"]
    dyn_met = te_metrics(dyn["te_uniform"], n_revolutions=dur * design.input_speed_rpm / 60.0 / abs(ratio))

    # issue 21: stiffness and lost-motion budgets, datasheet with declared allowables
    honest = honest_figures(design, model, q_rated, quick=quick, bearing_model=bearing_model,
                            peaks_rated=peaks_rated, allowables=allowables,
                            te_states=(qs["theta_in"], te_states))

    results = {
        "ratio_nominal": float(ratio),
        "te_pp_arcsec": met["pp"] * ARCSEC_PER_RAD,
        "te_rms_arcsec": met["rms"] * ARCSEC_PER_RAD,
        "te_mean_offset_arcsec": met["mean"] * ARCSEC_PER_RAD,
        "te_orders": met["peak_orders"],
        "te_order_amplitudes_arcsec": met["peak_amplitudes"] * ARCSEC_PER_RAD,
        "te_interval": {"output_revolutions": revs, "points": n_pts, "points_per_mesh_cycle": ppm,
                        "mesh_cycle": "2 pi / z_b of input rotation"},
        "pin_forces_at_rated_N": F_rated,
        # per physical contact (slices and laminae summed): the load a pin, roller or ball carries
        "peak_loads_N": {f: qs["peak_contact_loads"].get(f) for f in FAMILIES},
        # per row (one axial slice or lamina): the figures reported as peak loads before issue 21
        "peak_slice_loads_N": {f: qs["peak_loads"].get(f) for f in FAMILIES},
        "peak_loads_at_rated_N": peaks_rated,
        "n_active_pins": (F_rated > 1e-6 * max(F_rated.max(), 1.0)).sum(axis=1),
        "wall_s": time.perf_counter() - t_all,
        "wall_s_quasistatic": qs["wall_s"],
        "ms_per_quasistatic_point": 1e3 * qs["wall_s"] / n_pts,
        "quasistatic_newton_iterations": qs["stats"]["newton_iterations"],
        "regularization_max_N": qs["regularization_max"],
        "te_refinement": {"te_pp_window_arcsec": pp_c * ARCSEC_PER_RAD, "te_pp_window_refined_arcsec": pp_f * ARCSEC_PER_RAD,
                          "te_max_abs_diff_arcsec": te_diff * ARCSEC_PER_RAD,
                          "reference": "one mesh cycle at the refined resolution (model.refined_design) and 2x points"},
        "steps": rec.accepted_steps,
        "newton_iterations": rec.newton_iterations,
        "rejected_steps": rec.rejected_steps,
        "dynamic": {"duration_s": dur, "step_s": dynamic_step, "wall_s": rec.wall_s,
                    "us_per_step": 1e6 * rec.wall_s / max(rec.accepted_steps, 1),
                    "te_pp_arcsec": float(np.ptp(dyn["te"]) * ARCSEC_PER_RAD), "te_rms_arcsec": dyn_met["rms"] * ARCSEC_PER_RAD,
                    "te_orders": dyn_met["peak_orders"], "te_order_amplitudes_arcsec": dyn_met["peak_amplitudes"] * ARCSEC_PER_RAD,
                    "max_residual": rec.max_residual, "min_step_s": rec.to_dict()["min_step_s"],
                    "peak_loads_N": dyn_peaks,
                    "peak_slice_loads_N": dyn_slice_peaks,
                    "peak_loads_source": "accepted-step observers: ContactPeaks (rows summed per physical "
                                         "contact, then the largest step) and WholeRun F_pk (per row)"},
        "width_moments_at_rated_Nm": model.mesh_width_moments(q_rated),
        "stiffness_budget": honest["stiffness_budget"],
        "lost_motion_budget_arcmin": honest["lost_motion_budget_arcmin"],
        "datasheet": honest["datasheet"],
    }
    _budget_plots(honest, out_dir)
    _plots(model, q_rated, F_rated, qs, met, dyn, out_dir, revs)
    settings = {"design": design.name, "bearing_model": bearing_model, "run_spec_dynamic": spec.to_dict(),
                **model.resolution_settings(), "quick": quick}
    return results, settings


def _plots(model, q, F, qs, met, dyn, out_dir, revs):
    import matplotlib.pyplot as plt

    from .output import save_figure
    # transverse section with the contact forces at the rated state
    fig, ax = plt.subplots(figsize=(6, 6))
    model.draw_section(ax, q)
    ax.set_title(f"{model.design.name}: contact forces at {model.design.rated_torque} N m")
    save_figure(fig, out_dir, "profile_contacts")
    # TE and spectrum
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    out_deg = np.rad2deg(qs["theta_in"] / abs(model.ratio))
    ax[0].plot(out_deg, (qs["te"] - np.mean(qs["te"])) * ARCSEC_PER_RAD, lw=0.8, label="quasi-static")
    out_dyn = np.rad2deg(dyn["theta_in"] - dyn["theta_in"][0]) / abs(model.ratio)
    ax[0].plot(out_dyn, (dyn["te"] - np.mean(dyn["te"])) * ARCSEC_PER_RAD, lw=0.8, label="dynamic")
    ax[0].set(xlabel="output angle [deg]", ylabel="TE - mean [arcsec]")
    ax[0].legend(fontsize=8)
    o, a = met["orders"], met["amplitudes"] * ARCSEC_PER_RAD
    ax[1].semilogy(o[1:], np.maximum(a[1:], 1e-8), lw=0.8)
    ax[1].set(xlabel="output-shaft order", ylabel="amplitude [arcsec]", title=f"order spectrum ({revs:.3g} output rev)")
    save_figure(fig, out_dir, "transmission_error")
    # pin-force distribution
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for k in range(F.shape[0]):
        ax.bar(np.arange(F.shape[1]) + 0.4 * k, F[k], width=0.4, label=f"wheel {k}")
    ax.set(xlabel="pin index (clockwise from +y)", ylabel="normal force [N]", title="pin forces at the rated state")
    ax.legend(fontsize=8)
    save_figure(fig, out_dir, "pin_forces")


def honest_figures(design, model, q_rated, *, quick, bearing_model, peaks_rated, allowables=None, te_states=None):
    """Issue 21 figures at the rated state q_rated of ``model``: the stiffness budget (energy shares
    and switch-to-rigid shares, :mod:`rvtool.protocols.budget`), the lost-motion budget at +-3 %
    with its closed-form estimates, the branch stiffness slopes and catalogue secant (stiffness
    sequence; --quick: 25 % level steps), the default-resolution error of the rated peak pin
    force against 8x the profile samples, the hysteresis loss of a closed +-T_rated cycle, and the
    datasheet against ``allowables``. te_states: (input angles [rad], states) of a quasi-static TE
    sequence of ``model`` at the rated torque (None: q_rated alone); the pin bending stress is the
    largest over these states and the bearings' ISO 281 mean load is taken over them."""
    from .. import designs
    from ..protocols.budget import stiffness_budget
    from .budget import lost_motion_budget
    from ..designs.allowables import load_allowables
    from ..protocols.datasheet import datasheet
    from ..protocols.stiffness import TorqueSequence, branch_fits, quasi_static_stiffness
    t0 = time.perf_counter()
    allowables = allowables or load_allowables(designs.path("rd40_allowables"))
    sb = stiffness_budget(model, q_rated)
    energy = sb["shares"]
    stiffness = {"shares": energy, "rigid_shares": sb["rigid_shares"],
                 "sensitivity_shares": sb["sensitivity_shares"],
                 "rigid_minus_energy": {f: sb["rigid_shares"][f] - energy[f] for f in sb["rigid_shares"]},
                 "rigid_shares_sum": float(sum(sb["rigid_shares"].values())),
                 "K_t_Nm_per_arcmin": sb["K_t_Nm_per_arcmin"], "residual_entry": sb["residual"],
                 "difference": "energy shares sum to one (springs in series share the compliance by their "
                               "compliance) and equal the sensitivity shares (the compliance lost by stiffening "
                               "a path by 1 + 1e-4, per 1e-4: the infinitesimal switch to rigid); the finite "
                               "switch-to-rigid shares add the load redistribution a rigid path causes (the "
                               "wheels float on bearings, output pins and ring pins at once, in parallel), so "
                               "they exceed the energy shares and sum above one"}
    lm = lost_motion_budget(design, bearing_model=bearing_model)
    lm_out = dict(lm["budget_arcmin"])
    lm_out["estimates"] = lm["estimates_arcmin"]
    lm_out["total"] = lm["total_arcmin"]
    step = 0.25 if quick else None
    seq = TorqueSequence(rated_torque=design.rated_torque, **({"loading_step": step, "other_step": step} if quick else {}))
    st = quasi_static_stiffness(build(design, bearing_model=bearing_model), seq)
    fits = branch_fits(st["torque_Nm"], st["angle_arcmin"], st["labels"], design.rated_torque)
    tq, ang = np.asarray(st["torque_Nm"]), np.asarray(st["angle_arcmin"])
    i50 = int(np.flatnonzero(np.isclose(tq, 0.5 * design.rated_torque))[0])
    i100 = int(np.flatnonzero(np.isclose(tq, design.rated_torque))[0])
    secant = float((tq[i100] - tq[i50]) / (ang[i100] - ang[i50]))
    # default resolution: rated peak pin force at the default against 8x the profile samples
    fine = design
    for _ in range(3):
        fine = build(fine, bearing_model=bearing_model).refined_design()
    m_fine = build(fine, bearing_model=bearing_model)
    m_fine.set_output_torque(-np.sign(m_fine.ratio) * design.rated_torque)
    f_fine = m_fine.family_contact_peaks(StaticSolver(m_fine).solve(0.0))["pins"]
    res_err = float(abs(peaks_rated["pins"] - f_fine) / f_fine)
    angles, states = te_states if te_states is not None else (np.zeros(1), [q_rated])
    bending = {}
    for fam, sup in (("pins", allowables.assumed_ring_pin_support),
                     ("output_pins", allowables.assumed_output_pin_support)):
        b = model.pin_bending(states, fam, sup)
        if b is not None:
            b.update(n_states=len(states), input_angle_deg=float(np.rad2deg(angles[b["state"]])))
        bending[fam] = b
    hyst = hysteresis_loss(design, bearing_model=bearing_model, quick=quick)
    sheet = datasheet(rated_torque=design.rated_torque, ratio=float(model.ratio),
                      branch_slopes={b: f["K_Nm_per_arcmin"] for b, f in fits.items()}, secant=secant,
                      lost_motion_arcmin=lm["total_arcmin"], hertz_peaks=model.hertz_peaks(q_rated),
                      pin_bending_stress=bending,
                      bearing_loads={f: v for f, v in peaks_rated.items() if f not in ("pins", "output_pins")},
                      resolution_error=res_err, allowables=allowables, hysteresis=hyst,
                      bearing_life=bearing_lives(model, design, states))
    sheet["resolution_error"]["reference"] = {"default": model.resolution_settings(),
                                              "refined_samples_per_tooth": fine.wheels.samples_per_tooth,
                                              "peak_pin_force_default_N": peaks_rated["pins"],
                                              "peak_pin_force_refined_N": f_fine}
    return {"stiffness_budget": stiffness, "lost_motion_budget_arcmin": lm_out, "datasheet": sheet,
            "wall_s": time.perf_counter() - t0}


CYCLE_TOL_ARCMIN = 1e-4
"""Repeatability tolerance of the hysteresis cycle [arcmin] (as cases/cycloid/hysteresis_friction.py: the
static solves' Newton tolerance moves a level by ~1e-7 arcmin)."""


def hysteresis_loss(design, *, bearing_model, quick):
    """Hysteresis loss [arcmin] of ``design``: the loop width at zero torque of the second of two
    closed -T_rated -> +T_rated -> -T_rated cycles after a virgin preload
    (:func:`rvtool.protocols.hysteresis_cycles.quasi_static_cycles`, levels every 25 % (quick) or
    6.25 % of T_rated plus +-3 %), with the second cycle's repeatability against the first and a
    note on the friction the design declares. The width is the catalogue's
    (:mod:`rvtool.protocols.catalogue`): along the unloading branches, each extrapolated to zero
    torque from its own side, so it holds the friction memory AND the free play of the clearances."""
    from ..units import RAD_PER_ARCMIN
    from ..protocols import hysteresis as H
    from ..protocols import hysteresis_cycles as HC
    seq = HC.CycleSequence(rated_torque=design.rated_torque, step=0.25 if quick else 0.0625)
    r = HC.quasi_static_cycles(build(design, bearing_model=bearing_model), seq, energy=False)
    prev, last = r["cycles"][-2], r["cycles"][-1]
    fig = HC.catalogue_figures(last["torque_Nm"], last["angle_rad"], last["labels"], design.rated_torque)
    rep = H.repeatability(H.Cycle(torque=prev["torque_Nm"], angle=prev["angle_rad"]),
                          H.Cycle(torque=last["torque_Nm"], angle=last["angle_rad"]),
                          tolerance=CYCLE_TOL_ARCMIN * RAD_PER_ARCMIN)
    mu = {"pin_contact": getattr(getattr(design, "pin_contact", None), "mu", 0.0),
          "output_pins": getattr(getattr(design, "output_pins", None), "mu", 0.0)}
    note = ("frictionless contacts (mu = 0): no friction memory, the width is the clearances' free play"
            if not any(mu.values()) else f"friction mu {mu}; the width includes the clearances' free play")
    if not rep.passed:
        note += f"; the cycle does not repeat within {CYCLE_TOL_ARCMIN:g} arcmin"
    return {"loss_arcmin": fig.hysteresis_loss_arcmin, "repeat_arcmin": rep.max_angle_diff / RAD_PER_ARCMIN,
            "note": note, "levels_per_cycle": len(last["torque_Nm"]), "step": seq.step}


RADIAL_ZERO = 1e-9
"""A bearing resultant below this fraction of its element loads is the round-off of a balanced
(preloaded) ring, not a radial load (as cases/studies/fatigue_life.py)."""


def bearing_lives(model, design, states):
    """Bearing name -> ISO 281 figures (:func:`rvtool.slow.fatigue.rating_life`) at the design's
    input speed from the radial loads |sum_j Q_j n_j| of the rolling-element rows at ``states``
    (points of a quasi-static TE sequence, equally spaced in input angle, hence in time at constant
    speed: the ISO mean load is P_m = (mean P^p)^(1/p)); L10_h None where a bearing carries no
    radial load (e.g. the opposed wheels' input bearings under pure torque: their life needs the
    application's external loads). Topologies without ISO 281 geometries give {}."""
    from ..slow import fatigue as Fa
    from ..slow.cycloid import rating_geometries
    try:
        geometries = rating_geometries(design)
    except AttributeError:        # a topology without the cycloid drive's bearing sections
        return {}
    fam_of = {"eccentric_bearing": "eccentric_bearings", "main_bearing": "main_bearings",
              "input_bearing": "input_bearings"}
    omega = design.input_speed_rpm * np.pi / 30.0
    out = {}
    for name, (geom, speed_factor) in geometries.items():
        fam = fam_of[name.rstrip("0123456789")]
        P, Qsum = [], 0.0
        for q in states:
            ob = model.observe(q, fam)
            rows = [i for i, r in enumerate(ob.ids) if r.startswith(name + "/")]
            if not rows:
                break
            P.append(Fa.radial_load_from_elements(ob.normal_force[rows], ob.normal[rows]))
            Qsum = max(Qsum, float(np.sum(ob.normal_force[rows])))
        if not P:
            continue                     # no rolling-element rows of this bearing (lumped bearings)
        P = np.where(np.array(P) > RADIAL_ZERO * Qsum, P, 0.0)
        p = geom.life_exponent
        Pm = Fa.mean_equivalent_load(float(np.sum(P ** p)), float(len(P)), p)
        row = {"C_r_N": geom.dynamic_load_rating(), "P_m_N": Pm, "P_max_N": float(P.max()), "exponent": p,
               "speed_rpm": speed_factor * design.input_speed_rpm, "L10_h": None}
        if Pm > 0.0:
            row["L10_h"] = Fa.rating_life(geom, Pm, speed_factor * omega).L10_hours
        out[name] = row
    return out


def _budget_plots(h, out_dir):
    import matplotlib.pyplot as plt

    from .output import save_figure
    fig, ax = plt.subplots(1, 3, figsize=(15, 4))
    sb = h["stiffness_budget"]
    names = list(sb["shares"])
    ax[0].barh(names, [sb["shares"][n] for n in names], label="energy share (condensed tangent)")
    ax[0].barh(list(sb["rigid_shares"]), list(sb["rigid_shares"].values()), height=0.4, label="switch to rigid")
    ax[0].set(xlabel="share of output compliance [-]", title=f"stiffness budget, K_t {sb['K_t_Nm_per_arcmin']:.1f} N m/arcmin")
    ax[0].legend(fontsize=7)
    lm = h["lost_motion_budget_arcmin"]
    parts = [k for k in lm if k not in ("estimates", "total")]
    ax[1].barh(parts, [lm[k] for k in parts], label="simulated")
    est = [lm["estimates"].get(k, np.nan) for k in parts]
    ax[1].plot(est, parts, "k|", ms=14, label="closed-form estimate")
    ax[1].set(xlabel="arcmin", title=f"lost motion +-3 %: {lm['total']:.3f} arcmin")
    ax[1].legend(fontsize=7)
    ds = h["datasheet"]
    rows = [(k, v) for k, v in ds.items() if v.get("allowable") is not None and v.get("value") is not None]
    ratio = [v["value"] / v["allowable"] for _, v in rows]
    ax[2].barh([k for k, _ in rows], ratio, color=["g" if v["meets_allowable"] else "r" for _, v in rows])
    ax[2].axvline(1.0, color="k", lw=0.8)
    ax[2].set(xlabel="value / allowable", title="datasheet (green: pass)")
    save_figure(fig, out_dir, "budgets_datasheet")
