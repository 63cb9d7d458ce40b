"""The elastic cycloid wheel body (issue 30): rigid default bit-identical, port compliance against the parent FE,
mesh convergence, the station compliance of the closure, the switch in the RV model, bad input by key.

Coarse meshes throughout (6-8 mm, 4 ports per tooth): the machine is shared."""
import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

import rvtool
from rvtool import designs
from rvtool.errors import RvtoolInputError
from rvtool.solver.static import StaticSolver

COARSE = {"mesh_size": 0.008, "samples_per_tooth": 4, "layers": 1}


@pytest.fixture(scope="module")
def rv40e():
    return rvtool.load_design(designs.path("rv40e"))


@pytest.fixture(scope="module")
def coarse_wheel(rv40e):
    from rvtool.assembly.wheel_body import wheel_model
    return wheel_model(rv40e.replace(wheels={"body": "ported", "structure": COARSE}), 0)


def rated_state(design):
    model = rvtool.build(design)
    model.set_output_torque(-np.sign(model.ratio) * design.rated_torque)
    return model, StaticSolver(model).solve(0.0)


def test_rigid_is_bit_identical_and_builds_no_wheel(rv40e):
    """wheels.body = 'rigid' with a [wheels.structure] table is today's model: same state bit for bit, no
    wheel element."""
    m0, q0 = rated_state(rv40e)
    d1 = rv40e.replace(wheels={"body": "rigid", "structure": {"mesh_size": 0.002}})
    m1, q1 = rated_state(d1)
    assert np.array_equal(q0, q1)
    assert "wheel_bodies" not in m1.elements and set(m1.elements) == set(m0.elements)


def test_port_compliance_matches_parent_bordered_solve(coarse_wheel):
    """The wheel's port compliance (3-2-1 support and projections) equals the parent's bordered inertia-relief
    solve (rvtool.structure.static.InertiaReliefCompliance, a different factorization of the same K, M) to 1e-6
    relative, and it is symmetric."""
    from rvtool.structure.static import InertiaReliefCompliance
    wb = coarse_wheel
    rows = np.concatenate([wb.rows("profile")[:12], wb.rows("bore0"), wb.rows("bore2")])
    irc = InertiaReliefCompliance(wb.fe.elastic_stiffness, wb.fe.mass, wb.fe.rigid_body_modes())
    u, _ = irc.solve(wb.load_matrix[rows].T.toarray())
    C_ref = wb.measure_matrix[rows] @ u
    C_ref = 0.5 * (C_ref + C_ref.T)
    C = wb.static_compliance[np.ix_(rows, rows)]
    assert np.abs(C - C_ref).max() <= 1e-6 * np.abs(C_ref).max()
    assert np.array_equal(wb.static_compliance, wb.static_compliance.T)


def test_ports_are_spread_and_work_conjugate(coarse_wheel):
    """Every port's weights sum to one per component (a uniform translation is read exactly); a profile port's
    patch runs through the whole width and, where the mesh has flank vertices between two samples, spreads over
    them (the hat between the neighbouring samples)."""
    wb = coarse_wheel
    P = wb.load_matrix
    n = wb.fe.n_dofs
    for c in range(2):
        t = np.zeros(n)
        t[wb.fe.dof_component == c] = 1.0
        read = P @ t
        assert np.allclose(read[c::2], 1.0, atol=1e-12) and np.allclose(read[1 - c::2], 0.0, atol=1e-12)
    nnz = np.diff(P.indptr)[wb.rows("profile")]
    levels = wb.spec.layers + 1
    assert nnz.min() >= levels and nnz.max() > levels


def test_mesh_convergence_trend(rv40e):
    """The wheel's compliance under a fixed balanced load (a torque carried from four profile ports to the bores)
    over three meshes: first-order tetrahedra are too stiff, so the compliance grows with refinement, and the
    change shrinks. Meshes of 5, 3.5 and 2.5 mm: coarser ones (7-10 mm, larger than the web between the bores
    and the tooth root) are not yet in the asymptotic range (measured: 5.62e-5, 5.61e-5, 5.52e-5 m/N at 10, 7,
    5 mm, then 5.69e-5, 5.74e-5)."""
    from rvtool.assembly.wheel_body import wheel_geometry
    from rvtool.structure.wheel_body import WheelBodySpec, inertia_relief_solve, wheel_body
    out = []
    for h, layers in ((0.005, 3), (0.0035, 4), (0.0025, 6)):
        spec = WheelBodySpec(mesh_size=h, layers=layers, samples_per_tooth=4)
        d = rv40e.replace(wheels={"body": "ported"})
        wb = wheel_body(wheel_geometry(d, 0, spec), spec, rv40e.material)
        N = wb.n_profile_ports
        f = np.zeros(wb.load_matrix.shape[0])
        for i in (0, N // 4, N // 2, 3 * N // 4):
            p = wb.profile_points[i]
            t = np.array([-p[1], p[0]]) / np.linalg.norm(p)
            f[wb.rows("profile")[2 * i:2 * i + 2]] = 100.0 * t
        T = 0.0
        for i in (0, N // 4, N // 2, 3 * N // 4):
            p, fi = wb.profile_points[i], f[wb.rows("profile")[2 * i:2 * i + 2]]
            T += p[0] * fi[1] - p[1] * fi[0]
        bores = [np.array(b[:2]) for b in wb.geometry.bores]
        for k, b in enumerate(bores):        # each bore takes T / (n r) tangentially, against the ports
            f[wb.rows(f"bore{k}")] = -T / (len(bores) * b @ b) * np.array([-b[1], b[0]])
        u = inertia_relief_solve(wb.fe, wb.load_matrix.T @ f)
        out.append(float(f @ (wb.measure_matrix @ u)))
    c1, c2, c3 = out
    assert c1 < c2 < c3
    assert abs(c3 - c2) < abs(c2 - c1)


def test_station_compliance_balanced_response(rv40e, coarse_wheel):
    """The closure's station compliance answers a balanced station load exactly as S R W C W^T R^T S (its
    rigid-motion term acts on unbalanced loads only) and is positive definite."""
    from rvtool.contact.wheel_closure import WheelBodyClosure
    d = rv40e.replace(wheels={"body": "ported", "structure": COARSE})
    model = rvtool.build(d)
    closure = model.elements["wheel_bodies"].evaluator
    assert isinstance(closure, WheelBodyClosure)
    pose = np.asarray(model.reference, float)
    C = closure.station_matrix(0, pose)
    assert np.linalg.eigvalsh(C).min() > 0
    zb, nb = closure.n_ring_pins, closure.n_bores
    wc = pose[model.layout.wheel(0), :2]
    pts = np.vstack([closure.pin_centres - wc, [b[:2] for b in closure.bodies[0].geometry.bores]])
    G = np.zeros((2 * len(pts), 3))
    G[0::2, 0] = G[1::2, 1] = 1.0
    G[0::2, 2], G[1::2, 2] = -pts[:, 1], pts[:, 0]
    S = np.ones(2 * len(pts))
    S[:2 * zb] = -1.0
    rng = np.random.default_rng(1)
    Q = rng.standard_normal(2 * (zb + nb))
    B = (S[:, None] * G)
    Q -= B @ np.linalg.lstsq(B, Q, rcond=None)[0]          # balanced: G^T S Q = 0
    from rvtool.structure.wheel_body import profile_interpolation
    wb = closure.bodies[0]
    Wp, _ = profile_interpolation(wb, closure.pin_centres - wc)
    W = np.zeros((2 * (zb + nb), wb.static_compliance.shape[0]))
    W[:2 * zb, wb.rows("profile")] = -Wp
    for k in range(nb):
        W[2 * zb + 2 * k + np.arange(2), wb.rows(f"bore{k}")] = 1.0
    ref = W @ wb.static_compliance @ W.T @ Q
    assert np.allclose(C @ Q, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_ported_wheels_soften_the_torque_path(rv40e):
    """The switch in the RV model: at T_R the ported wheels lower the output stiffness, the wheels' energy share
    agrees with their switch-on share within 0.05 (compliance_budget's SHARE_TOL) and the budget sums to one with a
    small residual."""
    from rvtool.protocols.budget import stiffness_budget
    m0, q0 = rated_state(rv40e)
    b0 = stiffness_budget(m0, q0)
    m1, q1 = rated_state(rv40e.replace(wheels={"body": "ported", "structure": COARSE}))
    b1 = stiffness_budget(m1, q1)
    K0, K1 = b0["K_t_Nm_per_arcmin"], b1["K_t_Nm_per_arcmin"]
    share = 1.0 - K1 / K0
    assert 0.02 < share < 0.4
    assert abs(b1["shares"]["wheel_bodies"] - share) < 0.05
    assert abs(b1["shares"]["geometric_and_regularization"]) < 0.01


@pytest.mark.parametrize("change, key", [
    ({"wheels": {"body": "elastic"}}, "wheels.body"),
    ({"wheels": {"structure": {"layers": 0}}}, "wheels.structure.layers"),
    ({"wheels": {"structure": {"mesh_size": -1.0}}}, "wheels.structure.mesh_size"),
    ({"wheels": {"structure": {"pillar_holes": {"count": 3, "radius": 0.008, "circle_radius": 0.036}}}},
     "wheels.structure.pillar_holes"),
    ({"wheels": {"structure": {"port_depth": 0.02}}}, "wheels.structure.port_depth"),
])
def test_bad_input_names_the_key(rv40e, change, key):
    from rvtool.assembly.wheel_body import wheel_geometry
    with pytest.raises(RvtoolInputError, match=key.replace(".", r"\.")):
        wheel_geometry(rv40e.replace(**change), 0)


def test_unsupported_combination_named(rv40e):
    d = rv40e.replace(wheels={"body": "ported", "structure": COARSE}, bodies={"wheel_coordinates": "spatial"})
    with pytest.raises(RvtoolInputError, match=r"wheels\.body = 'ported' with bodies\.wheel_coordinates"):
        rvtool.build(d)


def test_device_backend_refuses_ported_wheels_by_name(rv40e):
    from rvtool.solver.replica import replica_reasons
    m, _ = rated_state(rv40e.replace(wheels={"body": "ported", "structure": COARSE}))
    reasons = replica_reasons(m)
    assert any("wheels.body = 'ported'" in r for r in reasons)
    assert not replica_reasons(rvtool.build(rv40e))
