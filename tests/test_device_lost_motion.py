"""Lost motion on the device Newton (issue 19): the batched load continuation against the
sequential Exudyn lost motion, equilibria against a tight StaticSolver oracle, isolation of a
failing copy, the Exudyn fallback. cpu always; cuda where present.

The variants are Monte Carlo samples of RD-40 (seed 2026, the case's regularization), as in
tests/test_lost_motion.py: 1 and 3: the sequential load continuation succeeds; 2: it fails and
spring control succeeds; 30: the sequential load continuation succeeds, the device Newton
finds its loaded start only at 2.5 f (the start ladder); 0: the sequential load continuation
stalls where the torque--angle curve folds (spring control passes the fold with a stiffer spring),
and the device continuation stalls where the sequential one does."""
import dataclasses
import numpy as np
import pytest
import warp as wp

from rvtool import designs
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.variants import VariantProtocol, variant_lost_motion
from rvtool.variants.tolerances import load_tolerances, sample_variant

REG = (1.0e4, 100.0)
SEED = 2026
PROTOCOL = VariantProtocol(n_te_points=53)
DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]


def _skip_absent(device):
    wp.init()
    if device != "cpu" and wp.get_cuda_device_count() == 0:
        pytest.skip(f"{device} not present")


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("rd40"))


@pytest.fixture(scope="module")
def samples(design):
    # the variants chosen below for their edge cases were drawn before pin_circle_coaxiality_error joined the
    # file; that field is drawn last, so leaving it out draws them as they were (tests/test_cycloid_coaxiality.py)
    tol = dataclasses.replace(load_tolerances(designs.path("rd40_tolerances")), pin_circle_coaxiality_error=None)
    return {k: sample_variant(tol, design, k, SEED) for k in (0, 1, 2, 3, 30)}


@pytest.mark.parametrize("device", DEVICES)
def test_lost_motion_matches_the_sequential_path(design, samples, device):
    """Device lost motion of variants 1, 2, 3, 30 against ``variant_lost_motion`` on each variant's
    Exudyn model, and the device equilibria at +-f against StaticSolver at abs_tol 1e-8 N
    polishing the sequential continuation's states (load-controlled variants 1, 3, 30).

    Tolerances: equilibria to 1e-9 relative to the flange's elastic rotation (the device Newton
    applies one more step after |residual| <= 1e-6 N, so its own error is quadratically small;
    measured 3e-13). Lost motion to 2e-7 arcmin against the sequential path: that path stops
    each level at Exudyn's tolerances (1e-6 N absolute or 1e-9 of the first residual), which
    left its +f state of variant 3 2.6e-11 rad (9e-8 arcmin) off the tight oracle, which agrees
    with the device to 1e-14 relative. Variant 2 (load control fails sequentially, spring
    control gives the figure) is reached by the device continuation: the two methods give the
    same figure (spring control's regula falsi stops at |T - level| <= 1e-7 level: measured 2e-9
    arcmin)."""
    _skip_absent(device)
    from rvtool.batched.device_lost_motion import device_lost_motion
    from rvtool.solver.continuation import Continuation
    from rvtool.solver.static import StaticSolver
    ks = [1, 2, 3, 30]
    r = device_lost_motion(design, [samples[k] for k in ks], PROTOCOL, regularization=REG, device=device,
                           fallback=False)
    assert r.status == ["ok"] * 4 and r.path == ["device"] * 4 and r.stats["fallback_copies"] == 0
    assert r.stats["start_scales"] == {"1": 3, "2.5": 1, "6": 0, "15": 0}     # 30 starts at 2.5 f
    levels = PROTOCOL.lost_motion_torques(design)
    for c, k in enumerate(ks):
        d = samples[k].apply(design)
        ref = variant_lost_motion(build(d, bearing_model="lumped", regularization=REG), d, PROTOCOL)
        assert ref["method"] == ("spring" if k == 2 else "load")
        assert abs(r.lost_motion_arcmin[c] - ref["lost_motion_arcmin"]) <= 2e-7, k
        if k == 2:
            continue
        m = build(d, bearing_model="lumped", regularization=REG)
        i = m.output_index
        cont = Continuation(m, input_angle=0.0, initial_torque=float(levels[0]))
        q_plus = cont.q.copy()
        for t in levels[1:]:
            q_minus = cont.go_to(float(t)).copy()
        oracle = StaticSolver(m, abs_tol=1e-8)
        for T, q_seq, th in ((levels[0], q_plus, r.theta_plus[c]), (levels[-1], q_minus, r.theta_minus[c])):
            m.set_output_torque(float(T))
            ok, q = oracle.newton(q_seq)
            assert ok
            assert abs(q[i] - th) <= 1e-9 * abs(th), (k, T)


def test_failing_copy_does_not_change_the_others(design, samples):
    """Variant 0's device continuation stalls in the free play (where the sequential one
    does): it is reported failed (no fallback here) while variants 1 and 3 beside it get bit-identical
    figures and iteration counts to a run without it; the batch ends."""
    from rvtool.batched.device_lost_motion import device_lost_motion
    both = device_lost_motion(design, [samples[k] for k in (0, 1, 3)], PROTOCOL, regularization=REG, fallback=False)
    alone = device_lost_motion(design, [samples[k] for k in (1, 3)], PROTOCOL, regularization=REG, fallback=False)
    assert both.status == ["failed", "ok", "ok"] and "stalled between -0.0596436 and -1.4 N m" in both.error[0]
    assert both.stats["fallback_copies"] == 1 and both.stats["failed_copies"] == 1
    assert np.isnan(both.lost_motion_arcmin[0])
    assert np.array_equal(both.lost_motion_arcmin[1:], alone.lost_motion_arcmin)
    assert np.array_equal(both.iterations[1:], alone.iterations)


def test_failed_copies_go_to_the_exudyn_path(design, samples):
    """With a device budget too small to converge (1 iteration, no homotopy) the copy falls
    back to the per-variant Exudyn lost motion: counted, and the figure is the sequential
    one exactly (the same function on the same model)."""
    from rvtool.batched.device_lost_motion import device_lost_motion
    from rvtool.solver.device_newton import DeviceNewtonSettings
    r = device_lost_motion(design, [samples[1]], PROTOCOL, regularization=REG,
                           settings=DeviceNewtonSettings(max_iterations=1, homotopy=False))
    d = samples[1].apply(design)
    ref = variant_lost_motion(build(d, bearing_model="lumped", regularization=REG), d, PROTOCOL)
    assert r.stats["fallback_copies"] == 1 and r.stats["failed_copies"] == 0
    assert r.path == ["exudyn"] and r.status == ["ok"] and r.method == [ref["method"]]
    assert r.lost_motion_arcmin[0] == ref["lost_motion_arcmin"]


def test_bad_settings(design, samples):
    from rvtool.batched.device_lost_motion import ContinuationSettings, device_lost_motion
    with pytest.raises(RvtoolInputError, match="lost_motion.min_increment"):
        ContinuationSettings(min_increment=0.0)
    with pytest.raises(RvtoolInputError, match="lost_motion.max_rounds"):
        ContinuationSettings(max_rounds=0)
    with pytest.raises(RvtoolInputError, match="bearing_model"):
        device_lost_motion(design, [samples[1]], VariantProtocol(n_te_points=53, bearing_model="rolling"))


def test_parameters_in_shares_and_fallbacks_on_an_executor(design, samples):
    """The per-copy parameters built in shares on an executor and merged equal the direct build
    row for row (profile tables read through each row's table index), the lost motion from
    them is bit-identical, and the Exudyn fallbacks submitted to an executor give the
    sequential figure exactly."""
    from concurrent.futures import ThreadPoolExecutor

    from warp_contacts import cycloid_pins_ref as pref

    from rvtool.solver.device_copies import nominal_copy_parameters
    from rvtool.batched.device_lost_motion import device_lost_motion
    from rvtool.solver.device_newton import DeviceNewtonSettings
    vs = [samples[k] for k in (1, 3, 2)]
    direct = nominal_copy_parameters(design, vs, regularization=REG)
    with ThreadPoolExecutor(max_workers=1) as ex:      # one thread: Exudyn systems are built one at a time
        merged = nominal_copy_parameters(design, vs, regularization=REG, executor=ex, share=1)
        assert len(merged.variants) == 4 and len(merged.tables) > len(direct.tables)   # a nominal table per share
        for nm in ("pin_f", "brg_f", "reference", "eccentricity"):
            assert np.array_equal(getattr(merged, nm), getattr(direct, nm)), nm
        cols = [c for c in range(pref.N_INT) if c != pref.J_TABLE]
        assert np.array_equal(merged.pin_i[:, :, cols], direct.pin_i[:, :, cols])
        for c in range(4):
            for tm, td in zip(merged.pin_i[c, :, pref.J_TABLE], direct.pin_i[c, :, pref.J_TABLE]):
                assert all(np.array_equal(a, b) for a, b in zip(merged.tables[tm], direct.tables[td]))
        a = device_lost_motion(design, vs, PROTOCOL, regularization=REG, params=direct, fallback=False)
        b = device_lost_motion(design, vs, PROTOCOL, regularization=REG, params=merged, fallback=False)
        assert np.array_equal(a.lost_motion_arcmin, b.lost_motion_arcmin)
        r = device_lost_motion(design, [samples[1]], PROTOCOL, regularization=REG, executor=ex,
                               settings=DeviceNewtonSettings(max_iterations=1, homotopy=False))
    d = samples[1].apply(design)
    ref = variant_lost_motion(build(d, bearing_model="lumped", regularization=REG), d, PROTOCOL)
    assert r.path == ["exudyn"] and r.stats["fallback_copies"] == 1
    assert r.lost_motion_arcmin[0] == ref["lost_motion_arcmin"]
