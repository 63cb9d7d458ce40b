"""TE over the output revolution in resumable units (issue 30, Deliver 3; rvtool.analysis.te_revolution): the
chunked TE equals one warm-started run, units are keyed by their inputs, resume keeps them, a deadline stops new
ones."""
import time

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.analysis import te_revolution as TR
from rvtool.analysis import validate_te as VT
from rvtool.analysis.workunits import folder_runner
from rvtool.protocols.precision import quasi_static_te
from rvtool.units import ARCSEC_PER_RAD
from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design


def test_orders_pick_the_harmonics_of_one_period():
    """A curve of orders 1 and 40 (amplitudes 0.5 and 3 arcsec) over one period of 3120 points."""
    x = np.arange(3120) / 3120 * 2 * np.pi
    o = TR.orders(0.5 * np.sin(x + 0.3) + 3.0 * np.cos(40 * x) + 7.0, top=2)
    assert o["order1_arcsec"] == pytest.approx(0.5, rel=1e-9)
    assert [k for k, _ in o["top_orders"]] == [40, 1] and o["top_orders"][0][1] == pytest.approx(3.0, rel=1e-9)


def test_chunks_cover_the_grid_in_order():
    assert TR.chunks(3120, 800) == [(0, 780), (780, 1560), (1560, 2340), (2340, 3120)]
    assert TR.chunks(5, 800) == [(0, 5)]
    c = TR.chunks(1001, 100)
    assert c[0][0] == 0 and c[-1][1] == 1001 and all(a[1] == b[0] for a, b in zip(c, c[1:]))
    assert max(b - a for a, b in c) <= 100


def test_unit_keys_follow_the_inputs_not_the_position():
    d = rvtool.load_design("rv80e")
    spec = load_rv_tolerances(designs.path("rv80e_tolerances"))
    a, _ = sample_rv_design(spec, d, 0, VT.SEED)
    b, _ = sample_rv_design(spec, d, 0, VT.SEED)         # the same draw again
    c, _ = sample_rv_design(spec, d, 1, VT.SEED)
    k = TR.design_digest(a, torque=78.4, step=0.3)
    assert TR.design_digest(b, torque=78.4, step=0.3) == k
    assert len({k, TR.design_digest(c, torque=78.4, step=0.3), TR.design_digest(a, torque=78.5, step=0.3),
                TR.design_digest(a, torque=78.4, step=0.31), TR.design_digest(d, torque=78.4, step=0.3)}) == 5
    assert TR.unit_key(k, 0, 10) != TR.unit_key(k, 10, 20)


def test_unit_keys_are_portable_and_pinned(monkeypatch):
    """The plan of te_measured_rv80e's full mode (the output revolution, 16 variants, one draw per field, the
    resolution job) gives 140 unit keys that (1) do not move with the last bits of a computed float: the GPU host
    computed the angle step 0.3081177410251525 where this machine computes 0.30811774102515266 at the same commit,
    and before the digest rounded its floats (te_revolution.PORTABLE_DIGITS) no unit solved on the host was found
    here; (2) are pinned (the SHA-256 of their sorted names, <key>.pkl, joined by newlines): a change of the digest,
    of the job list or of the chunking makes stored units unreachable and must be deliberate. The committed
    results.json carries the inputs digest the full `rvtool validate` checks before it takes the TE rows from
    there: equal to this plan's where the committed run used the grades rv80e_measured.toml records (its
    tolerances_commit), else validate refuses the stale rows."""
    import hashlib
    import json
    from pathlib import Path

    from rvtool.designs.measured import load_measured
    committed = json.loads((Path(__file__).resolve().parents[1] / "docs" / "case_results" / "rv" /
                            "te_measured_rv80e" / "results.json").read_text())["settings"]
    d = rvtool.load_design("rv80e")
    plan = TR.plan_revolution("rv80e", d, d.rated_torque, variants=16, draws=1)
    keys = sorted(key for j in plan["jobs"] for key, _, _ in j["units"])
    assert len(keys) == 140
    assert hashlib.sha256("\n".join(keys).encode()).hexdigest() == PINNED_PLAN_KEYS
    job = plan["jobs"][0]
    ulp = np.nextafter(job["step"], 1.0)
    assert ulp != job["step"]
    assert TR.design_digest(job["design"], torque=job["torque"], step=ulp) == job["digest"]
    assert TR.design_digest(job["design"], torque=job["torque"], step=job["step"] * (1 + 1e-9)) != job["digest"]
    if committed["tolerances_commit"] == load_measured("rv80e_measured").tolerances_commit:
        assert plan["settings"]["inputs_digest"] == committed["inputs_digest"]
        assert plan["settings"]["units"] == committed["units"] and plan["settings"]["jobs"] == committed["jobs"]
    else:
        assert plan["settings"]["inputs_digest"] != committed["inputs_digest"]


PINNED_PLAN_KEYS = "121739e127f46b6b11dfeeebc363d07401d93ba7bacdb748d517540a5bb206e4"


def test_chunked_te_equals_one_run_and_resumes(tmp_path):
    """rv80e variant 0 over one input revolution at 2 points per mesh (20 points) in 3 units, each started cold:
    the TE formed from the units equals one warm-started run (the equilibrium is unique under the load; 1e-4
    arcsec is 5e-10 rad, the static solver's tolerance scale); a second store resumes every unit, and a deadline
    already past starts none."""
    d = rvtool.load_design("rv80e")
    dv, _ = sample_rv_design(load_rv_tolerances(designs.path("rv80e_tolerances")), d, 0, VT.SEED)
    model = rvtool.build(dv)
    torque = VT.TE_TORQUE_FRACTION * d.rated_torque
    job = TR.make_job("v0", dv, torque=torque, mesh_period=model.mesh_period, points_per_mesh=2, input_revolutions=1,
                      chunk_points=7)
    assert job["n"] == 20 and len(job["units"]) == 3
    with folder_runner(str(tmp_path / "a")) as store:
        st = TR.run_units([job], store, log=lambda *_: None)
    assert st["solved"] == 3 and st["failed"] == 0 and not st["stopped_by_deadline"]
    te = TR.job_te(job, store)
    ref = quasi_static_te(model, torque=torque, input_angles=np.arange(20) * job["step"])["te"] * ARCSEC_PER_RAD
    assert te["status"] == "ok" and np.max(np.abs(te["te_arcsec"] - ref)) < 1e-4
    assert te["pp_arcsec"] > 0.1      # a variant's TE, not a constant
    again = folder_runner(str(tmp_path / "b"), resume=[str(tmp_path / "a")])
    st = TR.run_units([job], again, log=lambda *_: None)
    assert st["kept"] == 3 and st["solved"] == 0 and len(list((tmp_path / "b" / "units").iterdir())) == 3
    assert TR.job_te(job, again)["pp_arcsec"] == te["pp_arcsec"]
    late = folder_runner(str(tmp_path / "c"), deadline=time.time() - 1)
    st = TR.run_units([job], late, log=lambda *_: None)
    assert st["not_started"] == 3 and st["stopped_by_deadline"] and TR.job_te(job, late)["status"] == "missing"


def test_case_full_mode_writes_a_judged_result(tmp_path):
    """The full mode of te_measured_rv80e end to end on a shortened grid (0.2 input revolutions: 4 points per job;
    the nominal design, variant 0 and variant 0 at 4 points per mesh): rows, resolution, complete and the plots;
    a resumed second call solves nothing."""
    import json

    from rvtool import casekit
    case = casekit.import_case("rv/te_measured_rv80e")
    argv = ["--variants", "1", "--sensitivity", "0", "--input-revolutions", "0.2"]
    r = case.main(argv + ["--out", str(tmp_path / "a")])
    assert r["complete"] and r["jobs_total"] == 3 and r["n_failed"] == 0
    assert r["records"][0]["te_pp_arcsec"] > r["nominal_pp_arcsec"] > 0
    assert r["resolution"]["pp_arcsec"][0] == r["records"][0]["te_pp_arcsec"]
    assert {"complete", "resolution_error", "no_failed_variant"} <= set(r["checks"])
    assert r["orders_per"] == "run of 0.2 input revolutions" and r["records"][0]["order1_arcsec"] >= 0
    assert all((tmp_path / "a" / p).is_file() for p in r["plots"]) and "te_revolution.png" in r["plots"]
    again = case.main(argv + ["--resume", str(tmp_path / "a"), "--out", str(tmp_path / "b")])
    saved = json.loads((tmp_path / "b" / "results.json").read_text())
    assert again["units"]["solved"] == 0 and again["units"]["kept"] == 3 and saved["complete"] is True
    assert saved["records"][0]["te_pp_arcsec"] == r["records"][0]["te_pp_arcsec"]
    # validate's TE row (issue 30, Deliver 4): its full mode takes the case's results where the inputs digest
    # matches, else solves the same units (the same keys: the case's units folder serves it, nothing is solved)
    from rvtool.analysis.workunits import UnitRunner
    d = rvtool.load_design("rv80e")
    dg = TR.revolution_inputs_digest("rv80e", d, d.rated_torque, variants=1, input_revolutions=0.2)
    assert saved["settings"]["inputs_digest"] == dg
    assert dg != TR.revolution_inputs_digest("rv80e", d, d.rated_torque, variants=2, input_revolutions=0.2)
    kw = dict(variants=1, input_revolutions=0.2, log=lambda *_: None)
    hit = VT.te_comparison("rv80e", d, d.rated_torque, reuse=[str(tmp_path / "b" / "results.json")], **kw)
    assert hit["reused_from"]["path"].endswith("results.json") and hit["rows"] == saved["rows"]
    runner = UnitRunner(resume=[str(tmp_path / "a" / "units")], log=lambda *_: None)
    own = VT.te_comparison("rv80e", d, d.rated_torque, runner=runner, reuse=[str(tmp_path / "none.json")], **kw)
    assert runner.counts["reused"] == 2 and runner.counts["run"] == 0 and "reused_from" not in own
    assert own["rows"][0]["predicted"] == saved["rows"][0]["predicted"] and own["settings"]["inputs_digest"] == dg
    assert "model TE over 0.2 input revolutions" in own["rows"][0]["conditions"]
