"""Thermal network of Eq. (obs_thermal): the single-node instance Eq.
(obs_single_node) against its closed-form transient and steady state, the
steady fixed point against a closed-form fixed point, sources from the
sliding-loss model, the expansion maps (Eq. (obs_thermal_gap) and the bearing
clearance) and named input errors.
"""
import math

import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.slow.exposure import WindowExposure
from rvtool.slow.thermal import (BearingClearanceExpansion, CycloidEnvelopeExpansion, FixedPointNotConverged,
                                 SlidingLossSources, ThermalGapChannel, ThermalNetwork, combine_phase_sources,
                                 single_node_transient, single_node_update, steady_fixed_point, thermal_gap_offsets)

C, G, T_AMB, P = 800.0, 4.0, 293.15, 60.0      # J/K, W/K, K, W: time constant C/G = 200 s
MU, TAU_W = 0.05, 0.02                          # -, s: I_s_total = P tau_w / mu gives the source P


def _one_node():
    return ThermalNetwork(nodes=("wheel",), capacity=[C], ambient_conductance=[G], ambient_temperature=T_AMB)


def test_network_step_is_the_single_node_update():
    # Eq. (obs_single_node): T+ = [(C/dtau) T + mu sum I_s / tau_w + G T_amb] / (C/dtau + G)
    net, I_s = _one_node(), P * TAU_W / MU
    T_net = net.step([300.0], [MU * I_s / TAU_W], 10.0)[0]
    T_one = single_node_update(300.0, capacity=C, dtau=10.0, mu=MU, I_s_total=I_s, tau_w=TAU_W, conductance=G,
                               ambient_temperature=T_AMB)
    assert T_net == pytest.approx(T_one, rel=1e-15)
    assert T_one == pytest.approx((80.0 * 300.0 + P + G * T_AMB) / 84.0, rel=1e-15)


def test_single_node_transient_converges_first_order_to_closed_form():
    # C dT/dt + G (T - T_amb) = P: T(t) = T_inf + (T0 - T_inf) exp(-G t / C), T_inf = T_amb + P / G.
    # The implicit update is backward Euler: its error at fixed t halves with dtau (ratio -> 2).
    net, t_end = _one_node(), 300.0
    exact = single_node_transient(t_end, T0=T_AMB, capacity=C, conductance=G, power=P, ambient_temperature=T_AMB)
    errors = [abs(net.march([T_AMB], [P], t_end, dtau)[0] - exact) for dtau in (20.0, 10.0, 5.0, 2.5)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.9) & (ratios < 2.1)), ratios
    # leading error of backward Euler on y' = -(y - y_inf) / tau: (1 + h/tau)^(-t/h) = exp(-t/tau) (1 + t h / (2 tau^2)
    # + O(h^2)), so |e| = |T0 - T_inf| exp(-t/tau) t h / (2 tau^2); the next term is O(h / tau) = 1.3 % of it
    tau = C / G
    leading = (P / G) * math.exp(-t_end / tau) * t_end * 2.5 / (2 * tau ** 2)
    assert errors[-1] == pytest.approx(leading, rel=2e-2)


def test_steady_state_closed_form_and_energy_balance():
    net = _one_node()
    assert net.steady([P])[0] == pytest.approx(T_AMB + P / G, rel=1e-15)
    # after 20 time constants the march has reached the steady state to exp(-20) of the rise
    assert net.march([T_AMB], [P], 4000.0, 10.0)[0] == pytest.approx(T_AMB + P / G, abs=1e-6)
    chain = ThermalNetwork(nodes=("pins", "wheel", "housing"), capacity=[100.0, 800.0, 5000.0],
                           links=(("pins", "wheel", 2.0), ("pins", "housing", 6.0)),
                           ambient_conductance=[0.0, 0.0, 10.0], ambient_temperature=T_AMB)
    Q = np.array([30.0, 50.0, 0.0])
    T = chain.steady(Q)
    # all heat leaves through the housing: G_amb (T_h - T_amb) = sum Q; the wheel's heat crosses pins -> housing
    assert 10.0 * (T[2] - T_AMB) == pytest.approx(Q.sum(), rel=1e-13)
    assert T[1] - T[0] == pytest.approx(50.0 / 2.0, rel=1e-13)
    assert T[0] - T[2] == pytest.approx(80.0 / 6.0, rel=1e-13)


def test_sliding_loss_sources_partition_and_phase_samples():
    net = ThermalNetwork(nodes=("pins", "wheel"), capacity=[1.0, 1.0], links=(("pins", "wheel", 1.0),),
                         ambient_conductance=[1.0, 0.0], ambient_temperature=T_AMB)
    x = WindowExposure(ids=("pins/0", "pins/1", "bearing/0"), tau_w=0.5, m=3, I_s=[1.0, 2.0, 4.0],
                       I_m=[0, 0, 0], I_F=[1, 1, 1], F_pk=[1, 1, 1], position=np.zeros((3, 3)))
    src = SlidingLossSources(friction={"pins": 0.1, "bearing": 0.002},
                             partition={"pins": {"pins": 0.5, "wheel": 0.5}, "bearing/0": {"wheel": 1.0}})
    # P = mu I_s / tau_w: pins 0.2 and 0.4 W, bearing 0.016 W
    np.testing.assert_allclose(src.power(x), [0.2, 0.4, 0.016], rtol=1e-15)
    np.testing.assert_allclose(src.node_sources(x, net), [0.3, 0.3 + 0.016], rtol=1e-15)
    # coupled lubrication writes mu per contact instance: it overrides the declared value
    np.testing.assert_allclose(src.power(x, {"pins/1": 0.05}), [0.2, 0.2, 0.016], rtol=1e-15)
    np.testing.assert_allclose(combine_phase_sources([[1.0, 2.0], [3.0, 6.0]], [1.0, 3.0]), [2.5, 5.0], rtol=1e-15)
    with pytest.raises(RvtoolInputError, match=r"partition\['pins'\] fractions sum to 0.9"):
        SlidingLossSources(friction=0.1, partition={"pins": {"pins": 0.5, "wheel": 0.4}})
    with pytest.raises(RvtoolInputError, match="partition has no entry for contact 'ring/0'"):
        SlidingLossSources(friction=0.1, partition={"pins": {"pins": 1.0}}).node_sources(
            WindowExposure(ids=("ring/0",), tau_w=1, m=3, I_s=[1], I_m=[0], I_F=[0], F_pk=[0],
                           position=np.zeros((1, 3))), net)


@pytest.mark.parametrize("relaxation", [1.0, 0.5])
def test_fixed_point_matches_closed_form(relaxation):
    # friction rising with temperature: Q(T) = P0 (1 + beta (T - T_ref)); steady G (T - T_amb) = Q(T) gives
    # T* = [G T_amb + P0 (1 - beta T_ref)] / (G - P0 beta); the iteration map has slope P0 beta / G = 0.3.
    P0, beta, T_ref = 40.0, 0.03, T_AMB
    net = _one_node()
    exact = (G * T_AMB + P0 * (1 - beta * T_ref)) / (G - P0 * beta)
    res = steady_fixed_point(net, lambda T: P0 * (1 + beta * (T - T_ref)), [T_AMB], relaxation=relaxation,
                             temperature_tol_K=1e-8, source_tol_rel=1e-10)
    assert res.converged and res.iterations > 2
    assert res.temperature_residual_K <= 1e-8 and res.source_drift_rel <= 1e-10
    # the unrelaxed residual bounds the distance to the fixed point by 1 / (1 - slope)
    assert abs(res.temperature[0] - exact) <= res.temperature_residual_K / (1 - 0.3) + 1e-12
    assert res.history[0][1] == math.inf         # one source evaluation has no drift yet


def test_fixed_point_needs_relaxation_where_the_plain_iteration_oscillates():
    # friction falling with temperature, slope P0 beta / G = -1.5: plain substitution diverges (factor -1.5),
    # omega = 0.3 contracts with factor 1 - omega + omega * slope = 1 - 0.3 - 0.45 = 0.25
    P0, beta = 40.0, -0.15
    net = _one_node()
    exact = (G * T_AMB + P0 * (1 - beta * T_AMB)) / (G - P0 * beta)

    def src(T):
        return P0 * (1 + beta * (T - T_AMB))
    with pytest.raises(FixedPointNotConverged) as info:
        steady_fixed_point(net, src, [T_AMB + 1.0], relaxation=1.0, max_iterations=20)
    assert info.value.result.temperature_residual_K > 1.0
    res = steady_fixed_point(net, src, [T_AMB + 1.0], relaxation=0.3, temperature_tol_K=1e-9, source_tol_rel=1e-9)
    assert res.temperature[0] == pytest.approx(exact, abs=1e-8)
    # error factor 0.25 per iteration from |T0 - T*| = 3 K (T* = T_amb + 4 K) to the 1e-9 K residual: 16 iterations (+2)
    assert 10 <= res.iterations <= 25


def test_expansion_maps_signs_and_first_order_cancellation():
    env = CycloidEnvelopeExpansion(pin_circle_radius=0.06, pin_radius=0.004, housing_expansion=11.5e-6,
                                   pin_expansion=11.5e-6, wheel_expansion=11.5e-6)
    # Eq. (obs_thermal_gap) with equal alpha and dT: alpha dT [R_z - r_z - (R_z - r_z)] = 0 up to round-off of
    # alpha dT R_z = 1.4e-5 m (1 ulp ~ 2e-21 m)
    assert abs(env.gap_change(20.0, 20.0, 20.0)) < 1e-19
    assert env.gap_change(10.0, 0.0, 0.0) == pytest.approx(11.5e-6 * 10 * 0.06, rel=1e-15)     # housing opens
    assert env.gap_change(0.0, 0.0, 10.0) == pytest.approx(-11.5e-6 * 10 * 0.056, rel=1e-15)   # wheel closes
    assert env.gap_change(0.0, 10.0, 0.0) < 0.0
    brg = BearingClearanceExpansion(outer_raceway_radius=0.0240, inner_raceway_radius=0.0160,
                                    element_diameter=0.00799, outer_expansion=12e-6, inner_expansion=12e-6,
                                    element_expansion=12e-6)
    # equal expansion: Delta c = alpha dT c, c = 10 um, i.e. 12e-6 * 30 * 1e-5 = 3.6e-9 m (round-off ~ 1e-21 m)
    assert brg.clearance == pytest.approx(1e-5, rel=1e-9)
    assert brg.gap_change(30.0, 30.0, 30.0) == pytest.approx(12e-6 * 30 * brg.clearance, rel=1e-9)
    # a hotter inner ring than outer ring (shaft-side heat) closes the clearance
    assert brg.gap_change(10.0, 30.0, 20.0) < 0.0
    net = ThermalNetwork(nodes=("housing", "pins", "wheel"), capacity=[1.0, 1.0, 1.0],
                         ambient_conductance=[1.0, 1.0, 1.0], ambient_temperature=T_AMB)
    ch = ThermalGapChannel(name="thermal/pins", contacts="pins", expansion=env, nodes=("housing", "pins", "wheel"),
                           reference_temperature=(T_AMB, T_AMB, T_AMB))
    off = thermal_gap_offsets([ch], net, [T_AMB + 10.0, T_AMB, T_AMB])
    assert off.offset("pins/3") == pytest.approx(env.gap_change(10.0, 0.0, 0.0), rel=1e-12)
    assert off.offset("bearing/0") == 0.0


def test_bad_inputs_give_named_errors():
    with pytest.raises(RvtoolInputError, match=r"thermal.links\[0\].conductance = -1.0 is outside the valid range"):
        ThermalNetwork(nodes=("a", "b"), capacity=[1.0, 1.0], links=(("a", "b", -1.0),), ambient_conductance=[1.0, 0],
                       ambient_temperature=T_AMB)
    with pytest.raises(RvtoolInputError, match="thermal.ambient_conductance is 0 for every node of the group"):
        ThermalNetwork(nodes=("a", "b"), capacity=[1.0, 1.0], ambient_conductance=[1.0, 0.0], ambient_temperature=T_AMB)
    with pytest.raises(RvtoolInputError, match=r"thermal.capacity"):
        ThermalNetwork(nodes=("a",), capacity=[0.0], ambient_conductance=[1.0], ambient_temperature=T_AMB)
    net = _one_node()
    with pytest.raises(RvtoolInputError, match=r"T = \[nan\] at nodes \[0\]"):
        net.step([math.nan], [1.0], 1.0)
    with pytest.raises(RvtoolInputError, match="T_k"):
        single_node_update(math.nan, capacity=C, dtau=1.0, mu=0.1, I_s_total=1.0, tau_w=1.0, conductance=G,
                           ambient_temperature=T_AMB)
    with pytest.raises(RvtoolInputError, match="conductance"):
        single_node_update(300.0, capacity=C, dtau=1.0, mu=0.1, I_s_total=1.0, tau_w=1.0, conductance=-G,
                           ambient_temperature=T_AMB)
    with pytest.raises(RvtoolInputError, match="source_of_temperature"):
        steady_fixed_point(net, lambda T: [math.nan], [T_AMB])
    with pytest.raises(RvtoolInputError, match="pin_radius"):
        CycloidEnvelopeExpansion(pin_circle_radius=0.06, pin_radius=0.07, housing_expansion=1e-5,
                                 pin_expansion=1e-5, wheel_expansion=1e-5)
