"""Helpers shared by the kernel wrappers' recorded launches (one definition instead of one per
family): replaying a recorded launch over the first rows only, and overwriting the packed row
parameters in place so that the recorded launch keeps pointing at them."""
import numpy as np


def launch_rows(cmd, n, n_rows=None):
    """Replay the recorded launch ``cmd`` (``n`` rows) over its first ``n_rows`` rows (a batch
    compacted to the front of the arrays, e.g. by the device Newton; None: all)."""
    if n_rows is None or int(n_rows) == n:
        cmd.launch()
        return
    cmd.set_dim(int(n_rows))
    try:
        cmd.launch()
    finally:
        cmd.set_dim(n)


def assign_parameters(array, fparams, dtype):
    """Overwrite the device array of packed float parameters in place with ``fparams`` (same
    shape; slow-state gap offsets and friction between mechanical windows)."""
    fp = np.ascontiguousarray(fparams, dtype=dtype)
    if fp.shape != tuple(array.shape):
        raise ValueError(f"parameter rows of shape {fp.shape} for a launch recorded with {tuple(array.shape)}")
    array.assign(fp)
