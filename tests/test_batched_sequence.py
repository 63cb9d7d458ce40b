"""Angle-batched quasi-static TE (rvtool.batched.sequence) against the sequential path."""
import numpy as np
import pytest

from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.batched import build_batched
from rvtool.batched.sequence import batched_quasi_static_te
from rvtool.solver.backends.replica import segments
from rvtool.errors import RvtoolInputError
from rvtool.units import ARCSEC_PER_RAD
from rvtool.protocols.precision import quasi_static_te
from rvtool.variants import Variant
from rvtool import designs

DESIGN = load_design(designs.path("rd40"))
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
    assert np.max(np.abs(r["te"] - sequential["te"])) * ARCSEC_PER_RAD < 1e-6
    assert r["peak_loads"].keys() == sequential["peak_loads"].keys()
    for fam, f in sequential["peak_loads"].items():
        assert abs(r["peak_loads"][fam] - f) <= 1e-7 * max(f, 1.0), fam
    assert r["stats"]["points"] == len(ANGLES) and r["stats"]["failed_copies"] == 0


def test_default_tolerance_and_two_workers(sequential):
    """abs_tol 1e-4 N (the default) moves the TE by far less than 1e-4 arcsec; two worker
    processes give the points of one."""
    r = batched_quasi_static_te(DESIGN, torque=DESIGN.rated_torque, input_angles=ANGLES, copies=6, workers=2)
    assert r["workers"] == 2
    assert np.max(np.abs(r["te"] - sequential["te"])) * ARCSEC_PER_RAD < 1e-4
    one = batched_quasi_static_te(DESIGN, torque=DESIGN.rated_torque, input_angles=ANGLES, copies=6)
    # not bit-identical: a batch Newton iterates until all its copies converge, and the two
    # processes hold 3 copies each
    np.testing.assert_array_equal(r["theta_in"], one["theta_in"])
    assert np.max(np.abs(r["te"] - one["te"])) * ARCSEC_PER_RAD < 1e-4


def test_segments_cover_every_angle_once():
    idx, real = segments(10, 4)
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


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401
    wp.init()
    return [d.alias for d in wp.get_devices()]


@pytest.mark.parametrize("device", _devices())
def test_device_block_scatter_matches_the_csr_reference(device):
    """BlockScatter (atomics, one thread per row) against CopyBlockAssembler (CSR product) on
    the rows of all three families of a 3-copy batch; on a GPU also the whole static-mode
    evaluation (device scatter) against the CPU evaluation."""
    import warp as wp
    from warp_contacts.block_scatter import BlockScatter
    vs = [Variant(index=0), Variant(index=1, eccentricity_error=2e-6), Variant(index=2, pin_clearance=3e-6)]
    model = build_batched(DESIGN, vs)
    ev = model.evaluator
    ev.set_static(True)
    rng = np.random.default_rng(4)
    q = model.kinematic_vectors(0.7) + rng.normal(0, 1e-6, (3, 3 * model.nb))
    ref = model.elements.evaluate_state(q, np.zeros_like(q))
    pose = (model.elements.reference + q).reshape(-1, 3)
    Qp, Kp, _, _ = ev.pin_set.raw(pose, np.zeros_like(pose))
    ev._pose[:-1] = pose
    r = ev.output_kernel.evaluate(ev._pose)
    Qb, Kb, _, _, _ = ev.bearings.raw(pose, np.zeros_like(pose))
    rows = [(wp.array(np.ascontiguousarray(a), dtype=wp.float64, device=device),
             wp.array(np.ascontiguousarray(k), dtype=wp.float64, device=device))
            for a, k in ((Qp, Kp), (r["Q"], r["dQdq"]), (Qb, Kb))]
    sc = BlockScatter([(a.local, a.row_copy) for a in (ev.pin_asm, ev.op_asm, ev.brg_asm)], 3, ev.pin_asm.n,
                      wp.float64, device)
    Q, K = sc(rows)
    scale = np.max(np.abs(ref.dQdq))
    np.testing.assert_allclose(Q, ref.Q, rtol=0, atol=1e-12 * np.max(np.abs(ref.Q)))
    np.testing.assert_allclose(K, ref.dQdq, rtol=0, atol=1e-12 * scale)
    if not wp.get_device(device).is_cpu:
        gm = build_batched(DESIGN, vs, device=device)
        gm.evaluator.set_static(True)
        assert gm.evaluator.device_scatter
        g = gm.elements.evaluate_state(q, np.zeros_like(q))
        np.testing.assert_allclose(g.Q, ref.Q, rtol=0, atol=1e-9 * np.max(np.abs(ref.Q)))
        np.testing.assert_allclose(g.dQdq, ref.dQdq, rtol=0, atol=1e-9 * scale)
