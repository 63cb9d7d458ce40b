"""Slow-state feedback on the RV (issue 18): gap offsets of the tapered crank bearings (kernel and
reference, per device), the RV thermal network and gap channels of :mod:`rvtool.slow.rv` (signs,
first-order cancellation of equal expansion, projection), offsets through
``ReducerModel.set_gap_offsets`` on every RV channel family, and input errors."""
import math

import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.rv import build, load_design
from rvtool.bearings.tapered import TaperedPair, TaperedRollerBearing
from rvtool.bearings.tapered_set import TaperedBearingSet, TaperedMounting
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.slow import rv as RV
from rvtool.slow.thermal import InvoluteMeshExpansion
from warp_contacts import circle_pairs_ref as O

ROW = dict(n_rollers=14, pitch_diameter=0.0335, roller_diameter=0.0055, roller_length=0.010, cup_angle=math.radians(14.0),
           cone_angle=math.radians(11.0), n_slices=2)


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401  (sets Warp's log level)
    wp.init()
    return [d.alias for d in wp.get_devices()]


def tapered(backend="numpy", device="cpu"):
    pair = TaperedPair(rows=(TaperedRollerBearing(**ROW), TaperedRollerBearing(**ROW)), row_spacing=0.04,
                       axial_preload=300.0)
    return TaperedBearingSet([TaperedMounting(name="crank_bearing", bearing=pair, inner=0, outer=1)], 2,
                             backend=backend, device=device)


POSE = np.array([[4e-6, -3e-6, 0.2], [0.0, 0.0, -0.1]])


@pytest.mark.parametrize("device", _devices())
def test_tapered_gap_offsets(device):
    # a gap offset o on a lamina lowers its approach by exactly o (the offset adds to o_s); kernel
    # and reference agree with offsets in force (float64: 1e-11 relative, the kernel's test bound);
    # zeros restore the built evaluation bit for bit
    ref, ker = tapered(), tapered("warp", device)
    built = ref.evaluate(POSE).obs.copy()
    built_k = ker.evaluate(POSE).obs.copy()
    off = np.linspace(-0.5e-6, 1.0e-6, len(ref.ids))
    for s in (ref, ker):
        s.set_gap_offsets(off)
    a, b = ref.evaluate(POSE), ker.evaluate(POSE)
    np.testing.assert_allclose(a.obs[:, O.O_GAP], built[:, O.O_GAP] + off, rtol=0, atol=1e-18)
    np.testing.assert_allclose(b.obs, a.obs, rtol=1e-11, atol=1e-9)
    np.testing.assert_allclose(b.Q, a.Q, rtol=1e-11, atol=1e-9)
    assert np.any(a.obs[:, O.O_FN] != built[:, O.O_FN])
    for s in (ref, ker):
        s.set_gap_offsets(np.zeros(len(ref.ids)))
    np.testing.assert_array_equal(ref.evaluate(POSE).obs, built)
    np.testing.assert_array_equal(ker.evaluate(POSE).obs, built_k)
    with pytest.raises(RvtoolInputError, match="crank_bearing|tapered"):
        ref.set_gap_offsets(np.full(len(ref.ids), np.nan))


@pytest.fixture(scope="module")
def rv40e():
    return load_design(designs.path("rv40e"))


def test_rv_network_and_channels(rv40e):
    inputs = RV.RvSlowInputs()
    th = RV.thermal_coupling(rv40e, inputs)
    net = th.network
    assert net.nodes == RV.NODES and np.all(np.asarray(net.capacity) > 0)
    names = [ch.name for ch in th.channels]
    assert names == ["thermal/pins", "thermal/eccentric_bearings", "thermal/crank_bearings", "thermal/main_bearings"]
    a, dT = inputs.expansion, 10.0
    T = np.full(len(net.nodes), RV.T_AMBIENT + dT)
    gaps = {ch.name: ch.gap_change(net, T) for ch in th.channels}
    # equal expansion of races and elements cancels to first order: Delta c = alpha dT c (Eq.
    # (obs_thermal_gap) for bearings), times the projection of the law's offset direction
    eb = rv40e.eccentric_bearing
    assert gaps["thermal/eccentric_bearings"] == pytest.approx(a * dT * eb.radial_clearance, rel=1e-9, abs=1e-18)
    assert abs(gaps["thermal/crank_bearings"]) < 1e-15 and abs(gaps["thermal/main_bearings"]) < 1e-15
    # envelope: equal expansion of housing, pins and wheel cancels too (R_z - r_z - (R_z - r_z) = 0)
    assert abs(gaps["thermal/pins"]) < 1e-15
    # a hotter carrier than the crank opens the tapered clearance by alpha dT R_o cos(cup angle)
    T2 = np.full(len(net.nodes), RV.T_AMBIENT)
    T2[net.index("carrier")] += dT
    row = rv40e.crank_bearing.rows[0]
    want = a * dT * 0.5 * (row.pitch_diameter + row.roller_diameter) * math.cos(row.cup_angle)
    crank = [ch for ch in th.channels if ch.name == "thermal/crank_bearings"][0]
    assert crank.gap_change(net, T2) == pytest.approx(want, rel=1e-12)
    # a hotter wheel than the housing closes the pin gaps
    T3 = np.full(len(net.nodes), RV.T_AMBIENT)
    T3[net.index("wheels")] += dT
    assert th.channels[0].gap_change(net, T3) < 0


def test_rv_gap_offsets_reach_every_channel_family(rv40e):
    m = build(rv40e, backend="numpy")
    q = np.zeros(m.mbs.systemData.ODE2Size())
    for fam in (Family.PINS, Family.ECCENTRIC_BEARINGS, Family.CRANK_BEARINGS, Family.MAIN_BEARINGS):
        names, _ = m.observe(q, fam).per_contact()
        m.set_gap_offsets(fam, {names[0]: 1e-6})
        got = m.gap_offsets(fam)
        assert got[names[0]] == 1e-6 and all(v == 0.0 for k, v in got.items() if k != names[0])
        m.set_gap_offsets(fam, {})


def test_rv_slow_input_errors(rv40e):
    with pytest.raises(RvtoolInputError, match="housing_outer_radius"):
        RV.heat_capacities(rv40e, RV.RvSlowInputs(housing_outer_radius=0.05))
    with pytest.raises(RvtoolInputError, match="mu_pins"):
        RV.RvSlowInputs(mu_pins=-0.1)
    with pytest.raises(RvtoolInputError, match="factor"):
        RV.ProjectedExpansion(None, 0.0)
    with pytest.raises(RvtoolInputError, match="mu_involute"):
        RV.RvSlowInputs(mu_involute=-0.1)
    with pytest.raises(RvtoolInputError, match="working_pitch_radius"):
        InvoluteMeshExpansion(centre_distance=0.036, working_pitch_radius_a=0.009, working_pitch_radius_b=0.045,
                              working_pressure_angle=0.35, frame_expansion=1e-5, gear_a_expansion=1e-5,
                              gear_b_expansion=1e-5)     # a = r_wB - r_wA: an internal pair, refused
    with pytest.raises(RvtoolInputError, match="body 'flange'"):
        RV.body_node("flange")


def test_involute_mesh_expansion_closed_form():
    # Delta g = sin(alpha_w) (alpha_f dT_f a - alpha_A dT_A r_wA - alpha_B dT_B r_wB): equal alpha dT
    # cancel (a = r_wA + r_wB, to rounding 1e-20 m); each term alone is its closed form to rounding
    x = InvoluteMeshExpansion(centre_distance=0.036, working_pitch_radius_a=0.009, working_pitch_radius_b=0.027,
                              working_pressure_angle=0.35, frame_expansion=11.5e-6, gear_a_expansion=11.5e-6,
                              gear_b_expansion=11.5e-6)
    s = math.sin(0.35)
    assert abs(x.gap_change(10.0, 10.0, 10.0)) < 1e-20
    assert x.gap_change(10.0, 0.0, 0.0) == pytest.approx(s * 11.5e-6 * 10.0 * 0.036, rel=1e-14)
    assert x.gap_change(0.0, 10.0, 0.0) == pytest.approx(-s * 11.5e-6 * 10.0 * 0.009, rel=1e-14)
    assert x.gap_change(0.0, 0.0, 10.0) == pytest.approx(-s * 11.5e-6 * 10.0 * 0.027, rel=1e-14)


@pytest.fixture(scope="module")
def rv_windows(rv40e):
    from rvtool.slow.reducer_windows import ReducerWindows, WindowProtocol
    m = build(rv40e)
    omega = rv40e.input_speed_rpm * math.pi / 30
    w = ReducerWindows(m, WindowProtocol(torque=rv40e.rated_torque, input_speed=omega, steps=6),
                       bodies=RV.contact_bodies(m))
    return m, w, RV.thermal_coupling(rv40e, RV.RvSlowInputs(), model=m)


def test_rv_involute_stage_heat(rv40e, rv_windows):
    """Issue 18: the involute flanks are window contacts with sliding exposure; their loss
    mu_involute I_s / tau_w is shared equally by the input node (the sun) and the cranks node (the
    crank gears): with the bearings rolling, these two nodes get nothing else, so each gets half of
    the involute loss (to rounding, 1e-12 relative), and the loss is positive. Without the model the
    declaration is the one before issue 18 (no involute window contacts)."""
    m, w, th = rv_windows
    net = th.network
    ex = w.window()
    inv = [i for i, c in enumerate(ex.ids) if c.startswith(Family.INVOLUTE_STAGE.value + "/")]
    assert inv and np.sum(ex.I_s[inv]) > 0
    P = th.sources.power(ex)
    Q = th.sources.node_sources(ex, net)
    half = 0.5 * float(np.sum(P[inv]))
    assert half > 0
    assert Q[net.index("input")] == pytest.approx(half, rel=1e-12)
    assert Q[net.index("cranks")] == pytest.approx(half, rel=1e-12)
    assert sum(Q) == pytest.approx(float(np.sum(P)), rel=1e-12)
    assert Family.INVOLUTE_STAGE not in RV.contact_bodies()


def test_rv_involute_flank_channel_shifts_the_output(rv40e, rv_windows):
    """Issue 18: a hotter carrier opens each sun--crank-gear pair by alpha dT a sin(alpha_w) (the
    channel writes it on the sun's flanks); at rated torque the sun must turn that much further
    along the line of action before the crank gears take the load, so at a fixed input angle the
    output lags by delta / (r_b,sun |i|) more (every mesh opened alike: the same loads, a rigid shift;
    measured 1.2e-4 relative, tolerance 1e-3: the contacts are evaluated at slightly different roll
    positions and crank deflections). The gear B flanks get no offset; zeros restore the rated state."""
    from rvtool.slow.thermal import thermal_gap_offsets
    from rvtool.solver.static import StaticSolver
    m, w, th = rv_windows
    net = th.network
    inv = [ch for ch in th.channels if ch.name.startswith("thermal/involute_stage/")]
    assert [ch.nodes for ch in inv] == [("carrier", "input", "cranks")] * 3
    T = np.full(len(net.nodes), RV.T_AMBIENT)
    T[net.index("carrier")] += 20.0
    pair = m.family_element(Family.INVOLUTE_STAGE).evaluator.meshes[0].pair
    delta = RV.RvSlowInputs().expansion * 20.0 * pair.a * math.sin(pair.working_pressure_angle)
    assert inv[0].gap_change(net, T) == pytest.approx(delta, rel=1e-12)

    def rated_output():
        s = StaticSolver(m)
        m.set_output_torque(-np.sign(m.ratio) * rv40e.rated_torque)
        return s.solve(0.0)[m.output_index]

    cold = rated_output()
    w.apply_offsets(thermal_gap_offsets(inv, net, T), None)      # the flank channels alone (the bearings'
    # channels also see the carrier's temperature)
    offs = m.gap_offsets(Family.INVOLUTE_STAGE)
    assert all(v == pytest.approx(delta, rel=1e-12) for k, v in offs.items() if "/gear_a/" in k)
    assert all(v == 0.0 for k, v in offs.items() if "/gear_b/" in k)
    hot = rated_output()
    w.apply_offsets(thermal_gap_offsets(th.channels, net, np.full(len(net.nodes), RV.T_AMBIENT)), None)
    want = delta / (pair.gear_a.base_radius * abs(m.ratio))
    assert abs(hot - cold) == pytest.approx(want, rel=1e-3)
    assert abs(rated_output() - cold) < 1e-12
