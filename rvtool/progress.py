"""Progress of long loops (TE sequences, continuation levels, dynamic runs, Monte Carlo
variants, sweeps), kept out of the protocols' outputs.

Protocols only *declare* progress: they wrap a loop in :func:`track` or feed a
:func:`task` with the amount done (a dynamic run: simulated time). Whether anything is
shown is decided once, by the caller, with the :func:`reporting` context:

* no active reporter (the default, e.g. tests and library use): silent, no cost beyond a
  context-variable lookup per loop;
* ``mode="bar"``: a tqdm bar on the stream (a terminal);
* ``mode="lines"``: plain lines, at most one per ``interval_s`` and one at the end of each
  loop (a log file or a CI console, where a redrawn bar would be one long line);
* ``mode="auto"``: "bar" where the stream is a terminal, else "lines";
* ``mode="quiet"``: silent (``--quiet``).

tqdm is the one progress library (delegated, style rule 12); it is imported only when a
bar is drawn.
"""
import contextlib
import contextvars
import sys
import time

MODES = ("auto", "bar", "lines", "quiet")
"""Valid ``mode`` values of :func:`reporting`."""

_ACTIVE = contextvars.ContextVar("rvtool_progress_reporter", default=None)


class _Lines:
    """One loop's plain-line progress: ``desc: done/total unit (pct %), elapsed s``."""

    def __init__(self, stream, total, desc, unit, interval_s):
        self.stream, self.total, self.desc, self.unit, self.interval = stream, total, desc, unit, interval_s
        self.t0 = self.last = time.perf_counter()
        self.done = 0.0
        self.printed = None
        self.closed = False

    def _line(self):
        self.printed = self.done
        el = time.perf_counter() - self.t0
        if self.total:
            frac = min(self.done / self.total, 1.0)
            body = f"{self.done:.6g}/{self.total:.6g} {self.unit} ({100 * frac:.0f} %)"
        else:
            body = f"{self.done:.6g} {self.unit}"
        self.stream.write(f"{self.desc}: {body}, {el:.1f} s\n")
        self.stream.flush()

    def update_to(self, done):
        self.done = done
        now = time.perf_counter()
        if now - self.last >= self.interval:
            self.last = now
            self._line()

    def close(self):
        if not self.closed:
            self.closed = True
            if self.printed != self.done:
                self._line()


class _Bar:
    """One loop's tqdm bar."""

    def __init__(self, stream, total, desc, unit):
        from tqdm import tqdm
        self.bar = tqdm(total=total, desc=desc, unit=unit, file=stream, leave=True, dynamic_ncols=True)
        self.done = 0.0

    def update_to(self, done):
        self.bar.update(done - self.done)
        self.done = done

    def close(self):
        self.bar.close()


class Reporter:
    """Where and how progress is shown (see the module docstring)."""

    def __init__(self, mode="auto", stream=None, interval_s=5.0):
        if mode not in MODES:
            from .errors import RvtoolInputError
            raise RvtoolInputError(f"progress mode = {mode!r}; valid choices are {list(MODES)}")
        self.stream = stream if stream is not None else sys.stderr
        if mode == "auto":
            isatty = getattr(self.stream, "isatty", None)
            mode = "bar" if isatty is not None and isatty() else "lines"
        self.mode = mode
        self.interval_s = float(interval_s)

    def open(self, total, desc, unit):
        """A handle with ``update_to(done)`` and ``close()``, or None when quiet."""
        if self.mode == "quiet":
            return None
        if self.mode == "bar":
            return _Bar(self.stream, total, desc, unit)
        return _Lines(self.stream, total, desc, unit, self.interval_s)


@contextlib.contextmanager
def reporting(mode="auto", stream=None, interval_s=5.0):
    """Show the progress of the loops run inside this context (module docstring)."""
    token = _ACTIVE.set(Reporter(mode, stream, interval_s))
    try:
        yield _ACTIVE.get()
    finally:
        _ACTIVE.reset(token)


@contextlib.contextmanager
def task(total, desc, unit="it"):
    """Context yielding ``update(done)``: report an amount done out of ``total`` (e.g.
    simulated time out of the run's end time). A no-op without an active reporter."""
    reporter = _ACTIVE.get()
    handle = reporter.open(total, desc, unit) if reporter is not None else None
    if handle is None:
        yield _ignore
        return
    try:
        yield handle.update_to
    finally:
        handle.close()


def _ignore(done):
    return None


def track(iterable, *, total=None, desc="", unit="it"):
    """Iterate ``iterable``, reporting one unit per item when a reporter is active."""
    reporter = _ACTIVE.get()
    if reporter is None or reporter.mode == "quiet":
        yield from iterable
        return
    if total is None:
        try:
            total = len(iterable)
        except TypeError:
            total = None
    with task(total, desc, unit) as update:
        for k, item in enumerate(iterable):
            yield item
            update(k + 1)


def callback(desc, unit="it"):
    """A ``progress(done, total)`` callback (the Monte Carlo's and the sweep's convention)
    bound to the active reporter; call it with done == total to close the line or bar."""
    reporter = _ACTIVE.get()
    state = {"handle": None}

    def progress(done, total):
        if reporter is None or reporter.mode == "quiet":
            return
        if state["handle"] is None:
            state["handle"] = reporter.open(total, desc, unit)
        state["handle"].update_to(done)
        if total is not None and done >= total:
            state["handle"].close()

    return progress


def active():
    """True when a non-quiet reporter is active (callers that format their own text progress)."""
    reporter = _ACTIVE.get()
    return reporter is not None and reporter.mode != "quiet"
