"""Bearing friction on the rolling-element bearing models (issue 17, Deliver 2): P1 from the accepted
element loads (ball, needle, tapered), Palmgren's moment against the hand-computed closed form, and
the switchable static part M1 (a Jenkins element on the relative rotation) against its closed-form
loop."""
import math

import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import BearingFriction, load_design, replace
from rvtool.bearings.friction_element import (BearingFrictionEvaluator, BearingLoss, ElementResultantLoads,
                                              mounting_losses, rolling_friction_evaluator)
from rvtool.bearings.friction_torque import PalmgrenFrictionTorque
from rvtool.bearings.tapered import TaperedRollerBearing
from rvtool.bearings.tapered_set import TaperedBearingSet, TaperedMounting
from rvtool.contact.circle_set import GROUND
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.solver.static import StaticSolver
from warp_contacts import circle_pairs_ref as cref

RD40 = load_design(designs.path("rd40"))


@pytest.fixture(scope="module")
def rolling():
    d = replace(RD40, bearing_friction={"model": "palmgren"})
    m = build(d, bearing_model="rolling")
    m.set_output_torque(-np.sign(m.ratio) * 0.5 * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    m.commit_contacts(q)
    return d, m, q


def test_rolling_load_is_the_element_resultant_and_balances_the_wheel(rolling):
    """P1 of an eccentric needle bearing = |sum of its element forces|; statics of the wheel: that
    resultant balances the pin and output-pin forces on the wheel (to the solver's residual and the
    weak regularization springs: 1e-3)."""
    d, m, q = rolling
    ev = m.elements["bearing_friction"].evaluator
    names = [b.name for b in ev.bearings]
    assert set(names) >= {"eccentric_bearing0", "eccentric_bearing1", "main_bearing"}
    for k in range(d.n_wheels):
        force = np.zeros(2)
        # force on the wheel: -F n of the pin rows (normal out of the profile), +F n of the output-pin
        # rows (normal of the pin, out of the hole's material)
        for fam, pick, sign in ((Family.PINS, lambda c: c.startswith(f"wheel{k}/"), -1.0),
                                (Family.OUTPUT_PINS, lambda c: f"/wheel{k}/" in c + "/", 1.0)):
            ob = m.observe(q, fam)
            on = np.array([pick(i) for i in ob.ids])
            force += sign * np.sum(ob.normal_force[on, None] * ob.normal[on], axis=0)
        P1 = ev.history.load[names.index(f"eccentric_bearing{k}")]
        assert P1 > 1e3
        assert P1 == pytest.approx(np.linalg.norm(force), rel=1e-3)


def test_rolling_moment_is_palmgren_by_hand(rolling):
    """M = 1e-7 f0 (nu n)^(2/3) d_m^3 + f1 P1 d_m [N mm] (Palmgren, nu [mm^2/s], n [r/min], d_m [mm]),
    evaluated by hand for eccentric bearing 0 at 1500 r/min relative speed; tanh(omega / 1e-2) = 1."""
    d, m, q = rolling
    el = m.elements["bearing_friction"]
    ev = el.evaluator
    k = [b.name for b in ev.bearings].index("eccentric_bearing0")
    w = 1500 * 2 * math.pi / 60
    vel = np.zeros((ev.n_bodies, 3))
    vel[0, 2] = w                                    # the shaft (inner) turns, the wheel held
    pose = np.zeros((ev.n_bodies, 3))
    e = ev.evaluate(pose, vel)
    bf, eb = d.bearing_friction, d.eccentric_bearing
    dm_mm = (2 * eb.inner_radius + eb.roller_diameter) * 1e3
    nu_n = bf.kinematic_viscosity * 1e6 * 1500.0
    M_nmm = 1e-7 * bf.f0_needle * nu_n ** (2 / 3) * dm_mm ** 3 + bf.f1_needle * ev.history.load[k] * dm_mm
    assert -e.obs[k, cref.O_FT] * 0.5 * ev.bearings[k].model.pitch_diameter == pytest.approx(M_nmm * 1e-3, rel=1e-9)


def test_tapered_pair_gets_its_factors_and_its_element_load():
    row = TaperedRollerBearing(n_rollers=14, pitch_diameter=0.0335, roller_diameter=0.0055, roller_length=0.010,
                               cup_angle=math.radians(14.0), cone_angle=math.radians(11.0))
    s = TaperedBearingSet([TaperedMounting(name="row", bearing=row, inner=0, outer=GROUND)], 1, backend="numpy")
    bf = BearingFriction(model="palmgren")
    (loss,) = mounting_losses(s.mountings, bf)
    assert (loss.model.f0, loss.model.f1, loss.model.pitch_diameter) == (bf.f0_tapered, bf.f1_tapered, 0.0335)
    ev = rolling_friction_evaluator(s, bf)
    pose = np.array([[2e-5, -1e-5, 0.0]])            # the cone pressed into the rollers
    ev.commit(pose, np.zeros((1, 3)))
    F = s.resultants(pose, np.zeros((1, 3)))["row"].force
    assert ev.history.load[0] == np.linalg.norm(F) > 0


def _jenkins(static_stiffness, f1=5e-4, dm=0.04, load=2000.0):
    model = PalmgrenFrictionTorque(f0=4.0, f1=f1, pitch_diameter=dm, kinematic_viscosity=3.2e-5)
    ev = BearingFrictionEvaluator([BearingLoss("b", 0, GROUND, model, ())], 1, lambda pose, vel: np.array([load]),
                                  static_stiffness=static_stiffness)
    return ev, f1 * load * dm


def test_static_part_is_a_jenkins_element_with_the_closed_form_loop():
    """Relative angle cycled quasi-statically (zero velocity: M0's speed law gives nothing) between
    +-phi_amp, each point an accepted step: the torque sticks with slope k_phi up to M1 = f1 P1 d_m,
    slips at |T| = M1, and the closed loop's area is 4 M1 (phi_amp - M1 / k_phi) (Jenkins element).
    The trapezoid rule on the piecewise-linear loop is exact at the breakpoints, which the sampling
    resolves to one step: tolerance one step's strip, 2 M1 dphi / loop area."""
    k = 2e4
    ev, M1 = _jenkins(k)
    zero = np.zeros((1, 3))
    ev.commit(zero, zero)                             # the first accepted state: the load committed
    amp, n = 4 * M1 / k, 400
    path = np.concatenate([np.linspace(0, amp, n // 4), np.linspace(amp, -amp, n // 2), np.linspace(-amp, amp, n // 2)])
    T, ft, slip = [], [], []
    for phi in path:
        pose = np.array([[0.0, 0.0, phi]])
        e = ev.evaluate(pose, zero)
        T.append(e.Q[2])
        assert abs(e.Q[2]) <= M1 * (1 + 1e-12)
        ev.commit(pose, zero, e)
        ft.append(abs(e.obs[1, cref.O_FT]))
        slip.append(ev.history.slip_distance[1])
    T, ft, slip = np.array(T), np.array(ft), np.array(slip)
    loop = slice(n // 4 + n // 2 - 1, None)           # from -amp back to +amp, then the down branch
    down = slice(n // 4 - 1, n // 4 + n // 2)
    phis = np.concatenate([path[down], path[loop]])
    Ts = np.concatenate([T[down], T[loop]])
    area = -np.trapezoid(Ts, phis)                    # the torque opposes the motion: loss positive
    exact = 4 * M1 * (amp - M1 / k)
    dphi = 2 * amp / (n // 2 - 1)
    assert area == pytest.approx(exact, abs=2 * M1 * dphi)
    # the energy account's anchor dissipation of the static row (|F_t| times the anchor travel r |d phi_a|)
    # over the closed cycle +amp -> -amp -> +amp (same anchor at both ends: no stored energy change)
    # is the loop area: the anchor moves only in slip, where |F_t| r = M1; the account's trapezoid
    # averages in the stick force of the step before each of the two stick-slip transitions (one step)
    c = slice(n // 4 - 1, None)
    diss = np.sum(0.5 * (ft[c][1:] + ft[c][:-1]) * np.diff(slip[c]))
    assert diss == pytest.approx(exact, abs=2 * M1 * dphi)
    law = ev.energy_law()
    assert list(law.friction_model) == [cref.FRICTION_REGULARIZED, cref.FRICTION_ANCHOR]
    assert law.tangential_stiffness[1] == pytest.approx(k / 0.02 ** 2, rel=1e-12)
    # the reversal branch at +amp: stick with slope k until -M1
    rev = path[down]
    Tr = T[down]
    stick = rev >= amp - 2 * M1 / k
    # after slipping at +amp the anchor is amp - M1/k: T = -M1 + k (amp - phi) until it reaches +M1
    np.testing.assert_allclose(Tr[stick], -M1 + k * (amp - rev[stick]), rtol=0, atol=1e-12 * M1)
    assert np.all(np.abs(Tr[~stick]) == pytest.approx(M1, rel=1e-12))


def test_static_tangent_and_switch():
    k = 2e4
    ev, M1 = _jenkins(k)
    zero = np.zeros((1, 3))
    ev.commit(zero, zero)
    e = ev.evaluate(np.array([[0.0, 0.0, 0.5 * M1 / k]]), zero)       # stick: dQ/dtheta = -k_phi
    assert e.dQdq[2, 2] == -k and e.Q[2] == pytest.approx(-0.5 * M1, rel=1e-12)
    e = ev.evaluate(np.array([[0.0, 0.0, 3 * M1 / k]]), zero)         # slip: the bound, no stiffness
    assert e.dQdq[2, 2] == 0.0 and e.Q[2] == pytest.approx(-M1, rel=1e-12)
    off, _ = _jenkins(None)
    off.commit(zero, zero)
    e = off.evaluate(np.array([[0.0, 0.0, 3 * M1 / k]]), zero)        # off: nothing at rest
    assert e.Q[2] == 0.0 and not np.any(e.dQdq)
    with pytest.raises(RvtoolInputError, match="static_stiffness"):
        _jenkins(-1.0)
    with pytest.raises(RvtoolInputError, match="bearing_friction.static_stiffness"):
        BearingFriction(model="palmgren", static_stiffness=float("nan"))


def test_static_part_in_the_energy_account_of_a_driven_run():
    """RD-40 driven at 1500 r/min with the static part on: the eccentric bearings slip continuously, the
    static rows dissipate M1 |d phi_a| as anchors, the speed rows M0 omega dt; the account closes as
    without the static part (1e-3)."""
    import exudyn as exu

    from rvtool.observe.energy import EnergyAccount
    from rvtool.protocols.hysteresis_cycles import energy_laws
    from rvtool.solver import RunSpec, simulate
    from rvtool.solver.continuation import Continuation
    w = 1500 * 2 * np.pi / 60
    model = build(replace(RD40, bearing_friction={"model": "palmgren", "static_stiffness": 1e4}))
    q = Continuation(model).go_to(50.0)
    model.commit_contacts(q)
    model.set_input_speed(w)
    mbs = model.mbs
    mbs.systemData.SetODE2Coordinates(q, configuration=exu.ConfigurationType.Initial)
    mbs.systemData.SetODE2Coordinates_t(model.body_vector(model.kinematic_state(0.0, w).velocities),
                                        configuration=exu.ConfigurationType.Initial)
    acc = EnergyAccount(mbs, model.contact_elements(), laws=energy_laws(model))
    rec = simulate(mbs, RunSpec(end_time=4e-4, step=2e-5, abs_tol=1e-6, rel_tol=1e-8), model.contact_elements(),
                   None, energy=acc)
    e = rec.energy
    ev = model.elements["bearing_friction"].evaluator
    assert ev.ids[0].endswith("/speed") and ev.ids[1].endswith("/static")
    assert ev.history.slip_distance[1::2].max() > 0 and not ev.history.slip_distance[0::2].any()
    loss = e["friction_dissipation_J"]["bearing_friction"]
    assert 0.0 < loss < 0.1 * e["drive_work_J"]
    assert e["balance_rel_err"] < 1e-3
