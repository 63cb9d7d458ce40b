"""Shared plumbing for the scripts in ``cases/``: command line, provenance and
``results.json`` writing, and headless figure output.

A case script computes in ``main(argv)`` and returns the results dict::

    def main(argv=None):
        args = casekit.parse_args(argv, __doc__)
        t0 = time.perf_counter()
        ...  # compute
        casekit.verdict(results, judge)    # judge(r) -> {name: casekit.check(value, bound, op, why)}
        return casekit.write_results(args.out, results, settings=..., wall_s=...,
                                     precision="float64", device="cpu")

Every case is judged by its own criteria (:func:`check`, :func:`verdict`): ``results["passed"]``
is true when every check passes and no figure anywhere in the results is NaN. The cases live in
sub-folders of ``cases/`` by kind and topology (``rvtool list`` groups them; see
``docs/guide/cases.md``).
"""
import argparse
import math
import os
import sys
import time

import numpy as np

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


_OPS = {"<=": lambda v, b: v <= b, "<": lambda v, b: v < b, ">=": lambda v, b: v >= b,
        ">": lambda v, b: v > b, "==": lambda v, b: v == b, "in": lambda v, b: b[0] <= v <= b[1]}


def check(value, bound, op="<=", why=None):
    """One criterion of a case's verdict: ``{"value", "bound", "passed", "why"}``.

    ``op`` is ``<=``, ``<``, ``>=``, ``>``, ``==`` or ``in`` (``bound`` = ``(low, high)``, inclusive);
    ``why`` says where the bound comes from (the reference and its own error). A value that is
    None or not finite fails: a criterion that could not be evaluated is not met."""
    if op not in _OPS:
        raise ValueError(f"unknown comparison {op!r}; one of {sorted(_OPS)}")
    if isinstance(value, (bool, np.bool_)):
        value = bool(value)
    elif isinstance(value, (np.integer, np.floating)):
        value = value.item()
    numeric = isinstance(value, (int, float)) and math.isfinite(value)
    ok = bool((numeric or (op == "==" and value is not None)) and _OPS[op](value, bound))
    shown = f"in [{bound[0]}, {bound[1]}]" if op == "in" else f"{op} {bound}"
    return {"value": value, "bound": shown, "passed": ok, "why": why}


def nan_paths(obj, path=""):
    """Key paths of every NaN in a results dict (floats and the ``'nan'`` strings :func:`write_results`
    writes for them); ``provenance`` is skipped."""
    found = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k != "provenance":
                found += nan_paths(v, f"{path}/{k}")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            found += nan_paths(v, f"{path}[{i}]")
    elif isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc" and np.isnan(obj).any():
            found.append(path)
    elif isinstance(obj, (float, np.floating)):
        if math.isnan(obj):
            found.append(path)
    elif isinstance(obj, str) and obj.lower() == "nan":
        found.append(path)
    return found


def plain(obj):
    """``obj`` with NumPy arrays and scalars as Python lists and numbers (NaN stays a float), tuples as
    lists: the form a case's ``judge`` sees, the same as reading its results.json back."""
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    return obj


def verdict(results, judge):
    """Judge a case: ``judge(plain(results))`` returns its checks (name -> :func:`check`), stored under
    ``results["checks"]``; ``results["passed"]`` is set true when every check passed, no value anywhere
    in ``results`` is NaN (their key paths are listed under ``results["nan_at"]``) and a ``passed``
    the case wrote before is true. ``judge`` may also be the checks dict itself. Returns ``results``.

    A case defines ``judge(r)`` at module level from the figures it reports, so that the verdict can
    be re-read from a results.json (``judge(json.load(...))``) as well."""
    checks = judge(plain(results)) if callable(judge) else judge
    if not checks:
        raise ValueError("a verdict needs at least one check")
    earlier = results.get("passed", True)
    results["checks"] = checks
    nans = nan_paths(results)
    if nans:
        results["nan_at"] = nans
    results["passed"] = bool(earlier is True or earlier is np.True_) and not nans and all(
        c["passed"] for c in checks.values())
    return results


def time_call(fn, min_time=0.2, max_reps=2000):
    """Mean wall time [s] of ``fn()`` over at least 3 calls and ``min_time`` seconds (one warm-up call)."""
    fn()
    reps, t0 = 0, time.perf_counter()
    while reps < max_reps and (time.perf_counter() - t0 < min_time or reps < 3):
        fn()
        reps += 1
    return (time.perf_counter() - t0) / reps


def import_case(name):
    """Import another case script as a module (e.g. a benchmark reusing a verification case's
    scene): ``name`` is the bare case name or ``group/name`` (see :func:`rvtool.cli.resolve_case`);
    the module is registered under its bare name, as a plain ``import name`` beside it would."""
    import importlib.util

    from .cli import case_path
    path = case_path(name)
    if path.stem in sys.modules:
        return sys.modules[path.stem]
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module  # registered before execution: dataclasses and pickling look it up
    spec.loader.exec_module(module)
    return module


# -- hard cases ----------------------------------------------------------------------------

def hard_case(name, design, quick, out, extra=None):
    """Run the hard case ``name`` of :mod:`rvtool.analysis.hard_cases` on ``design``, judge it by its
    declared criteria and plot it into ``out``; return its result dict (``passed``, ``criteria``, ...).
    ``extra(result, arr, design, quick, out)`` may add sub-runs and criteria."""
    from .analysis.hard_cases import CRITERIA, case_by_name, run_hard_case
    case = case_by_name(name)
    result, arr = run_hard_case(case, design, quick=quick, out_dir=os.path.join(out, f"state_{name}"),
                                criteria_fn=CRITERIA.get(name))
    if extra is not None:
        extra(result, arr, design, quick, out)
        result["passed"] = bool(result["passed"] and all(c["passed"] for c in result["criteria"].values()))
        if result["saved_state"] is None:
            result["message"] = ("finished: " if result["passed"] else "finished but failed: ") + ", ".join(
                f"{k}={'ok' if c['passed'] else 'FAIL'}" for k, c in result["criteria"].items())
    result["energy_balance"] = ("not evaluated: the driver records neither the drive constraint's work nor "
                                "the contact dissipation; kinetic energy is bounded instead (criterion)")
    _plot_hard_case(out, name, arr)
    return result


def hard_cases_judge(r):
    """Checks of a hard-case run's results (``r["cases"][name]["criteria"]``, each ``{value, limit: "<= x"
    or ">= x", passed}`` as declared in :mod:`rvtool.analysis.hard_cases`): every declared criterion of
    every case, re-checked from its value and limit, and every case finished without a saved failure state."""
    checks = {}
    for name, case in r["cases"].items():
        for crit, c in case["criteria"].items():
            op, limit = c["limit"].split()
            checks[f"{name}_{crit}"] = check(c["value"], float(limit), op, why=f"declared criterion of hard case {name}")
        checks[f"{name}_finished"] = check(case.get("saved_state") is None, True, "==",
                                           why="the run ends without a saved failure state")
    return checks


def _plot_hard_case(out, name, arr):
    import matplotlib.pyplot as plt

    from .units import ARCSEC_PER_RAD
    fig, ax = plt.subplots(1, 3, figsize=(12, 3.2), layout="constrained")   # no y label over its neighbour
    fig.suptitle(f"hard case {name}")
    ax[0].plot(arr["t"] * 1e3, arr["te"] * ARCSEC_PER_RAD)
    ax[0].set_ylabel("TE [arcsec]")
    ax[1].plot(arr["t"] * 1e3, arr["pin_sum_N"])
    ax[1].set_ylabel("pin-force sum [N]")
    ax[2].plot(arr["t"] * 1e3, arr["kinetic_J"])
    ax[2].set_ylabel("kinetic energy [J]")
    for a in ax:
        a.set_xlabel("t [ms]")
    save_figure(fig, out, f"hard_{name}")
