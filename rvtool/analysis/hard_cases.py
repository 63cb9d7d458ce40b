"""The hard cases on a design: build the case's model, run the protocol
(:func:`rvtool.protocols.hard_cases.run_case`). The protocol is handed the built model; the
building (a topology's builder) happens here, one layer up."""
from ..assembly import build
from ..protocols.hard_cases import CASES, CRITERIA, HardCase, case_by_name, case_design, criterion, run_case

__all__ = ["CASES", "CRITERIA", "HardCase", "case_by_name", "case_design", "criterion", "run_case", "run_hard_case"]


def run_hard_case(case: HardCase, design, **kw):
    """Run ``case`` on ``design`` (its :func:`case_design`, built once); keywords and result as
    :func:`rvtool.protocols.hard_cases.run_case`."""
    return run_case(case, build(case_design(case, design)), **kw)
