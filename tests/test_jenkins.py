"""Anchor friction of the circle-contact family as a Jenkins element under the production driver.

* the quick form of cases/verification/verify_jenkins.py against the closed form of the
  series springs k, k_t with a Coulomb slider (k_s = k k_t / (k + k_t)):
  loop area 4 F_c (x_a - F_c/k_s) and the Masing branches;
* history ownership: the committed anchors are a function of the accepted
  states only (a replay of the accepted states through a fresh evaluator
  reproduces them bit for bit, whatever the rejected attempts and Newton
  iterations in between);
* stick has zero material slip (the anchor does not move), slip obeys
  |F_t| = mu F_n;
* the analytic tangent against central differences in stick and in slip, for
  the NumPy reference and the Warp kernel on every available device;
* bad friction inputs raise named errors.
"""
import importlib.util
import math
import os

import numpy as np
import pytest
import warp as wp

from rvtool.contact.circle_set import CircleContact, CircleContactSet, FrictionLaw, FrictionModel, NormalLaw
from rvtool.errors import RvtoolInputError
from warp_contacts.planar_ref import perp, rot
from warp_contacts import circle_pairs_ref as ref
from warp_contacts.precision import resolve_device

resolve_device("cpu")
DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(
    wp.get_cuda_device_count() == 0, reason="no CUDA device"))]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _case():
    spec = importlib.util.spec_from_file_location("verify_jenkins", os.path.join(ROOT, "cases", "verification", "verify_jenkins.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def quick():
    mod = _case()
    return mod, mod.run(quick=True)


def test_quick_case_matches_the_closed_form(quick):
    mod, res = quick
    p, d = mod.PARAMS, res["_detail"]
    k, kt, m_b = p["spring"], p["tangential_stiffness"], p["block_mass"]
    x_a, w, R, F_N, mu = p["amplitude"], 2 * math.pi * p["frequency"], p["surface_radius"], p["normal_load"], p["mu"]
    k_s, f_c, dt = d["k_s"], d["f_c"], d["spec"].step
    area = 4 * f_c * (x_a - f_c / k_s)
    # loop area: (1) the trapezoidal loop through accepted samples cuts the two stick->slip corners,
    # at most k_s dx^2/8 each with dx = w x_a dt; (2) the ground circle of radius R adds the
    # conservative outward force F_N x_b / R (a spring of -F_N/R), whose work over the loop is at most
    # (F_N/R)/k * 4 F_c x_a, and (3) changes F_n, hence F_c, by mu F_c x_a / R over a path 4 x_a
    area_tol = k_s * (w * x_a * dt) ** 2 / 4 + F_N / (R * k) * 4 * f_c * x_a + mu * f_c * x_a / R * 4 * x_a
    assert res["loop_area_rel_err"] <= area_tol / area
    # branches: the return mapping is exact at the accepted states of a quasi-static drive; what
    # remains is (1) the block's inertia ringing after each stick->slip transition, where its velocity
    # jumps by at most w x_a k_t/(k + k_t), on the spring k: amplitude <= that / sqrt(k/m_b)
    # (undamped bound; the algorithm damps it), (2) the ground curvature F_N x_a / (R k), and
    # (3) the Newton tolerance abs_tol / k
    branch_tol = (w * x_a * kt / (k + kt)) / math.sqrt(k / m_b) + F_N * x_a / (R * k) + d["spec"].abs_tol / k
    assert res["branch_max_abs_err_m"] <= branch_tol
    # energy balance: the friction dissipation 1/2 (|F_n| + |F_n+1|) Delta s differs from the
    # trapezoidal work at a stick->slip step by at most k_s dx^2/2; one transition per half cycle
    # (3 in the quick run), plus the ringing energy 1/2 m_b dv^2 per transition that the algorithm
    # dissipates unattributed
    dv = w * x_a * kt / (k + kt)
    balance_tol = 3 * (k_s * (w * x_a * dt) ** 2 / 2 + 0.5 * m_b * dv ** 2)
    assert res["energy_balance_rel_err"] * d["energy"]["balance_scale_J"] <= balance_tol
    # and the zero-force width of the loop, 2 (x_a - F_c/k_s), within the same corner and curvature bounds
    assert abs(d["width_m"] - d["width_cf_m"]) <= (w * x_a * dt) + F_N * x_a / (R * k)


@pytest.fixture(scope="module")
def recorded():
    """A Jenkins run through virgin stick, slip and one reversal, with forced rejections;
    every accepted state, the committed history after it and the observations."""
    from exudyn_user_elements.scenes import jenkins_element
    from rvtool.solver import RunSpec, simulate
    SC, mbs, el, items = jenkins_element(frequency=0.1, dwell=0.025)
    rows = []

    def keep(t, q, v):
        h = el.evaluator.history
        rows.append(dict(t=t, q=q.copy(), v=v.copy(), active=h.active.copy(), a=h.anchor_a.copy(),
                         b=h.anchor_b.copy(), slip=float(h.slip_distance[0]), obs=el.last_obs[0].copy()))
    rec = simulate(mbs, RunSpec(end_time=4.0, step=0.025, abs_tol=1e-6, rel_tol=1e-8), [el],
                   reject_attempts=range(5, 2000, 15), before_accept=keep)
    return el, rec, rows


def test_anchors_are_a_function_of_the_accepted_states_only(recorded):
    from rvtool.contact.evaluator import ContactSetEvaluator
    el, rec, rows = recorded
    # the run did reject attempts and evaluated far more trials than it accepted
    assert rec.rejected_steps >= 8
    assert el.n_evaluations > 2 * rec.accepted_steps
    replay = ContactSetEvaluator(el.evaluator.set, backend="warp")
    for r in rows:
        replay.commit(*el.pose_velocity(el.local(r["q"]), el.local(r["v"])))
        np.testing.assert_array_equal(replay.history.active, r["active"])
        np.testing.assert_array_equal(replay.history.anchor_a, r["a"])
        np.testing.assert_array_equal(replay.history.anchor_b, r["b"])
        assert replay.history.slip_distance[0] == r["slip"]


def test_trial_evaluations_do_not_move_the_anchors(recorded):
    el, rec, rows = recorded
    h0 = el.evaluator.history.copy()
    rng = np.random.default_rng(3)
    q, v = rows[-1]["q"], rows[-1]["v"]
    for _ in range(25):
        pose, vel = el.pose_velocity(el.local(q + rng.normal(0, 2e-5, q.size)), el.local(v + rng.normal(0, 1e-3, v.size)))
        el.evaluator.evaluate(pose, vel)
    h = el.evaluator.history
    for name in ("active", "anchor_a", "anchor_b", "slip_distance"):
        np.testing.assert_array_equal(getattr(h, name), getattr(h0, name))


def test_stick_has_zero_slip_and_slip_obeys_the_bound(recorded):
    el, rec, rows = recorded
    mu = el.evaluator.set.contacts[0].friction.mu_kinetic
    n_stick = n_slip = 0
    for prev, r in zip(rows[1:], rows[2:]):  # from the second accepted state on, the anchor exists
        ds = r["slip"] - prev["slip"]
        ft, fn = abs(r["obs"][ref.O_FT]), r["obs"][ref.O_FN]
        if ds > 0:
            n_slip += 1
            # slip: the anchor is projected onto the bound, |F_t| = mu F_n up to round-off
            assert ft == pytest.approx(mu * fn, rel=1e-12)
        else:
            n_stick += 1
            # stick: the material points keep their anchors (zero slip) and the force is inside the cone
            assert ds == 0.0 and ft <= mu * fn
    assert n_stick > 10 and n_slip > 10


def _anchored_pair(model=FrictionModel.ANCHOR, kt=1e7, mu=0.3):
    contact = CircleContact(body_a=0, body_b=1, centre_a=(1e-3, 0.5e-3), centre_b=(-0.5e-3, 0.2e-3), radius_a=3e-3,
                            radius_b=4e-3, normal=NormalLaw(law="point", stiffness=1e10, damping=50.0, ramp_depth=1e-5),
                            friction=FrictionLaw(model=model, mu_kinetic=mu, tangential_stiffness=kt))
    cset = CircleContactSet(name="pair", n_bodies=2, contacts=(contact,))
    fp, ip = cset.packed()
    # place B so that the circles overlap by 2 um along a skew direction, both bodies rotated
    tha, thb = 0.3, -0.2
    ca = rot(np.array(tha), np.array([1e-3, 0.5e-3]))
    u = np.array([math.cos(0.7), math.sin(0.7)])
    cb = ca + u * (3e-3 + 4e-3 - 2e-6)
    pose = np.array([[0.0, 0.0, tha], [*(cb - rot(np.array(thb), np.array([-0.5e-3, 0.2e-3]))), thb], [0, 0, 0]])
    vel = np.array([[1e-3, -2e-3, 0.4], [-1e-3, 0.5e-3, -0.3], [0, 0, 0]])
    return fp, ip, pose, vel


def _history_at(fp, ip, pose, vel, shift):
    """Anchors at the current material points with A's anchor moved by ``shift`` [m] along t."""
    zero = (np.zeros(1, np.int32), np.zeros((1, 2)), np.zeros((1, 2)))
    *_, obs, (act, a, b) = ref.evaluate(pose, vel, fp, ip, *zero)
    t = perp(obs[:, ref.O_NX:ref.O_NY + 1])
    a = a + shift * rot(np.array([-pose[0, 2]]), t)
    return act, a, b


def _evaluator(device):
    if device is None:
        return lambda pose, vel, fp, ip, *h: ref.evaluate(pose, vel, fp, ip, *h)
    from warp_contacts.circle_pairs import CirclePairKernel
    cache = {}

    def ev(pose, vel, fp, ip, *h):
        if "k" not in cache:
            cache["k"] = CirclePairKernel(fp, ip, 2, "float64", device)
        Q, dq, dv, obs, hist = cache["k"].evaluate(pose, vel, *h)
        return np.array(Q), np.array(dq), np.array(dv), np.array(obs), hist
    return ev


# Central differences on a contact with 2 um overlap. Positions: h = 1e-9 (m, rad), truncation
# ~ h^2 F''' ~ 1e-8 of the tangent scale (F ~ delta^1.5, dQ/dq ~ 1e7 N/m), round-off
# ~ eps |Q| / h ~ 6e-6 N/m ~ 1e-12 of it. Velocities: the force is linear in them away from the
# clamps, so h = 1e-6 (m/s, rad/s) has no truncation and round-off ~ 6e-9 of a tangent scale ~ 6 N s/m.
# A missing chain-rule term is O(1). Both stick and slip states sit 3x away from the cone edge,
# so no difference crosses it.
FD_H = {"q": 1e-9, "v": 1e-6}
FD_RTOL = 1e-6


@pytest.mark.parametrize("device", [None] + DEVICES)
@pytest.mark.parametrize("regime, shift", [("stick", 3e-7), ("slip", 3e-6)])
def test_tangent_matches_central_differences(device, regime, shift):
    fp, ip, pose, vel = _anchored_pair()
    hist = _history_at(fp, ip, pose, vel, shift)
    ev = _evaluator(device)
    Q, dQdq, dQdv, obs, _ = ev(pose, vel, fp, ip, *hist)
    ft, lim = abs(obs[0, ref.O_FT]), 0.3 * obs[0, ref.O_FN]
    assert (ft < lim / 2) if regime == "stick" else (ft == pytest.approx(lim, rel=1e-12))
    for which, J in (("q", dQdq), ("v", dQdv)):
        fd = np.zeros((6, 6))
        for j in range(6):
            # perturb coordinate j (body j // 3, component j % 3) of the poses or the velocities
            Q_pm = []
            for sign in (1.0, -1.0):
                p, v = pose.copy(), vel.copy()
                (p if which == "q" else v)[j // 3, j % 3] += sign * FD_H[which]
                Q_pm.append(np.array(ev(p, v, fp, ip, *hist)[0][0]))
            fd[:, j] = (Q_pm[0] - Q_pm[1]) / (2 * FD_H[which])
        scale = np.abs(J[0]).max()
        np.testing.assert_allclose(J[0], fd, rtol=0, atol=FD_RTOL * scale, err_msg=f"dQ/d{which} in {regime}")


@pytest.mark.parametrize("kwargs, name", [
    (dict(model=FrictionModel.ANCHOR, mu_kinetic=-0.1, tangential_stiffness=1e6), "mu_kinetic"),
    (dict(model=FrictionModel.ANCHOR, mu_kinetic=math.nan, tangential_stiffness=1e6), "mu_kinetic"),
    (dict(model=FrictionModel.ANCHOR, mu_kinetic=0.3, tangential_stiffness=math.nan), "tangential_stiffness"),
    (dict(model=FrictionModel.ANCHOR, mu_kinetic=0.3, tangential_stiffness=0.0), "tangential_stiffness"),
])
def test_bad_friction_inputs_raise_naming_the_parameter(kwargs, name):
    with pytest.raises(RvtoolInputError, match=name):
        FrictionLaw(**kwargs)


def test_bad_jenkins_scene_inputs_raise():
    from exudyn_user_elements.scenes import jenkins_element
    with pytest.raises(RvtoolInputError, match="mu_kinetic"):
        jenkins_element(mu=-0.3)
