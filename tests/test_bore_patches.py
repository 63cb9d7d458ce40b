"""Compression-only bore patches of the elastic wheel (issue 30, ``wheels.structure.bore_ports``): the patch law
and its tangent, the patch ports against the parent FE, the key off bit-identical, bad input by key.

The law's tests use a synthetic stiffness (milliseconds); the wheel's use the coarse 8 mm mesh of
tests/test_wheel_body.py (one mesh, a few seconds)."""
import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.contact.bore_patches import patch_law, patch_matrix
from rvtool.errors import RvtoolInputError
from rvtool.structure.wheel_body import WheelBodySpec

COARSE = {"mesh_size": 0.008, "samples_per_tooth": 4, "layers": 1}


def synthetic(n_fixed=4, n_bores=2, n_patches=8, seed=3):
    """A symmetric positive definite row stiffness [N/m] of the order of a wheel's and the patches' map."""
    rng = np.random.default_rng(seed)
    n_r = n_fixed + n_bores * n_patches
    B = rng.standard_normal((n_r, n_r))
    K = 1e8 * (B @ B.T / n_r + np.eye(n_r))
    a = 2 * np.pi * np.arange(n_patches) / n_patches
    normals = [0.95 * np.column_stack([np.cos(a + 0.1 * b), np.sin(a + 0.1 * b)]) for b in range(n_bores)]
    return K, patch_matrix(n_fixed, normals), n_fixed


def test_patch_law_is_compression_only_and_complementary():
    """Patch forces p >= 0, gaps z >= 0, p . z = 0; the race's force is sum_k p_k n_k; a race pushed one way loads
    the patches on that side only (the other arc opens), and pulled back the other way loads the opposite arc."""
    K, P, nf = synthetic()
    u = np.zeros(P.shape[1])
    u[nf:nf + 2] = (1e-6, 0.0)                       # bore 0's race pushed along +x
    s, T, open_, p, z = patch_law(K, P, nf, u)
    assert p.min() >= 0 and z.min() >= 0
    assert abs(p @ z) <= 1e-12 * np.abs(p).max() * np.abs(z).max() * len(p)
    assert open_.any() and not open_.all()
    n0 = P[nf:nf + 8, nf:nf + 2]
    assert np.allclose(s[nf:nf + 2], n0.T @ p[:8], rtol=1e-9, atol=1e-9 * np.abs(s).max())
    loaded = np.flatnonzero(p[:8] > 1e-9 * p.max())
    assert np.all(n0[loaded, 0] > 0)                 # only the arc the race presses on carries load
    s2, _, open2, p2, _ = patch_law(K, P, nf, -u)
    assert np.all(n0[np.flatnonzero(p2[:8] > 1e-9 * p2.max()), 0] < 0)
    assert s[nf] > 0 and s2[nf] < 0


def test_patch_law_tangent_matches_central_differences():
    """ds/du = P^T K_S P against central differences of s at a generic state (the set of open patches unchanged
    over the step); the law is piecewise linear, so the match is to round-off (1e-7 relative)."""
    K, P, nf = synthetic()
    rng = np.random.default_rng(7)
    u = 1e-6 * rng.standard_normal(P.shape[1])
    s, T, open_, _, _ = patch_law(K, P, nf, u)
    assert open_.any()
    h = 1e-12
    J = np.column_stack([(patch_law(K, P, nf, u + h * e)[0] - patch_law(K, P, nf, u - h * e)[0]) / (2 * h)
                         for e in np.eye(len(u))])
    assert np.abs(J - T).max() <= 1e-7 * np.abs(T).max()
    assert np.allclose(T @ u, s, rtol=0, atol=1e-12 * np.abs(s).max())


def test_all_closed_at_zero_and_bad_shapes():
    """At u = 0 every patch counts as closed (the stiffest tangent: a Newton start sees every patch); shapes that
    do not agree are refused."""
    K, P, nf = synthetic()
    s, T, open_, p, z = patch_law(K, P, nf, np.zeros(P.shape[1]))
    assert not open_.any() and not s.any()
    assert np.allclose(T, P.T @ K @ P)
    with pytest.raises(RvtoolInputError):
        patch_law(K, P, nf, np.zeros(3))


@pytest.fixture(scope="module")
def rv40e():
    return rvtool.load_design(designs.path("rv40e"))


@pytest.fixture(scope="module")
def patched(rv40e):
    from rvtool.assembly.wheel_body import wheel_model
    # 2 profile ports per tooth (the fewest): the port compliance's cost is its columns, and the profile rows
    # are not what these tests check
    return wheel_model(rv40e.replace(wheels={"body": "ported", "structure": {**COARSE, "samples_per_tooth": 2,
                                                                            "bore_ports": 8}}), 0)


def test_patch_ports_spread_and_against_parent_fe(patched):
    """The patches read a uniform radial expansion of their bore as 1 and a translation t as n_k . t (n_k their
    mean outward normal, about 0.95 long for a hat over 2 pi / N either side); their compliance (3-2-1 support and
    projections) equals the parent's bordered inertia-relief solve to 1e-6 relative (the existing check)."""
    from rvtool.structure.static import InertiaReliefCompliance
    wb = patched
    rows = wb.rows("bore1_patches")
    assert len(rows) == 8 and rows.min() > max(wb.rows("bore2"))       # appended after every other row
    V = wb.fe.vertices[wb.fe.dof_vertex]            # the vertex of every dof
    c = np.array(wb.geometry.bores[1][:2])
    r = np.linalg.norm(V[:, :2] - c, axis=1)
    comp = wb.fe.dof_component
    radial = np.zeros(wb.fe.n_dofs)                  # the unit radial field about bore 1's centre
    for k in range(2):
        radial[comp == k] = (V[comp == k, k] - c[k]) / r[comp == k]
    assert np.allclose(wb.load_matrix[rows] @ radial, 1.0, atol=1e-9)
    n = wb.patch_normals(1)
    assert np.all((np.linalg.norm(n, axis=1) > 0.9) & (np.linalg.norm(n, axis=1) < 1.0))
    sub = np.concatenate([wb.rows("bore0"), rows])
    irc = InertiaReliefCompliance(wb.fe.elastic_stiffness, wb.fe.mass, wb.fe.rigid_body_modes())
    u, _ = irc.solve(wb.load_matrix[sub].T.toarray())
    C_ref = wb.measure_matrix[sub] @ u
    C_ref = 0.5 * (C_ref + C_ref.T)
    C = wb.static_compliance[np.ix_(sub, sub)]
    assert np.abs(C - C_ref).max() <= 1e-6 * np.abs(C_ref).max()


def test_key_off_is_the_mean_tie_bit_for_bit(rv40e, patched):
    """bore_ports = 0 (the default) builds no patch rows and no patch law; with patches the other rows' load and
    measure matrices are unchanged bit for bit (the patches only append rows)."""
    from rvtool.assembly.wheel_body import wheel_model
    assert WheelBodySpec().bore_ports == 0
    off = wheel_model(rv40e.replace(wheels={"body": "ported", "structure": {**COARSE, "samples_per_tooth": 2}}), 0)
    assert not any(g.endswith("_patches") for g in off.groups)
    n = off.load_matrix.shape[0]
    for a, b in ((off.load_matrix, patched.load_matrix), (off.measure_matrix, patched.measure_matrix)):
        d = (b[:n] - a)
        assert d.nnz == 0 or not d.data.any()
        assert np.array_equal(a.indices, b[:n].indices) and np.array_equal(a.data, b[:n].data)


@pytest.mark.parametrize("value", [3, 65, -1, 2.5, True, "8"])
def test_bad_bore_ports_names_the_key(rv40e, value):
    with pytest.raises(RvtoolInputError, match=r"wheels\.structure\.bore_ports = .*valid"):
        rv40e.replace(wheels={"body": "ported", "structure": {"bore_ports": value}})


def test_more_patches_than_the_bore_mesh_carries_is_refused(rv40e):
    from rvtool.assembly.wheel_body import wheel_model
    with pytest.raises(RvtoolInputError, match=r"wheels\.structure\.bore_ports = 64 .*mesh_size"):
        wheel_model(rv40e.replace(wheels={"body": "ported", "structure": {**COARSE, "bore_ports": 64}}), 0)


@pytest.mark.slow
@pytest.mark.timeout(1200)
def test_patched_closure_tangent_matches_central_differences(rv40e):
    """The wheels' closure with bore patches in the RV model at T_R: part of each bore's patches is open (the
    unloaded arc), and the condensed tangent (the patches' exact law, its pose term by central differences at the
    open set held) along random directions matches central differences of the forces to 1e-6 relative (measured
    1.4e-7 at a 1e-10 step, the mean tie's 1.2e-7: the contact points interpolate linearly between profile ports,
    so the step stays far below a port spacing). Marked slow: a static solve of rv40e with two FE wheels, 3.7 s
    with OPENBLAS_NUM_THREADS=1 but about 3 min on the loaded shared 2-core machine with OpenBLAS's own threads
    (oversubscribed: one 104x104 inverse took 0.18 s instead of 2.5 ms)."""
    from rvtool.contact.wheel_closure import WheelBodyClosure
    from rvtool.solver.static import StaticSolver
    d = rv40e.replace(wheels={"body": "ported", "structure": {**COARSE, "bore_ports": 8}})
    model = rvtool.build(d)
    model.set_output_torque(-np.sign(model.ratio) * d.rated_torque)
    q = StaticSolver(model).solve(0.0)
    el = model.elements["wheel_bodies"]
    ql = el.local(q)
    pose, vel = el.pose_velocity(ql, 0 * ql)
    ev = el.evaluator
    assert isinstance(ev, WheelBodyClosure) and ev.bore_ports == 8
    K = ev.evaluate(pose, vel).dQdq
    opened = [int(o.sum()) for o in ev.open_patches]
    assert all(0 < n < 3 * 8 for n in opened)
    rng = np.random.default_rng(3)
    step = 1e-10
    v = rng.standard_normal(pose.shape)
    v /= np.abs(v).max()
    fd = (ev.evaluate(pose + step * v, vel).Q - ev.evaluate(pose - step * v, vel).Q) / (2 * step)
    Kv = K @ v.ravel()
    assert np.abs(fd - Kv).max() <= 1e-6 * np.abs(Kv).max()


def test_flexible_wheels_refuse_bore_patches_by_key(rv40e):
    """The floating flexible wheels of dynamic runs keep mean-motion bore ports: bore_ports > 0 is refused there
    by key (before any mesh is built)."""
    from rvtool.assembly.rv.flexible_wheels import wheel_mesh
    d = rv40e.replace(wheels={"structure": {**COARSE, "bore_ports": 8}})
    with pytest.raises(RvtoolInputError, match=r"wheels\.structure\.bore_ports = 8 with wheels\.dynamics"):
        wheel_mesh(d, 0)


@pytest.mark.slow
@pytest.mark.timeout(1200)
def test_patched_wheels_nested_joint_equals_nested_solve(rv40e, monkeypatch):
    """Bore patches inside the nested members (crank bending > crank torsion > wheels): the joint network
    (WheelBodyClosure.station_forces with the patches' law, tangent and pose term) and the level-by-level nested
    solve reach the same state at T_R (1e-9 relative: both converge their stations to 1e-13 of the largest contact
    force; measured 2.8e-12), and the top tangent matches central differences (1e-6; measured 2.0e-7 joint,
    7.8e-8 nested). A wrong station law in either path would move the state by the wheels' share (~1e-1).
    Marked slow: two static solves of rv40e with FE wheels (4 s each with OPENBLAS_NUM_THREADS=1)."""
    from rvtool.solver.static import StaticSolver
    d = rv40e.replace(wheels={"body": "ported", "structure": {**COARSE, "bore_ports": 8}},
                      cranks={"shaft": {"model": "simply_supported", "torsion": "elastic"}})
    states = {}
    for mode in ("joint", "nested"):
        monkeypatch.setenv("RVTOOL_NESTED_SOLVE", mode)
        model = rvtool.build(d)
        assert model.series_paths == {"cranks": 0, "crank_torsion": 1, "wheel_bodies": 2}
        model.set_output_torque(-np.sign(model.ratio) * d.rated_torque)
        q = StaticSolver(model).solve(0.0)
        states[mode] = q
        el = model.elements["wheel_bodies"]
        ql = el.local(q)
        pose, vel = el.pose_velocity(ql, 0 * ql)
        ev = el.evaluator
        K = ev.evaluate(pose, vel).dQdq
        v = np.random.default_rng(5).standard_normal(pose.shape)
        v /= np.abs(v).max()
        step = 1e-10
        fd = (ev.evaluate(pose + step * v, vel).Q - ev.evaluate(pose - step * v, vel).Q) / (2 * step)
        Kv = K @ v.ravel()
        assert np.abs(fd - Kv).max() <= 1e-6 * np.abs(Kv).max(), mode
    a, b = states["joint"], states["nested"]
    assert np.abs(a - b).max() <= 1e-9 * np.abs(a).max()
