"""Elastic energy of the involute series law (Eq. (series_contact)) and of the rolling-element
laws (needle/cylindrical laminae, tapered laminae, balls of Eq. (ball_bearing)) as the energy
account reads them (:class:`rvtool.observe.energy.ContactEnergyLaw` ``normal_potential``):
the potential against an adaptive numerical integral of the force law, its derivative against
the force by central differences, the force rebuilt from observations against the evaluator's,
and an energy balance on a gear pair loaded quasi-statically."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from rvtool.bearings.set import BearingSet, Mounting
from rvtool.bearings.spec import AngularContactPair, BallBearing, NeedleBearing
from rvtool.contact.involute_set import GearMesh, InvoluteContactSet
from rvtool.errors import RvtoolInputError
from rvtool.geometry.involute import InvoluteGear, InvolutePair
from rvtool.observe.energy import ContactEnergyLaw
from warp_contacts import involute_pairs_ref as iref
from warp_contacts import rolling_elements_ref as rref

E, NU = 206e9, 0.3


def series_args(C=7e-9, hA=4e-3, hB=5e-3, K=1 / 8e-3 + 1 / 20e-3, bs=10e-3):
    one = np.ones(1)
    return dict(C=C * one, hA=hA * one, hB=hB * one, K=K * one, EA=E * one, nuA=NU * one, EB=E * one, nuB=NU * one,
                bs=bs * one)


def series_F(delta, a):
    return iref.series_force(np.atleast_1d(float(delta)), a["C"], a["hA"], a["hB"], a["K"], a["EA"], a["nuA"],
                             a["EB"], a["nuB"], a["bs"])[0][0]


def series_V(delta, a):
    F = series_F(delta, a)
    return iref.series_potential(F, delta, a["EA"], a["nuA"], a["EB"], a["nuB"], a["bs"])[0]


@pytest.mark.parametrize("C", [7e-9, 1e-9])   # c' / b_s: 14 N/(mm um) over 10 mm, and a stiffer tooth
def test_series_potential_is_the_integral_of_the_force(C):
    # V(delta) = int_0^delta F(d) dd (Eq. (series_contact)); F is a Newton root to 1e-14 relative
    # and adaptive quadrature reaches ~1e-12 here, so 1e-9 leaves three decades for both
    a = series_args(C=C)
    for delta in (0.5e-6, 3e-6, 12e-6):
        ref, _ = quad(lambda d: series_F(d, a), 0.0, delta, epsabs=0.0, epsrel=1e-13, limit=200)
        assert abs(series_V(delta, a) - ref) <= 1e-9 * ref


def test_series_potential_derivative_is_the_force():
    # central difference of V with step h: error ~ h^2 V''' / 6 = h^2 F'' / 6; F'' ~ F / delta^2,
    # so with h = 1e-4 delta the truncation is ~2e-9 F, and the rounding V eps / h ~ 1e-12 F:
    # 1e-7 is the bound with margin
    a = series_args()
    for delta in (0.5e-6, 3e-6, 12e-6):
        h = 1e-4 * delta
        dV = (series_V(delta + h, a) - series_V(delta - h, a)) / (2 * h)
        assert abs(dV - series_F(delta, a)) <= 1e-7 * series_F(delta, a)


def fzg_set(**kw):
    A = InvoluteGear(module=4.5e-3, n_teeth=16, face_width=14e-3, profile_shift=0.1817, tip_diameter=82.46e-3,
                     bore_diameter=30e-3, name="gear_a")
    B = InvoluteGear(module=4.5e-3, n_teeth=24, face_width=14e-3, profile_shift=0.1715, tip_diameter=118.36e-3,
                     bore_diameter=40e-3, name="gear_b")
    pair = InvolutePair(gear_a=A, gear_b=B, centre_distance=91.5e-3)
    return pair, InvoluteContactSet([GearMesh(pair=pair, body_a=0, body_b=1, **kw)], 2, backend="numpy")


@pytest.mark.parametrize("theta_a, corner", [(0.07, None), (0.31, None), (0.2, iref.MODE_CORNER_A),
                                              (0.38, iref.MODE_CORNER_B)])
def test_involute_elastic_state_rebuilds_the_evaluated_force(theta_a, corner):
    # at rest the damping part vanishes, so the evaluator's normal force is the elastic force:
    # rebuilding it from the observed mode and roll angles (line of action, and the tip edges of
    # A and of B at these angles) must reproduce it to the series iteration's tolerance (1e-14
    # relative; 1e-12 for the re-solve from another start)
    pair, cs = fzg_set(n_slices=2, damping=50.0)
    th_b = pair.mesh_phase(0) + pair.ratio * theta_a - 2e-4      # loaded on line 0 (about 10 um approach)
    pose = np.array([[0.0, 0.0, theta_a], [pair.a, 0.0, th_b]])
    obs = cs.evaluate(pose, np.zeros((2, 3))).obs
    F, V = cs.elastic_energy(obs)
    loaded = obs[:, iref.O_FN] > 0
    assert loaded.sum() >= 2
    if corner is not None:
        assert np.any(loaded & (obs[:, iref.O_MODE] == corner))
    np.testing.assert_allclose(F, obs[:, iref.O_FN], rtol=1e-12, atol=0.0)
    assert np.all(V[loaded] > 0) and np.all(V[~loaded] == 0)


def test_involute_elastic_state_without_damping_part():
    # moving into contact, the observed normal force carries c r(delta) delta_dot on top of the
    # elastic force; the rebuilt elastic force excludes it (equal to the at-rest force to 1e-12)
    pair, cs = fzg_set(damping=5e4)
    th_b = pair.mesh_phase(0) + pair.ratio * 0.05 - 2e-4
    pose = np.array([[0.0, 0.0, 0.05], [pair.a, 0.0, th_b]])
    moving = cs.evaluate(pose, np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1e-3]])).obs
    rest = cs.evaluate(pose, np.zeros((2, 3))).obs
    loaded = rest[:, iref.O_FN] > 0
    assert np.all(moving[loaded, iref.O_FN] > rest[loaded, iref.O_FN] * (1 + 1e-6))
    np.testing.assert_allclose(cs.elastic_energy(moving)[0], rest[:, iref.O_FN], rtol=1e-12, atol=0.0)


def test_involute_energy_law_in_the_account():
    pair, cs = fzg_set()
    law = cs.energy_law()
    assert isinstance(law, ContactEnergyLaw) and law.normal_potential is not None
    th_b = pair.mesh_phase(0) + pair.ratio * 0.1 - 1e-4
    obs = cs.evaluate(np.array([[0.0, 0.0, 0.1], [pair.a, 0.0, th_b]]), np.zeros((2, 3))).obs
    delta, fe, v_n, v_t = law.split(obs)
    np.testing.assert_array_equal(fe, cs.elastic_energy(obs)[0])
    assert v_n.sum() > 0 and np.all(v_t == 0)


# -- rolling elements -------------------------------------------------------------------------
def ball_set():
    row = BallBearing(n_balls=12, ball_diameter=7.9375e-3, pitch_diameter=0.15, contact_angle=math.radians(40),
                      axial_preload=500.0)
    pair = AngularContactPair(rows=(row, row), row_spacing=0.05, arrangement="back_to_back")
    return BearingSet([Mounting(name="main", bearing=pair, inner=0, outer=-1)], 1, backend="numpy")


def needle_set():
    nb = NeedleBearing(inner_radius=0.011, n_rollers=20, roller_diameter=0.003, roller_length=0.01,
                       radial_clearance=1.5e-6, n_slices=2)
    return BearingSet([Mounting(name="needle", bearing=nb, inner=0, outer=1)], 2, backend="numpy")


def test_ball_potential_is_the_integral_of_the_force():
    # Gauss--Legendre (12 nodes) of a polynomial times the weakly varying K(alpha_w) against
    # adaptive quadrature of K(alpha_w(d)) d^(3/2): both to ~1e-13, bound 1e-10
    s = ball_set()
    fp = s.fparams[:1]
    for delta in (1e-7, 2e-6, 2e-5):
        ref, _ = quad(lambda d: rref.ball_elastic(np.array([d]), fp)[0], 0.0, delta, epsabs=0.0, epsrel=1e-13,
                      limit=200)
        V = rref.ball_potential(np.array([delta]), fp)[0]
        assert abs(V - ref) <= 1e-10 * ref


def test_ball_potential_derivative_is_the_radial_force():
    # dV/dr = F cos(alpha_w) = f_r of ball_law (the working angle moves with r); central
    # differences in r with h = 1e-4 delta: truncation ~ h^2 f_r'' / 6 ~ 2e-9 f_r, bound 1e-7
    s = ball_set()
    fp = s.fparams[:1]
    ar0 = fp[0, rref.R_A] * math.cos(fp[0, rref.R_ALPHA])
    az = fp[0, rref.R_A] * math.sin(fp[0, rref.R_ALPHA]) + fp[0, rref.R_SAX]
    free = math.sqrt((fp[0, rref.R_A] + fp[0, rref.R_CLEAR]) ** 2 - az ** 2) - ar0   # r at first touch

    def V_of_r(r):
        delta = math.hypot(ar0 + r, az) - fp[0, rref.R_A] - fp[0, rref.R_CLEAR]
        return rref.ball_potential(np.array([delta]), fp)[0]

    for dr in (2e-7, 3e-6, 2e-5):
        r = free + dr
        h = 1e-4 * dr
        dV = (V_of_r(r + h) - V_of_r(r - h)) / (2 * h)
        fr = rref.ball_law(np.array([r]), np.zeros(1), fp)[2][0]
        assert fr > 0 and abs(dV - fr) <= 1e-7 * fr


def test_lamina_potential_and_bearing_energy_law():
    # needle laminae: V = k delta^(p+1)/(p+1) with p = 10/9; its delta-derivative is k delta^p
    # (central differences, h = 1e-4 delta: truncation ~1e-9 relative, bound 1e-7)
    s = needle_set()
    law = s.energy_law()
    n = len(s.ids)
    obs = np.zeros((n, 8))
    delta = np.linspace(-1e-6, 8e-6, n)
    obs[:, rref.O_GAP] = -delta
    F, V = s.elastic_energy(obs)
    k, p = s.fparams[:, rref.R_K], s.fparams[:, rref.R_P]
    on = delta > 0
    np.testing.assert_allclose(V[on], k[on] * delta[on] ** (p[on] + 1) / (p[on] + 1), rtol=1e-14)
    assert np.all(V[~on] == 0) and np.all(F[~on] == 0)
    h = 1e-4 * delta[on]
    up, dn = obs[on].copy(), obs[on].copy()
    up[:, rref.O_GAP] -= h
    dn[:, rref.O_GAP] += h
    sub = s.fparams[on]
    dV = (rref.elastic_state(np.zeros(on.sum(), int), -up[:, rref.O_GAP], sub)[1]
          - rref.elastic_state(np.zeros(on.sum(), int), -dn[:, rref.O_GAP], sub)[1]) / (2 * h)
    np.testing.assert_allclose(dV, F[on], rtol=1e-7)
    assert np.all(law.split(obs)[2] == V)


def test_ball_bearing_elastic_force_matches_the_evaluator():
    # at rest the evaluator's ball force is the elastic force K(alpha_w) delta^(3/2): the law
    # rebuilt from the observed approach alone agrees to rounding (1e-12)
    s = ball_set()
    obs = s.evaluate(np.array([[3e-6, -1e-6, 0.0]]), np.zeros((1, 3))).obs
    F, V = s.elastic_energy(obs)
    assert np.sum(obs[:, rref.O_FN] > 0) > 4
    np.testing.assert_allclose(F, obs[:, rref.O_FN], rtol=1e-12, atol=1e-9)
    assert np.all(V >= 0)


def test_energy_law_input_errors():
    with pytest.raises(RvtoolInputError, match="normal_stiffness and normal_exponent"):
        ContactEnergyLaw(tangential_stiffness=np.zeros(2), friction_model=np.zeros(2, int))
    with pytest.raises(RvtoolInputError, match="normal_potential must be None or a callable"):
        ContactEnergyLaw(tangential_stiffness=np.zeros(2), friction_model=np.zeros(2, int), normal_potential=3.0)


def test_gear_pair_energy_balance_with_the_series_potential():
    # a gear pair loaded quasi-statically in 16 levels to 300 N/mm: the load work (trapezoidal on
    # the levels) equals the stored series-law energy up to the trapezoid's O(h^2) error and the
    # non-potential part of the law (the compliance and depths move with the roll angle, about
    # F^2 dC/du du ~ 4e-4 V here); measured 2.3e-4. 1e-3 keeps margin while a potential without
    # Weber's term (V = F delta / 2) leaves 1.7e-2: the bound tests the closed form
    from rvtool.assembly.gear_pair import build_gear_pair
    from rvtool.solver.gear_pair import GearPairStatics
    from rvtool.observe.energy import EnergyAccount
    pair, _ = fzg_set()
    m = build_gear_pair(pair)
    st = GearPairStatics(m)
    account = EnergyAccount(m.mbs, [m.element])
    th_a, th_b = 0.1, m.kinematic_angle_b(0.1)
    for k, T in enumerate(np.linspace(0.0, m.line_load_torque(300e3), 17)[1:]):
        m.set_output_torque(T)
        th_b = st.solve(th_a, th_b)
        q = np.array(m.mbs.systemData.GetODE2Coordinates())
        m.element.commit(q, np.zeros_like(q))
        (account.accept if k else account.start)(0.0, q, np.zeros_like(q))
    r = account.results()
    assert r["elastic_end_J"]["contact_normal/mesh"] > 0.04
    assert r["balance_rel_err"] < 1e-3
