"""Fused dynamic stepper (issue 19): the fused step kernel against its NumPy reference, the driven
RD-40 run against Exudyn's generalized-alpha (the oracle), isolation of a failing copy,
determinism and named setting errors. cpu always; cuda where present."""
import dataclasses

import numpy as np
import pytest
import warp as wp

from rvtool import designs
from rvtool.assembly.spec import load_design
from rvtool.solver.device_copies import copy_parameters
from rvtool.errors import RvtoolInputError
from rvtool.solver.device_dynamics import (DeviceDynamics, DeviceDynamicsSettings, check_supported,
                                           dynamic_te_fused, kinematic_velocities)
from rvtool.units import ARCSEC_PER_RAD
from rvtool.variants import Variant
from warp_contacts.fused_step_ref import (C_RECORDED, DONE, FAILED, H_OUTPUT, H_TORQUE, M_SPEED, N_COUNT,
                                          N_MOTION, ReferenceModel)

DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]
STEP = 2e-5
OMEGA = 1500 * np.pi / 30


def _skip_absent(device):
    wp.init()
    if device != "cpu" and wp.get_cuda_device_count() == 0:
        pytest.skip(f"{device} not present")


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("rd40"))


@pytest.fixture(scope="module")
def params(design):
    rng = np.random.default_rng(11)
    return copy_parameters(design, [Variant(), Variant(index=1, eccentricity_error=2e-6,
                                                       pin_centre_errors=rng.normal(0, 2e-6, (40, 2)))])


def _start(params, vi, angle=0.3, seed=5):
    """A loaded, moving state near the kinematic one: the flange turned against the wheels so
    that pins, output pins and bearings carry load, small random offsets, kinematic velocities."""
    q = params.kinematic(vi, [angle] * len(vi))
    for p, v in enumerate(vi):           # the offsets of a copy depend on its variant only
        q[p, params.free] += np.random.default_rng(seed + v).normal(0, 1e-6, params.free.sum())
    q[:, params.output_index] += 3e-4
    return q, kinematic_velocities(params, vi, angle, OMEGA)


def _settings(**kw):
    return DeviceDynamicsSettings(**{"step": STEP, "abs_tol": 1e-6, "rel_tol": 1e-8, **kw})


@pytest.mark.parametrize("device", DEVICES)
def test_fused_step_matches_reference(params, device):
    """One launch of one step per copy against fused_step_ref.ReferenceModel.advance (initial
    accelerations included). The two differ only in the order of the floating-point sums and
    in the dense solve (Gaussian elimination vs LAPACK): the converged states agree to the
    round-off of the contact stiffness times the coordinates, ~1e-16 relative per operation,
    amplified by the tangent's condition number (~1e6 for k_contact / k_soft): 1e-9 relative on
    the accelerations (the most sensitive: beta' ~ 1/h^2 times the position increment), and the
    same Newton iteration count."""
    _skip_absent(device)
    vi = [0, 1]
    st = _settings()
    motion = np.zeros((2, N_MOTION))
    motion[:, M_SPEED] = OMEGA
    dyn = DeviceDynamics(params, vi, torque=[140.0, 90.0], motion=motion, end_time=1.0, device=device, settings=st)
    q0, v0 = _start(params, vi)
    dyn.start(q0, v0)
    s0 = dyn.stepper.state()
    ref = ReferenceModel(**dyn.arrays)
    for p in range(2):
        a_ref = ref.initial_accelerations(p, s0["q"][p], s0["v"][p])
        np.testing.assert_allclose(s0["a"][p], a_ref, rtol=1e-9, atol=1e-9 * np.max(np.abs(a_ref)))
    hist, rec, status = dyn.stepper.advance(1)
    s1 = dyn.stepper.state()
    state = {k: s0[k].copy() for k in ("q", "v", "a", "abar", "t", "h", "status")}
    state["counters"] = np.zeros((2, N_COUNT), int)
    href = ref.advance(state, 1)
    assert np.all(rec == 1) and np.all(state["counters"][:, C_RECORDED] == 1)
    assert np.array_equal(s1["counters"][:, 2], state["counters"][:, 2])           # Newton iterations
    for k in ("q", "v", "a", "abar"):
        scale = np.max(np.abs(state[k]), axis=1, keepdims=True)
        np.testing.assert_allclose(s1[k], state[k], rtol=0, atol=1e-9 * np.max(scale), err_msg=k)
    np.testing.assert_allclose(hist[:, 0, H_TORQUE], href[:, 0, H_TORQUE], rtol=1e-8)
    np.testing.assert_allclose(hist[:, 0, H_OUTPUT], href[:, 0, H_OUTPUT], rtol=0, atol=1e-15)


def test_fused_run_matches_exudyn(design):
    """RD-40, lumped bearings, rated torque, 1500 rpm, 300 steps of 20 us: the fused stepper
    against Exudyn's generalized-alpha through the merged contact element (same start, same
    RunSpec). The integrators are the same (fused_step_ref), so the histories agree to the Newton
    tolerance: abs_tol 1e-6 N over the pin stiffness ~2.6e8 N/m is 4e-15 m of position, 8e-14 rad
    (1.6e-8 arcsec) of output angle at the 50 mm pin circle per step; 300 steps: 5e-6 arcsec."""
    from rvtool.assembly.cycloid import build
    from rvtool.protocols.precision import dynamic_te
    from rvtool.solver import RunSpec
    n = 300
    spec = RunSpec(end_time=n * STEP, step=STEP, abs_tol=1e-6, rel_tol=1e-8)
    fused = dynamic_te_fused(design, torque=design.rated_torque, speed_rpm=design.input_speed_rpm,
                             duration=n * STEP, settings=DeviceDynamicsSettings.from_run_spec(spec, steps_per_launch=64))
    exu = dynamic_te(build(design), torque=design.rated_torque, speed_rpm=design.input_speed_rpm, duration=n * STEP,
                     run_spec=spec)
    assert len(fused["t"]) == len(exu["t"]) == n + 1
    np.testing.assert_allclose(fused["t"], exu["t"], rtol=0, atol=1e-15)
    assert np.max(np.abs(fused["te"] - exu["te"])) * ARCSEC_PER_RAD < 5e-6
    assert fused["record"].newton_iterations == exu["record"].newton_iterations
    # the drive torque is the output torque over the ratio plus the inertia and mesh terms: within 5 %
    assert abs(np.mean(fused["torque_in"][1:]) - design.rated_torque / abs(design.ratio)) < 0.05 * design.rated_torque / abs(design.ratio)


def _run(params, vi, torque, device, **kw):
    motion = np.zeros((len(vi), N_MOTION))
    motion[:, M_SPEED] = OMEGA
    dyn = DeviceDynamics(params, vi, torque=torque, motion=motion, end_time=40 * STEP, device=device,
                         settings=_settings(steps_per_launch=16, min_step=STEP / 4, **kw))
    q0, v0 = _start(params, vi)
    dyn.start(q0, v0)
    return dyn.run()


@pytest.mark.parametrize("device", DEVICES)
def test_failing_copy_is_isolated_and_runs_are_deterministic(params, device):
    """A copy whose load is not finite is rejected, retried with halved steps down to min_step
    and FAILED; the run ends and the other copies' histories are bit-identical to a run without
    it. Two identical runs are bit-identical (fixed summation order, no atomics)."""
    _skip_absent(device)
    good = _run(params, [0, 1], [140.0, 90.0], device)
    mixed = _run(params, [0, 1, 1], [140.0, np.nan, 90.0], device)
    assert list(good.status) == [DONE, DONE]
    assert list(mixed.status) == [DONE, FAILED, DONE]
    assert mixed.rejected[1] == 3 and mixed.accepted[1] == 0       # h, h/2, h/4 = min_step
    for p_good, p_mixed in ((0, 0), (1, 2)):
        assert np.array_equal(good.theta_out[p_good], mixed.theta_out[p_mixed])
        assert np.array_equal(good.torque_in[p_good], mixed.torque_in[p_mixed], equal_nan=True)
    again = _run(params, [0, 1], [140.0, 90.0], device)
    for k in ("q", "v", "a", "abar", "t"):
        assert np.array_equal(good.state[k], again.state[k])


def test_fused_failure_is_loud(design, tmp_path):
    """The single-system run raises SolverFailure with the last accepted state saved (no silent
    hand-over to another solver): one Newton iteration cannot reach rel_tol 1e-12, and the
    minimum step is the step."""
    from rvtool.errors import SolverFailure
    with pytest.raises(SolverFailure, match="min_step") as err:
        dynamic_te_fused(design, torque=design.rated_torque, speed_rpm=1500.0, duration=4 * STEP,
                         settings=_settings(min_step=STEP, max_newton_iterations=1, rel_tol=1e-12, abs_tol=1e-12),
                         out_dir=str(tmp_path))
    saved = np.load(err.value.state_file)
    assert saved["time"] == 0.0 and np.all(np.isfinite(saved["q"]))


@pytest.mark.parametrize("kw, key", [({"step": -1e-5}, "device_dynamics.step"),
                                     ({"spectral_radius": 1.5}, "device_dynamics.spectral_radius"),
                                     ({"min_step": 1.0}, "device_dynamics.min_step"),
                                     ({"abs_tol": 0.0}, "device_dynamics.abs_tol"),
                                     ({"steps_per_launch": 0}, "device_dynamics.steps_per_launch"),
                                     ({"max_newton_iterations": 2.5}, "device_dynamics.max_newton_iterations")])
def test_bad_settings_named(kw, key):
    with pytest.raises(RvtoolInputError, match=key.replace(".", r"\.")):
        DeviceDynamicsSettings(**{"step": STEP, **kw})


def test_unsupported_models_named(params):
    from rvtool.solver import RunSpec
    from warp_contacts import cycloid_pins_ref as pref
    from warp_contacts.circle_pairs_ref import FRICTION_ANCHOR
    with pytest.raises(RvtoolInputError, match="newton_mode"):
        DeviceDynamicsSettings.from_run_spec(RunSpec(end_time=1e-3, step=STEP, newton_mode="modified"))
    pin_i = params.pin_i.copy()
    pin_i[:, :, pref.J_FRICTION] = FRICTION_ANCHOR
    with pytest.raises(RvtoolInputError, match="anchor"):
        check_supported(dataclasses.replace(params, pin_i=pin_i))
    with pytest.raises(RvtoolInputError, match="end_time"):
        DeviceDynamics(params, [0], torque=[1.0], motion=np.zeros((1, N_MOTION)), end_time=0.0, settings=_settings())


def test_row_function_kernels_bit_identical(params):
    """The kernels that are now thin wrappers over their row functions give the outputs of the
    kernels before the move, bit for bit (tests/golden/row_functions_rd40.npz: written by the
    pre-move kernels on these RD-40 rows and poses, Warp CPU, float64)."""
    from pathlib import Path

    from rvtool.output_pins.spec import PinMode
    from warp_contacts.circle_pairs import CirclePairKernel
    from warp_contacts.cycloid_pins import CycloidPinKernel
    from warp_contacts.output_pins import OutputPinKernel
    pr = copy_parameters(params.design, [Variant()])
    nb = pr.nb
    rng = np.random.default_rng(3)
    kin = pr.kinematic([0], [0.3])[0]
    pose = np.zeros((nb + 1, 3))
    pose[:nb] = (pr.reference[0] + kin.reshape(nb, 3)) + rng.normal(0, 2e-6, (nb, 3))
    pose[nb - 1, 2] += 4e-4          # the flange turned against the wheels: the output pins carry load
    vel = np.zeros((nb + 1, 3))
    vel[:nb] = rng.normal(0, 0.05, (nb, 3))
    out = {}
    for vt in (True, False):
        k = CycloidPinKernel(pr.pin_f[0], pr.pin_i[0], pr.tables, pr.window, nb, "float64", "cpu", analytic=pr.analytic)
        k.set_velocity_tangent(vt)
        for j, a in enumerate(k.evaluate(pose, vel)[:4]):
            if a is not None:
                out[f"pin{vt}_{j}"] = np.array(a)
    r = OutputPinKernel(pr.op_f, pr.op_i, pr.stations, nb + 1, PinMode.PLAIN.value, "float64", "cpu").evaluate(pose)
    for key in ("Q", "dQdq", "tilt_moments", "slices"):
        out["op_" + key] = np.array(r[key])
    nr = len(pr.brg_i)
    r = CirclePairKernel(pr.brg_f[0], pr.brg_i, nb, "float64", "cpu").evaluate(pose, vel, np.zeros(nr, np.int32),
                                                                              np.zeros((nr, 2)), np.zeros((nr, 2)))
    for j, a in enumerate(r[:4]):
        out[f"brg_{j}"] = np.array(a)
    golden = np.load(Path(__file__).parent / "golden" / "row_functions_rd40.npz")
    assert sorted(golden.files) == sorted(out)
    for k in golden.files:
        # bit-identical on the development machine (x86-64, Warp's bundled clang); the tolerance
        # only admits a different CPU's floating-point contraction (a few ulp of the row's scale),
        # far below any change a moved or edited statement would cause
        scale = max(float(np.max(np.abs(golden[k]))), 1e-300)
        assert np.allclose(out[k], golden[k], rtol=0.0, atol=1e-13 * scale), k
    assert np.max(np.abs(out["op_Q"])) > 100.0 and np.max(np.abs(out["pinTrue_0"])) > 100.0
