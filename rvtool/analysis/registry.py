"""Protocol registry of ``rvtool analyze``: name -> :class:`AnalysisProtocol`.

An analysis protocol is a function ``run(ctx) -> Outcome`` that composes the library's
protocols (:mod:`rvtool.protocols`, :mod:`rvtool.pressure`, :mod:`rvtool.variants`) on models
built by ``ctx.build()`` (:func:`rvtool.assembly.build`: any registered topology) and
reports typed figures with error statements. It raises :class:`Unsupported` when the design's
topology lacks what it needs (a contact family, a model method): the protocol is then
reported as skipped with that reason. It prints nothing: long loops report through
:mod:`rvtool.progress`.
"""
import os
from dataclasses import dataclass, field

from ..errors import RvtoolInputError


class Unsupported(Exception):
    """The protocol does not apply to this design (the message says why)."""


@dataclass
class Outcome:
    """What a protocol returns: figures (:class:`~rvtool.analysis.results.Figure`), data, settings,
    warnings and plot file names."""
    figures: list = field(default_factory=list)
    data: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    plots: list = field(default_factory=list)


@dataclass(frozen=True)
class AnalysisProtocol:
    """name (the ``--protocols`` key), summary (one line, shown in the report) and run(ctx)."""
    name: str
    summary: str
    run: object


PROTOCOLS = {}
"""name -> :class:`AnalysisProtocol`, in the order they run."""


def register(name, summary):
    """Decorator registering ``run(ctx)`` as the protocol ``name``."""
    def wrap(fn):
        PROTOCOLS[name] = AnalysisProtocol(name, summary, fn)
        return fn
    return wrap


def select(names=None):
    """The protocols named (a list or a comma-separated string; None: all), in registry order."""
    from . import protocols  # noqa: F401  (registers the built-in protocols)
    if names is None:
        return list(PROTOCOLS.values())
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",") if n.strip()]
    unknown = [n for n in names if n not in PROTOCOLS]
    if unknown or not names:
        raise RvtoolInputError(f"--protocols {','.join(names) or '(empty)'}: unknown {unknown}; valid choices are "
                               f"{list(PROTOCOLS)}")
    return [p for n, p in PROTOCOLS.items() if n in names]


class Context:
    """What a protocol runs on: the design, the run mode and a cache shared by the protocols
    of one analysis (e.g. the stiffness sequence that lost motion and hysteresis reuse)."""

    def __init__(self, design, *, quick, out_dir, device="cpu", tolerances=None, backend="auto", scheduler=None,
                 guided_free_play=False, bearing_model=None):
        self.design = design
        #: models built with the guide-spring homotopy as their solvers' last fallback (the retry of a
        #: protocol whose solver failed, :meth:`guided_retry`); off: the design's own models
        self.guided_free_play = bool(guided_free_play)
        self.bearing_model = bearing_model  # None: the builder's default (lumped); else "lumped" / "rolling"
        self.backend = backend          # a name of rvtool.solver.backends.CHOICES
        self.scheduler = scheduler      # Dask scheduler address of the studies' pool (None: a LocalCluster)
        self.quick = bool(quick)
        self.out_dir = out_dir
        self.device = device
        self.tolerances = tolerances
        self.cache = {}

    def build_options(self):
        """Keyword options of :func:`rvtool.assembly.build` this analysis asks for: the device (when not
        the CPU), ``guided_free_play`` (when on) and the bearing model (when chosen: ``--bearing-model``);
        {} builds with the builder's defaults."""
        opts = {} if self.device == "cpu" else {"device": self.device}
        if self.guided_free_play:
            opts["guided_free_play"] = True
        if self.bearing_model is not None:
            opts["bearing_model"] = self.bearing_model
        return opts

    def build(self, design=None):
        """A fresh model of the design, or of ``design`` (e.g. its refined resolution or a tolerance
        variant), with :meth:`build_options` (:func:`rvtool.assembly.build`, any topology)."""
        from ..assembly import build
        return build(self.design if design is None else design, **self.build_options())

    def guided_retry(self):
        """The context of a protocol's retry after a :class:`~rvtool.errors.SolverFailure`: the same
        design and settings with models whose ``guided_free_play`` is on (a stalled load
        continuation and a static point every other start missed are reached by the guide-spring
        homotopy, :mod:`rvtool.solver.guide`), one per analysis (its cache shared by the retried
        protocols); None where the design's models already have it (the retry would repeat the
        failure) or the topology's builder has no such option (the cycloid's has)."""
        if self.guided_free_play:
            return None
        if "guided_retry" not in self.cache:
            from ..assembly.spec import CycloidDesign
            ctx = None
            if isinstance(self.design, CycloidDesign):
                ctx = Context(self.design, quick=self.quick, out_dir=self.out_dir, device=self.device,
                              tolerances=self.tolerances, backend=self.backend, scheduler=self.scheduler,
                              guided_free_play=True, bearing_model=self.bearing_model)
            self.cache["guided_retry"] = ctx
        return self.cache["guided_retry"]

    def require(self, *attributes):
        """The design's attributes the protocol needs (rated torque, input speed, ...);
        :class:`Unsupported` naming the first one missing."""
        out = []
        for a in attributes:
            if not hasattr(self.design, a):
                raise Unsupported(f"the {type(self.design).__name__} design has no {a!r}")
            out.append(getattr(self.design, a))
        return out if len(out) > 1 else out[0]

    def save(self, fig, name):
        """Save a matplotlib figure as OUT/name.png (closed either way); the file name, or None
        when the analysis writes no files."""
        import matplotlib.pyplot as plt
        if self.out_dir is None:
            plt.close(fig)
            return None
        from .output import save_figure
        os.makedirs(self.out_dir, exist_ok=True)
        return os.path.basename(save_figure(fig, self.out_dir, name))
