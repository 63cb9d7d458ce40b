"""The gap-offset hook of the model interface and the reducer adapter of the slow loop (RD-40)."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design, replace
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.slow.offsets import GapOffsets
from rvtool.slow.reducer_windows import ReducerWindows, WindowProtocol, loaded_start
from rvtool.slow.rerun import MatchedProtocol

DESIGN = load_design(designs.path("rd40"))
T = DESIGN.rated_torque


def _states(model, n=4):
    solver = loaded_start(model, T, 0.0)
    out, prev = [solver.q.copy()], 0.0
    for k in range(1, n):
        out.append(solver.solve(k * model.mesh_period / n, prev).copy())
        prev = solver.last_angle
    return np.array(out)


def _contacts(model, family):
    return model.observe(np.zeros(model.mbs.systemData.ODE2Size()), family).per_contact()[0]


def test_zero_offsets_are_bit_identical_and_a_uniform_pin_offset_is_the_design_clearance():
    q_built = _states(build(DESIGN))
    m = build(DESIGN)
    for fam in m.families:
        m.set_gap_offsets(fam, {c: 0.0 for c in _contacts(m, fam)})
    assert np.array_equal(_states(m), q_built)          # switched off: bit for bit
    # e of Eq. (gap) = clearance + ...: a uniform offset is the design's clearance, exactly
    q_clear = _states(build(replace(DESIGN, wheels={"clearance": 2e-6})))
    m = build(DESIGN)
    m.set_gap_offsets(Family.PINS, {c: 2e-6 for c in _contacts(m, Family.PINS)})
    assert np.array_equal(_states(m), q_clear)
    assert np.max(np.abs(q_clear - q_built)) > 1e-6      # and it does move the solution


def test_bearing_offset_is_the_design_radial_clearance():
    # R_B = r_a + c (+1e-12 at build): the offset adds to c; equal up to the round-off of the sum
    q_ref = _states(build(replace(DESIGN, eccentric_bearing={"radial_clearance": 8e-6})))
    m = build(DESIGN)
    m.set_gap_offsets(Family.ECCENTRIC_BEARINGS, {c: 3e-6 for c in _contacts(m, Family.ECCENTRIC_BEARINGS)})
    assert np.max(np.abs(_states(m) - q_ref)) < 1e-12


def test_gap_offset_errors_are_named():
    m = build(DESIGN)
    with pytest.raises(RvtoolInputError, match="wheel9/pin0"):
        m.set_gap_offsets(Family.PINS, {"wheel9/pin0": 1e-6})
    with pytest.raises(RvtoolInputError, match="finite"):
        m.set_gap_offsets(Family.PINS, {"wheel0/pin0": float("nan")})
    with pytest.raises(RvtoolInputError, match="involute_stage"):
        m.set_gap_offsets(Family.INVOLUTE_STAGE, {})


def test_reducer_windows_exposure_and_offsets():
    m = build(DESIGN)
    omega = DESIGN.input_speed_rpm * np.pi / 30.0
    w = ReducerWindows(m, WindowProtocol(torque=T, input_speed=omega, steps=4))
    x = w.window()
    # the accepted clock: one mesh period of input rotation at omega (kink shifts <= 1e-5 rad per step)
    assert abs(x.tau_w - m.mesh_period / omega) <= 5 * 1e-5 / omega
    pins = [k for k, c in enumerate(x.ids) if c.startswith("pins/")]
    rolling = [k for k, c in enumerate(x.ids) if c.startswith("eccentric_bearings/")]
    assert len(pins) == 80 and np.all(x.I_s[pins] >= 0) and np.sum(x.I_s[pins]) > 0
    assert np.all(x.I_s[rolling] == 0.0) and np.all(x.I_F[rolling] > 0)   # rolling: load, no sliding
    # the window sums the loads of its accepted steps: mean load of the bearing = torque balance scale
    assert np.all(x.F_pk >= x.I_F / x.tau_w - 1e-9)
    # a set selector writes every contact of the family; channels add
    w.apply_offsets(GapOffsets(by_channel={"thermal/pins": {"pins": -1e-6}, "wear": {"pins/wheel0/pin3": 2e-6}}), None)
    g = m.gap_offsets(Family.PINS)
    assert g["wheel0/pin3"] == pytest.approx(1e-6, abs=1e-18) and g["wheel1/pin3"] == -1e-6
    by_ch = w.offsets_by_channel()
    assert len(by_ch["thermal/pins"]) == 80 and list(by_ch["wear"]) == ["pins/wheel0/pin3"]
    w.apply_offsets(GapOffsets.none(), None)
    assert not any(m.gap_offsets(Family.PINS).values())


def test_matched_protocol_inputs_are_checked():
    with pytest.raises(RvtoolInputError):
        MatchedProtocol(torque=T, te_angles=(0.0,), output_revolutions=1.0, lost_motion_torque=1.0, rated_torque=T)
    with pytest.raises(RvtoolInputError):
        MatchedProtocol(torque=T, te_angles=(0.0, 0.1), output_revolutions=1.0, lost_motion_torque=1.0,
                        rated_torque=T, stiffness_fractions=(0.5, 1.5))
    with pytest.raises(RvtoolInputError):
        WindowProtocol(torque=-1.0, input_speed=1.0)
