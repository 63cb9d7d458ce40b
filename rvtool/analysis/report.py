"""One self-contained ``report.html`` from an analysis' results.json dict, laid out as an
engineer's datasheet: the design line, then the **summary** of the figures a review checks
first (:func:`rvtool.analysis.summary.summary_rows`: TE, torsional rigidity, lost motion,
hysteresis, peak contact loads and pressures, bearing lives -- in words, with units, errors,
the design's allowables and pass/fail), the warnings, then the **details**: a section per
protocol (status, figures with units, their errors and references, settings, warnings, plots
embedded as base64 PNG), then the provenance. No script, no stylesheet or
font from the network: the file opens offline and archives as one file."""
import base64
import html
import json
import os

_CSS = """
body{font-family:sans-serif;margin:2em auto;max-width:1100px;color:#222;background:#fff}
h1{border-bottom:2px solid #345}h2{margin-top:2em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;vertical-align:top}
th{background:#eef}.ok{color:#070}
table.summary{width:100%}table.summary td:first-child{width:36%}
table.summary td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
.pass{color:#070;font-weight:bold}.FAIL{color:#fff;background:#b00;font-weight:bold}
.noallow,.notcomp{color:#666}.src{color:#777;font-size:85%}
.design{font-size:95%;color:#333}.failed{color:#b00;font-weight:bold}.skipped{color:#777}
.warn{background:#fff4d6;border-left:4px solid #e0a000;padding:4px 8px;margin:4px 0}
img{max-width:100%;border:1px solid #ddd;margin:6px 0}pre{background:#f6f6f6;padding:6px;overflow-x:auto;font-size:85%}
"""


def _e(x):
    return html.escape(str(x))


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list) and len(v) > 8:
        return f"[{', '.join(_fmt(x) for x in v[:8])}, ... ({len(v)} values)]"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return "\u2014" if v is None else str(v)


def _img(path, alt):
    with open(path, "rb") as fh:
        b64 = base64.b64encode(fh.read()).decode("ascii")
    return f'<img alt="{_e(alt)}" src="data:image/png;base64,{b64}">'


def _section(name, r, out_dir):
    parts = [f'<h3 id="{_e(name)}">{_e(name)} <span class="{_e(r["status"])}">[{_e(r["status"])}]</span></h3>',
             f"<p>{_e(r['summary'])}</p>"]
    if r["reason"]:
        parts.append(f'<p class="warn">{_e(r["reason"])}</p>')
    if r["figures"]:
        rows = "".join(f"<tr><td>{_e(k)}</td><td>{_e(_fmt(f['value']))}</td><td>{_e(f['unit'])}</td>"
                       f"<td>{_e(_fmt(f['error']))} {_e(f['error_unit']) if f['error'] is not None else ''}</td>"
                       f"<td>{_e(f['error_statement'])}</td><td>{_e(f['description'])}</td></tr>"
                       for k, f in r["figures"].items())
        parts.append("<table><tr><th>figure</th><th>value</th><th>unit</th><th>error</th>"
                     f"<th>error against (reference)</th><th>what it is</th></tr>{rows}</table>")
    for w in r["warnings"]:
        parts.append(f'<p class="warn">warning: {_e(w)}</p>')
    for p in r["plots"]:
        path = os.path.join(out_dir, p)
        if os.path.isfile(path):
            parts.append(_img(path, f"{name}: {p}"))
    if r["settings"]:
        parts.append(f"<details><summary>settings</summary><pre>{_e(json.dumps(r['settings'], indent=1))}</pre></details>")
    parts.append(f"<p>wall time {r['wall_s']:.2f} s</p>")
    return "\n".join(parts)


_VERDICT_CLASS = {"pass": "pass", "FAIL": "FAIL", "no allowable": "noallow", "not computed": "notcomp"}


def _summary(data):
    from .summary import summary_rows
    rows = summary_rows(data)
    src = (data.get("allowables") or {}).get("source")
    allow_line = (f"Allowables: <code>{_e(os.path.basename(src))}</code> ({_e(src)})." if src else
                  "Allowables: none declared for this design (no <code>&lt;design&gt;_allowables.toml</code>): "
                  "every figure says \u201cno allowable\u201d.")
    n_fail = sum(r.verdict == "FAIL" for r in rows)
    n_pass = sum(r.verdict == "pass" for r in rows)
    body = "".join(
        f"<tr><td>{_e(r.quantity)}<div class=\"src\">{_e(r.source)}</div></td>"
        f"<td class=\"num\">{_e(_fmt4(r.value))}</td><td>{_e(r.unit)}</td><td>{_e(r.error)}</td>"
        f"<td class=\"num\">{_e(r.allowable)}</td>"
        f"<td><span class=\"{_VERDICT_CLASS.get(r.verdict, '')}\">{_e(r.verdict)}</span>"
        f"{'<div class=src>' + _e(r.note) + '</div>' if r.note else ''}</td></tr>"
        for r in rows)
    counts = f" {n_pass} pass, {n_fail} fail against the allowables." if src else ""
    return (f'<h2 id="summary">Summary</h2><p>{allow_line}{counts}</p>'
            '<table class="summary"><tr><th>quantity</th><th>value</th><th>unit</th><th>numerical error</th>'
            f"<th>allowable</th><th>verdict</th></tr>{body}</table>")


def _fmt4(v):
    if v is None:
        return "\u2014"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _design_line(data):
    te = data.get("te") if isinstance(data.get("te"), dict) else {}
    ratio = ((te.get("figures") or {}).get("ratio") or {}).get("value")
    torque = (te.get("settings") or {}).get("torque_Nm")
    prov = data.get("provenance", {})
    parts = [f"topology {_e(data['topology'])}"]
    if ratio is not None:
        parts.append(f"ratio {_e(_fmt4(ratio))}")
    if torque is not None:
        parts.append(f"rated torque {_e(_fmt4(torque))} N m")
    parts += [f"{'quick' if data['quick'] else 'full'} protocols", f"device {_e(prov['device']['device'])}",
              f"design file <code>{_e(data['design_source'])}</code>"]
    return '<p class="design">' + "; ".join(parts) + "</p>"


def render(data, out_dir):
    """HTML text of the report of results dict ``data`` (plots read from ``out_dir``)."""
    names = [k for k in data if isinstance(data[k], dict) and "status" in data[k] and "figures" in data[k]]
    toc = " &middot; ".join(f'<a href="#{_e(n)}">{_e(n)}</a> <span class="{_e(data[n]["status"])}">'
                            f'{_e(data[n]["status"])}</span>' for n in names)
    head = f"<h1>Datasheet: {_e(data['design'])}</h1>" + _design_line(data)
    warn = "".join(f'<p class="warn">{_e(w)}</p>' for w in data["warnings"]) or "<p>none</p>"
    body = [head, _summary(data), "<h2>Warnings</h2>", warn,
            f'<h2 id="details">Details, protocol by protocol</h2><p>{toc}</p>'] + [_section(n, data[n], out_dir)
                                                                                 for n in names]
    body.append(f"<h2 id=\"provenance\">Provenance</h2><pre>{_e(json.dumps(data['provenance'], indent=1))}</pre>")
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>rvtool datasheet: {_e(data['design'])}</title><style>{_CSS}</style></head><body>"
            + "\n".join(body) + "</body></html>\n")


def write_report(data, out_dir):
    """Write ``out_dir/report.html``; returns its path."""
    path = os.path.join(out_dir, "report.html")
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(render(data, out_dir))
    os.replace(tmp, path)
    return path
