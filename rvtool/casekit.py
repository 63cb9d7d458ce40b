"""Shared plumbing for the scripts in ``cases/``: command line, provenance and
``results.json`` writing, and headless figure output.

A case script computes in ``main(argv)`` and returns the results dict::

    def main(argv=None):
        args = casekit.parse_args(argv, __doc__)
        t0 = time.perf_counter()
        ...  # compute
        return casekit.write_results(args.out, results, settings=..., wall_s=...,
                                     precision="float64", device="cpu")
"""
import argparse
import dataclasses
import os
import time

import matplotlib

matplotlib.use("Agg")  # cases are headless by default

from .analysis.output import device_info, save_figure, versions, write_results  # noqa: E402  (the cases' names)


def parse_args(argv=None, description=None, extra=None):
    """Parse ``[--quick] [--out DIR]`` (plus optional extra arguments added by ``extra(parser)``)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help="fast, reduced version of the study")
    parser.add_argument("--out", default=None, help="output directory (default: results/<case name>)")
    if extra is not None:
        extra(parser)
    args = parser.parse_args(argv)
    if args.out is None:
        # name the folder after the calling case script, also when main(argv) is called from Python
        import inspect
        caller = inspect.stack()[1].filename
        name = os.path.splitext(os.path.basename(caller))[0]
        args.out = os.path.join("results", name)
    os.makedirs(args.out, exist_ok=True)
    return args


def time_call(fn, min_time=0.2, max_reps=2000):
    """Mean wall time [s] of ``fn()`` over at least 3 calls and ``min_time`` seconds (one warm-up call)."""
    fn()
    reps, t0 = 0, time.perf_counter()
    while reps < max_reps and (time.perf_counter() - t0 < min_time or reps < 3):
        fn()
        reps += 1
    return (time.perf_counter() - t0) / reps


# -- hard cases ----------------------------------------------------------------------------

def hard_case_main(name, argv=None, doc=None, extra=None, design="rd40"):
    """Shared ``main`` of the cases/hard_*.py scripts: run, judge, plot, write results.json.
    ``extra(result, arr, design, quick, out)`` may add sub-runs and criteria."""
    from . import designs
    from .assembly.topologies import load as load_design
    from .analysis.hard_cases import CRITERIA, case_by_name, run_hard_case
    args = parse_args(argv, doc)
    t_start = time.perf_counter()
    design = load_design(designs.path(design))
    case = case_by_name(name)
    result, arr = run_hard_case(case, design, quick=args.quick, out_dir=os.path.join(args.out, "state"),
                                criteria_fn=CRITERIA.get(name))
    if extra is not None:
        extra(result, arr, design, args.quick, args.out)
        result["passed"] = bool(result["passed"] and all(c["passed"] for c in result["criteria"].values()))
        if result["saved_state"] is None:
            result["message"] = ("finished: " if result["passed"] else "finished but failed: ") + ", ".join(
                f"{k}={'ok' if c['passed'] else 'FAIL'}" for k, c in result["criteria"].items())
    result["energy_balance"] = ("not evaluated: the driver records neither the drive constraint's work nor "
                                "the contact dissipation; kinetic energy is bounded instead (criterion)")
    _plot_hard_case(args.out, name, arr)
    settings = {"case": dataclasses.asdict(case), "quick": args.quick, "design": design.name}
    return write_results(args.out, result, settings=settings, wall_s=time.perf_counter() - t_start)


def _plot_hard_case(out, name, arr):
    import matplotlib.pyplot as plt

    from .units import ARCSEC_PER_RAD
    fig, ax = plt.subplots(1, 3, figsize=(12, 3))
    ax[0].plot(arr["t"] * 1e3, arr["te"] * ARCSEC_PER_RAD)
    ax[0].set_ylabel("TE [arcsec]")
    ax[1].plot(arr["t"] * 1e3, arr["pin_sum_N"])
    ax[1].set_ylabel("pin-force sum [N]")
    ax[2].plot(arr["t"] * 1e3, arr["kinetic_J"])
    ax[2].set_ylabel("kinetic energy [J]")
    for a in ax:
        a.set_xlabel("t [ms]")
    save_figure(fig, out, f"hard_{name}")
