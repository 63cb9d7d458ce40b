"""The design file format, read off the component specs themselves: ``rvtool new`` templates
and the format documentation (``rvtool designs --format-doc``).

Nothing here lists keys by hand. For a registered topology (:mod:`rvtool.assembly.topologies`)
the top-level design dataclass gives the top-level keys and, through its dataclass-typed
fields (also ``A | B | None``: the spec the reference design holds), the sections; each
section's dataclass fields are its keys, a field holding a spec is a sub-table
(``[housing.structure]``), and the rows of an angular-contact pair are listed with the pair's
keys (the loader's flat rule). The walk follows the reference design as loaded, so linked
keys show their linked values (and are optional) and an angle the file gives in degrees
(``NAME_deg``) is listed under that key. Per key:

* **unit and meaning** -- from ``field(metadata={"unit": ..., "doc": ...})`` where a spec sets
  it, else from the spec's docstring (the text after the key's name up to its ``[unit]``);
* **valid range** -- asked of the spec's own validation: the section is constructed with the
  key set far below and far above its example value (and to an invalid string for text keys)
  and the range or the choices quoted by the resulting :class:`~rvtool.errors.RvtoolInputError`
  are reported. A range that depends on other keys is quoted at the example's values of those
  keys (e.g. ``output_pins.hole_radius`` above ``output_pins.pin_radius``). So the documented
  range is the range the loader enforces, by construction.
* **example value** -- the topology's reference design (a shipped file) or the field default.

The template is written with tomlkit (a TOML library that keeps comments), so the comments
are TOML comments attached to their keys, not pasted strings.
"""
import dataclasses
import math
import re
import tomllib
import textwrap
import typing

import numpy as np

from ..errors import RvtoolInputError
from ..units import angle_columns, file_key, is_angle

_RANGE = re.compile(r"valid range\s*(?:is\s*)?([\[\(][^\]\)]*[\]\)])")
_CHOICES = re.compile(r"valid(?: choices(?: are)?|:)?\s*(\[[^\]]*\])")
LEFT_OUT = "(left out: {})"
"""How a key's meaning ends when the key follows another key where the file leaves it out (a link);
the template writes such a key commented out, so that it follows the key it names."""
_LINKED = re.compile(r"\(left out: [^()]*\)\.?$")
PROBES = (-1e30, 1e30)
"""Values far outside any physical range: the spec's validation quotes its bounds."""


def _is_spec(tp):
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


def _hints(cls):
    try:
        return typing.get_type_hints(cls)
    except Exception:  # an unresolvable annotation: fall back to the raw field types
        return {f.name: f.type for f in dataclasses.fields(cls)}


def _spec_types(tp):
    """The spec dataclasses of an annotation (``X``, or the dataclasses of ``X | Y | None``)."""
    return [t for t in (tp, *typing.get_args(tp)) if _is_spec(t)]


def sections(design_cls, design=None):
    """(top-level fields, {section name: section dataclass}) of a design dataclass; for a field
    of several spec types, the type ``design`` holds there (else the first). Fields marked
    ``metadata={"file": False}`` are not file keys."""
    hints = _hints(design_cls)
    top, secs = [], {}
    for f in dataclasses.fields(design_cls):
        if f.metadata.get("file", True) is False or not f.init:
            continue                        # not a file key, or derived by the design (init=False)
        specs = _spec_types(hints.get(f.name, f.type))
        if specs:
            value = getattr(design, f.name, None) if design is not None else None
            secs[f.name] = type(value) if value is not None and _is_spec(type(value)) else specs[0]
        else:
            top.append(f)
    return top, secs


_UNIT = re.compile(r"\[(-|[A-Za-z%][A-Za-z0-9^/ .*\-]*)\]")
"""A unit in brackets (``[m]``, ``[N m/rad]``, ``[kg m^2]``, ``[-]``), not a range (``[0, 3]``)."""


def _clause_end(doc, i, names):
    """Index where the clause starting at ``doc[i]`` ends, outside parentheses: the next ``;``, a
    sentence end (a ``.`` before a capital letter, before another key's ``name:`` / ``name,`` or at
    the end) or ``, NAME`` of another field ``NAME`` in ``names`` (a comma-separated key list)."""
    depth = 0
    for j in range(i, len(doc)):
        c = doc[j]
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth = max(0, depth - 1)
        elif depth == 0 and c == ";":
            return j
        elif depth == 0 and c == "." and (j + 1 == len(doc) or re.match(r"\s+(?:[A-Z]|`?\w+`?[:,]|$)", doc[j + 1:])):
            return j
        elif depth == 0 and c == ",":
            m = re.match(r",\s*(?:and\s+)?`*(\w+)`*", doc[j:])
            if m and m.group(1) in names:
                return j
    return len(doc)


_PATTERNS = (r"(?<![\w.`]){name}(?![\w`])((?:,\s*(?:and\s+)?\w+)*):\s*",   # name: meaning
             r"(?<![\w.`]){name}(?![\w`])(?=[^\[\];.]{{0,40}}\[)",          # name SYMBOL [unit]
             r"``{name}``\s*[:]?\s*",                                       # ``name`` ...
             r"(?<![\w.`]){name}(?![\w`])\s*")                              # name ...


def _clause(doc, name, names=(), patterns=_PATTERNS):
    """The clause of docstring ``doc`` describing key ``name`` (its text after the name, or after a
    list of keys that share it: ``f0_ball, f1_ball: ...``), or ""."""
    # code examples (``Spec(key=value)``) describe nothing (pairs of `` taken in order)
    doc = re.sub(r"``([^`]*)``", lambda m: "" if "=" in m.group(1) else m.group(0), doc)
    for pattern in patterns:
        pattern = pattern.format(name=re.escape(name))
        for m in re.finditer(pattern, doc):
            listed = re.findall(r"\w+", m.group(1)) if m.groups() else []
            if any(n not in names for n in listed if n != "and"):
                continue                # "name, word:" that is not a list of keys
            p = m.end()
            while True:                 # a key list "name, other, third [unit]": skip the other names
                k = re.match(r",\s*(?:and\s+)?(\w+)\s*", doc[p:])
                if not (k and k.group(1) in names):
                    break
                p += k.end()
            text = doc[p:_clause_end(doc, p, set(names) - {name})].strip(" ,:")
            if text:
                return text
    return ""


def describe(cls, name):
    """(meaning, unit) of field ``name`` of spec ``cls`` (module docstring). The docstrings of
    the spec and its bases are searched for the key's clause (``name: meaning [unit]``, or
    ``name SYMBOL [unit]``, e.g. ``pin_circle_radius R_z [m]``) up to the next ``;`` or the end of
    its sentence, so the meaning is whole; its first bracketed unit is the key's unit. An integer
    field is a count ([-])."""
    f = {x.name: x for x in dataclasses.fields(cls)}[name]
    if "doc" in f.metadata:
        return f.metadata["doc"], f.metadata.get("unit", "")
    meaning, unit = "", f.metadata.get("unit", "")
    docs = [" ".join((b.__doc__ or "").split()) for b in cls.__mro__ if b is not object and b.__doc__]
    names = [x.name for x in dataclasses.fields(cls)]
    for pattern in _PATTERNS:               # the most specific form in any docstring first
        meaning = next((c for c in (_clause(d, name, names, (pattern,)) for d in docs) if c), "")
        if meaning:
            u = _UNIT.search(meaning)
            unit = unit or (u.group(1) if u else "")
            break
    if not unit and _hints(cls).get(name) is int:
        unit = "-"
    return meaning, unit


def _probe_message(cls, kw, name, value):
    """The validation message about ``name`` when the spec is built with ``name = value``
    (None when it is accepted or the message is about another key)."""
    try:
        cls(**{**kw, name: value})
    except RvtoolInputError as exc:
        msg = str(exc)
        return msg if re.search(rf"(?<![\w]){re.escape(name)}(?![\w])\s*(=|must|\(|contains|:)", msg) else None
    except (TypeError, ValueError, OverflowError, MemoryError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def valid_range(cls, kw, name):
    """Valid range or choices of field ``name`` as the spec's validation states them
    (constructed with the other fields at ``kw``); "" when the spec does not bound it."""
    value = kw.get(name)
    if isinstance(value, bool):
        return "true or false"
    if isinstance(value, str):
        msg = _probe_message(cls, kw, name, "__not_a_choice__")
        m = _CHOICES.search(msg or "")
        return f"one of {m.group(1)}" if m else "text"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        found = []
        for probe in PROBES:
            msg = _probe_message(cls, kw, name, int(probe) if isinstance(value, int) else probe)
            m = _RANGE.search(msg or "")
            if m and m.group(1) not in found:
                found.append(m.group(1))
        integer = " (integer)" if isinstance(value, int) else ""
        if not found:
            probes = [int(p) if isinstance(value, int) else p for p in PROBES]
            other = [(msg, p) for msg, p in ((_probe_message(cls, kw, name, p), p) for p in probes) if msg]
            if other:
                msg, p = other[0]
                return "constrained by other keys: " + msg.split(";")[0].replace(str(p), "VALUE")
            return "any finite number" + integer
        return " and ".join(found) + integer
    if isinstance(value, (list, tuple)):
        return "list"
    return ""


def _to_degrees(text):
    """The numbers of a range quoted in rad, in degrees (``inf`` stays)."""
    return re.sub(r"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?", lambda m: f"{math.degrees(float(m.group(0))):.6g}", text)


def angle_range(cls, kw, name):
    """Valid range [deg] of angle field ``name`` (held in rad) as the spec's validation states it:
    a message about ``name`` quotes radians, one about the file key ``name_deg`` degrees."""
    if isinstance(kw.get(name), (list, tuple)):
        return "list of numbers"
    found = []
    for probe in PROBES:
        try:
            cls(**{**kw, name: probe})
        except RvtoolInputError as exc:
            msg = str(exc)
        except (TypeError, ValueError, OverflowError):
            continue
        else:
            continue
        m = re.search(rf"(?<![\w]){re.escape(name)}(_deg)?(?![\w])\s*(=|must)", msg)
        r = _RANGE.search(msg) if m else None
        if r:
            text = r.group(1) if m.group(1) else _to_degrees(r.group(1))
            if text not in found:
                found.append(text)
    return " and ".join(found) if found else "any finite number"


def _example_kwargs(cls, table):
    kw = {}
    for f in dataclasses.fields(cls):
        if f.name in table:
            v = table[f.name]
            kw[f.name] = tuple(v) if isinstance(v, list) else v
        elif f.default is not dataclasses.MISSING:
            kw[f.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            kw[f.name] = f.default_factory()
    return kw


def _degrees(v):
    """An angle value [rad] (a number or a list) in degrees: rounded to 12 digits where that reads
    back as the same radians (0.2443... rad -> 14.0), else in full."""
    if isinstance(v, (list, tuple)):
        return tuple(_degrees(x) for x in v)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return v
    d = math.degrees(v)
    short = float(f"{d:.12g}")
    return short if math.radians(short) == v or float(np.deg2rad(short)) == v else d


def _plain(v):
    import enum
    if dataclasses.is_dataclass(v) and not isinstance(v, type):   # a nested component spec: its sub-table
        return {f.name: _plain(getattr(v, f.name)) for f in dataclasses.fields(v) if getattr(v, f.name) is not None}
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    if isinstance(v, enum.Enum):            # an Enum (also a str Enum): its file value
        return v.value
    return v


def _section_rows(path, cls, obj, raw, links, set_by_design):
    """Rows of one (sub-)table ``path`` of spec ``cls``, example values from the loaded spec
    ``obj`` (None: field defaults) and the file's table ``raw``; sub-tables recursively."""
    kw = {f.name: getattr(obj, f.name) for f in dataclasses.fields(cls)} if obj is not None \
        else _example_kwargs(cls, raw)
    if isinstance(kw.get("rows"), tuple) and kw["rows"] and _is_spec(type(kw["rows"][0])):
        # an angular-contact pair: its rows' keys sit in the pair's table (the loader's flat rule)
        row = kw["rows"][0]
        rows = [r for r in _section_rows(path, type(row), row, raw, links, set_by_design)]
        own = [f for f in dataclasses.fields(cls) if f.name != "rows"]
        return _field_rows(path, cls, own, kw, raw, links, set_by_design) + rows
    return _field_rows(path, cls, dataclasses.fields(cls), kw, raw, links, set_by_design)


def _field_rows(path, cls, fields, kw, raw, links, set_by_design):
    rows, subs = [], []
    for f in fields:
        if f.metadata.get("file", True) is False:
            continue                        # held for the code only (e.g. profile.lobe_rotations): not a file key
        value = kw.get(f.name)
        if f.name in set_by_design.get(path, ()):
            continue                        # the design sets it (e.g. a gear's name): not a file key
        if _is_spec(type(value)):
            sub = raw.get(f.name, {}) if isinstance(raw.get(f.name), dict) else {}
            subs += _section_rows(f"{path}.{f.name}", type(value), value, sub, links, set_by_design)
            continue
        meaning, unit = describe(cls, f.name)
        required = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        rng = valid_range(cls, kw, f.name) if f.name in kw and not is_angle(f) else ""
        key, shown = f.name, _plain(value)
        if is_angle(f):                     # an angle: the file gives it in degrees (the loader converts it)
            key, unit = file_key(f), "deg"
            shown = raw.get(key, _plain(_degrees(value)))
            cols = angle_columns(f)
            if cols is not None:            # a table: its angle columns in degrees, the others SI
                unit = f.metadata["unit"].replace("rad", "deg")
                shown = raw.get(key, None if value is None else [
                    [_degrees(x) if j in cols else x for j, x in enumerate(row)] for row in value])
            rng = angle_range(cls, kw, f.name) if f.name in kw else ""
            # "(file: ``NAME_deg``)" says what the key above says; "(file: ``NAME_deg``; more)" keeps "(more)"
            meaning = re.sub(r"\(file: ``[^`]*``;\s*", "(", meaning)
            meaning = re.sub(r"\s*\(file: ``[^`]*``\)?|\s*\[rad\]", "", meaning).strip(" ,;")
        if f.name in links.get(path, {}) and f.name not in raw and key not in raw:
            meaning = f"{meaning} {LEFT_OUT.format(links[path][f.name])}".strip()
            required = False
        elif f.default is None and value is not None and f.name not in raw and key not in raw:
            # a default the spec fills in from other keys (e.g. output_pins.gap_offsets: one 0 per wheel)
            meaning = f"{meaning} {LEFT_OUT.format('filled in by the spec from the other keys')}".strip()
        rows.append((path, key, shown, unit, rng, meaning, required))
    return rows + subs


def key_table(topology):
    """[(section path or "" for top level, key, example value, unit, valid range, meaning,
    required)] of a topology, in the design class's field order (sub-tables after their table)."""
    from .. import designs
    from ..assembly import topologies
    top = topologies.get(topology)
    cls = topologies.design_class(topology)
    table = {}
    if top.reference:
        with open(designs.path(top.reference), "rb") as fh:
            table = tomllib.load(fh)
    rows = []
    design = topologies.design_from_table(dict(table)) if table else None
    top_fields, secs = sections(cls, design)
    module = __import__(cls.__module__, fromlist=["_"])
    links = getattr(module, "LINKS", {})
    set_by_design = getattr(module, "SET_BY_DESIGN", {})
    kinds = getattr(module, "BEARING_KINDS", {})
    for f in top_fields:
        # the constructor's keywords only (a derived field, init=False, e.g. the std design's pair, is not one)
        kw = {g.name: getattr(design, g.name) for g in dataclasses.fields(cls) if g.init} if design is not None else {}
        meaning, unit = describe(cls, f.name)
        value = table.get(f.name, None if f.default is dataclasses.MISSING else f.default)
        rng = valid_range(cls, kw, f.name) if kw else ""
        rows.append(("", f.name, _plain(value), unit, rng, meaning, f.default is dataclasses.MISSING))
    for sec, scls in secs.items():
        sec_table = table.get(sec, {})
        obj = getattr(design, sec, None) if design is not None else None
        sec_kinds = getattr(module, "SECTIONS", {}).get(sec)
        sec_kinds = sec_kinds if isinstance(sec_kinds, dict) else kinds
        if "kind" in sec_table and sec_kinds:
            rows.append((sec, "kind", sec_table["kind"], "", f"one of {list(sec_kinds)}",
                         "the spec of this section (a bearing's type)", False))
        if obj is None and design is not None:
            continue                         # e.g. a locked bearing: no spec, no keys
        rows += _section_rows(sec, scls, obj, sec_table, links, set_by_design)
    return rows


def sentence(text):
    """``text`` as a whole sentence: stripped, ending in a full stop (never cut)."""
    text = " ".join(str(text).split()).rstrip(" ,;:")
    return text if not text or text.endswith((".", "?", "!")) else text + "."


def summary(cls):
    """The first paragraph of a spec's docstring, whole (what a table's comment says)."""
    return sentence(" ".join((cls.__doc__ or "").strip().split("\n\n")[0].split()))


def _comment(unit, rng, meaning, required):
    parts = [f"[{unit}]" if unit else "", rng and f"valid: {rng}", "" if required else "optional", sentence(meaning)]
    return "  ".join(p for p in parts if p)


def template(topology, name=None):
    """TOML text of a commented design template of ``topology`` (raises
    :class:`~rvtool.assembly.topologies.TopologyUnavailable` when its spec is not installed)."""
    import tomlkit

    from ..assembly import topologies
    top = topologies.get(topology)
    cls = topologies.design_class(topology)
    doc = tomlkit.document()
    doc.add(tomlkit.comment(f"rvtool design: {top.summary}."))
    doc.add(tomlkit.comment("SI units unless a key's name says otherwise (e.g. *_deg, *_rpm). Each key's comment: "
                            "[unit], the valid range its spec enforces, optional (a default applies when the key "
                            "is left out), meaning."))
    doc.add(tomlkit.comment(f"Example values: {top.reference or 'field defaults'}. Check: rvtool analyze THIS_FILE --quick"))
    doc.add(tomlkit.comment("A key written commented out, '(left out: OTHER)', follows OTHER (e.g. the profile's pin radius "
                            "follows pins.pin_radius): uncomment it only to give it a value of its own."))
    doc.add(tomlkit.nl())
    version = tomlkit.item(topologies.FORMAT_VERSION)
    version.comment("the design file format: every angle in degrees (NAME_deg), every other key SI")
    doc.add("format_version", version)
    doc.add("topology", topology)
    rows = key_table(topology)
    classes = _table_classes(topology)
    tables = {}
    for sec, key, value, unit, rng, meaning, required in rows:
        if value is None or (sec == "" and key == "topology"):
            continue    # an optional key without a value (TOML has no null): left out, its default applies;
            # the topology key is written above (a design class may record it as a field)
        if sec == "" and key == "name" and name is not None:
            value = name
        item = tomlkit.item(value)
        text = _comment(unit, rng, meaning, required)
        if text:
            item.comment(text)
        if _LINKED.search(meaning):
            # a linked key written out would keep its value when the key it follows changes (a wheel
            # made wider kept the output pins' 8 mm contact length; a new pins.pin_radius was refused
            # as differing from profile.pin_radius): commented out, it follows
            commented = tomlkit.comment(f"{key} = {item.as_string()}" + (f" # {text}" if text else ""))
            item = None
        if sec == "":
            doc.add(key, item) if item is not None else doc.add(commented)
        else:
            if sec not in tables:
                t = tomlkit.table()
                c = classes.get(sec)
                if c is not None:
                    for line in textwrap.wrap(f"{c.__name__}: {summary(c)}", 100):
                        t.add(tomlkit.comment(line))
                tables[sec] = t
            tables[sec].add(key, item) if item is not None else tables[sec].add(commented)
    for sec, t in tables.items():
        head, _, tail = sec.rpartition(".")
        if head:
            tables[head].add(tail, t)        # a sub-table inside its table ([housing.structure])
    for sec, t in tables.items():
        if "." not in sec:
            doc.add(tomlkit.nl())
            doc.add(sec, t)
    return tomlkit.dumps(doc)


def _table_classes(topology):
    """{table path: spec class} of the reference design (the class named in each table's comment)."""
    from .. import designs
    from ..assembly import topologies
    top = topologies.get(topology)
    cls = topologies.design_class(topology)
    design = None
    if top.reference:
        with open(designs.path(top.reference), "rb") as fh:
            design = topologies.design_from_table(tomllib.load(fh))
    out = {}

    def walk(path, obj):
        out[path] = type(obj)
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if _is_spec(type(v)):
                walk(f"{path}.{f.name}", v)
    _, secs = sections(cls, design)
    for sec, scls in secs.items():
        obj = getattr(design, sec, None) if design is not None else None
        if obj is not None:
            walk(sec, obj)
        else:
            out[sec] = scls
    return out


def format_doc():
    """Markdown documentation of the design file format of every available topology."""
    from ..assembly import topologies
    out = ["# Design file format", "",
           "Generated by `rvtool designs --format-doc` from the component specs (`rvtool/designs/format.py`): "
           "keys, units and meanings from the specs' dataclass fields and docstrings, valid ranges from the "
           "specs' own validation, example values from each topology's reference design. Do not edit by hand.",
           "", "A design file is TOML. `topology` (top level) picks the topology (default `cycloid`); the other "
           "top-level keys and the `[section]` tables below belong to that topology. A range shown with "
           "numbers from other keys is the range at the reference design's values of those keys.", ""]
    for name, top in topologies.TOPOLOGIES.items():
        out.append(f"## `topology = \"{name}\"`: {top.summary}")
        out.append("")
        reason = topologies.available(name)
        if reason:
            out += [f"Not available in this installation: {reason}.", ""]
            continue
        classes = _table_classes(name)
        current = None
        for sec, key, value, unit, rng, meaning, required in key_table(name):
            if sec != current:
                current = sec
                title = "top level" if sec == "" else f"`[{sec}]` ({classes[sec].__name__})"
                out += ["", f"### {title}", "", "| key | unit | valid range | required | example | meaning |",
                        "|---|---|---|---|---|---|"]
            ex = "" if value is None else f"`{value}`"
            out.append(f"| `{key}` | {unit} | {rng} | {'yes' if required else 'no'} | {ex} | {sentence(meaning)} |")
        out.append("")
    out += _tolerance_doc()
    return "\n".join(out) + "\n"


def _tolerance_doc():
    """The keys of the tolerance files (``<design>_tolerances.toml``) of each topology's Monte Carlo
    (:mod:`rvtool.designs.tolerance_keys`; samplers in :mod:`rvtool.variants`)."""
    from .tolerance_keys import CYCLOID_TOLERANCE_KEYS, RV_TOLERANCE_KEYS, STD_TOLERANCE_KEYS
    out = ["## Tolerance files (`<design>_tolerances.toml`)", "",
           "The manufacturing tolerances of a design's Monte Carlo (`rvtool analyze --protocols monte_carlo`). "
           "`rvtool new --name NAME` writes `NAME_tolerances.toml` beside `NAME.toml`, with grades computed from "
           "the template's sizes (ISO 286-1 IT4 for the pins, ISO 1328-1:2013 f_pT for the gears; for RV designs "
           "also the pin ring's and the wheel's pitch, IT5 position and coaxiality tolerances, the profile slope "
           "f_HaT and the gear runout F_rT at the design's sizes, by the rules of rv80e_tolerances.toml) and the "
           "other values marked `assumed` with their range (`rvtool/designs/tolerance_template.py`); `rvtool "
           "analyze NAME.toml` reads it (or `--tolerances FILE`). A `[tolerances]` table; every key optional "
           "(absent: no deviation, the design as it is), each an inline table `{ dist = \"normal\" | \"uniform\" | "
           "\"truncnormal\" | \"fixed\", ... }` of the drawn value (normal: mean, std > 0; uniform: low < high; "
           "truncnormal: mean, std, low, high; fixed: value), any finite values. A bad key or value stops `rvtool "
           "analyze` with the file, the key and its valid range. Variant k draws from `default_rng([seed, k])` in "
           "the order of the table of its topology. A position tolerance (ISO 1101) of diameter t is written as "
           "the distribution of each deviation coordinate.", ""]
    for title, keys, module, col in (
            ("cycloid", CYCLOID_TOLERANCE_KEYS, "rvtool/variants/tolerances.py", "changes"),
            ("rv2, rv3", RV_TOLERANCE_KEYS, "rvtool/variants/rv_tolerances.py", "writes"),
            ("std-involute", STD_TOLERANCE_KEYS, "rvtool/variants/std_tolerances.py", "writes")):
        out += [f"### Tolerance keys: {title} (`{module}`)", "",
                f"| key | unit | meaning | {col} |", "|---|---|---|---|"]
        out += [f"| `{k}` | {unit} | {sentence(meaning)} | " + (f"`{writes}`" if "." in writes.split(" ")[0] else writes)
                + " |" for k, (unit, meaning, writes) in keys.items()]
        out.append("")
    return out
