"""RD-40 hysteresis with friction memory: anchor (stick--slip) friction on the pin mesh and output pins.

Protocol (rvtool.protocols.hysteresis_cycles): fixed input (angle 0) and
housing, a virgin preload from zero to -T_rated, then two identical signed
cycles -T_rated -> +T_rated -> -T_rated with levels symmetric about zero
torque (fine levels down to 0.05 % of T_rated resolve the free-play crossing).
Path (b), quasi-static continuation, commits the contact history (anchors) once
per converged level and samples the energy account there; ∮T dθ of the second
cycle is admitted as dissipation only when that cycle closes and repeats the
first (rvtool.protocols.hysteresis.cycle_dissipation), and is then compared
with the friction dissipation the account recorded from the committed anchors.
Path (a), dynamic relaxation with the implicit integrator (ramps, dwells,
kinetic resets), runs a coarser cycle sequence; path (b) runs the same coarse
levels for the comparison of the paths.

Figures (RD-40, mu = 0.05 on both families): hysteresis loss (loop width at
zero torque), lost motion (catalogue midpoint definition at +-3 % of rated
torque), the four branch fits of Eq. (stiffness_fit) over 50-100 % of rated
torque, ∮T dθ, friction dissipation per family, the run's energy balance, cycle
repeatability, the difference of the paths; and hysteresis loss and lost
motion versus mu in (0, 0.02, 0.05, 0.1).

RV (rv40e, issue 16's design, with its declared needle clearance and backlash): anchor friction
mu = 0.05 on the cycloid--pin mesh and on the involute stage (``[involute_stage]`` mu, anchor
stiffness from Mindlin's ratio of the tooth pair's secant stiffness at the rated mesh force
T_rated / (|i| r_b,sun N_cranks)), path (b) on the same kind of cycle sequence (--quick: 12.5 %
steps), under the key ``rv40e`` of every figure: hysteresis loss, lost motion, the four branch
fits, ∮T dθ, closure and repeatability of the second cycle, the friction dissipation per family
from the energy account (the involute series law and the rolling-element sets have their elastic
energy: ``energy_law()`` of each contact set), ∮T dθ against it, the run's energy balance, and
(full run only: about 45 s of dynamic relaxation through the free play) path (a) against path (b).
"""
import os
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build
from rvtool import load_design, replace_design as replace
from rvtool import build as build_any
from rvtool import load_design as load_rv_design
from rvtool.protocols import hysteresis_cycles as HC
from rvtool.protocols import stiffness as S
from rvtool.units import RAD_PER_ARCMIN

DESIGN = designs.path("rd40")
MU = 0.05
MU_SWEEP = (0.0, 0.02, 0.05, 0.1)
#: Repeatability and closure tolerance of a cycle [arcmin]: the Newton tolerance of the static
#: solves moves a level's angle by ~1e-7 arcmin; 1e-4 arcmin (0.03 urad) leaves three decades.
CYCLE_TOL_ARCMIN = 1e-4
#: Energy balance of the whole run: trapezoidal work on the levels against the account; the
#: largest quadrature error is the free-play crossing of the virgin preload (0 -> -0.05 % T_rated),
#: bounded below by 1e-3 of the load work at these levels (measured 4e-4 with step 1/8).
ENERGY_TOL = 5e-3


def friction_design(design, mu):
    """RD-40 with anchor friction mu on the pin mesh and the output pins (mu = 0: frictionless code)."""
    return replace(design, pin_contact={"mu": mu, "friction_model": "anchor"}, output_pins={"mu": mu})


def quasi_static(design, mu, seq):
    """Path (b) at friction mu: catalogue figures of the last cycle, the closed-cycle check,
    dissipation per family of the last cycle and the energy account of the run."""
    t0 = time.perf_counter()
    r = HC.quasi_static_cycles(build(friction_design(design, mu)), seq)
    return {**cycle_figures(r, seq), "wall_s": time.perf_counter() - t0}


def cycle_figures(r, seq):
    """The catalogue figures of the last cycle of a quasi-static cycle run ``r``, its closure and
    repeatability against the cycle before, the friction dissipation of that cycle and the run's
    energy account (RD-40 and rv40e alike)."""
    from rvtool.protocols import hysteresis as H
    prev, last = r["cycles"][-2], r["cycles"][-1]
    fig = HC.catalogue_figures(last["torque_Nm"], last["angle_rad"], last["labels"], seq.rated_torque)
    cyc = H.Cycle(torque=last["torque_Nm"], angle=last["angle_rad"])
    rep = H.repeatability(H.Cycle(torque=prev["torque_Nm"], angle=prev["angle_rad"]), cyc,
                          tolerance=CYCLE_TOL_ARCMIN * RAD_PER_ARCMIN)
    closed = HC.closed_cycle(prev, last, angle_tolerance=CYCLE_TOL_ARCMIN * RAD_PER_ARCMIN)
    return {"figures": fig, "cycle": last, "repeat_arcmin": rep.max_angle_diff / RAD_PER_ARCMIN,
            "closure_arcmin": closed.closure_angle / RAD_PER_ARCMIN, "loop_J": closed.loop_integral,
            "dissipation_J": last["friction_dissipation_J"], "energy": r["energy"], "stats": r["stats"],
            "quadrature_bound_J": HC.loop_quadrature_bound(cyc)}


RV_DESIGN = designs.path("rv40e")
#: Energy balance of the RV run: measured 4.2e-3 (25 % steps), 4.9e-4 (12.5 %), 2.6e-4 (6.25 %): the
#: trapezoidal work converges as h^2 to a floor from the free-play crossings (as on RD-40) and from the
#: migration of the involute contact along the flanks and of the rolling elements with the cage (the
#: series coefficients and the element directions move with the state, a non-potential part of the
#: contact forces of the order of the flank-position change); the RD-40 tolerance covers both.
RV_ENERGY_TOL = ENERGY_TOL


def rv_design(mu):
    """rv40e with anchor friction mu on the pin mesh and the involute stage (mu = 0: frictionless code)."""
    d = load_rv_design(RV_DESIGN)
    from rvtool.assembly.rv.gear_graph import GearGraph
    g = GearGraph.of(d)
    # the anchor stiffness is calibrated at the rated force of one sun--crank-gear mesh
    f_mesh = d.rated_torque / abs(g.ratio) / g.sun_pair.gear_a.base_radius / d.cranks.count
    return d.replace(pin_contact={"mu": mu, "friction_model": "anchor"},
                     involute_stage={"mu": mu, "friction_model": "anchor", "reference_force": f_mesh})


def rv_quasi_static(mu, quick):
    """Path (b) on rv40e with anchor friction mu on the pin mesh and the involute stage: the catalogue
    figures of the second cycle, its closure and repeatability against the first, the friction
    dissipation per family of that cycle and the energy account of the run."""
    t0 = time.perf_counter()
    d = rv_design(mu)
    seq = HC.CycleSequence(rated_torque=d.rated_torque, step=0.125 if quick else 0.0625,
                           fine_levels=(0.0005, 0.001, 0.003, 0.01, 0.03))
    r = HC.quasi_static_cycles(build_any(d), seq)
    return {**cycle_figures(r, seq), "sequence": seq.__dict__, "design": d.name, "wall_s": time.perf_counter() - t0}


def loop_max_width(cycle):
    """Largest angle [arcmin] between the loading and the unloading branch at one torque (positive side)."""
    th = cycle["angle_rad"] / RAD_PER_ARCMIN
    lab, T = cycle["labels"], cycle["torque_Nm"]
    return max(abs(th[j] - th[i]) for i, li in enumerate(lab) for j, lj in enumerate(lab)
               if li == "pos_loading" and lj == "pos_unloading" and T[i] == T[j])


def rv_paths(mu, rv_run):
    """Path (a) (dynamic relaxation) against path (b) on one coarse rv40e cycle sequence."""
    d = rv_design(mu)
    dseq = HC.CycleSequence(rated_torque=d.rated_torque, step=1.0, fine_levels=(0.03,), ramp_steps=20,
                            dwell_steps=60, reset_interval=30, settle_span_arcmin=0.01)
    dyn = S.dynamic_stiffness(build_any(d), dseq, step=2e-5)
    qs = HC.quasi_static_cycles(build_any(d), dseq, energy=False)
    dyn_last = dseq.split(dyn["angle_arcmin"])[-1]
    qs_last = qs["cycles"][-1]["angle_rad"] / RAD_PER_ARCMIN
    span = float(np.ptp(qs_last))
    diff = float(np.max(np.abs(dyn_last - qs_last)))
    width = loop_max_width(rv_run["cycle"])
    tail = float(np.max(dyn["tail_span_arcmin"]))
    # rate-independent friction: equilibria at one torque differ by locked-in stick states, by at most
    # the loop's width; on the RV the wheels float in the needle clearance, so the dynamic path does
    # not settle within its dwell at every level (forced commits): its tail drift is added
    tol = width + tail
    return {"value": diff / span, "tolerance": tol / span, "passed": bool(diff <= tol),
            "max_level_diff_arcmin": diff, "loop_max_width_arcmin": width, "max_tail_span_arcmin": tail,
            "cycle_span_arcmin": span,
            "note": "max over the levels of the last cycle |theta_a - theta_b| / peak-to-peak angle of path (b); "
                    "tolerance: largest loop width of path (b) plus the largest unsettled tail span of path (a)",
            "dynamic": {"forced_commits": dyn["stats"]["forced_commits"], "steps": dyn["stats"]["steps"],
                        "step_s": dyn["step_s"]},
            "wall_s": {"dynamic_path": dyn["wall_s"], "quasi_static_coarse_path": qs["wall_s"]}}


def judge(r):
    """The case's checks on its results (see casekit.verdict): each criterion against the tolerance the
    case derives for it (quadrature bound, energy tolerance, repeatability), RD-40 and rv40e."""
    checks = {}
    for key in ("loop_vs_dissipation_rel_err", "energy_balance_rel_err", "cycle_repeatability_arcmin",
                "paths_rel_diff"):
        for label, block in (("rd40", r[key]), ("rv40e", r[key].get("rv40e", {}))):
            if "tolerance" in block:
                value = max(block["value"], block.get("closure_arcmin", 0.0))
                checks[f"{label}_{key}"] = casekit.check(value, block["tolerance"], "<=",
                                                         why=block.get("tolerance_note", "the case's tolerance"))
    # frictionless contacts (mu = 0) dissipate nothing: the loop encloses no area, to the trapezoid's
    # quadrature bound on its levels (HC.loop_quadrature_bound). Its catalogue hysteresis loss is not zero:
    # the catalogue's width at zero torque along the unloading branches holds the free play (clearances)
    checks["frictionless_no_dissipation"] = casekit.check(
        abs(r["loop_area_J"]["vs_mu"]["0.0"]), max(r["loop_area_J"]["quadrature_bound_vs_mu"]["0.0"], 1e-12), "<=",
        why="no friction, no dissipation: the frictionless loop's integral within its quadrature bound")
    # Coulomb friction: the loss grows with mu (monotone over the sweep)
    losses = [v for _, v in sorted((float(k), v) for k, v in r["hysteresis_loss_arcmin"]["vs_mu"].items())]
    checks["loss_grows_with_mu"] = casekit.check(min(b - a for a, b in zip(losses, losses[1:])), 0.0, ">",
                                                 why="more friction, wider loop")
    return checks


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_start = time.perf_counter()
    design = load_design(DESIGN)
    rated = design.rated_torque
    fine = (0.0005, 0.001, 0.003, 0.01, 0.03)
    seq = HC.CycleSequence(rated_torque=rated, step=0.125 if args.quick else 0.0625, fine_levels=fine)

    sweep = {mu: quasi_static(design, mu, seq) for mu in MU_SWEEP}
    main_run = sweep[MU]
    fig = main_run["figures"]
    D = main_run["dissipation_J"]
    D_total = float(sum(D.values()))
    loop = main_run["loop_J"]
    loop_err = abs(loop - D_total) / D_total
    loop_tol = main_run["quadrature_bound_J"] / D_total
    energy = main_run["energy"]

    # path (a) against path (b) on one coarse cycle sequence (the same levels)
    dseq = HC.CycleSequence(rated_torque=rated, step=1.0 if args.quick else 0.25, fine_levels=(0.03,),
                            ramp_steps=20 if args.quick else 30, dwell_steps=60 if args.quick else 100,
                            reset_interval=30 if args.quick else 100,
                            settle_span_arcmin=0.01 if args.quick else 0.002)
    dyn = S.dynamic_stiffness(build(friction_design(design, MU)), dseq, step=2e-5)
    qs = HC.quasi_static_cycles(build(friction_design(design, MU)), dseq, energy=False)
    dyn_last = dseq.split(dyn["angle_arcmin"])[-1]
    qs_last = qs["cycles"][-1]["angle_rad"] / RAD_PER_ARCMIN
    fr, labels = dseq.cycle()
    span = float(np.ptp(qs_last))
    level_diff = float(np.max(np.abs(dyn_last - qs_last)))
    # rate-independent friction: equilibria at one torque differ by locked-in stick states, by at
    # most about the loop's width; the tolerance is the largest width of the path-(b) loop
    # (same torque on its loading and unloading branch, from the fine sequence of the sweep)
    width = loop_max_width(main_run["cycle"])
    paths = {"value": level_diff / span, "tolerance": width / span, "passed": bool(level_diff <= width),
             "max_level_diff_arcmin": level_diff, "loop_max_width_arcmin": width, "cycle_span_arcmin": span,
             "note": "max over the levels of the last cycle |theta_a - theta_b| / peak-to-peak angle of path (b)",
             "dynamic": {"forced_commits": dyn["stats"]["forced_commits"], "steps": dyn["stats"]["steps"],
                         "step_s": dyn["step_s"], "max_tail_span_arcmin": float(np.max(dyn["tail_span_arcmin"]))}}
    if not args.quick:
        tq = fr * rated
        fd, fq = (S.branch_fits(tq, a, labels, rated) for a in (dyn_last, qs_last))
        paths["branch_K_rel_diff"] = {b: abs(fd[b]["K_Nm_per_arcmin"] - fq[b]["K_Nm_per_arcmin"])
                                      / abs(fq[b]["K_Nm_per_arcmin"]) for b in S.BRANCHES}

    results = {
        "hysteresis_loss_arcmin": {"value": fig.hysteresis_loss_arcmin, "mu": MU,
                                   "vs_mu": {str(m): r["figures"].hysteresis_loss_arcmin for m, r in sweep.items()}},
        "lost_motion_arcmin": {"value": fig.lost_motion_arcmin, "mu": MU,
                               "vs_mu": {str(m): r["figures"].lost_motion_arcmin for m, r in sweep.items()}},
        "branch_fits": dict(fig.branch_fits),   # a copy: the rv40e entry is added below
        "loop_area_J": {"value": loop, "vs_mu": {str(m): r["loop_J"] for m, r in sweep.items()},
                        "quadrature_bound_vs_mu": {str(m): r["quadrature_bound_J"] for m, r in sweep.items()}},
        "friction_dissipation_J": {**D, "total": D_total},
        "loop_vs_dissipation_rel_err": {"value": loop_err, "tolerance": loop_tol, "passed": bool(loop_err <= loop_tol),
                                        "tolerance_note": "quadrature bound of the trapezoidal loop on its levels "
                                                          "(free-play crossings and a step-doubling estimate on "
                                                          "the branches, HC.loop_quadrature_bound), relative to D"},
        "energy_balance_rel_err": {"value": energy["balance_rel_err"], "tolerance": ENERGY_TOL,
                                   "passed": bool(energy["balance_rel_err"] <= ENERGY_TOL),
                                   "residual_J": energy["balance_residual_J"], "load_work_J": energy["load_work_J"],
                                   "friction_dissipation_total_J": energy["friction_dissipation_total_J"]},
        "cycle_repeatability_arcmin": {"value": main_run["repeat_arcmin"], "closure_arcmin": main_run["closure_arcmin"],
                                       "tolerance": CYCLE_TOL_ARCMIN,
                                       "passed": bool(max(main_run["repeat_arcmin"], main_run["closure_arcmin"])
                                                      <= CYCLE_TOL_ARCMIN)},
        "paths_rel_diff": paths,
        "wall_s": {"quasi_static_per_mu": {str(m): r["wall_s"] for m, r in sweep.items()},
                   "dynamic_path": dyn["wall_s"], "quasi_static_coarse_path": qs["wall_s"]},
    }
    rv = rv_quasi_static(MU, args.quick)
    rvf = rv["figures"]
    rv_ok = bool(max(rv["repeat_arcmin"], rv["closure_arcmin"]) <= CYCLE_TOL_ARCMIN)
    rvD = rv["dissipation_J"]
    rvD_total = float(sum(rvD.values()))
    rv_loop_err = abs(rv["loop_J"] - rvD_total) / rvD_total
    rv_loop_tol = rv["quadrature_bound_J"] / rvD_total
    rve = rv["energy"]
    results["hysteresis_loss_arcmin"]["rv40e"] = {"value": rvf.hysteresis_loss_arcmin, "mu": MU,
                                                  "friction_families": ["pins", "gears"]}
    results["lost_motion_arcmin"]["rv40e"] = {"value": rvf.lost_motion_arcmin, "mu": MU}
    results["branch_fits"]["rv40e"] = rvf.branch_fits
    results["loop_area_J"]["rv40e"] = {"value": rv["loop_J"]}
    results["friction_dissipation_J"]["rv40e"] = {**rvD, "total": rvD_total}
    results["loop_vs_dissipation_rel_err"]["rv40e"] = {
        "value": rv_loop_err, "tolerance": rv_loop_tol, "passed": bool(rv_loop_err <= rv_loop_tol),
        "tolerance_note": "quadrature bound of the trapezoidal loop on its levels (HC.loop_quadrature_bound), "
                          "relative to D"}
    results["energy_balance_rel_err"]["rv40e"] = {
        "value": rve["balance_rel_err"], "tolerance": RV_ENERGY_TOL, "passed": bool(rve["balance_rel_err"] <= RV_ENERGY_TOL),
        "residual_J": rve["balance_residual_J"], "load_work_J": rve["load_work_J"],
        "friction_dissipation_total_J": rve["friction_dissipation_total_J"],
        "elastic_end_J": rve["elastic_end_J"]}
    results["cycle_repeatability_arcmin"]["rv40e"] = {"value": rv["repeat_arcmin"], "closure_arcmin": rv["closure_arcmin"],
                                                      "tolerance": CYCLE_TOL_ARCMIN, "passed": rv_ok}
    if args.quick:
        results["paths_rel_diff"]["rv40e"] = {"available": False,
                                              "reason": "path (a) on rv40e runs in the full case only (about 45 s of "
                                                        "dynamic relaxation through the free play on 2 cores)"}
    else:
        results["paths_rel_diff"]["rv40e"] = rv_paths(MU, rv)
    results["wall_s"]["rv40e_quasi_static"] = rv["wall_s"]
    settings = {"design": design.name, "rv_design": rv["design"], "rv_sequence": rv["sequence"],
                "rv_continuation": rv["stats"], "mu": MU, "mu_sweep": MU_SWEEP, "sequence": seq.__dict__,
                "dynamic_sequence": dseq.__dict__, "n_levels_per_cycle": len(seq.cycle()[0]),
                "continuation": main_run["stats"], "bearing_model": "lumped", "input_angle_rad": 0.0,
                "quick": args.quick,
                "friction": "anchor model on cycloid-pin slices and output-pin slices, k_t = Mindlin ratio "
                            "2(1-nu)/(2-nu) of the normal secant stiffness"}
    _plot(args.out, main_run, sweep, fig)
    print(f"RD-40 mu={MU}: hysteresis loss {fig.hysteresis_loss_arcmin:.4g} arcmin, lost motion "
          f"{fig.lost_motion_arcmin:.4g} arcmin, loop {loop:.4e} J vs dissipation {D_total:.4e} J "
          f"(rel. err {loop_err:.2e}, bound {loop_tol:.2e}), energy balance {energy['balance_rel_err']:.2e}, "
          f"repeatability {main_run['repeat_arcmin']:.2e} arcmin, paths {paths['value']:.2e} (tol {paths['tolerance']:.2e})")
    print(f"rv40e mu={MU} on the pins and the involute stage: hysteresis loss {rvf.hysteresis_loss_arcmin:.4g} "
          f"arcmin, lost motion {rvf.lost_motion_arcmin:.4g} arcmin, loop {rv['loop_J']:.4e} J vs dissipation "
          f"{rvD_total:.4e} J {rvD} (rel. err {rv_loop_err:.2e}, bound {rv_loop_tol:.2e}), energy balance "
          f"{rve['balance_rel_err']:.2e}, repeatability {rv['repeat_arcmin']:.2e} arcmin")
    _plot_rv(args.out, rv)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_start)


def _plot_rv(out, rv):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    c = rv["cycle"]
    T, th = c["torque_Nm"], c["angle_rad"] / RAD_PER_ARCMIN
    f, ax = plt.subplots(figsize=(6, 4.3))
    ax.plot(th, T, ".-", lw=0.8, ms=3, label=f"rv40e, mu = {MU} on the pins and gears, second cycle")
    for b, fit in rv["figures"].branch_fits.items():
        if fit["K_Nm_per_arcmin"] is not None:
            y = (1.0 if b.startswith("pos") else -1.0) * np.linspace(0.5, 1.0, 20) * np.max(np.abs(T))
            ax.plot((y - fit["b_Nm"]) / fit["K_Nm_per_arcmin"], y, "--", lw=0.9, label=f"fit {b}")
    ax.set(xlabel="output angle [arcmin]", ylabel="output torque [N m]", title="rv40e loop and branch fits")
    ax.legend(fontsize=7)
    f.tight_layout()
    casekit.save_figure(f, out, "hysteresis_friction_rv40e")


def _plot(out, main_run, sweep, fig):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    c = main_run["cycle"]
    T, th = c["torque_Nm"], c["angle_rad"] / RAD_PER_ARCMIN
    f, ax = plt.subplots(1, 3, figsize=(15, 4.3))
    ax[0].plot(th, T, ".-", lw=0.8, ms=3, label=f"mu = {MU}, second cycle")
    for b, fit in fig.branch_fits.items():
        if fit["K_Nm_per_arcmin"] is not None:
            y = (1.0 if b.startswith("pos") else -1.0) * np.linspace(0.5, 1.0, 20) * np.max(np.abs(T))
            ax[0].plot((y - fit["b_Nm"]) / fit["K_Nm_per_arcmin"], y, "--", lw=0.9, label=f"fit {b}")
    ax[0].set(xlabel="output angle [arcmin]", ylabel="output torque [N m]", title="loop and branch fits")
    ax[0].legend(fontsize=7)
    for m, r in sweep.items():
        cc = r["cycle"]
        s = np.abs(cc["torque_Nm"]) <= 0.05 * np.max(np.abs(cc["torque_Nm"]))
        ax[1].plot(cc["angle_rad"][s] / RAD_PER_ARCMIN, cc["torque_Nm"][s], ".-", lw=0.8, ms=3, label=f"mu = {m}")
    ax[1].set(xlabel="output angle [arcmin]", ylabel="output torque [N m]", title="low-torque detail")
    ax[1].legend(fontsize=7)
    mus = list(sweep)
    ax[2].plot(mus, [sweep[m]["figures"].hysteresis_loss_arcmin for m in mus], "o-", color="C0")
    ax[2].set(xlabel="friction coefficient mu [-]", title="catalogue figures vs mu")
    ax[2].set_ylabel("hysteresis loss (width at zero torque) [arcmin]", color="C0")
    tw = ax[2].twinx()
    tw.plot(mus, [sweep[m]["figures"].lost_motion_arcmin for m in mus], "s-", color="C1")
    tw.set_ylabel("lost motion (+-3 % midpoints) [arcmin]", color="C1")
    f.tight_layout()
    os.makedirs(out, exist_ok=True)
    casekit.save_figure(f, out, "hysteresis_friction")


if __name__ == "__main__":
    main()
