"""Tolerance Monte Carlo of the RV-40E class reducer (rv40e) with RV tolerances: TE, crank load sharing and lost motion per variant.

Tolerances: rvtool/designs/rv40e_tolerances.toml (crank phase errors and eccentricity
differences per crank, pin radius, needle clearance, sun-gear and crank-gear pitch deviations; all chosen and
declared there), sampled by rvtool.variants.rv_tolerances (variant k from default_rng([seed, k])).
Per variant (a design): the quasi-static TE peak-to-peak at rated load over one crank revolution
at 37 points (a prime count: spread mesh phases; --quick: 7 points), the largest deviation of a
crank's load share from 1/3 over those points, and the lost motion at +-3 % of the rated torque
(spring-controlled march, rvtool.protocols.lost_motion, through the needle clearance).
Summary: mean, standard deviation, 5/50/95 % quantiles; the nominal design's figures alongside.
--quick: 2 variants.
"""
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build, load_design
from rvtool.errors import SolverFailure
from rvtool.protocols.lost_motion import lost_motion
from rvtool.protocols.precision import quasi_static_te
from rvtool.units import ARCMIN_PER_RAD, ARCSEC_PER_RAD
from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design

SEED = 20261124
FIGURES = ("te_pp_arcsec", "crank_share_max_dev", "lost_motion_arcmin")


MAX_FAILURE_RATE = 0.025
"""Largest share of variants that may fail: the full run (40 variants) measured none; one in 40 allowed."""


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    n = len(r["variants"])
    nom = r["nominal"]
    return {
        "failures": casekit.check(r["failed_variants"], int(MAX_FAILURE_RATE * n), "<=",
                                  why="stated maximum failure share MAX_FAILURE_RATE"),
        # every successful variant enters the statistics (no silent drop)
        "all_ok_variants_summarised": casekit.check(r["summary"]["te_pp_arcsec"]["n"], n - r["failed_variants"], "==",
                                                    why="summary over every successful variant"),
        # crank load shares sum to one: a share deviation of 1/3 would mean a crank carries all or nothing
        "nominal_crank_share": casekit.check(nom["crank_share_max_dev"], 1.0 / 3.0, "<",
                                             why="the nominal design loads all three cranks"),
    }


def figures(design, n_points):
    model = build(design)
    crank_rev = 2 * np.pi / abs(model.graph.crank_rate)
    angles = np.arange(n_points) * crank_rev / n_points
    sh = []
    qs = quasi_static_te(model, torque=design.rated_torque, input_angles=angles,
                         record=lambda k, a, q: sh.append(model.crank_load_share(q)))
    lm = lost_motion(build(design), torque_level=0.03 * design.rated_torque)
    return {"te_pp_arcsec": float(np.ptp(qs["te"]) * ARCSEC_PER_RAD),
            "crank_share_max_dev": float(np.max(np.abs(np.array(sh) - 1.0 / design.cranks.count))),
            "lost_motion_arcmin": lm["lost_motion_rad"] * ARCMIN_PER_RAD}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    design = load_design(designs.path("rv40e"))
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    n_var = 2 if args.quick else 40
    n_pts = 7 if args.quick else 37
    nominal = figures(design, n_pts)
    records = []
    for k in range(n_var):
        t0 = time.perf_counter()
        d, drawn = sample_rv_design(tol, design, k, SEED)
        try:
            rec = {"index": k, **figures(d, n_pts), "error": None}
        except SolverFailure as exc:            # recorded, never dropped silently
            rec = {"index": k, **{f: None for f in FIGURES}, "error": str(exc)}
        rec["wall_s"] = time.perf_counter() - t0
        pitch = ("sun_pitch_deviation", "crank_gear_pitch_deviation")
        rec["deviations"] = {k2: v for k2, v in drawn.items() if k2 not in pitch}
        for k2 in pitch:               # per-tooth lists: their largest magnitude is recorded
            rec[f"{k2}_max_abs_m"] = float(np.max(np.abs(drawn[k2]))) if k2 in drawn else None
        records.append(rec)
    summary = {}
    for f in FIGURES:
        x = np.array([r[f] for r in records if r[f] is not None], float)
        summary[f] = {"n": len(x), "mean": float(x.mean()) if len(x) else None,
                      "std": float(x.std(ddof=1)) if len(x) > 1 else None,
                      "q05_q50_q95": np.quantile(x, [0.05, 0.5, 0.95]) if len(x) else None}
    results = {"nominal": nominal, "summary": summary, "variants": records,
               "failed_variants": sum(r["error"] is not None for r in records), "wall_s": time.perf_counter() - t_all}
    _plot(records, nominal, args.out)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"quick": args.quick, "seed": SEED, "variants": n_var,
                                                              "te_points_per_crank_revolution": n_pts,
                                                              "tolerances": "rvtool/designs/rv40e_tolerances.toml"},
                                 wall_s=results["wall_s"])


def _plot(records, nominal, out):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(12, 3.4))
    for a, f in zip(ax, FIGURES):
        x = [r[f] for r in records if r[f] is not None]
        a.hist(x, bins=max(5, len(x) // 4))
        a.axvline(nominal[f], color="k", lw=0.8, label="nominal")
        a.set(xlabel=f, ylabel="variants")
    ax[0].legend(fontsize=8)
    casekit.save_figure(fig, out, "monte_carlo_rv")


if __name__ == "__main__":
    main()
