"""A new user's session (helper "newuser3"): a fresh install, `rvtool new` for every topology, the
quick protocols, the docs' commands and one bad value per design section. Each test failed before
its fix (the output or message quoted in its docstring)."""
import os
import subprocess
import sys

import pytest

import rvtool
from rvtool.errors import RvtoolInputError
from _design_files import load_table, template_table


def test_list_into_a_closed_pipe_is_quiet():
    """Before: ``rvtool list | head`` ended in a ``BrokenPipeError`` traceback once ``head`` had read
    its lines. The reader here closes the pipe before the command writes anything."""
    r, w = os.pipe()
    os.close(r)
    p = subprocess.run([sys.executable, "-c", "import sys; from rvtool.cli import main; sys.exit(main(['list']))"],
                       stdout=w, stderr=subprocess.PIPE, text=True, timeout=120)
    os.close(w)
    assert "Traceback" not in p.stderr and "BrokenPipeError" not in p.stderr, p.stderr
    assert p.returncode == 1


@pytest.mark.parametrize("topology,gear", [("rv2", "sun_gear"), ("std-involute", "wheel")])
def test_gear_sub_table_errors_name_the_file_key_once(topology, gear, tmp_path):
    """Before: ``sun_gear.rack.rack.pressure_angle = 0.8726646259971648 is outside the valid range (0.0,
    0.7853981633974483)`` (the rack's own prefix doubled, the field in radians instead of the file's
    ``pressure_angle_deg`` in degrees), and ``sun_gear.modification.modification.tip_relief``."""
    table = template_table(topology)
    table[gear]["rack"]["pressure_angle_deg"] = 50.0
    with pytest.raises(RvtoolInputError) as e:
        load_table(tmp_path, table)
    assert str(e.value) == f"{gear}.rack.pressure_angle_deg = 50 is outside the valid range (0, 45) deg"
    table = template_table(topology)
    table[gear]["modification"]["tip_relief"] = -1e-6
    with pytest.raises(RvtoolInputError) as e:
        load_table(tmp_path, table)
    assert str(e.value).startswith(f"{gear}.modification.tip_relief = -1e-06 is outside the valid range [0.0, inf)")


@pytest.mark.parametrize("topology,section,key,value", [
    ("cycloid", "profile", "rotation_mod_deg", float("inf")),
    ("rv2", "cranks", "phase_errors_deg", [0.0, 0.0, float("nan")]),
])
def test_non_finite_angle_names_the_deg_key(topology, section, key, value, tmp_path):
    """Before: ``profile.rotation_mod = inf must be finite``: the spec's field, not the file's key."""
    table = template_table(topology)
    table[section][key] = value
    with pytest.raises(RvtoolInputError, match=rf"^{section}\.{key} = (inf|nan) must be finite"):
        load_table(tmp_path, table)


def test_crank_phase_error_count_names_the_deg_key(tmp_path):
    """Before: ``cranks.phase_errors has 1 entries`` (the file key is ``phase_errors_deg``)."""
    table = template_table("rv2")
    table["cranks"]["phase_errors_deg"] = [1.0]
    with pytest.raises(RvtoolInputError, match=r"^cranks\.phase_errors_deg has 1 entries; valid: 0 or cranks\.count"):
        load_table(tmp_path, table)


@pytest.mark.parametrize("topology,section,key,expect", [
    ("cycloid", "pins", "n_pins", r"\[pins\] is missing the required key pins\.n_pins \(valid: \[3, inf\) \(integer\)\)"),
    ("cycloid", None, "rated_torque", r"the top level is missing the required key rated_torque \(valid: \(0\.0, inf\)\)"),
    ("rv2", "crank_bearing", "n_rollers", r"\[crank_bearing\] is missing the required key crank_bearing\.n_rollers"),
    ("rv2", "crank_bearing", "cup_angle_deg", r"\[crank_bearing\] is missing the required key crank_bearing\.cup_angle_deg"),
])
def test_missing_required_key_is_named_as_the_file_writes_it(topology, section, key, expect, tmp_path):
    """Before: ``[pins]: Pins.__init__() missing 1 required keyword-only argument: 'n_pins'``, ``[design]:
    CycloidDesign.__init__() ...`` (no such section) and ``crank_bearing: TaperedRollerBearing.__init__()
    missing 1 required keyword-only argument: 'cup_angle'`` (the file key is cup_angle_deg)."""
    table = template_table(topology)
    del (table if section is None else table[section])[key]
    with pytest.raises(RvtoolInputError, match="^" + expect):
        load_table(tmp_path, table)


def test_tapered_unknown_key_lists_the_deg_keys(tmp_path):
    """Before: ``crank_bearing.foo is not a parameter of TaperedRollerBearing; valid: ['cone_angle', ...,
    'cup_angle', ...]``: writing 'cup_angle' is itself refused (degrees as cup_angle_deg)."""
    table = template_table("rv2")
    table["crank_bearing"]["foo"] = 1.0
    with pytest.raises(RvtoolInputError) as e:
        load_table(tmp_path, table)
    assert "'cup_angle_deg'" in str(e.value) and "'cup_angle'" not in str(e.value)


def test_calibration_frequencies_message_is_plain_numbers(tmp_path):
    """Before: ``calibration_frequencies = (np.float64(5000.0), np.float64(500.0)) must be increasing``."""
    table = template_table("cycloid")
    table["housing"]["structure"]["damping"]["calibration_frequencies"] = [5000.0, 500.0]
    with pytest.raises(RvtoolInputError) as e:
        load_table(tmp_path, table)
    assert "np.float64" not in str(e.value)
    assert str(e.value).startswith("housing.structure.damping.calibration_frequencies = [5000.0, 500.0] [Hz] must be "
                                   "increasing (valid: f_a < f_b")


def test_allowables_file_without_its_table(tmp_path):
    """Before (``--allowables mydrive.toml``, the design file given by mistake): ``[allowables]:
    Allowables.__init__() missing 6 required keyword-only arguments: ...``."""
    from rvtool.designs.allowables import load_allowables
    p = tmp_path / "mine.toml"
    p.write_text('topology = "cycloid"\n[pins]\nn_pins = 40\n')
    with pytest.raises(RvtoolInputError, match=r"has no \[allowables\] table; valid: an allowables file"):
        load_allowables(str(p))
    p.write_text("[allowables]\nmin_torsional_stiffness = 100.0\n")     # not a design file: no template's hint
    with pytest.raises(RvtoolInputError, match=r"^\[allowables\] is missing the required keys allowables\.max_lost_motion"
                                               r", .*; rvtool/designs/rd40_allowables\.toml gives every key"):
        load_allowables(str(p))


def test_lumped_needles_without_load_have_no_hertz_peak():
    """Before: a cycloid design with ``rated_torque = 1e-9`` was refused by the rated-state check with
    ``eccentric_bearing0/stribeck_max: the needle carries no load at this state`` (the lumped bearing's
    contact was listed as a loaded candidate whatever its force). At the unloaded built state the
    lumped needles carry nothing: no candidate, no error."""
    import numpy as np

    from rvtool.pressure.state import candidates
    model = rvtool.build(rvtool.load_design("rd40"))
    q = model.body_vector(np.zeros_like(model.reference))      # every body at its reference pose
    names, forces = model.observe(q, "eccentric_bearings").per_contact()
    assert not np.any(forces > 0), "the test needs an unloaded lumped needle bearing"
    assert candidates(model, q, "needles", 0) == []
    assert "needles" not in model.hertz_peaks(q)      # raised before


def _cli(argv, tmp_path, monkeypatch):
    from rvtool import cli
    monkeypatch.chdir(tmp_path)
    return cli.main(argv)


@pytest.mark.parametrize("argv,expect", [
    (["new", "--topology", "cycloid", "--name", ""], "--name = ''; valid: a non-empty design name"),
    (["new", "--topology", "cycloid", "--name", "a/b"], "--name = 'a/b'; valid: a non-empty design name"),
    (["new", "--topology", "cycloid", "--out", "nodir/x.toml"], "the folder 'nodir' does not exist"),
    (["validate", "rv40e", "--tornado-keys", "-1"], "--tornado-keys = -1 is outside the valid range [0, inf)"),
])
def test_cli_option_values_are_refused_by_name(argv, expect, tmp_path, monkeypatch, capsys):
    """Before: ``--name ''`` wrote mine.toml without a word, ``--name a/b`` (or ``--out`` into a missing
    folder) ended in a FileNotFoundError traceback, and ``validate --tornado-keys -1`` ran (the tornado
    then dropped the last key: ``order[:-1]``)."""
    assert _cli(argv, tmp_path, monkeypatch) == 2
    assert expect in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_mesh_that_never_engages_is_a_geometry_error(tmp_path):
    """Before: the cycloid template with ``wheels.clearance = 0.01`` (10 mm: the wheel never reaches the
    pins) said ``valid range: 0 < rated_torque <= 0.005904 N m (the largest torque shown to
    equilibrate)``, a torque the solver's regularization springs carried with the pins unloaded. No
    rated torque is admissible for that geometry; the error says so and names the clearance."""
    from rvtool.analysis.admissible import check_rated_state
    table = template_table("cycloid")
    table["wheels"]["clearance"] = 0.01
    design = load_table(tmp_path, table)
    with pytest.raises(RvtoolInputError, match=r"the main mesh \(pins\) carries no load at .* no rated_torque is "
                                               r"admissible.*wheels\.clearance = 0\.01 m"):
        check_rated_state(design, lambda: rvtool.build(design))


def test_a_small_clearance_rated_state_is_no_false_torque_limit(tmp_path):
    """Before: the cycloid template with ``wheels.clearance = 1e-4`` (0.1 mm) failed its rated-state
    solve at 10 and 140 N m (the load ramp jumped to a periodic copy of the engagement, the wheels
    turned by -0.97 rad) but solved at 30 N m, and the check said ``valid range: 0 < rated_torque
    <= 44.27 N m``. The check's solver now ends its ladder with the guide-spring homotopy, so the
    rated state is found with the pins carrying the load; a solver built without the option keeps
    the model's ladder (the protocols' paths do not change)."""
    import numpy as np
    from rvtool.analysis.admissible import check_rated_state
    from rvtool.solver.static import StaticSolver
    table = template_table("cycloid")
    table["wheels"]["clearance"] = 1e-4
    design = load_table(tmp_path, table)
    model, q = check_rated_state(design, lambda: rvtool.build(design))
    assert q is not None
    # the rated torque is carried by the mesh, not by the regularization springs: the pin forces
    # balance a torque of the order of the rated one (measured peak pin force 889 N)
    assert np.max(model.observe(q, model.main_mesh).normal_force) > 100.0
    assert StaticSolver(model).guided_fallback is False


def test_a_small_clearance_design_analyzes_by_the_guided_retry(tmp_path):
    """Before: with ``wheels.clearance = 1e-4`` the quick ``lost_motion`` failed ("torque continuation
    stalled between 0.000897217 and 2.1 N m"): at zero load the 0.1 mm free play leaves the wheels
    without contact stiffness. ``rvtool analyze`` now retries a protocol whose solver failed, on fresh
    models with the guide-spring homotopy (``guided_free_play``) as the last fallback, and says so in
    a warning; a protocol that ran before never reaches the retry (its path is unchanged)."""
    table = template_table("cycloid")
    table["wheels"]["clearance"] = 1e-4
    design = load_table(tmp_path, table)
    res = rvtool.analyze(design, "lost_motion", quick=True)
    lm = res["lost_motion"]
    assert lm.status == "ok", lm.reason
    assert any("guide-spring homotopy" in w for w in lm.warnings), lm.warnings
    value = {f.name: f.value for f in lm.figures}["lost_motion"]
    # every pin's contact normal passes through the pitch point, at e z_c from the wheel centre: a rotation
    # dtheta of the wheel (= the output) closes a gap c by at most dtheta e z_c, so the clearance alone gives
    # at least 2 c / (e z_c) = 2e-4 / (0.8e-3 x 39) rad = 22.04 arcmin of play; the elastic part at the
    # catalogue's measuring torque adds a few arcmin (the template without clearance: 3.35 arcmin, measured)
    # and the discrete pins a little more (measured 26.0 arcmin)
    assert 22.0 <= value <= 30.0, value


def test_pointed_tip_names_the_thickness_allowance(tmp_path):
    """Before: ``sun_gear.thickness_allowance = 0.01`` (10 mm on a 1 mm module) said ``... gives a pointed
    tip ...; valid: tip thickness > 0.0 m (reduce profile_shift = 0.1 or the tip diameter)``: the key
    that made the tip pointed was not named."""
    table = template_table("rv2")
    table["sun_gear"]["thickness_allowance"] = 0.01
    with pytest.raises(RvtoolInputError, match=r"pointed tip .*the thickness allowance \(sun_gear\.thickness_allowance, "
                                               r"0\.01 m\)"):
        load_table(tmp_path, table)


@pytest.mark.parametrize("topology", ["cycloid", "rv2", "rv3", "std-involute"])
def test_template_ranges_quote_no_probe_values(topology):
    """The template's range of a key comes from probing the spec with -1e30 and 1e30: a message that
    quotes the probe (a first version of the pointed-tip message above made thickness_allowance read
    "constrained by other keys: sun_gear.tip_diameter = 0.0202 m gives a pointed tip (tooth thickness
    at the tip -1.122e+30 m)") is no range."""
    from rvtool.designs.format import key_table
    for sec, key, value, unit, rng, meaning, required in key_table(topology):
        assert "e+30" not in rng and "e-30" not in rng and "VALUE" not in rng, f"{sec}.{key}: {rng}"


def test_sweep_protocol_value_names_its_table(tmp_path):
    """Before: ``n_te_points = -1 is outside the valid range [3, inf) (integer)`` for a key of the sweep
    spec's ``[protocol]`` table (``cluster.n_workers`` already named its table)."""
    from rvtool.variants.sweep import load_sweep_spec
    p = tmp_path / "s.toml"
    p.write_text('design = "d.toml"\n[protocol]\nn_te_points = -1\n[parameters]\npin_clearance = [0.0]\n')
    with pytest.raises(RvtoolInputError, match=r"^protocol\.n_te_points = -1 is outside the valid range \[3, inf\)"):
        load_sweep_spec(str(p))


def test_te_error_statement_quotes_the_refined_resolution(tmp_path):
    """Before: the TE figures' error statement read "reference: the topology's refined resolution
    ({'mesh_window_teeth': 4, 'mesh_n_slices': 1})": the run's own resolution, not the refined one it
    was measured against (window + 2 teeth, twice the slices for the std-involute drive)."""
    res = rvtool.analyze(rvtool.load_design("std_involute"), "te", quick=True, out_dir=str(tmp_path))
    model = rvtool.build(rvtool.load_design("std_involute"))
    fine = rvtool.build(model.refined_design()).resolution_settings()
    assert fine != model.resolution_settings()
    statement = res["te"].figure("te_pp").error_statement
    assert f"refined resolution ({fine})" in statement, statement
    # the peak-to-peak's error also counts the extrema missed between the run's points (before: it was the
    # points' own difference only, the same as the RMS's); this drive's extrema fall on common points of both
    # grids (sampling part 0), tests/test_te_pp_error.py checks the sum on a drive where they do not
    pp, rms = res["te"].figure("te_pp"), res["te"].figure("te_rms")
    assert "sampling error" in pp.error_statement and "sampling error" not in rms.error_statement
    assert pp.error >= rms.error > 0.0


def test_crank_eccentricity_error_keeps_the_eccentric_off_the_axis(tmp_path):
    """Before: ``cranks.eccentricity_errors = [-0.0013, 0, 0]`` on a 1.2 mm eccentricity (crank 0's
    eccentric across its axis) was accepted and reported by the rated-state check as "the geometry,
    not the load, is inadmissible: check the clearances and radii", naming no key."""
    table = template_table("rv2")
    table["cranks"]["eccentricity_errors"] = [-0.0013, 0.0, 0.0]
    with pytest.raises(RvtoolInputError, match=r"^cranks\.eccentricity_errors\[0\] = -0\.0013 m .* valid range "
                                               r"\(-0\.0012, inf\) m"):
        load_table(tmp_path, table)
    table["cranks"]["eccentricity_errors"] = [2e-6, 0.0, -1e-6]      # a tolerance's size: accepted
    load_table(tmp_path, table)


@pytest.mark.parametrize("out", ["taken.txt", "taken.txt/sub"])
def test_out_into_a_file_is_an_input_error_before_any_work(out, tmp_path, monkeypatch, capsys):
    """Before: ``rvtool analyze mydrive.toml --out mydrive.toml`` (or a path under a file) solved the
    rated state and then ended in a ``FileExistsError`` / ``NotADirectoryError`` traceback."""
    (tmp_path / "taken.txt").write_text("x")
    assert _cli(["analyze", "rd40", "--quick", "--protocols", "lost_motion", "--out", out, "--quiet"],
                tmp_path, monkeypatch) == 2
    err = capsys.readouterr().err
    assert f"--out / out_dir = '{out}'" in err and "Traceback" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken.txt"]


@pytest.mark.parametrize("argv", [
    ["run", "hard_rd40", "--quick", "--out", "taken.txt"],
    ["sweep", "spec.toml", "--out", "taken.txt", "--quiet"],
    ["validate", "rv40e", "--quick", "--out", "taken.txt", "--quiet"],
])
def test_other_commands_refuse_an_out_that_is_a_file(argv, tmp_path, monkeypatch, capsys):
    """Before: ``rvtool run CASE --out FILE`` and ``rvtool sweep SPEC --out FILE`` ended in a
    ``FileExistsError`` traceback, ``rvtool validate --out FILE`` in a ``NotADirectoryError``."""
    (tmp_path / "taken.txt").write_text("x")
    (tmp_path / "spec.toml").write_text('design = "d.toml"\n[parameters]\npin_clearance = [0.0]\n')
    assert _cli(argv, tmp_path, monkeypatch) == 2
    err = capsys.readouterr().err
    assert "--out = 'taken.txt' is an existing file" in err and "Traceback" not in err, err


@pytest.mark.parametrize("topology,section", [("rv2", "crank_bearing"), ("rv2", "main_bearing"),
                                              ("cycloid", "main_bearing")])
def test_misspelt_pair_key_is_answered_with_the_pairs_keys(topology, section, tmp_path):
    """Before: ``rowspacing`` in ``[main_bearing]`` was answered with the ball row's keys alone, without
    ``row_spacing`` and without a "did you mean" (``crank_bearing.rowspacing is not a parameter of
    TaperedRollerBearing; valid: [...]``): the pair's own keys share the table with its rows'."""
    table = template_table(topology)
    table[section]["rowspacing"] = table[section].pop("row_spacing")
    with pytest.raises(RvtoolInputError) as e:
        load_table(tmp_path, table)
    msg = str(e.value)
    assert msg.startswith(f"[{section}] has unknown keys ['rowspacing']; valid keys are ["), msg
    assert "'row_spacing'" in msg and "'arrangement'" in msg and "did you mean 'rowspacing' -> 'row_spacing'" in msg


def test_design_file_with_a_byte_order_mark_says_so(tmp_path):
    """Before: a design file saved with a UTF-8 byte-order mark (Windows Notepad) was refused as
    ``is not valid TOML: Invalid statement (at line 1, column 1)``, pointing at nothing visible."""
    from rvtool.designs.format import template
    p = tmp_path / "mine.toml"
    p.write_bytes(b"\xef\xbb\xbf" + template("cycloid", "mine").encode())
    with pytest.raises(RvtoolInputError, match=r"starts with a UTF-8 byte-order mark"):
        rvtool.load_design(str(p))


def test_an_unused_scheduler_is_said(tmp_path):
    """Before: ``rvtool analyze mydrive.toml --quick --protocols monte_carlo --scheduler HOST:PORT`` ran
    the variants in this process and said nothing (an address nobody listens on passed unnoticed)."""
    res = rvtool.analyze("rd40", "monte_carlo", quick=True, scheduler="tcp://nohost:1")     # its tolerance file
    mc = res["monte_carlo"]
    assert mc.status == "ok"
    assert any("--scheduler tcp://nohost:1 was not used" in w for w in mc.warnings), mc.warnings


def test_shared_output_pins_name_the_table_they_need(tmp_path):
    """Before: ``output_pins.mode = "shared"`` (a choice the template offers) was refused with
    ``output_pins.compliance = None must be a SharedPinCompliance in shared mode``: no key of that name
    in the template, and the format doc said "compliance [m/N] (None: rigid)"."""
    table = template_table("cycloid")
    table["output_pins"]["mode"] = "shared"
    with pytest.raises(RvtoolInputError, match=r"output_pins\.mode = 'shared' needs .*\[output_pins\.compliance\] "
                                               r"\(self_compliance_0, self_compliance_1"):
        load_table(tmp_path, table)
    table["output_pins"]["compliance"] = {"self_compliance_0": 1e-9, "self_compliance_1": 1e-9}
    assert load_table(tmp_path, table).output_pins.mode.value == "shared"


@pytest.mark.parametrize("section,key,value", [("bodies", "flange_coordinates", "spatial"),
                                               ("eccentric_bearing", "slices", "influence")])
def test_a_rolling_bearing_only_choice_names_the_command_line_option(section, key, value, tmp_path):
    """Before: a cycloid design file with ``bodies.flange_coordinates = "spatial"`` was refused under
    `rvtool analyze` with "valid: build(..., bearing_model='rolling')", a keyword the command line had
    no option for; the lumped build now says so and names `--bearing-model rolling` (tests/test_bearcli.py
    runs it)."""
    table = template_table("cycloid")
    table[section][key] = value
    design = load_table(tmp_path, table)
    with pytest.raises(RvtoolInputError,
                       match=r"`rvtool analyze` builds the cycloid .* with lumped bearings.*--bearing-model rolling"):
        rvtool.build(design)


def test_wheel_midplanes_must_be_numbers(tmp_path):
    """Before: ``wheels.midplanes = [[0.0], [1.0]]`` was refused as ``output_pins.wheel_midplanes must list
    one axial position per wheel`` (a key the template leaves to follow wheels.midplanes)."""
    table = template_table("cycloid")
    table["wheels"]["midplanes"] = [[0.0], [1.0]]
    with pytest.raises(RvtoolInputError, match=r"^wheels\.midplanes = \[\[0\.0\], \[1\.0\]\]; valid: a list of numbers"):
        load_table(tmp_path, table)
