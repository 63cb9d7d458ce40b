"""The six hard cases of rvtool.analysis.hard_cases on RD-40 (double wheel), each judged by its declared criteria.

Histories, settings and pass/fail criteria: rvtool.analysis.hard_cases.CASES and CRITERIA
(reversal, startup, runup, rattle, stiff100, nan). ``--case NAME`` runs one of them only.

The 'nan' case adds two criteria here: one forced NaN in a pin-contact evaluation mid-run must
be rejected and the step retried, and the result must match a clean run (max TE difference
<= 0.05 arcsec: the retried step halves dt, so the trajectories differ by the integrator's
local error only); a persistent NaN must end the run with SolverFailure, a clear message and
the last accepted state saved (failed_state.npz), with no results written as success.

Keys: cases.<name>.{passed, criteria, rejected_steps, min_step_s, max_residual, message};
passed (every declared criterion of every case, casekit.hard_cases_judge).
"""
import dataclasses
import os
import time

import numpy as np

import rvtool
from rvtool import casekit
from rvtool.analysis import hard_cases as H
from rvtool.units import ARCSEC_PER_RAD

NAN_TE_DIFF_ARCSEC = 0.05
"""Bound of the TE difference between the run with one forced NaN and a clean run [arcsec]."""


def _nan_extra(result, arr, design, quick, out):
    case = H.case_by_name("nan")
    clean, arr_c = H.run_hard_case(dataclasses.replace(case, nan_at_evaluation=()), design, quick=quick)
    te_diff = float(np.max(np.abs(np.interp(arr_c["t"], arr["t"], arr["te"]) - arr_c["te"]))) * ARCSEC_PER_RAD
    result["criteria"]["te_diff_vs_clean_arcsec"] = H.criterion(te_diff, NAN_TE_DIFF_ARCSEC, "<=")
    persistent = dataclasses.replace(case, nan_at_evaluation=tuple(range(30, 20000)))
    bad, _ = H.run_hard_case(persistent, design, quick=quick, out_dir=os.path.join(out, "persistent_nan_state"))
    saved = bad["saved_state"]
    ok = (not bad["passed"]) and saved is not None and os.path.isfile(saved) and "non-finite" in bad["message"]
    result["criteria"]["persistent_nan_fails_with_saved_state"] = H.criterion(int(ok), 1, ">=")
    result["persistent_nan_message"] = bad["message"]
    result["persistent_nan_saved_state"] = saved


EXTRA = {"nan": _nan_extra}
"""Case-specific sub-runs and criteria added to the declared ones."""


def _extra_args(parser):
    parser.add_argument("--case", action="append", choices=[c.name for c in H.CASES], default=None,
                        help="run this hard case only (repeatable; default: all six)")


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=_extra_args)
    t_all = time.perf_counter()
    design = rvtool.load_design("rd40")
    names = args.case or [c.name for c in H.CASES]
    out = {}
    for name in names:
        res = casekit.hard_case(name, design, args.quick, args.out, extra=EXTRA.get(name))
        out[name] = {k: v for k, v in res.items() if k != "reject_reasons"}
    results = {"cases": out}
    casekit.verdict(results, casekit.hard_cases_judge)
    settings = {"design": design.name, "quick": args.quick,
                "cases": {n: dataclasses.asdict(H.case_by_name(n)) for n in names}}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


if __name__ == "__main__":
    main()
