"""RD-40 (double wheel) torsional stiffness, lost motion and hysteresis: 74-level signed torque sequence.

Fixed input (angle 0) and housing; output torque through loading to +T_rated,
unloading, reversal to -T_rated and return to zero. Path (b), the quasi-static
equilibrium continuation, is run; path (a), dynamic settling with the implicit
integrator, is not implemented yet (its keys are null). Reports branch fits of
Eq. (stiffness_fit) over 50-100 % of T_rated, lost motion at +-3 %, the zero-load
return difference, per-level pin-mesh statistics per wheel, and the condensed
tangent K_t (Eq. obs_condensed_stiffness) against a finite torque increment.
"""
import os
import time

import numpy as np

from rvtool import casekit
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.protocols import stiffness as S

DESIGN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "designs", "rd40.toml")


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
    fit_k = fits["pos_loading"]["K_Nm_per_arcmin"]
    results = {
        "torque_Nm": torque, "angle_arcmin": angle, "branch_labels": labels,
        "branch_fits": {b: {k: v for k, v in f.items()} for b, f in fits.items()},
        "lost_motion_arcmin": S.lost_motion(torque, angle, rated),
        "zero_load_return_arcmin": S.zero_load_return(torque, angle),
        "Kt_condensed_Nm_per_arcmin": tc["Kt_condensed_Nm_per_arcmin"],
        "Kt_at_torque_Nm": t_ref,
        "K_finite_increment_Nm_per_arcmin": tc["K_finite_increment_Nm_per_arcmin"],
        "Kt_rel_diff_finite_increment": tc["rel_diff"],
        "Kt_rel_diff_branch_fit_pos_loading": abs(tc["Kt_condensed_Nm_per_arcmin"] - fit_k) / fit_k,
        "wall_s_quasistatic": qs["wall_s"],
        "wall_s_dynamic": None,
        "stiffness_rel_diff_paths": None,
        "dynamic_path": "not implemented: path (a) dynamic settling is not available yet",
        "sum_Fn_N": qs["sum_Fn_N"], "max_Fn_N": qs["max_Fn_N"],
        "max_tail_span_arcmin": 0.0,
        "settling_note": "quasi-static levels are converged Newton equilibria (tail span 0 by construction)",
        "continuation": qs["stats"], "regularization_max_N": qs["regularization_max"],
    }
    settings = {"design": design.name, "sequence": seq.__dict__, "n_levels": len(torque),
                "bearing_model": "lumped", "input_angle_rad": 0.0, "quick": args.quick,
                "note": "the full 74-level sequence also runs in --quick (about 2 s)"}
    _plot(args.out, torque, angle, fits, qs)
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
