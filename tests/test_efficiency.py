"""Quasi-static efficiency by energy accounting (rvtool.protocols.efficiency) on rv40e."""
import math

import numpy as np
import pytest

import rvtool
from rvtool.errors import RvtoolInputError
from rvtool.protocols.efficiency import (SlidingFriction, efficiency, kinematic_velocity, power_balance_error,
                                         rolling_losses, sliding_losses)
from rvtool.solver.static import StaticSolver


@pytest.fixture(scope="module")
def rated():
    d = rvtool.load_design("rvtool/designs/rv40e.toml")
    m = rvtool.build(d)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    return m, StaticSolver(m).solve(0.0)


def test_frictionless_power_balance(rated):
    # the drive's power equals the power delivered to the load along the kinematic velocities: 1e-4
    # at input angle 0 (measured 2.0e-5; at a single angle the stored elastic energy's rate adds up to
    # 4e-3 elsewhere in the mesh period, averaging out over it); a wrong rate or sign gives O(1)
    m, q = rated
    v = kinematic_velocity(m, 0.0, 1500 * 2 * math.pi / 60)
    err, P_in, P_out = power_balance_error(m, q, v)
    assert err <= 1e-4
    # and P_out is the rated torque times the output speed
    assert math.isclose(abs(P_out), 412.0 * 1500 * 2 * math.pi / 60 / abs(m.ratio), rel_tol=1e-3)


def test_sliding_losses_scale_with_mu_and_speed(rated):
    m, q = rated
    v = kinematic_velocity(m, 0.0, 100.0)
    a = sliding_losses(m, q, v, SlidingFriction(pins=0.05, gears=0.05))
    b = sliding_losses(m, q, 2 * v, SlidingFriction(pins=0.1, gears=0.0))
    assert a["pins"] > 0 and a["gears"] > 0
    assert math.isclose(b["pins"], 4 * a["pins"], rel_tol=1e-9) and b["gears"] == 0.0


def test_main_bearing_loss_is_palmgrens_moment_times_output_speed(rated):
    # hand: M0 = 160e-7 f0 d_m^3 [N mm] below nu n = 2000 (32 mm^2/s x 12.4 r/min), M1 = f1 P1 d_m with
    # Palmgren's P1 of the two rows at their 500 N preload, 2 x 0.9 F_a cot(40 deg) - 0.1 F_r, F_r the pair's
    # radial load at T_R (below 1 kN: within -0.1 F_r of the preload form, 10 % of M1)
    m, q = rated
    w_in = 1500 * 2 * math.pi / 60
    loss = rolling_losses(m, q, kinematic_velocity(m, 0.0, w_in))["main_bearings"]
    w_out = w_in / abs(m.ratio)
    M0 = 160e-7 * 2.0 * 150.0 ** 3 * 1e-3
    M1 = m.design.bearing_friction.f1_ball * 2 * 0.9 * 500.0 / math.tan(math.radians(40.0)) * 150.0 * 1e-3
    assert (M0 + 0.9 * M1) * w_out <= loss <= (M0 + M1) * w_out
    radial = m.design.replace(bearing_friction={"palmgren_load": "radial"})
    m_r = rvtool.build(radial)
    loss_r = rolling_losses(m_r, q, kinematic_velocity(m_r, 0.0, w_in))["main_bearings"]
    assert M0 * w_out <= loss_r <= 1.5 * M0 * w_out


def test_efficiency_points(rated):
    m, _ = rated
    r = efficiency(m, 412.0, [500, 3000], input_angles=(0.0,))
    for p in r["points"]:
        assert 0.5 < p["efficiency"] < 1.0
        assert all(v >= 0 for v in p["loss_by_family_W"].values())
        assert math.isclose(p["P_in_W"], p["P_out_W"] + p["P_loss_W"], rel_tol=1e-14)


def test_efficiency_refuses_elastic_cranks():
    d = rvtool.load_design("rvtool/designs/rv40e.toml").replace(cranks={"shaft": {"torsion": "elastic"}})
    with pytest.raises(RvtoolInputError, match="cranks.shaft"):
        efficiency(rvtool.build(d), 412.0, [1500])


def test_bad_inputs():
    with pytest.raises(RvtoolInputError, match="sliding_friction.pins"):
        SlidingFriction(pins=-0.1)
