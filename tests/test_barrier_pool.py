"""rvtool.variants.barrier_pool, the warmed pools of multi_device.helper_pool and bench_device_mc: every
worker warmed exactly once, and what a warm-up that raises or misses a worker does in each mode."""
import os
import time
from pathlib import Path

import pytest

from rvtool.errors import RvtoolInputError
from rvtool.variants.barrier_pool import barrier_pool, warm_every_worker, warmed_pool


def _record(folder):
    """A warm-up (runs in a worker): appends one line, the worker's OMP_NUM_THREADS, to a file named by its pid."""
    with open(os.path.join(folder, str(os.getpid())), "a") as fh:
        fh.write(f"{os.environ.get('OMP_NUM_THREADS')}\n")


def _hold(flag):
    """Keeps a worker busy until ``flag`` exists (at most 60 s)."""
    end = time.monotonic() + 60.0
    while not os.path.exists(flag) and time.monotonic() < end:
        time.sleep(0.02)


def test_every_worker_once_and_raise_mode(tmp_path):
    """The library's mode (one BLAS thread, "raise"): each of 2 workers runs one warm-up; a warm-up that
    raises (int("x")) fails the warm-up, in "warn" mode too (its barrier party given: the other worker is
    not held for the 60 s timeout)."""
    ex, warm_s = warmed_pool(2, _record, [str(tmp_path)] * 2, one_blas_thread=True, timeout_s=60.0,
                             on_missed="raise")
    with ex:
        lines = {p.name: p.read_text().splitlines() for p in tmp_path.iterdir()}
        assert len(lines) == 2 and all(v == ["1"] for v in lines.values()), lines   # two pids, once each, 1 thread
        assert 0.0 < warm_s < 60.0
        t = time.perf_counter()
        with pytest.raises(ValueError):
            warm_every_worker(ex, 2, int, ["1", "x"], timeout_s=60.0, on_missed="warn")
        assert time.perf_counter() - t < 30.0        # the worker of "1" was released by the raising one's party
        with pytest.raises(ValueError):
            warm_every_worker(ex, 2, int, ["x", "1"], timeout_s=0.5, on_missed="raise")
    with pytest.raises(RvtoolInputError, match="on_missed"):
        warm_every_worker(None, 2, int, [], timeout_s=1.0, on_missed="ignore")
    with pytest.raises(RvtoolInputError, match="workers"):
        barrier_pool(0, one_blas_thread=False)


def test_warn_mode_reports_a_missed_worker(tmp_path, capsys):
    """The benchmark's mode (default BLAS threads, "warn"): with one worker busy, the other takes both
    warm-ups, its barrier times out; the warm-up says so on stderr and returns 1 instead of raising."""
    flag = tmp_path / "go"
    (tmp_path / "warm").mkdir()
    ex = barrier_pool(2, one_blas_thread=False)
    try:
        busy = ex.submit(_hold, str(flag))
        assert warm_every_worker(ex, 2, _record, [str(tmp_path / "warm")] * 2, timeout_s=0.5, on_missed="warn") == 1
        assert "reached 1 of 2 workers" in capsys.readouterr().err
        (lines,) = [p.read_text().splitlines() for p in (tmp_path / "warm").iterdir()]
        assert lines == [str(os.environ.get("OMP_NUM_THREADS"))] * 2      # one worker, twice; this process's threads
    finally:
        Path(flag).touch()
        ex.shutdown(wait=True)
    busy.result()


@pytest.mark.parametrize("one_blas_thread", [True, False])
def test_one_blas_thread_pool_workers_start_with_one_thread(monkeypatch, one_blas_thread):
    """A worker's OpenBLAS takes its thread count from the environment its interpreter starts with (numpy loads
    before any initializer): a one-thread pool's workers start inside single_thread_env (session 6's started at
    the first submit, after it had closed, with the parent's setting); the other mode keeps the parent's."""
    from rvtool.variants import barrier_pool as BP
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "3")
    pool = BP.barrier_pool(2, one_blas_thread=one_blas_thread, start_timeout_s=60.0)
    try:
        seen = set(pool.map(BP.env_at_start, [None] * 4))
    finally:
        pool.shutdown()
    assert seen == ({"1"} if one_blas_thread else {"3"})
