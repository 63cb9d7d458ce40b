"""report.html opens with a datasheet summary: the figures a review checks first, in words, with
units, errors, the design's allowables and pass/fail (rvtool.analysis.summary)."""
import json
import re

import pytest

from rvtool.analysis import analyze
from rvtool.analysis.report import render
from rvtool.analysis.summary import allowables_record, find_allowables, summary_rows
from rvtool import designs


def _fig(value, unit, error=None, error_unit=None, statement=""):
    return {"value": value, "unit": unit, "description": "", "error": error, "error_unit": error_unit or unit,
            "error_statement": statement}


def _data(allowables):
    ok = {"status": "ok", "summary": "", "reason": "", "warnings": [], "plots": [], "settings": {}, "wall_s": 0.0}
    return {
        "design": "X", "topology": "cycloid", "design_source": "x.toml", "quick": True, "warnings": [],
        "protocols": ["te", "stiffness", "lost_motion", "hysteresis"],
        "te": {**ok, "figures": {"te_pp": _fig(4.0, "arcsec", 0.01), "ratio": _fig(-39.0, "-"),
                                 "peak_load_pins": _fig(230.0, "N")},
               "data": {"hertz_peaks_at_rated_Pa": {"pins": 2.6e9, "output_pins": 1.0e9}},
               "settings": {"torque_Nm": 140.0}},
        "stiffness": {**ok, "figures": {"K_pos_loading": _fig(90.0, "N m/arcmin", 0.02, "-"),
                                        "Kt_condensed": _fig(120.0, "N m/arcmin", 1e-7, "-")}, "data": {}},
        "lost_motion": {**ok, "figures": {"lost_motion": _fig(0.5, "arcmin", 1e-9)}, "data": {}},
        "hysteresis": {**ok, "status": "failed", "reason": "SolverFailure: stalled", "figures": {}, "data": {}},
        "allowables": allowables, "provenance": {"device": {"device": "cpu"}},
    }


RD40_ALLOWABLES = allowables_record(designs.path("rd40_allowables"))


def _row(rows, start):
    hits = [r for r in rows if r.quantity.startswith(start)]
    assert len(hits) == 1, (start, [r.quantity for r in rows])
    return hits[0]


def test_rows_judge_against_allowables():
    rows = summary_rows(_data(RD40_ALLOWABLES))
    # rd40_allowables.toml: stiffness >= 100 N m/arcmin, lost motion <= 1 arcmin, pins <= 2.5 GPa,
    # output pins <= 2.5 GPa; TE and contact loads have no allowable there
    k = _row(rows, "Torsional rigidity, secant")
    assert (k.verdict, k.unit, k.allowable) == ("FAIL", "N m/arcmin", "\u2265 100 N m/arcmin")
    assert k.error == "2 % (relative)"
    assert _row(rows, "Lost motion").verdict == "pass"
    assert _row(rows, "Peak Hertz pressure at rated torque, ring pins").verdict == "FAIL"    # 2600 > 2500 MPa
    assert _row(rows, "Peak Hertz pressure at rated torque, output pins").verdict == "pass"
    assert _row(rows, "Transmission error").verdict == "no allowable"
    assert _row(rows, "Peak contact-row force (largest slice or lamina), ring pins").verdict == "no allowable"
    hy = _row(rows, "Hysteresis")
    assert hy.verdict == "not computed" and "failed" in hy.note and hy.allowable == "\u2264 1 arcmin"
    life = _row(rows, "Bearing rating life")
    assert life.verdict == "not computed" and life.allowable == "\u2265 6000 h"


def test_missing_pressures_are_said_not_left_out():
    data = _data(RD40_ALLOWABLES)
    data["te"]["data"]["hertz_peaks_at_rated_Pa"] = {}
    data["pressure"] = {"status": "skipped", "reason": "main mesh is 'involute_stage'", "summary": "",
                        "figures": {}, "data": {}}
    row = _row(summary_rows(data), "Peak contact pressure, main mesh")
    assert row.verdict == "not computed" and "involute_stage" in row.note and "no Hertz peaks" in row.note


def test_rows_without_allowables_say_so():
    rows = summary_rows(_data({"source": None, "values": None}))
    judged = [r for r in rows if r.value is not None]
    assert judged and all(r.verdict == "no allowable" for r in judged)
    html = render(_data({"source": None, "values": None}), ".")
    assert "none declared for this design" in html and "no allowable" in html


def test_allowables_are_found_beside_the_design(tmp_path):
    assert find_allowables("whatever", "rd40").endswith("rd40_allowables.toml")
    assert find_allowables("whatever", "rv40e") is None
    design = tmp_path / "mine.toml"
    design.write_text("")
    assert find_allowables(str(design)) is None
    (tmp_path / "mine_allowables.toml").write_text("")
    assert find_allowables(str(design)) == str(tmp_path / "mine_allowables.toml")


@pytest.fixture(scope="module")
def rd40_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    res = analyze("rd40", "te,stiffness,lost_motion", quick=True, out_dir=str(out))
    return res, out


def test_report_opens_with_the_summary(rd40_report):
    res, out = rd40_report
    html = (out / "report.html").read_text()
    data = json.loads((out / "results.json").read_text())
    assert data["allowables"]["source"].endswith("rd40_allowables.toml")
    # the summary comes before the details, and names the figures in words with units
    i_sum, i_det = html.index('id="summary"'), html.index('id="details"')
    assert i_sum < i_det < html.index('id="te"')
    summary = html[i_sum:i_det]
    for words in ("Transmission error, peak-to-peak", "Torsional rigidity, secant", "Lost motion at +-3 %",
                  "Hysteresis loss", "Peak contact-row force (largest slice or lamina), ring pins", "Peak Hertz pressure at rated torque, ring pins",
                  "Bearing rating life", "arcsec", "N m/arcmin", "arcmin", "MPa", "\u2265 100 N m/arcmin"):
        assert words in summary, words
    # the stiffness row shows the figure of results.json and its verdict against 100 N m/arcmin
    k = data["stiffness"]["figures"]["K_pos_loading"]["value"]
    row = re.search(r"Torsional rigidity, secant.*?</tr>", summary, re.S).group(0)
    assert f"{k:.4g}" in row
    assert ("pass" if k >= 100.0 else "FAIL") in row
    # hysteresis was not run: said so, not left blank
    assert "protocol hysteresis was not run" in summary


def test_quick_te_resolves_the_mesh_ripple(rd40_report):
    res, _ = rd40_report
    # >= 10 points per mesh cycle: the mesh-order ripple and its second harmonic are sampled above
    # Nyquist (the 4 points of before drew the rv40e ripple as a jagged polygon)
    assert res["te"].settings["points_per_mesh_cycle"] >= 10
    assert "hertz_peaks_at_rated_Pa" in res["te"].data and res["te"].data["hertz_peaks_at_rated_Pa"]["pins"] > 0
