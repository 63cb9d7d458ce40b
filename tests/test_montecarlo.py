"""Tolerance distributions, seeded sampling and the resumable tolerance Monte Carlo (issue 8)."""
import json
import math
import os

import numpy as np
import pytest

from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.variants.montecarlo import (MonteCarloSettings, fingerprint, order_statistic_ci, read_chunk, run_monte_carlo,
                               run_variant, summarize)
from rvtool.variants.tolerances import (Fixed, Normal, ToleranceSpec, TruncatedNormal, Uniform, load_tolerances,
                               sample_variant, sample_variants, spec_from_dict)
from rvtool.variants import Variant, VariantProtocol
from rvtool import designs

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DESIGN = designs.path("rd40")
TOLERANCES = designs.path("rd40_tolerances")
# small per-variant protocol: 23 TE points (0.1 s: the eccentric turns -110 deg per point, where the
# static solver's warm starts hold; 5 points would alias onto one mesh phase of RD-40)
PROTOCOL = VariantProtocol(n_te_points=23)
BUILD = {"regularization": (1.0e4, 100.0)}   # as the cases: lets the lost-motion continuation cross free play


@pytest.fixture(scope="module")
def design():
    return load_design(DESIGN)


@pytest.fixture(scope="module")
def tol():
    return load_tolerances(TOLERANCES)


def _figures(records):
    """Records without the wall times (the only non-deterministic entries)."""
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in records]


def test_sampling_reproducible_per_index(design, tol):
    batch = sample_variants(tol, design, 12, seed=7)
    part = sample_variants(tol, design, 4, seed=7, start=8)
    for a, b in zip(batch[8:], part):
        assert a.index == b.index
        assert np.array_equal(a.pin_centre_errors, b.pin_centre_errors)
        assert (a.eccentricity_error, a.pin_clearance, a.bearing_clearance) == \
               (b.eccentricity_error, b.pin_clearance, b.bearing_clearance)
    assert np.array_equal(sample_variant(tol, design, 3, 7).pin_centre_errors, batch[3].pin_centre_errors)
    other = sample_variant(tol, design, 3, 8)
    assert not np.array_equal(other.pin_centre_errors, batch[3].pin_centre_errors)
    assert batch[3].pin_centre_errors.shape == (design.pins.n_pins, 2)


def test_sampling_matches_declared_moments(design):
    # Reference moments in closed form: uniform (a+b)/2 and (b-a)^2/12; the truncated normal's from
    # scipy.stats.truncnorm (independent of the inverse-CDF sampler and of the moments() formula).
    from scipy.stats import truncnorm
    spec = ToleranceSpec(eccentricity_error=Normal(mean=1e-6, std=2e-6),
                         pin_centre_errors=TruncatedNormal(mean=1e-6, std=2e-6, low=0.0, high=4e-6),
                         pin_clearance=Uniform(low=1e-6, high=9e-6),
                         bearing_clearance=TruncatedNormal(mean=5e-6, std=2e-6, low=1e-6))
    vs = sample_variants(spec, design, 4000, seed=1)
    tn = truncnorm((0.0 - 1e-6) / 2e-6, (4e-6 - 1e-6) / 2e-6, loc=1e-6, scale=2e-6)
    tn2 = truncnorm((1e-6 - 5e-6) / 2e-6, np.inf, loc=5e-6, scale=2e-6)
    cases = [(np.array([v.eccentricity_error for v in vs]), 1e-6, 4e-12),
             (np.concatenate([v.pin_centre_errors.ravel() for v in vs]), tn.mean(), tn.var()),
             (np.array([v.pin_clearance for v in vs]), 5e-6, (8e-6) ** 2 / 12),
             (np.array([v.bearing_clearance for v in vs]), tn2.mean(), tn2.var())]
    for x, m, var in cases:
        n = len(x)
        # 5 standard errors of the mean and of the variance (4th moment bounded by 3 var^2 here)
        assert abs(x.mean() - m) < 5 * math.sqrt(var / n)
        assert abs(x.var() - var) < 5 * math.sqrt(2 * var ** 2 / n)
    assert np.all(np.concatenate([v.pin_centre_errors.ravel() for v in vs]) >= 0.0)
    for dist, ref in ((spec.pin_centre_errors, tn), (spec.bearing_clearance, tn2)):
        m, v = dist.moments()
        assert m == pytest.approx(ref.mean(), rel=1e-12) and v == pytest.approx(ref.var(), rel=1e-10)


def test_tolerance_file_validation(design, tol):
    assert tol.pin_clearance.moments()[0] > 0          # nominal reducers are not preloaded on average
    assert tol.bearing_clearance.support()[0] >= 0
    with pytest.raises(RvtoolInputError, match=r"tolerances.pin_clearance.std"):
        spec_from_dict({"tolerances": {"pin_clearance": {"dist": "normal", "std": -1e-6}}})
    with pytest.raises(RvtoolInputError, match=r"tolerances.pin_clearance.high"):
        spec_from_dict({"pin_clearance": {"dist": "uniform", "low": 2e-6, "high": 1e-6}})
    with pytest.raises(RvtoolInputError, match=r"unknown keys \['pin_clearanc'\]"):
        spec_from_dict({"pin_clearanc": {"dist": "fixed", "value": 0.0}})
    with pytest.raises(RvtoolInputError, match=r"tolerances.offset_mod.dist"):
        spec_from_dict({"offset_mod": {"dist": "gauss", "std": 1e-6}})
    with pytest.raises(RvtoolInputError, match=r"tolerances.offset_mod \(uniform\) has unknown keys \['std'\]"):
        spec_from_dict({"offset_mod": {"dist": "uniform", "low": 0.0, "high": 1e-6, "std": 1.0}})
    with pytest.raises(RvtoolInputError, match=r"bearing_clearance.*valid range \[0, inf\)"):
        ToleranceSpec(bearing_clearance=Normal(mean=5e-6, std=1e-6))
    with pytest.raises(RvtoolInputError, match=r"tolerances.eccentricity_error reaches"):
        sample_variants(ToleranceSpec(eccentricity_error=Normal(std=2e-4)), design, 1, 0)
    assert sample_variant(ToleranceSpec(offset_mod=Fixed(value=2e-6)), design, 0, 0).offset_mod == 2e-6


def test_order_statistic_ci_coverage():
    # Coverage of [X_(l), X_(u)] for the p-quantile is sum_{j=l}^{u-1} C(n, j) p^j (1-p)^(n-j)
    # (the number of samples below x_p is binomial), evaluated here with exact integer binomials.
    p = 0.95
    for n in (100, 400, 1000):
        x = np.arange(1, n + 1, dtype=float)        # ranks as values: the interval returns ranks
        lo, hi = order_statistic_ci(x, p)
        l, u = int(lo), int(hi)
        cover = sum(math.comb(n, j) * p ** j * (1 - p) ** (n - j) for j in range(l, u))
        assert cover >= 0.95 and l < 0.95 * n < u
    assert order_statistic_ci(np.arange(1.0, 21.0), p)[1] is None   # n = 20: no upper rank exists


def test_summarize_against_numpy():
    rng = np.random.default_rng(0)
    x = rng.normal(3.0, 0.5, 200)
    recs = [{"status": "ok", "te_pp_arcsec": v} for v in x] + [{"status": "failed", "te_pp_arcsec": None}]
    s = summarize(recs, figures=("te_pp_arcsec",))
    t = s["te_pp_arcsec"]
    assert s["n_failed"] == 1 and t["n"] == 200
    assert t["mean"] == pytest.approx(x.mean(), rel=1e-14) and t["std"] == pytest.approx(x.std(ddof=1), rel=1e-12)
    assert t["p95"] == pytest.approx(np.percentile(x, 95), rel=1e-14)
    half = 1.971956544 * x.std(ddof=1) / math.sqrt(200)   # t_{0.975, 199}
    assert t["mean_ci"][1] - t["mean"] == pytest.approx(half, rel=1e-8)
    assert t["p95_ci"][0] <= t["p95"] <= t["p95_ci"][1]


def test_failed_variant_is_recorded(design):
    rec = run_variant(design, Variant(index=5, eccentricity_error=-1e-3), PROTOCOL)
    assert rec["status"] == "failed" and rec["index"] == 5 and "eccentricity_error" in rec["error"]
    assert rec["te_pp_arcsec"] is None


@pytest.fixture(scope="module")
def uninterrupted(design, tol, tmp_path_factory):
    out = tmp_path_factory.mktemp("mc_full")
    settings = MonteCarloSettings(n_variants=2, seed=2, chunk_size=1, mode="serial")
    return run_monte_carlo(design, tol, PROTOCOL, settings, str(out), build_kw=BUILD)


def test_resumed_study_equals_uninterrupted(design, tol, uninterrupted, tmp_path):
    settings = MonteCarloSettings(n_variants=2, seed=2, chunk_size=1, mode="serial")

    class Interrupt(Exception):
        pass

    def kill(i, recs):
        raise Interrupt(i)

    with pytest.raises(Interrupt):
        run_monte_carlo(design, tol, PROTOCOL, settings, str(tmp_path), on_chunk=kill, build_kw=BUILD)
    files = sorted(f for f in os.listdir(tmp_path) if f.startswith("chunk_"))
    assert files == ["chunk_00000.json"]                 # the first chunk was written, atomically
    assert not [f for f in os.listdir(tmp_path) if f.endswith(".tmp")]
    resumed = run_monte_carlo(design, tol, PROTOCOL, settings, str(tmp_path), build_kw=BUILD)
    assert resumed["chunks_loaded"] == 1 and resumed["chunks_run"] == 1
    assert all(r["status"] == "ok" for r in uninterrupted["records"]), uninterrupted["records"]
    assert _figures(resumed["records"]) == _figures(uninterrupted["records"])
    assert resumed["summary"]["te_pp_arcsec"]["mean"] == uninterrupted["summary"]["te_pp_arcsec"]["mean"]
    # a chunk written under other settings (here: another seed) is not reused
    fp = fingerprint(design, tol, PROTOCOL, 12, 1, BUILD)
    assert read_chunk(str(tmp_path), 0, fp, range(0, 1)) is None
    with open(os.path.join(tmp_path, "chunk_00000.json")) as fh:
        assert json.load(fh)["fingerprint"] == resumed["fingerprint"]


def test_pool_equals_serial(design, tol, uninterrupted, tmp_path):
    """The pool on its default Dask LocalCluster (2 worker processes) gives the serial figures."""
    settings = MonteCarloSettings(n_variants=2, seed=2, chunk_size=1, mode="pool", workers=2)
    res = run_monte_carlo(design, tol, PROTOCOL, settings, str(tmp_path), build_kw=BUILD)
    assert _figures(res["records"]) == _figures(uninterrupted["records"])


def test_pool_on_a_scheduler_address_equals_serial(design, tol, uninterrupted, tmp_path):
    """settings.scheduler: the pool's tasks go to the cluster at that address (here a LocalCluster
    of one in-process worker, fast); the scheduler sees them and the figures are the serial ones."""
    from dask.distributed import LocalCluster
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        before = cluster.scheduler.transition_counter
        settings = MonteCarloSettings(n_variants=2, seed=2, chunk_size=1, mode="pool", workers=1,
                                      scheduler=cluster.scheduler_address)
        res = run_monte_carlo(design, tol, PROTOCOL, settings, str(tmp_path), build_kw=BUILD)
        assert cluster.scheduler.transition_counter > before
    assert _figures(res["records"]) == _figures(uninterrupted["records"])


def test_batched_mode(design, tmp_path):
    # no free play here (eccentricity errors >= 0 close the pin mesh); the batched path takes the
    # builder's regularization, so batched and serial run the same reducer under BUILD
    spec = ToleranceSpec(eccentricity_error=TruncatedNormal(mean=1e-6, std=0.5e-6, low=0.0))
    settings = MonteCarloSettings(n_variants=2, seed=2, chunk_size=2, mode="batched")
    try:
        from rvtool.variants.batched import batched_variant_figures  # noqa: F401  (absent before issue 8 part 2 lands)
    except ImportError:
        with pytest.raises(RvtoolInputError, match="batched"):
            run_monte_carlo(design, spec, PROTOCOL, settings, str(tmp_path))
        return
    res = run_monte_carlo(design, spec, PROTOCOL, settings, str(tmp_path / "b"), build_kw=BUILD)
    ref = run_monte_carlo(design, spec, PROTOCOL, MonteCarloSettings(n_variants=2, seed=2, chunk_size=2, mode="serial"),
                          str(tmp_path / "s"), build_kw=BUILD)
    with pytest.raises(RvtoolInputError, match=r"build options \['bearing_stiffness'\]"):
        run_monte_carlo(design, spec, PROTOCOL, settings, str(tmp_path / "b0"), build_kw={"bearing_stiffness": 1.0})
    for a, b in zip(res["records"], ref["records"]):
        assert a["status"] == b["status"] == "ok", (a["error"], b["error"])
        for nm in ("te_pp_arcsec", "lost_motion_arcmin", "max_pin_force_N"):
            # one system of B copies vs one system per variant: equal up to the Newton tolerances
            assert a[nm] == pytest.approx(b[nm], rel=1e-6, abs=1e-6)


def test_device_mode(design, tol, uninterrupted, tmp_path):
    """Mode "device" (TE and lost motion on the device Newton) reproduces the serial per-variant
    study: TE to 1e-6 arcsec, max pin force to 1e-6 N and lost motion to 1e-6 arcmin (both paths
    converge the same equilibria to |residual| <= 1e-6 N; tests/test_device_lost_motion.py
    bounds the lost motion tighter on chosen variants); records name the TE and lost-motion
    paths. "auto" resolves to the device mode (the fastest measured for this protocol)."""
    from rvtool.variants.montecarlo import resolve_mode
    settings = MonteCarloSettings(n_variants=2, seed=2, chunk_size=2, mode="device", workers=1)
    res = run_monte_carlo(design, tol, PROTOCOL, settings, str(tmp_path), build_kw=BUILD)
    assert res["mode"] == "device" and res["te_paths"] == ["device_newton:cpu:host_loop"]
    for a, b in zip(res["records"], uninterrupted["records"]):
        assert a["status"] == b["status"] == "ok", (a["error"], b["error"])
        assert abs(a["te_pp_arcsec"] - b["te_pp_arcsec"]) <= 1e-6
        assert abs(a["max_pin_force_N"] - b["max_pin_force_N"]) <= 1e-6
        assert abs(a["lost_motion_arcmin"] - b["lost_motion_arcmin"]) <= 1e-6
        assert a["te_fallback_points"] == 0 and b["te_path"] == "exudyn"
        assert a["lost_motion_path"] == "device_newton:cpu:host_loop" and a["lost_motion_fallback"] is False
        assert b["lost_motion_path"] == "exudyn" and b["lost_motion_fallback"] is None
    assert res["lost_motion_paths"] == ["device_newton:cpu:host_loop"] and res["lost_motion_fallback_copies"] == 0
    # the full protocol (TE + lost motion) is fastest on the device Newton (resolve_mode's docstring)
    assert resolve_mode("auto", "cpu") == ("device", "cpu")
    with pytest.raises(RvtoolInputError, match="mode"):
        MonteCarloSettings(n_variants=2, mode="fast")
