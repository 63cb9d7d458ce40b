"""``rvtool analyze``: run the registered protocols on one design and report typed figures.

    from rvtool.analysis import analyze
    res = analyze("rd40", protocols="te,stiffness", quick=True, out_dir="results/rd40")
    res["stiffness"].figure("Kt_condensed").value      # N m/arcmin, with .error and .error_statement

A design is a :class:`~rvtool.assembly.spec.CycloidDesign` (or another registered
topology's design), a design file or a shipped design's name. Protocols
(:mod:`rvtool.analysis.protocols`) build their models with :func:`rvtool.assembly.build`
only, so every topology registered there is analysed; a protocol the topology does not
support is reported as skipped with the reason. With ``out_dir`` the analysis writes
``results.json`` (keys: ``design``, ``topology``, ``protocols`` -- the list that ran --,
``skipped``, ``warnings``, one key per protocol, ``provenance``), one PNG per plot and
``report.html`` (self-contained: plots embedded).
"""
import os
import time
from pathlib import Path

from ..errors import RvtoolInputError, SolverFailure
from .admissible import check_rated_state
from .registry import PROTOCOLS, Context, Unsupported, select
from .results import AnalysisResult, Figure, ProtocolResult, finite_or_none

DEVICES = ("auto", "cpu", "cuda")
"""Valid ``device`` values ("cuda:N" also accepted)."""

__all__ = ["analyze", "resolve_device", "load", "AnalysisResult", "ProtocolResult", "Figure", "PROTOCOLS"]


def resolve_device(device):
    """"auto" -> "cuda" where Warp sees a CUDA device, else "cpu"; "cpu", "cuda", "cuda:N" checked."""
    if device not in DEVICES and not (isinstance(device, str) and device.startswith("cuda:") and device[5:].isdigit()):
        raise RvtoolInputError(f"device = {device!r}; valid choices are {list(DEVICES)} or 'cuda:N'")
    if device == "cpu":
        return "cpu"
    import warp as wp

    from warp_contacts.precision import init_warp
    init_warp()                     # quietly: no driver notice on a CPU-only machine
    n = wp.get_cuda_device_count()
    if device == "auto":
        return "cuda:0" if n > 0 else "cpu"
    if n == 0:
        raise RvtoolInputError(f"device = {device!r} but Warp finds no CUDA device; valid here: ['cpu', 'auto']")
    return "cuda:0" if device == "cuda" else device


def load(design):
    """(design object, source text, shipped name or None) from a design object, a file path or a
    shipped design's name."""
    from .. import designs
    from ..assembly import topologies
    if isinstance(design, (str, Path)):
        path = topologies.resolve_design_path(design)
        shipped = Path(path).stem if Path(path).parent == designs.HERE else None
        return topologies.design_from_table(topologies.read_table(path)), str(path), shipped
    if not hasattr(design, "__dataclass_fields__"):
        raise RvtoolInputError(f"design = {design!r}: a design object, a design file or a shipped design's name")
    return design, f"<{type(design).__name__} object>", None


def _run_one(proto, ctx):
    t0 = time.perf_counter()
    retried = None
    try:
        try:
            outcome = proto.run(ctx)
        except SolverFailure as exc:
            # rejected and retried on fresh models (no history carried over) with the guide-spring
            # homotopy as the solvers' last fallback; reached only where the protocol has already
            # failed, so no result that ran before changes; a second failure fails loudly, naming both
            retry = ctx.guided_retry()
            if retry is None:
                raise
            retried = f"{type(exc).__name__}: {exc}"
            try:
                outcome = proto.run(retry)
            except Exception as exc2:
                raise type(exc2)(f"{exc2} (retried with the guide-spring homotopy, guided_free_play, after: "
                                 f"{retried})") from exc
    except Unsupported as exc:
        return ProtocolResult(proto.name, "skipped", proto.summary, reason=str(exc), wall_s=time.perf_counter() - t0)
    except Exception as exc:  # a failed protocol is a result; the others still run
        return ProtocolResult(proto.name, "failed", proto.summary, reason=f"{type(exc).__name__}: {exc}",
                              wall_s=time.perf_counter() - t0)
    warnings = list(outcome.warnings)
    if retried is not None:
        warnings.append(f"the solver's default ladder failed ({retried}); this result comes from fresh models "
                        "with the guide-spring homotopy (guided_free_play) as the solvers' last fallback")
    figures = []
    for f in outcome.figures:
        value, bad_v = finite_or_none(f.value)
        error, bad_e = finite_or_none(f.error)
        if bad_v or bad_e:
            warnings.append(f"figure {f.name}: a non-finite {'value' if bad_v else 'error'} was computed and is "
                            "reported as null")
        figures.append(Figure(f.name, value, f.unit, f.description, error, f.error_unit, f.error_statement))
    data, bad = finite_or_none(outcome.data)
    if bad:
        warnings.append("non-finite entries in the data are reported as null")
    settings, _ = finite_or_none(outcome.settings)
    return ProtocolResult(proto.name, "ok", proto.summary, tuple(figures), data, settings, tuple(warnings),
                          tuple(p for p in outcome.plots if p), time.perf_counter() - t0)


BEARING_MODELS = ("lumped", "rolling")
"""Valid ``--bearing-model`` / ``bearing_model`` values of :func:`analyze` (the cycloid and
small-tooth-difference builders' ``bearing_model``)."""


def check_bearing_model(design, bearing_model):
    """Raise :class:`~rvtool.errors.RvtoolInputError` for a ``--bearing-model`` that is not one of
    :data:`BEARING_MODELS`, or one given for a design whose builder offers no choice (RV)."""
    if bearing_model is None:
        return
    from ..validation import check_choice
    check_choice("--bearing-model / bearing_model", bearing_model, BEARING_MODELS)
    from ..assembly.spec import CycloidDesign
    from ..assembly.std_spec import StdInvoluteDesign
    if not isinstance(design, (CycloidDesign, StdInvoluteDesign)):
        raise RvtoolInputError(f"--bearing-model {bearing_model}: the {type(design).__name__} builder has no bearing "
                               "model choice (its bearings are fixed by its topology); valid: leave --bearing-model "
                               "out, or a cycloid or small-tooth-difference design")


def analyze(design, protocols=None, *, quick=False, out_dir=None, device="cpu", tolerances=None, allowables=None,
            backend="auto", scheduler=None, bearing_model=None):
    """Run ``protocols`` (names, a comma-separated string or None for all) on ``design``;
    returns an :class:`AnalysisResult`. Input errors (design, protocol names, device, a rated
    torque outside the design's admissible range, :mod:`rvtool.analysis.admissible`) raise
    :class:`~rvtool.errors.RvtoolInputError` before anything is written. ``tolerances``: the
    Monte Carlo's tolerance file (default: ``NAME_tolerances.toml`` beside a design file ``NAME.toml``, as
    ``rvtool new`` writes it, or a shipped design's ``<name>_tolerances``); when the Monte Carlo is among
    the protocols, a bad key or value in it raises :class:`~rvtool.errors.RvtoolInputError` naming the file
    and the key before anything runs.
    ``allowables``: the design-review allowables file the report's summary checks the figures
    against (default: :func:`rvtool.analysis.summary.find_allowables`, ``<name>_allowables``).
    ``backend``: the solver backend (:data:`rvtool.solver.backends.CHOICES`): "auto" runs each
    protocol on the fastest backend that supports the model; a named backend runs where it can and
    skips a protocol it cannot run, with the reasons. Each protocol's settings record
    ``backend``: {"requested", "ran", "not_taken": {name: reason}}. ``scheduler``: the address of
    the Dask scheduler of the Monte Carlo's CPU pool (None: a LocalCluster started for it).
    ``bearing_model`` (``--bearing-model``): "lumped" (one circle contact per bearing) or "rolling"
    (rolling elements: needed by spatial bodies and influence-coefficient roller slices) for the
    cycloid and small-tooth-difference designs (``build(..., bearing_model=...)``); None builds
    with the builder's default, lumped. RV designs have no choice (None only).
    A protocol whose solver fails (:class:`~rvtool.errors.SolverFailure`) on a model without
    ``guided_free_play`` is retried once on fresh models with it on
    (:meth:`~rvtool.analysis.registry.Context.guided_retry`; free play such as a cycloid's
    ``wheels.clearance`` leaves the zero-load state without contact stiffness): a warning says so,
    and a second failure names both; a protocol that ran never reaches the retry."""
    t0 = time.perf_counter()
    chosen = select(protocols)
    dev = resolve_device(device)
    from ..solver.backends import CHOICES
    from ..validation import check_choice
    check_choice("backend", backend, CHOICES)
    obj, source, shipped = load(design)
    check_bearing_model(obj, bearing_model)
    from .. import designs
    from ..assembly import topologies
    if tolerances is None and shipped is not None and designs.tolerances_of(shipped):
        tolerances = designs.path(designs.tolerances_of(shipped))
    elif tolerances is None and shipped is None and str(source).endswith(".toml"):
        # a design file of one's own: NAME_tolerances.toml beside NAME.toml, as `rvtool new` writes it
        from ..designs.tolerance_template import tolerance_path
        if os.path.isfile(tolerance_path(source)):
            tolerances = tolerance_path(source)
    if tolerances is not None and not os.path.isfile(tolerances):
        raise RvtoolInputError(f"tolerances file {str(tolerances)!r} not found")
    if tolerances is not None and any(p.name == "monte_carlo" for p in chosen):
        from .protocols import load_tolerance_spec
        load_tolerance_spec(obj, tolerances)     # a bad key or value is an input error, raised before any work
    from .summary import allowables_record, find_allowables
    if allowables is None:
        allowables = find_allowables(source, shipped)
    elif not os.path.isfile(allowables):
        raise RvtoolInputError(f"allowables file {str(allowables)!r} not found")
    allowed = allowables_record(allowables)      # a bad file is an input error, raised before any work
    if out_dir is not None:
        from ..validation import check_out_dir
        check_out_dir(out_dir)                   # likewise a folder that cannot be made
    ctx = Context(obj, quick=quick, out_dir=out_dir, device=dev, tolerances=tolerances, backend=backend,
                  scheduler=scheduler, bearing_model=bearing_model)
    # a valid but unsolvable load is an input error: raised here, before anything is written
    ctx.cache["rated_state"] = check_rated_state(obj, ctx.build)
    if out_dir is not None:
        try:
            os.makedirs(out_dir, exist_ok=True)
        except OSError as exc:
            raise RvtoolInputError(f"--out / out_dir = {str(out_dir)!r} cannot be created as a folder ({exc.strerror}); "
                                   "valid: a folder path in a writable place") from None
    results = tuple(_run_one(p, ctx) for p in chosen)
    res = AnalysisResult(getattr(obj, "name", type(obj).__name__), topologies.topology_of(obj) or type(obj).__name__,
                         source, bool(quick), dev, results, out_dir, time.perf_counter() - t0, backend,
                         bearing_model)
    if out_dir is not None:
        write(res, allowed)
    return res


def write(res, allowables=None):
    """Write results.json and report.html of ``res`` into its output folder; ``allowables``: the
    :func:`rvtool.analysis.summary.allowables_record` the report's summary checks against."""
    from .output import write_results
    from .report import write_report
    settings = {"design_source": res.source, "quick": res.quick, "protocols_requested": [r.name for r in res.results],
                "device": res.device, "backend": res.backend}
    if res.bearing_model is not None:           # recorded where chosen (a default run's file is unchanged)
        settings["bearing_model"] = res.bearing_model
    d = res.to_dict()
    d["allowables"] = allowables or {"source": None, "values": None}
    data = write_results(res.out_dir, d, settings=settings, wall_s=res.wall_s,
                         precision="float64", device=res.device)
    write_report(data, res.out_dir)
    return data
