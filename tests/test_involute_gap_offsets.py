"""Slow-state gap offsets of involute meshes per tooth flank (issue 18): kernel against reference on
every device, the offset follows its tooth through the window slots, a uniform flank offset is the
mesh clearance, zeros are bit-identical, and the slow windows run on the small-tooth-difference drive."""
import numpy as np
import pytest
import warp as wp

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.slow.offsets import GapOffsets
from rvtool.slow.reducer_windows import (ReducerWindows, WindowProtocol, involute_stage_bodies,
                                         std_involute_contact_bodies)
from test_involute_pairs import _cases, poses, scene
from warp_contacts import involute_pairs_ref as ref

DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(wp.get_cuda_device_count() == 0,
                                                                    reason="no CUDA device"))]


def _offsets(s, seed=5):
    return np.random.default_rng(seed).uniform(-3e-6, 3e-6, len(s.gap_offset_ids))


def _sweep(pair, dth):
    return poses(pair, np.linspace(0.0, 2 * np.pi / pair.gear_a.n_teeth, 7), dth)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("case", [0, 1])
def test_kernel_matches_reference_with_flank_offsets(case, device):
    """Tolerance as in test_involute_pairs.test_kernel_matches_numpy_reference (float64: 1e-9)."""
    _, pair, kw, dth, vel = _cases()[case]
    s_w, s_n = scene(pair, "warp", "float64", device, **kw), scene(pair, "numpy", **kw)
    off = _offsets(s_n)
    s_w.set_gap_offsets(off)
    s_n.set_gap_offsets(off)
    for pose in _sweep(pair, dth):
        a, b = s_w.evaluate(pose, vel), s_n.evaluate(pose, vel)
        for x, y in ((a.Q, b.Q), (a.dQdq, b.dQdq)):
            assert np.max(np.abs(x - y)) <= 1e-9 * np.max(np.abs(y))
        np.testing.assert_array_equal(a.obs[:, ref.O_MODE], b.obs[:, ref.O_MODE])


@pytest.mark.parametrize("backend", ["warp", "numpy"])
def test_offset_follows_its_tooth_and_zeros_are_bit_identical(backend):
    _, pair, kw, dth, vel = _cases()[1]
    built = scene(pair, backend, **kw)
    s = scene(pair, backend, **kw)
    ids = s.gap_offset_ids
    first = built.evaluate(_sweep(pair, dth)[0], vel).obs
    r0 = int(np.argmax(first[:, ref.O_FN]))
    target = built.flank_ids(first)[0][r0]          # the A flank of the most loaded row at the first pose
    off = np.zeros(len(ids))
    off[ids.index(target)] = 2e-6
    s.set_gap_offsets(off)
    slots = set()
    for pose in _sweep(pair, dth):
        b, x = built.evaluate(pose, vel), s.evaluate(pose, vel)
        fa, _ = s.flank_ids(x.obs)
        hit = np.array([f == target for f in fa]) & (b.obs[:, ref.O_MODE] != ref.MODE_OPEN)
        # the rows that hold that flank (whichever slot) open by exactly 2 um (gap sums
        # of ~5e-2 m positions: round-off 1e-17 m), every other row is untouched bit for bit
        assert np.allclose(x.obs[hit, ref.O_GAP] - b.obs[hit, ref.O_GAP], 2e-6, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(x.obs[~hit], b.obs[~hit])
        slots |= {s.ids[r].split("/")[2] for r in np.flatnonzero(hit)}
    assert len(slots) >= 2            # the tooth passed through more than one window slot
    s.set_gap_offsets(np.zeros(len(ids)))
    for pose in _sweep(pair, dth):
        b, x = built.evaluate(pose, vel), s.evaluate(pose, vel)
        for u, v in ((b.Q, x.Q), (b.dQdq, x.dQdq), (b.dQdv, x.dQdv), (b.obs, x.obs)):
            np.testing.assert_array_equal(u, v)


def test_uniform_flank_offset_is_the_mesh_clearance():
    """Every flank of gear A on both lines opened by c: the gap of Eq. (gap) with clearance e_0 + c
    (the same sum in another order: round-off of the ~1e-5 m approach, forces to 1e-9 relative)."""
    _, pair, kw, dth, vel = _cases()[1]
    s = scene(pair, "numpy", **kw)
    s.set_gap_offsets([1.5e-6 if "/gear_a/" in i else 0.0 for i in s.gap_offset_ids])
    c = scene(pair, "numpy", clearance=1.5e-6, **kw)
    for pose in _sweep(pair, 2 * dth):
        a, b = s.evaluate(pose, vel), c.evaluate(pose, vel)
        assert np.max(np.abs(a.Q - b.Q)) <= 1e-9 * max(np.max(np.abs(b.Q)), 1.0)


def test_bad_flank_offsets_are_named():
    _, pair, kw, _, _ = _cases()[1]
    s = scene(pair, "numpy", **kw)
    with pytest.raises(RvtoolInputError, match="one per tooth flank"):
        s.set_gap_offsets(np.zeros(3))
    with pytest.raises(RvtoolInputError, match="finite"):
        s.set_gap_offsets(np.full(len(s.gap_offset_ids), np.nan))


def test_slow_windows_run_on_the_small_tooth_difference_drive():
    d = load_design(designs.path("std_involute"))
    m = build(d)
    with pytest.raises(RvtoolInputError, match="wheel0/pin3"):
        m.set_gap_offsets(Family.INVOLUTE_STAGE, {"wheel0/pin3": 1e-6})
    w = ReducerWindows(m, WindowProtocol(torque=d.rated_torque, input_speed=d.input_speed_rpm * np.pi / 30, steps=4),
                       bodies=std_involute_contact_bodies(m))
    x0 = w.window()
    te0 = w.last_te.copy()
    flanks = [i for i in x0.ids if i.startswith("involute_stage/")]
    loaded = [i for i in flanks if x0.I_F[x0.index(i)] > 0]
    assert loaded and all("/tooth" in i for i in loaded)
    assert any(x0.I_s[x0.index(i)] > 0 for i in loaded)      # the flanks slide (kinematic speeds)
    # zeros written through the slow path: the window is bit-identical
    w.apply_offsets(GapOffsets(by_channel={"wear": {i: 0.0 for i in flanks}}), None)
    w.window()
    np.testing.assert_array_equal(w.last_te, te0)
    # wear of every loaded ring flank: the flank offsets reach the contact law and the wheels turn back
    w.apply_offsets(GapOffsets(by_channel={"wear": {i: 3e-6 for i in loaded if "/gear_b/" in i}}), None)
    assert max(m.gap_offsets(Family.INVOLUTE_STAGE).values()) == 3e-6
    w.window()
    assert np.max(np.abs(w.last_te - te0)) > 1e-7


def test_window_radii_of_the_mesh_are_per_flank():
    from rvtool.slow.contact_radius import window_radii
    d = load_design(designs.path("std_involute"))
    m = build(d)
    w = ReducerWindows(m, WindowProtocol(torque=d.rated_torque, input_speed=d.input_speed_rpm * np.pi / 30, steps=2),
                       bodies=std_involute_contact_bodies(m))
    x = w.window()
    R = window_radii(m, w.last_states)
    loaded = {i for i in x.ids if i.startswith("involute_stage/") and x.I_F[x.index(i)] > 0}
    assert set(R) == loaded
    # on the line of action the conformal internal pair: R = rho_A rho_B / (rho_B - rho_A) far above
    # either flank radius (rho ~ 17 mm, rho_B - rho_A = a sin alpha_w ~ 1.1 mm); a flank that also
    # met a tip edge (rho_e = 0.02 m_n) in the window is dominated by the edge's curvature
    v = np.array(list(R.values()))
    assert np.all(v > 0) and 0.1 < v.max() < 1.0
    rho_e = min(mm.pair.gear_a.edge_radius for mm in m.family_element(Family.INVOLUTE_STAGE).evaluator.meshes)
    assert 0.9 * rho_e < v.min() < rho_e      # R = (1/rho_e + 1/rho_flank)^-1, rho_flank >> rho_e


def test_rv_involute_stage_takes_flank_offsets():
    """The RV's spur stage (crank gears on the sun pinion) through the same model interface: zeros
    bit-identical; opening every crank-gear flank moves the equilibrium; a window observes it per
    flank with sliding (sun and crank bodies of each mesh) and a ring of flank offsets moves its TE."""
    from rvtool.solver.static import StaticSolver
    d = load_design(designs.path("rv40e"))
    m = build(d)
    ids = m.family_element(Family.INVOLUTE_STAGE).evaluator.gap_offset_ids
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q0 = StaticSolver(m).solve(0.0).copy()
    m.set_gap_offsets(Family.INVOLUTE_STAGE, {i: 0.0 for i in ids})
    np.testing.assert_array_equal(StaticSolver(m).solve(0.0), q0)
    m.set_gap_offsets(Family.INVOLUTE_STAGE, {i: 5e-6 for i in ids if "/gear_b/" in i})
    assert m.gap_offsets(Family.INVOLUTE_STAGE)[ids[-1]] == 5e-6
    assert np.max(np.abs(StaticSolver(m).solve(0.0) - q0)) > 1e-6
    m.set_gap_offsets(Family.INVOLUTE_STAGE, {})
    w = ReducerWindows(m, WindowProtocol(torque=d.rated_torque, input_speed=1500 * np.pi / 30, steps=4),
                       bodies={Family.INVOLUTE_STAGE: involute_stage_bodies(m)})
    assert involute_stage_bodies(m).body_b("crank_gear2/gear_b/tooth0/line0") == "crank2"
    x = w.window()
    te0 = w.last_te.copy()
    loaded = [i for i in x.ids if x.I_F[x.index(i)] > 0]
    assert loaded and all(x.I_s[x.index(i)] > 0 for i in loaded)
    w.apply_offsets(GapOffsets(by_channel={"wear": {i: 5e-6 for i in loaded if "/gear_b/" in i}}), None)
    w.window()
    assert np.max(np.abs(w.last_te - te0)) > 1e-7


def test_slow_loop_wears_and_heats_the_small_tooth_difference_mesh():
    """One slow update on std_involute's mesh: Archard wear per tooth flank (constant k_w; a flank takes
    half its pair's sliding exposure, so its depth is half the pair's loss, equal shares) reaches the
    contact law as flank offsets, and the heat of a pair is counted once."""
    from rvtool.slow.orchestrator import SlowOrchestrator, SlowSchedule, ThermalCoupling
    from rvtool.slow.thermal import SlidingLossSources, ThermalNetwork
    from rvtool.slow.wear import ConstantWearCoefficient, SurfaceAssociation, WearModel
    d = load_design(designs.path("std_involute"))
    m = build(d)
    omega = d.input_speed_rpm * np.pi / 30
    fam = Family.INVOLUTE_STAGE
    w = ReducerWindows(m, WindowProtocol(torque=d.rated_torque, input_speed=omega, steps=4),
                       bodies={fam: involute_stage_bodies(m)})
    x0 = w.window()
    te0 = w.last_te.copy()
    # the pair's sliding exposure from the rows themselves: sum over the window's rows of F |v_s| dt, with
    # v_s the kinematic sliding speed; the flanks' exposures sum to twice the half of each row
    a_flanks = sum(x0.I_s[x0.index(c)] for c in x0.ids if "/gear_a/" in c)
    b_flanks = sum(x0.I_s[x0.index(c)] for c in x0.ids if "/gear_b/" in c)
    assert a_flanks == pytest.approx(b_flanks, rel=1e-12) and a_flanks > 0
    k, A, hours = 1e-18, 2e-5, 500.0
    flank_bin = lambda cid, pos: "flank/" + cid.split("/", 1)[1]          # noqa: E731  the flank itself
    wear = WearModel(coefficient=ConstantWearCoefficient(k=k), nominal_area=A,
                     association=SurfaceAssociation(rules={fam.value: ((flank_bin, 1.0),)}))
    net = ThermalNetwork(nodes=("wheels", "housing"), capacity=[2e3, 2e4], links=(("wheels", "housing", 2.0),),
                         ambient_conductance=[0.0, 5.0], ambient_temperature=293.15)
    mu = 0.05
    sources = SlidingLossSources(friction=mu, partition={f"{fam.value}/wheel0/gear_a": {"wheels": 1.0},
                                                         f"{fam.value}/wheel1/gear_a": {"wheels": 1.0},
                                                         fam.value: {"housing": 1.0}})
    sch = SlowSchedule(service_time=hours * 3600, service_interval=hours * 3600, thermal_interval=600.0,
                       settling_windows=0)
    run = SlowOrchestrator(w, sch, wear=wear, thermal=ThermalCoupling(network=net, sources=sources)).run()
    s = hours * 3600 / x0.tau_w
    for cid in x0.ids:            # Eq. (obs_wear) per flank (the run's window is the same state as x0)
        assert run.contact_wear.get(cid, 0.0) == pytest.approx(k * x0.I_s[x0.index(cid)] / A * s, rel=1e-9)
    offs = m.gap_offsets(fam)     # the flank depths are the offsets in force
    for cid, depth in run.contact_wear.items():
        assert offs[cid.split("/", 1)[1]] == depth
    assert max(run.contact_wear.values()) > 1e-8
    w.window()
    assert np.max(np.abs(w.last_te - te0)) > 1e-8
    # heat: each pair once, half to each gear's node
    Q = sources.node_sources(x0, net)
    assert Q[0] == pytest.approx(Q[1], rel=1e-12) and Q[0] == pytest.approx(mu * a_flanks / x0.tau_w, rel=1e-12)
    assert run.temperature["wheels"] > 293.15
