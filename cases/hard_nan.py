"""Hard case 'nan' on RD-40 (double wheel): one forced NaN in a pin-contact evaluation mid-run.

The poisoned trial must be rejected and the step retried, and the result must match a
clean run (max TE difference); a persistent NaN must end the run with SolverFailure,
a clear message and the last accepted state saved (failed_state.npz), with no results
written as success. Keys: passed, criteria, rejected_steps, min_step_s, max_residual, message.
"""
import dataclasses
import os

import numpy as np

from rvtool.casekit import hard_case_main
from rvtool.analysis import hard_cases as H
from rvtool.units import ARCSEC_PER_RAD


def _extra(result, arr, design, quick, out):
    case = H.case_by_name("nan")
    clean, arr_c = H.run_hard_case(dataclasses.replace(case, nan_at_evaluation=()), design, quick=quick)
    # the retried step halves dt, so the trajectories differ by the integrator's local error only
    te_diff = float(np.max(np.abs(np.interp(arr_c["t"], arr["t"], arr["te"]) - arr_c["te"]))) * ARCSEC_PER_RAD
    result["criteria"]["te_diff_vs_clean_arcsec"] = H.criterion(te_diff, 0.05, "<=")
    persistent = dataclasses.replace(case, nan_at_evaluation=tuple(range(30, 20000)))
    bad, _ = H.run_hard_case(persistent, design, quick=quick, out_dir=os.path.join(out, "persistent_nan_state"))
    saved = bad["saved_state"]
    ok = (not bad["passed"]) and saved is not None and os.path.isfile(saved) and "non-finite" in bad["message"]
    result["criteria"]["persistent_nan_fails_with_saved_state"] = H.criterion(int(ok), 1, ">=")
    result["persistent_nan_message"] = bad["message"]
    result["persistent_nan_saved_state"] = saved


def main(argv=None):
    return hard_case_main("nan", argv, __doc__, extra=_extra)


if __name__ == "__main__":
    main()
