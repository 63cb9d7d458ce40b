"""The documentation builds with warnings as errors, and its generated parts are there.

The build (``python -m sphinx -W -b html docs OUT``) reads the committed results under
docs/case_results/ and never reruns a study; it takes ~10-25 s on a shared 2-core machine.
"""
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx", reason="the docs need the 'docs' or 'test' extra (sphinx, myst-parser)")
pytest.importorskip("myst_parser", reason="the docs need the 'docs' or 'test' extra (sphinx, myst-parser)")

pytestmark = pytest.mark.xdist_group("docs")
"""Under pytest-xdist (``-n``, ``--dist=loadgroup`` in setup.cfg) every docs test runs on one worker: one
Sphinx build, and no two builds writing the same generated figures in docs/_generated at once."""

ROOT = Path(__file__).resolve().parents[1]
BUILD_TIMEOUT_S = 240
"""Generous against a loaded CI machine; a quiet 2-core machine builds in ~10 s."""


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("docs")
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(out / "doctrees"), str(ROOT / "docs"), str(out / "html")],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=BUILD_TIMEOUT_S)
    assert proc.returncode == 0, f"sphinx-build -W failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-6000:]}"
    return out / "html"


def _text(html_path):
    """The page's text: tags removed (inline markup joins its words as a reader sees them)."""
    import html
    text = re.sub(r"<[^>]+>", "", html_path.read_text(encoding="utf-8"))
    return re.sub(r"\s+", " ", html.unescape(text))


def test_docs_build_without_warnings(site):
    for page in ("index", "install", "getting_started", "guide/cycloid", "guide/rv", "guide/std_involute",
                 "reference/design_format", "protocols/index", "protocols/figures", "validation/index",
                 "benchmarks/index", "api/rvtool", "changelog", "history/index"):
        assert (site / f"{page}.html").is_file(), f"page {page} missing"


def test_design_format_is_generated_at_build(site):
    from rvtool.designs.format import format_doc
    text = _text(site / "reference" / "design_format.html")
    assert "replaced at build time" not in text, "the stub was not replaced by the generator"
    # every section heading of the generator's output is on the page
    for sec in re.findall(r"^### `\[([a-z_.]+)\]`", format_doc(), re.M)[:40]:
        assert f"[{sec}]" in text, f"section [{sec}] of the format doc missing from the page"


def test_api_reference_documents_the_public_entry_points(site):
    text = _text(site / "api" / "rvtool.html")
    for name in ("load_design", "build", "analyze"):
        assert f"rvtool.{name}" in text
    assert "ReducerModel" in _text(site / "api" / "model.html")


def test_results_pages_are_generated_from_committed_results(site):
    committed = sorted(p.parent.name for p in (ROOT / "docs" / "case_results").glob("verification/*/results.json"))
    assert committed, "no committed verification results"
    index = _text(site / "validation" / "index.html")
    for case in committed:
        assert case in index, f"{case} has committed results but no row on the verification page"
    # a value of the committed file appears on the generated figures page, with its error statement
    data = json.loads((ROOT / "docs/case_results/analyze/analyze_rd40/results.json").read_text())
    te = data["te"]["figures"]["te_pp"]
    figures = _text(site / "protocols" / "figures.html")
    assert f"{te['value']:.4g}" in figures and "te_pp" in figures
    assert te["error_statement"].split(";")[0][:40] in figures


def test_changelog_includes_every_fragment(site):
    text = _text(site / "changelog.html")
    for frag in (ROOT / "docs" / "changelog.d").glob("*.md"):
        assert f"from {frag.stem}" in text, f"fragment {frag.name} not in the changelog"


def test_readme_fits_on_a_screen_and_links_the_docs():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 200
    for cmd in ("pip install", "pytest", "rvtool analyze", "rvtool new"):
        assert cmd in readme
    for img in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", readme):
        assert (ROOT / img).is_file(), f"README picture {img} is not committed"
    links = [t for t in re.findall(r"\]\(([^)#]+)\)", readme) if not t.startswith("http")]
    assert links, "the README links into the docs"
    for target in links:
        assert (ROOT / target).exists(), f"README links to {target}, which does not exist"


def _ext():
    import importlib.util
    spec = importlib.util.spec_from_file_location("rvtool_docs_ext", ROOT / "docs" / "_ext" / "rvtool_docs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_units_are_read_from_key_names():
    ext = _ext()
    cases = {"L10_h": "h", "K_t_Nm_per_arcmin": "N m/arcmin", "designs/rv40e/p0_MPa": "MPa",
             "variants_per_s": "1/s", "wall_s": "s", "us_per_roller": "\u00b5s/roller", "axial_N_per_m": "N/m",
             "added_compliance_arcmin_per_Nm": "arcmin/(N m)", "lost_motion": "", "passed": "", "tilt_deg": "deg",
             "band/tornado/main_bearing.row.contact_angle_deg": "",     # a design key naming a row, not a unit
             "loss_by_family_W/pins": "W", "us_per_roller/needle_planar/laminae": "\u00b5s/roller",
             "law/curve/0.01/psi": ""}
    for key, unit in cases.items():
        assert ext.unit_of(key) == unit, key
    assert ext.key_spec("central/torsional_rigidity [N m/arcmin]") == ("central/torsional_rigidity", "N m/arcmin")
    assert ext.key_spec(" central/lost_motion_arcmin ") == ("central/lost_motion_arcmin", "arcmin")


def test_each_table_and_star_keys_select_from_nested_results():
    ext = _ext()
    data = {"designs": {"a": {"c": {"k_Nm": 1.0}, "life_h": 2.0}, "b": {"c": {"k_Nm": 3.5}}},
            "runs": [{"name": "x", "v": 1}, {"name": "y", "v": 2}]}
    rows = ext.each_rows(data, "designs", [("c/k_Nm", "N m"), ("life_h", "h")])
    assert rows == [["`a`", "1", "2"], ["`b`", "3.5", "\u2014"]]      # missing entry: a dash, not an error
    assert ext.each_rows(data, "runs", [("v", "")], label="name") == [["x", "1"], ["y", "2"]]
    paths = [p for p, _ in ext.flatten(data) if ext.match_key(p, ["designs/*/c"])]
    assert paths == ["designs/a/c/k_Nm", "designs/b/c/k_Nm"]
    assert not ext.match_key("designs/a/life_h", ["designs/*/c"])


_TABLE_NUMBER = re.compile(r"(?<![\w.])(\d+\.\d+(?:e[-+]?\d+)?|\d+e[-+]?\d+)(?![\w.])")
_CITATION_YEAR = re.compile(r"\b(19|20)\d\d\b")


def _printed_results():
    """Every float of the committed results as ``case-results`` prints it (scalars, short lists)."""
    ext = _ext()
    printed = set()
    for f in (ROOT / "docs" / "case_results").glob("*/*/results.json"):
        for _, v in ext.flatten(json.loads(f.read_text())):
            for x in (v if isinstance(v, list) else [v]):
                if isinstance(x, float) and x == x and abs(x) not in (0.0, float("inf")):
                    printed.add(ext.fmt(abs(x)))
    return printed


def _hand_copies(docs, printed):
    hits = []
    for page in sorted(docs.rglob("*.md")):
        rel = page.relative_to(docs).as_posix()
        if rel.startswith(("history/", "changelog", "case_results/", "_generated/")):
            continue
        for n, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            if not line.lstrip().startswith("|") or _CITATION_YEAR.search(line):
                continue
            for num in _TABLE_NUMBER.findall(line.replace(",", "")):
                digits = num.split("e")[0].replace(".", "").lstrip("0")
                if len(digits) >= 3 and num in printed:
                    hits.append(f"docs/{rel}:{n}: {num}")
    return hits


def test_no_table_on_a_page_copies_a_committed_result_by_hand():
    """A table row typed on a page (not generated) that holds a number exactly as ``case-results``
    prints a scalar of a committed results.json (4 significant digits) is a hand copy: it goes stale
    when the run is redone. Numbers of fewer than 3 significant digits (bounds, settings such as
    1e-6 or 0.05) are not looked at, nor rows citing a dated source (an input with its reference,
    e.g. "Palmgren 1959"). History and changelog pages keep what was measured then. A random
    3-digit input collides with a committed value with a chance of a few per cent: cite its source."""
    printed = _printed_results()
    assert printed, "no committed results to compare with"
    hits = _hand_copies(ROOT / "docs", printed)
    assert not hits, ("measured figures typed into tables; generate them with ```{case-results}``` "
                      "(or cite the input's source in the row): " + ", ".join(hits))


def test_table_copy_check_can_fail(tmp_path):
    """The check finds a hand copy of a committed value; it leaves bounds, cited inputs and history alone."""
    ext = _ext()
    data = json.loads((ROOT / "docs/case_results/rv/validate_rv/results.json").read_text())
    value = ext.fmt(data["designs"]["rv40e"]["central"]["torsional_rigidity"])
    (tmp_path / "validation").mkdir()
    (tmp_path / "history").mkdir()
    (tmp_path / "validation" / "page.md").write_text(
        f"| figure | value |\n|---|---|\n| rigidity | {value} (+402 %) |\n| bound | 1e-6 |\n"
        f"| cited | {value} (Someone 2021) |\n")
    (tmp_path / "history" / "old.md").write_text(f"| rigidity | {value} |\n")
    assert _hand_copies(tmp_path, _printed_results()) == [f"docs/validation/page.md:3: {value}"]
