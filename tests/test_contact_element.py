"""Contact element: Warp kernel vs NumPy reference, analytic tangent vs central
differences, virtual-work identity, Exudyn callback conventions, history
ownership and input errors."""
import numpy as np
import pytest

exu = pytest.importorskip("exudyn")
from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D  # noqa: E402

from exudyn_user_elements.contact_element import ContactElement  # noqa: E402
from rvtool.contact.circle_set import (GROUND, CircleContact, CircleContactSet, FrictionLaw,  # noqa: E402
                                       FrictionModel, NormalLaw)
from rvtool.contact.evaluator import ContactSetEvaluator  # noqa: E402
from exudyn_user_elements.scenes import random_pair_scene  # noqa: E402
from rvtool.errors import RvtoolInputError  # noqa: E402


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401  (sets Warp's log level)
    wp.init()
    return [d.alias for d in wp.get_devices()]


def _committed_scene(seed, backend="warp", precision="float64", n_bodies=3, n_contacts=12, device="cpu"):
    """Scene whose anchor contacts have committed anchors, then a small perturbation
    so that the anchored contacts stick with a non-zero elastic displacement."""
    rng = np.random.default_rng(seed)
    cset, pose, vel = random_pair_scene(rng, n_bodies, n_contacts)
    ev = ContactSetEvaluator(cset, backend=backend, precision=precision, device=device)
    ev.commit(pose, vel)
    pose = pose + np.column_stack([rng.normal(0, 2e-8, (n_bodies, 2)), rng.normal(0, 2e-6, n_bodies)])
    return ev, pose, vel


def _fd_tangent(ev, pose, vel):
    """Central differences of the assembled forces; steps balance truncation and
    round-off for indentations of ~2e-5 m (1e-9 m, 1e-7 rad, 1e-6 m/s, 1e-4 rad/s)."""
    n = 3 * ev.n_bodies
    Kq, Kv = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        b, c = divmod(j, 3)
        for K, arr, h in ((Kq, "q", 1e-9 if c < 2 else 1e-7), (Kv, "v", 1e-6 if c < 2 else 1e-4)):
            P, V = pose.copy(), vel.copy()
            (P if arr == "q" else V)[b, c] += h
            qp = ev.evaluate(P, V).Q
            P, V = pose.copy(), vel.copy()
            (P if arr == "q" else V)[b, c] -= h
            qm = ev.evaluate(P, V).Q
            K[:, j] = (qp - qm) / (2 * h)
    return Kq, Kv


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tangent_matches_central_differences(seed):
    ev, pose, vel = _committed_scene(seed)
    e = ev.evaluate(pose, vel)
    Kq, Kv = _fd_tangent(ev, pose, vel)
    # relative Frobenius error < 1e-6 (issue criterion); the FD error itself is ~1e-8
    assert np.linalg.norm(e.dQdq - Kq) / np.linalg.norm(Kq) < 1e-6
    assert np.linalg.norm(e.dQdv - Kv) / np.linalg.norm(Kv) < 1e-6


def test_tangent_in_slip_and_regularized_friction():
    """Anchors displaced far enough to slip: the slip branch of the tangent is checked too."""
    rng = np.random.default_rng(5)
    cset, pose, vel = random_pair_scene(rng, 3, 12)
    ev = ContactSetEvaluator(cset)
    ev.commit(pose, vel)
    pose = pose + np.column_stack([rng.normal(0, 2e-6, (3, 2)), rng.normal(0, 1e-4, 3)])
    e = ev.evaluate(pose, vel)
    Kq, Kv = _fd_tangent(ev, pose, vel)
    assert np.linalg.norm(e.dQdq - Kq) / np.linalg.norm(Kq) < 1e-6
    assert np.linalg.norm(e.dQdv - Kv) / np.linalg.norm(Kv) < 1e-6


@pytest.mark.parametrize("device", _devices())
@pytest.mark.parametrize("precision,tol", [("float64", 1e-12), ("float32", 5e-3)])
def test_warp_matches_numpy_reference(precision, tol, device):
    """float32: positions ~2e-2 m carry ~2e-9 m rounding against ~2e-5 m indentation,
    so forces agree to ~1e-4 relative (p <= 1.5); 5e-3 leaves margin for the tangent.
    float64: the same arithmetic in another order, ~1e-15; 1e-12 allows for
    fused multiply-add on GPUs."""
    ev_w, pose, vel = _committed_scene(3, backend="warp", precision=precision, device=device)
    ev_n, _, _ = _committed_scene(3, backend="numpy")
    a, b = ev_w.evaluate(pose, vel), ev_n.evaluate(pose, vel)
    for x, y in ((a.Q, b.Q), (a.dQdq, b.dQdq), (a.dQdv, b.dQdv)):
        assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y))


def test_virtual_work_identity():
    """v^T Q = v_rel^T f (Eq. (contact_mapping)): contact power equals generalized power."""
    rng = np.random.default_rng(7)
    cset, pose, vel = random_pair_scene(rng, 3, 9, friction=True)
    ev = ContactSetEvaluator(cset, backend="numpy")
    ev.commit(pose, vel)
    Qc, _, _, obs, _ = ev.raw(pose, vel)
    # generalized power: per contact, the two body velocity triples times Q
    ia, ib = ev.iparams[:, 0], ev.iparams[:, 1]
    V = np.vstack([vel, np.zeros(3)])
    p_gen = np.sum(Qc[:, :3] * V[ia], axis=1) + np.sum(Qc[:, 3:] * V[ib], axis=1)
    # contact power recomputed independently from the material velocities of the points where
    # each force acts: normal force at the circle centres, friction at the contact points
    from warp_contacts import circle_pairs_ref as R
    fp = ev.fparams
    P = np.vstack([pose, np.zeros(3)])
    def vpoint(body, local_vec):
        th = P[body, 2]
        r = np.column_stack([np.cos(th) * local_vec[:, 0] - np.sin(th) * local_vec[:, 1],
                             np.sin(th) * local_vec[:, 0] + np.cos(th) * local_vec[:, 1]])
        return V[body, :2] + V[body, 2:3] * np.column_stack([-r[:, 1], r[:, 0]]), P[body, :2] + r
    va, ca = vpoint(ia, fp[:, R.P_XI_A:R.P_XI_A + 2])
    vb, cb = vpoint(ib, fp[:, R.P_XI_B:R.P_XI_B + 2])
    n = obs[:, R.O_NX:R.O_NY + 1]
    s = np.where(ev.iparams[:, 2] != 0, -1.0, 1.0)
    fn = (-s * obs[:, R.O_FN])[:, None] * n
    ft = np.stack([Qc[:, 0] - fn[:, 0], Qc[:, 1] - fn[:, 1]], axis=1)
    p_normal = np.sum((va - vb) * fn, axis=1)
    # friction acts along t at points whose relative material velocity has tangential part v_t
    t = np.column_stack([-n[:, 1], n[:, 0]])
    reg = ev.iparams[:, 3] == FrictionModel.REGULARIZED
    p_fric = np.where(reg, np.sum(ft * t, axis=1) * obs[:, R.O_VT], 0.0)
    np.testing.assert_allclose(p_gen[reg], (p_normal + p_fric)[reg], rtol=1e-10, atol=1e-12)
    none = ev.iparams[:, 3] == FrictionModel.NONE
    np.testing.assert_allclose(p_gen[none], p_normal[none], rtol=1e-10, atol=1e-12)
    # regularized friction dissipates
    assert np.all(p_fric[reg] <= 1e-15)


def _three_body_mbs(cset):
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = []
    for i in range(cset.n_bodies):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0, 0, 0]))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=1.0, inertia=1e-3))
        nodes.append(n)
    return SC, mbs, nodes


def test_exudyn_callbacks_use_exudyn_jacobian_convention():
    rng = np.random.default_rng(11)
    cset, pose, vel = random_pair_scene(rng, 3, 6)
    SC, mbs, nodes = _three_body_mbs(cset)
    el = ContactElement(mbs, nodes, cset)
    mbs.Assemble()
    q, v = pose.ravel(), vel.ravel()
    Q = el.force_callback(mbs, 0.0, el.object_number, q, v)
    J = el.jacobian_callback(mbs, 0.0, el.object_number, q, v, 2.0, 3.0)
    ev = el.evaluate(0.0, q, v)
    np.testing.assert_allclose(J, -(2.0 * ev.dQdq + 3.0 * ev.dQdv))
    assert el.n_evaluations == 1, "the Jacobian at the residual's state must reuse the cached launch"
    np.testing.assert_allclose(Q, ev.Q)


def test_trial_evaluations_do_not_change_committed_history():
    ev, pose, vel = _committed_scene(4)
    before = ev.history.copy()
    for _ in range(5):
        ev.evaluate(pose + 1e-6, vel)
    np.testing.assert_array_equal(before.anchor_a, ev.history.anchor_a)
    np.testing.assert_array_equal(before.active, ev.history.active)


def test_bad_inputs_name_the_parameter():
    law = NormalLaw(law="point", stiffness=1e9)
    with pytest.raises(RvtoolInputError, match="stiffness"):
        NormalLaw(law="point", stiffness=-1.0)
    with pytest.raises(RvtoolInputError, match="law"):
        NormalLaw(law="hertzish", stiffness=1.0)
    with pytest.raises(RvtoolInputError, match="centre_a"):
        CircleContact(body_a=0, body_b=GROUND, centre_a=(np.nan, 0), centre_b=(0, 0), radius_a=1e-3,
                      radius_b=2e-3, normal=law)
    with pytest.raises(RvtoolInputError, match="body_b"):
        CircleContactSet(name="s", n_bodies=1, contacts=(CircleContact(
            body_a=0, body_b=3, centre_a=(0, 0), centre_b=(0, 0), radius_a=1e-3, radius_b=2e-3, normal=law),))
    with pytest.raises(RvtoolInputError, match="friction model"):
        FrictionLaw(model=7)
    with pytest.raises(RvtoolInputError, match="backend"):
        ContactSetEvaluator(CircleContactSet(name="s", n_bodies=1, contacts=(CircleContact(
            body_a=0, body_b=GROUND, centre_a=(0, 0), centre_b=(0, 0), radius_a=1e-3, radius_b=2e-3, normal=law),)),
            backend="cuda-magic")
    cset = CircleContactSet(name="s", n_bodies=2, contacts=(CircleContact(
        body_a=0, body_b=1, centre_a=(0, 0), centre_b=(0, 0), radius_a=1e-3, radius_b=2e-3, normal=law),))
    SC, mbs, nodes = _three_body_mbs(cset)
    with pytest.raises(RvtoolInputError, match="nodes"):
        ContactElement(mbs, nodes[:1], cset)
    with pytest.raises(RvtoolInputError, match="contact_set must be a CircleContactSet or a contact evaluator"):
        ContactElement(mbs, nodes, "involute-gearz")  # unknown contact family
    ev = ContactSetEvaluator(cset, backend="numpy")
    with pytest.raises(RvtoolInputError, match=r"pose must have shape \(2, 3\)"):
        ev.evaluate(np.zeros((3, 3)), np.zeros((2, 3)))
    with pytest.raises(RvtoolInputError, match="pose contains non-finite"):
        ev.evaluate(np.array([[0, 0, 0], [np.nan, 0, 0]]), np.zeros((2, 3)))


def test_auto_device_rule():
    """"auto" uses the GPU only for sets above the measured crossover, and the CPU without one."""
    import warp as wp
    from warp_contacts.precision import AUTO_CUDA_MIN_CONTACTS, resolve_device
    has_cuda = any(d.is_cuda for d in wp.get_devices())
    assert resolve_device("auto", 10) == "cpu"
    big = resolve_device("auto", AUTO_CUDA_MIN_CONTACTS)
    assert big.startswith("cuda") if has_cuda else big == "cpu"
    with pytest.raises(RvtoolInputError, match="device"):
        resolve_device("tpu:0")
