"""Wear of Eq. (obs_wear): constant-load Archard depth in closed form, the
single-channel limiter (depth per represented service time and the service
time itself conserved), the contact-to-surface association and named errors.

Tolerance REL = 1e-12: the depths are products and sums of a few hundred
float64 terms.
"""
import math

import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.slow.exposure import WindowExposure
from rvtool.slow.lubrication import MixedFriction
from rvtool.slow.wear import (AngularBins, ConstantWearCoefficient, FilmWearCoefficient, IdentityBin,
                              SurfaceAssociation, SurfaceWear, WearModel, limit_single_channel)

REL = 1e-12
F, V, TAU_W, AREA, K = 400.0, 0.3, 0.05, 2e-6, 2e-19     # N, m/s, s, m^2, m^2/N (K H ~ 1e-9: mild wear)
HOUR = 3600.0


def _window(force=F, ids=("pins/0",), positions=None):
    n = len(ids)
    f = np.full(n, force)
    return WindowExposure(ids=ids, tau_w=TAU_W, m=3, I_s=f * V * TAU_W, I_m=f ** 3 * TAU_W, I_F=f * TAU_W, F_pk=f,
                          position=np.zeros((n, 3)) if positions is None else positions)


def _model(association=None, k=K):
    assoc = association or SurfaceAssociation(rules={"pins": ((IdentityBin(surface="pins"), 1.0),)})
    return WearModel(coefficient=ConstantWearCoefficient(k=k), nominal_area=AREA, association=assoc)


def test_constant_load_archard_depth():
    # Archard: h = k F v t / A over service time t; Eq. (obs_wear) with I_s = F v tau_w and s = t / tau_w
    inc = _model().increment(_window(), 1000 * HOUR)
    expected = K * F * V * 1000 * HOUR / AREA          # 2e-19 * 400 * 0.3 * 3.6e6 / 2e-6 = 4.32e-5 m
    assert expected == pytest.approx(4.32e-5, rel=1e-15)
    assert inc.contact_increment[0] == pytest.approx(expected, rel=REL)
    assert inc.bin_increment == {"pins/0": pytest.approx(expected, rel=REL)}


def test_limiter_scales_service_time_by_the_same_factor():
    inc = _model().increment(_window(), 1000 * HOUR)
    lim = limit_single_channel(inc, 1e-5)
    f = 1e-5 / inc.max_increment                        # = 1e-5 / 4.32e-5
    assert lim.factor == pytest.approx(f, rel=REL) and lim.max_increment == pytest.approx(1e-5, rel=REL)
    assert lim.service_interval == pytest.approx(f * 1000 * HOUR, rel=REL)
    # the depth per represented service time is that of the unlimited update
    assert lim.contact_increment[0] / lim.service_interval == pytest.approx(inc.contact_increment[0] / (1000 * HOUR),
                                                                            rel=REL)
    assert limit_single_channel(inc, 1e-4) is inc      # below the limit: unchanged


def test_limited_updates_conserve_represented_service_time():
    # cover T = 10,000 h in nominal intervals of 1,000 h with at most 5 um per update:
    # depth rate r = k F v / A = 1.2e-11 m/s, total depth r T = 4.32e-4 m -> ceil(4.32e-4 / 5e-6) = 87 updates
    model, surf = _model(), SurfaceWear()
    T, nominal, cap = 10_000 * HOUR, 1000 * HOUR, 5e-6
    t, updates = 0.0, 0
    while t < T * (1 - 1e-12):
        lim = limit_single_channel(model.increment(_window(), min(nominal, T - t)), cap)
        surf.apply(lim)
        t += lim.service_interval
        updates += 1
    assert surf.service_time == pytest.approx(T, rel=REL)
    assert updates == math.ceil(K * F * V * T / AREA / cap) == 87
    assert surf.limited_updates == 86                   # the last one covers the remainder unlimited
    assert surf.depth["pins/0"] == pytest.approx(K * F * V * T / AREA, rel=REL)
    assert surf.offsets().offset("pins/0") == pytest.approx(K * F * V * T / AREA, rel=REL)
    assert surf.max_depth() == surf.depth["pins/0"]


def test_association_shares_and_shared_bins():
    # two pins touching the same lobe region of the wheel; each contact's loss split 50/50 pin / wheel
    assoc = SurfaceAssociation(rules={"pins": ((IdentityBin(surface="pins"), 0.5),
                                               (AngularBins(surface="wheel/lobe", center=(0.0, 0.0), n_bins=4), 0.5))})
    pos = np.array([[0.05, 0.01, 0.0], [0.05, 0.02, 0.0], [-0.05, 0.01, 0.0]])   # zones 0, 0 and 1
    x = WindowExposure(ids=("pins/0", "pins/1", "pins/2"), tau_w=TAU_W, m=3, I_s=[1.0, 2.0, 4.0], I_m=[0, 0, 0],
                       I_F=[1, 1, 1], F_pk=[1, 1, 1], position=pos)
    inc = _model(assoc).increment(x, 100.0)
    dh = K * np.array([1.0, 2.0, 4.0]) / AREA * (100.0 / TAU_W)
    np.testing.assert_allclose(inc.contact_increment, dh, rtol=REL)
    assert inc.bin_increment["wheel/lobe/0"] == pytest.approx(0.5 * (dh[0] + dh[1]), rel=REL)
    assert inc.bin_increment["wheel/lobe/1"] == pytest.approx(0.5 * dh[2], rel=REL)
    assert inc.bin_increment["pins/2"] == pytest.approx(0.5 * dh[2], rel=REL)
    surf = SurfaceWear()
    surf.apply(inc)
    # the gap of pins/0 opens by its own pin's recession plus the lobe region's, which pins/1 also wore
    assert surf.contact_offset("pins/0") == pytest.approx(0.5 * dh[0] + 0.5 * (dh[0] + dh[1]), rel=REL)
    # an unshared contact recovers exactly its own Delta h_c
    assert surf.contact_offset("pins/2") == pytest.approx(dh[2], rel=REL)


def test_film_dependent_coefficient():
    law = MixedFriction(boundary_friction=0.12, fluid_friction=0.02, transition_lambda=1.5, sharpness=2.0)
    kw = FilmWearCoefficient(boundary_coefficient=K, friction_law=law)
    assert kw(1.5) == pytest.approx(K / math.e, rel=1e-15)
    model = WearModel(coefficient=kw, nominal_area=AREA,
                      association=SurfaceAssociation(rules={"pins": ((IdentityBin(surface="pins"), 1.0),)}))
    full = model.increment(_window(), 100.0)                               # lambda = 0: boundary
    thin = model.increment(_window(), 100.0, film_parameter={"pins/0": 1.5})
    assert thin.contact_increment[0] == pytest.approx(full.contact_increment[0] / math.e, rel=REL)
    # a contact the lubrication saw unloaded has lambda = inf: no asperity load, no wear
    assert kw(math.inf) == 0.0


def test_negative_wear_coefficient_and_bad_inputs_are_named():
    with pytest.raises(RvtoolInputError, match=r"k = -1e-16 is outside the valid range \[0, inf\) m\^2/N"):
        ConstantWearCoefficient(k=-1e-16)
    model = WearModel(coefficient=lambda lam: -1e-16 * np.ones_like(lam), nominal_area=AREA,
                      association=SurfaceAssociation(rules={"pins": ((IdentityBin(surface="pins"), 1.0),)}))
    with pytest.raises(RvtoolInputError, match=r"k_w\(lambda = 0.0\) = -1e-16 at contact 'pins/0'"):
        model.increment(_window(), 1.0)
    with pytest.raises(RvtoolInputError, match="shares sum to 0.9"):
        SurfaceAssociation(rules={"pins": ((IdentityBin(surface="pins"), 0.9),)})
    with pytest.raises(RvtoolInputError, match="nominal_area"):
        _model().__class__(coefficient=ConstantWearCoefficient(k=K), nominal_area=0.0,
                           association=SurfaceAssociation(rules={"pins": ((IdentityBin(surface="pins"), 1.0),)}))
    with pytest.raises(RvtoolInputError, match="association.rules has no entry for contact 'ring/0'"):
        _model().increment(_window(ids=("ring/0",)), 1.0)
    with pytest.raises(RvtoolInputError, match="max_increment"):
        limit_single_channel(_model().increment(_window(), 1.0), 0.0)
