"""Input checks that raise :class:`rvtool.errors.RvtoolInputError` with the
parameter name, its value and the valid range (never a silent clamp)."""
import math

import numpy as np

from .errors import RvtoolInputError


def check_finite(name, value):
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise RvtoolInputError(f"{name} must be finite; got {value!r} (valid range: finite real numbers)")
    return value


def check_range(name, value, low=-math.inf, high=math.inf, low_open=False, high_open=False):
    """Check ``low <= value <= high`` (open ends where requested) element-wise."""
    if (type(value) is float and type(low) in (float, int) and type(high) in (float, int) and math.isfinite(value)
            and (value > low if low_open else value >= low) and (value < high if high_open else value <= high)):
        return value          # a Python number within range: the array path's verdict without its arrays
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise RvtoolInputError(f"{name} must be a real number; got {value!r}") from None
    if np.any(np.isnan(arr)):
        raise RvtoolInputError(f"{name} must not be NaN; got {value!r}")
    if np.any(np.isinf(arr)):
        # an infinite parameter is never physical, whatever the bounds
        raise RvtoolInputError(f"{name} must be finite; got {value!r} (valid range "
                               f"{'(' if low_open else '['}{low}, {high}{')' if high_open else ']'})")
    lo_ok = arr > low if low_open else arr >= low
    hi_ok = arr < high if high_open else arr <= high
    if not (np.all(lo_ok) and np.all(hi_ok)):
        lb = "(" if (low_open or low == -math.inf) else "["
        hb = ")" if (high_open or high == math.inf) else "]"
        if arr.ndim:        # a list or array: its first values outside the range
            bad = arr[~(lo_ok & hi_ok)]
            shown = f"{bad[:4].tolist()}{'...' if bad.size > 4 else ''}"
        else:               # a number: as the user wrote it (not a one-element list)
            shown = repr(value if type(value) in (int, float) else arr.item())
        raise RvtoolInputError(f"{name} = {shown} is outside the valid range {lb}{low}, {high}{hb}")
    return value


def check_positive(name, value):
    return check_range(name, value, 0.0, math.inf, low_open=True)


def check_nonnegative(name, value):
    return check_range(name, value, 0.0, math.inf)


def check_integer(name, value, low, high=math.inf):
    """Check that ``value`` is an integer (not a bool) with ``low <= value <= high``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        hb = "inf)" if high == math.inf else f"{high}]"
        raise RvtoolInputError(f"{name} = {value!r} is outside the valid range [{low}, {hb} (integer)")
    return value


def check_shape(name, array, shape):
    """Check an array's shape; ``None`` in ``shape`` matches any length."""
    arr = np.asarray(array)
    ok = arr.ndim == len(shape) and all(s is None or s == a for s, a in zip(shape, arr.shape))
    if not ok:
        want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
        raise RvtoolInputError(f"{name} must have shape {want}; got {arr.shape}")
    return arr


def check_choice(name, value, choices):
    if value not in choices:
        raise RvtoolInputError(f"{name} = {value!r} is not one of the valid choices {sorted(map(str, choices))}")
    return value


def check_out_dir(out_dir, name="--out / out_dir"):
    """Raise where ``out_dir`` cannot become an output folder: an existing file, or a path under
    one (a missing folder is made later by its writer); returns ``out_dir``."""
    import os
    path = os.path.abspath(str(out_dir))
    if os.path.exists(path) and not os.path.isdir(path):
        raise RvtoolInputError(f"{name} = {str(out_dir)!r} is an existing file; valid: a folder (made if missing)")
    parent = os.path.dirname(path)
    while parent and not os.path.exists(parent) and parent != os.path.dirname(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        raise RvtoolInputError(f"{name} = {str(out_dir)!r} lies under the file {parent!r}; valid: a folder path in a "
                               "writable place")
    return out_dir


PLANAR_LAYOUT = "x, y, theta per body"
SPATIAL_LAYOUT = "x, y, theta per planar body; z, gamma_x, gamma_y per out-of-plane row"


def check_body_state(owner, pose, vel, shape, layout=PLANAR_LAYOUT):
    """Raise :class:`RvtoolInputError` for a pose or velocity array (None: skipped) of another shape
    than ``shape`` or with NaN/inf, naming ``owner`` (e.g. "bearing set 'needles'") and the layout."""
    for nm, arr in (("pose", pose), ("vel", vel)):
        if arr is None:
            continue
        a = np.asarray(arr)
        if a.shape != tuple(shape):
            raise RvtoolInputError(f"{nm} must have shape {tuple(shape)} for {owner} ({layout}); got {a.shape}")
        if not np.all(np.isfinite(a)):
            rows = np.unique(np.nonzero(~np.isfinite(a))[0]).tolist()
            raise RvtoolInputError(f"{nm} contains non-finite values (NaN or inf) at rows {rows}; valid: finite reals")
