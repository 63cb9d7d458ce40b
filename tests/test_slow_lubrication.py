"""Lubrication: viscosity laws, Dowson--Higginson and Hamrock--Dowson film
thickness, film parameter and the declared mixed-friction law, each at one
point computed by hand (steps in the comments).

Tolerance HAND = 1e-4 relative: the hand values below are carried to 5-6
significant digits.
"""
import math

import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.slow.exposure import WindowExposure
from rvtool.slow.lubrication import (FilmContact, Lubrication, MixedFriction, RoelandsViscosity, VogelViscosity,
                                     film_parameter, film_thickness_line, film_thickness_point, reduced_modulus)

HAND = 1e-4


def test_line_contact_dowson_higginson_by_hand():
    # w' = 1e5 N/m, R_x = 0.01 m, u = 2 m/s, eta0 = 0.05 Pa s, alpha = 2e-8 1/Pa, E' = 2.2e11 Pa
    # U = eta0 u / (E' R) = 0.1 / 2.2e9 = 4.54545e-11  -> U^0.70 = exp(0.7 * -23.81431) = 5.75843e-8
    # G = alpha E' = 4400                             -> G^0.54 = exp(0.54 * 8.38936) = 92.7822
    # W' = w' / (E' R) = 1e5 / 2.2e9 = 4.54545e-5     -> W'^-0.13 = exp(-0.13 * -9.99881) = 3.66872
    # h_min = 2.65 * 5.75843e-8 * 92.7822 * 3.66872 * 0.01 m = 5.19433e-7 m
    h = film_thickness_line(load_per_length=1e5, radius=0.01, entrainment_speed=2.0, viscosity=0.05,
                            pressure_viscosity=2e-8, reduced_modulus=2.2e11)
    assert h == pytest.approx(5.19433e-7, rel=HAND)


def test_point_contact_hamrock_dowson_by_hand():
    # w = 500 N, R_x = 5e-3 m, R_y = 5e-2 m, u = 5 m/s, eta0 = 0.02 Pa s, alpha = 2e-8 1/Pa, E' = 2.2e11 Pa
    # k = 1.0339 * 10^0.636 = 1.0339 * 4.32514 = 4.47176;  1 - exp(-0.68 k) = 1 - exp(-3.04080) = 0.952203
    # U = 0.1 / 1.1e9 = 9.09091e-11   -> U^0.68 = exp(0.68 * -23.12116) = 1.48543e-7
    # G = 4400                        -> G^0.49 = exp(0.49 * 8.38936) = 60.9947
    # W = w / (E' R_x^2) = 500 / 5.5e6 = 9.09091e-5  -> W^-0.073 = exp(-0.073 * -9.30566) = 1.97252
    # h_min = 3.63 * 1.48543e-7 * 60.9947 * 1.97252 * 0.952203 * 5e-3 m = 3.08868e-7 m
    h = film_thickness_point(load=500.0, radius_x=5e-3, radius_y=5e-2, entrainment_speed=5.0, viscosity=0.02,
                             pressure_viscosity=2e-8, reduced_modulus=2.2e11)
    assert h == pytest.approx(3.08868e-7, rel=HAND)


def test_viscosity_laws_by_hand():
    # Vogel: eta = 5e-5 exp(1000 / (350 - 150)) = 5e-5 e^5 = 5e-5 * 148.41316 = 7.42066e-3 Pa s
    v = VogelViscosity(A=5e-5, B=1000.0, C=150.0, pressure_viscosity=2e-8)
    assert v.viscosity(350.0) == pytest.approx(7.42066e-3, rel=HAND)
    # Roelands, eta_ref = 0.1 Pa s at 313.15 K, S0 = 1.1, Z = 0.6, at T = 353.15 K:
    # ratio = (353.15 - 138) / (313.15 - 138) = 1.228376;  ratio^-1.1 = exp(-1.1 * 0.205700) = 0.797494
    # ln eta_ref + 9.67 = 7.367415;  eta = 0.1 exp(7.367415 * (0.797494 - 1)) = 0.1 exp(-1.491946) = 0.0224960 Pa s
    r = RoelandsViscosity(reference_viscosity=0.1, reference_temperature=313.15, temperature_index=1.1,
                          pressure_index=0.6)
    assert r.viscosity(353.15) == pytest.approx(0.0224960, rel=HAND)
    assert r.viscosity(313.15) == pytest.approx(0.1, rel=1e-15)
    # alpha(T_ref) = Z (ln eta_ref + 9.67) / 1.96e8 = 0.6 * 7.367415 / 1.96e8 = 2.25533e-8 1/Pa
    assert r.alpha(313.15) == pytest.approx(2.25533e-8, rel=HAND)
    with pytest.raises(RvtoolInputError, match="T = "):
        v.viscosity(140.0)                        # below Vogel's C


def test_film_parameter_and_mixed_friction_by_hand():
    # lambda = 0.5 um / sqrt(0.3^2 + 0.4^2) um = 0.5 / 0.5 = 1
    assert film_parameter(0.5e-6, 0.3e-6, 0.4e-6) == pytest.approx(1.0, rel=1e-15)
    law = MixedFriction(boundary_friction=0.12, fluid_friction=0.02, transition_lambda=1.5, sharpness=2.0)
    # at lambda = lambda_t: f_a = e^-1, mu = 0.02 + 0.10 / e = 0.0567879
    assert law.mu(1.5) == pytest.approx(0.0567879, rel=HAND)
    assert law.mu(0.0) == pytest.approx(0.12, rel=1e-15)          # boundary limit
    assert law.mu(20.0) == pytest.approx(0.02, rel=1e-12)         # full film: exp(-(20/1.5)^2) ~ 1e-77
    assert law.mu(math.inf) == 0.02                                 # unloaded contact: no asperity load
    with pytest.raises(RvtoolInputError, match=r"lambda = -0.1 is outside the valid range"):
        law.mu(-0.1)
    with pytest.raises(RvtoolInputError, match="lambda = nan is outside"):
        law.mu(math.nan)
    with pytest.raises(RvtoolInputError, match="sqrt"):
        film_parameter(1e-6, 0.0, 0.0)


def test_lubrication_evaluates_mean_loads_per_contact():
    # E' of two steels (E = 206 GPa, nu = 0.3): E / (1 - nu^2) = 2.26374e11 Pa
    E = reduced_modulus(206e9, 0.3, 206e9, 0.3)
    assert E == pytest.approx(2.26374e11, rel=HAND)
    lub = Lubrication(lubricant=VogelViscosity(A=5e-5, B=1000.0, C=150.0, pressure_viscosity=2e-8),
                      friction_law=MixedFriction(boundary_friction=0.12, fluid_friction=0.02, transition_lambda=1.5,
                                                 sharpness=2.0),
                      contacts={"pins": FilmContact(kind="line", radius_x=0.004, length=0.01, entrainment_speed=0.5,
                                                    reduced_modulus=E, roughness_1=0.2e-6, roughness_2=0.2e-6,
                                                    node="pins")})
    x = WindowExposure(ids=("pins/0", "pins/1"), tau_w=0.2, m=3, I_s=[1.0, 0.0], I_m=[0, 0], I_F=[200.0, 0.0],
                       F_pk=[1000.0, 0.0], position=np.zeros((2, 3)))
    film = lub.evaluate(x, {"pins": 350.0})
    # pins/0: mean load 200 / 0.2 = 1000 N over 10 mm -> w' = 1e5 N/m at eta(350 K) = 7.42066e-3 Pa s
    h = film_thickness_line(load_per_length=1e5, radius=0.004, entrainment_speed=0.5, viscosity=7.42066e-3,
                            pressure_viscosity=2e-8, reduced_modulus=E)
    assert film.h_min[0] == pytest.approx(h, rel=HAND)
    assert film.film_parameter[0] == pytest.approx(h / (math.sqrt(2) * 0.2e-6), rel=HAND)
    assert film.friction()["pins/0"] == pytest.approx(lub.friction_law.mu(film.film_parameter[0]), rel=1e-15)
    # an unloaded contact has no film load: lambda = inf and the full-film coefficient
    assert film.film_parameter[1] == math.inf and film.mu[1] == 0.02
    with pytest.raises(RvtoolInputError, match="no temperature for thermal node 'pins'"):
        lub.evaluate(x, {"wheel": 350.0})
    with pytest.raises(RvtoolInputError, match="length is required"):
        FilmContact(kind="line", radius_x=0.004, entrainment_speed=0.5, reduced_modulus=E, roughness_1=0.0,
                    roughness_2=0.1e-6, node="pins")
    with pytest.raises(RvtoolInputError, match="kind = 'area'"):
        FilmContact(kind="area", radius_x=0.004, entrainment_speed=0.5, reduced_modulus=E, roughness_1=0.0,
                    roughness_2=0.1e-6, node="pins")
