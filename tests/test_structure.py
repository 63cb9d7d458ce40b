"""Structural operators at contact ports (Section "Structural operators, contact ports, and coupled
deformation"), on small annulus meshes: full-basis identities, symmetry and definiteness, the runtime
map T_e, inertia relief, port condensation, grounding errors, delayed offsets and the Exudyn paths.

Tolerances: symmetric eigen-solves and factorizations of the parents here have backward errors of
order n eps ||A||, which become relative errors of order eps * cond in compliances; tests use
``ROUNDOFF * cond`` with ROUNDOFF = 1e3 eps (n up to ~1e3 coordinates, growth below n).
"""
import math

import numpy as np
import pytest
import scipy.linalg as sla

from rvtool.errors import RvtoolInputError
from rvtool.structure import (AnnularHousingSpec, DelayedOffsetFeedback, ElasticMaterial, InertiaReliefCompliance,
                              NodalPort, OffsetFeedbackSpec, PortReductionSpec, RayleighDamping, SupportedCompliance,
                              annular_housing, condense_ports, craig_bampton, expanded_map, fe_model_from_geometry,
                              floating_basis, parent_modes, reduce_ports, reduce_tangent, trace_consistency)
from rvtool.structure.response import modal_port_frf_matrix, parent_port_frf_matrix
from rvtool.structure.trace_check import N_RIGID, radial_traces

ROUNDOFF = 1e3 * np.finfo(float).eps
SMALL = AnnularHousingSpec(mesh_size=0.02, n_ports=8, n_mounts=6)
N_FIXED = 10


@pytest.fixture(scope="module")
def small():
    model = annular_housing(SMALL)
    cb = craig_bampton(model, n_modes=N_FIXED)
    return model, cb, parent_modes(cb)


@pytest.fixture(scope="module")
def free_model():
    """The same annulus without supports (a floating body)."""
    return annular_housing(AnnularHousingSpec(mesh_size=0.02, n_ports=8, n_mounts=0))


def _cond(modes):
    return modes.omega2[-1] / modes.omega2[0]


# -- model ------------------------------------------------------------------------------------------

def test_parent_model_mass_ports_and_rigid_kernel(small, free_model):
    model, _, _ = small
    # total mass of the faceted annulus: rigid translation through M equals rho * volume of the mesh
    R = model.rigid_body_modes()
    X = model.vertices[model.tetrahedra]
    vol = np.abs(np.einsum("ij,ij->i", X[:, 1] - X[:, 0], np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]))).sum() / 6
    for c in range(3):
        assert R[:, c] @ model.mass @ R[:, c] == pytest.approx(SMALL.material.density * vol, rel=1e-12)
    # rigid motions are in the kernel of the elastic stiffness, not of the mounted one
    Ke = free_model.elastic_stiffness
    assert np.abs(Ke @ free_model.rigid_body_modes()).max() < 1e-9 * abs(Ke).max()
    assert model.port_matrix.shape == (3 * SMALL.n_ports, model.n_dofs)
    assert len({p.vertex for p in model.ports}) == SMALL.n_ports
    # ports snap to vertices on the inner surface
    r = np.hypot(*model.vertices[[p.vertex for p in model.ports], :2].T)
    assert np.allclose(r, SMALL.inner_radius, atol=1e-9)


def test_direction_ports_project_the_cartesian_compliance():
    # a normal port samples n^T u at its vertex: its compliance is n^T C_xyz n, through the CB parent too
    spec = AnnularHousingSpec(mesh_size=0.02, n_ports=4, n_mounts=6)
    ports = tuple(NodalPort(name=p.name, point=p.point, directions=((math.cos(t), math.sin(t), 0.0),))
                  for p, t in zip(spec.ports(), spec.port_angles()))
    m = fe_model_from_geometry(spec.geometry(), mesh_size=spec.mesh_size, material=spec.material, ports=ports,
                               supports=spec.supports(), damping=spec.damping)
    assert m.port_matrix.shape == (4, m.n_dofs)
    cart = np.zeros((12, m.n_dofs))
    for g, p in enumerate(m.ports):
        cart[3 * g:3 * g + 3, m.vertex_dofs(p.vertex)] = np.eye(3)
    sc = SupportedCompliance(m.stiffness, m.port_matrix)
    N = sla.block_diag(*[p.directions for p in m.ports])
    C_xyz = sc.compliance(cart)
    assert np.allclose(sc.compliance(), N @ C_xyz @ N.T, rtol=1e-12, atol=0)
    modes = parent_modes(craig_bampton(m, n_modes=4))   # rtol: round-off times cond(K_r) ~ 1e6 (see module)
    assert np.allclose(modes.reference_compliance, N @ C_xyz @ N.T, rtol=1e-9, atol=0)


def test_rayleigh_calibration_reaches_zeta_at_both_frequencies():
    d = RayleighDamping(damping_ratio=0.02, calibration_frequencies=(500.0, 5000.0))
    a, b = d.coefficients()
    for f in d.calibration_frequencies:
        w = 2 * math.pi * f
        assert a / (2 * w) + b * w / 2 == pytest.approx(0.02, rel=1e-14)


def test_colliding_ports_are_rejected():
    spec = AnnularHousingSpec(mesh_size=0.02, n_ports=8, n_mounts=6)
    ports = spec.ports() + (NodalPort(name="twin", point=spec.ports()[0].point),)
    with pytest.raises(RvtoolInputError, match="both map to mesh vertex"):
        fe_model_from_geometry(spec.geometry(), mesh_size=0.02, material=spec.material, ports=ports,
                               supports=spec.supports())


def test_invalid_inputs_name_parameter_and_range():
    with pytest.raises(RvtoolInputError, match="poisson_ratio"):
        ElasticMaterial(youngs_modulus=1e9, poisson_ratio=0.5, density=1.0)
    with pytest.raises(RvtoolInputError, match="calibration_frequencies"):
        RayleighDamping(damping_ratio=0.02, calibration_frequencies=(5000.0, 500.0))
    with pytest.raises(RvtoolInputError, match="n_modes"):
        PortReductionSpec(n_modes=-1)
    with pytest.raises(RvtoolInputError, match="relaxation"):
        OffsetFeedbackSpec(relaxation=0.0)


# -- Craig-Bampton and port reduction ----------------------------------------------------------------

def test_symmetry_and_positive_definiteness(small):
    model, cb, modes = small
    for A in (model.stiffness, model.mass, model.damping):
        assert abs(A - A.T).max() <= 1e-14 * abs(A).max()
    for A in (cb.stiffness, cb.mass, cb.damping):
        assert np.array_equal(A, A.T)
    assert np.linalg.eigvalsh(cb.mass)[0] > 0 and np.linalg.eigvalsh(cb.stiffness)[0] > 0
    assert cb.grounded()
    assert modes.omega2[0] > 0
    # the fixed-interface block of K_r is diag(Omega_i^2) and decoupled from the boundary (Eq. cb_reduction)
    nb = cb.n_boundary
    lam = (2 * np.pi * cb.fixed_interface_hz) ** 2
    assert np.allclose(np.diag(cb.stiffness)[nb:], lam, rtol=1e-10)
    assert np.abs(cb.stiffness[:nb, nb:]).max() < 1e-8 * np.abs(cb.stiffness).max()


def test_cb_static_compliance_equals_parent_back_substitution(small):
    # boundary coordinates stay physical, so S_b K_r^-1 S_b^T = P K^-1 P^T (Eq. body_compliance)
    model, cb, modes = small
    C_b = SupportedCompliance(model.stiffness, model.port_matrix, rigid_modes=model.rigid_body_modes()).compliance()
    err = np.linalg.norm(C_b - modes.reference_compliance) / np.linalg.norm(C_b)
    assert err < ROUNDOFF * _cond(modes)


def test_full_basis_static_and_frf_identities(small):
    _, cb, modes = small
    full = reduce_ports(cb, PortReductionSpec(n_modes=cb.n_coordinates), modes)
    C = full.static_compliance()
    assert np.linalg.norm(C - modes.reference_compliance) / np.linalg.norm(modes.reference_compliance) \
        < ROUNDOFF * _cond(modes)
    for f in (100.0, 500.0, 1500.0, 3000.0, 5000.0):
        G = parent_port_frf_matrix(cb, f)
        assert np.linalg.norm(modal_port_frf_matrix(full, f) - G) / np.linalg.norm(G) < ROUNDOFF * _cond(modes)


@pytest.mark.parametrize("n_modes,n_residual", [(4, 0), (3, 6), (4, 5)])
def test_reduced_basis_identities(small, n_modes, n_residual):
    _, cb, modes = small
    r = reduce_ports(cb, PortReductionSpec(n_modes=n_modes, n_residual=n_residual, local_correction=True), modes)
    n = n_modes + n_residual
    tol = ROUNDOFF * _cond(modes)
    assert r.n_coordinates == n and r.maps.shape == (cb.port_selector.shape[0], n)
    # M = I, K = diag(Omega^2): mass-normalized, K-orthogonal basis
    assert np.abs(r.basis.T @ cb.mass @ r.basis - np.eye(n)).max() < tol
    K = r.basis.T @ cb.stiffness @ r.basis
    assert np.abs(K - np.diag(r.omega2)).max() < tol * r.omega2.max()
    # the retained modes stay exact parent modes (up to sign)
    P = modes.shapes[:, :n_modes]
    assert np.abs(np.abs(np.sum(P * (cb.mass @ r.basis[:, :n_modes]), axis=0)) - 1).max() < tol
    # projected damping is the full matrix Phi^T C_r Phi
    assert np.allclose(r.damping, r.basis.T @ cb.damping @ r.basis, rtol=0, atol=tol * np.abs(r.damping).max())
    # static port compliance = retained part + the rank-r truncation of R_p (Eq. port_residual_flexibility),
    # reference built independently from the eigen-decomposition of R_p
    H = cb.port_selector @ P
    R_p = modes.reference_compliance - (H / modes.omega2[:n_modes]) @ H.T
    lam, V = np.linalg.eigh(R_p)
    trunc = (V[:, ::-1][:, :n_residual] * lam[::-1][:n_residual]) @ V[:, ::-1][:, :n_residual].T
    C = r.static_compliance()
    assert np.linalg.norm(C - (H / modes.omega2[:n_modes]) @ H.T - trunc) / np.linalg.norm(C) < tol
    # the remaining residual is positive semi-definite (Ritz compliance is a lower bound); its
    # self-blocks are the local correction, which is symmetric and adds no cross-port terms
    R_rem = modes.reference_compliance - C
    assert np.linalg.eigvalsh(R_rem)[0] > -tol * np.abs(R_rem).max()
    L = r.local_block_matrix()
    assert np.array_equal(L, L.T)
    g0, g1 = cb.port_rows[0], cb.port_rows[1]
    assert not L[np.ix_(g0, g1)].any()
    assert np.allclose(r.static_compliance(include_local=True)[np.ix_(g0, g0)],
                       modes.reference_compliance[np.ix_(g0, g0)], rtol=0, atol=tol * np.abs(R_rem).max())


def test_sampled_maps_share_the_structural_coordinates(small):
    _, cb, modes = small
    r = reduce_ports(cb, PortReductionSpec(n_modes=5), modes)
    assert r.sampled_maps([0, 2, 4, 6]).shape == (12, 5)
    assert r.sampled_maps(range(8)).shape == (24, 5)
    assert np.array_equal(r.sampled_maps([3]), r.maps[cb.port_rows[3]])


# -- runtime map ------------------------------------------------------------------------------------

def test_runtime_map_virtual_work_and_tangent(small):
    _, cb, modes = small
    r = reduce_ports(cb, PortReductionSpec(n_modes=6), modes)
    theta = SMALL.port_angles()
    k = 1e8 * (1 + 0.2 * np.cos(2 * theta))
    out = trace_consistency(r.maps, r.port_rows, theta, k)
    # a quadratic energy: the central difference is exact, only cancellation round-off remains
    # (eps / perturbation = 2e-13 per unit relative size)
    assert out["virtual_work_rel_err"] < 1e-10
    assert out["tangent_rel_err"] < 1e-14
    # the contracted tangent is the derivative of the reduced force, including the rigid-port blocks
    traces = radial_traces(r.maps, r.port_rows, theta, k)
    T = expanded_map(N_RIGID, r.maps)
    J = reduce_tangent(T, traces.tangent())
    rng = np.random.default_rng(1)
    q, dq = rng.standard_normal(T.shape[1]), rng.standard_normal(T.shape[1])
    fd = (T.T @ traces.force(T @ (q + dq)) - T.T @ traces.force(T @ (q - dq))) / 2
    assert np.linalg.norm(J @ dq - fd) / np.linalg.norm(fd) < 1e-12
    assert np.abs(J[:N_RIGID, N_RIGID:]).max() > 0      # mixed rigid-structure block is present


# -- static operators --------------------------------------------------------------------------------

def test_inertia_relief_is_balanced_and_mass_orthogonal(free_model):
    m = free_model
    R = m.rigid_body_modes(centre=(0.0, 0.0, SMALL.height / 2))
    ir = InertiaReliefCompliance(m.elastic_stiffness, m.mass, R, m.port_matrix)
    rng = np.random.default_rng(3)
    f = m.port_matrix.T @ rng.standard_normal(m.port_matrix.shape[0])   # unbalanced port loads
    u, lam = ir.solve(f)
    MR = m.mass @ R
    scale = np.linalg.norm(MR, axis=0) * np.linalg.norm(u)
    assert np.all(np.abs(MR.T @ u) < 1e-10 * scale)                       # R^T M u = 0
    # the multiplier balances the rigid part of the load: R^T (f - M R lambda) = 0
    assert np.abs(R.T @ (f - MR @ lam)).max() < 1e-10 * np.abs(R.T @ f).max()
    # and u solves the elastic problem under the balanced load
    res = m.elastic_stiffness @ u - (f - MR @ lam)
    assert np.linalg.norm(res) < 1e-8 * np.linalg.norm(f)
    C = ir.compliance()
    assert np.allclose(C, C.T, rtol=0, atol=1e-8 * np.abs(C).max())


def test_condensation_matches_direct_constrained_solve(small):
    # Eq. (port_condensation) against holding the declared support ports in the parent
    model, _, _ = small
    C = SupportedCompliance(model.stiffness, model.port_matrix).compliance()
    held_ports, kept_ports = [0, 3], [1, 2, 4, 5, 6, 7]
    rows = lambda ports: np.concatenate([model.ports[g].rows for g in ports])
    Ct = condense_ports(C, rows(kept_ports), rows(held_ports))
    held = np.concatenate([model.vertex_dofs(model.ports[g].vertex) for g in held_ports])
    free = np.setdiff1d(np.arange(model.n_dofs), held)
    P_t = model.port_matrix[rows(kept_ports)][:, free]
    direct = SupportedCompliance(model.stiffness[free][:, free], P_t).compliance()
    lam = sla.eigvalsh(model.stiffness.toarray(), model.mass.toarray())
    assert np.linalg.norm(Ct - direct) / np.linalg.norm(direct) < ROUNDOFF * lam[-1] / lam[0]
    with pytest.raises(RvtoolInputError, match="disjoint"):
        condense_ports(C, rows([0, 1]), rows([1]))


def test_ungrounded_structure_is_rejected(free_model):
    m = free_model
    cb = craig_bampton(m, n_modes=4)           # the held boundary grounds K_ii: the reduction itself works
    assert not cb.grounded()
    with pytest.raises(RvtoolInputError, match=r"not positive definite.*valid range.*not grounded"):
        parent_modes(cb)
    with pytest.raises(RvtoolInputError, match="not positive definite"):
        reduce_ports(cb, PortReductionSpec(n_modes=4))
    with pytest.raises(RvtoolInputError, match=r"K_f is not grounded: rigid-body energy ratio"):
        SupportedCompliance(m.stiffness, m.port_matrix, rigid_modes=m.rigid_body_modes())


def test_delayed_offset_update_relaxes_geometrically():
    # Eq. (weak_coupling) with constant load: u_k - C f = (1 - omega)^k (u_0 - C f), one update per interval
    C = np.array([[2.0, 0.5], [0.5, 1.0]]) * 1e-9
    f = np.array([100.0, -50.0])
    fb = DelayedOffsetFeedback(C, OffsetFeedbackSpec(relaxation=0.4, interval=3), n=2)
    for _ in range(12):
        u = fb.on_accepted_step(f)
    assert fb.updates == 4
    assert np.allclose(u, (1 - 0.6 ** 4) * (C @ f), rtol=1e-14, atol=0)


# -- Exudyn paths --------------------------------------------------------------------------------------

def _static(mbs):
    import exudyn as exu
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.solution.file.write = False
    ss.staticSolver.newton.relativeTolerance = 1e-12
    ss.staticSolver.newton.absoluteTolerance = 1e-14
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    assert mbs.SolveStatic(ss)


def test_exudyn_reduced_structure_static_port_load(small):
    import exudyn as exu
    from exudyn_user_elements.reduced_structure import PortCouplingElement, ReducedStructure
    _, cb, modes = small
    r = reduce_ports(cb, PortReductionSpec(n_modes=4, n_residual=4), modes)
    f = np.zeros(r.maps.shape[0])
    f[cb.port_rows[0]] = (300.0, -120.0, 40.0)
    n_e = r.n_coordinates + len(f)

    def law(t, q_e, v_e):   # constant port load in the expanded workspace
        return np.concatenate([np.zeros(r.n_coordinates), f]), np.zeros((n_e, n_e)), np.zeros((n_e, n_e))

    mbs = exu.SystemContainer().AddSystem()
    st = ReducedStructure(mbs, r)
    PortCouplingElement(mbs, [], st, law)
    _static(mbs)
    u = st.port_displacements()
    ref = r.static_compliance() @ f                      # u = H Omega^-2 H^T f
    assert np.linalg.norm(u - ref) < 1e-9 * np.linalg.norm(ref)


def test_exudyn_trace_contact_equilibrium_with_contracted_tangent(small):
    import exudyn as exu
    from exudyn.itemInterface import LoadCoordinate, MarkerNodeCoordinate, MassPoint2D, NodePoint2D
    from exudyn_user_elements.reduced_structure import PortCouplingElement, ReducedStructure
    _, cb, modes = small
    r = reduce_ports(cb, PortReductionSpec(n_modes=6), modes)
    theta = SMALL.port_angles()
    traces = radial_traces(r.maps, r.port_rows, theta, 1e8 * (1 + 0.2 * np.cos(2 * theta)))
    J_e = traces.tangent()

    def law(t, q_e, v_e):
        return traces.force(q_e), J_e, np.zeros_like(J_e)

    mbs = exu.SystemContainer().AddSystem()
    node = mbs.AddNode(NodePoint2D(referenceCoordinates=[0.0, 0.0]))
    mbs.AddObject(MassPoint2D(nodeNumber=node, mass=1.0))
    F = np.array([800.0, -300.0])
    for c in range(2):
        mbs.AddLoad(LoadCoordinate(markerNumber=mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=c)),
                                   load=F[c]))
    st = ReducedStructure(mbs, r)
    el = PortCouplingElement(mbs, [node], st, law)
    _static(mbs)
    q = np.concatenate([mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates), st.coordinates()])
    # independent linear solve: (K_s - T_e^T J_e T_e) q = [F; 0]
    K_s = sla.block_diag(np.zeros((2, 2)), np.diag(r.omega2))
    ref = np.linalg.solve(K_s - reduce_tangent(el.T_e, J_e), np.concatenate([F, np.zeros(r.n_coordinates)]))
    assert np.linalg.norm(q - ref) < 1e-9 * np.linalg.norm(ref)


@pytest.fixture(scope="module")
def wheel():
    """Small free wheel: bore 20 mm, outer radius 40 mm, 10 mm thick; one port on the rim (meshed
    once for the three floating-frame tests, which only read it)."""
    spec = AnnularHousingSpec(inner_radius=0.02, outer_radius=0.04, height=0.01, mesh_size=0.006, n_ports=1,
                              n_mounts=0, mount_radius=0.03)
    port = NodalPort(name="tooth", point=(0.04, 0.0, 0.005))
    return fe_model_from_geometry(spec.geometry(), mesh_size=spec.mesh_size, material=spec.material,
                                  ports=(port,)), spec


@pytest.fixture(scope="module")
def free_free_basis(wheel):
    """The wheel's free-free basis with 6 elastic modes (read by two tests)."""
    return floating_basis(wheel[0], n_modes=6)


def test_free_free_basis_is_mass_orthogonal_to_rigid_modes(wheel, free_free_basis):
    m, _ = wheel
    b = free_free_basis
    Phi = b["matrix"]
    assert np.abs(Phi.T @ m.mass @ Phi - np.eye(6)).max() < 1e-10
    MR = m.mass @ m.rigid_body_modes()
    assert np.abs(Phi.T @ MR).max() < 1e-8 * np.abs(MR).max()
    lam = sla.eigh(m.elastic_stiffness.toarray(), m.mass.toarray(), eigvals_only=True, subset_by_index=[0, 11])
    assert np.allclose(b["eigenvalues"], lam[6:], rtol=1e-8)


def test_exudyn_ffrf_body_port_compliance(wheel):
    # floating frame held at rest; the frame follows the bore, the port load at the rim deflects the body
    # exactly as the bore-clamped parent does (Craig-Bampton with the port as boundary is exact in statics)
    import exudyn as exu
    from exudyn.itemInterface import CoordinateConstraint, Force, MarkerNodeCoordinate, NodePointGround
    from exudyn_user_elements.reduced_structure import add_floating_flexible_body, add_port_marker
    m, spec = wheel
    bore = np.flatnonzero(np.abs(np.hypot(m.vertices[:, 0], m.vertices[:, 1]) - spec.inner_radius) < 1e-9)
    port = m.ports[0].vertex
    b = floating_basis(m, n_modes=4, frame_vertices=bore, boundary_vertices=[port])
    mbs = exu.SystemContainer().AddSystem()
    cms = add_floating_flexible_body(mbs, m, b)
    ground = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    for c in range(6):
        mc = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=cms.nRigidBody, coordinate=c))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, mc]))
    f = np.array([-400.0, 150.0, 60.0])
    mbs.AddLoad(Force(markerNumber=add_port_marker(mbs, cms.oFFRFreducedOrder, [port]), loadVector=list(f)))
    _static(mbs)
    q = np.asarray(mbs.GetNodeOutput(cms.nGenericODE2, exu.OutputVariableType.Coordinates))
    u = b["matrix"][3 * port:3 * port + 3] @ q
    held = np.concatenate([3 * v + np.arange(3) for v in bore])
    free = np.setdiff1d(np.arange(m.n_dofs), held)
    P = m.port_matrix[:, free]
    ref = SupportedCompliance(m.elastic_stiffness[free][:, free], P).compliance() @ f
    assert np.linalg.norm(u - ref) < 1e-8 * np.linalg.norm(ref)


def test_exudyn_ffrf_free_wheel_translates_and_spins(wheel, free_free_basis):
    # a free body with free-free modes (orthogonal to the rigid modes) keeps its initial rigid motion;
    # the frame origin lies on the wheel axis, the mesh centre of mass within ~1e-8 m of it, so the
    # frame follows v0 t and w0 t up to that offset times the 0.2 rad turned (rel. < 1e-5)
    import exudyn as exu
    from exudyn_user_elements.reduced_structure import add_floating_flexible_body
    from rvtool.solver import RunSpec, simulate
    m, _ = wheel
    b = free_free_basis
    mbs = exu.SystemContainer().AddSystem()
    v0, w0, T = np.array([0.3, -0.2, 0.0]), np.array([0.0, 0.0, 20.0]), 0.01
    cms = add_floating_flexible_body(mbs, m, b, velocity=v0, angular_velocity=w0)
    mbs.Assemble()
    rec = simulate(mbs, RunSpec(end_time=T, step=1e-4))
    assert rec.accepted_steps == 100
    pos = mbs.GetNodeOutput(cms.nRigidBody, exu.OutputVariableType.Position)
    rot = mbs.GetNodeOutput(cms.nRigidBody, exu.OutputVariableType.Rotation)
    assert np.linalg.norm(pos - v0 * T) < 1e-5 * np.linalg.norm(v0 * T)
    assert np.linalg.norm(rot - w0 * T) < 1e-5 * np.linalg.norm(w0 * T)
    # elastic motion stays below the static centrifugal deflection rho w^2 r^3 / E = 1e-9 m at 20 rad/s
    q = mbs.GetNodeOutput(cms.nGenericODE2, exu.OutputVariableType.Coordinates)
    assert np.abs(b["matrix"] @ q).max() < 7850 * 20.0 ** 2 * 0.04 ** 3 / 210e9
