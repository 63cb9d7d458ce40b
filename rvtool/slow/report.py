"""details.json beside a slow-process case's results.json: the origin attribution, the studies'
errors against their references and their wall times (results.json keeps the issue's keys)."""
import json
import math
import os

import numpy as np


def _plain(obj):
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return _plain(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None if math.isnan(obj) else ("inf" if obj > 0 else "-inf")
    return obj


def write_details(out_dir, details) -> dict:
    """Write ``out_dir/details.json`` (numpy values as lists, inf as "inf"); returns what was written."""
    data = _plain(details)
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "details.json"), "w") as fh:
        json.dump(data, fh, indent=1)
    return data
