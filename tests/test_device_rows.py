"""The device backend's row Newton (rvtool.solver.device_rows) on the non-cycloid topologies
against the Exudyn oracle: tests/golden/backends.json's Exudyn figures (written by
tests/golden/capture_backends.py, see tests/golden/README.md).

Tolerances as tests/test_backends_golden.py (the issue's targets): equilibria 1e-9 relative
(each coordinate kind against its largest elastic deviation: a 1e-6 N residual over contact
stiffnesses of ~1e8 N/m moves a state by ~1e-14 m), TE 1e-6 arcsec, peak loads 1e-6 relative.
A lost family or another regularization misses these by orders of magnitude (dropping the
tapered crank bearings moves RV-40E's carrier by its whole elastic deflection).
"""
import dataclasses
import json
import pathlib

import numpy as np
import pytest
from states import assert_equal_states

import rvtool
from rvtool.errors import RvtoolInputError
from rvtool.protocols.precision import quasi_static_te
from rvtool.solver.backends import DeviceBackend, EquilibriumBatch, choose
from rvtool.solver.device_rows import CONVERGED, DeviceRowNewton
from rvtool.units import ARCSEC_PER_RAD

def _skip_absent(device):
    import warp as wp
    if device.startswith("cuda") and wp.get_cuda_device_count() == 0:
        pytest.skip(f"{device} not present")


DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]
GOLDEN = json.loads((pathlib.Path(__file__).parent / "golden" / "backends.json").read_text())["exudyn"]
TE_TOL = 1e-6           # arcsec
EQ_TOL = 1e-9           # relative


@pytest.fixture(scope="module")
def rv():
    d = rvtool.load_design("rv40e")
    return d, rvtool.build(d)


def _model_q(model, q_local):
    """Model (Exudyn) coordinates of states in the body order of the copies."""
    idx = np.concatenate([np.asarray(model.mbs.systemData.GetNodeLTGODE2(n), int) for n in model.nodes])
    out = np.zeros((len(q_local), model.mbs.systemData.ODE2Size()))
    out[:, idx] = q_local
    return out


def _equal_states(q, q_ref, model):
    assert_equal_states(q, q_ref, model, EQ_TOL)


@pytest.mark.parametrize("device", DEVICES)
def test_rv40e_equilibria_and_te_on_the_device_equal_exudyn(rv, device):
    """Every family of RV-40E's merged element (cycloid pins, involute pairs, needle and ball
    rolling elements, tapered crank bearings carrying the output carrier) on the device row
    Newton: equilibria and the quick TE sequence against the Exudyn oracle, every point
    converged on the device (no Exudyn hand-over)."""
    _skip_absent(device)
    d, model = rv
    g = GOLDEN["rv40e"]
    b = DeviceBackend(device=device)
    assert b.supports(model, "equilibria").ok and b.path(model)[0] == "rows"
    eq = b.solve_equilibria(model, EquilibriumBatch(input_angles=g["equilibria_angles_rad"], torque=d.rated_torque))
    assert eq.stats["exudyn_points"] == 0 and eq.stats["path"] == "rows"
    _equal_states(eq.q, g["equilibria_q"], model)
    te = quasi_static_te(model, torque=d.rated_torque, input_angles=g["te_angles_rad"], backend="device",
                         device=device)
    assert te["backend"]["ran"] == "device" and te["stats"]["exudyn_points"] == 0 and te["stats"]["device"] == device
    assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - g["te_arcsec"])) <= TE_TOL
    assert set(te["peak_loads"]) == set(g["te_peak_loads_N"])
    for fam, f in g["te_peak_loads_N"].items():
        assert te["peak_loads"][fam] == pytest.approx(f, rel=1e-6)


@pytest.mark.parametrize("name", ["std_involute", "rv_three_stage"])
def test_other_topologies_te_on_the_device_equals_exudyn(name):
    """The small-tooth-difference reducer (involute internal pair, plain output pins, circle-pair
    bearings) and the three-stage RV (a second involute stage) on the device row Newton: the
    quick TE sequence against the Exudyn oracle's golden TE and peak loads, no Exudyn hand-over."""
    g = GOLDEN[name]
    d = rvtool.load_design(name)
    model = rvtool.build(d)
    assert DeviceBackend().path(model)[0] == "rows"
    te = quasi_static_te(model, torque=d.rated_torque, input_angles=g["te_angles_rad"], backend="device")
    assert te["backend"]["ran"] == "device" and te["stats"]["exudyn_points"] == 0
    assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - g["te_arcsec"])) <= TE_TOL
    for fam, f in g["te_peak_loads_N"].items():
        # abs 1e-6 N: a family at the edge of contact (golden 0 N) may carry a force below the
        # Newton's residual tolerance (abs_tol = 1e-6 N), which neither solver resolves
        assert te["peak_loads"][fam] == pytest.approx(f, rel=1e-6, abs=1e-6)


def test_rd40_with_rolling_bearings_takes_the_row_path():
    """RD-40 built with rolling-element bearings (needle, ball, angular-contact pairs) is outside
    the resident path's copy parameters (lumped bearings): the row path runs it, and its TE and
    peak loads equal the Exudyn backend's at the same points."""
    from rvtool.assembly.cycloid import build
    d = rvtool.load_design("rd40")
    model = build(d, bearing_model="rolling")
    assert DeviceBackend().path(model)[0] == "rows"
    a = np.linspace(0.0, 0.3, 12)
    ref = quasi_static_te(model, torque=d.rated_torque, input_angles=a, backend="exudyn")
    te = quasi_static_te(model, torque=d.rated_torque, input_angles=a, backend="device")
    assert te["stats"]["path"] == "rows" and te["stats"]["exudyn_points"] == 0
    assert np.max(np.abs(te["te"] - ref["te"])) * ARCSEC_PER_RAD <= TE_TOL
    for fam, f in ref["peak_loads"].items():
        assert te["peak_loads"][fam] == pytest.approx(f, rel=1e-6, abs=1e-6)


def test_warm_started_segments_give_the_oracles_te_in_fewer_sweeps(rv):
    """More points than copies with batch.warm_start: the row path marches warm-started segments
    (solve_sequence); the TE equals the Exudyn oracle's and takes fewer device sweeps than cold
    starts of every point (the same equilibria: the states differ by round-off only)."""
    d, model = rv
    g = GOLDEN["rv40e"]
    warm = quasi_static_te(model, torque=d.rated_torque, input_angles=g["te_angles_rad"],
                           backend=DeviceBackend(copies=4))
    cold = quasi_static_te(model, torque=d.rated_torque, input_angles=g["te_angles_rad"],
                           backend=DeviceBackend(copies=4), warm_start=False)
    for te in (warm, cold):
        assert te["stats"]["exudyn_points"] == 0
        assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - g["te_arcsec"])) <= TE_TOL
    assert warm["stats"]["newton_iterations"] < 0.8 * cold["stats"]["newton_iterations"]


def test_chunks_and_the_homotopy_give_the_same_equilibria(rv):
    """Solving 3 points in chunks of 2 copies (a padded last chunk) gives the equilibria of one
    chunk of 3; a start outside the plausibility bounds fails its warm start, goes through the
    regularization homotopy from the kinematic state and reaches the same equilibrium."""
    d, model = rv
    g = GOLDEN["rv40e"]
    a = np.asarray(g["equilibria_angles_rad"])
    tq = np.full(len(a), -np.sign(model.ratio) * d.rated_torque)
    one = DeviceRowNewton(model, 3).solve(a, tq)
    two = DeviceRowNewton(model, 2).solve(a, tq)
    assert np.all(one.status == CONVERGED) and np.all(two.status == CONVERGED)
    np.testing.assert_allclose(two.q, one.q, rtol=0, atol=1e-15 * np.max(np.abs(one.q)) + 1e-18)
    newton = DeviceRowNewton(model, 3)
    start = newton.kinematic(a)
    start[:, newton.free & ~newton.rot] += 1e-3          # 1 mm: beyond max_translation = 0.5 mm
    far = newton.solve(a, tq, start)
    assert np.all(far.status == CONVERGED) and np.all(far.stage >= 0)   # converged in the homotopy
    assert np.all(one.stage == -1)                                      # the kinematic start needs none
    _equal_states(_model_q(model, far.q), g["equilibria_q"], model)


def test_the_device_side_row_sum_equals_the_host_scatter(rv):
    """DeviceRowSum (rows summed into per-copy blocks by a Warp kernel, the tapered rollers' host
    rows uploaded; the default on CUDA) gives the host scatter's Newton: the same iterations and
    states to 1e-12 relative (only the order of the additions differs: last bits)."""
    d, model = rv
    a = np.asarray(GOLDEN["rv40e"]["te_angles_rad"][:4])
    tq = np.full(len(a), -np.sign(model.ratio) * d.rated_torque)
    host = DeviceRowNewton(model, 4, device_sum=False)
    dev = DeviceRowNewton(model, 4, device_sum=True)
    assert not host.device_sum and dev.device_sum
    r0, r1 = host.solve(a, tq), dev.solve(a, tq)
    assert np.all(r1.converged) and np.array_equal(r0.iterations, r1.iterations)
    assert np.max(np.abs(r1.q - r0.q)) <= 1e-12 * np.max(np.abs(r0.q))


def test_auto_does_not_take_the_unmeasured_row_path(rv):
    """auto on CUDA puts the device first (measured on the cycloid path); the row path is not
    measured there, so auto names why it did not take it and runs the next backend."""
    from rvtool.solver.backends import auto_order
    _, model = rv
    assert auto_order("equilibria", n_states=52, device="cuda:0")[0] == "device"
    b, choice = choose("auto", model, "equilibria", n_states=52, device="cuda:0")
    assert b.name == "replica" and "no measured place in auto's order" in choice["not_taken"]["device"]


def test_what_the_device_does_not_cover_is_named(rv):
    """Friction with stick--slip anchors runs on the device row Newton (history committed per level:
    tests/test_device_families.py); a closure with a nonlinear station law (conformal grooves) does
    not: a named reason, and --backend device refuses instead of running something else."""
    d, _ = rv
    anchored = dataclasses.replace(d, involute_stage=dataclasses.replace(d.involute_stage, mu=0.05,
                                                                         friction_model="anchor"))
    model = rvtool.build(anchored)
    assert DeviceBackend().supports(model, "equilibria").ok
    grooved = rvtool.build(d.replace(pins={"groove": "conformal", "groove_clearance": 5e-6}))
    sup = DeviceBackend().supports(grooved, "equilibria")
    assert not sup.ok and any("station law" in r and "row path" in r for r in sup.reasons)
    with pytest.raises(RvtoolInputError, match=r"backend = 'device'.*station law"):
        choose("device", grooved, "equilibria")
    # driven runs of anchored RV take the fused backend's row stepper (anchors committed per accepted step,
    # tests/test_fused_closures.py); the grooves' station law is refused there by name as well
    assert choose("device", model, "dynamic")[1]["ran"] == "fused"
    with pytest.raises(RvtoolInputError, match=r"backend = 'device'.*groove"):
        choose("device", grooved, "dynamic")
    with pytest.raises(RvtoolInputError, match=r"copies = 0 is outside the valid range"):
        DeviceRowNewton(rvtool.build(d), 0)
    with pytest.raises(RvtoolInputError, match=r"copies = 0 is outside the valid range"):
        DeviceBackend(copies=0)


@pytest.mark.parametrize("device", DEVICES)
def test_rv40e_lost_motion_on_the_device_equals_exudyn(rv, device):
    """Lost motion at +-3 % T_rated through the needle clearance and the gear backlash on the device
    row Newton (load continuation) against the Exudyn oracle's figures (spring-controlled march
    and torque continuation, tests/golden/backends.json), reached without an Exudyn hand-over."""
    from rvtool.batched.device_rows_lost_motion import device_row_lost_motion
    from rvtool.units import ARCMIN_PER_RAD
    _skip_absent(device)
    d, model = rv
    g = GOLDEN["rv40e"]
    r = device_row_lost_motion(DeviceRowNewton(model, 1, device=device), 0.03 * d.rated_torque)
    assert r["path"] == ["device"] and r["status"] == ["ok"] and r["stats"]["exudyn_copies"] == 0
    lm = r["lost_motion_rad"][0] * ARCMIN_PER_RAD
    assert abs(lm - g["lost_motion_march_arcmin"]) <= 1e-6        # arcmin (the target)
    assert abs(lm - g["lost_motion_continuation_arcmin"]) <= 1e-6
    with pytest.raises(RvtoolInputError, match=r"torque_level = -1"):
        device_row_lost_motion(DeviceRowNewton(model, 1), -1.0)


def test_variant_copies_equal_each_variants_exudyn_solution(rv):
    """Monte Carlo variants of RV-40E (rv40e_tolerances: crank phase and eccentricity errors, pin
    radius, needle clearance, pitch deviations) as copies of one row Newton, each copy its own
    model: equilibria at two crank angles and the lost motion equal each variant's own Exudyn
    solution (static solver; spring-controlled march)."""
    from rvtool import designs
    from rvtool.batched.device_rows_lost_motion import device_row_lost_motion
    from rvtool.protocols.lost_motion import lost_motion
    from rvtool.solver.static import StaticSolver
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    d, _ = rv
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    models = [rvtool.build(sample_rv_design(tol, d, k, 20261124)[0]) for k in range(2)]
    newton = DeviceRowNewton(models)
    for a in (0.0, 1.3):
        r = newton.solve(np.full(2, a), np.full(2, -np.sign(models[0].ratio) * d.rated_torque))
        assert np.all(r.converged)
        for c, m in enumerate(models):
            m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
            q_ref = StaticSolver(m).solve(a)
            _equal_states(_model_q(m, r.q[c:c + 1]), q_ref[None], m)
    assert not np.allclose(r.q[0], r.q[1], rtol=1e-6)               # the variants differ
    lm = device_row_lost_motion(newton, 0.03 * d.rated_torque)
    assert lm["path"] == ["device", "device"]
    for c, m in enumerate(models):
        m.set_output_torque(0.0)
        ref = lost_motion(m, torque_level=0.03 * d.rated_torque)["lost_motion_rad"]
        assert abs(lm["lost_motion_rad"][c] - ref) * 60 * 180 / np.pi <= 1e-6     # arcmin
    with pytest.raises(RvtoolInputError, match=r"distinct variant copies"):
        newton.solve(np.zeros(2), np.zeros(2), copies=[0, 0])


def test_variants_te_counts_every_exudyn_hand_over(rv):
    """rvtool.batched.device_rows_variants (the Monte Carlo's device path): the variants' TE equals
    each variant's Exudyn TE (quasi_static_te) to 1e-6 arcsec; with a Newton that cannot converge
    (one iteration, no homotopy) every point goes to Exudyn, is counted, and the TE is unchanged."""
    from rvtool import designs
    from rvtool.batched.device_rows_variants import device_rows_variants
    from rvtool.solver.device_newton import DeviceNewtonSettings
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    d, _ = rv
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    models = [rvtool.build(sample_rv_design(tol, d, k, 20261124)[0]) for k in (2, 3)]
    angles = np.array([0.0, 0.4, 0.8])
    ref = [quasi_static_te(m, torque=d.rated_torque, input_angles=angles, backend="exudyn")["te"] for m in models]
    r = device_rows_variants(models, torque=d.rated_torque, input_angles=angles)
    assert r.status == ["ok", "ok"] and r.exudyn_points == 0 and r.lost_motion_rad is None
    assert np.max(np.abs(r.te - np.array(ref))) * ARCSEC_PER_RAD <= TE_TOL
    stuck = device_rows_variants(models, torque=d.rated_torque, input_angles=angles,
                                 settings=DeviceNewtonSettings(max_iterations=1, homotopy=False))
    assert stuck.exudyn_points == 6 and stuck.status == ["ok", "ok"] and stuck.split["fallback_s"] > 0
    assert np.max(np.abs(stuck.te - np.array(ref))) * ARCSEC_PER_RAD <= TE_TOL


def test_rv40e_hysteresis_loop_on_the_device_equals_exudyn(rv):
    """The catalogue's loop (virgin preload, then -T -> +T -> -T at 1/16 T_R steps plus the rigidity
    and lost-motion points) on the device torque path against the Exudyn load continuation
    (rvtool.protocols.catalogue.ContinuationPath): every level's output angle within 1e-6 arcmin,
    the catalogue figures (rigidity, lost motion, hysteresis loss) within 1e-9 relative."""
    from rvtool.batched.device_rows_lost_motion import DeviceTorquePath
    from rvtool.protocols import catalogue as C
    from rvtool.units import ARCMIN_PER_RAD
    d, _ = rv
    pts = (0.5, 1.0)
    seq = C.catalogue_sequence(d.rated_torque, rigidity_points=pts)
    ref = C.catalogue_loop(C.ContinuationPath(rvtool.build(d)), seq, rigidity_points=pts)
    path = DeviceTorquePath(DeviceRowNewton(rvtool.build(d), 1))
    dev = C.catalogue_loop(path, seq, rigidity_points=pts)
    assert path.status() == ["device"] and path.stats()["exudyn_copies"] == 0
    for key in ("preload",):
        assert np.max(np.abs(dev[key] - ref[key])) * ARCMIN_PER_RAD <= 1e-6
    assert np.max(np.abs(dev["cycles"][0]["angle_rad"] - ref["cycles"][0]["angle_rad"])) * ARCMIN_PER_RAD <= 1e-6
    a, b = dev["metrics"], ref["metrics"]
    assert a.rigidity.value == pytest.approx(b.rigidity.value, rel=1e-9)
    assert a.lost_motion == pytest.approx(b.lost_motion, rel=1e-9)
    assert a.hysteresis_loss.value == pytest.approx(b.hysteresis_loss.value, rel=1e-9)


def test_a_copy_that_leaves_the_device_continues_on_exudyn(rv):
    """A continuation that cannot finish on the device (no step accepted: max_step 1e-12) hands the
    copy to the Exudyn load continuation at that level: counted, and the figures are Exudyn's."""
    from rvtool.batched.device_lost_motion import ContinuationSettings
    from rvtool.batched.device_rows_lost_motion import DeviceTorquePath
    from rvtool.protocols.catalogue import ContinuationPath
    d, model = rv
    levels = (0.5 * d.rated_torque, -0.5 * d.rated_torque, 0.25 * d.rated_torque)
    path = DeviceTorquePath(DeviceRowNewton(model, 1), continuation=ContinuationSettings(max_step=1e-12))
    got = [path.go_to(t) for t in levels]
    assert path.status() == ["exudyn"] and path.stats()["exudyn_copies"] == 1
    ref = ContinuationPath(rvtool.build(d))
    want = [ref.go_to(t) for t in levels]
    assert np.max(np.abs(np.array(got) - want)) * 60 * 180 / np.pi <= 1e-6          # arcmin


def test_analyze_hysteresis_runs_on_the_device_with_exudyns_figures():
    """rvtool analyze rv40e --protocols hysteresis --backend device: the loops on the device torque
    path, recorded as such, every figure equal to the Exudyn run's (angles within 1e-6 arcmin; the
    rigidity 1e-9 relative)."""
    ex = rvtool.analyze("rv40e", "hysteresis", quick=True, out_dir=None, backend="exudyn")["hysteresis"]
    dv = rvtool.analyze("rv40e", "hysteresis", quick=True, out_dir=None, backend="device")["hysteresis"]
    assert dv.status == "ok" and dv.settings["backend"]["ran"] == "device" and not dv.warnings
    assert ex.settings["backend"]["ran"] == "exudyn"
    fe, fd = ({f.name: f.value for f in r.figures} for r in (ex, dv))
    assert set(fe) == set(fd)
    for k in ("hysteresis_loss", "lost_motion_catalogue"):
        assert abs(fd[k] - fe[k]) <= 1e-6                                   # arcmin
    assert fd["torsional_rigidity_b_over_a"] == pytest.approx(fe["torsional_rigidity_b_over_a"], rel=1e-9)
    for key in ("angle_arcmin_loop1", "angle_arcmin_loop2"):
        assert np.max(np.abs(np.asarray(dv.data[key]) - np.asarray(ex.data[key]))) <= 1e-6


def test_variant_copies_reuse_the_built_profile_tables_and_compliances_bit_for_bit(rv):
    """copy_families of variant models takes each variant's cycloid profile tables and tooth
    compliances from its built sets (no second sampling: ~40 ms per copy); the copied rows and
    tables equal those of sets built from the meshes alone."""
    from rvtool.contact.cycloid_set import CycloidPinSet
    from rvtool.contact.involute_set import InvoluteContactSet
    from rvtool.solver.replica import copy_families
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    design = rv[0]
    tol = load_rv_tolerances(rvtool.designs.path("rv40e_tolerances"))
    models = [rvtool.build(sample_rv_design(tol, design, k, 7)[0]) for k in range(2)]
    fam = {f.name: f.set for f in copy_families(models, 2)}
    pins, gears = fam["pins"], fam["gears"]
    built = [e.evaluator for m in models for e in m.contact_elements() if e.evaluator.name == "pins"]
    assert len(pins.tables) == sum(len(b.tables) for b in built) > 2     # each variant's wheels' own profiles
    assert all(any(t is u for u in pins.tables) for b in built for t in b.tables)     # taken, not sampled again
    fresh = CycloidPinSet(pins.meshes, pins.n_bodies, samples_per_tooth=pins.samples_per_tooth, search=pins.search,
                          search_band=pins.search_band)
    assert fresh.window == pins.window
    np.testing.assert_array_equal(fresh.fparams, pins.fparams)
    np.testing.assert_array_equal(fresh.iparams, pins.iparams)
    for a, b in zip(fresh.tables, pins.tables):
        for x, y in zip(a, b):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    g = InvoluteContactSet(gears.meshes, gears.n_bodies)
    np.testing.assert_array_equal(g.fparams, gears.fparams)
    assert dataclasses.is_dataclass(pins.meshes[0])


def _same_set(old, new):
    """Every attribute of two sets equal (arrays bit for bit, kernels and assemblers by their index maps)."""
    assert set(vars(old)) == set(vars(new)), set(vars(old)) ^ set(vars(new))
    for k, v in vars(old).items():
        w = getattr(new, k)
        if isinstance(v, np.ndarray):
            assert v.dtype == w.dtype and np.array_equal(v, w), k
        elif hasattr(v, "tocsr"):                                   # a sparse matrix
            assert v.shape == w.shape and (v != w).nnz == 0, k
        elif isinstance(v, tuple) and v and isinstance(v[0], np.ndarray):
            for x, y in zip(v, w):
                np.testing.assert_array_equal(x, y)
        elif isinstance(v, (tuple, str, int, float, bool, dict, list)) or v is None:
            assert type(v) is type(w), k
            if not (isinstance(v, (tuple, list)) and v and isinstance(v[0], tuple)):
                assert v == w, k
    if hasattr(old, "assembler"):
        np.testing.assert_array_equal(old.assembler.index, new.assembler.index)


def test_copied_sets_equal_sets_built_from_the_shifted_renamed_members(rv):
    """copy_families concatenates the variants' built rows (bearings, cycloid pins, involute pairs)
    instead of building the B-copy set from the renamed, shifted mountings and meshes: every
    attribute equals the built set's."""
    from rvtool.solver.replica import _renamed, _shift, copy_families
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    tol = load_rv_tolerances(rvtool.designs.path("rv40e_tolerances"))
    models = [rvtool.build(sample_rv_design(tol, rv[0], k, 11)[0]) for k in range(3)]
    nb = len(models[0].body_names)
    fam = {f.name: f.set for f in copy_families(models, 3)}
    checked = 0
    for name, s_new in fam.items():
        sets = [next(e.evaluator for e in m.contact_elements() if e.evaluator.name == name) for m in models]
        s = sets[0]
        kind = type(s).__name__
        if kind in ("BearingSet", "TaperedBearingSet"):
            members = [_renamed(m, c, inner=_shift(m.inner, c * nb), outer=_shift(m.outer, c * nb))
                       for c, sc in enumerate(sets) for m in sc.mountings]
            old = type(s)(members, 3 * nb, name=s.name, backend=s.backend)
        elif kind == "CycloidPinSet":
            members = [_renamed(m, c, wheel_body=_shift(m.wheel_body, c * nb), pin_body=_shift(m.pin_body, c * nb))
                       for c, sc in enumerate(sets) for m in sc.meshes]
            old = type(s)(members, 3 * nb, samples_per_tooth=s.samples_per_tooth, search=s.search,
                          search_band=s.search_band, name=s.name)
            assert len(old.tables) == len(s_new.tables) == 6           # 3 variants x 2 wheels
            for a, b in zip(old.tables, s_new.tables):
                for x, y in zip(a, b):
                    np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
        elif kind == "InvoluteContactSet":
            members = [_renamed(m, c, body_a=_shift(m.body_a, c * nb), body_b=_shift(m.body_b, c * nb))
                       for c, sc in enumerate(sets) for m in sc.meshes]
            old = type(s)(members, 3 * nb, name=s.name)
            assert old.gap_offset_ids == s_new.gap_offset_ids
        else:
            continue
        _same_set(old, s_new)
        checked += 1
    assert checked == 5                             # eccentric, crank (tapered) and main bearings, pins, gears


def test_copies_take_the_built_rows_not_a_slow_state_offset(rv):
    """A built set's slow-state gap offsets (thermal, wear) are not part of its copy: the
    concatenated copy holds the built rows, as a set built from the members would."""
    from rvtool.solver.replica import copy_families
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    tol = load_rv_tolerances(rvtool.designs.path("rv40e_tolerances"))
    models = [rvtool.build(sample_rv_design(tol, rv[0], k, 13)[0]) for k in range(2)]
    before = {f.name: np.array(f.set.fparams if hasattr(f.set, "fparams") else f.set.lamina_fp)
              for f in copy_families(models, 2)}
    rows = lambda s: np.array(s.fparams if hasattr(s, "fparams") else s.lamina_fp)
    changed = 0
    for el in models[0].contact_elements():
        s = el.evaluator
        if callable(getattr(s, "set_gap_offsets", None)) and s.name != "gears":
            built = rows(s)
            s.set_gap_offsets(np.full(len(s.ids), 1e-6))
            changed += int(not np.array_equal(rows(s), built))
    assert changed >= 3                               # pins, bearings, tapered rows carry an offset now
    after = {f.name: np.array(f.set.fparams if hasattr(f.set, "fparams") else f.set.lamina_fp)
             for f in copy_families(models, 2)}
    for name in before:
        np.testing.assert_array_equal(after[name], before[name], err_msg=name)


def test_variant_snapshots_give_the_models_figures(rv):
    """device_rows_variants on pickled ModelSnapshots (what prepare_variant_models' workers send)
    gives the TE and lost motion of the built models bit for bit; a snapshot builds its model only
    where Exudyn takes over (real_model)."""
    import pickle
    from rvtool.batched.device_rows_variants import device_rows_variants, prepare_variant_models
    from rvtool.solver.model_snapshot import ModelSnapshot, real_model
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    design = rv[0]
    tol = load_rv_tolerances(rvtool.designs.path("rv40e_tolerances"))
    designs = [sample_rv_design(tol, design, k, 17)[0] for k in range(2)]
    models = [rvtool.build(d) for d in designs]
    snaps = [pickle.loads(pickle.dumps(ModelSnapshot(m, d))) for m, d in zip(models, designs)]
    angles = np.linspace(0.0, 0.4, 3)
    kw = dict(torque=design.rated_torque, input_angles=angles, lost_motion_level=0.03 * design.rated_torque)
    a = device_rows_variants(models, **kw)
    b = device_rows_variants(snaps, **kw)
    np.testing.assert_array_equal(b.te, a.te)
    np.testing.assert_array_equal(b.lost_motion_rad, a.lost_motion_rad)
    assert b.exudyn_points == a.exudyn_points == 0
    assert not snaps[0].is_built                             # nothing handed over: no model built
    m0 = real_model(snaps[0])
    assert snaps[0].is_built and real_model(snaps[0]) is m0
    np.testing.assert_array_equal(np.asarray(m0.reference), np.asarray(models[0].reference))
    # the pool path: two spawned workers build and send the snapshots
    pooled = prepare_variant_models(designs, workers=2)
    assert all(isinstance(s, ModelSnapshot) for s in pooled)
    c = device_rows_variants(pooled, **kw)
    np.testing.assert_array_equal(c.te, a.te)


def test_variant_kinematics_come_from_one_call_per_copy_bit_for_bit(rv):
    """prime_kinematics evaluates each variant copy's kinematics once for all angles; kinematic()
    reads them: equal to each copy's own call at each angle, for any assignment of copies."""
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    tol = load_rv_tolerances(rvtool.designs.path("rv40e_tolerances"))
    models = [rvtool.build(sample_rv_design(tol, rv[0], k, 19)[0]) for k in range(3)]
    nw = DeviceRowNewton(models)
    a = np.array([0.3, 0.1, 0.3])
    cp = np.array([2, 0, 1])
    got = nw.kinematic(a, cp)
    want = np.array([(models[c].kinematics.poses(a[p:p + 1])[0] - models[c].reference).reshape(-1)
                     for p, c in enumerate(cp)])
    want[:, nw.held] = 0.0
    want[:, nw.input_local] = a
    np.testing.assert_array_equal(got, want)
    assert not np.array_equal(got[0], got[1])                 # the angles are told apart


def test_resident_loop_as_a_cuda_graph():
    """On CUDA the device-resident row Newton loop is captured as a conditional graph on its second
    solve and replayed (loop_path "cuda_graph"): RV-40E's quick TE points on three copies equal the host
    loop's (settings graph=False) within 1e-9 arcsec (the atomic row sums vary in order between runs; the
    host loop's extra sweeps after the last copy ends leave every copy as it is), every point converged.
    Fails if the replay skipped or repeated a step. Skips without CUDA (the cpu runs the host loop)."""
    _skip_absent("cuda:0")
    from rvtool.solver.device_newton import DeviceNewtonSettings
    d = rvtool.load_design("rv40e")
    m = rvtool.build(d)
    angles = np.linspace(0.0, 0.6, 3)
    runs = {}
    for graph in (True, False):
        newton = DeviceRowNewton(m, 3, device="cuda:0", settings=DeviceNewtonSettings(graph=graph))
        tq = np.full(3, -np.sign(m.ratio) * d.rated_torque)
        r1 = newton.solve(angles, tq)                                  # the host loop: modules loaded
        r2 = newton.solve(angles + 0.1, tq, r1.q + newton.kinematic(angles + 0.1) - newton.kinematic(angles))
        assert np.all(r1.status == CONVERGED) and np.all(r2.status == CONVERGED)
        runs[graph] = (r2.q[:, newton.output_local], newton.loop_path)
    assert runs[True][1] == "cuda_graph" and runs[False][1] == "host_loop"
    assert np.max(np.abs(runs[True][0] - runs[False][0])) * ARCSEC_PER_RAD <= 1e-9


def test_rv_variant_kinematics_stacked_bit_for_bit():
    """RvKinematics.stacked_poses (the row Newton primes the kinematic states of RV variant copies in one
    evaluation, as CycloidKinematics'): equal to each variant's poses bit for bit; None for kinematics of
    another layout. Fails if a stacked operation differs from the per-variant one."""
    from rvtool.assembly.rv.builder import RvKinematics
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    d = rvtool.load_design("rv40e")
    tol = load_rv_tolerances(rvtool.designs.path("rv40e_tolerances"))
    ks = [rvtool.build(sample_rv_design(tol, d, k, 20261124)[0]).kinematics for k in (0, 1, 2)]
    angles = np.linspace(-1.0, 19.0, 11)
    assert np.array_equal(RvKinematics.stacked_poses(ks, angles), np.array([k.poses(angles) for k in ks]))
    from rvtool.assembly.cycloid import CycloidKinematics
    assert RvKinematics.stacked_poses(ks + [CycloidKinematics(rvtool.load_design("rd40"))], angles) is None
