"""warp_contacts.block_newton (the device row Newton's step kernel) against its NumPy reference
warp_contacts.block_newton_ref, per device (cuda skipped without a GPU), and the row Newton with
the step on the device against the host step."""
import numpy as np
import pytest
import warp as wp

from warp_contacts.block_newton import BlockNewtonStep
from warp_contacts.block_newton_ref import ACTIVE, CONVERGED, FAILED, WARM, StepModel, block_step

DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]


def _skip(device):
    if device != "cpu" and wp.get_cuda_device_count() == 0:
        pytest.skip("no CUDA device")


def _model(n, **kw):
    free = np.ones(n, bool)
    free[[0, 5]] = False                        # a drive and a lock: identity rows
    args = dict(spring_k=np.where(np.arange(n) % 4 == 1, 1e4, 0.0), free=free, rot=np.arange(n) % 3 == 2,
                out_index=n - 1, stiffening=np.array([1e3, 1e1, 1.0]), abs_tol=1e-6, max_iterations=4,
                max_step_translation=1e-4, max_step_rotation=1e-3, bound_translation=1e-2, bound_rotation=0.1,
                homotopy=True)
    args.update(kw)
    return StepModel(**args)


def _problem(B, n, seed=3):
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(B, n, n))
    K = -(M @ M.transpose(0, 2, 1) + n * np.eye(n)) * 1e7      # dQ/dq of a stable contact set [N/m]
    q_star = rng.normal(size=(B, n)) * 1e-5
    q = np.zeros((B, n))
    return K, q_star, q


def _device_step(m, Q, K, q, kin, tq, status, stage, iters, total, device):
    B, n = q.shape
    s = BlockNewtonStep(m, B, n, device)
    s.load(q=q, kin=kin, torque=tq, status=status, stage=stage, iters=iters, total=total)
    s.step(wp.array(Q, dtype=wp.float64, device=device), wp.array(K, dtype=wp.float64, device=device))
    return dict(zip(("q", "status", "stage", "iters", "total", "residual"),
                    s.read("q", "status", "stage", "iters", "total", "residual"))), int(s.active.numpy()[0])


@pytest.mark.parametrize("device", DEVICES)
def test_one_step_of_every_branch_equals_the_reference(device):
    _skip(device)
    B, n = 8, 12
    m = _model(n)
    K, q_star, q = _problem(B, n)
    kin = np.zeros((B, n))
    q[:, ~m.free] = 0.0
    q_star[0] *= 100.0                           # a long step: limited
    Q = np.einsum("bij,bj->bi", K, q - q_star)                  # linear contact law about q_star
    tq = np.linspace(-5.0, 5.0, B)
    status = np.full(B, ACTIVE, np.int32)
    stage = np.full(B, WARM, np.int32)
    iters = np.zeros(B, np.int32)
    total = np.zeros(B, np.int32)
    Q[1] *= 1e-9                                 # small step: not limited
    Q[2, 3] = np.nan                             # non-finite: warm start -> homotopy stage 0 from kin
    q[3] = kin[3] = q_star[3]                    # at rest ...
    Q[3] = 0.0
    tq[3] = 0.0                                  # ... converged: CONVERGED
    status[4] = CONVERGED                        # not active: untouched
    stage[5], iters[5] = 2, 3                    # last stage, converged next? no: iteration limit -> FAILED
    stage[6] = 0                                 # homotopy stage 0 (stiffening 1e3)
    K[7, :, 2] = 0.0
    K[7, 2, :] = 0.0                             # singular block (free coordinate 2 without stiffness) ...
    stage[7] = 1                                 # ... in a homotopy stage: FAILED
    q[6] = q_star[6]
    ref = dict(q=q.copy(), status=status.copy(), stage=stage.copy(), iters=iters.copy(), total=total.copy(),
               residual=np.zeros(B))
    block_step(Q, K, ref["q"], kin, tq, ref["status"], ref["stage"], ref["iters"], ref["total"], ref["residual"], m)
    dev, active = _device_step(m, Q, K, q, kin, tq, status, stage, iters, total, device)
    for k in ("status", "stage", "iters", "total"):
        np.testing.assert_array_equal(dev[k], ref[k], err_msg=k)
    # the dense solves differ in their last bits (LAPACK against the kernel's elimination)
    np.testing.assert_allclose(dev["q"], ref["q"], rtol=1e-9, atol=1e-18)
    ok = ~np.isnan(ref["residual"])
    np.testing.assert_allclose(dev["residual"][ok], ref["residual"][ok], rtol=1e-12)
    assert active == int(np.sum(ref["status"] == ACTIVE))
    # the branches were taken (a test that cannot pass by accident)
    assert ref["status"][3] == CONVERGED and ref["status"][5] == FAILED and ref["status"][7] == FAILED
    assert ref["stage"][2] == 0 and np.all(ref["q"][2] == kin[2]) and np.all(ref["q"][4] == q[4])
    assert np.max(np.abs(ref["q"][0] - q[0])[~m.rot]) == pytest.approx(m.max_step_translation, rel=1e-12) or \
        np.max(np.abs(ref["q"][0] - q[0])[m.rot]) == pytest.approx(m.max_step_rotation, rel=1e-12)


@pytest.mark.parametrize("device", DEVICES)
def test_the_loop_converges_to_the_linear_solution_as_the_reference(device):
    _skip(device)
    B, n = 5, 9
    m = _model(n, max_iterations=50, spring_k=np.zeros(n))
    K, q_star, q = _problem(B, n, seed=11)
    q_star[:, ~m.free] = 0.0
    kin = np.zeros((B, n))
    tq = np.zeros(B)
    st = [np.full(B, ACTIVE, np.int32), np.full(B, WARM, np.int32), np.zeros(B, np.int32), np.zeros(B, np.int32)]
    s = BlockNewtonStep(m, B, n, device)
    s.load(q=q, kin=kin, torque=tq, status=st[0], stage=st[1], iters=st[2], total=st[3])
    qr, res = q.copy(), np.zeros(B)
    Kd = wp.array(K, dtype=wp.float64, device=device)
    for _ in range(60):
        Q = np.einsum("bij,bj->bi", K, qr - q_star)
        if np.all(st[0] != ACTIVE):
            break
        block_step(Q, K, qr, kin, tq, *st, res, m)
    qd = q.copy()
    for _ in range(60):
        Q = np.einsum("bij,bj->bi", K, qd - q_star)
        s.step(wp.array(Q, dtype=wp.float64, device=device), Kd)
        qd, status = s.read("q", "status")
        if np.all(status != ACTIVE):
            break
    assert np.all(st[0] == CONVERGED) and np.all(status == CONVERGED)
    np.testing.assert_allclose(qd, q_star, rtol=0, atol=1e-14)       # 1e-6 N over ~1e8 N/m
    np.testing.assert_allclose(qd, qr, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(s.read("total")[0], st[3])


@pytest.fixture(scope="module")
def rv():
    from rvtool import build, designs, load_design
    return build(load_design(designs.path("rv40e")))


@pytest.mark.parametrize("device", DEVICES)
def test_row_newton_with_the_device_step_equals_the_host_step(rv, device):
    """rv40e's TE points and a lost-motion level: the same statuses, iterations and equilibria
    (1e-9 relative, the backends' equilibrium bound) with the step on the device and on the host."""
    _skip(device)
    from rvtool.solver.device_rows import DeviceRowNewton
    angles = np.linspace(0.0, 0.3, 5)
    tq = -np.sign(rv.ratio) * 412.0
    out = {}
    for on in (False, True):
        nw = DeviceRowNewton(rv, 5, device=device, device_step=on)
        out[on] = nw.solve(angles, np.full(5, tq))
    a, b = out[False], out[True]
    assert np.all(a.converged) and np.all(b.converged)
    np.testing.assert_array_equal(a.iterations, b.iterations)
    np.testing.assert_array_equal(a.stage, b.stage)
    scale = np.max(np.abs(a.q), axis=1, keepdims=True)
    assert np.max(np.abs(a.q - b.q) / scale) < 1e-9


@pytest.mark.parametrize("device", DEVICES)
def test_device_resident_loop_equals_the_host_staged_loop(rv, device):
    """device_sum + device_step: poses written on the device, families launched from them, the
    active count read every sync_every sweeps. Same statuses and iterations as the host-summed,
    host-staged loop, equilibria to 1e-9 relative; sync_every = 3 gives the same states (the extra
    sweeps leave finished copies as they are)."""
    _skip(device)
    from rvtool.solver.device_rows import DeviceRowNewton
    angles = np.linspace(0.0, 0.3, 4)
    tq = np.full(4, -np.sign(rv.ratio) * 412.0)
    ref = DeviceRowNewton(rv, 4, device=device, device_sum=False).solve(angles, tq)
    res = DeviceRowNewton(rv, 4, device=device, device_sum=True, sync_every=1)
    assert res.evaluator.resident
    a = res.solve(angles, tq)
    b = DeviceRowNewton(rv, 4, device=device, device_sum=True, sync_every=3).solve(angles, tq)
    assert np.all(ref.converged) and np.all(a.converged) and np.all(b.converged)
    np.testing.assert_array_equal(a.iterations, ref.iterations)
    scale = np.max(np.abs(ref.q), axis=1, keepdims=True)
    assert np.max(np.abs(a.q - ref.q) / scale) < 1e-9
    if device == "cpu":
        np.testing.assert_array_equal(b.q, a.q)
    else:                       # the device row sum's atomics add in any order on a GPU (last bits)
        assert np.max(np.abs(b.q - a.q) / scale) < 1e-9
    np.testing.assert_array_equal(b.iterations, a.iterations)
    assert a.sweeps <= b.sweeps <= a.sweeps + 2


def test_sync_every_is_checked(rv):
    from rvtool.errors import RvtoolInputError
    from rvtool.solver.device_rows import DeviceRowNewton
    with pytest.raises(RvtoolInputError, match="sync_every"):
        DeviceRowNewton(rv, 1, sync_every=0)


@pytest.mark.parametrize("device", DEVICES)
def test_device_resident_loop_with_plain_output_pins_equals_the_host_loop(device):
    """std_involute (internal involute pair, plain output pins, circle pairs): the output pins'
    kernel launches from device-written poses too (PlainPinCopies.launch_device_rows), so the loop
    is resident; same iterations as the host-summed loop, equilibria to 1e-9 relative."""
    _skip(device)
    import rvtool
    from rvtool.solver.device_rows import DeviceRowNewton
    m = rvtool.build(rvtool.load_design("std_involute"))
    angles = np.linspace(0.0, 0.3, 3)
    tq = np.full(3, -np.sign(m.ratio) * 0.5 * m.design.rated_torque)
    ref = DeviceRowNewton(m, 3, device=device, device_sum=False).solve(angles, tq)
    nw = DeviceRowNewton(m, 3, device=device, device_sum=True)
    assert nw.evaluator.resident and any(nw.evaluator.direct)
    a = nw.solve(angles, tq)
    assert np.all(ref.converged) and np.all(a.converged)
    np.testing.assert_array_equal(a.iterations, ref.iterations)
    assert np.max(np.abs(a.q - ref.q) / np.max(np.abs(ref.q), axis=1, keepdims=True)) < 1e-9
