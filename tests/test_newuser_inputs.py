"""What a new user meets first (helper "newuser"): the `rvtool new` template of each topology, edited
wrongly, must stop with an error that names the design-file key and its valid range -- never an
Exudyn traceback, a list of internal field names or a probe's TypeError in the template's comments.
Each test failed before its fix (the message quoted in its docstring)."""
import re
import tomllib

import pytest

import rvtool
from rvtool.assembly import topologies
from rvtool.designs.format import key_table, template
from rvtool.errors import RvtoolInputError
from _design_files import load_table, template_table

TOPOLOGIES = [t for t in topologies.TOPOLOGIES if topologies.available(t) is None]


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_template_ranges_are_never_a_python_error(topology):
    """The std-involute template said ``n_wheels = 2 # valid: constrained by other keys: TypeError:
    StdInvoluteDesign.__init__() got an unexpected keyword argument 'pair'`` (the range probe passed
    the design's derived ``pair`` field back to its constructor)."""
    for sec, key, value, unit, rng, meaning, required in key_table(topology):
        assert not re.search(r"\w+Error\b|__init__", rng), f"{topology}: {sec}.{key}: valid: {rng}"


def test_std_involute_top_level_ranges_are_the_specs_own():
    rows = {key: rng for sec, key, value, unit, rng, meaning, required in key_table("std-involute") if sec == ""}
    assert rows["rated_torque"] == "(0.0, inf)"
    assert rows["input_speed_rpm"] == "(0.0, inf)"


@pytest.mark.parametrize("topology", ["cycloid", "std-involute"])
@pytest.mark.parametrize("key", ["shaft_mass", "shaft_inertia", "flange_mass", "flange_inertia"])
def test_negative_body_mass_names_the_key(topology, key, tmp_path):
    """Before: ``exudyn.exudynCPP.ExudynValueError: parameter ObjectRigidBody2D.mass may not be
    negative, but received -1.2`` from deep inside the builder (the file was accepted)."""
    table = template_table(topology)
    table["bodies"][key] = -1.0
    with pytest.raises(RvtoolInputError, match=rf"bodies\.{key} = .*-1\.0.* is outside the valid range \(0\.0, inf\)"):
        load_table(tmp_path, table)
    table["bodies"][key] = 0.0          # a massless body: singular in the driven runs
    with pytest.raises(RvtoolInputError, match=rf"bodies\.{key}"):
        load_table(tmp_path, table)


def test_unknown_key_lists_the_file_keys_not_the_field_names(tmp_path):
    """Before: ``[wheels] has unknown keys ['widht']; valid keys are [..., 'phases', ...]``: 'phases' is
    the spec's field (radians), the file key is 'phases_deg'; writing 'phases' is itself refused."""
    table = template_table("cycloid")
    table["wheels"]["widht"] = 0.008
    with pytest.raises(RvtoolInputError) as exc:
        load_table(tmp_path, table)
    msg = str(exc.value)
    assert "'widht'" in msg and "'phases_deg'" in msg and "'phases'" not in msg, msg


def test_unknown_top_level_key_lists_no_internal_fields(tmp_path):
    """Before: ``[design] has unknown keys ['rated_torq']; valid keys are [..., 'source', ...,
    'topology'...]``: 'source' is the loader's copy of the file, not a key a file may give."""
    table = template_table("rv3")
    table["rated_torq"] = 400.0
    with pytest.raises(RvtoolInputError) as exc:
        load_table(tmp_path, table)
    msg = str(exc.value)
    assert "'rated_torq'" in msg and "'rated_torque'" in msg and "'source'" not in msg, msg
    assert msg.startswith("the top level has unknown keys") and "[design]" not in msg, msg   # no such table


@pytest.mark.parametrize("topology,section", [("cycloid", "pin_contact"), ("rv3", "compound_gear"),
                                              ("rv2", "cranks"), ("std-involute", "mesh")])
def test_misspelt_section_is_named_with_its_correct_spelling(topology, section, tmp_path):
    """Before: cycloid ``section [pin_contact] is missing from the design`` (the misspelt table not
    named), rv3 ``[compound_gear]: InvoluteGear.__init__() missing 3 required keyword-only
    arguments``."""
    table = template_table(topology)
    wrong = section[:3] + section[4:]           # one letter left out
    table[wrong] = table.pop(section)
    with pytest.raises(RvtoolInputError) as exc:
        load_table(tmp_path, table)
    msg = str(exc.value)
    assert f"[{wrong}]" in msg and f"[{section}]" in msg and "__init__" not in msg, msg


@pytest.mark.parametrize("topology", ["cycloid", "std-involute"])
def test_three_wheels_names_n_wheels(topology, tmp_path):
    """Before (cycloid): ``wheels.wheels: 3 wheels; valid range [1, 2]`` (no such key)."""
    table = template_table(topology)
    table["n_wheels"] = 3
    table["wheels"]["midplanes"] = [-0.012, 0.0, 0.012]
    table["wheels"]["phases_deg"] = [0.0, 120.0, 240.0]
    table["output_pins"].pop("wheel_midplanes", None)
    table["output_pins"]["gap_offsets"] = [0.0, 0.0, 0.0]
    with pytest.raises(RvtoolInputError, match=r"wheels\.midplanes has 3 entries.*valid range \[1, 2\]") as exc:
        load_table(tmp_path, table)
    assert "wheels.wheels" not in str(exc.value)


@pytest.mark.parametrize("topology", ["cycloid", "std-involute"])
def test_n_wheels_range_and_what_else_to_change(topology, tmp_path):
    """Before: the template said ``n_wheels = 2 # valid: constrained by other keys: n_wheels = VALUE but
    wheels.midplanes has 2 entries`` and n_wheels = 1 alone stopped with that sentence, naming none of
    the other keys a one-wheel design changes."""
    rows = {key: rng for sec, key, value, unit, rng, meaning, required in key_table(topology) if sec == ""}
    assert rows["n_wheels"] == "[1, 2] (integer)", rows["n_wheels"]
    table = template_table(topology)
    table["n_wheels"] = 1
    with pytest.raises(RvtoolInputError, match=r"n_wheels = 1 but wheels\.midplanes has 2 entries; valid: .*"
                                               r"wheels\.phases_deg.*output_pins\.gap_offsets"):
        load_table(tmp_path, table)
    table["wheels"]["midplanes"] = [0.0]
    table["wheels"]["phases_deg"] = [0.0]
    # the template leaves output_pins.wheel_midplanes and gap_offsets commented out: they follow
    assert "wheel_midplanes" not in table["output_pins"] and "gap_offsets" not in table["output_pins"]
    assert load_table(tmp_path, table).n_wheels == 1     # the three keys docs/guide/cycloid.md lists


def test_std_involute_has_marker_frequencies():
    """Before: ``rvtool analyze std_involute`` warned "vibration: no marker frequencies:
    'StdInvoluteModel' object has no attribute 'marker_frequencies'". STD-39 at 1500 rpm
    (rvtool/designs/std_involute.toml): f_in = 25 Hz; ring 80 teeth fixed, the eccentric carries the
    mesh point round it once per input revolution: mesh 80 x 25 = 2000 Hz (the frequency the
    vibration protocol's spectrum reports); wheels 78 teeth, |i| = 78 / 2 = 39: output 25 / 39 Hz;
    eccentric needles between the journal (25 Hz) and the wheel bore (-25/39 Hz): cage
    FTF = f_r / 2 (1 - D / d_m) with f_r = 25 + 25/39 Hz, D = 3 mm, d_m = 2 x 12 + 3 = 27 mm."""
    d = rvtool.load_design("std_involute")
    m = rvtool.build(d).marker_frequencies(1500.0)
    assert m["input_hz"] == pytest.approx(25.0, rel=1e-12)
    assert m["mesh_hz"] == pytest.approx(2000.0, rel=1e-12)
    assert m["output_hz"] == pytest.approx(25.0 / 39.0, rel=1e-12)
    eb = d.eccentric_bearing
    assert (eb.roller_diameter, eb.inner_radius) == pytest.approx((0.003, 0.012))   # the numbers above
    f_r = 25.0 + 25.0 / 39.0
    assert m["eccentric_bearing"]["ftf"] == pytest.approx(f_r / 2 * (1 - 3.0 / 27.0), rel=1e-12)
    assert {"main_bearing", "input_bearing"} <= set(m)


def test_cycloid_markers_unchanged_by_the_shared_function():
    """RD-40 (40 pins, 39 lobes) at 1500 rpm: mesh 40 x 25 Hz, output 25 / 39 Hz (as before the
    cycloid's body moved to eccentric_drive_markers)."""
    m = rvtool.build(rvtool.load_design("rd40")).marker_frequencies(1500.0)
    assert m["mesh_hz"] == pytest.approx(1000.0, rel=1e-12) and m["output_hz"] == pytest.approx(25 / 39, rel=1e-12)


def test_template_linked_keys_follow_the_key_they_name(tmp_path):
    """Before, the cycloid template wrote its linked keys out: a wheel made wider (wheels.width
    0.008 -> 0.010) kept output_pins.contact_length = 0.008 silently, and a new pins.pin_radius was
    refused ("profile.pin_radius = 0.003 differs from pins.pin_radius"). Now they are commented out
    ("# contact_length = 0.008 # ... (left out: wheels.width).") and follow."""
    text = template("cycloid", name="mine")
    assert re.search(r"^# contact_length = 0\.008 # .*\(left out: wheels\.width\)\.$", text, re.M), text
    table = tomllib.loads(text)
    assert "contact_length" not in table["output_pins"] and "pin_radius" not in table["profile"]
    table["wheels"]["width"] = 0.010
    table["pins"]["pin_radius"] = 0.0032
    d = load_table(tmp_path, table)
    assert d.output_pins.contact_length == 0.010 and d.profile.pin_radius == 0.0032


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_template_meanings_read_as_sentences(topology):
    """Comments a newcomer could not read, taken from docstrings cut in the wrong place: end_play
    "/ 2 off contact) or ``interference`` [m] (...", interference "[m] (the axial overlap ...",
    crank_bearing.row_spacing "/2 from the mounting's axial centre [m] ...", reference_roller_load
    "the load of that secant [N]", output_pins.mode "class:`PinMode`", flange_coordinates
    "needs rolling-element bearings, , and a ball main bearing"."""
    for sec, key, value, unit, rng, meaning, required in key_table(topology):
        where = f"{topology}: {sec}.{key}: {meaning!r}"
        assert not re.match(r"^[\[/),;:]|^class:", meaning), where
        assert ", ," not in meaning and "the load of that" not in meaning, where
        # a "(file: ``NAME_deg``; ...)" note cut to "...)" (std wheels.phases_deg, crank_bearing.cone_angle_deg)
        plain = re.sub(r"[\[(][^\[\]()]*,[^\[\]()]*[\])]", "", meaning)    # intervals such as [0, pi/2)
        assert plain.count("(") == plain.count(")"), where
        assert "() =" not in meaning, where                         # TOML has no (): an empty list is []


def test_std_involute_light_load_cold_start_solves():
    """`rvtool new --topology std-involute`, rated_torque = 1.0, `rvtool analyze --quick --protocols te`:
    the TE failed ("no plausible static equilibrium at input angles [2.2580197197676637] rad (batch
    warm start, homotopy and the per-variant ladder failed)"; auto ran the replica, whose segment
    starts are cold; Exudyn's warm march solved it). The static solver from the kinematic state at
    that angle under 1 N m failed; with the guide-spring homotopy (the RV's free-play fallback) it
    solves to a plausible state (every body within the solver's bounds of its kinematic position)."""
    import math

    from rvtool.solver.static import StaticSolver
    d = rvtool.replace_design(rvtool.load_design("std_involute"), rated_torque=1.0)
    m = rvtool.build(d)
    m.set_output_torque(-math.copysign(1.0, m.ratio) * 1.0)     # as the protocols load it
    s = StaticSolver(m)
    q = s.solve(2.2580197197676637, None)
    assert s.stats.guided_levels == 1          # reached by the homotopy, not by an earlier rung
    assert s.plausible(q, 2.2580197197676637)


def test_pressure_angle_typed_in_radians_is_named(tmp_path):
    """``pressure_angle_deg = 0.349`` (20 deg typed in radians) passes its own range (0, 45) deg and
    stopped with "sun_gear.profile_shift = 0.1 undercuts the tooth ...; valid range [0.8720, inf) for
    z = 18", which does not point at the angle; the message now quotes the pressure angle it used."""
    table = template_table("rv2")
    table["sun_gear"]["rack"]["pressure_angle_deg"] = 0.349
    with pytest.raises(RvtoolInputError, match=r"sun_gear\.profile_shift = .* undercuts .* and "
                                               r"sun_gear\.rack\.pressure_angle_deg = 0\.349\b"):
        load_table(tmp_path, table)


def test_docs_name_the_topology_keys_the_loader_accepts():
    """docs/guide/std_involute.md said "the file's key is ``topology = "std_involute"``", which the
    loader refuses ("'std_involute' is not a known topology"): every ``topology = "X"`` a guide page
    shows must be a topology key."""
    from pathlib import Path
    docs = Path(__file__).resolve().parents[1] / "docs"
    pages = [p for p in docs.rglob("*.md") if "history" not in p.parts and "changelog.d" not in p.parts]
    shown = {(p.name, m) for p in pages for m in re.findall(r'topology = "([\w-]+)"', p.read_text())}
    assert shown, "no page shows a topology key"
    bad = [(page, key) for page, key in shown if key not in topologies.TOPOLOGIES]
    assert not bad, bad


def test_design_name_without_toml_points_at_the_file(tmp_path, monkeypatch):
    """`rvtool new --name mydrive` then `rvtool analyze mydrive` (the suffix left out): the error
    listed the shipped designs only; it now names mydrive.toml."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "mydrive.toml").write_text(template("cycloid", name="mydrive"))
    with pytest.raises(RvtoolInputError, match=r"the file 'mydrive\.toml' exists"):
        topologies.resolve_design_path("mydrive")
    with pytest.raises(RvtoolInputError) as exc:
        topologies.resolve_design_path("nothing_here")
    assert "exists" not in str(exc.value)


def test_interference_is_named_as_geometry_not_as_rated_torque():
    """The cycloid template with wheels.eccentricity 0.0008 -> 0.0009 m (profile generated with
    0.0008 m): the wheels are pressed 0.1 mm into the pins. Before: "rated_torque = 140 N m: the
    needles contacts reach a Hertz peak of 6.734 GPa ...; valid range: 0 < rated_torque <= 98.88 N m",
    a torque limit that does not exist (at 1.4e-4 N m the needles are at 6.73 GPa already)."""
    from rvtool.analysis.admissible import check_rated_state
    d = rvtool.replace_design(rvtool.load_design("rd40"), wheels={"eccentricity": 0.0009})
    with pytest.raises(RvtoolInputError) as exc:
        check_rated_state(d, lambda: rvtool.build(d))
    msg = str(exc.value)
    assert "already at 0.00014 N m" in msg and "no rated_torque is admissible" in msg, msg
    assert "wheels.eccentricity = 0.0009 m exceeds profile.generating_eccentricity = 0.0008 m" in msg, msg
    assert "rated_torque <=" not in msg, msg


def test_paths_the_docs_create_in_the_checkout_are_ignored():
    """docs/install.md creates the virtual environment in the checkout (``python -m venv .venv``):
    .venv/ was not in .gitignore, so `git status` listed the whole environment and `git add -A`
    would commit it. Every path the install and getting-started pages create in the checkout is
    ignored."""
    import shutil
    import subprocess
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    if shutil.which("git") is None or not (root / ".git").exists():
        pytest.skip("not a git checkout")
    install = (root / "docs" / "install.md").read_text()
    assert "python -m venv .venv" in install                   # what the page tells a user to run
    for path in (".venv/bin/python", "docs/_build/html/index.html", "results/rd40/results.json"):
        proc = subprocess.run(["git", "check-ignore", "-q", path], cwd=root)
        assert proc.returncode == 0, f"{path} is not ignored by .gitignore"


def test_equidistant_mod_has_a_range_and_a_negative_generating_radius_is_refused(tmp_path):
    """Before: the template said ``equidistant_mod = 0.0 # valid: constrained by other keys: the profile
    is undercut or pointed: generating radius VALUE m exceeds ...`` and a large negative value
    (pin_radius + equidistant_mod < 0, a generating circle of negative radius) was accepted. RD-40:
    r_p = 3 mm, the epitrochoid's smallest convex curvature radius 4.74877 mm (the number the old
    message quoted), so equidistant_mod lies in (-0.003, 0.00174877) m."""
    rows = {key: rng for sec, key, value, unit, rng, meaning, required in key_table("cycloid") if sec == "profile"}
    assert rows["equidistant_mod"] == "(-0.003, 0.00174877)", rows["equidistant_mod"]
    for bad in (-0.0031, 0.0018):
        table = template_table("cycloid")
        table["profile"]["equidistant_mod"] = bad
        with pytest.raises(RvtoolInputError, match=r"profile\.equidistant_mod = .* is outside the valid range "
                                                   r"\(-0\.003, 0\.00174877\) m"):
            load_table(tmp_path, table)


def test_misspelt_case_name_suggests_the_case(tmp_path):
    """`rvtool run cycloid_singel --quick` printed the whole list of cases (50 names) and no hint."""
    from rvtool import cli
    (tmp_path / "cycloid").mkdir()
    (tmp_path / "cycloid" / "cycloid_single.py").write_text('"""A case."""\ndef main(argv=None):\n    pass\n')
    (tmp_path / "rv").mkdir()
    (tmp_path / "rv" / "rv_two_stage.py").write_text('"""A case."""\ndef main(argv=None):\n    pass\n')
    with pytest.raises(LookupError, match=r"did you mean 'cycloid/cycloid_single'\?"):
        cli.resolve_case("cycloid_singel", tmp_path)
    with pytest.raises(LookupError) as exc:
        cli.resolve_case("zzzz", tmp_path)
    assert "did you mean" not in str(exc.value)


def test_failed_te_names_the_backend_that_failed(tmp_path, monkeypatch):
    """A failed TE wrote ``"reason": "SolverFailure: no plausible static equilibrium ..."`` and empty
    settings: nothing said that auto had run the replica (whose cold segment starts failed where
    Exudyn's march solved). The reason now names the backend."""
    from rvtool.errors import SolverFailure
    from rvtool.protocols import precision

    def fail(*args, **kwargs):
        raise SolverFailure("no plausible static equilibrium at input angles [2.258] rad")
    monkeypatch.setattr(precision, "quasi_static_te", fail)
    res = rvtool.analyze(rvtool.load_design("rd40"), "te", quick=True, out_dir=str(tmp_path / "out"))
    te = res["te"]
    assert te.status == "failed"
    assert "no plausible static equilibrium" in te.reason and "[backend 'exudyn', requested 'auto']" in te.reason, te.reason


def test_output_pin_slices_have_an_upper_bound(tmp_path):
    """``output_pins.n_slices = 1000000`` (valid range "[1, inf)") made `rvtool analyze --quick
    --protocols stiffness` build for more than 90 s without a word (killed); the wheels' slices stop
    at 64 for that reason. The bound is stated in the template and enforced."""
    rows = {(sec, key): rng for sec, key, value, unit, rng, meaning, required in key_table("cycloid")}
    assert rows[("output_pins", "n_slices")] == "[1, 64] (integer)", rows[("output_pins", "n_slices")]
    table = template_table("cycloid")
    table["output_pins"]["n_slices"] = 1000000
    with pytest.raises(RvtoolInputError, match=r"output_pins\.n_slices = 1000000 is outside the valid range \[1, 64\]"):
        load_table(tmp_path, table)


# (topology, section path, key, the valid range the template states and the loader enforces); each key was
# "[lo, inf)" before, and a mistyped 1e6 built (meshed, factored, unrolled) for minutes without a word
COUNT_BOUNDS = [
    ("rv2", ("involute_stage",), "n_slices", "[1, 64] (integer)"),
    ("std-involute", ("mesh",), "n_slices", "[1, 64] (integer)"),
    ("cycloid", ("output_pins", "sleeve"), "updates", "[0, 256] (integer)"),
    ("cycloid", ("housing",), "n_modes", "[0, 200] (integer)"),
    ("cycloid", ("housing",), "n_fixed_interface_modes", "[0, 200] (integer)"),
    ("cycloid", ("housing", "structure"), "n_ports", "[1, 256] (integer)"),
    ("cycloid", ("housing",), "n_residual", "[-1, 512] (integer)"),
    ("cycloid", ("housing", "structure"), "n_mounts", "[0, 256] (integer)"),
    ("rv2", ("carrier", "structure"), "n_modes", "[0, 200] (integer)"),
]


@pytest.mark.parametrize("topology, path, key, valid", COUNT_BOUNDS)
def test_count_keys_have_an_upper_bound(topology, path, key, valid, tmp_path):
    """Count keys (slices, sleeve updates, retained modes, ports) stated "[lo, inf)": the template now
    states the cost limit and the loader refuses a value above it by its key, before any meshing."""
    rows = {(sec, k): rng for sec, k, value, unit, rng, meaning, required in key_table(topology)}
    assert rows[(".".join(path), key)] == valid, rows[(".".join(path), key)]
    table = template_table(topology)
    sub = table
    for p in path:
        sub = sub.setdefault(p, {})
    sub[key] = 1000000
    hi = re.search(r", (\d+)\]", valid).group(1)
    with pytest.raises(RvtoolInputError, match=rf"{re.escape('.'.join(path))}\.{key} = 1000000 is outside the valid "
                                               rf"range \[-?\d, {hi}\]"):
        load_table(tmp_path, table)
    sub[key] = int(hi)                   # the bound itself is valid (the loader may refuse it for other reasons)
    try:
        load_table(tmp_path, table)
    except RvtoolInputError as exc:
        assert f"{key} = {hi} is outside" not in str(exc), exc


def test_std_mesh_window_is_bounded_by_the_wheels_teeth(tmp_path):
    """``mesh.window`` ("[0, inf)") counts wheel teeth on each side of the pitch point: beyond
    (wheel.n_teeth - 1) // 2 a tooth would be evaluated twice (and a mistyped 1e6 built for minutes)."""
    table = template_table("std-involute")
    w_max = (table["wheel"]["n_teeth"] - 1) // 2
    table["mesh"]["window"] = w_max + 1
    with pytest.raises(RvtoolInputError, match=rf"mesh\.window = {w_max + 1} is outside the valid range \[0, {w_max}\]"):
        load_table(tmp_path, table)
    table["mesh"]["window"] = w_max
    assert load_table(tmp_path, table).mesh.window == w_max
