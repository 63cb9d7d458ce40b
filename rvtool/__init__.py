"""rvtool: precision gear reducer simulation on Exudyn with Warp contact kernels.

Python API (imported on first use, so that ``import rvtool`` stays light)::

    import rvtool
    design = rvtool.load_design("rd40")          # a design file path or a shipped design's name
    variant = rvtool.replace_design(design, wheels={"n_slices": 4})   # changed keys, validated again
    model = rvtool.build(design)                 # the topology's ReducerModel
    res = rvtool.analyze(design, "te,stiffness", quick=True, out_dir="results/mine")
"""
__version__ = "0.1.0"

__all__ = ["load_design", "replace_design", "build", "analyze", "__version__"]


def load_design(design):
    """A validated design from a design file path or a shipped design's name (any registered
    topology; the file's ``topology`` key picks it). Input errors raise
    :class:`rvtool.errors.RvtoolInputError` naming the key path and the valid range."""
    from .assembly.topologies import load
    return load(design)


def replace_design(design, **sections):
    """A copy of a loaded ``design`` with sections replaced by dicts of changed keys (design-file keys)
    and top-level values, validated again, e.g. ``rvtool.replace_design(d, housing={"model": "ports"})``
    (see :func:`rvtool.assembly.spec.replace`)."""
    from .assembly.spec import replace
    return replace(design, **sections)


def build(design, **options):
    """The :class:`rvtool.model.ReducerModel` of ``design`` (see :func:`rvtool.assembly.build`)."""
    from .assembly import build as build_model
    return build_model(design, **options)


def analyze(design, protocols=None, **kw):
    """Run analysis protocols on a design; returns an :class:`rvtool.analysis.AnalysisResult`
    (see :func:`rvtool.analysis.analyze` for the keywords)."""
    from .analysis import analyze as run
    return run(design, protocols, **kw)
