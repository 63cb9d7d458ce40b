"""Cycloid geometry, the cycloid--pin contact family and the assembled reducer."""
import os

import numpy as np
import pytest
import scipy.spatial

from rvtool.contact.circle_set import NormalLaw
from rvtool.contact.cycloid_set import CycloidPinSet, WheelPinMesh
from rvtool.errors import RvtoolInputError
from rvtool.geometry.cycloid import CycloidProfile, pin_centres
from warp_contacts import cycloid_pins_ref as ref
from rvtool import designs

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RD40 = designs.path("rd40")


def _profile(**kw):
    base = dict(pin_circle_radius=0.05, pin_radius=0.003, n_pins=40, generating_eccentricity=0.0008)
    base.update(kw)
    return CycloidProfile(**base)


def test_profile_is_the_inward_offset_of_the_epitrochoid():
    """Independent construction: offset the pin-centre path E(phi) by r_c along its
    numerically differentiated inward normal; curvature from finite differences."""
    pr = _profile()
    phi = np.linspace(0.01, 1.0, 500)
    R, e, zb = pr.R, pr.generating_eccentricity, pr.n_pins
    # pin-centre path of a pin circle R with the wheel centre moved by e (independent of K1 notation)
    E = np.column_stack([R * np.sin(phi) - e * np.sin(zb * phi), R * np.cos(phi) - e * np.cos(zb * phi)])
    h = 1e-6
    Ep = np.column_stack([R * np.sin(phi + h) - e * np.sin(zb * (phi + h)), R * np.cos(phi + h) - e * np.cos(zb * (phi + h))])
    Em = np.column_stack([R * np.sin(phi - h) - e * np.sin(zb * (phi - h)), R * np.cos(phi - h) - e * np.cos(zb * (phi - h))])
    t = (Ep - Em) / np.linalg.norm(Ep - Em, axis=1)[:, None]
    inward = np.column_stack([t[:, 1], -t[:, 0]])          # clockwise curve: inward is the tangent turned -90 deg
    np.testing.assert_allclose(pr.points(phi), E + pr.pin_radius * inward, atol=1e-10)
    # curvature: osculating fit of three neighbouring points vs the analytic offset relation
    P0, P1, P2 = pr.points(phi - 1e-4), pr.points(phi), pr.points(phi + 1e-4)
    a, b, c = (np.linalg.norm(P1 - P0, axis=1), np.linalg.norm(P2 - P1, axis=1), np.linalg.norm(P2 - P0, axis=1))
    cross = (P1 - P0)[:, 0] * (P2 - P0)[:, 1] - (P1 - P0)[:, 1] * (P2 - P0)[:, 0]
    k_num = -2 * cross / (a * b * c)                        # signed Menger curvature, convex-outward positive
    np.testing.assert_allclose(pr.curvature_of_points(phi), k_num, rtol=1e-4, atol=1e-2)


@pytest.mark.parametrize("psi", [0.0, 0.37, 1.9, 4.0])
def test_conjugate_meshing_at_every_input_angle(psi):
    """With the wheel centre at e(-sin psi, cos psi) and the wheel turned by -psi/z_g,
    every pin centre lies exactly r_p off the unmodified profile (zero clearance)."""
    from scipy.spatial import cKDTree
    pr = _profile()
    tree = cKDTree(pr.points(np.linspace(0, 2 * np.pi, 600000, endpoint=False)))
    e = pr.generating_eccentricity
    cw = e * np.array([-np.sin(psi), np.cos(psi)])
    th = -psi / pr.n_teeth
    d = pin_centres(pr) - cw
    loc = np.column_stack([np.cos(th) * d[:, 0] + np.sin(th) * d[:, 1], -np.sin(th) * d[:, 0] + np.cos(th) * d[:, 1]])
    dist, _ = tree.query(loc)
    # 600k samples on a 0.3 m curve: 5e-7 m spacing -> chordal error ~ kappa h^2 / 8 < 1e-10 m
    assert np.max(np.abs(dist - pr.pin_radius)) < 2e-9


def test_feasibility_errors_name_the_parameter():
    with pytest.raises(RvtoolInputError, match="K1"):
        _profile(generating_eccentricity=0.002)
    with pytest.raises(RvtoolInputError, match="undercut"):
        _profile(pin_radius=0.0038, generating_eccentricity=0.0012)
    with pytest.raises(RvtoolInputError, match="overlap"):
        _profile(pin_radius=0.0045)
    from rvtool.assembly.spec import design_from_dict, load_design, replace
    d = load_design(RD40)
    with pytest.raises(RvtoolInputError, match="n_teeth"):
        replace(d, wheels={"n_teeth": 38})
    import tomllib
    raw = tomllib.load(open(RD40, "rb"))
    raw["pins"]["pin_radiuss"] = 1.0
    with pytest.raises(RvtoolInputError, match="pin_radiuss"):
        design_from_dict(raw)
    with pytest.raises(RvtoolInputError, match="samples_per_tooth"):
        CycloidPinSet([WheelPinMesh(profile=_profile(), wheel_body=0, face_width=0.008,
                                    normal=NormalLaw(law="line", stiffness=1e8))], 1, samples_per_tooth=2)


def _pin_scene(precision="float64", backend="warp", device="cpu", damping=300.0):
    pr = _profile()
    mesh = WheelPinMesh(profile=pr, wheel_body=0, pin_body=1, face_width=0.008, n_slices=2, tilt_x=1e-4, tilt_y=-2e-4,
                        crowning=1e-6, clearance=5e-7,
                        normal=NormalLaw(law="line", stiffness=2e8, damping=damping, ramp_depth=2e-6))
    s = CycloidPinSet([mesh], 2, backend=backend, precision=precision, device=device)
    psi = 0.3
    e = pr.generating_eccentricity
    pose = np.array([[-e * np.sin(psi) + 2e-6, e * np.cos(psi) - 1e-6, -psi / 39 + 1.5e-5], [1e-6, -2e-6, 1e-5]])
    vel = np.array([[0.01, -0.02, 3.0], [0.005, 0.01, -0.5]])
    return s, pose, vel


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401
    wp.init()
    return [d.alias for d in wp.get_devices()]


@pytest.mark.parametrize("device", _devices())
@pytest.mark.parametrize("precision,tol", [("float64", 1e-9), ("float32", 2e-2)])
def test_kernel_matches_numpy_reference(precision, tol, device):
    """The gap is a difference of positions ~5e-2 m for indentations ~1e-6 m, which amplifies
    rounding by ~5e4. float64: another operation order (fused multiply-add on GPUs) gives
    ~1e-16 x 5e4 ~ 1e-11 (measured 6e-11 on an H100, 0 on the CPU); 1e-9 leaves margin.
    float32: ~4e-9 m rounding against ~1e-6 m gives ~5e-3; 2e-2 leaves margin."""
    s_w, pose, vel = _pin_scene(precision, "warp", device)
    s_n, _, _ = _pin_scene("float64", "numpy")
    a, b = s_w.evaluate(pose, vel), s_n.evaluate(pose, vel)
    for x, y in ((a.Q, b.Q), (a.dQdq, b.dQdq), (a.dQdv, b.dQdv)):
        assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y))


def test_windowed_search_finds_the_global_nearest_sample():
    s, pose, vel = _pin_scene(backend="numpy")
    tab = s.tables[0]
    pins = pin_centres(s.meshes[0].profile)
    th = pose[0, 2]
    d = pins + pose[1, :2] - pose[0, :2]
    loc = np.column_stack([np.cos(th) * d[:, 0] + np.sin(th) * d[:, 1], -np.sin(th) * d[:, 0] + np.cos(th) * d[:, 1]])
    _, _, _, clamped, dist = ref.search(tab, loc, s.window)
    glob = np.min(np.linalg.norm(tab[0][None, :, :] - loc[:, None, :], axis=2), axis=1)
    np.testing.assert_allclose(dist, glob, rtol=0, atol=1e-15)
    assert not np.any(clamped)


@pytest.mark.parametrize("modification", [{}, {"equidistant_mod": 2e-5, "offset_mod": -1e-5}])
def test_pin_curve_window_holds_the_nearest_sample_within_the_band(modification):
    """Points at every sample's normal, (1 +- band) r_p off the profile (and between), with a
    random tangential scatter of a few samples: the window search returns the global nearest
    sample; points beyond the band are never given a distance below the true one."""
    pr = _profile(**modification)
    mesh = WheelPinMesh(profile=pr, wheel_body=0, face_width=0.008, normal=NormalLaw(law="line", stiffness=1e8))
    s = CycloidPinSet([mesh], 1, backend="numpy", search_band=0.05)
    tab = s.tables[0]
    P, N, h = tab[0], tab[1], tab[4]
    assert s.window <= 20            # vs 56 with the profile-keyed polar search
    rng = np.random.default_rng(3)
    i = rng.integers(0, len(P), 4000)
    f = rng.uniform(0.95, 1.05, len(i))
    t = np.column_stack([-N[:, 1], N[:, 0]])[i]
    pts = P[i] + (f * pr.pin_radius)[:, None] * N[i] + (rng.uniform(-3, 3, len(i)) * h)[:, None] * t
    # the global nearest sample by an exact k-d tree query (the all-pairs distance array it replaces
    # held 4000 x 4800 points)
    tree = scipy.spatial.cKDTree(P)
    glob = tree.query(pts)[0]
    _, _, _, _, dist = ref.search(tab, pts, s.window)
    np.testing.assert_allclose(dist, glob, rtol=0, atol=1e-15)
    far = P[i] + (rng.uniform(1.05, 1.6, len(i)) * pr.pin_radius)[:, None] * N[i]
    glob = tree.query(far)[0]
    _, _, _, _, dist = ref.search(tab, far, s.window)
    assert np.all(dist >= glob - 1e-15)
    with pytest.raises(RvtoolInputError, match="search_band"):
        CycloidPinSet([mesh], 1, backend="numpy", search_band=0.0)


def test_identical_profiles_share_one_table():
    law = NormalLaw(law="line", stiffness=1e8)
    a = WheelPinMesh(profile=_profile(), wheel_body=0, face_width=0.008, normal=law)
    b = WheelPinMesh(profile=_profile(), wheel_body=1, face_width=0.008, normal=law)
    c = WheelPinMesh(profile=_profile(equidistant_mod=1e-5), wheel_body=2, face_width=0.008, normal=law)
    s = CycloidPinSet([a, b, c], 3, backend="numpy")
    assert len(s.tables) == 2
    assert s.iparams[:, ref.J_TABLE].tolist() == [0] * 40 + [0] * 40 + [1] * 40


@pytest.mark.parametrize("damping", [0.0, 30.0])
def test_pin_tangent_matches_central_differences(damping):
    """Away from switching (no slice within 3 FD steps (3e-9 m) of opening)."""
    s, pose, vel = _pin_scene(backend="numpy", damping=damping)
    e = s.evaluate(pose, vel)
    assert np.min(np.abs(e.obs[:, ref.O_GAP])) > 3e-9
    n = 6
    Kq, Kv = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        b, c = divmod(j, 3)
        for K, which, h in ((Kq, 0, 1e-9 if c < 2 else 1e-8), (Kv, 1, 1e-6 if c < 2 else 1e-4)):
            P, V = pose.copy(), vel.copy()
            (P, V)[which][b, c] += h
            qp = s.evaluate(P, V).Q
            P, V = pose.copy(), vel.copy()
            (P, V)[which][b, c] -= h
            K[:, j] = (qp - s.evaluate(P, V).Q) / (2 * h)
    assert np.linalg.norm(e.dQdq - Kq) / np.linalg.norm(Kq) < 1e-6
    if damping == 0.0:
        assert not np.any(e.dQdv) and not np.any(Kv)   # no friction, no damping: no velocity dependence
    else:
        assert np.linalg.norm(e.dQdv - Kv) / np.linalg.norm(Kv) < 1e-6


@pytest.fixture(scope="module")
def rated_rd40():
    from rvtool.assembly.cycloid import build
    from rvtool.assembly.spec import load_design, replace
    from rvtool.solver.static import StaticSolver
    # main-bearing clearance keeps the (unloaded, symmetric) main bearing off its activation kink,
    # where central differences would straddle the switch
    d = replace(load_design(RD40), wheels={"samples_per_tooth": 60}, main_bearing={"radial_clearance": 2e-6})
    m = build(d)
    solver = StaticSolver(m)
    m.set_output_torque(d.rated_torque)
    q = solver.solve(0.0)
    return d, m, solver, q


def test_assembled_element_tangents_at_the_rated_state(rated_rd40):
    """Every contact element's analytic tangent vs central differences at the loaded state
    (contacts within 3 FD steps of opening would make the differences straddle a switch)."""
    d, m, solver, q = rated_rd40
    rng = np.random.default_rng(0)
    for name, el in m.elements.items():
        ql = el.local(q)
        vl = rng.normal(0, 1e-4, ql.shape)
        ev = el.evaluate(0.0, ql, vl)
        assert np.min(np.abs(ev.obs[:, 2])) > 3e-9, name
        K = np.zeros_like(ev.dQdq)
        for j in range(len(ql)):
            h = 1e-9 if j % 3 < 2 else 1e-8
            qp, qm = ql.copy(), ql.copy()
            qp[j] += h
            qm[j] -= h
            K[:, j] = (el.evaluate(1.0 + j, qp, vl).Q - el.evaluate(2.0 + j, qm, vl).Q) / (2 * h)
        assert np.linalg.norm(ev.dQdq - K) / np.linalg.norm(K) < 1e-5, name


def test_loaded_state_balances_the_torque(rated_rd40):
    """Sum of pin-force moments about the housing centre equals the output torque (statics)."""
    d, m, solver, q = rated_rd40
    from warp_contacts.circle_pairs_ref import O_FN, O_NX, O_NY, O_PX, O_PY
    el = m.elements["pins"]
    ev = el.evaluate(0.0, el.local(q), np.zeros(len(el.local(q))))
    f_on_pin = ev.obs[:, O_FN][:, None] * ev.obs[:, O_NX:O_NY + 1]
    pins = np.vstack([pin_centres(m.profiles[0])] * 1)
    # moment about the origin of the forces on the fixed pins (acting at the pin centres)
    ids = el.evaluator.pin_of
    M = np.sum(pins[ids, 0] * f_on_pin[:, 1] - pins[ids, 1] * f_on_pin[:, 0])
    # the housing reacts the input + output torques; the input torque is T / |i|
    T = d.rated_torque
    assert abs(abs(M) - T * (1 + 1 / abs(d.ratio))) < 2e-3 * T


def test_kinematic_ratio_of_contact_driven_rotation(rated_rd40):
    """Light load, wheels on rigid journals, clearance-free output pins (their clearance
    adds a phase-dependent lost motion): over one mesh cycle the flange turns by
    input / i (i = -z_g) to within the small elastic TE variation."""
    from rvtool.assembly.cycloid import build
    from rvtool.assembly.spec import replace
    from rvtool.protocols.precision import quasi_static_te
    d, _, _, _ = rated_rd40
    d = replace(d, output_pins={"hole_radius": d.output_pins.pin_radius + d.wheels.eccentricity})
    m = build(d, rigid_supports=True)
    ang = np.linspace(0, 2 * np.pi / d.pins.n_pins, 9)
    r = quasi_static_te(m, torque=1.0, input_angles=ang)
    ratio = (r["theta_in"][-1] - r["theta_in"][0]) / (r["theta_out"][-1] - r["theta_out"][0])
    assert abs(ratio / d.ratio - 1) < 1e-4


def test_analytic_search_finds_the_exact_closest_point():
    """Analytic path vs a brute-force dense sampling (2e6 points, chordal error < 1e-12 m)."""
    from scipy.spatial import cKDTree
    pr = _profile(rotation_mod=0.01, equidistant_mod=1e-5)
    tab = pr.table(30 * pr.n_teeth)
    rng = np.random.default_rng(0)
    phi = rng.uniform(0, 2 * np.pi, 100)
    _, n, _, _ = ref.analytic_point(pr.analytic_parameters(), phi)
    p = pr.points(phi) + 0.003 * n + rng.normal(0, 1e-6, (100, 2))
    c, _, _, clamped, _ = ref.search(tab, p, 40, pr.analytic_parameters())
    dist, _ = cKDTree(pr.points(np.linspace(0, 2 * np.pi, 2_000_000, endpoint=False))).query(p)
    assert np.max(np.abs(np.linalg.norm(p - c, axis=1) - dist)) < 1e-10 and not clamped.any()
    with pytest.raises(RvtoolInputError, match="radial_mod_table"):
        _profile(radial_mod_table=((0.0, 0.0), (0.1, 1e-6))).analytic_parameters()


@pytest.mark.parametrize("backend", ["numpy", "warp"])
def test_analytic_search_tangent_and_backends(backend):
    pr = _profile()
    mesh = WheelPinMesh(profile=pr, wheel_body=0, pin_body=1, face_width=0.008, n_slices=2, clearance=5e-7,
                        normal=NormalLaw(law="line", stiffness=2e8, damping=30.0, ramp_depth=2e-6))
    s = CycloidPinSet([mesh], 2, backend=backend, search="analytic")
    s_ref = CycloidPinSet([mesh], 2, backend="numpy", search="analytic")
    _, pose, vel = _pin_scene(backend="numpy")
    e = s.evaluate(pose, vel)
    np.testing.assert_allclose(e.Q, s_ref.evaluate(pose, vel).Q, rtol=0, atol=1e-12 * np.abs(e.Q).max())
    K = np.zeros((6, 6))
    for j in range(6):
        b, c = divmod(j, 3)
        h = 1e-9 if c < 2 else 1e-8
        P = pose.copy()
        P[b, c] += h
        qp = s.evaluate(P, vel).Q
        P = pose.copy()
        P[b, c] -= h
        K[:, j] = (qp - s.evaluate(P, vel).Q) / (2 * h)
    assert np.linalg.norm(e.dQdq - K) / np.linalg.norm(K) < 1e-6
