"""`rvtool new` writes a tolerance file beside the design (helper tolnew, session 6): before, a design of
one's own had no Monte Carlo (``monte_carlo skipped ... no tolerance file``) until a tolerance file was
written by hand. The file's grades carry their source (ISO 286-1, ISO 1328-1:2013) or ``assumed``; `rvtool
analyze NAME.toml` reads ``NAME_tolerances.toml``; a bad key or value there stops with the file, the key and
its valid range before anything is written."""
import json
import math
import re
import tomllib

import pytest

from rvtool import cli
from rvtool.analysis import protocols
from rvtool.designs.tolerance_keys import CYCLOID_TOLERANCE_KEYS, RV_TOLERANCE_KEYS, STD_TOLERANCE_KEYS
from rvtool.designs.tolerance_template import (iso286_it4, iso1328_profile_slope, iso1328_runout, iso1328_single_pitch,
                                               tolerance_template)
from rvtool.errors import RvtoolInputError

KEYS = {"cycloid": CYCLOID_TOLERANCE_KEYS, "rv2": RV_TOLERANCE_KEYS, "rv3": RV_TOLERANCE_KEYS,
        "std-involute": STD_TOLERANCE_KEYS}


def _keys_and_comments(text):
    """{key: the comment block above it} of the file's active (uncommented) keys."""
    out, block = {}, []
    for line in text.splitlines():
        if line.startswith("#"):
            block.append(line[1:].strip())
        elif "=" in line:
            out[line.split("=")[0].strip()] = " ".join(block)
            block = []
        else:
            block = []
    return out


@pytest.mark.parametrize("topology", ["cycloid", "rv2", "rv3", "std-involute"])
def test_new_writes_a_tolerance_file_and_analyze_runs_its_monte_carlo(topology, tmp_path, monkeypatch, capsys):
    """For each template: `rvtool new` writes NAME_tolerances.toml; every drawn key's comment gives its
    grade's source or says assumed; `rvtool analyze NAME.toml --protocols monte_carlo --quick` finds it
    without --tolerances and a 2-variant Monte Carlo finishes with no failed variant and finite, positive
    TE p-p and lost motion (a grade in the wrong unit, um read as m, would fail every variant)."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["new", "--topology", topology, "--name", "mine"]) == 0
    assert "mine_tolerances.toml" in capsys.readouterr().out
    text = (tmp_path / "mine_tolerances.toml").read_text()
    drawn = _keys_and_comments(text)
    assert drawn and set(drawn) <= set(KEYS[topology]), drawn
    for key, comment in drawn.items():
        assert comment.startswith(("source: ISO", "assumed:")), (key, comment)
    assert set(tomllib.loads(text)["tolerances"]) == set(drawn)
    monkeypatch.setattr(protocols, "MC_DESIGN_VARIANTS", (2, 40))
    monkeypatch.setattr(protocols, "MC_CYCLOID_VARIANTS", (2, 200))
    assert cli.main(["analyze", "mine.toml", "--protocols", "monte_carlo", "--quick", "--quiet", "--out", "out"]) == 0
    mc = json.loads((tmp_path / "out" / "results.json").read_text())["monte_carlo"]
    assert mc["status"] == "ok", mc.get("reason")
    assert mc["settings"]["tolerances"].endswith("mine_tolerances.toml") and mc["settings"]["n_variants"] == 2
    assert mc["data"]["summary"]["n_failed"] == 0, mc["warnings"]
    for f in ("te_pp_mean", "lost_motion_mean"):
        v = mc["figures"][f]["value"]
        assert math.isfinite(v) and v > 0, (f, v)


@pytest.mark.parametrize("topology, key, bad, shown", [
    ("cycloid", "pin_clearance", '{ dist = "truncnormal", mean = 5e-6, std = 0.0, low = 1e-6, high = 1e-5 }',
     r"tolerances\.pin_clearance\.std = 0\.0 is outside the valid range \(0\.0, inf\)"),
    ("cycloid", "eccentricity_error", '{ dist = "normal", mean = -1e-3, std = 1e-6 }',
     r"tolerances\.eccentricity_error reaches -0\.001008 m; valid range \(-0\.0008, inf\) m"),
    ("rv2", "needle_clearance", '{ dist = "uniform", low = -1e-6, high = 2e-6 }',
     r"tolerances\.needle_clearance has support starting at -1e-06 m; valid range \[0, inf\) m"),
    ("rv3", "sun_pitch_deviation", '{ dist = "gauss", std = 1e-6 }',
     r"tolerances\.sun_pitch_deviation\.dist = 'gauss'; valid choices are \['fixed', 'normal'"),
    ("std-involute", "needle_clearance", '{ dist = "uniform", low = 3e-6 }',
     r"tolerances\.needle_clearance \(uniform\) is missing \['high'\]; required keys are \['high', 'low'\]$"),
    ("rv2", "crank_phase_error", '{ dist = "normal", mean = 0.0, std = "1 arcmin" }',
     r"tolerances\.crank_phase_error\.std = '1 arcmin' is not a number; valid: a finite number$"),
    ("std-involute", "pin_radius_error", '{ dist = "fixed", value = 0.0 }',
     r"\[tolerances\] has unknown keys \['pin_radius_error'\]; valid keys are \['eccentricity_error'"),
])
def test_a_bad_tolerance_names_the_file_key_and_range(topology, key, bad, shown, tmp_path, monkeypatch, capsys):
    """One bad input in the written file: `rvtool analyze` prints one error line naming the file, the key and
    its valid range, exits 2 and writes nothing (before, an RV or std-involute file's error only skipped the
    protocol, and a cycloid file's failed it, after the other protocols had run)."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["new", "--topology", topology, "--name", "mine"]) == 0
    p = tmp_path / "mine_tolerances.toml"
    lines = [ln for ln in p.read_text().splitlines() if not ln.startswith(f"{key} =")]
    p.write_text("\n".join(lines + [f"{key} = {bad}"]) + "\n")
    capsys.readouterr()
    assert cli.main(["analyze", "mine.toml", "--protocols", "monte_carlo,te", "--quick", "--out", "out"]) == cli.EXIT_USAGE
    err = capsys.readouterr().err
    assert re.match(rf"^rvtool: error: mine_tolerances\.toml: {shown}", err), err
    assert not (tmp_path / "out").exists()
    # the API stops with the same error
    from rvtool.analysis import analyze
    with pytest.raises(RvtoolInputError, match="mine_tolerances.toml"):
        analyze("mine.toml", "monte_carlo", quick=True)


def test_new_overwrites_no_tolerance_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine_tolerances.toml").write_text("# mine\n")
    assert cli.main(["new", "--topology", "cycloid", "--name", "mine"]) == cli.EXIT_USAGE
    assert "mine_tolerances.toml exists" in capsys.readouterr().err
    assert not (tmp_path / "mine.toml").exists() and (tmp_path / "mine_tolerances.toml").read_text() == "# mine\n"


def test_iso_grades_of_the_template():
    """ISO 1328-1:2013 eq. (5) with the 5.2.3 rounding, and ISO 286-1 Table 1 IT4, at hand-computed points:
    d = 18 mm, m = 1 mm: 0.018 + 0.4 + 5 = 5.418 um, class 5 rounds to 0.5 um: 5.5; class 4 (/sqrt 2):
    3.831 -> 3.8 (0.1 um); d = 200, m = 3, class 7 (x2): 12.8 -> 13 (1 um). IT4: 6 mm is in "over 3 up to
    6" (4 um), 10.5 mm in "over 10 up to 18" (5 um)."""
    assert iso1328_single_pitch(0.018, 0.001, "g") == pytest.approx(5.5e-6, abs=1e-12)
    assert iso1328_single_pitch(0.018, 0.001, "g", flank_class=4) == pytest.approx(3.8e-6, abs=1e-12)
    assert iso1328_single_pitch(0.2, 0.003, "g", flank_class=7) == pytest.approx(13e-6, abs=1e-12)
    assert iso286_it4(0.006, "k") == pytest.approx(4e-6) and iso286_it4(0.0105, "k") == pytest.approx(5e-6)
    with pytest.raises(RvtoolInputError, match=r"^sun_gear: d = 4 mm, m = 0\.4 mm is outside the scope of ISO 1328-1"):
        iso1328_single_pitch(0.004, 0.0004, "sun_gear")
    with pytest.raises(RvtoolInputError, match=r"^pins\.pin_radius: nominal size 600 mm is outside"):
        iso286_it4(0.6, "pins.pin_radius")


def test_tolerances_for_a_changed_design_follow_its_sizes(tmp_path, monkeypatch, capsys):
    """`rvtool new --tolerances-for DESIGN` writes the tolerance file of an edited design from its own sizes:
    RV pins made 10.02 mm in diameter move into ISO 286-1's "over 10 up to 18 mm" row (IT4 5 um, the
    template's 7 mm pins: 4 um), so the h4 radius error runs down to -2.5 um; it overwrites nothing and
    takes no --topology."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["new", "--topology", "rv2", "--name", "mine"]) == 0
    assert 'pin_radius_error = { dist = "uniform", low = -2e-06, high = 0.0 }' in (tmp_path / "mine_tolerances.toml").read_text()
    (tmp_path / "mine_tolerances.toml").unlink()
    p = tmp_path / "mine.toml"
    p.write_text(re.sub(r"(?m)^pin_radius = 0\.0035", "pin_radius = 0.00501", p.read_text(), count=1))
    capsys.readouterr()
    assert cli.main(["new", "--tolerances-for", "mine.toml"]) == 0
    text = (tmp_path / "mine_tolerances.toml").read_text()
    assert 'pin_radius_error = { dist = "uniform", low = -2.5e-06, high = 0.0 }' in text
    assert "IT4 at the pin diameter 10.02 mm = 5 um" in " ".join(ln.lstrip("# ") for ln in text.splitlines())
    assert cli.main(["new", "--tolerances-for", "mine.toml"]) == cli.EXIT_USAGE
    assert "mine_tolerances.toml exists" in capsys.readouterr().err
    assert cli.main(["new", "--tolerances-for", "mine.toml", "--topology", "rv2"]) == cli.EXIT_USAGE
    assert cli.main(["new"]) == cli.EXIT_USAGE
    assert "needs --topology" in capsys.readouterr().err


def test_rv80e_template_reproduces_the_shipped_rv80e_grades():
    """The RV template at RV-80E's sizes (pins 8 mm, pin circle 155 mm, 40 pins, crank circle 2 a = 84 mm, sun
    z = 10 and crank gears z = 38 of m_n = 1.75 mm) writes every one of the 16 fields of the shipped
    rv80e_tolerances.toml, in the loader's order, with the same distribution and parameters: the rules of that
    file's header ([ISO1328], [ISO286], [ISO1101], [POS], [ISO1328P], [ISO1328R]) computed from the design,
    not copied. The one deliberate difference: the template writes 3 significant digits (a tolerance is not
    known better), the shipped file 4 (2.167e-6 against 2.17e-6): rel 5e-3 covers that rounding and no grade
    step (the smallest step, 0.5 um on 5.5 um, is 9 %)."""
    import rvtool
    from rvtool import designs
    from rvtool.variants.rv_tolerances import RV_FIELDS
    shipped = tomllib.loads(open(designs.path("rv80e_tolerances.toml")).read())["tolerances"]
    mine = tomllib.loads(tolerance_template(rvtool.load_design("rv80e"), "rv80e.toml"))["tolerances"]
    assert tuple(mine) == RV_FIELDS and set(shipped) == set(RV_FIELDS)
    for key in RV_FIELDS:
        a, b = mine[key], shipped[key]
        assert a["dist"] == b["dist"] and set(a) == set(b), (key, a, b)
        for p in set(a) - {"dist"}:
            assert a[p] == pytest.approx(b[p], rel=5e-3, abs=1e-15), (key, p, a[p], b[p])


@pytest.mark.parametrize("topology", ["rv2", "rv3"])
def test_rv_templates_write_every_rv_field_in_the_loaders_order(topology, tmp_path, monkeypatch, capsys):
    """`rvtool new --topology rv2|rv3` writes all 16 RV fields (both topologies draw through the one RV sampler,
    rvtool.variants.rv_tolerances.rv_design_changes), active and in the loader's draw order, and the loader
    reads them all; the three-stage file says its input stage draws nothing."""
    from rvtool.variants.rv_tolerances import RV_FIELDS, load_rv_tolerances
    monkeypatch.chdir(tmp_path)
    assert cli.main(["new", "--topology", topology, "--name", "mine"]) == 0
    text = (tmp_path / "mine_tolerances.toml").read_text()
    assert tuple(_keys_and_comments(text)) == RV_FIELDS
    spec = load_rv_tolerances(str(tmp_path / "mine_tolerances.toml"))
    assert all(getattr(spec, f) is not None for f in RV_FIELDS)
    assert ("input stage (input_pinion, compound_gear) draws no deviation" in " ".join(
        ln.lstrip("# ") for ln in text.splitlines())) == (topology == "rv3")


def test_rv_template_leaves_out_wheel_bores_of_ported_wheels():
    """cranks.wheel_bore_errors is refused with wheels.body = 'ported' (RVDesign check): the template writes
    wheel_bore_position_error commented out, with the reason, and every other field active."""
    import rvtool
    from rvtool.variants.rv_tolerances import RV_FIELDS
    d = rvtool.load_design("rv80e")
    text = tolerance_template(d.replace(wheels={"body": "ported"}))
    assert tuple(tomllib.loads(text)["tolerances"]) == tuple(f for f in RV_FIELDS if f != "wheel_bore_position_error")
    joined = " ".join(ln.lstrip("# ") for ln in text.splitlines())
    assert "\n# wheel_bore_position_error = " in text and "not implemented with wheels.body = 'ported'" in joined


def test_recalled_iso1328_profile_and_runout_grades():
    """f_HaT = (0.4 m + 0.001 d + 4) sqrt(2)^(A-5) and F_rT = 0.9 (0.002 d + 0.55 sqrt(d) + 0.7 m + 12)
    sqrt(2)^(A-5), rounded as f_pT (both recalled, not re-read), at hand-computed points: d = 151.1 mm, m = 3.875
    mm: 1.55 + 0.1511 + 4 = 5.70 -> 5.5 (class 5), /sqrt 2 = 4.03 -> 4.0 (class 4); sun d = 17.5, m = 1.75:
    F_pT = 0.035 + 2.301 + 1.225 + 12 = 15.56, 0.9 F_pT = 14.00 -> 14 (class 5), x sqrt 2 = 19.8 -> 20 (class 6)."""
    assert iso1328_profile_slope(0.1511, 0.003875, "g") == pytest.approx(5.5e-6, abs=1e-12)
    assert iso1328_profile_slope(0.1511, 0.003875, "g", flank_class=4) == pytest.approx(4.0e-6, abs=1e-12)
    assert iso1328_runout(0.0175, 0.00175, "g") == pytest.approx(14e-6, abs=1e-12)
    assert iso1328_runout(0.0175, 0.00175, "g", flank_class=6) == pytest.approx(20e-6, abs=1e-12)
    with pytest.raises(RvtoolInputError, match=r"^sun_gear: d = 4 mm"):
        iso1328_runout(0.004, 0.0004, "sun_gear")
