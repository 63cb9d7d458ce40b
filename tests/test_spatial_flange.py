"""Spatial output flange on its main-bearing rows (issue 32): the spatial ball rows
(rvtool.bearings.spatial_set), preload declarations, the RV builder's spatial carrier and the
moment-rigidity protocol."""
import dataclasses
import math

import numpy as np
import pytest

import rvtool
from rvtool.bearings.set import BearingSet, Mounting
from rvtool.bearings.spatial_set import SpatialBearingSet, flange_wrench
from rvtool.bearings.spec import AngularContactPair, BallBearing, CrossedRollerBearing
from rvtool.contact.circle_set import GROUND
from rvtool.errors import RvtoolInputError
from rvtool.protocols.moment_rigidity import (MomentRigidityTest, flange_equilibrium, moment_rigidity,
                                              pair_moment_rigidity, spatial_design)

ROW = BallBearing(n_balls=16, ball_diameter=7.938e-3, pitch_diameter=0.068, contact_angle=math.radians(25),
                  axial_preload=200.0)


def _pair(**kw):
    row = dataclasses.replace(ROW, axial_preload=kw.pop("axial_preload", 200.0))
    return AngularContactPair(rows=(row, row), row_spacing=0.040, **kw)


def _fd(set_, pose, steps):
    """Central differences of the assembled Q over the pose vector (step per coordinate)."""
    x = pose.ravel()
    K = np.zeros((len(x), len(x)))
    for j, h in enumerate(steps):
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        K[:, j] = (set_.evaluate(xp.reshape(pose.shape)).Q - set_.evaluate(xm.reshape(pose.shape)).Q) / (2 * h)
    return K


@pytest.mark.parametrize("pair", [_pair(), _pair(axial_preload=0.0, end_play=2e-6)], ids=["preload", "end_play"])
def test_tangent_central_difference(pair):
    """Analytic tangent vs central differences, all six coordinates of the flange (x, y, theta and
    z, gamma_x, gamma_y), at a loaded, tilted state where some balls have lost contact (end play).
    Steps 1e-9 m / 1e-7 rad against displacements of ~1e-6 m / 1e-5 rad: truncation ~(h/x)^2 ~ 1e-6,
    rounding ~1e-16 / 1e-9 ~ 1e-7; bound 1e-6 of the largest entry (the issue's check)."""
    s = SpatialBearingSet([Mounting(name="m", bearing=pair, inner=0, outer=GROUND, inner_centre=(2e-4, -1e-4))], 2, {0: 1})
    pose = np.array([[4e-6, -3e-6, 0.37], [3e-6, 2e-5, -1.5e-5]])
    ev = s.evaluate(pose)
    fn = s.commit(pose)[:, 0]
    assert 0 < np.count_nonzero(fn) <= len(fn)
    K = _fd(s, pose, [1e-9, 1e-9, 1e-7, 1e-9, 1e-9, 1e-9])
    assert np.max(np.abs(ev.dQdq - K)) <= 1e-6 * np.max(np.abs(ev.dQdq))


def test_in_plane_equals_planar_element():
    """At zero axial and tilt displacement the spatial rows give the planar element's generalized
    forces and tangent (the same law, term by term: equal to rounding, bound 1e-12 relative)."""
    pair = _pair()
    ms = [Mounting(name="m", bearing=pair, inner=0, outer=GROUND, inner_centre=(1e-4, 0.0))]
    planar, spatial = BearingSet(ms, 1, backend="numpy"), SpatialBearingSet(ms, 2, {0: 1})
    pose = np.array([[2e-6, -3e-6, 0.3]])
    a, b = planar.evaluate(pose), spatial.evaluate(np.vstack([pose, np.zeros((1, 3))]))
    assert np.max(np.abs(a.Q - b.Q[:3])) <= 1e-12 * np.max(np.abs(a.Q))
    assert np.max(np.abs(a.dQdq - b.dQdq[:3, :3])) <= 1e-12 * np.max(np.abs(a.dQdq))
    # the planar observation of the axial force per row is the spatial element's fed-back one
    rp, rs = planar.resultants(pose)["m"], spatial.resultants(np.vstack([pose, np.zeros((1, 3))]))["m"]
    assert np.allclose(rp.row_axial_forces, rs.row_axial_forces, rtol=1e-12)


def test_preload_declarations():
    """Force, interference and end play give each row its declared axial state at zero load."""
    w, _, rows = flange_wrench(_pair(), np.zeros(5))
    assert rows == pytest.approx([-200.0, 200.0], rel=1e-9)        # opposed rows, pressed by the preload
    assert np.max(np.abs(w)) < 1e-9 * 200.0                           # balanced: no net wrench
    s = 4e-6
    _, _, rows = flange_wrench(_pair(axial_preload=0.0, interference=2 * s), np.zeros(5))
    assert rows[1] == pytest.approx(ROW.axial_force_at(s), rel=1e-9)
    _, K, rows = flange_wrench(_pair(axial_preload=0.0, end_play=4e-6), np.zeros(5))
    assert np.all(rows == 0.0)
    assert np.all(K == 0.0)                                           # free within the end play


@pytest.mark.parametrize("kw, key", [(dict(end_play=2e-6), "preload declared"),
                                      (dict(axial_preload=0.0, end_play=-1e-6), "end_play"),
                                      (dict(axial_preload=0.0, interference=1.0), "interference")])
def test_preload_errors_name_keys(kw, key):
    with pytest.raises(RvtoolInputError, match=key):
        _pair(**kw)


def test_design_key_errors():
    d = rvtool.load_design("rv40e")
    with pytest.raises(RvtoolInputError, match="bodies.carrier_coordinates"):
        dataclasses.replace(d.bodies, carrier_coordinates="3d")
    model = rvtool.build(d)
    with pytest.raises(RvtoolInputError, match=r"bodies.carrier_coordinates \(RV\)"):
        model.set_flange_load(0.0, (10.0, 0.0))


def test_moment_rigidity_pair_physics():
    """Tilt odd in the moment, opposed rows share it (back to back: one row loaded, the other
    relieved), and a preloaded pair is stiffer than the same pair with end play."""
    pair = _pair()
    q_p = flange_equilibrium(pair, (0, 0, 0, 50.0, 0))
    q_m = flange_equilibrium(pair, (0, 0, 0, -50.0, 0))
    assert q_p[3] > 0 and q_m[3] == pytest.approx(-q_p[3], rel=1e-9)
    t = MomentRigidityTest(reference_moment=50.0, axial_force=500.0)
    stiff = pair_moment_rigidity(pair, t)
    loose = pair_moment_rigidity(_pair(axial_preload=0.0, end_play=2e-6), t)
    assert stiff.rigidity > loose.rigidity > 0 and stiff.axial_stiffness > loose.axial_stiffness > 0
    assert np.all(np.diff(stiff.tilt) > 0)
    a = stiff.row_axial_forces
    assert np.allclose(a[:, 0], -a[:, 1], rtol=1e-9)                   # pure moment: no net axial force


@pytest.fixture(scope="module")
def rv40e_pair():
    d = rvtool.load_design("rv40e")
    return rvtool.build(d), rvtool.build(spatial_design(d))


def test_rv40e_spatial_reproduces_planar(rv40e_pair):
    """Without out-of-plane load the spatial carrier reproduces the planar static point (issue 32:
    1e-9 relative): the planar coordinates of every body and the output angle at 40 % rated torque,
    at two input angles (the warm-started second point included)."""
    from rvtool.solver.static import StaticSolver
    qs = []
    for m in rv40e_pair:
        m.set_output_torque(165.0)
        s = StaticSolver(m)
        qs.append([s.solve(0.0), s.solve(0.05, previous_angle=0.0)])
    (mp, ms), n = rv40e_pair, len(qs[0][0])
    for qp, qsp in zip(*qs):
        assert np.max(np.abs(qsp[:n] - qp)) <= 1e-9 * np.max(np.abs(qp))
        assert ms.body_pose(qsp, "carrier")[2] == pytest.approx(mp.body_pose(qp, "carrier")[2], rel=1e-9)
        assert np.max(np.abs(ms.flange_displacement(qsp))) < 1e-15      # nothing out of plane
        lp, ls = mp.main_bearing_loads(qp), ms.main_bearing_loads(qsp)
        assert np.allclose(lp.force, ls.force, rtol=1e-9, atol=1e-9 * np.abs(lp.force).max())


def test_rv40e_moment_rigidity_model_equals_pair(rv40e_pair):
    """The reducer model's moment rigidity equals the main bearing's alone (rigid housing, no
    out-of-plane load path through the drive train); the weak regularization springs (100 N/m,
    0.1 N m/rad against ~1e8 N m/rad) and the Newton tolerance bound the difference: 1e-6."""
    _, ms = rv40e_pair
    t = MomentRigidityTest(reference_moment=1000.0, levels=(0.0, 0.5, 1.0), axial_force=1000.0)
    r_model = moment_rigidity(ms, t)
    r_pair = pair_moment_rigidity(ms.design.main_bearing, t)
    assert r_model.rigidity == pytest.approx(r_pair.rigidity, rel=1e-6)
    assert r_model.axial_stiffness == pytest.approx(r_pair.axial_stiffness, rel=1e-6)
    assert np.allclose(r_model.row_axial_forces, r_pair.row_axial_forces, rtol=1e-6)
    # the load is removed after the protocol
    from rvtool.solver.static import StaticSolver
    assert np.max(np.abs(ms.flange_displacement(StaticSolver(ms).solve(0.0)))) < 1e-15


def test_device_backends_name_spatial_bodies(rv40e_pair):
    from rvtool.solver.backends import DeviceBackend, FusedBackend
    from rvtool.solver.backends.base import SPATIAL_BODIES_REASON
    _, ms = rv40e_pair
    assert DeviceBackend().supports(ms, "equilibria").reasons == (SPATIAL_BODIES_REASON,)
    assert SPATIAL_BODIES_REASON in FusedBackend().supports(ms, "dynamic").reasons


def test_validate_moment_rigidity_row():
    """`rvtool validate`'s moment-rigidity row: computed on the spatial carrier, reference moment the
    catalogue's allowable moment, and "no catalogue value" where the catalogue file prints none."""
    from rvtool import designs
    from rvtool.analysis import validate as V
    from rvtool.designs.catalogue import load_catalogue
    cat = load_catalogue(designs.catalogue_of("rv40e"))
    out = V.moment_rigidity_figure(rvtool.load_design("rv40e"), cat, None, quick=True)
    (row,) = out["rows"]
    assert row["figure"] == "moment_rigidity" and row["unit"] == "N m/arcmin"
    assert out["reference_moment_Nm"] == cat.figure("allowable_moment").value_si
    assert row["predicted"] == pytest.approx(out["result"]["moment_rigidity_Nm_per_arcmin"], rel=1e-12)
    assert row["predicted"] > 0
    assert (row["verdict"] == "no catalogue value") == (not cat.figures_of("moment_rigidity"))


@pytest.fixture(scope="module")
def rd40_pair():
    d = rvtool.load_design("rd40")
    ds = rvtool.replace_design(d, bodies={"flange_coordinates": "spatial"})
    return rvtool.build(d, bearing_model="rolling"), rvtool.build(ds, bearing_model="rolling")


def test_rd40_spatial_reproduces_planar(rd40_pair):
    """The cycloid topology's flange (bodies.flange_coordinates = "spatial", rolling bearings): without
    out-of-plane load the planar static points are reproduced to 1e-9 relative (issue 32)."""
    from rvtool.solver.static import StaticSolver
    qs = []
    for m in rd40_pair:
        m.set_output_torque(-np.sign(m.ratio) * 0.5 * m.design.rated_torque)
        s = StaticSolver(m)
        qs.append([s.solve(0.0), s.solve(0.02, previous_angle=0.0)])
    (mp, ms), n = rd40_pair, len(qs[0][0])
    for qp, qsp in zip(*qs):
        assert np.max(np.abs(qsp[:n] - qp)) <= 1e-9 * np.max(np.abs(qp))
        assert np.max(np.abs(ms.flange_displacement(qsp))) < 1e-15
        # the main bearing's rows: the same preload split (its radial load is ~0 here: balanced wheels)
        assert np.allclose(mp.main_bearing_loads(qp).row_axial_forces, ms.main_bearing_loads(qsp).row_axial_forces,
                           rtol=1e-9)
    assert set(mp.families) == set(ms.families)


def test_rd40_moment_rigidity_model_equals_pair(rd40_pair):
    _, ms = rd40_pair
    t = MomentRigidityTest(reference_moment=100.0, levels=(0.0, 0.5, 1.0), axial_force=500.0)
    r_model, r_pair = moment_rigidity(ms, t), pair_moment_rigidity(ms.design.main_bearing, t)
    # regularization springs (100 N/m, 0.1 N m/rad against ~5e6 N m/rad) bound the difference
    assert r_model.rigidity == pytest.approx(r_pair.rigidity, rel=1e-6)
    assert r_model.axial_stiffness == pytest.approx(r_pair.axial_stiffness, rel=1e-6)


def test_cycloid_spatial_flange_needs_rolling_rows():
    ds = rvtool.replace_design(rvtool.load_design("rd40"), bodies={"flange_coordinates": "spatial"})
    with pytest.raises(RvtoolInputError, match="bearing_model"):
        rvtool.build(ds)
    with pytest.raises(RvtoolInputError, match="bodies.flange_coordinates"):
        rvtool.replace_design(rvtool.load_design("rd40"), bodies={"flange_coordinates": "tilted"})


CROSSED = CrossedRollerBearing(inner_radius=0.060, roller_diameter=0.008, roller_length=0.008, n_rollers=40,
                               radial_clearance=-2e-6, n_slices=4, crowning=2e-6)


def test_crossed_roller_tangent_and_planar_equality():
    """Crossed-roller rows (rollers alternating +-alpha, laminae along each roller): analytic tangent
    vs central differences (1e-6, as for the balls; the lamina law is k delta^(10/9), smooth away
    from its activation), and the planar element's forces at zero axial and tilt displacement."""
    ms = [Mounting(name="m", bearing=CROSSED, inner=0, outer=GROUND)]
    s = SpatialBearingSet(ms, 2, {0: 1})
    pose = np.array([[3e-6, -2e-6, 0.21], [1e-6, 2e-5, -1e-5]])
    ev = s.evaluate(pose)
    K = _fd(s, pose, [1e-10, 1e-10, 1e-8, 1e-10, 1e-10, 1e-10])
    assert np.max(np.abs(ev.dQdq - K)) <= 1e-6 * np.max(np.abs(ev.dQdq))
    planar = BearingSet(ms, 1, backend="numpy")
    p0 = pose[:1]
    a, b = planar.evaluate(p0), s.evaluate(np.vstack([p0, np.zeros((1, 3))]))
    assert np.max(np.abs(a.Q - b.Q[:3])) <= 1e-12 * np.max(np.abs(a.Q))
    assert np.max(np.abs(a.dQdq - b.dQdq[:3, :3])) <= 1e-12 * np.max(np.abs(a.dQdq))


def test_crossed_roller_carries_moment_and_axial_load():
    """A crossed-roller row carries a moment and an axial force in both directions (its +alpha and
    -alpha rollers), odd in the load."""
    t = MomentRigidityTest(reference_moment=200.0, levels=(0.0, 0.5, 1.0), axial_force=1000.0)
    r = pair_moment_rigidity(CROSSED, t)
    assert r.rigidity > 0 and r.axial_stiffness > 0 and np.all(np.diff(r.tilt) > 0)
    qp = flange_equilibrium(CROSSED, (0, 0, 800.0, 0, 0))
    qm = flange_equilibrium(CROSSED, (0, 0, -800.0, 0, 0))
    assert qp[2] > 0 and qm[2] == pytest.approx(-qp[2], rel=1e-6)
    m_p = flange_equilibrium(CROSSED, (0, 0, 0, 150.0, 0))
    m_m = flange_equilibrium(CROSSED, (0, 0, 0, -150.0, 0))
    assert m_p[3] > 0 and m_m[3] == pytest.approx(-m_p[3], rel=1e-6)


SPATIAL_DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(
    __import__("warp").get_cuda_device_count() == 0, reason="no CUDA device"))]


@pytest.mark.parametrize("device", SPATIAL_DEVICES)
@pytest.mark.parametrize("bearing", ["pair", "end_play", "crossed"])
def test_spatial_row_kernel_equals_the_reference(bearing, device):
    """The Warp kernel of the spatial rows (warp_contacts.spatial_balls) against the NumPy reference
    (SpatialBearingSet.balls) at a loaded, tilted state where some elements have lost contact: the same
    expressions in another order (atan2, pow and the forward-mode sums), so the bound is some roundings
    of the largest entry, 1e-13 relative (measured ~4e-16); and the kernel's tangent against central
    differences (1e-6, the issue's check)."""
    pair = {"pair": _pair(), "end_play": _pair(axial_preload=0.0, end_play=2e-6), "crossed": CROSSED}[bearing]
    ms = [Mounting(name="m", bearing=pair, inner=0, outer=GROUND, inner_centre=(2e-4, -1e-4))]
    ref, kern = SpatialBearingSet(ms, 2, {0: 1}), SpatialBearingSet(ms, 2, {0: 1}, backend="warp", device=device)
    pose = np.array([[4e-6, -3e-6, 0.37], [3e-6, 2e-5, -1.5e-5]])
    a, b = ref.evaluate(pose), kern.evaluate(pose)
    assert 0 < np.count_nonzero(a.obs[:, 0]) < len(a.obs)
    for f in ("Q", "dQdq", "obs"):
        x, y = getattr(b, f), getattr(a, f)
        assert np.max(np.abs(x - y)) <= 1e-13 * np.max(np.abs(y)), f
    K = _fd(kern, pose, [1e-9, 1e-9, 1e-7, 1e-9, 1e-9, 1e-9] if bearing != "crossed"
            else [1e-10, 1e-10, 1e-8, 1e-10, 1e-10, 1e-10])
    assert np.max(np.abs(b.dQdq - K)) <= 1e-6 * np.max(np.abs(b.dQdq))


def test_spatial_flange_rows_are_summed_on_the_device():
    """rd40 with a spatial flange: the main bearing's spatial rows (backend "warp") join the merged
    element's device sums, which then span the retained coordinates too; the element's force and
    tangent equal the per-family host assembly (the identity ports reading the same rows; sums in
    another order: 1e-13 relative)."""
    d = rvtool.replace_design(rvtool.load_design("rd40"), bodies={"flange_coordinates": "spatial"})
    m = rvtool.build(d, bearing_model="rolling")
    host = m.contact_host
    main = next(mm for mm in host.members if mm.evaluator.name == "main_bearing")
    assert main.launchable and main.identity_ports
    rng = np.random.default_rng(3)
    q = 2e-6 * rng.standard_normal(host.n)
    v = np.zeros(host.n)
    Q, _ = host.evaluate(0.0, q, v)
    J = host.tangent(0.0, q, v)
    assert host.row_sums().n == host.n
    Qh, Jh = np.zeros(host.n), np.zeros((host.n, host.n))
    for mm in host.members:
        ev = mm.evaluator.evaluate(*mm.pose_velocity(q[mm.positions], v[mm.positions]), check=False)
        Qh[mm.positions] += ev.Q
        Jh[np.ix_(mm.positions, mm.positions)] += ev.dQdq
    assert np.max(np.abs(Q - Qh)) <= 1e-13 * np.max(np.abs(Qh))
    assert np.max(np.abs(J - Jh)) <= 1e-13 * np.max(np.abs(Jh))
