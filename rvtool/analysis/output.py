"""Writing results: ``results.json`` with its provenance (package versions, device, settings,
wall time, date, command) and figures as PNG files. Used by ``rvtool analyze`` and, through
:mod:`rvtool.casekit`, by the case scripts."""
import json
import math
import os
import platform
import sys
import threading
import time

import numpy as np


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
            init_warp()                 # quietly: no driver notice on a CPU-only machine
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
    # a temporary name of this process and thread, opened as any file (mode 0666 less the umask;
    # tempfile.mkstemp's 0600 left results.json unreadable to the group and to a web server)
    tmp = os.path.join(out_dir, f".results.{os.getpid()}.{threading.get_ident()}.json")
    with open(tmp, "w") as fh:
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
