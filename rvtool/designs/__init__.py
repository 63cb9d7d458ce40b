"""Reference designs shipped with rvtool (TOML files beside this module, in the wheel too).

``path("rd40")`` is the file of a shipped design; ``names()`` lists them. Cases and tests
load designs from here, so a non-editable install finds them as well."""
from pathlib import Path

from ..errors import RvtoolInputError

HERE = Path(__file__).resolve().parent


def names():
    """Names of the shipped design files (without the .toml suffix)."""
    return sorted(p.stem for p in HERE.glob("*.toml"))


def path(name):
    """Path [str] of the shipped design file ``name`` (with or without ``.toml``)."""
    stem = name[:-5] if name.endswith(".toml") else name
    p = HERE / f"{stem}.toml"
    if not p.is_file():
        raise RvtoolInputError(f"design = {name!r} is not a shipped design; valid choices are {names()}")
    return str(p)


def kind(name):
    """What a shipped file holds: "tolerances" (a ``[tolerances]`` table, the Monte Carlo's input),
    "sweep" (a ``study`` key, ``rvtool sweep``'s input), "allowables" (an ``[allowables]`` table, the
    datasheet's input), "assumed" (``[[assumed]]`` tables: a design's assumed inputs with their cited
    ranges), "catalogue" (``[[figure]]`` tables: a design's catalogue figures), "measured"
    (``[[transmission_error]]`` tables: measurements of a design's prototypes published in a paper,
    :mod:`rvtool.designs.measured`), "friction" (a ``friction_set``), "efficiency" (an
    ``efficiency_catalogue``) or "design" (a reducer design)."""
    import tomllib
    with open(path(name), "rb") as fh:
        table = tomllib.load(fh)
    if "tolerances" in table:
        return "tolerances"
    if "study" in table:
        return "sweep"
    if "allowables" in table:
        return "allowables"
    if "assumed" in table:
        return "assumed"
    if "figure" in table:
        return "catalogue"
    if "transmission_error" in table:
        return "measured"
    if "friction_set" in table:
        return "friction"
    if "efficiency_catalogue" in table:
        return "efficiency"
    return "design"


def design_names():
    """Names of the shipped reducer designs (tolerance, sweep, allowables, assumed, catalogue, measurement, friction
    and efficiency files left out)."""
    return [n for n in names() if kind(n) == "design"]


def tolerances_of(name):
    """Name of the shipped tolerance file of shipped design ``name`` (``<name>_tolerances``), or None."""
    stem = name[:-5] if name.endswith(".toml") else name
    companion = f"{stem}_tolerances"
    return companion if companion in names() and kind(companion) == "tolerances" else None


def catalogue_of(name):
    """Name of the shipped catalogue file of shipped design ``name`` (``<name>_catalogue``), or None."""
    stem = name[:-5] if name.endswith(".toml") else name
    companion = f"{stem}_catalogue"
    return companion if companion in names() and kind(companion) == "catalogue" else None


def assumed_of(name):
    """Name of the shipped assumed-ranges file of shipped design ``name`` (``<name>_assumed``), or None."""
    stem = name[:-5] if name.endswith(".toml") else name
    companion = f"{stem}_assumed"
    return companion if companion in names() and kind(companion) == "assumed" else None


def measured_of(name):
    """Name of the shipped measurement file of shipped design ``name`` (``<name>_measured``), or None."""
    stem = name[:-5] if name.endswith(".toml") else name
    companion = f"{stem}_measured"
    return companion if companion in names() and kind(companion) == "measured" else None
