"""Shared test setup: headless plotting for everything the tests run, subprocesses included."""
import os

os.environ.setdefault("MPLBACKEND", "Agg")
# One BLAS thread per test process: the suite runs one xdist worker per core, and OpenBLAS's own threads on top of
# them oversubscribe the cores and spin (measured on the 2-core CI-sized machine: a 104 x 104 inverse 0.18 s
# instead of 2.5 ms, a static solve of rv40e with FE wheels ~3 min instead of 4 s). It must be set before NumPy
# loads OpenBLAS (this conftest is imported before any test module); the case subprocesses inherit it. Users'
# runs keep OpenBLAS's default (several threads help a single process on a big machine).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
