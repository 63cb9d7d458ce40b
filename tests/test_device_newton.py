"""Device Newton (issue 19): vectorized copy parameters, the Newton step kernel against its NumPy
reference, equilibria and TE against Exudyn's StaticSolver (the oracle), isolation of failing
copies, determinism. cpu always; cuda where present."""
import numpy as np
import pytest
import warp as wp

from rvtool import designs
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.variants import Variant

REG = (1e4, 100.0)          # the Monte Carlo's regularization


def _devices():
    wp.init()
    return ["cpu"] + (["cuda:0"] if wp.get_cuda_device_count() > 0 else [])


DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]


def _skip_absent(device):
    if device not in _devices():
        pytest.skip(f"{device} not present")


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("rd40"))


@pytest.fixture(scope="module")
def variants():
    rng = np.random.default_rng(7)
    return [Variant(index=i, eccentricity_error=rng.normal(0, 1e-6), pin_centre_errors=rng.normal(0, 2e-6, (40, 2)),
                    pin_radius_error=rng.normal(0, 1e-6), pin_clearance=abs(rng.normal(0, 2e-6)),
                    bearing_clearance=None if i % 2 else 6e-6) for i in range(3)]


@pytest.fixture(scope="module")
def params(design, variants):
    from rvtool.solver.device_copies import copy_parameters
    return copy_parameters(design, [Variant()] + variants, regularization=REG)


def _torque(design):
    return -np.sign(design.ratio) * design.rated_torque


def test_copy_parameters_equal_the_builder(design, variants, params):
    """The vectorized rows are bit-identical to the builder's own pieces applied per variant
    (Variant.apply -> copy_contacts), apart from the profile-table index (one shared table)."""
    from warp_contacts import cycloid_pins_ref as pref

    from rvtool.assembly.cycloid import lumped_bearing_contacts
    from rvtool.assembly.copies import copy_contacts
    from rvtool.contact.circle_set import CircleContactSet
    from rvtool.contact.cycloid_set import CycloidPinSet
    nb = params.nb
    for k, v in enumerate([Variant()] + variants):
        d = v.apply(design)
        meshes, _, (op_f, op_i, _) = copy_contacts(d, 0)
        ps = CycloidPinSet(meshes, nb, samples_per_tooth=d.wheels.samples_per_tooth, backend="numpy")
        cols = [c for c in range(pref.N_FLOAT)]
        assert np.array_equal(params.pin_f[k][:, cols], ps.fparams[:, cols]), k
        keep = [pref.J_BODY_A, pref.J_BODY_B, pref.J_FRICTION]
        assert np.array_equal(params.pin_i[k][:, keep], ps.iparams[:, keep])
        bf, bi = CircleContactSet(name="b", n_bodies=nb, contacts=tuple(lumped_bearing_contacts(d))).packed()
        assert np.array_equal(params.brg_f[k], bf) and np.array_equal(params.brg_i, bi)
        assert np.array_equal(params.op_f, op_f) and np.array_equal(params.op_i, op_i)
        from rvtool.assembly.cycloid import kinematic_poses
        assert np.array_equal(params.reference[k], kinematic_poses(d, [0.0])[0])     # wheels on their journals
        kin = kinematic_poses(d, [0.7])[0]
        assert np.array_equal(params.kinematic([k], [0.7])[0], (kin - params.reference[k]).ravel())


def test_copy_parameters_reject_bad_variants(design):
    from rvtool.solver.device_copies import copy_parameters
    with pytest.raises(RvtoolInputError, match="eccentricity_error"):
        copy_parameters(design, [Variant(eccentricity_error=-1.0)])
    with pytest.raises(RvtoolInputError, match="pin_centre_errors"):
        copy_parameters(design, [Variant(pin_centre_errors=np.zeros((3, 2)))])


def test_settings_reject_bad_values():
    from rvtool.solver.device_newton import DeviceNewtonSettings
    with pytest.raises(RvtoolInputError, match="device_newton.abs_tol"):
        DeviceNewtonSettings(abs_tol=-1.0)
    with pytest.raises(RvtoolInputError, match="device_newton.stiffening"):
        DeviceNewtonSettings(stiffening=(10.0, 2.0))


def _synthetic_rows(params, B, rng):
    """Random contact rows with the real local maps: forces of ~100 N and tangents that keep
    A = k I - K well conditioned (K = -(M M^T) - 1e6 I per row)."""
    rows = []
    for loc in (params.loc_pin, params.loc_op, params.loc_brg):
        R, k = loc.shape
        Q = rng.normal(0, 100.0, (B * R, k))
        M = rng.normal(0, 3e2, (B * R, k, k))
        K = -(M @ M.transpose(0, 2, 1)) - 1e6 * np.eye(k)
        rows.append((Q, K, loc))
    return rows


@pytest.mark.parametrize("device", DEVICES)
def test_step_kernel_matches_reference(params, device):
    """One Newton step of the Warp kernel against batched_newton_ref on copies in every branch:
    ordinary step, converged (tiny residual), NaN rows (warm start -> homotopy restart), last
    homotopy stage failing (-> FAILED), intermediate stage converging (-> next stage), inactive.
    Tolerance 1e-12 relative: the kernel's elimination and LAPACK's differ in rounding only."""
    _skip_absent(device)
    from warp_contacts import batched_newton_ref as ref
    from warp_contacts.batched_newton import kernels
    rng = np.random.default_rng(3)
    B, n = 7, params.n
    rows = _synthetic_rows(params, B, rng)
    kin = rng.normal(0, 1e-5, (B, n))
    q = kin + rng.normal(0, 1e-6, (B, n))
    spring_k = np.broadcast_to(params.spring_k, (B, n)).copy()
    torque = np.full(B, 100.0)
    status = np.zeros(B, np.int32)
    stage = np.array([-1, -1, -1, 3, 1, -1, -1], np.int32)
    iters = np.array([0, 0, 0, 29, 2, 0, 0], np.int32)
    status[6] = ref.CONVERGED
    # copy 1: residual below tolerance (forces balance the springs and the torque exactly)
    for Q, K, loc in rows:
        R = loc.shape[0]
        Q[R:2 * R] = 0.0
        Q[2 * R:3 * R][0, 0] = np.nan               # copy 2: non-finite row
    q[1] = kin[1]
    torque[1] = 0.0
    rows[0][0][4 * rows[0][2].shape[0]:5 * rows[0][2].shape[0]] = 0.0    # copy 4: small residual as well
    rows[1][0][4 * rows[1][2].shape[0]:5 * rows[1][2].shape[0]] = 0.0
    rows[2][0][4 * rows[2][2].shape[0]:5 * rows[2][2].shape[0]] = 0.0
    q[4] = kin[4]
    torque[4] = 0.0
    kw = dict(stiffening=(1e6, 1e4, 1e2, 1.0), abs_tol=1e-6, max_iterations=30, max_step_translation=1e-4,
              max_step_rotation=4e-3, bound_translation=5e-4, bound_rotation=2e-2, homotopy=True)
    qr, sr, gr, ir, tr = q.copy(), status.copy(), stage.copy(), iters.copy(), np.zeros(B, np.int32)
    norms = ref.newton_step(rows, qr, kin, spring_k, params.free, torque, params.output_index, sr, gr, ir, tr, **kw)
    f64 = wp.float64
    arr = lambda x, dt=f64: wp.array(np.ascontiguousarray(x), dtype=dt, device=device)
    scatter, step = kernels(f64)[:2]
    qd, sd, gd, idd, td = arr(q), arr(status, wp.int32), arr(stage, wp.int32), arr(iters, wp.int32), wp.zeros(B, dtype=wp.int32, device=device)
    res = wp.zeros(B, dtype=f64, device=device)
    active = wp.zeros(1, dtype=wp.int32, device=device)
    wp.launch(step, dim=B, device=device, inputs=[
        arr(params.loc_pin, wp.int32), arr(params.loc_op, wp.int32), arr(params.loc_brg, wp.int32), arr(kin),
        arr(spring_k), arr(params.free.astype(np.int32), wp.int32), arr(torque), params.output_index,
        arr(np.array(kw["stiffening"])), 1e-6, 30, 1e-4, 4e-3, 5e-4, 2e-2, 1,
        arr(rows[0][0]), arr(rows[0][1]), arr(rows[1][0]), arr(rows[1][1]), arr(rows[2][0]), arr(rows[2][1])],
        outputs=[qd, sd, gd, idd, td, res, wp.zeros((B, n), dtype=f64, device=device),
                 wp.zeros((B, n, n), dtype=f64, device=device), wp.zeros((B, n), dtype=f64, device=device), active])
    assert sr.tolist() == sd.numpy().tolist()
    assert gr.tolist() == gd.numpy().tolist()
    assert ir.tolist() == idd.numpy().tolist()
    assert tr.tolist() == td.numpy().tolist()
    # the branches this test is about (so that it cannot pass vacuously)
    assert sr[6] == ref.CONVERGED and tr[6] == 0                     # inactive: untouched
    assert sr[1] == ref.CONVERGED                                    # converged warm start
    assert sr[2] == ref.ACTIVE and gr[2] == 0 and np.array_equal(qr[2], kin[2])   # NaN -> homotopy from kin
    assert sr[3] == ref.FAILED                                       # last stage out of iterations
    assert sr[4] == ref.ACTIVE and gr[4] == 2 and ir[4] == 0         # intermediate stage converged
    assert int(active.numpy()[0]) == int(np.sum(sr == ref.ACTIVE))
    qk = qd.numpy()
    step_size = np.max(np.abs(qr - q), axis=1)
    ok = np.isfinite(norms)
    assert np.allclose(res.numpy()[ok], norms[ok], rtol=1e-12, atol=0)
    for p in range(B):
        assert np.max(np.abs(qk[p] - qr[p])) <= 1e-12 * max(step_size[p], 1e-30), p


def _oracle(design, variant, angles):
    """StaticSolver equilibria (local copy coordinates) at the angles, each from the kinematic
    state (homotopy ladder), and the TE of the sequential warm-started path."""
    from rvtool.assembly.cycloid import build
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.solver.static import StaticSolver
    d = variant.apply(design)
    m = build(d, regularization=REG)
    idx = np.concatenate([np.asarray(m.mbs.systemData.GetNodeLTGODE2(n), int) for n in m.nodes])
    r = quasi_static_te(m, torque=d.rated_torque, input_angles=angles, solver=StaticSolver(m))
    assert np.array_equal(r["theta_in"], angles)
    # the oracle's own error is |residual| / stiffness of the softest direction (~4e7 N/m):
    # 2.4e-14 m at its default 1e-6 N, 2.5e-9 of the deviations; 1e-8 N puts it below 1e-10
    s = StaticSolver(m, abs_tol=1e-8)
    m.set_output_torque(_torque(d))
    qs = np.array([s.solve(a)[idx] for a in angles])
    return qs, r["te"]


@pytest.mark.parametrize("device", DEVICES)
def test_equilibria_and_te_match_static_solver(design, variants, params, device):
    """Device Newton from the kinematic state and device_te (nominal warm starts) against
    Exudyn's StaticSolver: equilibria to 1e-9 relative (translations and rotations each
    relative to the copy's largest elastic deviation of that kind; the device Newton applies
    one more Newton step after |residual| <= 1e-6 N, so its error is quadratically small), TE
    to 1e-6 arcsec against the sequential path at its default tolerance."""
    _skip_absent(device)
    from rvtool.batched.device_te import device_te
    from rvtool.solver.device_newton import CONVERGED, DeviceNewton
    from rvtool.units import ARCSEC_PER_RAD
    angles = np.array([0.0, 1.3, 4.9])
    V, A = 2, len(angles)
    vi = 1 + np.repeat(np.arange(V), A)
    aa = np.tile(angles, V)
    dn = DeviceNewton(params, device=device)
    r = dn.solve(vi, aa, np.full(V * A, _torque(design)), params.kinematic(vi, aa))
    assert np.all(r.status == CONVERGED)
    te = device_te(design, variants[:V], angles, regularization=REG, device=device)
    assert te.stats["fallback_copies"] == 0 and te.status == ["ok"] * V
    rot = np.arange(params.n) % 3 == 2
    for c in range(V):
        qs, te_ref = _oracle(design, variants[c], angles)
        for k in range(A):
            p = c * A + k
            dev = qs[k] - params.kinematic(vi[p:p + 1], aa[p:p + 1])[0]
            err = np.abs(r.q[p] - qs[k])
            assert err[~rot].max() <= 1e-9 * np.abs(dev[~rot]).max(), (c, k)
            assert err[rot].max() <= 1e-9 * np.abs(dev[rot]).max(), (c, k)
        assert np.max(np.abs(te.te[c] - te_ref)) * ARCSEC_PER_RAD <= 1e-6


def test_failing_copy_does_not_change_the_others(design, params):
    """A copy that cannot converge (a torque far beyond any plausible equilibrium) fails through
    the whole homotopy within its iteration budget, the loop ends, and every other copy's
    state is bit-identical to a run without it."""
    from rvtool.solver.device_newton import CONVERGED, FAILED, DeviceNewton, DeviceNewtonSettings
    dn = DeviceNewton(params, settings=DeviceNewtonSettings(max_iterations=15))
    vi = np.array([1, 2, 3, 1])
    aa = np.array([0.3, 0.3, 2.0, 5.0])
    T = np.full(4, _torque(design))
    ok = dn.solve(vi, aa, T, params.kinematic(vi, aa))
    T_bad = T.copy()
    T_bad[1] = 1e7
    bad = dn.solve(vi, aa, T_bad, params.kinematic(vi, aa))
    assert bad.status[1] == FAILED and np.all(np.delete(bad.status, 1) == CONVERGED)
    assert bad.iterations.max() <= 15 * 5 + 1                     # warm start + 4 homotopy stages at most
    assert np.array_equal(np.delete(bad.q, 1, axis=0), np.delete(ok.q, 1, axis=0))


def test_determinism(design, params):
    """Two runs give bit-identical states (the per-copy sums have a fixed order)."""
    from rvtool.solver.device_newton import DeviceNewton
    dn = DeviceNewton(params)
    vi = np.array([1, 2, 3, 0, 2])
    aa = np.array([0.1, 0.9, 3.3, 7.0, 11.0])
    T = np.full(5, _torque(design))
    a = dn.solve(vi, aa, T, params.kinematic(vi, aa))
    b = dn.solve(vi, aa, T, params.kinematic(vi, aa))
    assert np.array_equal(a.q, b.q) and np.array_equal(a.iterations, b.iterations)


def test_failed_copies_go_to_the_exudyn_path(design, variants):
    """With a device budget too small to converge (1 iteration, no homotopy) every pair falls
    back to the per-variant StaticSolver: counted, and the TE equals the oracle's."""
    from rvtool.batched.device_te import device_te
    from rvtool.solver.device_newton import DeviceNewtonSettings
    from rvtool.units import ARCSEC_PER_RAD
    angles = np.array([0.0, 2.2])
    r = device_te(design, variants[:1], angles, regularization=REG,
                  settings=DeviceNewtonSettings(max_iterations=1, homotopy=False))
    assert r.stats["fallback_copies"] == 2 and r.stats["failed_copies"] == 0 and r.status == ["ok"]
    _, te_ref = _oracle(design, variants[0], angles)
    assert np.max(np.abs(r.te[0] - te_ref)) * ARCSEC_PER_RAD <= 1e-6


@pytest.mark.parametrize("device", DEVICES)
def test_gather_kernels_match_reference(params, device):
    """The device-side row refill equals its NumPy reference exactly (pure copies and integer
    index arithmetic): float rows by variant, and body columns made global per copy with the
    ground row last."""
    _skip_absent(device)
    from warp_contacts import batched_newton_ref as ref
    from warp_contacts import cycloid_pins_ref as pref
    from warp_contacts.batched_newton import kernels
    gather_rows, gather_bodies = kernels(wp.float64)[3:]
    vi = np.array([2, 0, 3, 3, 1], np.int32)
    P, R = len(vi), params.pin_f.shape[1]
    out_f = wp.zeros((P * R, pref.N_FLOAT), dtype=wp.float64, device=device)
    wp.launch(gather_rows, dim=(P, R), inputs=[wp.array(params.pin_f, dtype=wp.float64, device=device),
                                              wp.array(vi, dtype=wp.int32, device=device)], outputs=[out_f],
              device=device)
    assert np.array_equal(out_f.numpy(), ref.gather_rows(params.pin_f, vi))
    out_i = wp.zeros((P * R, pref.N_INT), dtype=wp.int32, device=device)
    cols = [pref.J_BODY_A, pref.J_BODY_B]
    wp.launch(gather_bodies, dim=(P, R), inputs=[wp.array(params.pin_i, dtype=wp.int32, device=device),
                                                wp.array(np.array(cols, np.int32), dtype=wp.int32, device=device),
                                                params.nb, P * params.nb, wp.array(vi, dtype=wp.int32, device=device)],
              outputs=[out_i], device=device)
    expected = ref.gather_bodies(params.pin_i, vi, cols, params.nb, P * params.nb)
    assert np.array_equal(out_i.numpy(), expected)
    assert expected[:, pref.J_BODY_B].max() == P * params.nb          # the pins sit on the ground row
    assert set(expected[R:2 * R, pref.J_BODY_A]) == {params.nb + 1, params.nb + 2}   # copy 1's wheels
