"""Hard case 'stiff100' on RD-40 (double wheel): see rvtool.protocols.hard_cases.CASES for the histories
and pass/fail criteria; writes passed, criteria, rejected_steps, min_step_s, max_residual, message."""
from rvtool.casekit import hard_case_main


def main(argv=None):
    return hard_case_main("stiff100", argv, __doc__)


if __name__ == "__main__":
    main()
