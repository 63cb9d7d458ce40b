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
import json
import math
import os
import platform
import sys
import tempfile
import time

import numpy as np

import matplotlib

matplotlib.use("Agg")  # cases are headless by default


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


def versions():
    """Versions of the packages a result depends on."""
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for mod in ("rvtool", "numpy", "scipy", "exudyn", "warp", "ngsolve", "matplotlib"):
        try:
            m = __import__(mod)
            out[mod] = getattr(m, "__version__", getattr(m, "config", None) and getattr(m.config, "version", "?"))
        except Exception:  # a missing optional package is recorded, not fatal
            out[mod] = None
    return out


def device_info(device="cpu"):
    """Name of the physical device a result was computed on."""
    info = {"device": device, "cpu": platform.processor() or platform.machine(), "cpu_count": os.cpu_count()}
    if device.startswith("cuda"):
        try:
            import warp as wp

            from warp_contacts.precision import init_warp
            init_warp()
            info["gpu"] = wp.get_device(device).name
        except Exception as exc:  # recorded honestly when the query fails
            info["gpu"] = f"unavailable: {exc}"
    return info


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else repr(v)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if hasattr(obj, "to_dict"):
        return _jsonable(obj.to_dict())
    return obj


def write_results(out_dir, results, settings=None, wall_s=None, precision="float64", device="cpu"):
    """Write ``out_dir/results.json`` atomically and return the written dict.

    ``results`` holds the keys an issue names; provenance (versions, device,
    precision, settings, wall time, date) goes under ``"provenance"``.
    """
    data = dict(results)
    data["provenance"] = {
        "versions": versions(),
        "device": device_info(device),
        "precision": precision,
        "settings": settings or {},
        "wall_s_total": wall_s,
        "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "command": " ".join(sys.argv),
    }
    data = _jsonable(data)
    os.makedirs(out_dir, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=out_dir, prefix=".results", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump(data, fh, indent=1)
    os.replace(tmp, os.path.join(out_dir, "results.json"))
    return data


def save_figure(fig, out_dir, name):
    """Save a matplotlib figure as ``out_dir/name.png`` and close it."""
    import matplotlib.pyplot as plt
    path = os.path.join(out_dir, name if name.endswith(".png") else name + ".png")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


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
    from .protocols.hard_cases import CRITERIA, case_by_name, run_hard_case
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
