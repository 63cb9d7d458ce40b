"""RD-40 (double wheel) torsional stiffness, lost motion and hysteresis: 74-level signed torque sequence.

Fixed input (angle 0) and housing; output torque through loading to +T_rated,
unloading, reversal to -T_rated and return to zero. Path (b), the quasi-static
equilibrium continuation, and path (a), dynamic settling with the implicit
integrator (ramp, dwell, kinetic resets at each level and every reset_interval
steps, tail-span settling check), are both run from the same sequence. Reports branch fits of
Eq. (stiffness_fit) over 50-100 % of T_rated, lost motion at +-3 %, the zero-load
return difference, per-level pin-mesh statistics per wheel, and the condensed
tangent K_t (Eq. obs_condensed_stiffness) against a finite torque increment.
"""
import os
import time

import numpy as np

from rvtool import casekit
from rvtool import build
from rvtool import load_design
from rvtool.protocols import stiffness as S
from rvtool import designs

DESIGN = designs.path("rd40")


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    dyn = r["dynamic"]
    rated = max(abs(t) for t in r["torque_Nm"])
    hi_tail = max(s for t, s in zip(dyn["torque_Nm"], dyn["tail_span_arcmin"]) if abs(t) >= 0.5 * rated)
    bf = r["branch_fits"]
    return {
        # Eq. (obs_condensed_stiffness) against a +-0.1 % central torque increment: the increment's own error
        # is O(increment^2 x curvature) (measured 1.7e-7)
        "Kt_vs_finite_increment": casekit.check(r["Kt_rel_diff_finite_increment"], 1e-5, "<=",
                                                why="condensed tangent = central difference at 0.1 % of T"),
        # path (a) settles in time; its level angles at |T| >= 50 % may differ from path (b)'s equilibria
        # by what is still moving at the end of each dwell: twice the largest tail span at those levels
        "paths_agree_high_load": casekit.check(r["angle_max_diff_paths_high_load_arcmin"], 2 * hi_tail, "<=",
                                               why="dynamic settling residual (tail span) of path (a)"),
        # frictionless contacts: the loaded and unloaded branches coincide, so the loop returns to zero
        "zero_load_return": casekit.check(abs(r["zero_load_return_arcmin"]), 1e-6, "<=",
                                          why="no friction, no hysteresis (frictionless nominal design)"),
        # the nominal design is point-symmetric in torque: the negative branches mirror the positive ones
        "branch_symmetry": casekit.check(
            abs(bf["neg_loading"]["K_Nm_per_arcmin"] / bf["pos_unloading"]["K_Nm_per_arcmin"] - 1), 1e-6, "<=",
            why="odd torque response of a symmetric reducer; Newton tolerance"),
        "regularization_unloaded": casekit.check(r["regularization_max_N"] / np.max(r["max_Fn_N"]), 1e-4, "<=",
                                                 why="regularization force negligible against contact loads"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_start = time.perf_counter()
    design = load_design(DESIGN)
    rated = design.rated_torque
    seq = S.rd40_sequence(rated)
    model = build(design)
    qs = S.quasi_static_stiffness(model, seq)
    torque, angle, labels = qs["torque_Nm"], qs["angle_arcmin"], qs["labels"]
    fits = S.branch_fits(torque, angle, labels, rated)
    t_ref = 0.75 * rated
    tc = S.tangent_check(build(design), t_ref)
    tc1 = S.tangent_check(build(design), t_ref, increment=0.01 * t_ref)
    fit_k = fits["pos_loading"]["K_Nm_per_arcmin"]

    # path (a): the same levels in time (quick: a coarse sequence with short dwells)
    if args.quick:
        dseq = S.TorqueSequence(rated_torque=rated, loading_step=0.25, other_step=0.25, ramp_steps=10,
                                dwell_steps=50, reset_interval=25)
    else:
        dseq = S.rd40_sequence(rated, ramp_steps=20, dwell_steps=100, reset_interval=25)
    dyn = S.dynamic_stiffness(build(design), dseq, step=2e-5)
    dfits = S.branch_fits(dyn["torque_Nm"], dyn["angle_arcmin"], dyn["labels"], rated)
    if args.quick:   # compare against quasi-static levels of the same coarse sequence
        ref = S.quasi_static_stiffness(build(design), dseq)
        rfits = S.branch_fits(ref["torque_Nm"], ref["angle_arcmin"], ref["labels"], rated)
        ref_angle = ref["angle_arcmin"]
    else:
        rfits, ref_angle = fits, angle
    rel = {b: abs(dfits[b]["K_Nm_per_arcmin"] - rfits[b]["K_Nm_per_arcmin"]) / rfits[b]["K_Nm_per_arcmin"]
           for b in S.BRANCHES if dfits[b]["K_Nm_per_arcmin"] and rfits[b]["K_Nm_per_arcmin"]}
    hi = np.abs(dyn["torque_Nm"]) >= 0.5 * rated
    results = {
        "torque_Nm": torque, "angle_arcmin": angle, "branch_labels": labels,
        "branch_fits": fits,
        "lost_motion_arcmin": S.lost_motion_from_levels(torque, angle, rated),
        "zero_load_return_arcmin": S.zero_load_return(torque, angle),
        "Kt_condensed_Nm_per_arcmin": tc["Kt_condensed_Nm_per_arcmin"],
        "Kt_at_torque_Nm": t_ref,
        "K_finite_increment_Nm_per_arcmin": tc["K_finite_increment_Nm_per_arcmin"],
        "Kt_rel_diff_finite_increment": tc["rel_diff"], "finite_increment_Nm": tc["increment_Nm"],
        "K_finite_increment_1pct_Nm_per_arcmin": tc1["K_finite_increment_Nm_per_arcmin"],
        "Kt_rel_diff_finite_increment_1pct": tc1["rel_diff"],
        "Kt_rel_diff_branch_fit_pos_loading": abs(tc["Kt_condensed_Nm_per_arcmin"] - fit_k) / fit_k,
        "wall_s_quasistatic": qs["wall_s"],
        "wall_s_dynamic": dyn["wall_s"],
        "speedup_quasistatic_over_dynamic": dyn["wall_s"] / qs["wall_s"] if not args.quick else None,
        "stiffness_rel_diff_paths": max(rel.values()),
        "stiffness_rel_diff_paths_per_branch": rel,
        "angle_max_diff_paths_high_load_arcmin": float(np.max(np.abs(dyn["angle_arcmin"] - ref_angle)[hi])),
        "dynamic": {"torque_Nm": dyn["torque_Nm"], "angle_arcmin": dyn["angle_arcmin"],
                    "tail_span_arcmin": dyn["tail_span_arcmin"], "branch_fits": dfits,
                    "lost_motion_arcmin": S.lost_motion_from_levels(dyn["torque_Nm"], dyn["angle_arcmin"], rated)
                    if np.any(np.isclose(dyn["torque_Nm"], 0.03 * rated)) else None,
                    "zero_load_return_arcmin": S.zero_load_return(dyn["torque_Nm"], dyn["angle_arcmin"]),
                    "max_tail_span_arcmin": float(np.max(dyn["tail_span_arcmin"])),
                    "sequence": dseq.__dict__, "step_s": dyn["step_s"], **dyn["stats"]},
        "sum_Fn_N": qs["sum_Fn_N"], "max_Fn_N": qs["max_Fn_N"],
        "max_tail_span_arcmin": float(np.max(dyn["tail_span_arcmin"])),
        "settling_note": "quasi-static levels are converged Newton equilibria; the tail span is that of path (a)",
        "continuation": qs["stats"], "regularization_max_N": qs["regularization_max"],
    }
    settings = {"design": design.name, "sequence": seq.__dict__, "n_levels": len(torque),
                "bearing_model": "lumped", "input_angle_rad": 0.0, "quick": args.quick,
                "note": "path (b) runs the full 74-level sequence also in --quick; path (a) runs the 74 levels "
                        "only without --quick (quick: a 22-level coarse sequence compared with path (b) on it)"}
    _plot(args.out, torque, angle, fits, qs)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_start)


def _plot(out, torque, angle, fits, qs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(angle, torque, ".-")
    for b, f in fits.items():
        if f["K_Nm_per_arcmin"] is not None:
            x = np.linspace(-3, 3, 50)
            x = x[(np.abs(f["K_Nm_per_arcmin"] * x + f["b_Nm"]) <= 150)]
            ax[0].plot(x, f["K_Nm_per_arcmin"] * x + f["b_Nm"], "--", lw=0.8, label=b)
    ax[0].set_xlabel("output angle [arcmin]")
    ax[0].set_ylabel("torque [N m]")
    ax[0].legend(fontsize=7)
    ax[1].plot(qs["sum_Fn_N"], label="sum Fn")
    ax[1].plot(qs["max_Fn_N"], label="max Fn")
    ax[1].set_xlabel("load level")
    ax[1].set_ylabel("pin normal force [N]")
    ax[1].legend(fontsize=7)
    os.makedirs(out, exist_ok=True)
    casekit.save_figure(fig, out, "stiffness_hysteresis")


if __name__ == "__main__":
    main()
