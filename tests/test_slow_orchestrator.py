"""Orchestrator of mechanical windows and slow updates, on a mechanical
stand-in: a ball of radius R pressed on a flat by a fixed load F and sliding
at speed v (a Hertz point contact; nominal wear area A = pi a^2 with the
Hertz radius a = (3 F R / (4 E*))^(1/3)). After every offset update its first
window is a settling transient with doubled sliding; the orchestrator must
discard it. The numbers checked are closed forms: Archard depth k F v T / A
including the limiter's scaling, the number of limited updates, the
represented service time, the steady temperature T_amb + mu F v / G, the
thermal clearance offset, and the damage nu T / N(F).
"""
import math

import pytest

from rvtool.errors import RvtoolInputError
from rvtool.slow.exposure import WindowExposure
from rvtool.slow.fatigue import ForceLifeLaw
from rvtool.slow.lubrication import FilmContact, Lubrication, MixedFriction, VogelViscosity
from rvtool.slow.offsets import GapOffsets
from rvtool.slow.orchestrator import (FatigueCoupling, LubricationMode, SlowOrchestrator, SlowSchedule,
                                      ThermalCoupling, represented_service_time)
from rvtool.slow.thermal import BearingClearanceExpansion, SlidingLossSources, ThermalGapChannel, ThermalNetwork
from rvtool.slow.wear import ConstantWearCoefficient, IdentityBin, SurfaceAssociation, WearModel

F, R, E_STAR, V, TAU_W = 200.0, 0.01, 1.15e11, 0.1, 0.02     # N, m, Pa, m/s, s
A_HERTZ = math.pi * (3 * F * R / (4 * E_STAR)) ** (2 / 3)     # m^2
K_W, MU, C_T, G_T, T_AMB = 1e-19, 0.1, 500.0, 2.0, 293.15     # m^2/N, -, J/K, W/K, K
HOUR = 3600.0


class HertzSlider:
    """Fixed-load sliding Hertz contact; the first window after apply_offsets doubles the sliding (settling)."""

    def __init__(self):
        self.settling = False
        self.windows = 0
        self.offsets, self.friction = [], []

    def run_window(self, state):
        self.windows += 1
        slip = 2 * V if self.settling else V
        self.settling = False
        return WindowExposure(ids=("pad/0",), tau_w=TAU_W, m=3.0, I_s=[F * slip * TAU_W], I_m=[F ** 3 * TAU_W],
                              I_F=[F * TAU_W], F_pk=[F], position=[[0.0, 0.0, 0.0]])

    def apply_offsets(self, offsets, friction):
        self.settling = True
        self.offsets.append(offsets)
        self.friction.append(friction)


CLEARANCE_MAP = BearingClearanceExpansion(outer_raceway_radius=0.024, inner_raceway_radius=0.016,
                                          element_diameter=0.00799, outer_expansion=12e-6, inner_expansion=11e-6,
                                          element_expansion=10e-6)


def _thermal():
    net = ThermalNetwork(nodes=("pad",), capacity=[C_T], ambient_conductance=[G_T], ambient_temperature=T_AMB)
    ch = ThermalGapChannel(name="thermal/pad", contacts="pad", expansion=CLEARANCE_MAP, nodes=("pad", "pad", "pad"),
                           reference_temperature=(T_AMB, T_AMB, T_AMB))
    return ThermalCoupling(network=net, sources=SlidingLossSources(friction=MU, partition={"pad": {"pad": 1.0}}),
                           channels=(ch,))


def _wear():
    return WearModel(coefficient=ConstantWearCoefficient(k=K_W), nominal_area=A_HERTZ,
                     association=SurfaceAssociation(rules={"pad": ((IdentityBin(surface="pad"), 1.0),)}))


def _run(settling_windows=1, **kw):
    model = HertzSlider()
    sch = SlowSchedule(service_time=1000 * HOUR, service_interval=100 * HOUR, thermal_interval=60.0,
                       max_wear_increment=2e-6, settling_windows=settling_windows)
    law = ForceLifeLaw(reference_life=1e8, reference_force=500.0, exponent=3.0)
    orch = SlowOrchestrator(model, sch, wear=_wear(), thermal=_thermal(),
                            fatigue=FatigueCoupling(law=law, cycle_rate=5.0), **kw)
    return model, orch.run(), law


def test_wear_thermal_fatigue_on_a_hertz_stand_in():
    model, res, law = _run()
    T = 1000 * HOUR
    rate = K_W * F * V / A_HERTZ                            # Archard depth rate [m/s]: 1.15e-11 m/s
    depth = rate * T                                        # 41.4 um over 1,000 h
    assert res.contact_wear["pad/0"] == pytest.approx(depth, rel=1e-12)
    assert res.wear_depth == {"pad/0": pytest.approx(depth, rel=1e-12)}
    # limiter: 100 h give 4.1 um > 2 um, so every update but the last is cut to 2 um and to 2 um / rate of service
    n = math.ceil(depth / 2e-6)
    assert len(res.records) == n and res.limiter_steps == n - 1
    assert all(r.service_interval == pytest.approx(2e-6 / rate, rel=1e-12) for r in res.records[:-1])
    assert represented_service_time(res.records) == pytest.approx(T, rel=1e-12)
    assert res.service_time == pytest.approx(T, rel=1e-12)
    # one discarded settling window after each of the n - 1 offset updates
    assert res.windows_discarded == n - 1 and model.windows == res.windows_run == 2 * n - 1
    # thermal: time constant C/G = 250 s << the 2 um interval (48 h), so the node is at T_amb + mu F v / G
    T_steady = T_AMB + MU * F * V / G_T
    assert res.temperature["pad"] == pytest.approx(T_steady, abs=1e-9)
    dT = T_steady - T_AMB
    last = model.offsets[-1]
    assert last.channel_offset("thermal/pad", "pad/0") == pytest.approx(CLEARANCE_MAP.gap_change(dT, dT, dT), rel=1e-9)
    assert last.channel_offset("wear", "pad/0") == pytest.approx(depth, rel=1e-12)
    assert last.offset("pad/0") == pytest.approx(depth + CLEARANCE_MAP.gap_change(dT, dT, dT), rel=1e-9)
    # fatigue: Eq. (obs_damage) at constant load = cycles / N(F) = 5 /s * T / (1e8 (500/200)^3)
    assert res.damage["pad/0"] == pytest.approx(5.0 * T / (1e8 * 2.5 ** 3), rel=1e-12)
    assert model.friction[-1] is None                       # no lubrication: declared friction stays


def test_settling_windows_are_excluded():
    # without the exclusion, the doubled-sliding transient after each update is extrapolated as service: every
    # update after the first (which follows no offset update) wears at twice the rate, so with the first interval
    # limited to 2 um the depth is 2 um + 2 rate (T - 2 um / rate) = 2 rate T - 2 um
    _, res0, _ = _run(settling_windows=0)
    T, rate = 1000 * HOUR, K_W * F * V / A_HERTZ
    assert res0.windows_discarded == 0 and res0.service_time == pytest.approx(T, rel=1e-12)
    assert res0.contact_wear["pad/0"] == pytest.approx(2 * rate * T - 2e-6, rel=1e-12)
    assert res0.records[1].service_interval == pytest.approx(1e-6 / rate, rel=1e-12)


def test_coupled_lubrication_writes_friction_per_contact():
    law = MixedFriction(boundary_friction=0.12, fluid_friction=0.02, transition_lambda=1.5, sharpness=2.0)
    lub = Lubrication(lubricant=VogelViscosity(A=5e-5, B=1000.0, C=150.0, pressure_viscosity=2e-8), friction_law=law,
                      contacts={"pad": FilmContact(kind="point", radius_x=R, radius_y=R, entrainment_speed=V,
                                                   reduced_modulus=2 * E_STAR, roughness_1=0.1e-6, roughness_2=0.1e-6,
                                                   node="pad")})
    model, res, _ = _run(lubrication=lub, lubrication_mode=LubricationMode.COUPLED)
    assert model.friction[-1] == res.film.friction() and set(model.friction[-1]) == {"pad/0"}
    assert 0.02 < model.friction[-1]["pad/0"] < 0.12
    model_o, res_o, _ = _run(lubrication=lub, lubrication_mode="observe")
    assert model_o.friction[-1] is None and res_o.film is not None


def test_protocol_and_schedule_errors():
    with pytest.raises(RvtoolInputError, match="model must implement run_window"):
        SlowOrchestrator(object(), SlowSchedule(service_time=1.0, service_interval=1.0, thermal_interval=1.0))
    with pytest.raises(RvtoolInputError, match="service_interval"):
        SlowSchedule(service_time=1.0, service_interval=0.0, thermal_interval=1.0)
    sch = SlowSchedule(service_time=1000 * HOUR, service_interval=100 * HOUR, thermal_interval=60.0,
                       max_wear_increment=1e-9, max_updates=5)
    with pytest.raises(RvtoolInputError, match="max_updates = 5 reached"):
        SlowOrchestrator(HertzSlider(), sch, wear=_wear()).run()
    assert GapOffsets.none().offset("pad/0") == 0.0
