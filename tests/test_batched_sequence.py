"""Angle-batched quasi-static TE (rvtool.batched.sequence) against the sequential path."""
import numpy as np
import pytest

from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.batched import build_batched
from rvtool.batched.sequence import _segments, batched_quasi_static_te
from rvtool.errors import RvtoolInputError
from rvtool.protocols.precision import ARCSEC, quasi_static_te
from rvtool.variants import Variant

DESIGN = load_design("cases/designs/rd40.toml")
# 1.5 mesh cycles at 40 points per cycle: segments cross contact activations
ANGLES = np.arange(60) * (2 * np.pi / 40) / 40


@pytest.fixture(scope="module")
def sequential():
    m = build(DESIGN)
    return quasi_static_te(m, torque=DESIGN.rated_torque, input_angles=ANGLES)


@pytest.mark.parametrize("copies,predictor", [(7, "secant"), (4, "constant")])
def test_equals_the_sequential_path(sequential, copies, predictor):
    """Same residual, same tolerance (1e-6 N): every point is the same equilibrium, whatever
    segment it sits in and however its warm start was predicted."""
    r = batched_quasi_static_te(DESIGN, torque=DESIGN.rated_torque, input_angles=ANGLES, copies=copies,
                                predictor=predictor, abs_tol=1e-6)
    np.testing.assert_array_equal(r["theta_in"], sequential["theta_in"])
    assert np.max(np.abs(r["te"] - sequential["te"])) * ARCSEC < 1e-6
    assert r["peak_loads"].keys() == sequential["peak_loads"].keys()
    for fam, f in sequential["peak_loads"].items():
        assert abs(r["peak_loads"][fam] - f) <= 1e-7 * max(f, 1.0), fam
    assert r["stats"]["points"] == len(ANGLES) and r["stats"]["failed_copies"] == 0


def test_default_tolerance_and_two_workers(sequential):
    """abs_tol 1e-4 N (the default) moves the TE by far less than 1e-4 arcsec; two worker
    processes give the points of one."""
    r = batched_quasi_static_te(DESIGN, torque=DESIGN.rated_torque, input_angles=ANGLES, copies=6, workers=2)
    assert r["workers"] == 2
    assert np.max(np.abs(r["te"] - sequential["te"])) * ARCSEC < 1e-4
    one = batched_quasi_static_te(DESIGN, torque=DESIGN.rated_torque, input_angles=ANGLES, copies=6)
    # not bit-identical: a batch Newton iterates until all its copies converge, and the two
    # processes hold 3 copies each
    np.testing.assert_array_equal(r["theta_in"], one["theta_in"])
    assert np.max(np.abs(r["te"] - one["te"])) * ARCSEC < 1e-4


def test_segments_cover_every_angle_once():
    idx, real = _segments(10, 4)
    assert idx.shape == (4, 3)
    assert sorted(idx[real].tolist()) == list(range(10))
    assert np.all(idx[~real] == 9)


def test_bad_input_names_the_parameter():
    for kw, name in (({"copies": 0}, "copies"), ({"copies": 61}, "copies"), ({"workers": 0}, "workers"),
                     ({"predictor": "quadratic"}, "predictor"), ({"abs_tol": -1.0}, "abs_tol")):
        with pytest.raises(RvtoolInputError, match=name):
            batched_quasi_static_te(DESIGN, torque=1.0, input_angles=ANGLES, **kw)
    with pytest.raises(RvtoolInputError, match="input_angles"):
        batched_quasi_static_te(DESIGN, torque=1.0, input_angles=[0.0, np.nan])


def test_static_mode_skips_only_the_velocity_tangent():
    """The cycloid-pin kernel without velocity seeds returns the same forces and position
    tangent; asking a static-mode evaluation for dQ/dv fails loudly instead of returning zeros."""
    model = build_batched(DESIGN, [Variant(index=0), Variant(index=1, eccentricity_error=3e-6)])
    ev = model.evaluator
    rng = np.random.default_rng(2)
    q = model.kinematic_vectors(0.2) + rng.normal(0, 1e-6, (2, 3 * model.nb))
    v = rng.normal(0, 1e-2, q.shape)
    full = model.elements.evaluate_state(q, v)
    Qf, Kf, Df = full.Q.copy(), full.dQdq.copy(), full.dQdv.copy()
    ev.set_static(True)
    st = model.elements.evaluate_state(q, v)
    np.testing.assert_array_equal(st.Q, Qf)
    np.testing.assert_array_equal(st.dQdq, Kf)
    assert np.any(Df)
    with pytest.raises(RuntimeError, match="static mode"):
        st.dQdv
    ev.set_static(False)
    np.testing.assert_array_equal(model.elements.evaluate_state(q, v).dQdv, Df)
