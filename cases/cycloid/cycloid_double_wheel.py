"""RD-40 double-wheel cycloid drive: transmission error, rated loads and load sharing (quasi-static and dynamic).

Quasi-static TE over one output revolution at 40 points per mesh cycle
(--quick: one input revolution at 4 points), its error against a refined
reference (twice the profile samples and points over one mesh cycle), the
rated-state pin forces at zero input angle, peak loads per contact family
and a driven run at the rated speed (one output revolution; --quick: four
mesh cycles).
"""
import time

import rvtool
from rvtool import casekit
from rvtool.analysis.precision_study import precision_study

DESIGN = "rd40"


def judge(r):
    """Checks of a precision study's results (also judges cycloid_single and cycloid_housing_ports)."""
    checks = {
        # the design's resolution must resolve the TE: its error against the refined reference (2x profile
        # samples, 2x points) within 1 % of the TE p-p it resolves (measured 0.2 % quick, 0.3 % full)
        "te_resolution": casekit.check(r["te_refinement"]["te_max_abs_diff_arcsec"] / r["te_pp_arcsec"], 0.01, "<=",
                                       why="refinement error below 1 % of the TE p-p"),
        # the weak regularization springs (100 N/m, 0.1 N m/rad) must not carry load: below 1e-4 of the
        # peak pin force (measured 4e-6)
        "regularization_unloaded": casekit.check(r["regularization_max_N"] / r["peak_loads_N"]["pins"], 1e-4, "<=",
                                                 why="regularization force negligible against contact loads"),
        # two independent stiffness budgets: energy shares vs sensitivities (stiffening one family by a
        # finite factor): equal to the finite-difference error (measured 3e-6)
        "budget_energy_vs_sensitivity": casekit.check(
            max(abs(v - r["stiffness_budget"]["sensitivity_shares"][k])
                for k, v in r["stiffness_budget"]["shares"].items() if k in r["stiffness_budget"]["sensitivity_shares"]),
            1e-4, "<=", why="energy shares = sensitivity shares (springs in series)"),
    }
    for fam, at_rated in r["peak_loads_at_rated_N"].items():
        # the rated state (input angle 0) is one of the TE sequence's states: its loads cannot exceed the peaks
        checks[f"peak_covers_rated_{fam}"] = casekit.check(r["peak_loads_N"][fam] - at_rated, -1e-6 * max(at_rated, 1.0),
                                                           ">=", why="peak over the sequence >= load at angle 0")
    for fam, qs in r["peak_loads_N"].items():
        if qs > 1.0:
            # at the rated speed the mesh frequency lies far below the first torsional mode: the driven peaks
            # stay near the quasi-static ones (measured within 2 %); 10 % flags a dynamic or sign error
            checks[f"dynamic_vs_static_peak_{fam}"] = casekit.check(
                abs(r["dynamic"]["peak_loads_N"][fam] / qs - 1), 0.10, "<=",
                why="driven run at rated speed near the quasi-static limit")
    return checks


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    results, settings = precision_study(rvtool.load_design(DESIGN), quick=args.quick, out_dir=args.out)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
