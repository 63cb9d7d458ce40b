"""RV reducers (two-stage and three-stage): specification (:mod:`.spec`), gear graph
(:mod:`.gear_graph`: ratio, crank placement, assembly phases, topology errors) and the builder
(:mod:`.builder`)."""
from .spec import RVDesign, design_from_dict, load_design

__all__ = ["RVDesign", "design_from_dict", "load_design", "build"]


def build(design, **options):
    """Build an :class:`~.builder.RvModel` of ``design``."""
    from .builder import build as _build
    return _build(design, **options)
