"""The RV carrier as a reduced structure (issue 30, ``[carrier] body = "rigid" | "ported"``).

Coarse meshes (10 mm nominal) keep these tests at a few seconds each; the figures of the shipped meshes are the
case's (cases/rv/compliance_budget.py)."""
import math

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.errors import RvtoolInputError

COARSE = 0.010
"""Nominal tetrahedron size [m] of the tests: about 2,000 vertices for rv40e's carrier."""


def _rv40e(**carrier):
    d = rvtool.load_design(designs.path("rv40e"))
    return d if not carrier else d.replace(carrier=carrier)


def _ported(name="rv40e", mesh_size=COARSE):
    d = rvtool.load_design(designs.path(name))
    return d.replace(carrier={"body": "ported", "structure": {"mesh_size": mesh_size}})


def test_rigid_carrier_is_bit_identical_to_a_design_without_the_section():
    """The default ("rigid", the section absent or present) builds the same model: identical static state and
    generalized forces (exact equality, not a tolerance: the same code path)."""
    import copy
    from rvtool.assembly.rv.spec import design_from_dict
    from rvtool.solver.static import StaticSolver
    with_section = _rv40e()
    src = copy.deepcopy(with_section.source)
    src.pop("carrier")
    without = design_from_dict(src)
    assert without.carrier.body == "rigid" and with_section.carrier.body == "rigid"
    states = []
    for d in (with_section, without):
        m = rvtool.build(d)
        m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
        states.append(StaticSolver(m).solve(0.0))
    assert np.array_equal(states[0], states[1])


def test_reduced_carrier_static_port_compliance_matches_the_parent():
    """Issue 30 target: the reduced structure's static port compliance H Omega^-2 H^T within 1e-6 relative of
    the parent FE's P K^-1 P^T (exact in theory: the static port modes are in the Ritz basis; round-off of the
    Rayleigh--Ritz eigen-solve is about 1e-12)."""
    from rvtool.assembly.carrier import carrier_ports
    red, C_ref, info = carrier_ports(_ported())
    C = red.static_compliance()
    assert C.shape == (8, 8) and info["ports"][-1] == "main_bearing"
    err = np.abs(C - C_ref).max() / np.abs(C_ref).max()
    assert err < 1e-6, err
    # the compliance is a compliance: symmetric positive definite
    assert np.allclose(C_ref, C_ref.T, rtol=0, atol=1e-12 * np.abs(C_ref).max())
    assert np.linalg.eigvalsh(C_ref).min() > 0


def test_reduction_without_the_static_modes_fails_the_target():
    """The test above can fail: a basis of clamped modes only (no static port modes) misses the parent's port
    compliance by far more than 1e-6."""
    import scipy.linalg as sla
    import scipy.sparse.linalg as spla
    from rvtool.structure.carrier import carrier_fe
    from rvtool.assembly.carrier import carrier_layout
    d = _ported()
    r, angles, _, _ = carrier_layout(d)
    parent = carrier_fe(d.carrier.structure, d.material, r, angles)
    K, M = parent.stiffness, parent.mass
    w2, phi = spla.eigsh(K, k=12, M=M, sigma=0.0, which="LM")
    H = parent.port_matrix @ phi
    C_modes = (H / w2) @ H.T
    C_ref = parent.compliance()
    assert np.abs(C_modes - C_ref).max() / np.abs(C_ref).max() > 1e-3
    assert sla.norm(C_ref) > 0


def test_ported_carrier_adds_compliance_in_series():
    """At rated torque the ported carrier lowers the tangent output stiffness, and the budget carries a
    ``carrier`` path that with the others sums to one (the residual below 1 %, as compliance_budget's
    RESIDUAL_TOL)."""
    from rvtool.protocols.budget import stiffness_budget
    from rvtool.solver.static import StaticSolver
    out = {}
    for body, d in (("rigid", _rv40e()), ("ported", _ported())):
        m = rvtool.build(d)
        m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
        q = StaticSolver(m).solve(0.0)
        out[body] = stiffness_budget(m, q)
        # the crank forces on the carrier are read at the seats: they carry the output torque, shared by the
        # three cranks (equal shares 1/3 up to the mesh phase at input angle 0: 5 % absolute)
        share = m.crank_load_share(q)
        assert abs(share.sum() - 1.0) < 1e-12 and np.abs(share - 1.0 / 3.0).max() < 0.05, share
        assert abs(m.crank_torques(q).sum() - d.rated_torque) < 0.02 * d.rated_torque
    assert out["ported"]["K_t_Nm_per_arcmin"] < 0.95 * out["rigid"]["K_t_Nm_per_arcmin"]
    sh = out["ported"]["shares"]
    assert 0.05 < sh["carrier"] < 0.9
    assert abs(sh["geometric_and_regularization"]) < 0.01
    # the energy view and the switch-on view of the carrier agree (series member): 1 - C_rigid / C_ported
    switch = 1.0 - out["ported"]["K_t_Nm_per_arcmin"] / out["rigid"]["K_t_Nm_per_arcmin"]
    assert abs(switch - sh["carrier"]) < 0.05, (switch, sh["carrier"])


def test_seat_support_turns_with_the_carrier():
    """The seat compliance is stated in the carrier's frame: turned by theta, a seat displacement turned by theta
    gets the force turned by theta (s(R u) = R s(u))."""
    from rvtool.assembly.carrier import CarrierSeatSupport
    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 6))
    sup = CarrierSeatSupport(A @ A.T + 6 * np.eye(6))
    u = rng.normal(size=(1, 3, 2))
    f0 = sup.forces(u)[0]
    th = 0.7
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    sup.turn_to(th)
    f1 = sup.forces(u @ R.T)[0]
    assert np.allclose(f1, f0 @ R.T, rtol=0, atol=1e-12 * np.abs(f0).max())


@pytest.mark.parametrize("key, value, match", [
    ("body", "elastic", "carrier.body"),
    ("flange_thickness", -0.01, "carrier.structure.flange_thickness"),
    ("pillar_shape", "square", "carrier.structure.pillar_shape"),
    ("seat_radius", 0.03, "carrier.structure.seat_radius"),
    ("pillar_radius", 0.02, "carrier.structure.pillar_radius"),
    ("inner_face_position", 0.030, "crank_bearing.row_spacing"),
])
def test_bad_input_names_the_key(key, value, match):
    d = rvtool.load_design(designs.path("rv40e"))
    change = {"body": value} if key == "body" else {"body": "ported", "structure": {key: value}}
    with pytest.raises(RvtoolInputError, match=match.replace(".", r"\.")):
        d.replace(carrier=change)


def test_ported_carrier_refuses_what_it_does_not_implement():
    """Spatial crank coordinates and Palmgren's bearing friction are refused by name, not ignored (a spatial
    carrier is taken: test_spatial_ported_carrier_*)."""
    d = _ported()
    with pytest.raises(RvtoolInputError, match="bodies.crank_coordinates"):
        rvtool.build(d.replace(bodies={"crank_coordinates": "spatial"}))
    with pytest.raises(RvtoolInputError, match="bearing_friction.model"):
        rvtool.build(d.replace(bearing_friction={"model": "palmgren"}))


def test_device_backends_refuse_the_ported_carrier_by_name():
    """The device row Newton (and the replica) do not copy the seat closure: supports() names carrier.body; the
    rigid carrier stays supported."""
    from rvtool.solver import backends
    dev = backends.get("device")
    ported = rvtool.build(_ported())
    sup = dev.supports(ported, "equilibria")
    assert not sup.ok and any("carrier.body = 'ported'" in r for r in sup.reasons)
    sup = dev.supports(ported, "torque_path")
    assert not sup.ok and any("carrier.body = 'ported'" in r for r in sup.reasons)
    assert not any("carrier.body" in r for r in dev.supports(rvtool.build(_rv40e()), "torque_path").reasons)


def test_three_stage_rv_takes_the_ported_carrier():
    """rv_three_stage (no [carrier] section: rigid) builds with a ported carrier of rv40e's sizes (its cranks sit
    on the same 36 mm circle) and the carrier enters its budget."""
    import tomllib
    from rvtool.protocols.budget import stiffness_budget
    from rvtool.solver.static import StaticSolver
    d = rvtool.load_design(designs.path("rv_three_stage"))
    assert d.carrier.body == "rigid"
    with open(designs.path("rv40e"), "rb") as fh:
        st = tomllib.load(fh)["carrier"]["structure"]
    dp = d.replace(carrier={"body": "ported", "structure": {**st, "mesh_size": COARSE}})
    m = rvtool.build(dp)
    m.set_output_torque(-np.sign(m.ratio) * dp.rated_torque)
    b = stiffness_budget(m, StaticSolver(m).solve(0.0))
    assert 0.05 < b["shares"]["carrier"] < 0.9 and abs(b["shares"]["geometric_and_regularization"]) < 0.01


def test_sector_pillars_are_stiffer_than_thin_circular_ones():
    """The pillar shape enters the structure: sector pillars of the same radial depth and 30 deg wide (more
    section than a circle of that radius at 36 mm: arc 2 x 36 x pi / 12 = 18.8 mm > 18 mm diameter) give a
    smaller tangential seat compliance than circular ones."""
    from rvtool.assembly.carrier import carrier_layout
    from rvtool.structure.carrier import carrier_fe
    d = _ported()
    r, angles, _, _ = carrier_layout(d)
    tang = {}
    for shape in ("circular", "sector"):
        st = d.replace(carrier={"body": "ported", "structure": {"pillar_shape": shape,
                                                               "mesh_size": COARSE}}).carrier.structure
        C = carrier_fe(st, d.material, r, angles).compliance()
        t = np.array([-math.sin(angles[0]), math.cos(angles[0])])
        tang[shape] = t @ C[:2, :2] @ t
    assert tang["sector"] < tang["circular"]


def test_closure_tangent_matches_central_differences():
    """The condensed tangent of the crank-bearing element on the ported carrier, at the rated state, against
    central differences of its generalized forces (step 1e-9 m / rad, where the laws are smooth; measured
    4e-9 of the largest entry, the O(h^2) truncation seen at 1e-7 / 1e-8 steps as 3.6e-5 / 3.6e-7). Without
    the turn of the seat forces with the carrier (CarrierSeatSupport.angle_derivative) the error is 5.1e-6:
    the bound 1e-6 separates the two."""
    from rvtool.solver.static import StaticSolver
    d = _ported()
    m = rvtool.build(d)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    el = m.elements["crank_bearings"]
    ql = el.local(q)
    pose, vel = el.pose_velocity(ql, 0 * ql)
    clo = el.evaluator
    ev = clo.evaluate(pose, vel)
    h = 1e-9
    fd = np.zeros_like(ev.dQdq)
    flat = pose.reshape(-1)
    for j in range(flat.size):
        qp, qm = flat.copy(), flat.copy()
        qp[j] += h
        qm[j] -= h
        fd[:, j] = (clo.evaluate(qp.reshape(pose.shape), vel).Q - clo.evaluate(qm.reshape(pose.shape), vel).Q) / (2 * h)
    scale = np.abs(ev.dQdq).max()
    err = np.abs(ev.dQdq - fd).max() / scale
    assert err < 1e-6, err


def test_rigid_fit_of_a_seat_recovers_rigid_motions_and_the_tilt_stiffness_is_reported():
    """The main-bearing seats' rigid fit (an RBE3-type port) returns the six rigid-body coordinates of a rigid
    displacement of the end plate's seat (no clamped vertex there) exactly (a least-squares fit of a rigid field
    is exact: 1e-9 of the unit amplitude, round-off of the normal equations); the carrier's tilt stiffness
    between the output face and the main seats is in the reduction's info."""
    from rvtool.assembly.carrier import carrier_layout, carrier_ports
    from rvtool.structure.carrier import carrier_fe
    d = _ported()
    r, angles, _, _ = carrier_layout(d)
    parent = carrier_fe(d.carrier.structure, d.material, r, angles)
    centre = (0.0, 0.0, 0.0)
    A = parent.rigid_fit(("main_end_plate",), centre)
    R = parent.rigid_modes(centre)
    assert np.abs(A @ R - np.eye(6)).max() < 1e-9
    info = carrier_ports(d)[2]
    C = np.array(info["main_seats_compliance"])
    assert C.shape == (6, 6) and np.linalg.eigvalsh(0.5 * (C + C.T)).min() > 0
    assert info["main_seats_tilt_stiffness_Nm_per_rad"] > 0


@pytest.fixture(scope="module")
def spatial_ported():
    """(planar + ported model, spatial + ported model) of rv40e on the coarse carrier mesh."""
    from rvtool.protocols.moment_rigidity import spatial_design
    d = _ported()
    return rvtool.build(d), rvtool.build(spatial_design(d))


def test_spatial_ported_carrier_without_out_of_plane_load_is_the_planar_ported_carrier(spatial_ported):
    """bodies.carrier_coordinates = "spatial" with carrier.body = "ported" (issue 32): the face and the main seats
    retain (z, gamma_x, gamma_y), closed by the carrier's out-of-plane seat compliance; without out-of-plane load
    the quasi-static output angle and TE equal the planar ported carrier's to 1e-9 relative (issue 32; measured
    ~3e-16: the seat spring carries nothing and the main bearing's in-plane rows are the planar ones)."""
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.solver.static import StaticSolver
    m0, m1 = spatial_ported
    assert m1.body_tilts.names == ("carrier", "carrier_seats") and "carrier_seats" in m1.elements
    d = m0.design
    ang = np.arange(3) * m0.mesh_period / 40
    r0 = quasi_static_te(m0, torque=float(d.rated_torque), input_angles=ang, solver=StaticSolver(m0))
    r1 = quasi_static_te(m1, torque=float(d.rated_torque), input_angles=ang, solver=StaticSolver(m1))
    scale = np.max(np.abs(r0["theta_out"]))
    assert np.max(np.abs(r1["theta_out"] - r0["theta_out"])) <= 1e-9 * scale
    assert np.max(np.abs(r1["te"] - r0["te"])) <= 1e-9 * scale


def test_spatial_ported_carrier_seat_compliance_is_the_parents(spatial_ported):
    """The seat spring's static compliance -- the face's (z, gamma_x, gamma_y) under unit loads with the seats
    held, from the element's own tangent -- is the parent FE's rigid-fit compliance block of the main seats
    relative to the clamped output face (issue 30's port check, 1e-6 relative: the same matrix inverted twice,
    ~1e-12), turned with the carrier: at carrier angle 0.4 rad it is R C_o R^T."""
    from rvtool.assembly.carrier import OUT_OF_PLANE, carrier_ports
    _, m1 = spatial_ported
    ev = m1.elements["carrier_seats"].evaluator
    _, _, info = carrier_ports(m1.design)
    C_parent = np.asarray(info["main_seats_compliance"])[np.ix_(OUT_OF_PLANE, OUT_OF_PLANE)]
    for angle in (0.0, 0.4):
        pose = np.zeros((ev.n_bodies, 3))
        pose[ev.carrier, 2] = angle
        K = -ev.evaluate(pose).dQdq
        f = slice(3 * ev.face, 3 * ev.face + 3)
        C = np.linalg.inv(K[f, f])
        c, s = math.cos(angle), math.sin(angle)
        R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
        want = R @ C_parent @ R.T
        assert np.max(np.abs(C - want)) <= 1e-6 * np.max(np.abs(want))


def test_spatial_ported_carrier_tangent_central_difference(spatial_ported):
    """The merged element's analytic tangent of the spatial ported carrier against central differences over
    every coordinate at a loaded, tilted state (the seat spring's turn with the carrier in its angle column, the
    seat closure, the spatial main-bearing rows). Steps 1e-10 m / 1e-8 rad against displacements ~1e-6 m: bound
    1e-6 of the largest entry (the issue's check)."""
    _, m1 = spatial_ported
    host = m1.contact_host
    rng = np.random.default_rng(2)
    from rvtool.solver.static import StaticSolver
    m1.set_output_torque(-np.sign(m1.ratio) * m1.design.rated_torque)
    m1.set_flange_load(200.0, (300.0, -150.0))
    try:
        q_all = StaticSolver(m1).solve(0.0)
    finally:
        m1.set_flange_load(0.0, (0.0, 0.0))
        m1.set_output_torque(0.0)
    q = np.asarray(q_all)[host.coordinate_indices] + 1e-8 * rng.standard_normal(host.n)
    v = np.zeros(host.n)
    K = host.tangent(0.0, q, v)
    fd = np.zeros_like(K)
    for j in range(host.n):
        h = 1e-8 if j % 3 == 2 or j >= host.n_rigid else 1e-10
        qp, qm = q.copy(), q.copy()
        qp[j] += h
        qm[j] -= h
        fd[:, j] = (host.evaluate(1.0 + j, qp, v)[0] - host.evaluate(2.0 + j, qm, v)[0]) / (2 * h)
    assert np.max(np.abs(K - fd)) <= 1e-6 * np.max(np.abs(K))


def test_moment_rigidity_runs_with_the_ported_carrier(spatial_ported):
    """The moment-rigidity protocol on the elastic carrier: the carrier's tilt compliance between the face and
    the main seats adds in series to the main bearing's, 1/K = 1/K_rigid + C_gamma within the bearing's change
    over the moment range and the small z--gamma couplings (measured 7e-4; bound 1e-2), and the axial
    stiffness likewise with C_z (measured 3e-7; bound 1e-5)."""
    from rvtool.protocols.moment_rigidity import MomentRigidityTest, moment_rigidity, spatial_design
    _, m1 = spatial_ported
    test = MomentRigidityTest(reference_moment=1000.0, levels=(0.0, 0.5, 1.0), axial_force=1000.0)
    ported = moment_rigidity(m1, test)
    rigid = moment_rigidity(rvtool.build(spatial_design(_rv40e())), test)
    C = m1.elements["carrier_seats"].evaluator.compliance
    assert ported.rigidity < rigid.rigidity
    want = 1.0 / rigid.rigidity + 0.5 * (C[1, 1] + C[2, 2])
    assert abs(1.0 / ported.rigidity - want) <= 1e-2 * want
    want = 1.0 / rigid.axial_stiffness + C[0, 0]
    assert abs(1.0 / ported.axial_stiffness - want) <= 1e-5 * want
