"""`rvtool analyze` runs the tolerance Monte Carlo for every topology with a tolerance file (issue 27:
rv40e skipped it, "covers the cycloid topology"): the RV reducers (rvtool.variants.rv_tolerances)
and the small-tooth-difference involute reducer (rvtool.variants.std_tolerances) on the CPU design-
variant path; every shipped design ships its tolerance file."""
import math

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.analysis import analyze
from rvtool.variants.std_tolerances import load_std_tolerances, sample_std_design


def test_every_shipped_design_has_a_tolerance_file():
    for name in designs.design_names():
        assert designs.tolerances_of(name) is not None, name


@pytest.mark.parametrize("name", ["rv40e", pytest.param("rv_three_stage", marks=pytest.mark.slow), "std_involute"])
def test_monte_carlo_runs_for_the_topology(name, tmp_path):
    res = analyze(name, "monte_carlo", quick=True, out_dir=str(tmp_path))
    mc = res.to_dict()["monte_carlo"]
    assert mc["status"] == "ok", mc.get("reason")
    assert mc["settings"]["n_variants"] == 4 and mc["data"]["summary"]["n_failed"] == 0, mc["warnings"]
    figs = {f: v["value"] for f, v in mc["figures"].items()}
    for f in ("te_pp_mean", "lost_motion_mean", "max_contact_force_mean"):
        assert math.isfinite(figs[f]) and figs[f] > 0, (f, figs)
    # the p95 interval reads as numbers in the report (was "[11.917479595648889, None] (None: ...)")
    statement = mc["figures"]["te_pp_p95"]["error_statement"]
    assert "None" not in statement and "too few variants" in statement, statement
    # the nominal quick TE p-p of the te protocol lies inside the variants' spread or near it: the
    # deviations are micrometres, so the mean stays within a factor 3 of the nominal (a wrong unit in
    # a sampled deviation, e.g. arcmin read as rad, moves it by orders of magnitude)
    te = analyze(name, "te", quick=True, out_dir=str(tmp_path / "te")).to_dict()["te"]["figures"]["te_pp"]["value"]
    assert te / 3 < figs["te_pp_mean"] < 3 * te + 1.0, (te, figs["te_pp_mean"])


def test_std_sampler_is_seeded_and_closes_the_pitch_circle():
    design = rvtool.load_design("std_involute")
    spec = load_std_tolerances(designs.path("std_involute_tolerances"))
    d1, a = sample_std_design(spec, design, 3, 7)
    d2, b = sample_std_design(spec, design, 3, 7)
    assert a == b and d1 == d2
    assert d1.wheels.eccentricity == pytest.approx(design.wheels.eccentricity + a["eccentricity_error"], abs=1e-18)
    assert 3e-6 <= d1.eccentric_bearing.radial_clearance <= 8e-6
    _, c = sample_std_design(spec, design, 4, 7)
    assert c != a                                         # another variant, other draws
    from rvtool.variants.std_tolerances import StdToleranceSpec
    from rvtool.variants.tolerances import Normal
    _, p = sample_std_design(StdToleranceSpec(ring_pitch_deviation=Normal(std=1e-6)), design, 0, 1)
    assert len(p["ring_pitch_deviation"]) == design.ring.n_teeth
    assert abs(np.sum(p["ring_pitch_deviation"])) < 1e-18  # the pitches of a closed circle sum to zero
