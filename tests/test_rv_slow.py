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
from warp_contacts import circle_pairs_ref as O

ROW = dict(n_rollers=14, pitch_diameter=0.0335, roller_diameter=0.0055, roller_length=0.010, cup_angle_deg=14.0,
           cone_angle_deg=11.0, n_slices=2)


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
    want = a * dT * 0.5 * (row.pitch_diameter + row.roller_diameter) * math.cos(math.radians(row.cup_angle_deg))
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
