"""Elastic pins closed per pin (rvtool/contact/pin_closure.py) against the closed form of one pin
loaded by two wheels, the exact condensed tangent, and RD-40's stiffness budget with elastic pins."""
import itertools

import numpy as np
import pytest
import warp as wp

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design, replace
from rvtool.contact.pin_closure import ElasticPinClosure
from rvtool.errors import RvtoolInputError
from rvtool.output_pins.evaluator import OutputPinEvaluator
from rvtool.output_pins.spec import OutputPinMechanism, PinMode
from rvtool.protocols.budget import stiffness_budget
from rvtool.solver.static import StaticSolver

R, R_PIN, R_HOLE = 0.05, 0.004, 0.00401       # pin circle, pin and hole radius [m]
CLEAR = R_HOLE - R_PIN
K = 2e8                                       # linear contact law [N/m] (exponent 1)
C = np.array([[2.0e-9, 1.2e-9], [1.2e-9, 3.0e-9]])   # station compliance [m/N], SPD


DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(
    wp.get_cuda_device_count() == 0, reason="no CUDA device"))]


def one_pin(backend="numpy", device="cpu"):
    """One pin on the flange (body 0) at (R, 0) in the holes of two wheels (bodies 1, 2); the
    station bodies 3, 4 are the pin at the wheel stations."""
    mech = OutputPinMechanism(pin_circle_radius=R, hole_circle_radius=R, n_pins=1, phase=0.0, pin_radius=R_PIN,
                              hole_radius=R_HOLE, coefficient=K, exponent=1.0, contact_length=0.01, n_slices=2,
                              wheel_midplanes=(-0.006, 0.006), mode=PinMode.PLAIN)
    inner = OutputPinEvaluator(mech, flange=0, wheels=(1, 2), n_bodies=5, backend=backend, device=device,
                               flange_bodies=[3, 4])
    return ElasticPinClosure(inner, n_bodies=3, carrier=0, station_compliance=C, station=[[0, 1]])


def lcp_closed_form(delta, sign):
    """Resultants F (2,) of two linear contacts (stiffness K, rigid-pin approaches delta) on one
    beam with compliance C, the forces on the pin along -sign_k x: the approaches lose the pin's
    deflection along their normals, d_k - sum_l C_kl (s_k s_l) F_l; the active set is the one of
    the four whose forces are non-negative and whose open contacts stay open."""
    Ct = C * np.outer(sign, sign)
    for act in itertools.product((0, 1), repeat=2):
        a = np.flatnonzero(act)
        F = np.zeros(2)
        if a.size:
            F[a] = np.linalg.solve(np.eye(a.size) / K + Ct[np.ix_(a, a)], delta[a])
        eff = delta - Ct @ F
        if np.all(F >= 0) and np.all(eff[np.array(act) == 0] <= 0):
            return F
    raise AssertionError("no active set")


@pytest.mark.parametrize("delta, sign", [
    ((2e-6, 2e-6), (1, 1)),          # symmetric loads, aligned: F = d / (1/K + C_00 + C_01) for C_00 = C_11
    ((2e-6, 1e-6), (1, 1)),          # unequal, aligned
    ((2e-6, 2e-6), (1, -1)),         # opposed wheels: n_0 . n_1 = -1 in Eq. (pin_compliance)
    ((-0.15e-6, 2e-6), (1, -1)),     # wheel 1 bends the pin into wheel 0's hole wall (pull-in)
])
def test_two_wheel_pin_against_closed_form(delta, sign):
    delta, sign = np.array(delta), np.array(sign)
    cl = one_pin()
    pose = np.zeros((3, 3))
    # wheel k's hole centre sits at R - sign_k (CLEAR + delta_k) on the x axis: pin-to-hole
    # distance CLEAR + delta_k (approach delta_k), force on the pin along -sign_k x, so the
    # closed form's normals have n_0 . n_1 = sign_0 sign_1
    for k in range(2):
        pose[1 + k, 0] = -sign[k] * (CLEAR + delta[k])
    ev = cl.evaluate(pose, 0 * pose)
    F = ev.obs[:, 0].reshape(2, 2).sum(axis=1)
    F_ref = lcp_closed_form(delta, sign)
    # the closure is solved to 1e-8 N; the pin's deflection along the normal is exact here (all on
    # the x axis), so only round-off remains: 1e-9 relative
    assert F == pytest.approx(F_ref, rel=1e-9, abs=1e-7)
    if delta[0] > 0 and delta[1] > 0 and sign[0] == sign[1]:
        assert F[0] + F[1] < K * delta.sum()           # the beam relieves both contacts
    if delta[0] < 0:
        assert F[0] > 0                                 # pulled into contact by the other wheel
    # equilibrium of the flange: it carries the contact forces of both stations
    assert ev.Q[0:2] == pytest.approx(-(ev.Q[3:5] + ev.Q[6:8]), abs=1e-9)


def test_symmetric_closed_form_explicitly():
    # Eq. (series_contact) for one pin, equal approaches and aligned normals:
    # F_k = d / (1/K + C_k0 + C_k1) only when both rows of C sum alike; with C symmetric the
    # 2x2 closed form is F = (I/K + C)^-1 d
    d = 2e-6
    cl = one_pin()
    pose = np.zeros((3, 3))
    pose[1:, 0] = -(CLEAR + d)
    F = cl.evaluate(pose, 0 * pose).obs[:, 0].reshape(2, 2).sum(axis=1)
    Ci = np.linalg.inv(np.eye(2) / K + C)
    assert F == pytest.approx(Ci @ [d, d], rel=1e-9)
    u = cl.deflections(pose)[0]
    # the station deflections are C times the forces on the pin (along -x)
    assert u[:, 0] == pytest.approx(-(C @ F), rel=1e-9)


def test_condensed_tangent_against_central_differences():
    cl = one_pin()
    pose = np.zeros((3, 3))
    pose[1] = (-(CLEAR + 2e-6), 0.4e-6, 1e-5)
    pose[2] = (-(CLEAR + 1e-6), -0.3e-6, -2e-5)
    pose[0, 2] = 3e-6
    ev = cl.evaluate(pose, 0 * pose)
    J = np.zeros((9, 9))
    h = 1e-10
    for i in range(9):
        pp, pm = pose.copy().ravel(), pose.copy().ravel()
        pp[i] += h
        pm[i] -= h
        J[:, i] = (cl.evaluate(pp.reshape(3, 3), 0 * pose).Q - cl.evaluate(pm.reshape(3, 3), 0 * pose).Q) / (2 * h)
    # central differences of a smooth branch: O(h^2) truncation plus round-off 1e-8 N / 1e-10 m
    # against entries of ~1e8 N/m: 1e-6 relative to the largest entry
    assert np.abs(J - ev.dQdq).max() < 1e-6 * np.abs(ev.dQdq).max()


def test_closure_input_errors():
    mech_inner = one_pin().inner
    with pytest.raises(RvtoolInputError, match="positive definite"):
        ElasticPinClosure(mech_inner, n_bodies=3, carrier=0, station_compliance=[[1e-9, 2e-9], [2e-9, 1e-9]],
                          station=[[0, 1]])
    with pytest.raises(RvtoolInputError, match="n_bodies"):
        ElasticPinClosure(mech_inner, n_bodies=2, carrier=0, station_compliance=C, station=[[0, 1]])


RING = {"model": "simply_supported", "ends": [-0.015, 0.015]}
OUT = {"model": "cantilever", "ends": [-0.012, 0.012]}


def test_budget_with_elastic_pins_closes():
    # RD-40 (lumped bearings) at 140 N m, both pin families elastic: every compliance is
    # allocated once, so the rows' normal stiffness and the beams carry the output compliance
    # up to the geometric stiffness of the loaded contacts and the regularization springs
    # (rigid pins: 1.4e-3; elastic pins: 9e-3 measured, the pins' contact geometry now moves with
    # the deflection); bound 3e-2. Before the per-pin closure it was -0.57.
    d = load_design(designs.path("rd40"))
    m = build(replace(d, pins={"support": RING}, output_pins={"support": OUT}), bearing_model="lumped")
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    b = stiffness_budget(m, q)
    s = b["shares"]
    assert sum(s.values()) == pytest.approx(1.0, abs=1e-12)
    assert abs(s["geometric_and_regularization"]) < 3e-2
    assert s["ring_pin_bending"] > 0.1 and s["output_pin_bending"] > 0.1
    for path in ("ring_pin_bending", "output_pin_bending"):
        # a beam in series with its contacts: stiffening it can only stiffen the output
        assert 0.0 < b["rigid_shares"][path] < 1.0
        # the beams' energy share (station deflections along the condensed mode) is the output
        # compliance's sensitivity to the beams' stiffness from the element's own condensed
        # tangent (Rayleigh: dC/dlambda = -u^T K_b u): an independent check of the decomposition;
        # measured to 2e-6, bound 1e-4 (the sensitivity's central-difference error, 1e-5)
        assert b["sensitivity_shares"][path] == pytest.approx(s[path], abs=1e-4)
    for fam in ("pins", "output_pins", "eccentric_bearings"):
        assert b["sensitivity_shares"][fam] == pytest.approx(s[fam], abs=1e-4)


@pytest.mark.parametrize("device", DEVICES)
def test_closure_on_the_warp_kernel_per_device(device):
    # the closure is NumPy around the family's kernel: the Warp kernel with per-row station bodies
    # (flange_bodies) against the NumPy reference, same closure; float64 kernels agree with the
    # reference to round-off, amplified by the Newton solve's conditioning (1 + K C ~ 2): 1e-9
    pose = np.zeros((3, 3))
    pose[1] = (-(CLEAR + 2e-6), 0.4e-6, 1e-5)
    pose[2] = (CLEAR + 1e-6, -0.3e-6, -2e-5)
    ref = one_pin("numpy").evaluate(pose, 0 * pose)
    ev = one_pin("warp", device).evaluate(pose, 0 * pose)
    assert ev.finite
    assert np.abs(ev.Q - ref.Q).max() < 1e-9 * np.abs(ref.Q).max()
    assert np.abs(ev.dQdq - ref.dQdq).max() < 1e-9 * np.abs(ref.dQdq).max()
