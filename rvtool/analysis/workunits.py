"""Independent units of work of a long study, run in a process pool with a deadline and resumed by the digest of
their inputs (the full run of ``rvtool validate``, cases/rv/validate_rv.py).

A unit is a module-level function and its arguments whose result does not depend on any other unit's. Each
unit is named by a *key*, the SHA-256 of a JSON description of its inputs (:func:`digest`, through the
library's one digest :func:`json_sha256`: the design table, the catalogue file's bytes, the settings), never by
its position, so a run that stopped, or a run with other designs or other unit counts, reuses exactly the units
whose inputs are the same. A finished unit's result is
pickled to ``<store>/<key>.pkl`` as soon as it finishes; :class:`UnitRunner` looks a key up in its store and in
the ``resume`` folders before running it (a hit in a resume folder is copied to the store, so the latest run
folder always holds every finished unit and the next call needs only that folder).

No unit is started after the ``deadline`` (seconds since the epoch), nor once the time left before it is
shorter than the longest unit of its kind seen so far in this run (the longest of any kind before one of its
own has finished), so the run ends near the deadline rather than one long unit after it: its future then raises
:class:`DeadlineReached`; the units already running finish and are stored. With ``workers`` > 1 the units run in a
``spawn`` process pool of that many processes, each with one BLAS thread (the solves are small dense systems;
cases/benchmarks/bench_nested_wheels.py measured a second OpenBLAS thread spinning on a shared machine), handed
to the pool no more than ``workers`` at a time by a dispatcher thread, in the order they were submitted (so the
deadline is checked at each start, not at submission). With ``workers`` <= 1 a unit runs in the submitting
thread at submission (the serial path of every quick run: no pool, no thread).
"""
import hashlib
import json
import os
import pickle
import threading
import time
from collections import deque
from concurrent.futures import Future

BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


class DeadlineReached(RuntimeError):
    """A unit was not started: the run's deadline had passed (resume the run to compute it)."""


def _plain(o):
    if hasattr(o, "tolist"):
        return o.tolist()
    if isinstance(o, float):
        return repr(o)
    return str(o)


def json_sha256(obj):
    """SHA-256 (hex) of the JSON text of ``obj``: sorted keys, floats (NumPy's too) by their shortest repr,
    tuples as lists, arrays and NumPy scalars by ``tolist()``, any other object by ``str()``. The one digest of
    the library: a unit's key (:func:`digest`), a TE job's design
    (:func:`rvtool.analysis.te_revolution.design_digest`) and a band draw's table
    (:func:`rvtool.analysis.validate_members.table_digest`).

    Those three were separate functions until session 8 and differed only in the fallback for an object JSON
    cannot write (``str``, ``repr``, ``float``); no committed input reaches a fallback (design tables and design
    dataclasses hold numbers, strings, lists and arrays only), so every committed key is unchanged:
    tests/test_validate_members.py recomputes the 65 draw digests of the committed
    ``checkpoint_rv80e.json``, tests/test_workunits.py pins a key of each kind. A TE job's digest rounds its
    floats first (:data:`rvtool.analysis.te_revolution.PORTABLE_DIGITS`: a computed float's last bits differ
    between machines), and its unit keys are pinned in tests/test_te_revolution.py."""
    text = json.dumps(obj, sort_keys=True, default=_plain)
    return hashlib.sha256(text.encode()).hexdigest()


def digest(kind, payload):
    """SHA-256 (hex) of ``kind`` and a JSON-able ``payload`` (:func:`json_sha256` of ``[kind, payload]``): a
    unit's key."""
    return json_sha256([kind, payload])


def file_digest(path):
    """SHA-256 (hex) of a data file as an input of a unit (a catalogue, tolerance, assumed or friction file): of
    its parsed content for TOML (a comment or the layout does not change a result, a value does), else of its
    bytes."""
    with open(path, "rb") as fh:
        raw = fh.read()
    if str(path).endswith(".toml"):
        import tomllib
        return digest("toml", tomllib.loads(raw.decode()))
    return hashlib.sha256(raw).hexdigest()


def _call(fn, args, kwargs):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0, time.process_time() - c0


def deadline_from(deadline_hhmm=None, budget_s=None, *, now=None):
    """Wall-clock stop time [s since the epoch] from ``HH:MM`` (UTC, today; a time more than 12 h in the past is
    tomorrow's) and/or a budget [s] from now: the earlier of the two, None for neither. A malformed HH:MM is an
    RvtoolInputError naming the option."""
    import datetime
    from ..errors import RvtoolInputError
    now = time.time() if now is None else now
    ends = []
    if budget_s is not None:
        if not budget_s > 0:
            raise RvtoolInputError(f"--budget-s must be > 0 seconds; got {budget_s}")
        ends.append(now + float(budget_s))
    if deadline_hhmm:
        try:
            hh, mm = (int(x) for x in str(deadline_hhmm).split(":"))
            if not (0 <= hh < 24 and 0 <= mm < 60):
                raise ValueError
        except ValueError:
            raise RvtoolInputError(f"--deadline must be HH:MM (UTC, 00:00 .. 23:59); got {deadline_hhmm!r}") from None
        t = datetime.datetime.fromtimestamp(now, datetime.timezone.utc).replace(hour=hh, minute=mm, second=0,
                                                                                microsecond=0).timestamp()
        if t < now - 12 * 3600:
            t += 24 * 3600
        ends.append(t)
    return min(ends) if ends else None


class UnitRunner:
    """Runs units (module docstring). ``store``: folder of this run's finished units (None: nothing stored);
    ``resume``: folders of earlier runs' units; ``deadline``: epoch seconds (None: none)."""

    def __init__(self, workers=1, deadline=None, store=None, resume=(), log=print, worker_env=None):
        self.workers, self.deadline, self.store, self.log = int(workers), deadline, store, log
        self.resume = [r for r in resume if r]
        if store is not None:
            os.makedirs(store, exist_ok=True)
        self.counts = {"run": 0, "reused": 0, "not_started": 0, "failed": 0}
        self.unit_seconds = {}            # kind -> [wall s, CPU s] of each unit run here
        self._lock = threading.Condition()
        self._pending = deque()
        self._inflight = 0
        self._closed = False
        self._pool = None
        self._thread = None
        if self.workers > 1:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor
            for v in BLAS_THREAD_VARIABLES:       # inherited by the spawned workers (set before they start)
                os.environ[v] = "1"
            os.environ.update(worker_env or {})   # e.g. CUDA_VISIBLE_DEVICES="" for CPU-only units
            self._pool = ProcessPoolExecutor(max_workers=self.workers,
                                             mp_context=multiprocessing.get_context("spawn"))
            self._thread = threading.Thread(target=self._dispatch, daemon=True)
            self._thread.start()

    # --- the store ---------------------------------------------------------------------------------------------
    def _path(self, folder, key):
        return os.path.join(folder, f"{key}.pkl")

    def lookup(self, key):
        """(True, result) of a finished unit in the store or a resume folder, else (False, None)."""
        if key is None:
            return False, None
        for folder in ([self.store] if self.store else []) + self.resume:
            p = self._path(folder, key)
            if os.path.exists(p):
                with open(p, "rb") as fh:
                    out = pickle.load(fh)
                if folder != self.store and self.store is not None:
                    self._save(key, out)
                return True, out
        return False, None

    def _save(self, key, result):
        if key is None or self.store is None:
            return
        tmp = self._path(self.store, key) + ".tmp"
        with open(tmp, "wb") as fh:
            pickle.dump(result, fh)
        os.replace(tmp, self._path(self.store, key))

    def past_deadline(self, kind=None):
        """Whether a unit of ``kind`` may no longer start (module docstring)."""
        if self.deadline is None:
            return False
        longest = [w for w, _ in self.unit_seconds.get(kind, ())] or \
            [w for v in self.unit_seconds.values() for w, _ in v] or [0.0]
        return time.time() + max(longest) > self.deadline

    # --- running -----------------------------------------------------------------------------------------------
    def submit(self, fn, *args, key=None, kind=None, **kwargs):
        """A future of ``fn(*args, **kwargs)``: from the store where ``key`` is there, else run (module
        docstring); :class:`DeadlineReached` where it was not started before the deadline."""
        fut = Future()
        hit, res = self.lookup(key)
        if hit:
            self.counts["reused"] += 1
            fut.set_result(res)
            return fut
        kind = kind or getattr(fn, "__name__", "unit")
        if self._pool is None:
            if self.past_deadline(kind):
                self.counts["not_started"] += 1
                fut.set_exception(DeadlineReached(f"{kind}: not started, the deadline had passed"))
                return fut
            try:
                out, wall, cpu = _call(fn, args, kwargs)
            except Exception as exc:      # the caller's result() raises it
                self.counts["failed"] += 1
                fut.set_exception(exc)
                return fut
            self._finished(key, kind, out, wall, cpu)
            fut.set_result(out)
            return fut
        with self._lock:
            self._pending.append((fut, fn, args, kwargs, key, kind))
            self._lock.notify_all()
        return fut

    def _finished(self, key, kind, out, wall, cpu):
        self.counts["run"] += 1
        self.unit_seconds.setdefault(kind, []).append([wall, cpu])
        self._save(key, out)

    def _dispatch(self):
        while True:
            with self._lock:
                while True:
                    while self._pending and self.past_deadline(self._pending[0][-1]):
                        fut, *_, kind = self._pending.popleft()
                        self.counts["not_started"] += 1
                        fut.set_exception(DeadlineReached(f"{kind}: not started, the deadline was too near"))
                    if self._pending and self._inflight < self.workers:
                        fut, fn, args, kwargs, key, kind = self._pending.popleft()
                        self._inflight += 1
                        break
                    if self._closed and not self._pending:
                        return
                    self._lock.wait(timeout=1.0)
            inner = self._pool.submit(_call, fn, args, kwargs)
            inner.add_done_callback(lambda f, o=fut, k=key, n=kind: self._done(f, o, k, n))

    def _done(self, inner, outer, key, kind):
        try:
            out, wall, cpu = inner.result()
        except Exception as exc:
            with self._lock:
                self.counts["failed"] += 1
                self._inflight -= 1
                self._lock.notify_all()
            outer.set_exception(exc)
            return
        with self._lock:
            self._finished(key, kind, out, wall, cpu)
            self._inflight -= 1
            self._lock.notify_all()
        outer.set_result(out)

    def close(self):
        """Wait for the running units, refuse the pending ones past the deadline, shut the pool down."""
        if self._pool is not None:
            with self._lock:
                self._closed = True
                self._lock.notify_all()
            self._thread.join()
            self._pool.shutdown(wait=True)
            self._pool = None

    def summary(self):
        """Counts and the wall / CPU seconds per unit kind run here (mean, max, count)."""
        per = {}
        for k, v in self.unit_seconds.items():
            w = [x[0] for x in v]
            c = [x[1] for x in v]
            per[k] = {"count": len(v), "wall_s_mean": sum(w) / len(w), "wall_s_max": max(w),
                      "cpu_s_mean": sum(c) / len(c), "cpu_s_max": max(c)}
        return {**self.counts, "workers": self.workers, "per_kind": per}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def folder_runner(out_dir, *, workers=1, deadline=None, resume=(), log=print):
    """The :class:`UnitRunner` of a run folder (``te_measured_rv80e``, ``validate_rv``): finished units in
    ``<out_dir>/units``, the ``units`` folders of the ``resume`` run folders read too (a hit is copied into
    ``out_dir``, so every stop leaves a folder complete in itself); ``workers`` > 1: a spawn pool of one BLAS
    thread per worker and no CUDA device (the units run on the CPU: a device host's CUDA context per worker
    would be wasted)."""
    return UnitRunner(workers=workers, deadline=deadline, store=os.path.join(out_dir, "units"),
                      resume=[os.path.join(r, "units") for r in resume if r], log=log,
                      worker_env={"CUDA_VISIBLE_DEVICES": ""})
