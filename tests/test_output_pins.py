"""Output-pin family: reaction balance, tangent versus central differences and
independent derivatives, sleeve clearance, open contacts, the C_01 = 0
transfer derivative, single versus double precision, Warp kernel versus
NumPy reference on every device, Hertz calibration, explicit sleeve, input
errors and the family inside an Exudyn contact element."""
import math

import numpy as np
import pytest
import warp as wp

from rvtool.errors import RvtoolInputError
from rvtool.output_pins import (ExplicitSleeveEvaluator, ExplicitSleeveInterface, ExplicitSleeveModel, OutputPinEvaluator, OutputPinMechanism,
                                PinMode, SharedPinCompliance, SharedPinModel, SleeveFit, calibrate_pin_coefficient,
                                hertz_calibrated_coefficient, hertz_pin_in_hole_approach, scaled_tangent,
                                shared_pin_study_mechanism)
from rvtool.output_pins import diagnostics as diag
from warp_contacts import output_pins_ref as ref
from warp_contacts.output_pins import OutputPinKernel, shared_pin_adjoint_jacobian
from warp_contacts.precision import resolve_device

R = 35e-3
resolve_device("cpu")  # initializes Warp
DEVICES = [d.alias for d in wp.get_devices()]


def _random_state(rng):
    """Non-collinear loaded state: wheel translations of 40-90 um in random directions, small rotations."""
    q = np.zeros(9)
    q[0:2] = rng.normal(0, 5e-6, 2)
    for i, sign in ((0, 1.0), (1, -1.0)):
        ang = rng.uniform(-0.6, 0.6)
        mag = rng.uniform(60e-6, 90e-6)
        q[3 + 3 * i:5 + 3 * i] = sign * mag * np.array([np.cos(ang), np.sin(ang)])
    q[[2, 5, 8]] = rng.normal(0, 2e-4, 3)
    return q


def _common_origin_moments(Q, tilt_m, q, z):
    """Total (M_x, M_y, M_z) about the flange origin of the 3D force system.

    Body b's force (F_x, F_y, 0) acts with its own moments about its origin at
    (x_b, y_b, z_b); translating adds r_b x F = (-z_b F_y, z_b F_x, x_b F_y - y_b F_x).
    """
    Q = Q.reshape(3, 3)
    x = q.reshape(3, 3)[:, :2]
    mz = np.sum(Q[:, 2] + x[:, 0] * Q[:, 1] - x[:, 1] * Q[:, 0])
    mx = np.sum(tilt_m[:, 0] - z * Q[:, 1])
    my = np.sum(tilt_m[:, 1] + z * Q[:, 0])
    return mx, my, mz


@pytest.mark.parametrize("seed", range(6))
def test_reaction_balance_random_noncollinear_states(seed):
    """Sum of forces = 0 and sum of moments about a common origin = 0 (Newton's third law at every slice:
    each slice force acts on the wheel and, opposite, on the flange along the same line)."""
    rng = np.random.default_rng(seed)
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=3, phase=rng.uniform(0, 1))
    model = SharedPinModel(mech)
    q = _random_state(rng)
    tilt = rng.normal(0, 2e-4, (3, 2))
    r = model.raw(q, tilt)
    Q = r["Q"].sum(axis=0)
    fmax = np.max(np.abs(Q))
    assert fmax > 100.0, "the state must be loaded"
    force, _ = diag.balance(Q, q)
    np.testing.assert_allclose(force, 0.0, atol=1e-12 * fmax)
    z = np.array([0.0, *mech.wheel_midplanes])
    mx, my, mz = _common_origin_moments(Q, r["tilt_moments"].sum(axis=0), q, z)
    # round-off of sums of ~kN forces times 35 mm arms
    assert max(abs(mx), abs(my), abs(mz)) <= 1e-12 * fmax * R


def test_plain_mode_reaction_balance():
    rng = np.random.default_rng(3)
    mech = shared_pin_study_mechanism(0.0, n_pins=5, mode=PinMode.PLAIN, compliance=None)
    ev = OutputPinEvaluator(mech)
    q = _random_state(rng)
    e = ev.evaluate(q.reshape(3, 3), np.zeros((3, 3)))
    fmax = np.max(np.abs(e.Q))
    assert fmax > 100.0
    force, moment = diag.balance(e.Q, q)
    np.testing.assert_allclose(force, 0.0, atol=1e-12 * fmax)
    assert abs(moment) <= 1e-12 * fmax * R


def _fd(fun, q, h_trans):
    K = np.zeros((9, 9))
    for j in range(9):
        h = h_trans if j % 3 < 2 else h_trans / R
        qp, qm = q.copy(), q.copy()
        qp[j] += h
        qm[j] -= h
        K[:, j] = -(fun(qp) - fun(qm)) / (2 * h)
    return K


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("c01", [0.0, 0.9e-9])
def test_tangent_matches_central_differences(seed, c01):
    """Analytic K_q = -dQ/dq vs central differences with 1 nm steps: the FD truncation error
    ~ h^2 F''' / F' ~ (1e-9 / 2e-5)^2 and round-off ~ 1e-16 F / (h K) ~ 1e-8 leave 1e-6 as margin."""
    rng = np.random.default_rng(100 + seed)
    mech = shared_pin_study_mechanism(c01, n_pins=2, phase=rng.uniform(0, 1))
    model = SharedPinModel(mech)
    q = _random_state(rng)
    K = model.evaluate(q).K_q
    Kfd = _fd(model.forces, q, 1e-9)
    S = diag.scaling_matrix(R)
    assert np.linalg.norm(S @ (K - Kfd) @ S) / np.linalg.norm(S @ Kfd @ S) < 1e-6


def test_study_tangent_columns_within_paper_criterion():
    """The paper's check: 0.5 um central differences agree with the two wheel-radial columns within 2.5 %."""
    for c01 in (0.0, 0.9e-9):
        model = SharedPinModel(shared_pin_study_mechanism(c01))
        q = np.zeros(9)
        q[3], q[6] = 110e-6, -70e-6
        K = model.evaluate(q).K_q
        Kfd = diag.central_difference_tangent(model, q, 0.5e-6, columns=(3, 6))
        assert max(diag.column_relative_error(K, Kfd, [3, 6], R)) < 0.025


def test_plain_tangent_matches_central_differences():
    rng = np.random.default_rng(8)
    mech = shared_pin_study_mechanism(0.0, n_pins=4, mode=PinMode.PLAIN, compliance=None)
    ev = OutputPinEvaluator(mech)
    q = _random_state(rng)
    K = -ev.evaluate(q.reshape(3, 3), np.zeros((3, 3))).dQdq
    Kfd = _fd(lambda x: ev.evaluate(x.reshape(3, 3), np.zeros((3, 3))).Q, q, 1e-9)
    assert np.linalg.norm(K - Kfd) / np.linalg.norm(Kfd) < 1e-6


@pytest.mark.parametrize("state", ["collinear", "non_collinear"])
def test_independent_derivatives_agree_with_production_tangent(state):
    """Eq. (moment_comparison_error): the complex step of the NumPy force routine, Warp's reverse mode
    of the unrolled force-only kernel and the separate moment assembly reproduce the production tangent
    to round-off (1e-12); dropping the force-arm term of Eq. (moment_chain_rule) does not (> 2e-4)."""
    q = np.zeros(9)
    if state == "collinear":
        q[3], q[6] = 110e-6, -70e-6
    else:
        q[3:5], q[6:8], q[[2, 5, 8]] = (70e-6, 30e-6), (-60e-6, -25e-6), (1e-4, 2e-4, -1.5e-4)
    for c01 in (0.0, 0.9e-9):
        mech = shared_pin_study_mechanism(c01)
        r = SharedPinModel(mech, slice_tangent=True).evaluate(q)
        assert diag.moment_comparison_error(r.K_q, diag.complex_step_tangent(mech, q), R) < 1e-12
        Qs, Ks = diag.separate_moment_assembly(mech, q, r)
        np.testing.assert_allclose(Qs, r.Q, rtol=0, atol=1e-12 * np.max(np.abs(r.Q)))
        assert diag.moment_comparison_error(r.K_q, Ks, R) < 1e-12
        _, Kf = diag.separate_moment_assembly(mech, q, r, include_arm_term=False)
        assert diag.moment_comparison_error(Kf, r.K_q, R) > 2e-4
        fp, ip = mech.packed(0, (1, 2))
        Qa, J = shared_pin_adjoint_jacobian(fp, ip, mech.stations, q.reshape(3, 3), unrolled=True)
        np.testing.assert_allclose(Qa.sum(axis=0), r.Q, rtol=0, atol=1e-12 * np.max(np.abs(r.Q)))
        assert diag.moment_comparison_error(r.K_q, -J.sum(axis=0).reshape(9, 9), R) < 1e-12


@pytest.mark.xfail(strict=True, reason="Warp's reverse mode through dynamic loops that mutate accumulators "
                   "(slice sums, sleeve updates) is not differentiable (Warp codegen: 'detected mutated variable "
                   "during a dynamic for-loop'); the production tangent is forward mode for this reason")
def test_warp_adjoint_with_dynamic_loops():
    mech = shared_pin_study_mechanism(0.9e-9)
    q = np.zeros(9)
    q[3], q[6] = 110e-6, -70e-6
    r = SharedPinModel(mech).evaluate(q)
    fp, ip = mech.packed(0, (1, 2))
    _, J = shared_pin_adjoint_jacobian(fp, ip, mech.stations, q.reshape(3, 3), unrolled=False)
    assert diag.moment_comparison_error(r.K_q, -J.sum(axis=0).reshape(9, 9), R) < 1e-6


@pytest.mark.parametrize("seed", range(5))
def test_sleeve_stays_inside_clearance_disk(seed):
    """|u_fit| <= c after the projected updates of Eq. (supp_pin_fit), seated or interior."""
    rng = np.random.default_rng(200 + seed)
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=4, phase=rng.uniform(0, 1))
    r = SharedPinModel(mech).evaluate(_random_state(rng))
    c = mech.sleeve.clearance
    assert np.all(np.linalg.norm(r.sleeve_offset, axis=1) <= c * (1 + 1e-12))


def test_zero_force_when_all_slices_open():
    """Centred wheels: approach = -(R_h - r_p) = -50 um on every slice, so Q = 0 and K_q = 0 exactly."""
    q = np.zeros(9)
    q[3], q[6] = 10e-6, -20e-6
    for mech in (shared_pin_study_mechanism(0.9e-9, n_pins=3),
                 shared_pin_study_mechanism(0.0, n_pins=3, mode=PinMode.PLAIN, compliance=None)):
        ev = OutputPinEvaluator(mech)
        e = ev.evaluate(q.reshape(3, 3), np.zeros((3, 3)))
        assert np.all(e.Q == 0.0) and np.all(e.dQdq == 0.0)
        assert np.all(e.obs[:, 0] == 0.0) and np.all(e.obs[:, 2] > 0.0)


def test_transfer_derivative_vanishes_without_cross_compliance():
    """With C_01 = 0 the station closures decouple and the seated sleeve's projection removes the
    radial direction, so dF_1/dx_0 is zero to round-off; with C_01 > 0 it is not, and matches
    central differences (0.5 um) to 1e-5."""
    q = np.zeros(9)
    q[6] = -70e-6
    for x0 in (100e-6, 110e-6, 120e-6):
        q[3] = x0
        r0 = SharedPinModel(shared_pin_study_mechanism(0.0)).evaluate(q)
        assert abs(r0.wheel_force_derivative(1, 3)) <= 1e-12 * abs(r0.wheel_force_derivative(0, 3))
        model = SharedPinModel(shared_pin_study_mechanism(0.9e-9))
        r1 = model.evaluate(q)
        d = r1.wheel_force_derivative(1, 3)
        qp, qm = q.copy(), q.copy()
        qp[3] += 0.5e-6
        qm[3] -= 0.5e-6
        fd = (model.evaluate(qp).wheel_forces[1] - model.evaluate(qm).wheel_forces[1]) / 1e-6
        assert d > 1e6 and abs(d - fd) <= 1e-5 * abs(d)


@pytest.mark.parametrize("mode", ["shared", "plain"])
def test_float32_agrees_with_float64(mode):
    """float32 coordinates near 35 mm are rounded to ~2e-9 m against approaches of ~2e-5 m, so the
    approaches carry ~1e-4 relative error and forces ~1.1e-4 (p = 10/9); 5e-4 is the bound for
    forces and tangent entries (relative to the largest entry)."""
    rng = np.random.default_rng(9)
    kw = {} if mode == "shared" else dict(mode=PinMode.PLAIN, compliance=None)
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=3, **kw)
    q = _random_state(rng)
    a = OutputPinEvaluator(mech, precision="float32").evaluate(q.reshape(3, 3), np.zeros((3, 3)))
    b = OutputPinEvaluator(mech).evaluate(q.reshape(3, 3), np.zeros((3, 3)))
    assert np.max(np.abs(a.Q - b.Q)) <= 5e-4 * np.max(np.abs(b.Q))
    assert np.max(np.abs(a.dQdq - b.dQdq)) <= 5e-4 * np.max(np.abs(b.dQdq))


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("mode", ["shared", "plain"])
def test_kernel_matches_numpy_reference(device, mode):
    """Same formulas, float64: agreement to 1e-12 relative (round-off of differently ordered sums),
    with tilts, several pins and all outputs."""
    rng = np.random.default_rng(12)
    kw = {} if mode == "shared" else dict(mode=PinMode.PLAIN, compliance=None)
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=4, phase=0.3, **kw)
    fp, ip = mech.packed(0, (1, 2))
    pose = _random_state(rng).reshape(3, 3)
    tilt = rng.normal(0, 2e-4, (3, 2))
    k = OutputPinKernel(fp, ip, mech.stations, 3, mode, "float64", device, slice_tangent=True)
    w = {key: np.array(v) for key, v in k.evaluate(pose, tilt).items()}
    r = (ref.evaluate_shared if mode == "shared" else ref.evaluate_plain)(pose, fp, ip, mech.stations, tilt=tilt)
    keys = ["Q", "dQdq", "tilt_moments", "slices"] + (["pin", "sleeve_tangent", "slice_force_tangent"]
                                                      if mode == "shared" else [])
    for key in keys:
        a, b = w[key], r[key].reshape(w[key].shape)
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b)), key


def test_hertz_calibration():
    """delta = F/(pi l E*) [ln(4 pi l E* dR / F) - 1] equals the sum of Johnson's centre approaches
    P V_k (2 ln(4 R_k / a) - 1)/pi of pin (R_1 = r_p) and hole (R_2 = R_h), with a = sqrt(4 P R / (pi E*)),
    1/R = 1/r_p - 1/R_h, V_k = (1 - nu^2)/E; and k = F/delta^(10/9) reproduces F at delta."""
    F, rp, rh, L, E, nu = 2000.0, 1.5e-3, 1.55e-3, 6e-3, 206e9, 0.3
    delta = hertz_pin_in_hole_approach(F, rp, rh, L, E, nu)
    P = F / L
    V = (1 - nu * nu) / E
    Es = 1.0 / (2 * V)
    a = math.sqrt(4 * P * (1.0 / (1.0 / rp - 1.0 / rh)) / (math.pi * Es))
    johnson = P * V / math.pi * ((2 * math.log(4 * rp / a) - 1) + (2 * math.log(4 * rh / a) - 1))
    assert delta == pytest.approx(johnson, rel=1e-12)
    k = hertz_calibrated_coefficient(F, rp, rh, L, E, nu)
    assert k * delta ** (10 / 9) == pytest.approx(F, rel=1e-12)
    assert calibrate_pin_coefficient(F, delta) == pytest.approx(k, rel=1e-14)
    with pytest.raises(RvtoolInputError, match="force"):
        hertz_pin_in_hole_approach(1e9, rp, rh, L, E, nu)


def test_explicit_sleeve_tangent_and_equilibrium():
    """Explicit sleeve: forward-mode tangent vs central differences (1e-6), a massless sleeve in
    equilibrium (net force below 1e-6 N), reaction balance, and the flexible interface satisfying
    delta_j = delta_j^rigid - sum_k C_jk F_k."""
    mech = shared_pin_study_mechanism(0.9e-9)
    model = ExplicitSleeveModel(mech, ExplicitSleeveInterface(inner_coefficient=2e10))
    q9 = np.zeros(9)
    q9[3], q9[6] = 110e-6, -70e-6
    q12, Q, K, info = model.sleeve_equilibrium(q9, start_offset=(5e-6, 0.0))
    assert np.linalg.norm(Q[9:11]) < 1e-6
    fmax = np.max(np.abs(Q))
    assert np.linalg.norm(Q[0::3].sum()) < 1e-9 * fmax and np.linalg.norm(Q[1::3].sum()) < 1e-9 * fmax
    Kfd = np.zeros((12, 12))
    for j in range(12):
        h = 1e-9 if j % 3 < 2 else 1e-9 / R
        a, b = q12.copy(), q12.copy()
        a[j] += h
        b[j] -= h
        Kfd[:, j] = -(model.evaluate(a)[0] - model.evaluate(b)[0]) / (2 * h)
    assert np.linalg.norm(K - Kfd) / np.linalg.norm(Kfd) < 1e-6
    Fin = info["inner_force"]
    rigid = np.linalg.norm(info["sleeve_offset"]) - 5e-6
    C = np.array([[1.5e-9, 0.9e-9], [0.9e-9, 1.5e-9]])
    defl = C @ Fin.sum(axis=1)
    np.testing.assert_allclose(info["inner_approach"], (rigid - defl)[:, None] * np.ones((1, 4)), atol=1e-13)


def test_bad_inputs_name_the_parameter():
    base = dict(pin_circle_radius=R, hole_circle_radius=R, pin_radius=1.5e-3, hole_radius=1.55e-3,
                coefficient=2e8, contact_length=6e-3)
    with pytest.raises(RvtoolInputError, match="hole_radius"):
        OutputPinMechanism(**dict(base, hole_radius=1.4e-3))
    with pytest.raises(RvtoolInputError, match="n_slices"):
        OutputPinMechanism(**base, n_slices=0)
    with pytest.raises(RvtoolInputError, match="mode"):
        OutputPinMechanism(**base, mode="condensed")
    with pytest.raises(RvtoolInputError, match="wheel_midplanes"):
        OutputPinMechanism(**base, mode="shared", wheel_midplanes=(0.0,),
                           compliance=SharedPinCompliance(self_compliance_0=1e-9, self_compliance_1=1e-9))
    with pytest.raises(RvtoolInputError, match="compliance"):
        OutputPinMechanism(**base, mode="shared", wheel_midplanes=(-3e-3, 3e-3))
    with pytest.raises(RvtoolInputError, match="cross_compliance"):
        SharedPinCompliance(self_compliance_0=1e-9, self_compliance_1=1e-9, cross_compliance=2e-9)
    with pytest.raises(RvtoolInputError, match="updates"):
        SleeveFit(updates=-1)
    with pytest.raises(RvtoolInputError, match="relaxation"):
        SleeveFit(relaxation=0.0)
    with pytest.raises(RvtoolInputError, match="mechanism"):
        SharedPinModel(OutputPinMechanism(**base))
    with pytest.raises(RvtoolInputError, match="precision"):
        SharedPinModel(shared_pin_study_mechanism(), precision="float16")
    with pytest.raises(RvtoolInputError, match="q must have"):
        SharedPinModel(shared_pin_study_mechanism()).evaluate(np.zeros(6))
    with pytest.raises(RvtoolInputError, match="wheels"):
        OutputPinEvaluator(shared_pin_study_mechanism(), wheels=(1, 5))


# ---------------------------------------------------------------- Exudyn integration
@pytest.fixture
def exu():
    """Exudyn, or a skip of the integration tests only (the family itself needs no Exudyn)."""
    return pytest.importorskip("exudyn")


def _reducer_output_stage(exu, mech, q0, masses=(0.5, 0.2, 0.2), inertias=(1e-3, 2e-4, 2e-4)):
    from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D
    from exudyn_user_elements.contact_element import ContactElement
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = []
    for b in range(3):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0], initialCoordinates=list(q0[3 * b:3 * b + 3])))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=masses[b], inertia=inertias[b]))
        nodes.append(n)
    el = ContactElement(mbs, nodes, OutputPinEvaluator(mech, name="pins"))
    mbs.Assemble()
    return SC, mbs, el, nodes


def test_exudyn_contact_element_forces_and_jacobian(exu):
    """Flange and two wheels on NodeRigidBody2D nodes: the element returns the family's Q and the
    Jacobian in Exudyn's ObjectGenericODE2 convention J = -(f_ODE2 dQ/dq + f_ODE2_t dQ/dv)."""
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=3)
    q0 = _random_state(np.random.default_rng(21))
    SC, mbs, el, nodes = _reducer_output_stage(exu, mech, q0)
    Q = el.force_callback(mbs, 0.0, el.object_number, q0, np.zeros(9))
    J = el.jacobian_callback(mbs, 0.0, el.object_number, q0, np.zeros(9), 1.0, 0.5)
    r = SharedPinModel(mech).evaluate(q0)
    np.testing.assert_allclose(Q, r.Q, rtol=0, atol=1e-12 * np.max(np.abs(r.Q)))
    np.testing.assert_allclose(J, r.K_q, rtol=0, atol=1e-12 * np.max(np.abs(r.K_q)))
    assert el.n_evaluations == 1
    snap = el.commit(np.asarray(mbs.systemData.GetODE2Coordinates()), np.zeros(9))
    assert len(snap.ids) == 3 * 2 * 4 and np.all(np.isfinite(snap.normal_force))


def test_exudyn_simulate_conserves_momentum(exu):
    """Free flange and wheels released from a pressed state: the pin forces are internal, so total
    linear momentum stays at its initial zero (to the Newton tolerance, here 1e-9 of m |v|)."""
    from rvtool.solver import RunSpec, simulate
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=3)
    q0 = np.zeros(9)
    # ~40 um approach on every pin; not symmetric, so the momentum balance is not trivial
    q0[3:6], q0[6:9] = (90e-6, 10e-6, 1e-4), (-85e-6, 5e-6, -5e-5)
    masses = (0.5, 0.2, 0.2)
    SC, mbs, el, nodes = _reducer_output_stage(exu, mech, q0, masses=masses)
    # well inside a quarter of the contact period 2 pi sqrt(0.2 kg / 3e8 N/m) ~ 0.16 ms: the pins stay loaded
    spec = RunSpec(end_time=2e-5, step=5e-6, abs_tol=1e-6, rel_tol=1e-10)
    rec = simulate(mbs, spec, elements=[el])
    assert rec.accepted_steps == 4
    v = np.asarray(mbs.systemData.GetODE2Coordinates_t()).reshape(3, 3)
    p = sum(m * v[b, :2] for b, m in enumerate(masses))
    vmax = np.max(np.abs(v[:, :2]))
    assert vmax > 1e-3, "the pressed wheels must have moved"
    assert np.linalg.norm(p) <= 1e-9 * max(masses) * vmax
    assert el.last_obs is not None and np.max(el.last_obs[:, 0]) > 0


def test_exudyn_explicit_sleeve_with_its_own_inertia(exu):
    """The explicit sleeve as a fourth body with a small mass: its node carries the inner and outer
    contacts, linear momentum of all four bodies stays zero (internal forces only)."""
    from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D
    from exudyn_user_elements.contact_element import ContactElement
    from rvtool.solver import RunSpec, simulate
    mech = shared_pin_study_mechanism(0.9e-9)
    q0 = np.zeros(12)
    q0[3:6], q0[6:9], q0[9:11] = (100e-6, 5e-6, 0.0), (-70e-6, -5e-6, 0.0), (R + 6e-6, 0.0)
    masses = (0.5, 0.2, 0.2, 0.005)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = []
    for b in range(4):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0], initialCoordinates=list(q0[3 * b:3 * b + 3])))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=masses[b], inertia=1e-6 if b == 3 else 1e-4))
        nodes.append(n)
    el = ContactElement(mbs, nodes, ExplicitSleeveEvaluator(mech, ExplicitSleeveInterface(inner_coefficient=2e9)))
    mbs.Assemble()
    ev = el.evaluate(0.0, np.asarray(mbs.systemData.GetODE2Coordinates()), np.zeros(12))
    assert np.max(ev.obs[:8, 0]) > 0 and np.max(ev.obs[8:, 0]) > 0, "outer and inner contacts must both be loaded"
    rec = simulate(mbs, RunSpec(end_time=1e-5, step=2.5e-6, abs_tol=1e-6, rel_tol=1e-10), elements=[el])
    assert rec.accepted_steps == 4
    v = np.asarray(mbs.systemData.GetODE2Coordinates_t()).reshape(4, 3)
    p = sum(m * v[b, :2] for b, m in enumerate(masses))
    assert np.linalg.norm(p) <= 1e-9 * max(m * np.linalg.norm(v[b, :2]) for b, m in enumerate(masses))


@pytest.mark.parametrize("mode", ["shared", "plain"])
def test_evaluator_with_grounded_flange(mode):
    """A fixed flange (GROUND) drops the flange rows and columns: the wheel blocks equal those of the
    same mechanism with the flange as a body at rest."""
    from rvtool.output_pins import GROUND
    kw = {} if mode == "shared" else dict(mode=PinMode.PLAIN, compliance=None)
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=3, **kw)
    q = _random_state(np.random.default_rng(31))
    q[0:3] = 0.0
    full = OutputPinEvaluator(mech).evaluate(q.reshape(3, 3), np.zeros((3, 3)))
    grounded = OutputPinEvaluator(mech, flange=GROUND, wheels=(0, 1)).evaluate(q[3:].reshape(2, 3), np.zeros((2, 3)))
    np.testing.assert_allclose(grounded.Q, full.Q[3:], rtol=0, atol=1e-12 * np.max(np.abs(full.Q)))
    np.testing.assert_allclose(grounded.dQdq, full.dQdq[3:, 3:], rtol=0, atol=1e-12 * np.max(np.abs(full.dQdq)))
