"""The device Monte Carlo over several devices of one host (rvtool.variants.multi_device): worker
slots and their CUDA_VISIBLE_DEVICES, the per-device batches, and two cpu workers giving the
records of one worker (the device copies are independent: equal to 1e-12)."""
import os

import numpy as np
import pytest
import warp as wp

import rvtool
from rvtool import designs
from rvtool.errors import RvtoolInputError
from rvtool.variants.multi_device import (RvVariantProtocol, batch_task, chunk_schedule, cycloid_batch,
                                          device_cluster, device_slots, multi_device_monte_carlo, plan, rows_batch,
                                          shutdown_helper_pools, split_indices, start_helper_pool, warm_helper_builds,
                                          warm_up)
from rvtool.variants.rv_tolerances import load_rv_tolerances
from rvtool.variants.tolerances import load_tolerances
from rvtool.variants.variant import VariantProtocol

FIGS = ("te_pp_arcsec", "te_rms_arcsec", "lost_motion_arcmin")
EQUAL = 1e-12
EQUAL_CUDA = 1e-9   # cuda row sums are atomic adds in varying order (3.9e-12 seen on 2x H200): the equilibrium bound
"""Relative bound of the one-worker / two-worker comparison: the same copies on the same device
(cpu), computed from the same inputs; only summation order inside a launch could differ."""


def _env_of_worker():
    return os.environ.get("CUDA_VISIBLE_DEVICES")


def test_slots_pin_one_gpu_per_worker():
    s = device_slots(2)
    assert [x.env["CUDA_VISIBLE_DEVICES"] for x in s] == ["0", "1"]
    assert {x.device for x in s} == {"cuda:0"}          # each worker sees its one GPU as cuda:0
    s = device_slots(["cuda:3", "cpu"])
    assert s[0].env == {"CUDA_VISIBLE_DEVICES": "3"} and s[1].env == {"CUDA_VISIBLE_DEVICES": ""}
    assert s[1].device == "cpu"
    for bad in (0, [], "cuda:0", ["cuda:0", "cuda:0"], ["gpu1"], ["cuda:x"]):
        with pytest.raises(RvtoolInputError):
            device_slots(bad)


def test_the_collector_is_paused_while_snapshots_are_received_and_restored_after():
    """paused_collector (rows_batch and bench_device_mc receive their snapshots inside it): the cyclic
    collector is off inside, back on after (also when the block raises), and left off where it was off."""
    import gc
    from rvtool.variants.multi_device import paused_collector
    assert gc.isenabled()
    with paused_collector():
        assert not gc.isenabled()
    assert gc.isenabled()
    with pytest.raises(ValueError):
        with paused_collector():
            raise ValueError("inside")
    assert gc.isenabled()
    gc.disable()
    try:
        with paused_collector():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_batches_cover_every_variant_once_in_order():
    for n, k in ((7, 2), (8192, 2), (3, 4), (1, 1)):
        b = split_indices(n, k)
        assert [i for r in b for i in r] == list(range(n))
        assert max(map(len, b)) - min(map(len, b)) <= 1
    s = device_slots(["cpu", "cpu"])
    p = plan(10, s, chunk=3)
    assert [(x.name, list(r)) for x, r in p] == [("device-0", [0, 1, 2]), ("device-0", [3, 4]),
                                                ("device-1", [5, 6, 7]), ("device-1", [8, 9])]
    with pytest.raises(RvtoolInputError):
        plan(10, s, chunk=0)


def _same(a, b, bound=EQUAL):
    assert [r["index"] for r in a] == [r["index"] for r in b]
    for x, y in zip(a, b):
        assert x["status"] == y["status"], (x["index"], x["error"], y["error"])
        if x["status"] != "ok":
            continue
        for f in FIGS:
            assert abs(x[f] - y[f]) <= bound * abs(y[f]), (x["index"], f, x[f], y[f])


@pytest.fixture(scope="module")
def rd40_case():
    rd40 = rvtool.load_design("rd40")
    tol = load_tolerances(designs.path("rd40_tolerances"))
    p = VariantProtocol(n_te_points=7)
    return rd40, tol, p, cycloid_batch(rd40, tol, p, 2026, range(2), "cpu")


RD_BUILD = {"bearing_model": "lumped", "regularization": (1.0e4, 100.0)}
"""RD-40's study build options (cases/cycloid/monte_carlo_te.py's REGULARIZATION, as bench_device_mc)."""


def test_two_cpu_workers_equal_one(rd40_case):
    """RD-40 and rv40e on the device row Newton (the path of bench_device_mc), TE + lost motion:
    the records of two cpu workers, each its batch, its variants built on its helper pool, equal
    those of one batch run here (built here); every worker starts with CUDA_VISIBLE_DEVICES set by
    its slot (cpu: "", no GPU visible)."""
    rd40, rd_tol, rd_p, _ = rd40_case
    # RD-40 with its profile tables computed by the worker (the benchmarks' --tables device): the
    # helper sends profiles, the worker's device computes the tables
    ref_rd = rows_batch(rd40, rd_tol, rd_p, 2026, range(2), "cpu", build_kw=RD_BUILD, tables="device")
    rv40e = rvtool.load_design("rv40e")
    rv_tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    rv_p = RvVariantProtocol(n_te_points=3)
    ref_rv = rows_batch(rv40e, rv_tol, rv_p, 20261124, range(2), "cpu")
    assert sum(r["status"] == "ok" for r in ref_rd) >= 1 and all(r["status"] == "ok" for r in ref_rv)
    assert {r["lost_motion_path"] for r in ref_rd + ref_rv} == {"device_rows:cpu"}
    with device_cluster(["cpu", "cpu"]) as (client, slots):
        env = client.run(_env_of_worker)
        assert sorted(env.values()) == ["", ""] and len(env) == 2
        # host_workers=1: each worker's host work on a helper process of its own (as on a GPU host;
        # the workers are non-daemonic so that they may start it), started ahead as warm_up does
        addrs = list(env)
        assert client.gather([client.submit(start_helper_pool, 1, workers=[a], pure=False) for a in addrs]) == [1, 1]
        rd = multi_device_monte_carlo(rd40, rd_tol, 2, protocol=rd_p, seed=2026, client=client, slots=slots,
                                      host_workers=1, build_kw=RD_BUILD, tables="device", solve_chunk=None)
        rv = multi_device_monte_carlo(rv40e, rv_tol, 2, protocol=rv_p, seed=20261124, client=client, slots=slots)
    assert [b["worker"] for b in rd["batches"]] == ["device-0", "device-1"]
    assert rd["failed"] == sum(r["status"] != "ok" for r in ref_rd) and rd["host_workers"] == 1
    assert rd["path"] == "rows" and {r["te_path"] for r in rd["records"]} == {"device_rows:cpu"}
    _same(rd["records"], ref_rd)
    _same(rv["records"], ref_rv)
    assert rv["failed"] == 0


def test_rows_batch_is_the_bench_device_mc_path(rd40_case):
    """rows_batch (helpers building the snapshots) gives the figures and failures of the direct call
    bench_device_mc makes: the variants sampled and built with the study's options, one
    device_rows_variants of them (same TE angles, torque and lost-motion level)."""
    from rvtool.batched.device_rows_variants import device_rows_variants
    from rvtool.units import ARCMIN_PER_RAD, ARCSEC_PER_RAD
    from rvtool.variants.tolerances import sample_variant
    rd40, tol, p, _ = rd40_case
    try:
        # the helpers warmed as warm_up does: each of the two runs the build task on the nominal design
        # exactly once (a barrier of the pool), not one of them twice
        assert start_helper_pool(2) == 2 and warm_helper_builds(rd40, RD_BUILD, 2) == 2
        recs = rows_batch(rd40, tol, p, 2026, [3, 4], "cpu", 2, build_kw=RD_BUILD, solve_chunk=1)
    finally:
        shutdown_helper_pools()                   # the helper processes this test started
    models = [rvtool.build(sample_variant(tol, rd40, k, 2026).apply(rd40), **RD_BUILD) for k in (3, 4)]
    r = device_rows_variants(models, torque=rd40.rated_torque, input_angles=p.input_angles(rd40),
                             lost_motion_level=0.03 * rd40.rated_torque, device="cpu")
    assert [x["index"] for x in recs] == [3, 4] and [x["status"] for x in recs] == r.status
    for c, x in enumerate(recs):
        if x["status"] == "ok":
            assert abs(x["te_pp_arcsec"] - np.ptp(r.te[c]) * ARCSEC_PER_RAD) <= EQUAL * x["te_pp_arcsec"]
            lm = r.lost_motion_rad[c] * ARCMIN_PER_RAD
            assert abs(x["lost_motion_arcmin"] - lm) <= EQUAL * abs(lm)
    assert sum(x["device_s"] > 0 for x in recs) == 2        # solve_chunk=1: one device solve per variant


def test_ramped_solves_give_the_records_of_full_chunks(rd40_case):
    """A worker's first device solve of a few copies, the next ones doubling (chunk_schedule), gives
    the records of solves of whole chunks bit for bit on cpu (the copies are independent: the
    chunks only decide when the device starts); each solve's first record carries its build wait,
    the batch's first record the time to its first device solve."""
    rd40, tol, p, _ = rd40_case
    assert chunk_schedule(4096, 1024) == [128, 256, 512, 1024, 1024, 1024, 128]
    assert chunk_schedule(5, 4, 4) == [4, 1] and chunk_schedule(5, 4, 1) == [1, 2, 2] and chunk_schedule(0, 4) == []
    for bad in ((4, 0, None), (4, 2, 0), (4, True, None), (4, 2, 1.5)):
        with pytest.raises(RvtoolInputError, match="valid range"):
            chunk_schedule(*bad)
    idx = [5, 6, 7, 8, 9]
    full = rows_batch(rd40, tol, p, 2026, idx, "cpu", build_kw=RD_BUILD, solve_chunk=4, first_chunk=4)
    ramp = rows_batch(rd40, tol, p, 2026, idx, "cpu", build_kw=RD_BUILD, solve_chunk=4, first_chunk=1)
    assert sum(r["status"] == "ok" for r in full) >= 3
    keys = ("index", "status", "error", "te_path", "lost_motion_path") + FIGS
    assert [[r[k] for k in keys] for r in ramp] == [[r[k] for k in keys] for r in full]     # bit for bit
    assert [r["index"] for r in ramp if "build_wait_s" in r] == [5, 6, 8]      # solves of 1, 2, 2 copies
    assert [r["index"] for r in full if "build_wait_s" in r] == [5, 9]
    assert 0 <= ramp[0]["first_device_start_s"] <= sum(r["wall_s"] for r in ramp)


def test_paths_refused_by_name():
    with pytest.raises(RvtoolInputError, match="valid"):
        batch_task(rvtool.load_design("rd40"), "exudyn")
    with pytest.raises(RvtoolInputError, match="cycloid designs only"):
        batch_task(rvtool.load_design("rv40e"), "device_newton")
    assert batch_task(rvtool.load_design("rd40")) is rows_batch


def test_monte_carlo_study_on_two_devices(rd40_case, tmp_path):
    """The resumable study (run_monte_carlo, mode "device") with settings.devices: its chunks on two
    cpu workers give the one-batch records; mixed or non-device settings are refused by name."""
    from rvtool.variants.montecarlo import MonteCarloSettings, run_monte_carlo
    rd40, tol, p, ref = rd40_case
    out = run_monte_carlo(rd40, tol, p, MonteCarloSettings(n_variants=2, seed=2026, chunk_size=1, mode="device",
                                                            devices=("cpu", "cpu")), str(tmp_path))
    assert out["device"] == "cpu x 2" and out["chunks_run"] == 2
    _same(out["records"], ref)
    with pytest.raises(RvtoolInputError, match="mixes cpu and cuda"):
        MonteCarloSettings(n_variants=2, mode="device", devices=("cpu", "cuda:0"))
    with pytest.raises(RvtoolInputError, match="runs the device mode"):
        MonteCarloSettings(n_variants=2, mode="pool", devices=2)


def test_workers_start_with_their_gpu_visible_only():
    """The environment pinning itself, without a GPU: slots for cuda:0 and cuda:1 start workers
    whose CUDA_VISIBLE_DEVICES are "0" and "1" (set before any task, so before Warp initialises)."""
    with device_cluster(["cuda:0", "cuda:1"]) as (client, slots):
        env = client.run(_env_of_worker)
        names = {w["name"]: a for a, w in client.scheduler_info()["workers"].items()}
    assert {env[names[s.name]] for s in slots} == {"0", "1"}
    assert env[names["device-0"]] == "0" and env[names["device-1"]] == "1"


def _cuda_seen():
    import warp
    warp.init()
    return [d.uuid for d in warp.get_cuda_devices()], os.environ.get("CUDA_VISIBLE_DEVICES")


@pytest.mark.skipif(wp.get_cuda_device_count() < 2, reason="needs two CUDA devices")
def test_cuda_two_gpus_each_worker_sees_one():
    """cuda: each worker sees exactly one GPU, and the RD-40 records of two GPUs equal one GPU's."""
    rd40 = rvtool.load_design("rd40")
    tol = load_tolerances(designs.path("rd40_tolerances"))
    p = VariantProtocol(n_te_points=7)
    with device_cluster(2) as (client, slots):
        seen = client.run(_cuda_seen)
        assert all(len(v[0]) == 1 for v in seen.values()) and {v[1] for v in seen.values()} == {"0", "1"}
        assert len({v[0][0] for v in seen.values()}) == 2          # two different GPUs
        opts = {"build_kw": RD_BUILD, "tables": "device", "graph": True}     # bench_multi_gpu's defaults
        warm_up(client, slots, rd40, tol, p, 2026, **opts)
        two = multi_device_monte_carlo(rd40, tol, 8, protocol=p, seed=2026, client=client, slots=slots,
                                       solve_chunk=2, first_chunk=1, **opts)
        one = multi_device_monte_carlo(rd40, tol, 8, protocol=p, seed=2026, client=client, slots=slots[:1],
                                       solve_chunk=None, **opts)
    _same(two["records"], one["records"], EQUAL_CUDA)
    assert {r["te_path"] for r in two["records"] if r["status"] == "ok"} == {"device_rows:cuda:0"}
    assert np.isfinite([r["te_pp_arcsec"] for r in two["records"] if r["status"] == "ok"]).all()


def test_failed_builds_are_failed_variants():
    """A chunk whose variant could not be built: the built ones keep their solved figures and status in
    place, the others are failed with their build error and NaN figures (never dropped); a chunk with
    none built is all failed."""
    from rvtool.batched.device_rows_variants import RowVariants
    from rvtool.variants.device_pipeline import merge_chunks, with_failed_builds
    split = {"setup_s": 1.0, "kernels_s": 0.0, "scatter_s": 0.0, "step_s": 2.0, "fallback_s": 0.0, "rest_s": 0.0}
    part = RowVariants(te=np.array([[1.0, 2.0], [3.0, 4.0]]), theta_out=np.zeros((2, 2)),
                       lost_motion_rad=np.array([5.0, 6.0]), status=["ok", "failed"], error=[None, "device"],
                       exudyn_points=1, exudyn_copies=0, split=split, te_s=1.0, lost_motion_s=1.0, wall_s=3.0,
                       stats={"points": 2, "te_order": "phase", "sweeps": 3, "newton_iterations": 4,
                              "device": "cpu", "device_sum": False, "lost_motion": {}})
    r = with_failed_builds(part, [True, False, True], ["ValueError: bad draw"], 2)
    assert r.status == ["ok", "failed", "failed"] and r.error == [None, "build: ValueError: bad draw", "device"]
    assert np.array_equal(r.te[[0, 2]], part.te) and np.isnan(r.te[1]).all() and np.isnan(r.lost_motion_rad[1])
    none = with_failed_builds(None, [False], ["x"], 2)
    assert none.status == ["failed"] and none.wall_s == 0.0 and np.isnan(none.te).all()
    m = merge_chunks([r, none], 4)
    assert m.status == ["ok", "failed", "failed", "failed"] and m.te.shape == (4, 2)
    assert m.exudyn_points == 1 and m.split["step_s"] == 2.0 and m.stats["chunks"] == 2


def _bench_multi_gpu():
    import importlib.util
    from pathlib import Path
    path = Path(__file__).resolve().parents[1] / "cases" / "benchmarks" / "bench_multi_gpu.py"
    spec = importlib.util.spec_from_file_location("bench_multi_gpu", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_judged_speedup_is_at_the_one_device_best():
    """bench_multi_gpu's judgement: the speed-up is taken at the one-device run's fastest schedule, so a
    schedule that handicaps the one-device run (here "ramp": 80 variants/s on one device, 190 on two,
    2.4x) cannot pass the check; the best-vs-best figure is reported beside it."""
    bench = _bench_multi_gpu()
    one = {"flat": {"variants_per_s": 100.0}, "ramp": {"variants_per_s": 80.0}}
    two = {"flat": {"variants_per_s": 170.0}, "ramp": {"variants_per_s": 190.0}}
    f = bench.fair_speedup(one, two)
    assert f["best_one_device_schedule"] == "flat" and f["speedup"] == pytest.approx(1.7)
    assert f["speedup_by_schedule"]["ramp"] == pytest.approx(190.0 / 80.0)
    assert f["speedup_best_vs_best"] == pytest.approx(1.9)
    assert [bench.parse_schedule(x) for x in ("all", "1024", "1024/128")] == [(None, None), (1024, 1024), (1024, 128)]
    for bad in ("", "0", "1024/0", "a/b", "1/2/3"):
        with pytest.raises(RvtoolInputError, match="schedules"):
            bench.parse_schedule(bad)
