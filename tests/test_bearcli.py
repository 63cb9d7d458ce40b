"""``rvtool analyze --bearing-model``: a cycloid design that needs rolling-element bearings (influence
roller slices, spatial bodies) runs from the command line; the default builds as before (lumped)."""
import json
import os

import pytest

import rvtool
from rvtool.analysis.registry import Context
from rvtool.cli import EXIT_USAGE, main
from rvtool.errors import RvtoolInputError
from _design_files import load_table, template_table


def influence_design_file(tmp_path):
    """The cycloid template with influence-coefficient slices in its eccentric bearing (the lumped
    bearing refuses them by name): its path."""
    table = template_table("cycloid")
    table["eccentric_bearing"]["slices"] = "influence"
    load_table(tmp_path, table)
    return str(tmp_path / "mine.toml")


def test_rolling_option_reaches_the_builder(tmp_path, capsys):
    """Before: the design below was refused under `rvtool analyze` (lumped bearings, no option),
    with a message sending the user to Python. Without the option it still is, and the message now
    names the option; with ``--bearing-model rolling`` the stiffness protocol runs on the
    rolling-element bearings (~3 s, the smallest protocol)."""
    path = influence_design_file(tmp_path)
    out = str(tmp_path / "out")
    assert main(["analyze", path, "--protocols", "stiffness", "--quick", "--quiet", "--out", out]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert "slices = 'influence' needs bearing_model = 'rolling'" in err
    assert "--bearing-model rolling" in err
    assert main(["analyze", path, "--protocols", "stiffness", "--quick", "--quiet", "--out", out,
                 "--bearing-model", "rolling"]) == 0
    with open(os.path.join(out, "results.json")) as f:
        res = json.load(f)
    assert res["stiffness"]["status"] == "ok", res["stiffness"]["reason"]
    assert res["provenance"]["settings"]["bearing_model"] == "rolling"


def test_default_builds_as_before(tmp_path):
    """No ``bearing_model``: the builder's defaults, no keyword passed (so bit-identical to the
    analyses before the option); "rolling" gives other figures on the same laminae design (the
    option reaches the build, not only the influence check)."""
    design = load_table(tmp_path, template_table("cycloid"))
    assert Context(design, quick=True, out_dir=None).build_options() == {}
    ctx = Context(design, quick=True, out_dir=None, bearing_model="rolling")
    assert ctx.build_options() == {"bearing_model": "rolling"}
    # a protocol retried after a solver failure keeps the bearing model asked for
    assert ctx.guided_retry().build_options() == {"guided_free_play": True, "bearing_model": "rolling"}

    def figures(**kw):
        (r,) = rvtool.analyze(design, "stiffness", quick=True, **kw).results
        assert r.status == "ok", r.reason
        return {f.name: f.value for f in r.figures}

    default = figures()
    rolling = figures(bearing_model="rolling")
    # different bearing laws: the condensed stiffness differs by far more than round-off
    assert abs(rolling["Kt_condensed"] / default["Kt_condensed"] - 1.0) > 1e-6


@pytest.mark.parametrize("value", ["ball", "Rolling", ""])
def test_bad_value_names_the_option_and_choices(value, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["analyze", "rd40", "--protocols", "stiffness", "--quick", "--quiet", "--out", str(out),
                 "--bearing-model", value]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert f"--bearing-model / bearing_model = {value!r} is not one of the valid choices ['lumped', 'rolling']" in err
    assert not out.exists()                     # refused before anything is written
    with pytest.raises(RvtoolInputError, match=r"bearing_model = 'ball' is not one of the valid choices"):
        rvtool.analyze("rd40", "stiffness", quick=True, bearing_model="ball")


def test_rv_design_has_no_bearing_model_choice(tmp_path, capsys):
    assert main(["analyze", "rv40e", "--protocols", "stiffness", "--quick", "--quiet",
                 "--out", str(tmp_path / "out"), "--bearing-model", "rolling"]) == EXIT_USAGE
    assert "RVDesign builder has no bearing model choice" in capsys.readouterr().err


def test_monte_carlo_with_rolling_bearings_runs_one_model_per_variant():
    """The Monte Carlo's batched and device modes build lumped bearings only: with "rolling" auto
    takes one Exudyn model per variant (the pool) and names why not the others; a backend asked for
    by name that builds lumped bearings skips the protocol with the reason. Without the option the
    choice is today's (the batched system on a CPU)."""
    from rvtool.analysis.protocols import _mc_backend
    from rvtool.analysis.registry import Unsupported
    rd40 = rvtool.load_design("rd40")
    assert _mc_backend(Context(rd40, quick=True, out_dir=None))[0] == "batched"
    mode, choice = _mc_backend(Context(rd40, quick=True, out_dir=None, bearing_model="rolling"))
    assert mode == "pool" and choice["ran"] == "exudyn"
    assert all("--bearing-model rolling" in choice["not_taken"][b] for b in ("device", "fused", "replica"))
    with pytest.raises(Unsupported, match="--bearing-model rolling: the replica Monte Carlo builds lumped"):
        _mc_backend(Context(rd40, quick=True, out_dir=None, backend="replica", bearing_model="rolling"))
