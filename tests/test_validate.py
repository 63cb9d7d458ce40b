"""`rvtool validate` (rvtool/analysis/validate.py): the table's verdicts follow the catalogue's kinds,
the ratio variant keeps the frame, the CLI's input errors, and one quick end-to-end run on rv40e
(no assumed ranges: no band) with its files."""
import json
import math
import os

import pytest

import rvtool
from rvtool import designs
from rvtool.analysis import validate as V
from rvtool.assembly.topologies import read_table
from rvtool.cli import main
from rvtool.designs.catalogue import Catalogue, CatalogueFigure, CatalogueSource, CatalogueTest
from rvtool.units import RAD_PER_ARCMIN


def _cat(*figs):
    test = CatalogueTest(rated_torque=400.0, rated_output_speed=math.pi / 2, rated_output_speed_rpm=15.0,
                         rated_life_h=6000.0, lost_motion_torque_fraction=0.03, rigidity_torque_points=None)
    return Catalogue(design="toy", source=CatalogueSource(title="T", edition="E"), test=test, figures=tuple(figs),
                     path="toy_catalogue.toml")


def _fig(key, value, unit, kind, **kw):
    from rvtool.designs.catalogue import UNITS
    return CatalogueFigure(key=key, value=value, unit=unit, value_si=value * UNITS[unit], page="p. 1", conditions="c",
                           kind=kind, **kw)


def test_rows_follow_the_catalogue_kinds():
    cat = _cat(_fig("lost_motion", 1.0, "arcmin", "max"),
               _fig("lost_motion", 0.45, "arcmin", "typical", low=0.3, high=0.6, status="read"),
               _fig("torsional_rigidity", 6000.0, "N m/rad", "typical", status="not_reread"),
               _fig("rated_life", 6000.0, "h", "typical"))
    r = V._rows("lost_motion", 0.7, "arcmin", cat)
    assert [x["verdict"] for x in r] == ["within max", "+55.6 % vs typical; outside the printed range"]
    assert V._rows("lost_motion", 1.2, "arcmin", cat)[0]["verdict"] == "above max"
    # units go through SI: 6000 N m/rad is 6000 x RAD_PER_ARCMIN N m/arcmin
    k = V._rows("torsional_rigidity", 2.0, "N m/arcmin", cat, band=(1.0, 2.0))[0]
    assert k["catalogue"] == pytest.approx(6000.0 * RAD_PER_ARCMIN, rel=1e-12)
    assert "catalogue in band" in k["verdict"] and "not re-read" in k["verdict"]
    assert V._rows("rated_life", 5000.0, "h", cat)[0]["verdict"] == "short"
    assert V._rows("hysteresis_loss", 0.3, "arcmin", cat)[0]["verdict"] == "no figure"
    assert V.rigidity_points(cat)[0] == V.DEFAULT_RIGIDITY_POINTS and "NOT the catalogue" in V.rigidity_points(cat)[1]


def test_ratio_variant_keeps_the_frame():
    t = read_table(designs.path("rv40e"))
    t2, ratio = V.ratio_variant(t)
    assert (t2["sun_gear"]["n_teeth"], t2["crank_gear"]["n_teeth"]) == (24, 48)
    assert ratio == 81.0 and t2["ratio_target"] == 81.0 and t2["pins"] == t["pins"]
    assert t["sun_gear"]["n_teeth"] == 18                 # the original table is untouched


def test_cli_unknown_design_is_a_usage_error(capsys, tmp_path):
    assert main(["validate", "rd40", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rvtool: error:") and "no catalogue file" in err and "rv80e" in err
    assert not os.listdir(tmp_path)
    assert main(["validate", "rv40e", "--samples", "1", "--out", str(tmp_path)]) == 2


def test_quick_validate_rv40e_end_to_end(tmp_path):
    # members=False: the all-members-on row (nested elastic members) is tested by tests/test_validate_members.py
    # and computed by cases/rv/validate_rv.py; here it would add minutes of nested closure solves
    out = V.validate("rv40e", quick=True, out_dir=str(tmp_path), members=False, log=lambda *a: None)
    c = V.checks(out)
    assert c == {"no_nan": True, "loops_repeat": True}            # rv40e ships no assumed ranges: no band
    assert out["uncertainty"] is None and "no rv40e_assumed.toml" in out["uncertainty_note"]
    keys = [r["figure"] for r in out["table"]]
    assert {"torsional_rigidity", "lost_motion", "hysteresis_loss", "rated_life"} <= set(keys)
    for r in out["table"]:
        assert r["source"] and (r["catalogue"] is None or "Nabtesco" in r["source"] or "catalogue" in r["source"])
    assert out["central"]["repeat_arcmin"] < V.REPEAT_TOLERANCE_ARCMIN
    assert len(out["assumptions_commit"]) == 40
    assert abs(out["ratio_variant"]["rel_diff"]) < 0.05          # one rigidity per frame (measured +0.57 %)
    # issue 30: the file keeps the rigid carrier; the ported carrier's share is the side figure of the budget
    pc = out["compliance_budget"]["with_ported_carrier"]
    assert out["compliance_budget"]["configuration"]["carrier.body"] == "rigid" and "carrier" not in \
        out["compliance_budget"]["shares"]
    assert 0.05 < pc["carrier_share"] < 0.9 and pc["K_t_Nm_per_arcmin"] < out["compliance_budget"]["K_t_Nm_per_arcmin"]
    for f in ("results.json", "report.html", "hysteresis.png"):
        assert os.path.isfile(tmp_path / f), f
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["table"][0]["figure"] == "torsional_rigidity"
    assert "data:image/png;base64," in (tmp_path / "report.html").read_text()


def test_band_tornado_and_fraction_on_rv40e_with_test_ranges(tmp_path, monkeypatch):
    """The uncertainty machinery on rv40e with two assumed ranges written here (the class design ships
    none): the band holds the central value, the tornado's keys come from the screening, and the
    needle clearance -- rv40e's free play -- moves the lost motion most."""
    ranges = tmp_path / "rv40e_assumed.toml"
    ranges.write_text('format_version = 2\ndesign = "rv40e"\n'
                      '[[assumed]]\nkey = "eccentric_bearing.radial_clearance"\nlow = 0.0\nhigh = 3.0e-6\nunit = "m"\n'
                      'source = "test range: rv40e_tolerances.toml needle_clearance [0, 3] um"\n'
                      '[[assumed]]\nkey = "bodies.carrier_mass"\nlow = 2.0\nhigh = 4.0\nunit = "kg"\n'
                      'source = "test range: a static figure must not move with a mass"\n')
    monkeypatch.setattr(designs, "assumed_of", lambda name: str(ranges))
    out = V.validate("rv40e", quick=True, samples=4, tornado_keys=1, members=False, log=lambda *a: None)
    c = V.checks(out)
    assert c["no_failed_sample"] and c["band_contains_central"], c
    u = out["uncertainty"]
    assert u["samples"] == 4 and len(u["figures"]) == 4
    assert list(u["tornado"]) == ["eccentric_bearing.radial_clearance"]
    t = u["tornado"]["eccentric_bearing.radial_clearance"]
    assert t["at_high"]["lost_motion"] > out["central"]["lost_motion"] > t["at_low"]["lost_motion"]
    assert 0.0 <= u["fraction_within_lost_motion_max"] <= 1.0
    lo, hi = u["band"]["lost_motion"]
    assert lo < out["central"]["lost_motion"] < hi


def test_budget_columns_show_every_member(tmp_path):
    """report.html / budget.png carry every budget the result has: the file's, the ported carrier's and the one
    with every member on (issue 30: validate shows every member's share)."""
    out = {"design": "x", "compliance_budget": {
        "shares": {"pins": 0.6, "eccentric_bearings": 0.4}, "K_t_Nm_per_arcmin": 500.0,
        "with_ported_carrier": {"shares": {"carrier": 0.5, "pins": 0.5}, "K_t_Nm_per_arcmin": 300.0},
        "all_members_on": {"shares": {"carrier": 0.4, "wheel_bodies": 0.1, "pin_grooves": 0.5},
                           "K_t_Nm_per_arcmin": 200.0}}}
    cols = V.budget_columns(out)
    assert len(cols) == 3 and list(cols.values())[2]["wheel_bodies"] == 0.1
    assert V.budget_plot(out, str(tmp_path)) == ["budget.png"] and (tmp_path / "budget.png").stat().st_size > 0
    out["compliance_budget"]["all_members_on"] = None
    assert len(V.budget_columns(out)) == 2


def test_te_comparison_reused_only_by_inputs_digest(tmp_path):
    """A te_measured results.json is taken only where its inputs digest equals this comparison's (the design,
    tolerance and measurement files, variants, resolution, torque, seed, run length) and its run is complete; any
    other is passed over. (On a shortened grid, 0.2 input revolutions and one variant, so that a miss would cost
    seconds, not the output revolution.)"""
    from rvtool.analysis import te_revolution as TR
    from rvtool.analysis import validate_te as VT
    d = rvtool.load_design("rv80e")
    dg = TR.revolution_inputs_digest("rv80e", d, d.rated_torque, variants=1, input_revolutions=0.2)
    good, bad, partial = tmp_path / "good.json", tmp_path / "bad.json", tmp_path / "partial.json"
    good.write_text(json.dumps({"rows": ["row"], "settings": {"inputs_digest": dg}, "n_failed": 0,
                                "complete": True}))
    bad.write_text(json.dumps({"rows": ["other"], "settings": {"inputs_digest": "0" * 64}}))
    partial.write_text(json.dumps({"rows": ["partial"], "settings": {"inputs_digest": dg}, "complete": False}))
    te = VT.te_comparison("rv80e", d, d.rated_torque, quick=False, variants=1, input_revolutions=0.2,
                          reuse=[str(tmp_path / "missing.json"), str(bad), str(partial), str(good)],
                          log=lambda *a: None)
    assert te["rows"] == ["row"] and te["reused_from"]["path"] == str(good)
    window = VT.te_inputs_digest(d, designs.path("rv80e_tolerances"), designs.path("rv80e_measured"), n=1,
                                 points_per_mesh=TR.RESOLUTION_PPM[0], torque=VT.TE_TORQUE_FRACTION * d.rated_torque)
    assert len({dg, window, TR.revolution_inputs_digest("rv80e", d, d.rated_torque, variants=1),
                TR.revolution_inputs_digest("rv80e", d, d.rated_torque, variants=2, input_revolutions=0.2)}) == 4
