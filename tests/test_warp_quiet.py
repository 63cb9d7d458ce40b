"""Warp's native notice about a missing NVIDIA driver is not printed on CPU-only runs (issue 27: it
came with every run on a machine without a GPU), while every other line Warp writes to stderr
(real errors) still reaches the user."""
import os
import subprocess
import sys
from pathlib import Path

from warp_contacts.precision import NO_DRIVER_NOTICE, call_dropping_native_lines

ROOT = Path(__file__).resolve().parents[1]


def test_only_the_driver_notice_is_dropped(capfd):
    def native_like():
        # what Warp's C code does: write straight to file descriptor 2
        os.write(2, (NO_DRIVER_NOTICE + ". GPU execution will not be available.\n").encode())
        os.write(2, b"Warp CUDA error: something real\n")
        return 42

    assert call_dropping_native_lines(native_like, (NO_DRIVER_NOTICE,)) == 42
    err = capfd.readouterr().err
    assert NO_DRIVER_NOTICE not in err
    assert "Warp CUDA error: something real" in err


def test_an_exception_still_restores_stderr(capfd):
    def fails():
        os.write(2, b"line before the error\n")
        raise RuntimeError("boom")

    try:
        call_dropping_native_lines(fails, (NO_DRIVER_NOTICE,))
    except RuntimeError:
        pass
    os.write(2, b"after\n")
    err = capfd.readouterr().err
    assert "line before the error" in err and "after" in err


def test_building_a_model_prints_no_driver_notice():
    """A fresh interpreter (Warp not yet initialized) builds RD-40, which initializes Warp through the
    contact kernels' device resolution, and asks Warp for its CUDA devices: nothing about a missing
    driver on stderr (on a machine with a GPU there is no such notice either)."""
    code = ("import rvtool, warp as wp; rvtool.build(rvtool.load_design('rd40')); "
            "print(wp.get_cuda_device_count())")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Warp CUDA warning" not in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
