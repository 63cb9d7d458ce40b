"""The six hard cases of rvtool.analysis.hard_cases on the RV-40E class reducer (rv40e), each judged by its declared criteria.

Same histories, settings and criteria as the RD-40 cases (cases/hard_*.py), run through
rvtool.analysis.hard_cases.run_hard_case on the RV model unchanged. One adaptation, declared:
the reversal case's two "after the reversal" criteria of RD-40 read the final sample; the RV's
output keeps swinging after the 0.2 ms reversal (pin-force sum between about 1 and 24 kN with a
period of about 3 ms, measured), so a single sample is arbitrary. Here they read the mean over
the run from 0.5 ms after the reversal to the end (same limits: reloaded >= 0.5 of the loaded
pin-force sum, TE shift >= 60 arcsec; the RV's static expectation is about 2 x 412 / 526 arcmin
+ lost motion = 100 arcsec). The final-sample values of those two criteria are reported under
``final_sample_values`` (not judged). --quick runs each case for its quick duration.
"""
import time

import numpy as np

from rvtool import casekit, designs, load_design
from rvtool.analysis.hard_cases import CASES, CRITERIA, criterion, run_hard_case
from rvtool.units import ARCSEC_PER_RAD

SETTLE_S = 5e-4
"""Time after the reversal from which the reversal criteria average [s]."""


def reversal_mean_criteria(arr, stats, d, case):
    t = arr["t"]
    before = arr["pin_sum_N"][t <= case.reverse_at_s]
    after = t > case.reverse_at_s
    late = t > case.reverse_at_s + SETTLE_S
    loaded = float(np.median(before))
    te = arr["te"] * ARCSEC_PER_RAD
    te_before = te[t <= case.reverse_at_s][-1]
    return {
        "contact_loss_min_over_loaded": criterion(float(arr["pin_sum_N"][after].min()) / loaded, 0.1, "<="),
        "reloaded_mean_over_loaded": criterion(float(np.mean(arr["pin_sum_N"][late])) / loaded, 0.5, ">="),
        "te_shift_mean_arcsec": criterion(float(abs(np.mean(te[late]) - te_before)), 60.0, ">="),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    design = load_design(designs.path("rv40e"))
    out = {}
    for case in CASES:
        fn = reversal_mean_criteria if case.name == "reversal" else CRITERIA.get(case.name)
        res, arr = run_hard_case(case, design, quick=args.quick, out_dir=f"{args.out}/state_{case.name}", criteria_fn=fn)
        if case.name == "reversal" and res["saved_state"] is None:
            rd = CRITERIA["reversal"](arr, None, design, case)
            res["final_sample_values"] = {k: {"value": c["value"], "limit": c["limit"]} for k, c in rd.items()
                                          if k != "contact_loss_min_over_loaded"}
        out[case.name] = {k: v for k, v in res.items() if k != "reject_reasons"}
        _plot(args.out, case.name, arr)
    results = {"cases": out, "wall_s": time.perf_counter() - t_all}
    casekit.verdict(results, casekit.hard_cases_judge)
    settings = {"design": design.name, "quick": args.quick, "reversal_settle_s": SETTLE_S,
                "cases": {c.name: c.description for c in CASES}}
    return casekit.write_results(args.out, results, settings=settings, wall_s=results["wall_s"])


def _plot(out, name, arr):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(9, 3), layout="constrained")
    ax[0].plot(arr["t"] * 1e3, arr["te"] * ARCSEC_PER_RAD)
    ax[0].set(xlabel="t [ms]", ylabel="TE [arcsec]", title=f"rv40e: {name}")
    ax[1].plot(arr["t"] * 1e3, arr["pin_sum_N"])
    ax[1].set(xlabel="t [ms]", ylabel="pin-force sum [N]")
    casekit.save_figure(fig, out, f"hard_{name}")


if __name__ == "__main__":
    main()
