"""The newcomer's path, walked again in a fresh virtual environment (helper "freshpath", session 5):
`rvtool new` for each topology, one wrong key each, `rvtool analyze --quick`, the report and its
plots. Each test failed before its fix (the message or behaviour quoted in its docstring)."""
import os
import stat
import tomllib

import pytest

import rvtool
from rvtool.designs.format import template
from rvtool.errors import RvtoolInputError
from rvtool.validation import check_range


def _load(tmp_path, table):
    import tomlkit
    p = tmp_path / "mine.toml"
    p.write_text(tomlkit.dumps(table))
    return rvtool.load_design(str(p))


@pytest.mark.parametrize("topology", ["rv2", "rv3"])
@pytest.mark.parametrize("section, key, value, shown", [
    ("crank_bearing", "n_rollers", 25, r"25 is outside the valid range \[3, 19\] \(integer\)"),
    ("crank_bearing", "roller_length", -0.01, r"-0\.01 is outside the valid range \(0\.0, inf\)"),
    ("main_bearing", "n_balls", 1, r"1 is outside the valid range \[3, 1000\] \(integer\)"),
    ("main_bearing", "contact_angle_deg", 120.0, r"120 is outside the valid range \[0, 90\) deg")])
def test_rv_bearing_row_keys_are_named_as_the_template_writes_them(topology, section, key, value, shown, tmp_path):
    """The RV template writes the bearing pairs' row keys flat in ``[crank_bearing]`` and
    ``[main_bearing]``; before, a wrong one was reported under a key the file does not have:
    ``crank_bearing.rows[0].n_rollers = 25 is outside the valid range [3, 19] (integer)``."""
    table = tomllib.loads(template(topology, name="mine"))
    assert key in table[section] and "rows" not in table[section]      # the flat form, as written
    table[section][key] = value
    with pytest.raises(RvtoolInputError, match=rf"^{section}\.{key} = {shown}$"):
        _load(tmp_path, table)


def test_rv_bearing_row_table_errors_name_that_table(tmp_path):
    """One ``[crank_bearing.row]`` table for both rows: the error names ``crank_bearing.row.KEY``;
    explicit ``rows`` tables keep ``crank_bearing.rows[k].KEY``."""
    table = tomllib.loads(template("rv2", name="mine"))
    pair = table["crank_bearing"]
    own = {"row_spacing", "arrangement", "axial_preload", "end_play"}
    row = {k: v for k, v in pair.items() if k not in own}
    table["crank_bearing"] = {**{k: v for k, v in pair.items() if k in own}, "row": {**row, "n_rollers": 2}}
    with pytest.raises(RvtoolInputError, match=r"^crank_bearing\.row\.n_rollers = 2 is outside"):
        _load(tmp_path, table)
    table["crank_bearing"] = {**{k: v for k, v in pair.items() if k in own}, "rows": [row, {**row, "n_rollers": 2}]}
    with pytest.raises(RvtoolInputError, match=r"^crank_bearing\.rows\[1\]\.n_rollers = 2 is outside"):
        _load(tmp_path, table)


def test_a_number_out_of_range_is_shown_as_written():
    """Before: ``pins.pin_radius = [-0.003] is outside the valid range (0.0, inf)``: the user wrote a
    number and read back a one-element list. A list keeps its list form (its first bad values)."""
    with pytest.raises(RvtoolInputError, match=r"^pin_radius = -0\.003 is outside the valid range \(0\.0, inf\)$"):
        check_range("pin_radius", -0.003, 0.0, low_open=True)
    with pytest.raises(RvtoolInputError, match=r"^n = 7 is outside the valid range \[0, 5\]$"):
        check_range("n", 7, 0, 5)
    with pytest.raises(RvtoolInputError, match=r"^midplanes = \[-1\.0, -2\.0\] is outside"):
        check_range("midplanes", [0.5, -1.0, -2.0], 0.0)


def test_cycloid_template_negative_pin_radius_message(tmp_path):
    table = tomllib.loads(template("cycloid", name="mine"))
    table["pins"]["pin_radius"] = -0.003
    with pytest.raises(RvtoolInputError, match=r"^pins\.pin_radius = -0\.003 is outside the valid range \(0\.0, inf\)$"):
        _load(tmp_path, table)


@pytest.mark.parametrize("topology", ["cycloid", "rv2", "rv3", "std-involute"])
def test_template_lists_the_choices_of_every_choice_key(topology):
    """Before: ``law = "power" # valid: text``, ``slices = "laminae" # valid: text``,
    ``arrangement = "back_to_back" # valid: text``: the template's range probe read the choices from
    "valid choices are [...]" but not from :func:`rvtool.validation.check_choice`'s "is not one of
    the valid choices [...]", so every key validated that way was offered as free text. Only the
    labels (``name``) are free text."""
    from rvtool.designs.format import key_table
    free = [(sec, key) for sec, key, value, unit, rng, meaning, required in key_table(topology) if rng == "text"]
    assert all(key == "name" for sec, key in free), free
    rows = {(sec, key): rng for sec, key, value, unit, rng, meaning, required in key_table(topology)}
    assert rows[("eccentric_bearing", "law")] == "one of ['power', 'linear']"
    assert rows[("eccentric_bearing", "slices")] == "one of ['laminae', 'influence']"


def test_results_and_sweep_tables_are_written_with_the_usual_file_mode(tmp_path):
    """Before: ``-rw------- results.json`` beside ``-rw-r--r-- report.html`` and the PNGs (the atomic
    write went through tempfile.mkstemp, which creates 0600 whatever the umask): a shared results
    folder or a web server could show the report but not its data. Now 0666 less the umask, as
    any file the run writes; no temporary file is left behind."""
    from rvtool.analysis.output import write_results
    from rvtool.variants.sweep import write_table
    mask = os.umask(0o022)
    try:
        write_results(str(tmp_path), {"passed": True})
        paths = write_table([{"a": 1.0, "b": 2.0}], str(tmp_path / "sweep"))
    finally:
        os.umask(mask)
    for p in [tmp_path / "results.json", *paths]:
        assert stat.S_IMODE(os.stat(p).st_mode) == 0o644, p
    assert sorted(os.listdir(tmp_path)) == ["results.json", "sweep"]
    assert sorted(os.listdir(tmp_path / "sweep")) == ["results.csv", "results.json"]


@pytest.mark.parametrize("name", ["rd40", "std_involute", "rv40e"])
def test_section_plot_says_what_its_arrows_and_circles_are(name):
    """Before: the report's section plot drew red and blue arrows with no legend entry and no scale
    (a reader could not tell a 200 N pin load from a 2 kN bearing load), the RV section had no
    legend at all, and the std-involute section drew each wheel's root circle in a colour of its
    own, unlabelled (five circles, two named). Then one arrow scale served every family: the
    2,247 N eccentric-bearing load of rd40 set it and the 231 N ring-pin arrows came out 1 mm long
    (0.9 % of the plot), hidden under the pins. Now every outline and contact family is in the
    legend, each wheel's circles share its colour, each family's largest force is drawn at the one
    key length (its legend entry names that force) and no arrow is longer than it."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.quiver import Quiver, QuiverKey

    from rvtool.model.reducer import FAMILY_ARROW_WORDS, SMALL_FAMILY_FLOOR
    from rvtool.solver.static import StaticSolver
    d = rvtool.load_design(name)
    m = rvtool.build(d)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    fig, ax = plt.subplots()
    try:
        m.draw_section(ax, q)
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert {"wheel 0", "wheel 1"} <= {lb.split(",")[0] for lb in labels}
        keys = [a for a in ax.get_children() if isinstance(a, QuiverKey)]
        assert len(keys) == 1
        length = keys[0].U
        assert keys[0].text.get_text() == f"{length * 1e3:.3g} mm"
        quivers = {a.get_label().split(":")[0]: a for a in ax.get_children() if isinstance(a, Quiver)}
        peaks = m.family_peaks(q)
        assert set(quivers) == {FAMILY_ARROW_WORDS[f] for f in m.families}
        largest = max(peaks[f.value] for f in m.families)
        if name == "rv40e":     # its main bearings (22 N) lie below the floor: drawn short, not at the key length
            assert any(0 < peaks[f.value] < SMALL_FAMILY_FLOOR * largest for f in m.families)
        for fam in m.families:
            words, peak = FAMILY_ARROW_WORDS[fam], peaks[fam.value]
            ref = max(peak, SMALL_FAMILY_FLOOR * largest)
            assert (f"{words}: {ref:.4g} N per {length * 1e3:.3g} mm" if ref > 0 else f"{words}: no load") in labels
            drawn = np.hypot(quivers[words].U, quivers[words].V)
            # the family's own scale: its largest force at the key length (rounding only), unless it lies
            # below the floor: then shorter in proportion, never blown up to the key length
            assert peak == 0 or np.max(drawn) == pytest.approx(length * peak / ref, rel=1e-9), words
        x, y = ax.get_xlim(), ax.get_ylim()
        extent = max(x[1] - x[0], y[1] - y[0])
        main = np.hypot(quivers[FAMILY_ARROW_WORDS[m.main_mesh]].U, quivers[FAMILY_ARROW_WORDS[m.main_mesh]].V)
        # a main-mesh arrow a reader sees (the single-scale plot drew rd40's at 0.9 % of the extent),
        # none past a fifth of the plot
        assert 0.05 * extent <= np.max(main) and length <= 0.2 * extent
        drawn = [ln for ln in ax.get_lines()]
        unlabelled = {ln.get_color() for ln in drawn if ln.get_label().startswith("_")}
        labelled = {ln.get_color() for ln in drawn if not ln.get_label().startswith("_")}
        assert unlabelled <= labelled          # every outline's colour is in the legend
    finally:
        plt.close(fig)


def test_run_prints_the_case_verdict(tmp_path, monkeypatch, capsys):
    """Before: ``rvtool run hard_rd40 --quick`` printed only ``results written to ...``: whether the
    case passed its own criteria was in results.json alone."""
    from rvtool import cli
    folder = tmp_path / "cases" / "hard"
    folder.mkdir(parents=True)
    for name, passed in (("good", True), ("bad", False)):
        (folder / f"{name}.py").write_text(
            f'"""A case that writes passed = {passed}."""\n'
            "from rvtool import casekit\n\n\n"
            "def main(argv=None):\n"
            "    args = casekit.parse_args(argv, __doc__)\n"
            f"    return casekit.write_results(args.out, {{'passed': {passed}}})\n")
    monkeypatch.setenv(cli.CASES_ENV, str(tmp_path / "cases"))
    assert cli.main(["run", "good", "--out", str(tmp_path / "g")]) == 0
    assert "good: passed = true" in capsys.readouterr().out
    assert cli.main(["run", "bad", "--out", str(tmp_path / "b")]) == 0
    assert "bad: passed = false" in capsys.readouterr().out


def test_hard_case_plot_labels_do_not_overlap_the_neighbouring_panel(tmp_path, monkeypatch):
    """Before: hard_<case>.png (``rvtool run hard_rd40``) had the pin-force and kinetic-energy y
    labels drawn over the panel to their left (three panels, no layout engine), and no title."""
    import matplotlib
    matplotlib.use("Agg")
    from rvtool import casekit
    figs = []
    monkeypatch.setattr(casekit, "save_figure", lambda fig, out, name: figs.append(fig))
    casekit.hard_case("stiff100", rvtool.load_design("rd40"), True, str(tmp_path))
    (fig,) = figs
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    ax = fig.axes
    for left, right in zip(ax, ax[1:]):
        assert right.yaxis.label.get_window_extent(r).x0 >= left.get_window_extent(r).x1
    assert "stiff100" in fig.get_suptitle()


def test_pressure_and_vibration_plots_say_what_they_show(tmp_path, monkeypatch):
    """Before: the pressure plot's axis read ``x [um]`` and its title ``N = 513`` (neither said what
    x or N is, nor which contact is drawn); the vibration plot's right panel had an unlabelled red
    line and neither panel a title."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rvtool.analysis import output
    figs = {}

    def keep(fig, out_dir, name):
        figs[name] = [(a.get_xlabel(), a.get_ylabel(), a.get_title(),
                       [t.get_text() for t in (a.get_legend().get_texts() if a.get_legend() else [])])
                      for a in fig.axes]
        plt.close(fig)
        return str(tmp_path / f"{name}.png")
    monkeypatch.setattr(output, "save_figure", keep)
    rvtool.analyze("rv40e", "vibration,pressure", quick=True, out_dir=str(tmp_path))
    ((xlabel, ylabel, title, _),) = figs["pressure"]
    assert xlabel == "x, across the contact from its centre [\u00b5m]" and ylabel == "contact pressure [MPa]"
    assert title.startswith("highest-pressure pin contact per wheel at 412") and title.endswith("panels)")
    left, right = figs["vibration"]
    assert left[2] and right[2]
    assert "mesh" in right[3] and {"dynamic", "quasi-static"} <= set(right[3])


def test_monte_carlo_plot_counts_whole_variants():
    """Before: the Monte Carlo histograms of ``rvtool analyze rd40 --quick`` (4 variants) had the count
    axis ticked 0.25, 0.5, 1.75 ... variants and said nowhere how many variants they hold.
    (The p95 row's ``[11.917479595648889, None] (None: too few variants)`` is checked in
    tests/test_monte_carlo_topologies.py, which runs the protocol.)"""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rvtool.analysis.protocols import monte_carlo_histograms
    records = [{"status": "ok", "te_pp_arcsec": te, "lost_motion_arcmin": lm}
               for te, lm in ((8.4, 4.5), (11.1, 4.9), (12.0, 5.3), (12.3, 5.9))] + [{"status": "failed"}]
    fig = monte_carlo_histograms(records)
    try:
        fig.canvas.draw()
        for a in fig.axes:
            lo, hi = a.get_ylim()
            ticks = [t for t in a.get_yticks() if lo <= t <= hi]
            assert len(ticks) >= 2 and all(float(t).is_integer() for t in ticks), ticks
            assert a.get_title() == "4 of 5 variants" and a.get_ylabel() == "variants [-]"
    finally:
        plt.close(fig)


@pytest.mark.parametrize("topology, r_z", [("cycloid", "0.05"), ("rv2", "0.064")])
def test_profile_offset_that_removes_the_pin_circle_names_the_key(topology, r_z, tmp_path):
    """Before: ``profile.offset_mod = -0.05`` (= -R_z, "valid: any finite number" in the template)
    was accepted; the profile's pin circle R_z + delta_off = 0 divided by zero (RuntimeWarnings, a NaN
    profile). Now an error naming the key and (-R_z, inf), and the template says so."""
    from rvtool.designs.format import key_table
    table = tomllib.loads(template(topology, name="mine"))
    table["profile"]["offset_mod"] = -float(r_z)
    with pytest.raises(RvtoolInputError, match=rf"^profile\.offset_mod = -{r_z} is outside the valid range \(-{r_z}, inf\)"):
        _load(tmp_path, table)
    rows = {(sec, key): rng for sec, key, value, unit, rng, meaning, required in key_table(topology)}
    assert rows[("profile", "offset_mod")] == f"(-{r_z}, inf)"


def test_gear_shifts_without_a_working_pressure_angle_name_the_keys(tmp_path):
    """Found by tests/test_design_fuzz.py's in-range template fuzz once the template's ranges grew:
    ``crank_gear.profile_shift = -2.0`` (inside its own range [-2, 2]) stopped with
    ``inv(alpha) = -0.0043 has no solution; valid range [0, inf)``, naming no key. The zero-backlash
    pair bounds the sum of the two shifts; the error names both keys and that bound."""
    table = tomllib.loads(template("rv2", name="mine"))
    table["crank_gear"]["profile_shift"] = -2.0
    with pytest.raises(RvtoolInputError, match=r"^sun_gear\.profile_shift \+ crank_gear\.profile_shift = -1\.9 is outside "
                                               r"the valid range \(-1\.47418, inf\) for z = 18 and 54"):
        _load(tmp_path, table)
