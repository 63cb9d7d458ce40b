"""Fatigue of the reducer: periodic rainflow blocks, the Hertz reference of the force--life law, the
subsurface stress history of a ring pin from the pressure module, the cycloid life inputs."""
import math

import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.pressure.state import pin_contact
from rvtool.slow import cycloid as C
from rvtool.slow import fatigue as Fa
from rvtool.slow.reducer_windows import loaded_start

DESIGN = load_design(designs.path("rd40"))


def test_periodic_block_counts_full_cycles_wherever_the_period_starts():
    curve = Fa.SNCurve(reference_amplitude=100e6, reference_life=1e6, exponent=5.0)
    t = np.linspace(0.0, 1.0, 64, endpoint=False)
    pulse = 200e6 * np.clip(np.sin(2 * np.pi * t), 0.0, None)    # one 0-to-200 MPa pulse per period
    exact = 1.0 / curve.life(100e6)                                # one full cycle of amplitude 100 MPa
    for shift in (0, 5, -10, -20):
        d = Fa.miner_damage(np.roll(pulse, shift), curve, periodic=True)
        assert d.damage == pytest.approx(exact, rel=1e-12)
    # counted once, a period that starts inside the pulse leaves two unequal half cycles
    once = Fa.miner_damage(np.roll(pulse, -10), curve)
    assert once.damage != pytest.approx(exact, rel=1e-3)


def test_hertz_reference_force_and_tresca_ratio():
    E = DESIGN.material.youngs_modulus / (2 * (1 - DESIGN.material.poisson_ratio ** 2))
    R, b, p_ref = 3e-3, 8e-3, 1.5e9
    F = Fa.hertz_line_reference_force(reference_pressure=p_ref, radius=R, length=b, reduced_modulus=E)
    # Hertz line contact: a = sqrt(4 F' R / (pi E*)), p0 = 2 F' / (pi a)
    a = math.sqrt(4 * F / b * R / (math.pi * E))
    assert 2 * F / b / (math.pi * a) == pytest.approx(p_ref, rel=1e-12)
    # Johnson (1985) Sec. 4.2: tau_1 max = 0.300 p0 at z = 0.786 a (three digits in the book)
    assert Fa.hertz_line_tresca_ratio(0.3) == pytest.approx(0.300, abs=1e-3)
    with pytest.raises(RvtoolInputError, match="radius"):
        Fa.hertz_line_reference_force(reference_pressure=p_ref, radius=-1.0, length=b, reduced_modulus=E)


def test_subsurface_history_of_a_ring_pin_matches_hertz():
    m = build(DESIGN)
    s = loaded_start(m, DESIGN.rated_torque, 0.0)
    names, F = m.observe(s.q, Family.PINS).per_contact()
    k = int(np.argmax(F))
    wheel, pin = int(names[k].split("/")[0][5:]), int(names[k].split("pin")[1])
    c = pin_contact(m, s.q, wheel, pin)
    h = Fa.subsurface_stress_history([None, c], panels=161, depths=41)
    assert h.tau_max[0] == 0.0 and h.force[0] == 0.0
    assert h.force[1] == pytest.approx(F[k], rel=1e-12)
    # 161 panels over +-3 a and 41 depths over 2 a: the peak within 1 % of the closed form (measured 0.1 %)
    assert h.tau_max[1] == pytest.approx(h.hertz_tau[1], rel=1e-2)
    assert 0.6 * c.hertz_halfwidth < h.depth[1] < 1.0 * c.hertz_halfwidth
    with pytest.raises(RvtoolInputError, match="panels"):
        Fa.subsurface_stress_history([c], panels=3)


def test_cycloid_life_laws_and_rates():
    inputs = C.CycloidSlowInputs()
    laws = C.life_laws(DESIGN, inputs, per_roller=True)
    E = DESIGN.material.youngs_modulus / (2 * (1 - DESIGN.material.poisson_ratio ** 2))
    R, b = C.contact_line_geometry(DESIGN)["pins"]
    assert laws["pins"].reference_force == pytest.approx(math.pi * R * b * inputs.fatigue_reference_pressure ** 2 / E,
                                                         rel=1e-12)
    assert laws["pins"].exponent == 0.5 * inputs.fatigue_pressure_exponent
    lumped = C.life_laws(DESIGN, inputs, per_roller=False)
    ratio = lumped["eccentric_bearings"].reference_force / laws["eccentric_bearings"].reference_force
    assert ratio == pytest.approx(DESIGN.eccentric_bearing.n_rollers / 4.08, rel=1e-12)
    small = C.life_laws(DESIGN, inputs, per_roller=True, radius={"pins": R / 2})
    assert small["pins"].reference_force == pytest.approx(0.5 * laws["pins"].reference_force, rel=1e-12)
    with pytest.raises(RvtoolInputError, match="family"):
        C.life_laws(DESIGN, inputs, per_roller=True, radius={"main_bearings": 1e-3})
    omega = 2 * math.pi * 25.0
    rates = C.cycle_rates(DESIGN, omega)
    assert rates["pins"] == pytest.approx(25.0, rel=1e-12)
    geo = C.rating_geometries(DESIGN)
    assert set(geo) == {"eccentric_bearing0", "eccentric_bearing1", "main_bearing", "input_bearing0", "input_bearing1"}
    assert geo["main_bearing"][1] == pytest.approx(1 / 39, rel=1e-12)
