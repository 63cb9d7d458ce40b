"""Topology registry: the design file's ``topology`` key -> the design class and its loader.

A design file names its topology at the top level (``topology = "cycloid"``; a file without
the key is a cycloid design, as the first shipped designs are). Each topology registers

* ``design``: "module:attribute" of its top-level design dataclass (a frozen dataclass whose
  dataclass-typed fields are the file's sections: the component specs),
* ``loader``: "module:attribute" of the function turning the file's table (a dict, the
  ``topology`` key removed) into that design, raising
  :class:`~rvtool.errors.RvtoolInputError` that names the key path,
* ``reference``: the shipped design whose values the template of ``rvtool new`` shows.

Modules are imported only when the topology is used, so a topology whose builder is not
part of this installation is reported as unavailable, naming the missing module, instead
of failing at import. A new topology registers itself here (one :func:`register` call) and
dispatches its models from :func:`rvtool.assembly.build`; nothing in the loader, the
templates, the format documentation or ``rvtool analyze`` changes.
"""
import importlib
import math
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path

from ..errors import RvtoolInputError

DEFAULT_TOPOLOGY = "cycloid"
"""Topology of a design file without a ``topology`` key."""

FORMAT_VERSION = 2
"""The design file format written today (top-level key ``format_version``). Format 2: every angle
key is ``NAME_deg`` [deg], every other dimensional key SI. A file without the key, or with
``format_version = 1``, is read as format 1 and its old keys renamed (:data:`FORMAT_1_KEYS`)."""

FORMAT_1_KEYS = {
    "contact_angle": ("contact_angle_deg", 180.0 / math.pi),        # bearing rows, [rad] -> [deg]
    "pressure_angle": ("pressure_angle_deg", 180.0 / math.pi),      # basic rack of a gear, [rad] -> [deg]
    "rotation_mod": ("rotation_mod_deg", 180.0 / math.pi),          # cycloid profile rotation, [rad] -> [deg]
    "phase_errors_arcmin": ("phase_errors_deg", 1.0 / 60.0),        # RV crank phase errors, [arcmin] -> [deg]
    "radial_mod_table": ("radial_mod_table_deg", (180.0 / math.pi, 1.0)),  # (phi [rad] -> [deg], delta_r [m]) rows
}
"""Format 1 keys of format 2: old key -> (new key, factor from the old unit to the new). The keys
are looked up in every table of the file (no other key of any section has these names)."""


@dataclass(frozen=True)
class Topology:
    """One registered topology (module docstring)."""
    name: str
    summary: str
    design: str
    loader: str
    reference: str | None = None
    provided_by: str = ""


class TopologyUnavailable(RvtoolInputError):
    """A registered topology whose design class or loader is not in this installation."""


TOPOLOGIES = {}
"""name -> :class:`Topology`, in registration order."""


def register(topology: Topology):
    """Add (or replace) a topology."""
    TOPOLOGIES[topology.name] = topology
    return topology


register(Topology("cycloid", "single-stage cycloid drive, one or two wheels, output through pins in wheel holes",
                  "rvtool.assembly.spec:CycloidDesign", "rvtool.assembly.spec:design_from_dict", "rd40",
                  "rvtool/assembly/spec.py and rvtool/assembly/cycloid.py"))
register(Topology("rv2", "RV two-stage reducer: involute preliminary stage, floating cranks, cycloid stage, carrier output",
                  "rvtool.assembly.rv:RVDesign", "rvtool.assembly.rv:design_from_dict", "rv40e",
                  "the RV builder of issue 16 (rvtool/assembly/rv/)"))
register(Topology("rv3", "RV three-stage reducer",
                  "rvtool.assembly.rv:RVDesign", "rvtool.assembly.rv:design_from_dict", "rv_three_stage",
                  "the RV three-stage topology of issue 16 (rvtool/assembly/rv/)"))
register(Topology("std-involute", "small-tooth-difference involute reducer: external wheel(s) in an internal ring gear",
                  "rvtool.assembly.std_spec:StdInvoluteDesign", "rvtool.assembly.std_spec:design_from_dict", "std_involute",
                  "rvtool/assembly/std_spec.py and rvtool/assembly/std_involute.py"))


def get(name):
    """The :class:`Topology` registered as ``name``."""
    if not isinstance(name, str) or name not in TOPOLOGIES:
        raise RvtoolInputError(f"topology = {name!r} is not a known topology; valid choices are {list(TOPOLOGIES)}")
    return TOPOLOGIES[name]


def _import(ref, topology):
    module, _, attr = ref.partition(":")
    try:
        return getattr(importlib.import_module(module), attr)
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            raise TopologyUnavailable(f"topology = {topology.name!r} is not available in this installation: "
                                      f"module {module} is missing (needs {topology.provided_by})") from None
        raise
    except AttributeError:
        raise TopologyUnavailable(f"topology = {topology.name!r} is not available in this installation: "
                                  f"{module} has no {attr} (needs {topology.provided_by})") from None


def design_class(name):
    """The design dataclass of topology ``name`` (raises :class:`TopologyUnavailable`)."""
    top = get(name)
    return _import(top.design, top)


def available(name):
    """None when topology ``name`` can be loaded, else the reason it cannot."""
    try:
        top = get(name)
        _import(top.design, top)
        _import(top.loader, top)
    except RvtoolInputError as exc:
        return str(exc)
    return None


def topology_of(design):
    """Name of the registered topology whose design class ``design`` is an instance of (None if none).
    A design class shared by several topologies (rv2 and rv3: :class:`~rvtool.assembly.rv.RVDesign`)
    records its topology in its ``topology`` field; that name wins."""
    recorded = getattr(design, "topology", None)
    if isinstance(recorded, str) and recorded in TOPOLOGIES and available(recorded) is None \
            and isinstance(design, design_class(recorded)):
        return recorded
    for name, top in TOPOLOGIES.items():
        if available(name) is None and isinstance(design, design_class(name)):
            return name
    return None


_WARNED = set()
"""Format 1 warnings already given in this process (:func:`upgrade_table`)."""


def _renamed(value, factor):
    if isinstance(factor, tuple):        # a table: one factor per column of each row
        if not isinstance(value, (list, tuple)) or not all(isinstance(r, (list, tuple)) for r in value):
            return value                 # not a table: the loader reports it under the new key
        return [[_renamed(x, f) for x, f in zip(row, factor)] + list(row[len(factor):]) for row in value]
    if isinstance(value, bool) or not isinstance(value, (int, float, list, tuple)):
        return value                     # not a number: the loader reports it under the new key
    if isinstance(value, (list, tuple)):
        return [_renamed(v, factor) for v in value]
    return value * factor


def _format_1_renames(table, path=""):
    """(table with the format 1 keys of :data:`FORMAT_1_KEYS` renamed and converted, [(old key path,
    new key path)]); sub-tables and arrays of tables are walked."""
    out, renames = {}, []
    for key, value in table.items():
        where = f"{path}.{key}" if path else key
        if isinstance(value, dict):
            value, sub = _format_1_renames(value, where)
            renames += sub
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            rows = []
            for k, v in enumerate(value):
                v, sub = _format_1_renames(v, f"{where}[{k}]")
                rows.append(v)
                renames += sub
            value = rows
        elif key in FORMAT_1_KEYS and path:
            new, factor = FORMAT_1_KEYS[key]
            if new in table:
                raise RvtoolInputError(f"[{path}] gives both {key} (format 1) and {new}; give {new}")
            out[new] = _renamed(value, factor)
            renames.append((where, f"{path}.{new}"))
            continue
        out[key] = value
    return out, renames


def upgrade_table(data):
    """A design file's table in format :data:`FORMAT_VERSION` (without the ``format_version`` key).
    A format 1 file (no ``format_version`` or 1) has its old keys renamed, with one
    :class:`FutureWarning` naming each old key and its new name; a format 2 file holding a format 1
    key is an error naming the new key."""
    data = dict(data)
    version = data.pop("format_version", 1)
    if isinstance(version, bool) or version not in (1, FORMAT_VERSION):
        raise RvtoolInputError(f"format_version = {version!r}; valid choices are [1, {FORMAT_VERSION}]")
    upgraded, renames = _format_1_renames(data)
    if renames and version == FORMAT_VERSION:
        old, new = renames[0]
        raise RvtoolInputError(f"{old} is a format 1 key; format_version = {FORMAT_VERSION} gives it as {new} "
                               "(every angle in degrees as NAME_deg)")
    if renames:
        names = ", ".join(f"{old} -> {new}" for old, new in renames)
        message = (f"design file format 1 (no format_version): rename {names} and write "
                   f"format_version = {FORMAT_VERSION} at the top (every angle in degrees as NAME_deg; "
                   "format 1 keys will stop loading in a later release)")
        # once per file content and process: `rvtool analyze` loads a file more than once (to check it,
        # then to run it), and a warnings filter reset in between would repeat Python's own "once"
        if message not in _WARNED:
            _WARNED.add(message)
            warnings.warn(message, FutureWarning, stacklevel=3)
    return upgraded


def design_from_table(data):
    """A validated design from a design file's table (the ``topology`` key picks the loader;
    ``format_version``: :func:`upgrade_table`)."""
    if not isinstance(data, dict):
        raise RvtoolInputError(f"a design must be a table of sections; got {type(data).__name__}")
    data = upgrade_table(data)
    name = data.pop("topology", DEFAULT_TOPOLOGY)
    top = get(name)
    cls = _import(top.design, top)
    loader = _import(top.loader, top)
    import dataclasses
    if dataclasses.is_dataclass(cls):
        _check_tables(name, cls, data)
    if dataclasses.is_dataclass(cls) and "topology" in {f.name for f in dataclasses.fields(cls)}:
        data["topology"] = name   # a design class that records its topology keeps the key
    return loader(data)


def _check_tables(name, cls, data):
    """A table (``[section]``) the topology does not have is an error naming it and, for a
    misspelling, the section meant -- before the loaders, which would otherwise report the
    section meant as missing (or fail building it from nothing)."""
    from .spec import _did_you_mean, file_keys
    valid = file_keys(cls)
    stray = sorted(k for k, v in data.items() if isinstance(v, dict) and k not in valid)
    if stray:
        sections = sorted(k for k in valid if k not in data)
        raise RvtoolInputError(f"topology {name!r} has no section{'s' if len(stray) > 1 else ''} "
                               f"{', '.join(f'[{k}]' for k in stray)}{_did_you_mean(stray, sections or valid, '[{}]')}; "
                               f"valid sections and top-level keys: {valid}")


def read_table(path):
    """The TOML table of the design file at ``path`` (errors name the file and the line)."""
    p = Path(path)
    if not p.is_file():
        raise RvtoolInputError(f"design file {str(path)!r} not found")
    try:
        with open(p, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        if p.read_bytes().startswith(b"\xef\xbb\xbf"):   # a Windows editor's byte-order mark: "Invalid statement (line 1)"
            raise RvtoolInputError(f"design file {str(path)!r} starts with a UTF-8 byte-order mark, which TOML "
                                   "parsing refuses; valid: the file saved as UTF-8 without BOM") from None
        raise RvtoolInputError(f"design file {str(path)!r} is not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise RvtoolInputError(f"design file {str(path)!r} is not UTF-8 text: {exc}") from None


def resolve_design_path(design):
    """Path of a design given as a file path or as the name of a shipped design
    (``rd40``); a path that exists wins over a shipped name."""
    from .. import designs
    p = Path(design)
    if p.is_file():
        return str(p)
    if p.suffix == ".toml" and (p.parent != Path(".") or not (designs.HERE / p.name).is_file()):
        raise RvtoolInputError(f"design file {str(design)!r} not found")
    stem = str(design)[:-5] if str(design).endswith(".toml") else str(design)
    if stem in designs.design_names():
        return designs.path(stem)
    hint = f" (the file {str(design) + '.toml'!r} exists: give its name with .toml)" \
        if Path(str(design) + ".toml").is_file() else ""
    raise RvtoolInputError(f"design = {str(design)!r} is neither a design file nor a shipped design{hint}; "
                           f"shipped designs are {designs.design_names()}")


def load(design):
    """A validated design from a file path or a shipped design's name."""
    return design_from_table(read_table(resolve_design_path(design)))
