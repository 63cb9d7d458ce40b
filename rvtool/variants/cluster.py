"""The Dask cluster of the studies (scale-out delegated to Dask): a client connected to an
existing scheduler by its address, or to a LocalCluster started for the study and closed after
it. The tolerance Monte Carlo's pool (:func:`rvtool.variants.montecarlo.run_monte_carlo`) and
the sweeps (:mod:`rvtool.variants.sweep`) run their tasks through it."""
import contextlib
import os

THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS")
"""Thread-count variables set to 1 for the workers of a LocalCluster: one process per core, one
thread each (the workers already use every core)."""


@contextlib.contextmanager
def single_thread_env():
    """Environment inherited by spawned workers: one BLAS/OpenMP thread each."""
    saved = {nm: os.environ.get(nm) for nm in THREAD_ENV}
    for nm in THREAD_ENV:
        os.environ[nm] = "1"
    try:
        yield
    finally:
        for nm, v in saved.items():
            if v is None:
                os.environ.pop(nm, None)
            else:
                os.environ[nm] = v


@contextlib.contextmanager
def dask_client(scheduler="", *, n_workers=2, threads_per_worker=1, processes=True):
    """A ``dask.distributed.Client``: connected to ``scheduler`` (an address such as
    ``tcp://host:8786``), or, for "" / None, to a new LocalCluster of ``n_workers`` workers of
    ``threads_per_worker`` threads (processes, each with one BLAS thread, or threads in this
    process), closed on exit. No dashboard: a study is headless and a fixed port would collide."""
    from dask.distributed import Client, LocalCluster
    if scheduler:
        client = Client(scheduler)
        try:
            yield client
        finally:
            client.close()
        return
    with single_thread_env():
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=processes,
                               dashboard_address=None)
    try:
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()
