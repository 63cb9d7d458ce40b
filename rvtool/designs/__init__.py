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
