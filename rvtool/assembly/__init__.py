"""Topology builders: a design (data) -> a :class:`~rvtool.model.ReducerModel`."""


def build(design, **options):
    """Build the reducer model of ``design`` with the builder of its topology (the design's type;
    RV designs by their ``topology`` key: "rv2" two-stage, "rv3" three-stage)."""
    from .spec import CycloidDesign
    from .std_spec import StdInvoluteDesign
    if isinstance(design, CycloidDesign):
        from .cycloid import build as build_cycloid
        return build_cycloid(design, **options)
    if isinstance(design, StdInvoluteDesign):
        from .std_involute import build as build_std
        return build_std(design, **options)
    from .rv.spec import TOPOLOGIES, RVDesign
    if isinstance(design, RVDesign) and design.topology in TOPOLOGIES:
        from .rv.builder import build as build_rv
        return build_rv(design, **options)
    from ..errors import RvtoolInputError
    raise RvtoolInputError(f"no topology builder for a design of type {type(design).__name__}; valid: CycloidDesign, "
                           f"StdInvoluteDesign, RVDesign (topology {list(TOPOLOGIES)})")
