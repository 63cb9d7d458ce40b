"""Precision and device selection for the Warp contact kernels.

Double precision is the default everywhere; ``"float32"`` is an explicit
option. Kernels are generated per scalar type by small factories so that the
float64 and float32 variants share one source.
"""
import functools

import numpy as np
import warp as wp

from rvtool.errors import RvtoolInputError

# Warp's start-up banner and per-module load lines are noise in case output
if hasattr(wp, "LOG_WARNING"):
    wp.config.log_level = wp.LOG_WARNING

PRECISIONS = {"float64": (wp.float64, np.float64), "float32": (wp.float32, np.float32)}


def scalar_types(precision):
    """Return ``(warp_dtype, numpy_dtype)`` for ``precision`` ("float64" or "float32")."""
    try:
        return PRECISIONS[precision]
    except KeyError:
        raise RvtoolInputError(
            f"precision = {precision!r} is not valid; valid choices are {sorted(PRECISIONS)}") from None


#: The one line Warp's native library prints on a machine without an NVIDIA driver (C code writing to
#: file descriptor 2, so neither ``warnings`` nor ``wp.config`` can silence it; Warp 1.19,
#: native/cuda_util.cpp). A CPU-only run is a supported configuration, not something to warn about;
#: asking for a CUDA device there is an RvtoolInputError naming the devices that exist.
NO_DRIVER_NOTICE = "Warp CUDA warning: Could not find or load the NVIDIA CUDA driver"


def call_dropping_native_lines(fn, prefixes):
    """``fn()`` with the lines starting with one of ``prefixes`` taken out of what it writes to file
    descriptor 2 (native code included); every other line is written to ``sys.stderr`` after the
    call, unchanged, so real errors stay visible. Where file descriptor 2 cannot be redirected the
    call runs as is."""
    import os
    import sys
    import tempfile
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):
        return fn()
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            return fn()
        finally:
            try:
                sys.stderr.flush()
            except (OSError, ValueError):
                pass
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            kept = [ln for ln in tmp.read().decode(errors="replace").splitlines(keepends=True)
                    if not ln.startswith(tuple(prefixes))]
            if kept:
                sys.stderr.write("".join(kept))
                sys.stderr.flush()


@functools.lru_cache(maxsize=None)
def init_warp():
    """``wp.init()`` once, without Warp's notice about a missing CUDA driver (every other line Warp
    prints passes through). Call it before anything that initializes Warp implicitly."""
    call_dropping_native_lines(wp.init, (NO_DRIVER_NOTICE,))
    return True


_warp_ready = init_warp


#: Contacts per launch above which ``device="auto"`` picks the GPU. Measured with
#: cases/benchmarks/bench_gpu.py on an H100 (float64, pose in and forces out per evaluation):
#: a CUDA evaluation costs ~70-100 us at any small size, the CPU ~0.3-0.8 us per
#: contact, so CUDA wins from ~1,000 contacts (crossover at 1,280 cycloid slices,
#: 256 output-pin rows, 2,880 rolling elements).
AUTO_CUDA_MIN_CONTACTS = 1000


def resolve_device(device, n_contacts=None):
    """Return a Warp device name for ``device`` ("cpu", "cuda", "cuda:N" or "auto": the
    first CUDA device when present and ``n_contacts`` >= AUTO_CUDA_MIN_CONTACTS, else "cpu")."""
    _warp_ready()
    names = [d.alias for d in wp.get_devices()]
    if device == "auto":
        cuda = [n for n in names if n.startswith("cuda")]
        return cuda[0] if cuda and (n_contacts or 0) >= AUTO_CUDA_MIN_CONTACTS else "cpu"
    if device == "cuda":
        device = "cuda:0"
    if device not in names:
        raise RvtoolInputError(f"device = {device!r} is not available; available Warp devices are {names}")
    return device
