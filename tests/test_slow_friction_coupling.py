"""Coupled friction in the quasi-static windows: the friction hook of the model interface, the
prescribed kinematic velocity of a window at speed, and mu reaching the equilibria (RD-40)."""
import numpy as np
import pytest

from warp_contacts.circle_pairs_ref import O_FN, O_FT, O_VT

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design, replace
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.slow.offsets import GapOffsets
from rvtool.slow.reducer_windows import ReducerWindows, WindowProtocol, loaded_start

BASE = load_design(designs.path("rd40"))
MU = 0.05
DESIGN = replace(BASE, pin_contact={"mu": MU})
T = DESIGN.rated_torque
OMEGA = DESIGN.input_speed_rpm * np.pi / 30.0
ANGLE = 0.3


def _contacts(model, family):
    return model.observe(np.zeros(model.mbs.systemData.ODE2Size()), family).per_contact()[0]


def _solve(model, *, speed):
    if speed:
        model.set_prescribed_velocity(model.body_vector(model.kinematic_state(ANGLE, OMEGA).velocities))
    try:
        s = loaded_start(model, T, ANGLE)
        obs = model.family_element(Family.PINS).evaluation_at(s.q).obs.copy()
    finally:
        model.set_prescribed_velocity(None)
    return s.q.copy(), obs


def test_static_solve_has_no_friction_and_the_prescribed_kinematic_velocity_gives_mu_fn():
    m = build(DESIGN)
    q0, obs0 = _solve(m, speed=False)
    assert np.all(obs0[:, O_FT] == 0.0)            # zero velocity: tanh(0) = 0, no tangential force
    q1, obs1 = _solve(m, speed=True)
    on = obs1[:, O_FN] > 0
    assert on.sum() > 5
    # |v_t| / v_reg > 100 at the engaged pins (sliding ~0.1 m/s, v_reg 1e-4 m/s): tanh = 1 to 1e-80
    assert np.min(np.abs(obs1[on, O_VT])) > 100 * 1e-4
    assert np.allclose(np.abs(obs1[on, O_FT]), MU * obs1[on, O_FN], rtol=1e-12)
    # friction opposes the drive: the loaded wind-up grows (measured +5.5 arcsec of 164 at mu = 0.05)
    i = m.output_index
    w0, w1 = abs(q0[i] - m.kinematic_output(ANGLE)), abs(q1[i] - m.kinematic_output(ANGLE))
    assert w1 > w0 * (1 + 1e-3)
    # switched off again: the static solve is the built one, bit for bit
    q2, _ = _solve(m, speed=False)
    assert np.array_equal(q2, q0)


def test_written_mu_enters_the_contact_law_and_none_restores_the_build():
    m = build(DESIGN)
    names = _contacts(m, Family.PINS)
    _, obs_built = _solve(m, speed=True)
    m.set_friction(Family.PINS, {c: 2 * MU for c in names})
    _, obs2 = _solve(m, speed=True)
    on = obs2[:, O_FN] > 0
    assert np.allclose(np.abs(obs2[on, O_FT]), 2 * MU * obs2[on, O_FN], rtol=1e-12)
    m.set_friction(Family.PINS, None)
    _, obs3 = _solve(m, speed=True)
    assert np.array_equal(obs3, obs_built)
    # one contact only: the others keep the built mu
    m.set_friction(Family.PINS, {names[0]: 0.2})
    ev = m.family_element(Family.PINS).evaluator
    from warp_contacts.cycloid_pins_ref import C_MUK, C_MUS
    assert ev.fparams[0, C_MUK] == 0.2 and ev.fparams[0, C_MUS] == 0.2
    assert np.all(ev.fparams[ev.ids.index(f"{names[1]}/s0"), [C_MUK, C_MUS]] == MU)


def test_gap_offsets_and_friction_compose():
    m = build(DESIGN)
    names = _contacts(m, Family.PINS)
    m.set_friction(Family.PINS, {c: 0.1 for c in names})
    m.set_gap_offsets(Family.PINS, {c: 1e-6 for c in names})
    from warp_contacts.cycloid_pins_ref import C_E, C_MUK
    ev = m.family_element(Family.PINS).evaluator
    assert np.all(ev.fparams[:, C_MUK] == 0.1)            # the gap write kept the friction write
    built = build(DESIGN).family_element(Family.PINS).evaluator.fparams
    assert np.allclose(ev.fparams[:, C_E] - built[:, C_E], 1e-6, rtol=0, atol=1e-18)


def test_named_errors():
    m = build(BASE)                                        # pin_contact.mu = 0: no friction law
    names = _contacts(m, Family.PINS)
    with pytest.raises(RvtoolInputError, match="pin_contact.mu"):
        m.set_friction(Family.PINS, {names[0]: 0.1})
    m = build(DESIGN)
    with pytest.raises(RvtoolInputError, match="valid range"):
        m.set_friction(Family.PINS, {names[0]: -0.1})
    with pytest.raises(RvtoolInputError, match="lacks"):
        m.set_friction(Family.PINS, {"wheel7/pin0": 0.1})
    with pytest.raises(RvtoolInputError, match="cycloid pins"):
        m.set_friction(Family.OUTPUT_PINS, {})
    with pytest.raises(RvtoolInputError, match="shape"):
        m.set_prescribed_velocity(np.zeros(3))
    with pytest.raises(RvtoolInputError, match="sliding_friction"):
        WindowProtocol(torque=T, input_speed=OMEGA, sliding_friction=1)
    w = ReducerWindows(build(BASE), WindowProtocol(torque=T, input_speed=OMEGA, sliding_friction=True))
    with pytest.raises(RvtoolInputError, match="pin_contact.mu"):
        w.apply_offsets(GapOffsets.none(), {"pins/wheel0/pin0": 0.1})


def test_window_friction_work_equals_the_source_model_and_mu_changes_it():
    m = build(DESIGN)
    wp = WindowProtocol(torque=T, input_speed=OMEGA, window_angle=8 * m.mesh_period, steps=8, sliding_friction=True)
    w = ReducerWindows(m, wp)
    x = w.window()
    pins = np.array([c.startswith("pins/") for c in x.ids])
    source = MU * float(np.sum(x.I_s[pins])) / x.tau_w
    # contact-law work sum |F_t v_t| over the accepted steps vs the declared source mu I_s / tau_w
    # (same steps; sliding speeds kinematic in both, measured agreement 1e-4)
    assert abs(w.last_friction_power - source) <= 2e-3 * source
    assert m.family_element(Family.PINS).prescribed_velocity is None      # reset after the window
    w.apply_offsets(GapOffsets.none(), {c: 2 * MU for c in x.ids})
    w.window()
    assert w.last_friction_power > 1.9 * source                            # twice mu, loads a little higher
    # off: the same window without sliding friction has no friction work
    w0 = ReducerWindows(build(DESIGN), WindowProtocol(torque=T, input_speed=OMEGA, window_angle=8 * m.mesh_period,
                                                      steps=8))
    w0.window()
    assert w0.last_friction_power == 0.0
