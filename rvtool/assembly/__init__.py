"""Topology builders: a design (data) -> a :class:`~rvtool.model.ReducerModel`."""


def build(design, **options):
    """Build the reducer model of ``design`` with the builder of its topology (the design's type;
    RV designs by their ``topology`` key: "rv_two_stage", "rv_three_stage")."""
    from .spec import CycloidDesign
    if isinstance(design, CycloidDesign):
        from .cycloid import build as build_cycloid
        return build_cycloid(design, **options)
    from .rv.spec import TOPOLOGIES, RvDesign
    if isinstance(design, RvDesign) and design.topology in TOPOLOGIES:
        from .rv.builder import build as build_rv
        return build_rv(design, **options)
    from ..errors import RvtoolInputError
    raise RvtoolInputError(f"no topology builder for a design of type {type(design).__name__}; valid: CycloidDesign, "
                           f"RvDesign (topology {list(TOPOLOGIES)})")


def load_design(path):
    """Load any design file: RV designs by their ``topology`` key ("rv_two_stage", "rv_three_stage"),
    files without one as cycloid designs (:func:`rvtool.assembly.spec.load_design`)."""
    import tomllib
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    if "topology" in data:
        from .rv.spec import design_from_dict as rv_design
        return rv_design(data)
    from .spec import design_from_dict
    return design_from_dict(data)
