"""The torque path, a task of the backend interface (issue 29): ``Backend.torque_path(model)``
with ``go_to(torque)``, ``state()``, ``stats()`` and ``supports(model, "torque_path")`` with named
reasons, on Exudyn (:class:`rvtool.solver.torque_path.ContinuationPath`) and the device row
Newton (:class:`rvtool.solver.device_torque_path.DeviceTorquePath`); the stiffness, lost-motion
and hysteresis protocols of ``rvtool analyze`` run their torque sequences through it."""
import numpy as np
import pytest

import rvtool
from rvtool.errors import RvtoolInputError
from rvtool.protocols import stiffness as S
from rvtool.solver.backends import TORQUE_PATH_ORDER, auto_order, choose, get
from rvtool.solver.continuation import Continuation
from rvtool.solver.device_torque_path import DeviceTorquePath
from rvtool.solver.torque_path import ContinuationPath
from rvtool.units import RAD_PER_ARCMIN

ARCMIN = 1.0 / RAD_PER_ARCMIN


@pytest.fixture(scope="module")
def rd40():
    d = rvtool.load_design("rd40")
    return d, S.TorqueSequence(rated_torque=d.rated_torque, loading_step=0.25, other_step=0.25)


def test_supports_names_every_reason():
    model = rvtool.build(rvtool.load_design("rd40"))
    assert get("exudyn").supports(model, "torque_path").ok and get("device").supports(model, "torque_path").ok
    for name in ("replica", "fused"):
        sup = get(name).supports(model, "torque_path")
        assert not sup.ok and "does not implement 'torque_path'" in sup.reasons[0]
        with pytest.raises(NotImplementedError, match="torque path"):
            get(name).torque_path(model)
    assert isinstance(get("exudyn").torque_path(model), ContinuationPath)
    assert isinstance(get("device").torque_path(model), DeviceTorquePath)
    # an elastic housing with ports and elastic crank closures: the device takes them as extra unknowns
    # (tests/test_device_families.py holds its figures to Exudyn's); auto keeps Exudyn there, with the reason
    rv80e = rvtool.build(rvtool.load_design("rv80e"))
    assert get("device").supports(rv80e, "torque_path").ok
    assert isinstance(get("device").torque_path(rv80e), DeviceTorquePath)
    b, choice = choose("auto", rv80e, "torque_path")
    assert b.name == "exudyn" and "extra unknowns" in choice["not_taken"]["device"]
    # a closure with a nonlinear station law (conformal grooves): the device names it
    grooved = rvtool.build(rvtool.load_design("rv40e").replace(pins={"groove": "conformal", "groove_clearance": 5e-6}))
    sup = get("device").supports(grooved, "torque_path")
    assert not sup.ok and any("station law" in r and "pins.groove" in r for r in sup.reasons)
    with pytest.raises(RvtoolInputError, match="cannot run a torque path"):
        get("device").torque_path(grooved)
    with pytest.raises(RvtoolInputError, match="cannot run torque_path"):
        choose("device", grooved, "torque_path")
    b, choice = choose("auto", grooved, "torque_path")
    assert b.name == "exudyn" and "station law" in choice["not_taken"]["device"]


def test_auto_order_of_the_torque_path():
    """auto's measured order (TORQUE_PATH_ORDER's docstring): on a CPU the device first, the
    cycloid left to Exudyn with its reason; CUDA unmeasured, the oracle first."""
    assert auto_order("torque_path") == ["device", "exudyn"] == list(TORQUE_PATH_ORDER["cpu"])
    assert auto_order("torque_path", device="cuda:0") == ["exudyn", "device"]
    b, choice = choose("auto", rvtool.build(rvtool.load_design("rd40")), "torque_path")
    assert b.name == "exudyn" and "cycloid drive the device torque path is slower" in choice["not_taken"]["device"]
    b, choice = choose("auto", rvtool.build(rvtool.load_design("rv40e")), "torque_path")
    assert b.name == "device" and "comes after 'device'" in choice["not_taken"]["exudyn"]


def test_exudyn_torque_path_is_todays_continuation_bit_for_bit(rd40):
    """The stiffness sequence and the tangent check on the Exudyn torque path are the continuation
    they were before the interface (the old loops, written out here): equal bit for bit."""
    d, seq = rd40
    got = S.quasi_static_stiffness(rvtool.build(d), seq)
    model = rvtool.build(d)
    cont = Continuation(model)
    th_kin = model.kinematic_output(0.0)
    want = [(cont.go_to(float(t))[model.output_index] - th_kin) / RAD_PER_ARCMIN for t in seq.levels()[0]]
    assert np.array_equal(got["angle_arcmin"], want)
    assert np.array_equal(got["q_final"], cont.q) and got["stats"] == {**cont.stats.to_dict(),
                                                                       "wall_s": got["stats"]["wall_s"]}
    assert got["backend"]["ran"] == "exudyn" and got["continuation"] is got["path"].continuation
    t = 0.75 * d.rated_torque
    tc = S.tangent_check(rvtool.build(d), t)
    model = rvtool.build(d)
    cont = Continuation(model)
    q = cont.go_to(t)
    kt = S.condensed_tangent(model, q) * RAD_PER_ARCMIN
    dt = 0.001 * t
    th_p = cont.go_to(t + dt)[model.output_index]
    cont.go_to(t)
    th_m = cont.go_to(t - dt)[model.output_index]
    assert tc["Kt_condensed_Nm_per_arcmin"] == kt
    assert tc["K_finite_increment_Nm_per_arcmin"] == 2 * dt / ((th_p - th_m) / RAD_PER_ARCMIN)


def test_device_torque_path_state_and_initial_torque(rd40):
    """state() is the equilibrium in the model's coordinates (every coordinate carried: the
    tangent at it equals Exudyn's); initial_torque starts the path at a level before the first
    asked for, as ContinuationPath's."""
    d, _ = rd40
    t = 0.75 * d.rated_torque
    ex_model, dv_model = rvtool.build(d), rvtool.build(d)
    ex = get("exudyn").torque_path(ex_model, initial_torque=0.0)
    dv = get("device").torque_path(dv_model, initial_torque=0.0)
    assert abs(ex.go_to(t) - dv.go_to(t)) * ARCMIN <= 1e-6
    assert dv.stats()["start_scales"]["1"] == 1 and dv.stats()["exudyn_copies"] == 0
    qe, qd = ex.state(), dv.state()
    assert qd.shape == qe.shape and np.max(np.abs(qd - qe)) <= 1e-9           # m, rad (Newton tolerances)
    assert S.condensed_tangent(dv_model, qd) == pytest.approx(S.condensed_tangent(ex_model, qe), rel=1e-9)
    with pytest.raises(RvtoolInputError, match="before its first go_to"):
        get("device").torque_path(dv_model).state()


@pytest.mark.parametrize("name", ["rd40", "rv40e"])
def test_analyze_stiffness_and_lost_motion_on_the_device_equal_exudyn(name):
    """rvtool analyze DESIGN --protocols stiffness,lost_motion --backend device (quick): the
    torque sequences on the device torque path, recorded as such, every figure equal to the
    Exudyn run's (stiffness 1e-9 relative, lost motion and the zero-load return 1e-6 arcmin)."""
    ex = rvtool.analyze(name, "stiffness,lost_motion", quick=True, out_dir=None, backend="exudyn")
    dv = rvtool.analyze(name, "stiffness,lost_motion", quick=True, out_dir=None, backend="device")
    for p in ("stiffness", "lost_motion"):
        assert ex[p].status == dv[p].status == "ok"
        assert ex[p].settings["backend"]["ran"] == "exudyn" and dv[p].settings["backend"]["ran"] == "device"
        assert set(dv[p].settings["backend"]["not_taken"]) == {"exudyn", "replica", "fused"}
        fe, fd = ({f.name: f.value for f in r[p].figures} for r in (ex, dv))
        assert set(fe) == set(fd)
        for k, v in fe.items():
            if k.startswith("K"):
                assert fd[k] == pytest.approx(v, rel=1e-9), k
            else:                                                               # arcmin
                assert abs(fd[k] - v) <= 1e-6, k
    assert not dv["stiffness"].warnings and dv["stiffness"].data["continuation"]["exudyn_copies"] == 0
    # auto: the measured order (the cycloid on Exudyn, the RV on the device), every reason named
    auto = rvtool.analyze(name, "lost_motion", quick=True, out_dir=None, backend="auto")["lost_motion"]
    rec = auto.settings["backend"]
    assert rec["ran"] == ("exudyn" if name == "rd40" else "device")
    assert set(rec["not_taken"]) == {"exudyn", "device", "replica", "fused"} - {rec["ran"]}
    assert "implements no torque path" in rec["not_taken"]["replica"]
    assert abs(auto.figures[0].value - {f.name: f.value for f in ex["lost_motion"].figures}["lost_motion"]) <= 1e-6


def test_named_backend_that_cannot_run_the_torque_path_skips():
    res = rvtool.analyze("rd40", "stiffness,lost_motion,hysteresis", quick=True, out_dir=None, backend="replica")
    for p in ("stiffness", "lost_motion", "hysteresis"):
        assert res[p].status == "skipped" and "does not run torque_path" in res[p].reason


@pytest.mark.parametrize("name,backend", [("rd40", "exudyn"), ("rv40e", "exudyn"), ("rv40e", "device"),
                                          ("std_involute", "exudyn"), ("rv_three_stage", "exudyn")])
def test_tangent_check_on_the_sequences_model_is_a_fresh_builds(name, backend):
    """The stiffness protocol builds its model once: the tangent check after the sequence on the
    same model (stateful_reasons empty) equals the one on a fresh build bit for bit (every shipped
    design the check admits)."""
    from rvtool.solver.torque_path import stateful_reasons
    d = rvtool.load_design(name)
    seq = S.TorqueSequence(rated_torque=d.rated_torque, loading_step=0.25, other_step=0.25)
    model = rvtool.build(d)
    assert stateful_reasons(model) == []
    S.quasi_static_stiffness(model, seq, backend=backend)
    t = 0.75 * d.rated_torque
    reused, fresh = S.tangent_check(model, t, backend=backend), S.tangent_check(rvtool.build(d), t, backend=backend)
    for k in ("Kt_condensed_Nm_per_arcmin", "K_finite_increment_Nm_per_arcmin", "rel_diff"):
        assert reused[k] == fresh[k], k
    assert stateful_reasons(rvtool.build(rvtool.load_design("rv80e")))          # elastic housing, crank closures


def test_device_state_after_the_exudyn_hand_over():
    """A copy that leaves the device (here forced: max_step 1e-12 rejects every device step)
    continues on Exudyn; state() is then its Exudyn continuation's, equal to a fresh Exudyn path's."""
    from rvtool.solver.device_rows import DeviceRowNewton
    from rvtool.solver.torque_path import ContinuationSettings
    d = rvtool.load_design("rd40")
    t = 0.5 * d.rated_torque
    path = DeviceTorquePath(DeviceRowNewton(rvtool.build(d), 1), continuation=ContinuationSettings(max_step=1e-12))
    path.go_to(t)                          # the loaded start: on the device
    assert path.status() == ["device"]
    got = path.go_to(-t)                   # every step rejected: Exudyn from -t on
    assert path.status() == ["exudyn"] and path.stats()["exudyn_copies"] == 1
    ref = ContinuationPath(rvtool.build(d))
    assert got == ref.go_to(-t) and np.array_equal(path.state(), ref.state())
