"""Lost motion through the free play: spring control against load control, the fallback
order of the variant protocol, snap-through detection and input errors (issue 8).

The variants are Monte Carlo samples of RD-40 (seed 2026, the case's regularization) chosen
for their behaviour, measured when the spring control was written: 1 and 3: load control
succeeds; 2 and 67: load control fails (no loaded start at +f; stall in the free play),
spring control succeeds; 0: load control stalls where the torque--angle curve folds, and
spring control at its default k_s meets the fold as a snap-through and passes it with a
stiffer spring (it failed before: the failed variant of `rvtool analyze rd40 --quick`)."""
import dataclasses
import os

import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError, SolverFailure
from rvtool.solver.static import StaticSolver
from rvtool.protocols.lost_motion import lost_motion
from rvtool.solver.spring_march import output_rotation_spring
from rvtool.solver.continuation import Continuation
from rvtool.variants.tolerances import load_tolerances, sample_variant
from rvtool.units import ARCMIN_PER_RAD
from rvtool.variants import VariantProtocol, variant_lost_motion

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DESIGNS = str(designs.HERE)
REG = (1.0e4, 100.0)
SEED = 2026


@pytest.fixture(scope="module")
def design():
    return load_design(os.path.join(DESIGNS, "rd40.toml"))


@pytest.fixture(scope="module")
def tol():
    # the variants chosen below for their edge cases were drawn before pin_circle_coaxiality_error joined the
    # file; that field is drawn last, so leaving it out draws them as they were (tests/test_cycloid_coaxiality.py)
    return dataclasses.replace(load_tolerances(os.path.join(DESIGNS, "rd40_tolerances.toml")),
                               pin_circle_coaxiality_error=None)


def _model(design, tol, k, reg=REG):
    d = sample_variant(tol, design, k, SEED).apply(design)
    return d, build(d, bearing_model="lumped", regularization=reg)


def _load_controlled(model, design, levels):
    cont = Continuation(model, input_angle=0.0, initial_torque=float(levels[0]))
    i = model.output_index
    return [cont.q[i]] + [cont.go_to(float(t))[i] for t in levels[1:]]


@pytest.mark.parametrize("k", [1, 3])
def test_spring_control_equals_load_control(design, tol, k):
    d, m = _model(design, tol, k)
    f = 0.03 * d.rated_torque
    ang = _load_controlled(m, d, VariantProtocol().lost_motion_torques(d))
    d, m = _model(design, tol, k)
    r = lost_motion(m, torque_level=f)
    # the two paths stop at different Newton iterates: agreement to the solver tolerance
    assert abs(r["theta_plus"] - ang[0]) < 1e-10
    assert abs(r["theta_minus"] - ang[-1]) < 1e-10
    assert r["lost_motion_rad"] * ARCMIN_PER_RAD == pytest.approx((ang[0] - ang[-1]) * ARCMIN_PER_RAD, abs=1e-6)
    assert r["lost_motion_rad"] > 0


def test_spring_states_are_load_controlled_equilibria(design, tol):
    """Where load control fails, the spring-controlled states at +-f are checked by the load
    problem itself: Newton under the applied torque +-f (spring back to the regularization)
    started from each state must stay there."""
    d, m = _model(design, tol, 2)
    f = 0.03 * d.rated_torque
    with pytest.raises(SolverFailure):
        _load_controlled(m, d, VariantProtocol().lost_motion_torques(d))
    d, m = _model(design, tol, 2)
    r = lost_motion(m, torque_level=f)
    assert r["start_torque"] > f          # the +f start itself is not found by load ramps
    s = StaticSolver(m)
    for q, t in ((r["q_plus"], f), (r["q_minus"], -f)):
        m.set_output_torque(t)
        ok, q2 = s.newton(q, ramp=False)
        assert ok
        assert np.max(np.abs(q2 - q)) < 1e-10
    assert 1.0 < r["lost_motion_rad"] * ARCMIN_PER_RAD < 10.0


def test_variant_lost_motion_fallback_order(design, tol):
    d, m = _model(design, tol, 1)
    assert variant_lost_motion(m, d)["method"] == "load"
    d, m = _model(design, tol, 67)
    r = variant_lost_motion(m, d)
    assert r["method"] == "spring" and np.isfinite(r["lost_motion_arcmin"])


def test_snap_through_is_passed_with_a_stiffer_spring(design, tol):
    """Variant 0 folds at -0.06 N m (the flange jumps by ~50 urad): with k_s = 1e5 the spring torque jumped
    across -f ("snap-through between equilibrium branches", and the variant failed). The march goes back to
    its last equilibrium and stiffens the spring. The lost motion is the one the device row Newton gets from
    loaded starts at +-f directly (no march through the free play; an independent path), within the device
    benchmark's 1e-6 arcmin (measured 2e-11), and the states are load-controlled equilibria."""
    from rvtool.batched.device_rows_lost_motion import device_row_lost_motion
    from rvtool.solver.device_rows import DeviceRowNewton
    from rvtool.solver.model_snapshot import build_snapshot
    d, m = _model(design, tol, 0)
    f = 0.03 * d.rated_torque
    r = lost_motion(m, torque_level=f)
    assert r["control_stiffness"] > 1e5                       # the march met the fold and stiffened
    direct = device_row_lost_motion(DeviceRowNewton([build_snapshot(d, {"bearing_model": "lumped",
                                                                        "regularization": REG})], device="cpu"), f)
    assert direct["stats"]["levels_path"] == "direct"
    assert abs(r["lost_motion_rad"] - direct["lost_motion_rad"][0]) * ARCMIN_PER_RAD <= 1e-6
    s = StaticSolver(m)
    for q, t in ((r["q_plus"], f), (r["q_minus"], -f)):
        m.set_output_torque(t)
        ok, q2 = s.newton(q, ramp=False)
        assert ok and np.max(np.abs(q2 - q)) < 1e-10
    m.set_output_torque(0.0)
    assert variant_lost_motion(m, d)["method"] == "spring"


def test_snap_through_fails_loudly_without_a_stiffer_spring(design, tol):
    d, m = _model(design, tol, 0)
    with pytest.raises(SolverFailure, match="jumps from .* without passing .*max_k_s = 100000 N m/rad"):
        lost_motion(m, torque_level=0.03 * d.rated_torque, max_k_s=1e5)
    # the model is left as built: flange spring and output torque restored
    obj, k_reg = output_rotation_spring(m)
    assert k_reg == REG[1] and m.mbs.GetObjectParameter(obj, "stiffness") == REG[1]
    with pytest.raises(RvtoolInputError, match="max_k_s"):
        lost_motion(m, torque_level=1.0, max_k_s=1e4)


def test_input_errors(design, tol):
    d, m = _model(design, tol, 1)
    with pytest.raises(RvtoolInputError, match="k_s"):
        lost_motion(m, torque_level=1.0, k_s=-1.0)
    with pytest.raises(RvtoolInputError, match="torque_level"):
        lost_motion(m, torque_level=0.0)
    d, m = _model(design, tol, 1, reg=(1e4, 0.0))
    with pytest.raises(RvtoolInputError, match="rotational regularization spring"):
        lost_motion(m, torque_level=1.0)


def test_batched_lost_motion_fallback_equals_per_variant(design, tol):
    from rvtool.variants.batched import batched_variant_figures
    from rvtool.variants import variant_figures
    p = VariantProtocol(n_te_points=5)
    vs = [sample_variant(tol, design, k, SEED) for k in (1, 67)]
    b = batched_variant_figures(design, vs, p, regularization=REG, lost_motion="batched")
    for v, rb in zip(vs, b):
        rv = variant_figures(design, v, p, regularization=REG)
        assert rb["status"] == "ok"
        assert rb["lost_motion_method"] == rv["lost_motion_method"]
        assert rb["lost_motion_arcmin"] == pytest.approx(rv["lost_motion_arcmin"], abs=1e-6)
    assert [r["lost_motion_method"] for r in b] == ["load", "spring"]
