"""Sweeps on Dask: spec loading, a grid with one deliberately failing task, the CLI, and the
Monte Carlo through a Dask executor (small LocalClusters with processes=False: fast)."""
import csv
import json
import os

import pytest

from rvtool import designs
from rvtool import cli
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.variants.montecarlo import MonteCarloSettings, run_monte_carlo
from rvtool.variants.sweep import load_sweep_spec, point_model, run_sweep
from rvtool.variants.tolerances import load_tolerances
from rvtool.variants import Variant, VariantProtocol, variant_figures

pytest.importorskip("dask.distributed")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DESIGNS = str(designs.HERE)
BUILD = {"regularization": (1.0e4, 100.0)}
FIGS = ("te_pp_arcsec", "te_rms_arcsec", "max_pin_force_N", "lost_motion_arcmin", "newton_iterations")


def _spec(tmp_path, body, head=""):
    path = tmp_path / "spec.toml"
    path.write_text(f'design = "{os.path.join(DESIGNS, "rd40.toml")}"\n' + head + body)
    return str(path)


SMALL = """
[protocol]
n_te_points = 23
[build]
regularization = [1.0e4, 100.0]
[cluster]
n_workers = 1
threads_per_worker = 1
processes = false
"""


def test_spec_loading(tmp_path):
    spec = load_sweep_spec(os.path.join(DESIGNS, "sweep_rd40.toml"))
    d = load_design(spec.design_path)
    pts = spec.points(d)
    assert len(pts) == 25 and pts[1] == {"eccentricity_error": -4e-6, "pin_clearance": 2.5e-6}
    assert spec.build["regularization"] == (1.0e4, 100.0)
    dd, v = point_model(d, {"eccentricity_error": 1e-6, "wheels.clearance": 2e-6})
    assert v == Variant(eccentricity_error=1e-6) and dd.wheels.clearance == 2e-6
    with pytest.raises(RvtoolInputError, match="unknown keys"):
        load_sweep_spec(_spec(tmp_path, 'colour = "red"\n[parameters]\npin_clearance = [0.0]\n'))
    bad = load_sweep_spec(_spec(tmp_path, '[parameters]\n"wheels.colour" = [0.0]\n'))
    with pytest.raises(RvtoolInputError, match="parameters.wheels.colour"):
        bad.points(d)
    with pytest.raises(RvtoolInputError, match="n_te_points"):
        load_sweep_spec(_spec(tmp_path, '[protocol]\nn_te_points = 1\n[parameters]\npin_clearance = [0.0]\n'))


def test_cli_sweep_with_failing_task(tmp_path):
    # point 1 is impossible (e + error < 0): its task fails, the sweep completes and marks its row
    path = _spec(tmp_path, SMALL + "[parameters]\neccentricity_error = [1e-6, -1e-3]\npin_clearance = [2e-6]\n")
    out = tmp_path / "out"
    assert cli.main(["sweep", path, "--out", str(out), "--quiet"]) == 0
    with open(out / "results.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows] == ["ok", "failed"]
    assert "eccentricity_error" in rows[1]["error"] and rows[1]["te_pp_arcsec"] == ""
    data = json.loads((out / "results.json").read_text())
    # the ok row is the reference protocol run directly on the same variant
    ref = variant_figures(load_design(os.path.join(DESIGNS, "rd40.toml")),
                          Variant(eccentricity_error=1e-6, pin_clearance=2e-6), VariantProtocol(n_te_points=23), **BUILD)
    for nm in FIGS:
        assert data[0][nm] == ref[nm]
    assert data[0]["wall_s"] > 0 and data[1]["status"] == "failed"


def test_cli_sweep_usage_errors(tmp_path, capsys):
    with pytest.raises(SystemExit):
        cli.main(["sweep", str(tmp_path / "missing.toml")])
    path = _spec(tmp_path, SMALL + "[parameters]\nnot_a_parameter = [1.0]\n")
    assert cli.main(["sweep", path, "--quiet"]) == cli.EXIT_USAGE
    assert "not_a_parameter" in capsys.readouterr().err


def test_monte_carlo_on_dask_equals_serial(tmp_path):
    # each Dask task is one variant; chunk files make it resumable exactly as the pool path
    path = _spec(tmp_path, SMALL + f'[monte_carlo]\ntolerances = "{os.path.join(DESIGNS, "rd40_tolerances.toml")}"\n'
                 f'n_variants = 2\nseed = 2\nchunk_size = 1\n', head='study = "monte_carlo"\n')
    res = run_sweep(load_sweep_spec(path), out_dir=str(tmp_path / "out"), progress=False)
    assert len(res["rows"]) == 2
    assert sorted(os.listdir(tmp_path / "out" / "chunks")) == ["chunk_00000.json", "chunk_00001.json"]
    d = load_design(os.path.join(DESIGNS, "rd40.toml"))
    ref = run_monte_carlo(d, load_tolerances(os.path.join(DESIGNS, "rd40_tolerances.toml")),
                          VariantProtocol(n_te_points=23), MonteCarloSettings(n_variants=2, seed=2, chunk_size=1,
                                                                             mode="serial"),
                          str(tmp_path / "serial"), build_kw=BUILD)
    # identical records, failed ones included (a failure is a deterministic result of the variant)
    assert any(r["status"] == "ok" for r in res["rows"])
    assert res["failed"] == ref["summary"]["n_failed"]
    for a, b in zip(res["rows"], ref["records"]):
        assert {k: v for k, v in a.items() if k != "wall_s"} == {k: v for k, v in b.items() if k != "wall_s"}
    # a second run of the same spec loads every chunk and runs nothing
    again = run_sweep(load_sweep_spec(path), out_dir=str(tmp_path / "out"), progress=False)
    assert [r["wall_s"] for r in again["rows"]] == [r["wall_s"] for r in res["rows"]]


def test_cli_sweep_on_existing_scheduler(tmp_path):
    from dask.distributed import LocalCluster
    path = _spec(tmp_path, SMALL + "[parameters]\npin_clearance = [1e-6]\n")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        out = tmp_path / "out"
        before = cluster.scheduler.transition_counter
        assert cli.main(["sweep", path, "--scheduler", cluster.scheduler_address, "--out", str(out), "--quiet"]) == 0
        # the sweep connected to this cluster: its scheduler moved the task through its states
        assert cluster.scheduler.transition_counter > before
    rows = json.loads((out / "results.json").read_text())
    assert len(rows) == 1 and rows[0]["status"] == "ok" and rows[0]["pin_clearance"] == 1e-6


def test_grid_device_mode_equals_point_mode(tmp_path):
    """grid.mode = "device": the points that share a design run their TE and lost motion in one
    device Newton batch; rows equal the per-point Exudyn rows (TE, max pin force and lost motion
    to 1e-6: both paths converge the same equilibria to |residual| <= 1e-6 N) and name the TE
    path. A bad grid key is an error naming it."""
    grid = '[parameters]\neccentricity_error = [0.0, 2e-6]\n"wheels.clearance" = [0.0, 1e-6]\n'
    pt = run_sweep(load_sweep_spec(_spec(tmp_path, SMALL + grid)), out_dir=str(tmp_path / "p"), progress=False)
    dv = run_sweep(load_sweep_spec(_spec(tmp_path, SMALL + grid + '[grid]\nmode = "device"\ndevice = "cpu"\n')),
                   out_dir=str(tmp_path / "d"), progress=False)
    assert len(dv["rows"]) == 4
    for a, b in zip(dv["rows"], pt["rows"]):
        assert a["status"] == b["status"] == "ok", (a["error"], b["error"])
        assert a["eccentricity_error"] == b["eccentricity_error"] and a["wheels.clearance"] == b["wheels.clearance"]
        assert abs(a["te_pp_arcsec"] - b["te_pp_arcsec"]) <= 1e-6
        assert abs(a["max_pin_force_N"] - b["max_pin_force_N"]) <= 1e-6
        assert abs(a["lost_motion_arcmin"] - b["lost_motion_arcmin"]) <= 1e-6
        assert a["te_path"] == "device_newton:cpu:host_loop" and a["te_fallback_points"] == 0
    with pytest.raises(RvtoolInputError, match="grid.mode"):
        load_sweep_spec(_spec(tmp_path, SMALL + grid + '[grid]\nmode = "fast"\n'))
