"""Gaps of issue 32 closed after the tilting wheels and cranks: the three-stage design's crank gear
station (its sun--crank meshes sliced on spatial cranks), the slice evaluation's cost path
(SkewSlices' one sparse sandwich per evaluation equals the per-slice sums), and the named
decisions on the elastic crank's bending slope and the input shaft."""
import numpy as np
import pytest

import rvtool
from rvtool.assembly.rv.builder import crank_centre
from rvtool.contact.skew import SkewSlices


def test_three_stage_meshes_sliced_on_spatial_cranks():
    """rv_three_stage declares cranks.shaft.gear_position (assumed, the rv40e crank stage): with spatial
    cranks its sun--crank meshes are width-sliced at the gear's station about the crank centre; planar
    cranks keep the planar family (the station is not read)."""
    d = rvtool.load_design("rv_three_stage")
    assert d.cranks.shaft.model == "rigid" and d.cranks.shaft.gear_position == pytest.approx(-0.030)
    planar = rvtool.build(d)
    assert not isinstance(planar.elements["gears"].evaluator, SkewSlices)
    ds = rvtool.replace_design(d, bodies={"carrier_coordinates": "spatial", "crank_coordinates": "spatial"})
    g = rvtool.build(ds).elements["gears"].evaluator
    assert isinstance(g, SkewSlices) and len(g.tilt_rows) == d.cranks.count
    # each crank's arm: the gear station about the crank centre plus the slice station over the face
    z = np.polynomial.legendre.leggauss(ds.bodies.tilt_slices)[0] * 0.5 * d.crank_gear.face_width
    arms = g.arms[:, sorted(g.tilt_rows)]
    assert np.allclose(arms - z[:, None], arms[0] - z[0], atol=1e-15)       # one station per crank, + the slices
    assert np.allclose(arms[0] - z[0], -0.030 - crank_centre(ds), atol=1e-15)


def test_skew_sparse_sums_equal_the_per_slice_sums():
    """SkewSlices forms sum_s w_s T_s^T Q_s and sum_s w_s T_s^T K_s T_s as one sparse product over all
    slices: equal to the explicit per-slice sums (dense maps) at a tilted, loaded pose where every slice
    differs, and at zero tilt (one shared evaluation) -- 1e-12 of the largest entry (round-off of a
    different summation order only)."""
    from rvtool.bearings.set import BearingSet, Mounting
    from rvtool.contact.skew import slice_stations
    d = rvtool.load_design("rv40e")
    m = Mounting(name="n", bearing=d.eccentric_bearing, inner=0, outer=1, inner_centre=(0.0, 0.0))
    planar = BearingSet([m], 2, backend="numpy")
    z, w = slice_stations(d.wheels.width, 5)
    sk = SkewSlices(planar, 2, {0: 0, 1: 1}, np.column_stack([z + 0.01, z]), w)
    for tilt in (np.zeros(3), np.array([0.0, 2e-4, -1e-4])):
        pose = np.zeros((4, 3))
        pose[0] = (4e-6, -2e-6, 0.2)
        pose[2] = tilt
        vel = np.full((4, 3), 1e-3)
        ev = sk.evaluate(pose, vel)
        P, V = sk.slice_poses(pose), sk.slice_poses(vel)
        Q, K, C = 0.0, 0.0, 0.0
        for s in range(sk.n_slices):
            e = planar.evaluate(P[s], V[s], check=False)
            T = sk.maps[s]
            Q, K, C = Q + w[s] * T.T @ e.Q, K + w[s] * T.T @ e.dQdq @ T, C + w[s] * T.T @ e.dQdv @ T
        assert np.max(np.abs(K)) > 0 and np.max(np.abs(Q)) > 0
        for a, b in ((ev.Q, Q), (ev.dQdq, K), (ev.dQdv, C)):
            assert np.max(np.abs(a - b)) <= 1e-12 * max(np.max(np.abs(b)), 1e-300)


def _floating_sun(**bodies):
    return rvtool.replace_design(rvtool.load_design("rv40e"), bodies={"input": ["x", "y", "theta"], **bodies})


def test_spatial_input_shaft_reproduces_planar_and_carries_a_tilting_moment():
    """bodies.input_coordinates = "spatial" (a floating sun): the sun--crank meshes are sliced with the
    sun's tilt; without out-of-plane load the quasi-static TE equals the planar floating sun's (1e-9
    relative to the output angle, issue 32: the slices are evaluated in one stacked launch and summed
    with their width fractions, which rounds otherwise than the planar sum, so Newton stops at another
    iterate inside its tolerance; measured 4e-13 of the output angle. The TE differs exactly as the
    output angle does, its kinematic part being the same; over these three points its peak-to-peak is
    only ~3e-5 of the output angle, so 1e-9 of it would ask for the iterates' last bits); a
    tilting moment on the sun is carried by the meshes' width moments, not by the regularization
    spring (0.1 N m/rad would give 5 rad under 0.5 N m)."""
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.solver.static import StaticSolver
    d = _floating_sun()
    assert d.bodies.input_coordinates == "planar"
    m0, m1 = rvtool.build(d), rvtool.build(_floating_sun(input_coordinates="spatial"))
    assert m0.body_tilts is None and not isinstance(m0.elements["gears"].evaluator, SkewSlices)
    g = m1.elements["gears"].evaluator
    assert isinstance(g, SkewSlices) and m1.body_tilts.names == ("sun",)
    ang = np.arange(3) * m0.mesh_period / 40
    r0 = quasi_static_te(m0, torque=float(d.rated_torque), input_angles=ang, solver=StaticSolver(m0))
    s1 = StaticSolver(m1)
    r1 = quasi_static_te(m1, torque=float(d.rated_torque), input_angles=ang, solver=s1)
    assert np.max(np.abs(r1["theta_out"] - r0["theta_out"])) <= 1e-9 * np.max(np.abs(r0["theta_out"]))
    assert np.max(np.abs(r1["te"] - r0["te"])) <= 1e-9 * np.max(np.abs(r0["theta_out"]))
    m1.set_body_load("sun", 0.0, (0.5, 0.0))
    q = s1.solve(float(ang[-1]), previous_angle=float(ang[-1]))
    gx = m1.tilts(q)["sun"][1]
    assert 1e-6 < abs(gx) < 1e-2


def test_spatial_input_shaft_refusals():
    """A held sun (x, y held by its bearings: its tilt is held too), the three-stage topology (its input
    body is the offset pinion) and elastic crankshafts (the meshes inside the crank closures) are
    refused by name."""
    from rvtool.errors import RvtoolInputError
    with pytest.raises(RvtoolInputError, match="bodies.input"):
        rvtool.replace_design(rvtool.load_design("rv40e"), bodies={"input_coordinates": "spatial"})
    three = rvtool.load_design("rv_three_stage")
    with pytest.raises(RvtoolInputError, match="three-stage"):
        rvtool.build(rvtool.replace_design(three, bodies={"input": ["x", "y", "theta"], "input_coordinates": "spatial"}))
    rv80 = rvtool.load_design("rv80e")
    with pytest.raises(RvtoolInputError, match="elastic crankshafts"):
        rvtool.build(rvtool.replace_design(rv80, bodies={"input": ["x", "y", "theta"], "input_coordinates": "spatial"}))
    with pytest.raises(RvtoolInputError, match="input_coordinates"):
        _floating_sun(input_coordinates="tilted")


def test_device_backends_name_a_spatial_input_shaft():
    from rvtool.solver.backends.base import SPATIAL_WHEELS_REASON, spatial_body_reasons
    assert spatial_body_reasons(rvtool.build(_floating_sun(input_coordinates="spatial"))) == [SPATIAL_WHEELS_REASON]


def test_identity_ports_contract_to_the_family_result():
    from rvtool.solver.static import StaticSolver
    """The merged element contracts a family on the retained out-of-plane rows (ports with P = I) to the
    family's own result (a copy, no products): the same static state as the per-family elements, whose
    contraction forms T^T Q and T^T K T with the full block products (1e-12 relative: summation order)."""
    d = rvtool.replace_design(rvtool.load_design("rv40e"), bodies={"carrier_coordinates": "spatial",
                                                                   "wheel_coordinates": "spatial"})
    out = []
    for kind in ("merged", "per_family"):
        m = rvtool.build(d, contact_element=kind)
        m.set_flange_load(0.0, (300.0, 0.0))
        q = StaticSolver(m).solve(0.0, previous_angle=0.0)
        out.append((np.asarray(m.flange_displacement(q)), m.tilts(q)))
    (f0, t0), (f1, t1) = out
    assert np.allclose(f0, f1, rtol=1e-12, atol=1e-12 * np.max(np.abs(f0)))
    assert np.max(np.abs(f0[1:])) > 0                 # the moment tilts the carrier
    for nm in t0:
        assert np.allclose(t0[nm], t1[nm], rtol=1e-9, atol=1e-12 * np.max(np.abs(f0[1:])))
