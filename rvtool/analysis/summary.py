"""The datasheet summary that opens ``report.html``: the figures a design review checks first,
named in words with their units, their numerical error and pass/fail against the design's
declared allowables (:class:`rvtool.designs.allowables.Allowables`).

Allowables are found beside the design: a shipped design ``NAME`` uses the shipped
``NAME_allowables`` file (``rvtool/designs/rd40_allowables.toml``), a design file
``dir/X.toml`` uses ``dir/X_allowables.toml``; ``rvtool analyze --allowables FILE`` names one.
Without a file every row says "no allowable". The summary is computed from the results dict
alone (``results.json``), so a report can be re-rendered from the file.
"""
from dataclasses import dataclass
from pathlib import Path

PA_PER_MPA = 1e6
AT_LEAST, AT_MOST = "\u2265", "\u2264"

FAMILY_WORDS = {
    "pins": "ring pins (cycloid-pin mesh)",
    "output_pins": "output pins in the wheel holes",
    "eccentric_bearings": "eccentric bearings",
    "input_bearings": "input bearings",
    "main_bearings": "main bearings",
    "needles": "eccentric-bearing needles",
    "gears": "involute gear mesh",
    "involute_stage": "involute mesh",
    "crank_bearings": "crank bearings",
}
"""Contact families and Hertz groups in words (a family not listed is shown by its name)."""

HERTZ_ALLOWABLE = {"pins": "max_hertz_pins", "output_pins": "max_hertz_output_pins", "needles": "max_hertz_needles"}
"""Hertz group -> the Allowables key that bounds its peak pressure."""

MEMBER_HERTZ_GROUP = "pins"
"""The pressure protocol's members (``wheel0``, ...) are the main mesh; on the cycloid and RV
topologies that is the cycloid--ring-pin contact, bounded by ``max_hertz_pins``."""


@dataclass(frozen=True)
class Row:
    """One summary line: ``quantity`` in words, ``value`` in ``unit`` (None: not computed, with
    ``note`` saying why), ``error`` text, ``allowable`` text, ``verdict`` ("pass", "FAIL",
    "no allowable", "not computed", "not checked")."""
    quantity: str
    value: float | None
    unit: str
    error: str
    allowable: str
    verdict: str
    source: str
    note: str = ""


def find_allowables(design_source, shipped=None):
    """Path [str] of the allowables file of a design (see the module docstring), or None."""
    from .. import designs
    if shipped:
        name = f"{shipped}_allowables"
        if name in designs.names() and designs.kind(name) == "allowables":
            return designs.path(name)
        return None
    p = Path(str(design_source))
    if p.suffix == ".toml":
        cand = p.with_name(f"{p.stem}_allowables.toml")
        if cand.is_file():
            return str(cand)
    return None


def allowables_record(path):
    """The ``allowables`` entry of results.json: {"source": path or None, "values": {key: SI value}
    or None}. Loading errors name the file's keys (:func:`rvtool.designs.allowables.load_allowables`)."""
    if path is None:
        return {"source": None, "values": None}
    from ..designs.allowables import load_allowables
    a = load_allowables(path)
    keys = ("min_torsional_stiffness", "max_lost_motion", "max_hertz_pins", "max_hertz_output_pins",
            "max_hertz_needles", "max_hysteresis_loss", "min_bearing_life")
    return {"source": str(path), "values": {k: getattr(a, k) for k in keys}}


def _figure(data, proto, name):
    block = data.get(proto)
    if not isinstance(block, dict) or block.get("status") != "ok":
        return None
    return block.get("figures", {}).get(name)


def _status_note(data, proto):
    block = data.get(proto)
    if not isinstance(block, dict):
        return f"protocol {proto} was not run"
    if block.get("status") != "ok":
        return f"protocol {proto} {block.get('status')}: {block.get('reason', '')}".rstrip(": ")
    return ""


def _error_text(f):
    if f is None or f.get("error") is None:
        return "not estimated"
    unit = f.get("error_unit") or f.get("unit", "")
    if unit == "-":
        return f"{100.0 * f['error']:.2g} % (relative)"
    return f"{f['error']:.3g} {unit}"


def _judge(value, limit, kind):
    if limit is None:
        return "no allowable"
    if value is None:
        return "not computed"
    ok = value >= limit if kind == "min" else value <= limit
    return "pass" if ok else "FAIL"


def _limit_text(limit, kind, unit):
    if limit is None:
        return "no allowable"
    return f"{AT_LEAST if kind == 'min' else AT_MOST} {limit:.4g} {unit}"


def summary_rows(data):
    """The summary :class:`Row` list of a results dict (``rvtool analyze``'s results.json)."""
    allow = (data.get("allowables") or {}).get("values") or {}
    rows = []

    def add(quantity, proto, fig_name, unit, allow_key=None, kind="max", scale=1.0):
        f = _figure(data, proto, fig_name)
        limit = allow.get(allow_key) if allow_key else None
        limit = None if limit is None else limit * scale
        value = None if f is None else f.get("value")
        u = unit
        if f is not None and f.get("unit") != unit:       # a renamed unit must not pass a check silently
            raise ValueError(f"{proto}/{fig_name} is in {f.get('unit')!r}; the summary expects {unit!r}")
        note = "" if f is not None else (_status_note(data, proto) or f"{proto} reports no {fig_name}")
        verdict = "not computed" if value is None else _judge(value, limit, kind)
        rows.append(Row(quantity, value, u, _error_text(f), _limit_text(limit, kind, u), verdict,
                        f"{proto} / {fig_name}", note))

    add("Transmission error, peak-to-peak (quasi-static, rated torque)", "te", "te_pp", "arcsec")
    add("Torsional rigidity, secant over 50-100 % rated torque (first loading)", "stiffness", "K_pos_loading",
        "N m/arcmin", "min_torsional_stiffness", "min")
    add("Torsional rigidity, tangent at 75 % rated torque", "stiffness", "Kt_condensed", "N m/arcmin")
    add("Lost motion at +-3 % rated torque", "lost_motion", "lost_motion", "arcmin", "max_lost_motion")
    add("Hysteresis loss (catalogue: loop width at zero torque along the unloading branches)", "hysteresis",
        "hysteresis_loss", "arcmin", "max_hysteresis_loss")
    te = data.get("te") if isinstance(data.get("te"), dict) else {}
    for name in sorted((te.get("figures") or {})):
        if name.startswith("peak_load_"):
            fam = name[len("peak_load_"):]
            add(f"Peak contact-row force (largest slice or lamina), {FAMILY_WORDS.get(fam, fam)}", "te", name, "N")
    # Hertz peaks at the rated state of every contact group the topology gives (te protocol's data)
    peaks = ((te.get("data") or {}).get("hertz_peaks_at_rated_Pa") or {}) if te.get("status") == "ok" else {}
    for grp, p0 in sorted(peaks.items()):
        key = HERTZ_ALLOWABLE.get(grp)
        limit = allow.get(key) if key else None
        v = None if p0 is None else p0 / PA_PER_MPA
        lim = None if limit is None else limit / PA_PER_MPA
        rows.append(Row(f"Peak Hertz pressure at rated torque, {FAMILY_WORDS.get(grp, grp)}", v, "MPa",
                        "not estimated (Hertz line contact at the solved state)", _limit_text(lim, "max", "MPa"),
                        _judge(v, lim, "max"), "te / data.hertz_peaks_at_rated_Pa"))
    pr = data.get("pressure") if isinstance(data.get("pressure"), dict) else {}
    for name in sorted((pr.get("figures") or {})):
        if name.startswith("p_window_"):
            member = name[len("p_window_"):]
            add(f"Peak local contact pressure, main mesh, {member} (pressure field)", "pressure", name,
                "MPa", HERTZ_ALLOWABLE[MEMBER_HERTZ_GROUP], "max", 1.0 / PA_PER_MPA)
    if not any("pressure" in r.quantity for r in rows):    # said, not left out
        lim = allow.get(HERTZ_ALLOWABLE[MEMBER_HERTZ_GROUP])
        note = _status_note(data, "pressure") or "the protocol reported no pressure figure"
        if te.get("status") == "ok" and not peaks:
            note += "; the topology gives no Hertz peaks at the rated state"
        rows.append(Row("Peak contact pressure, main mesh", None, "MPa", "-",
                        _limit_text(None if lim is None else lim / PA_PER_MPA, "max", "MPa"), "not computed",
                        "pressure", note))
    life_limit = allow.get("min_bearing_life")
    rows.append(Row("Bearing rating life L10h (ISO 281, rated torque and speed)", None, "h",
                    "-", _limit_text(life_limit, "min", "h"), "not computed", "-",
                    "rvtool analyze does not compute bearing rating lives: they need the rolling-element loads of "
                    "a bearing model the quick and full protocols do not build; the cycloid drive's come from "
                    "rvtool.analysis.precision_study (cases/cycloid/cycloid_double_wheel.py)"))
    return rows
