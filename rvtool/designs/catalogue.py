"""Catalogue data and `assumed` input ranges of a shipped design (the schema of
``docs/validation/validate.md``): ``<design>_catalogue.toml`` (the manufacturer's figures with
their source, page, test conditions and kind) and ``<design>_assumed.toml`` (every `assumed`
design input with the range its cited sources give).

:func:`load_catalogue` and :func:`load_assumed` return frozen dataclasses in SI units (angles in
rad, stiffness in N m/rad, life in h as printed and in s, speeds in rad/s); bad input raises
:class:`~rvtool.errors.RvtoolInputError` naming the key (``figure[2].unit``, ``test.rated_torque``)
and its valid range. :func:`check_assumed_middle` checks the rule of issue 28: each `assumed` value
of the design file is the middle of its cited range (fixed before any catalogue comparison).
"""
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import RvtoolInputError
from ..units import RAD_PER_ARCMIN
from ..validation import check_integer, check_range

FORMAT_VERSION = 2

UNITS = {
    "N m/arcmin": 1.0 / RAD_PER_ARCMIN, "Nm/arcmin": 1.0 / RAD_PER_ARCMIN, "Nm/arc.min": 1.0 / RAD_PER_ARCMIN,
    "N m/rad": 1.0, "Nm/rad": 1.0,
    "arcmin": RAD_PER_ARCMIN, "arc.min": RAD_PER_ARCMIN, "arcsec": RAD_PER_ARCMIN / 60.0, "rad": 1.0,
    "deg": math.pi / 180.0,
    "N m": 1.0, "Nm": 1.0, "N": 1.0, "kN": 1e3, "kg": 1.0, "kg m^2": 1.0,
    "h": 3600.0, "s": 1.0, "rpm": math.pi / 30.0, "rad/s": 1.0,
    "%": 0.01, "-": 1.0, "m": 1.0, "mm": 1e-3, "um": 1e-6, "Pa": 1.0, "MPa": 1e6, "GPa": 1e9,
}
"""Units as printed -> factor to SI (angles rad, time s, speed rad/s, fractions)."""

KINDS = ("max", "typical", "min", "rated")
"""What the catalogue says a figure is."""

STATUSES = ("read", "not_reread")
"""Reading status of a figure: read from the cited page, or written from memory and not re-read."""


def _unit_factor(unit, where):
    if unit not in UNITS:
        raise RvtoolInputError(f"{where} = {unit!r} is not a known unit (valid: {sorted(UNITS)})")
    return UNITS[unit]


def text_field(table, key, where, required=True):
    """``table[key]`` as a non-empty string (None where absent and not required); errors name ``where.key``."""
    v = table.get(key)
    if v is None and not required:
        return None
    if not isinstance(v, str) or not v.strip():
        raise RvtoolInputError(f"{where}.{key} = {v!r} is not valid (valid: a non-empty string)")
    return v


def _num(table, key, where, low=-math.inf, high=math.inf, low_open=False, high_open=False):
    if key not in table:
        raise RvtoolInputError(f"{where}.{key} is missing (valid range {'(' if low_open else '['}{low}, {high}"
                               f"{')' if high_open else ']'})")
    v = table[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise RvtoolInputError(f"{where}.{key} = {v!r} is not a number")
    check_range(f"{where}.{key}", v, low, high, low_open, high_open)
    return float(v)


def read_data_file(path, what):
    """(table, path) of a data file beside a design (a path or a shipped name): valid TOML, the current
    ``format_version`` and a ``design`` key; ``what`` names the file kind in the errors."""
    p = Path(path)
    if not p.is_file():
        from . import path as shipped
        p = Path(shipped(str(path)))
    try:
        with open(p, "rb") as fh:
            table = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise RvtoolInputError(f"{what} file {str(p)!r} is not valid TOML: {exc}") from None
    fv = table.get("format_version")
    check_integer("format_version", fv, FORMAT_VERSION, FORMAT_VERSION)
    text_field(table, "design", "file")
    return table, p


@dataclass(frozen=True, kw_only=True)
class CatalogueSource:
    """The document: exact title, edition (catalogue number / edition / year as printed), url."""
    title: str
    edition: str
    url: str | None = None


@dataclass(frozen=True, kw_only=True)
class CatalogueTest:
    """The catalogue's own test definition. rated_torque: T_R [N m]; rated_output_speed: [rad/s]
    (and as printed in rpm); rated_life_h: [h]; lost_motion_torque_fraction: [-] of T_R;
    rigidity_torque_points: the two torques of b/a as fractions of T_R, or None where the file
    does not give them (the catalogue's figure was not read)."""
    rated_torque: float
    rated_output_speed: float
    rated_output_speed_rpm: float
    rated_life_h: float
    lost_motion_torque_fraction: float
    rigidity_torque_points: tuple | None


@dataclass(frozen=True, kw_only=True)
class CatalogueFigure:
    """One printed figure: key, value and unit as printed, value_si (SI), page, conditions, kind,
    an optional printed range [low, high] (same unit) and the reading status ("read" or
    "not_reread": the value was not re-read from the page in the session that wrote it)."""
    key: str
    value: float
    unit: str
    value_si: float
    page: str
    conditions: str
    kind: str
    low: float | None = None
    high: float | None = None
    status: str | None = None


@dataclass(frozen=True, kw_only=True)
class Catalogue:
    """A design's catalogue data (``<design>_catalogue.toml``)."""
    design: str
    source: CatalogueSource
    test: CatalogueTest
    figures: tuple
    path: str
    assumptions_commit: str | None = None

    def figures_of(self, key):
        """Every :class:`CatalogueFigure` of ``key`` (one per kind), in file order."""
        return [f for f in self.figures if f.key == key]

    def figure(self, key, kind=None):
        """The :class:`CatalogueFigure` of ``key`` (of ``kind``; None: the first in the file), or
        None when the catalogue prints none."""
        for f in self.figures:
            if f.key == key and (kind is None or f.kind == kind):
                return f
        return None

    def citation(self, figure=None):
        """'title, edition, page' of the source (and of one figure's page)."""
        s = f"{self.source.title}, {self.source.edition}"
        return f"{s}, {figure.page}" if figure is not None else s


def load_catalogue(path):
    """:class:`Catalogue` from a file path or a shipped name (``rv40e_catalogue``)."""
    t, p = read_data_file(path, "catalogue")
    src = t.get("source")
    if not isinstance(src, dict):
        raise RvtoolInputError("section [source] is missing from the catalogue file (title, edition)")
    source = CatalogueSource(title=text_field(src, "title", "source"), edition=text_field(src, "edition", "source"),
                             url=text_field(src, "url", "source", required=False))
    te = t.get("test")
    if not isinstance(te, dict):
        raise RvtoolInputError("section [test] is missing from the catalogue file")
    pts = te.get("rigidity_torque_points")
    if pts is not None:
        if not isinstance(pts, list) or len(pts) != 2:
            raise RvtoolInputError(f"test.rigidity_torque_points = {pts!r} is not valid (valid: two fractions of the "
                                   "rated torque, 0 < a < b <= 1)")
        check_range("test.rigidity_torque_points[0]", pts[0], 0.0, 1.0, low_open=True, high_open=True)
        check_range("test.rigidity_torque_points[1]", pts[1], pts[0], 1.0, low_open=True)
        pts = (float(pts[0]), float(pts[1]))
    rpm = _num(te, "rated_output_speed_rpm", "test", 0.0, low_open=True)
    test = CatalogueTest(rated_torque=_num(te, "rated_torque", "test", 0.0, low_open=True),
                         rated_output_speed=rpm * math.pi / 30.0, rated_output_speed_rpm=rpm,
                         rated_life_h=_num(te, "rated_life_h", "test", 0.0, low_open=True),
                         lost_motion_torque_fraction=_num(te, "lost_motion_torque_fraction", "test", 0.0, 1.0,
                                                          low_open=True),
                         rigidity_torque_points=pts)
    raw = t.get("figure", [])
    if not isinstance(raw, list):
        raise RvtoolInputError("figure must be an array of tables ([[figure]])")
    figs, seen = [], set()
    for i, f in enumerate(raw):
        w = f"figure[{i}]"
        key = text_field(f, "key", w)
        unit = text_field(f, "unit", w)
        kind = text_field(f, "kind", w)
        if kind not in KINDS:
            raise RvtoolInputError(f"{w}.kind = {kind!r} is not valid (valid: {list(KINDS)})")
        if (key, kind) in seen:
            raise RvtoolInputError(f"{w}: key {key!r} of kind {kind!r} appears twice (valid: one figure per key "
                                   "and kind)")
        seen.add((key, kind))
        value = _num(f, "value", w)
        low = _num(f, "low", w) if "low" in f else None
        high = _num(f, "high", w, low if low is not None else -math.inf) if "high" in f else None
        status = text_field(f, "status", w, required=False)
        if status is not None and status not in STATUSES:
            raise RvtoolInputError(f"{w}.status = {status!r} is not valid (valid: {list(STATUSES)})")
        figs.append(CatalogueFigure(key=key, value=value, unit=unit, value_si=value * _unit_factor(unit, f"{w}.unit"),
                                    page=text_field(f, "page", w), conditions=text_field(f, "conditions", w, required=False) or "",
                                    kind=kind, low=low, high=high, status=status))
    commit = t.get("assumptions_commit")
    if commit is not None and (not isinstance(commit, str) or len(commit) < 7
                               or any(c not in "0123456789abcdef" for c in commit)):
        raise RvtoolInputError(f"assumptions_commit = {commit!r} is not valid (valid: a git commit hash, hex)")
    return Catalogue(design=t["design"], source=source, test=test, figures=tuple(figs), path=str(p),
                     assumptions_commit=commit)


@dataclass(frozen=True, kw_only=True)
class AssumedInput:
    """One `assumed` design input: dotted design-file key, the cited range [low, high] in the
    design file's unit (SI; `_deg` keys in degrees; a list-valued key has element-wise lists), unit
    as written, and the source. An integer key (both ends integers) takes integer values."""
    key: str
    low: float | tuple
    high: float | tuple
    unit: str
    source: str

    @property
    def integer(self):
        return isinstance(self.low, int) and isinstance(self.high, int)

    @property
    def middle(self):
        m = 0.5 * (np.asarray(self.low, float) + np.asarray(self.high, float))
        return m.tolist() if m.ndim else float(m)

    def at(self, u):
        """The design-file value at the fraction ``u`` in [0, 1] of the range (element-wise for a list;
        rounded to the nearest integer for an integer key)."""
        v = np.asarray(self.low, float) + float(u) * (np.asarray(self.high, float) - np.asarray(self.low, float))
        if self.integer:
            return int(round(float(v)))
        return v.tolist() if v.ndim else float(v)


@dataclass(frozen=True, kw_only=True)
class AssumedRanges:
    """A design's `assumed` inputs (``<design>_assumed.toml``)."""
    design: str
    inputs: tuple
    path: str


def _bound(table, key, where):
    if key not in table:
        raise RvtoolInputError(f"{where}.{key} is missing (valid: a number, or a list of numbers for a list-valued key)")
    v = table[key]
    if isinstance(v, list):
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                raise RvtoolInputError(f"{where}.{key}[{i}] = {x!r} is not a number")
            check_range(f"{where}.{key}[{i}]", x)
        return tuple(float(x) for x in v)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise RvtoolInputError(f"{where}.{key} = {v!r} is not a number")
    check_range(f"{where}.{key}", v)
    return v


def load_assumed(path):
    """:class:`AssumedRanges` from a file path or a shipped name (``rv40e_assumed``)."""
    t, p = read_data_file(path, "assumed")
    raw = t.get("assumed", [])
    if not isinstance(raw, list) or not raw:
        raise RvtoolInputError("assumed must be a non-empty array of tables ([[assumed]] with key, low, high, unit, "
                               "source)")
    out, seen = [], set()
    for i, a in enumerate(raw):
        w = f"assumed[{i}]"
        key = text_field(a, "key", w)
        if key in seen:
            raise RvtoolInputError(f"{w}.key = {key!r} appears twice (valid: one range per key)")
        seen.add(key)
        low, high = _bound(a, "low", w), _bound(a, "high", w)
        if np.shape(low) != np.shape(high):
            raise RvtoolInputError(f"{w}: low {low!r} and high {high!r} must have one shape")
        if not np.all(np.asarray(low, float) <= np.asarray(high, float)) or np.all(np.asarray(low) == np.asarray(high)):
            raise RvtoolInputError(f"{w}.high = {high!r} is outside the valid range [low = {low!r}, inf) (element-wise, "
                                   "and above low somewhere: a range, not a value)")
        out.append(AssumedInput(key=key, low=low, high=high, unit=text_field(a, "unit", w), source=text_field(a, "source", w)))
    return AssumedRanges(design=t["design"], inputs=tuple(out), path=str(p))


def get_key(table, key):
    """Value of the dotted design-file ``key`` in a design table (``a.b.c``; ``a.b[1].c`` indexes
    an array of tables)."""
    node = table
    for part in key.split("."):
        name, idx = part, None
        if part.endswith("]") and "[" in part:
            name, idx = part[:-1].split("[")
            idx = int(idx)
        if not isinstance(node, dict) or name not in node:
            raise RvtoolInputError(f"assumed key {key!r}: the design has no {name!r} (valid: a dotted key of the "
                                   "design file)")
        node = node[name]
        if idx is not None:
            node = node[idx]
    return node


def set_key(table, key, value):
    """A copy of the design ``table`` with the dotted ``key`` set to ``value``."""
    import copy
    out = copy.deepcopy(table)
    *path, last = key.split(".")
    node = out
    for part in path:
        name, idx = part, None
        if part.endswith("]") and "[" in part:
            name, idx = part[:-1].split("[")
            idx = int(idx)
        node = node[name] if idx is None else node[name][idx]
    get_key(table, key)                   # names a missing key
    if last.endswith("]"):
        name, idx = last[:-1].split("[")
        node[name][int(idx)] = value
    else:
        node[last] = value
    return out


def check_assumed_middle(assumed: AssumedRanges, design_table, *, rtol=1e-9):
    """Raise unless every `assumed` value of the design table is the middle of its cited range
    (relative tolerance ``rtol`` of the range's width: a decimal written in the file)."""
    for a in assumed.inputs:
        v = get_key(design_table, a.key)
        try:
            va = np.asarray(v, float)
        except (TypeError, ValueError):
            raise RvtoolInputError(f"assumed key {a.key!r}: the design's value {v!r} is not a number") from None
        width = np.abs(np.asarray(a.high, float) - np.asarray(a.low, float))
        if va.shape != np.shape(a.middle) or np.any(np.abs(va - np.asarray(a.middle)) > rtol * np.max(width)):
            raise RvtoolInputError(f"{a.key} = {v!r} in the design is not the middle {a.middle!r} of its assumed range "
                                   f"[{a.low!r}, {a.high!r}] {a.unit} ({a.source}); valid: the middle, fixed "
                                   "before any catalogue comparison")
