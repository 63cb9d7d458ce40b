"""Build-time generators of the rvtool documentation (a Sphinx extension).

Nothing a page shows as a measured figure is typed by hand: it is read here from a committed
``results.json`` of a case run (``docs/case_results/<folder>/<case>/results.json`` with a
``source.json`` beside it naming the commit, host, date and command of the run; written by
``python docs/_ext/collect_results.py``). The docs build reads those files; it never reruns a
study. Cases are looked up by name, whatever folder of ``cases/`` or of ``docs/case_results/``
they live in.

Generated content:

* ``reference/design_format`` -- the page's source is replaced by
  :func:`rvtool.designs.format.format_doc` (the text ``rvtool designs --format-doc`` prints);
* ``changelog`` -- the fragments ``docs/changelog.d/*.md`` (one per helper or branch) are
  appended in name order under "Unreleased";
* directive ``case-results NAME`` -- provenance line, verdict and a table of the scalar figures
  of one case's results.json; ``:keys:`` (comma-separated key-path prefixes) narrows the table,
  ``*`` in a key path matches one level; ``:each: PATH`` with ``:keys: SUB [unit], ...`` makes a
  table of one row per entry of the dict or list at PATH (a design, a variant) and one column per
  sub-path, its unit read from the key's name (``L10_h``, ``K_t_Nm_per_arcmin``) or given in brackets;
  ``:label: SUB`` labels list entries by a sub-key;
  ``:plot:`` (``X_PATH Y_PATH [Y_PATH ...]``, key paths joined by ``/``) draws a figure of
  list-valued entries, ``:log:`` (``x``, ``y`` or ``xy``) sets log axes;
* directive ``results-index FOLDER`` -- one row per committed case of a folder (verdict, wall
  time, quick or full, host, commit), each linking to nothing but its data: a page per case is
  written by whoever owns the case (``case-results`` there).
"""
import json
import math
import re
import os
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import directives
from docutils.statemachine import StringList
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

DOCS = Path(__file__).resolve().parents[1]
RESULTS = DOCS / "case_results"
GENERATED = DOCS / "_generated"
MAX_ROWS = 60
"""Longest generated table; the rest is counted and left in results.json (the page says so)."""


# -- reading committed results ------------------------------------------------------------------

class MissingResults(LookupError):
    """A page names a case with no (or ambiguous) committed results."""


def case_dir(name):
    """Folder of the committed results of case ``name`` (any ``docs/case_results/<folder>/``)."""
    hits = sorted(RESULTS.glob(f"*/{name}/results.json"))
    if not hits:
        raise MissingResults(f"no committed results for case {name!r} under {RESULTS} "
                       "(add them with docs/_ext/collect_results.py)")
    if len(hits) > 1:
        raise MissingResults(f"case {name!r} has results in several folders: {[str(h.parent) for h in hits]}")
    return hits[0].parent


def load_case(name):
    """(results dict, source dict) of case ``name``."""
    d = case_dir(name)
    data = json.loads((d / "results.json").read_text())
    src_path = d / "source.json"
    source = json.loads(src_path.read_text()) if src_path.is_file() else {}
    return data, source


def flatten(obj, prefix=""):
    """(key path, scalar) pairs of a results dict; lists of <= 6 scalars count as one value,
    longer lists and the provenance are left out."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k == "provenance" and not prefix:
                continue
            yield from flatten(v, f"{prefix}/{k}" if prefix else str(k))
    elif isinstance(obj, list):
        if len(obj) <= 6 and all(isinstance(v, (int, float, str, bool)) or v is None for v in obj):
            yield prefix, obj
    else:
        yield prefix, obj


def get_path(data, path):
    """The entry at key path ``a/b/0/c`` (list indices as integers)."""
    cur = data
    for part in path.split("/"):
        if isinstance(cur, list):
            cur = cur[int(part)]
        else:
            cur = cur[part]
    return cur


def fmt(v):
    """A results value as table text (4 significant digits; None as a dash)."""
    if v is None:
        return "\u2014"
    if isinstance(v, bool):
        return "yes" if v else "**no**"
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        return f"{v:.4g}"
    if isinstance(v, list):
        return "[" + ", ".join(fmt(x) for x in v) + "]"
    return str(v).replace("|", "\\|").replace("\n", " ")


def passed_flags(obj, path=""):
    """Every ``passed`` entry of a results dict (provenance excluded)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k == "provenance":
                continue
            if k == "passed":
                yield path or "/", v
            else:
                yield from passed_flags(v, f"{path}/{k}")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from passed_flags(v, f"{path}[{i}]")


def verdict(data):
    """'passed', 'FAILED at ...' or 'no verdict written' from a case's own ``passed`` flags."""
    flags = list(passed_flags(data))
    if not flags:
        return "no verdict written"
    bad = [p for p, v in flags if v is not True]
    return "passed" if not bad else "FAILED at " + ", ".join(bad)


def provenance_line(name, data, source):
    """One sentence: which run, commit, host and date produced the committed results."""
    prov = data.get("provenance", {})
    dev = prov.get("device", {}) if isinstance(prov.get("device"), dict) else {"device": prov.get("device")}
    quick = prov.get("settings", {}).get("quick") if isinstance(prov.get("settings"), dict) else None
    mode = source.get("mode") or ("--quick" if quick else "full run" if quick is False else "run")
    wall = prov.get("wall_s_total")
    parts = [f"`{name}` (`{mode}`)", f"commit `{source.get('commit', 'unknown')}`",
             f"host {source.get('host', 'unknown')} ({dev.get('cpu', '?')}, {dev.get('cpu_count', '?')} cores"
             f"{', ' + str(dev['gpu']) if dev.get('gpu') else ''}), device {dev.get('device', '?')}",
             f"precision {prov.get('precision', '?')}", f"run {source.get('date', 'date unknown')}"]
    if isinstance(wall, (int, float)):
        parts.append(f"wall {wall:.3g} s")
    if source.get("note"):
        parts.append(source["note"])
    return "Source: " + "; ".join(parts) + "."


_UNITS = [  # key-name suffix -> unit (longest first); results keys carry their unit in their name
    ("_Nm_per_arcmin", "N m/arcmin"), ("_Nm_per_rad", "N m/rad"), ("_N_per_m", "N/m"),
    ("_arcmin_per_Nm", "arcmin/(N m)"), ("_per_s", "1/s"), ("_arcmin", "arcmin"), ("_arcsec", "arcsec"), ("_MPa", "MPa"),
    ("_GPa", "GPa"), ("_Pa", "Pa"), ("_Nm", "N m"), ("_kN", "kN"), ("_N", "N"), ("_rpm", "r/min"),
    ("_deg", "deg"), ("_rad", "rad"), ("_um", "\u00b5m"), ("_mm", "mm"), ("_m", "m"), ("_ms", "ms"),
    ("_us", "\u00b5s"), ("_s", "s"), ("_h", "h"), ("_W", "W"), ("_pct", "%"), ("_percent", "%"),
]


def _unit_of_name(last):
    if "." in last:             # a design-file key used as a results key (tornado/<key>): not a unit
        return ""
    for suffix, unit in _UNITS:
        if last.endswith(suffix) and len(last) > len(suffix):
            return unit
    head = last.split("_per_")[0] if "_per_" in last else None
    if head and "_" + head in dict(_UNITS):
        return dict(_UNITS)["_" + head] + "/" + last.split("_per_", 1)[1].replace("_", " ")
    return ""


def unit_of(path):
    """Unit named by the key path (``L10_h`` -> h, ``K_t_Nm_per_arcmin`` -> N m/arcmin,
    ``loss_by_family_W/pins`` -> W: the nearest key that names one, the last key first), or ''
    where none does. Dotted design-file keys (``row.contact_angle_deg`` as a tornado entry) name
    no unit. ``us_per_roller`` style (unit first) is read as the leading unit."""
    for part in reversed(str(path).rstrip("/").split("/")):
        unit = _unit_of_name(part)
        if unit:
            return unit
    return ""


def key_spec(text):
    """``path`` or ``path [unit]`` (a unit the key's name does not carry) -> (path, unit)."""
    m = re.fullmatch(r"\s*(.*?)\s*(?:\[([^\]]*)\])?\s*", text)
    path, unit = m.group(1), m.group(2)
    return path, (unit if unit is not None else unit_of(path))


def match_key(path, keys):
    """``path`` is selected by one of ``keys``: equal, below it, or a ``*`` pattern (one level each)."""
    for k in keys:
        if "*" in k:
            pat = "^" + re.escape(k).replace("\\*", "[^/]+") + "(/.*)?$"
            if re.match(pat, path):
                return True
        elif path == k or path.startswith(k + "/"):
            return True
    return False


def each_rows(data, each, specs, label=None):
    """Rows of a per-entry table: one row per child of the dict or list at key path ``each``,
    one column per (sub-path, unit) of ``specs``; a missing entry is a dash. ``label`` names a
    sub-key whose value labels a list element's row (default: the dict key or the index)."""
    base = get_path(data, each)
    items = list(base.items()) if isinstance(base, dict) else list(enumerate(base))
    rows = []
    for k, child in items:
        name = fmt(get_path(child, label)) if label else f"`{k}`"
        cells = []
        for sub, _ in specs:
            try:
                cells.append(fmt(get_path(child, sub)))
            except (KeyError, IndexError, TypeError, ValueError):
                cells.append("\u2014")
        rows.append([name] + cells)
    return rows


def table_lines(rows, header):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def plot_case(name, data, spec, log="", title=""):
    """PNG (path under docs/_generated) of the list-valued entries ``spec`` = 'X Y [Y ...]'."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = spec.split()
    if len(paths) < 2:
        raise ValueError(f":plot: needs an x path and at least one y path; got {spec!r}")
    x = get_path(data, paths[0])
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for p in paths[1:]:
        y = get_path(data, p)
        ax.plot(x, y, "o-", ms=3, lw=1, label=p)
    ax.set_xlabel(paths[0])
    if "x" in log:
        ax.set_xscale("log")
    if "y" in log:
        ax.set_yscale("log")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    ax.set_title(title or f"{name} (from its committed results.json)", fontsize=9)
    GENERATED.mkdir(exist_ok=True)
    stem = f"{name}_" + "_".join(p.replace("/", "-") for p in paths)[:80]
    out = GENERATED / f"{stem}.png"
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


# -- directives -----------------------------------------------------------------------------------

class _MarkdownDirective(SphinxDirective):
    def run(self):
        try:
            return self.generate()
        except MissingResults as exc:      # a warning (an error under -W) at the page's line, not a crash
            logger.warning(str(exc), location=self.get_location())
            return []

    def emit(self, lines):
        node = nodes.container()
        self.state.nested_parse(StringList(lines, source=self.get_source_info()[0]), self.content_offset, node)
        return node.children


class CaseResults(_MarkdownDirective):
    """``case-results NAME``: provenance, verdict, figure and table of one case's committed results."""
    required_arguments = 1
    option_spec = {"keys": directives.unchanged, "plot": directives.unchanged, "log": directives.unchanged,
                   "title": directives.unchanged, "each": directives.unchanged, "label": directives.unchanged}

    def generate(self):
        name = self.arguments[0]
        d = case_dir(name)
        self.env.note_dependency(str(d / "results.json"))
        data, source = load_case(name)
        lines = [provenance_line(name, data, source), "",
                 f"Verdict of the case's own criteria: **{verdict(data)}**.", ""]
        if "plot" in self.options:
            png = plot_case(name, data, self.options["plot"], self.options.get("log", ""), self.options.get("title", ""))
            rel = os.path.relpath(png, DOCS).replace(os.sep, "/")
            lines += [f"```{{image}} /{rel}", f":alt: {name}", "```", ""]
        keys = [k.strip() for k in self.options.get("keys", "").split(",") if k.strip()]
        if "each" in self.options:
            if not keys:
                raise ValueError(":each: needs :keys: (the sub-paths that make the columns)")
            specs = [key_spec(k) for k in keys]
            try:
                rows = each_rows(data, self.options["each"], specs, self.options.get("label"))
            except (KeyError, IndexError, TypeError) as exc:
                raise MissingResults(f"case {name!r}: no entry {self.options['each']!r} in results.json ({exc})")
            first = self.options.get("label")
            header = [f"`{first}`" + (f" [{unit_of(first)}]" if unit_of(first) else "") if first
                      else f"`{self.options['each']}`"] + [f"`{p}`" + (f" [{u}]" if u else "") for p, u in specs]
            return self.emit(lines + table_lines(rows, header))
        keys = [key_spec(k)[0] for k in keys]
        rows = [(p, v) for p, v in flatten(data) if not keys or match_key(p, keys)]
        shown = rows[:MAX_ROWS]
        with_units = any(unit_of(p) for p, _ in shown)
        lines += table_lines([(f"`{p}`", fmt(v)) + ((unit_of(p),) if with_units else ()) for p, v in shown],
                             ["key in results.json", "value"] + (["unit (from the key's name)"] if with_units else []))
        if len(rows) > len(shown):
            lines += ["", f"{len(rows) - len(shown)} more scalar entries are in the case's results.json."]
        return self.emit(lines)


class ResultsIndex(_MarkdownDirective):
    """``results-index FOLDER``: one row per committed case under docs/case_results/FOLDER."""
    required_arguments = 1

    def generate(self):
        folder = RESULTS / self.arguments[0]
        rows = []
        for res in sorted(folder.glob("*/results.json")):
            name = res.parent.name
            self.env.note_dependency(str(res))
            data, source = load_case(name)
            prov = data.get("provenance", {})
            wall = prov.get("wall_s_total")
            rows.append([f"`{name}`", verdict(data), f"`{source.get('mode', '?')}`",
                         f"{wall:.3g}" if isinstance(wall, (int, float)) else "\u2014",
                         str(source.get("host", "?")), f"`{source.get('commit', '?')}`", str(source.get("date", "?"))])
        if not rows:
            return self.emit([f"No committed results under `docs/case_results/{self.arguments[0]}/` yet."])
        header = ["case", "verdict (its own criteria)", "run", "wall [s]", "host", "commit", "date"]
        hosts = {r[4] for r in rows}
        lines = []
        if len(hosts) == 1:          # one host for every run: said once, not in every row
            lines = [f"Every run below was made on: {hosts.pop()}.", ""]
            header.pop(4)
            for r in rows:
                r.pop(4)
        return self.emit(lines + table_lines(rows, header))


class AnalysisFigures(_MarkdownDirective):
    """``analysis-figures CASE``: per protocol of a committed ``rvtool analyze`` results.json, its
    summary and a table of its figures (name, meaning, unit, value of that run, error and what the
    error is measured against); ``:level:`` is the heading level of the protocol names (default 2)."""
    required_arguments = 1
    option_spec = {"level": directives.positive_int}

    def generate(self):
        name = self.arguments[0]
        self.env.note_dependency(str(case_dir(name) / "results.json"))
        data, source = load_case(name)
        lines = [provenance_line(name, data, source), ""]
        for proto in [k for k, v in data.items() if isinstance(v, dict) and "figures" in v and "status" in v]:
            r = data[proto]
            lines += ["#" * self.options.get("level", 2) + f" `{proto}`", "", fmt(r.get("summary", "")) + f" (status in that run: {r['status']}"
                      + (f": {fmt(r['reason'])}" if r.get("reason") else "") + ")", ""]
            if r["figures"]:
                rows = [(f"`{k}`", fmt(f.get("description", "")), fmt(f.get("unit", "")), fmt(f.get("value")),
                         fmt(f.get("error")) + (f" {fmt(f.get('error_unit'))}" if f.get("error") is not None else ""),
                         fmt(f.get("error_statement") or "not stated"))
                        for k, f in r["figures"].items()]
                lines += table_lines(rows, ["figure", "what it is", "unit", "value (that run)", "error",
                                            "error measured against"]) + [""]
        return self.emit(lines)


# -- docstrings ----------------------------------------------------------------------------------

_FIELD = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:, [A-Za-z_][A-Za-z0-9_]*)*): \S")
_PIPE = re.compile(r"(?<!\\)\|")


def plain_docstring(lines):
    """rvtool's docstrings list keys as ``name: meaning [unit]`` with indented continuation lines
    (the style guide's dataclass convention), which reStructuredText reads as broken block
    quotes. For the API pages: such lines become bullets, an indented continuation joins its line,
    and ``|x|`` (absolute values, not substitutions) is escaped. Literal blocks (after ``::``) and
    directives are left as they are. The source is not changed."""
    out, literal_indent, in_list = [], None, False
    for raw in lines:
        line = raw.rstrip()
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None:
            if line and indent <= literal_indent:
                literal_indent = None
            else:
                out.append(line)
                continue
        if not line:
            out.append(line)
            in_list = False
            continue
        prev = next((l for l in reversed(out) if l.strip()), None)
        prev_blank = not out or not out[-1].strip()
        text = line if "``" in line else _PIPE.sub(r"\\|", line)
        if "``" in line:
            parts = line.split("``")
            text = "``".join(p if i % 2 else _PIPE.sub(r"\\|", p) for i, p in enumerate(parts))
        if indent == 0 and _FIELD.match(line):
            if not in_list and not prev_blank:
                out.append("")
            out.append("* " + text)
            in_list = True
        elif indent > 0 and prev is not None and not prev_blank and not prev.rstrip().endswith("::") \
                and not prev.lstrip().startswith(".. "):
            out[-1] = out[-1] + " " + text.strip()
        else:
            if in_list and indent == 0:
                out.append("")
                in_list = False
            out.append(text)
        if line.endswith("::") or line.lstrip().startswith(".. "):
            literal_indent = indent
    return out


def _process_docstring(app, what, name, obj, options, lines):
    lines[:] = plain_docstring(lines)


# -- generated pages --------------------------------------------------------------------------------

def _source_read(app, docname, source):
    if docname == "reference/design_format":
        from rvtool.designs.format import format_doc
        source[0] = ("% generated at build time from rvtool/designs/format.py; the committed page is a stub\n"
                     + format_doc())
    elif docname == "changelog":
        frags = sorted((DOCS / "changelog.d").glob("*.md"))
        text = "\n\n".join(f"### from `{f.stem}`\n\n" + f.read_text().strip() for f in frags)
        source[0] = source[0].replace("<!-- changelog.d fragments -->", text or "(no fragments)")


def setup(app):
    app.add_directive("case-results", CaseResults)
    app.add_directive("results-index", ResultsIndex)
    app.add_directive("analysis-figures", AnalysisFigures)
    app.connect("source-read", _source_read)
    app.connect("autodoc-process-docstring", _process_docstring)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
