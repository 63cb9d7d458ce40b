"""Lobe-by-lobe pitch deviations of the cycloid wheels (issue 30, Deliver 3, helper tepitch): the design key
``wheels.lobe_pitch_deviations`` turns each lobe about the wheel centre by its accumulated pitch deviation
(``CycloidProfile.lobe_rotations``); the profile table, the NumPy reference and the Warp kernel (discrete and
analytic search) carry it alike, the analytic tangent holds, a design without it is unchanged bit for bit, and a
once-around accumulated pitch deviation gives the closed-form TE of the mesh kinematics."""
import dataclasses

import numpy as np
import pytest

import rvtool
from rvtool.assembly.cycloid import pin_meshes, wheel_profile
from rvtool.contact.circle_set import NormalLaw
from rvtool.contact.cycloid_set import CycloidPinSet, WheelPinMesh
from rvtool.errors import RvtoolInputError
from rvtool.geometry.cycloid import CycloidProfile, lobe_pitch_rotations
from rvtool.geometry.eccentric import journal_centre
from rvtool.variants.rv_tolerances import RV_FIELDS, RvToleranceSpec, load_rv_tolerances, sample_rv_design
from rvtool.variants.tolerances import Normal
from rvtool import designs
from warp_contacts import cycloid_pins_ref as ref


def _profile(**kw):
    base = dict(pin_circle_radius=0.05, pin_radius=0.003, n_pins=40, generating_eccentricity=0.0008)
    base.update(kw)
    return CycloidProfile(**base)


def _lobes(zg, amp=2e-5, seed=3):
    """Lobe rotations [rad] of ~1 um on a 50 mm wheel (a drawn accumulated pitch)."""
    return tuple(float(x) for x in np.random.default_rng(seed).normal(0.0, amp, zg))


def _devices():
    import warp as wp
    import warp_contacts.precision  # noqa: F401
    wp.init()
    return [d.alias for d in wp.get_devices()]


@pytest.fixture(scope="module")
def rv80e():
    return rvtool.load_design("rv80e")


def test_each_pitch_unit_turns_about_the_wheel_centre():
    """points() and the table turn each sample by its pitch unit's angle (unit j: the tooth space about the root
    at phi = 2 pi j / z_g, from tip to tip), blended linearly within 5 % of the pitch about the tips (continuous)."""
    pr = _profile()
    zg = pr.n_teeth
    lob = _lobes(zg)
    pt = dataclasses.replace(pr, lobe_rotations=lob)
    phi = np.random.default_rng(0).uniform(0, 2 * np.pi, 400)
    u = phi * zg / (2 * np.pi) + 0.5
    j, t = np.floor(u).astype(int) % zg, u - np.floor(u)
    inner = np.abs(t - 0.5) < 0.45
    d, dd = pt.lobe_turn(phi)
    assert np.array_equal(d[inner], np.asarray(lob)[j[inner]]) and not np.any(dd[inner])
    p0 = pr.points(phi)
    turned = np.column_stack([np.cos(d) * p0[:, 0] - np.sin(d) * p0[:, 1], np.sin(d) * p0[:, 0] + np.cos(d) * p0[:, 1]])
    np.testing.assert_allclose(pt.points(phi), turned, rtol=0, atol=1e-15)
    # continuous at every tip (t = 0 / 1): both units meet at the mean of their rotations
    tips = 2 * np.pi * (np.arange(zg) + 0.5) / zg
    for eps in (1e-9, -1e-9):
        np.testing.assert_allclose(pt.lobe_turn(tips + eps)[0], 0.5 * (np.asarray(lob) + np.roll(lob, -1)),
                                   rtol=0, atol=1e-11)        # slope ~3e-3 over eps
    # d' is the slope of d (central differences inside a blend)
    ph = tips + 0.02 * 2 * np.pi / zg
    h = 1e-7
    np.testing.assert_allclose(pt.lobe_turn(ph)[1], (pt.lobe_turn(ph + h)[0] - pt.lobe_turn(ph - h)[0]) / (2 * h),
                               rtol=1e-6)
    n = 30 * zg
    t0, t1 = pr.table(n), pt.table(n)
    order0, order1 = np.argsort(t0[5]), np.argsort(t1[5])       # the same generating angles, matched
    assert np.array_equal(t0[5][order0], t1[5][order1])
    d = pt.lobe_turn(t1[5][order1])[0]
    c, s = np.cos(d), np.sin(d)
    P0 = t0[0][order0]
    np.testing.assert_allclose(t1[0][order1], np.column_stack([c * P0[:, 0] - s * P0[:, 1], s * P0[:, 0] + c * P0[:, 1]]),
                               rtol=0, atol=1e-15)
    # normals: the turned curve's (finite differences of the turned points)
    ph = t1[5][order1]
    tang = (pt.points(ph + 1e-7) - pt.points(ph - 1e-7))
    tang /= np.linalg.norm(tang, axis=1)[:, None]
    np.testing.assert_allclose(t1[1][order1], np.column_stack([-tang[:, 1], tang[:, 0]]), rtol=0, atol=1e-6)
    assert np.array_equal(t1[2][order1], t0[2][order0])                                   # curvature unchanged
    assert np.all(np.diff(t1[3]) >= 0)                                                    # sorted by polar angle


def test_equal_lobe_rotations_are_the_rotation_modification():
    """Every lobe turned by d is the profile rotation d: the table and the analytic search agree to rounding."""
    pr = _profile(rotation_mod=0.003)
    d = 3e-5
    pl = dataclasses.replace(pr, lobe_rotations=(d,) * pr.n_teeth)
    pr2 = dataclasses.replace(pr, rotation_mod=pr.rotation_mod + d)
    n = 30 * pr.n_teeth
    # the two tables' arc-length sampling differs by rounding (generating angles ~1e-13 apart): points to 1e-14 m,
    # normals (turning fast on the tight flanks) to 1e-11
    for x, y, tol in zip(pl.table(n)[:2], pr2.table(n)[:2], (1e-14, 1e-11)):
        np.testing.assert_allclose(x, y, rtol=0, atol=tol)
    rng = np.random.default_rng(1)
    phi = rng.uniform(0, 2 * np.pi, 100)
    _, nn, _, _ = ref.analytic_point(pr2.analytic_parameters(), phi)
    p = pr2.points(phi) + 0.003 * nn + rng.normal(0, 1e-6, (100, 2))
    c1 = ref.search(pl.table(n), p, 40, pl.analytic_parameters())[0]
    c2 = ref.search(pr2.table(n), p, 40, pr2.analytic_parameters())[0]
    np.testing.assert_allclose(c1, c2, rtol=0, atol=1e-13)


def test_analytic_search_finds_the_closest_point_of_the_turned_lobe():
    """The analytic path's contact point is the closest point of the turned profile, blends included (brute force
    over 2e6 points: chordal error < 1e-12 m)."""
    from scipy.spatial import cKDTree
    pr = dataclasses.replace(_profile(equidistant_mod=1e-5), lobe_rotations=_lobes(39))
    zg, tab = pr.n_teeth, pr.table(30 * pr.n_teeth)
    rng = np.random.default_rng(2)
    phi = rng.uniform(0, 2 * np.pi, 100)
    d, dd = pr.lobe_turn(phi)
    _, nn, _, _ = ref.analytic_point_turned(pr.analytic_parameters()[:5], d, dd, phi)
    p = pr.points(phi) + 0.003 * nn + rng.normal(0, 1e-6, (100, 2))
    c = ref.search(tab, p, 40, pr.analytic_parameters())[0]
    dist, _ = cKDTree(pr.points(np.linspace(0, 2 * np.pi, 2_000_000, endpoint=False))).query(p)
    assert np.max(np.abs(np.linalg.norm(p - c, axis=1) - dist)) < 1e-10


def _scene(search, backend="warp", precision="float64", device="cpu"):
    pr = dataclasses.replace(_profile(), lobe_rotations=_lobes(39))
    mesh = WheelPinMesh(profile=pr, wheel_body=0, pin_body=1, face_width=0.008, n_slices=2, tilt_x=1e-4, clearance=5e-7,
                        normal=NormalLaw(law="line", stiffness=2e8, damping=30.0, ramp_depth=2e-6))
    s = CycloidPinSet([mesh], 2, backend=backend, precision=precision, device=device, search=search)
    psi, e = 0.3, pr.generating_eccentricity
    pose = np.array([[-e * np.sin(psi) + 2e-6, e * np.cos(psi) - 1e-6, -psi / 39 + 1.5e-5], [1e-6, -2e-6, 1e-5]])
    vel = np.array([[0.01, -0.02, 3.0], [0.005, 0.01, -0.5]])
    return s, pose, vel


@pytest.mark.parametrize("device", _devices())
@pytest.mark.parametrize("search", ["discrete", "analytic"])
@pytest.mark.parametrize("precision,tol", [("float64", 1e-9), ("float32", 2e-2)])
def test_kernel_matches_reference_with_lobe_rotations(search, precision, tol, device):
    """The Warp kernel against the NumPy reference on a wheel with lobe rotations (tolerances as
    tests/test_cycloid.py::test_kernel_matches_numpy_reference: rounding amplified by position / indentation)."""
    s_w, pose, vel = _scene(search, "warp", precision, device)
    s_n, _, _ = _scene(search, "numpy")
    a, b = s_w.evaluate(pose, vel), s_n.evaluate(pose, vel)
    assert np.count_nonzero(b.obs[:, ref.O_FN]) >= 4                  # a loaded scene
    for x, y in ((a.Q, b.Q), (a.dQdq, b.dQdq), (a.dQdv, b.dQdv)):
        assert np.max(np.abs(x - y)) <= tol * np.max(np.abs(y))


@pytest.mark.parametrize("search", ["discrete", "analytic"])
def test_tangent_with_lobe_rotations_matches_central_differences(search):
    """The analytic tangent (osculating arc of the turned lobe) against central differences of the kernel."""
    s, pose, vel = _scene(search, "warp")
    e = s.evaluate(pose, vel)
    assert np.min(np.abs(e.obs[:, ref.O_GAP])) > 3e-9        # no slice within the FD steps of switching
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


def test_lobe_pitch_rotations_accumulate_the_single_pitches():
    pr = _profile()
    zg, r = pr.n_teeth, pr.pin_circle_radius * pr.n_teeth / pr.n_pins
    f = np.zeros(zg)
    f[5], f[6] = 1e-6, -1e-6                   # lobe 5 one micrometre further along (clockwise), lobe 6 back in place
    rot = np.asarray(lobe_pitch_rotations(pr, f))
    s = np.zeros(zg)
    s[5] = 1e-6
    np.testing.assert_allclose(rot, -(s - s.mean()) / r, rtol=1e-12, atol=1e-20)
    assert abs(rot.mean()) < 1e-20                                    # no rigid turn of the wheel
    with pytest.raises(RvtoolInputError, match=r"shape \(39,\)"):
        lobe_pitch_rotations(pr, f[:-1])


def test_without_the_key_the_meshes_are_unchanged_bit_for_bit(rv80e):
    """No key: no lobe rotations; zero deviations: the same table, bit for bit (a turn by 0.0 is exact)."""
    d = rv80e
    assert d.wheels.lobe_pitch_deviations == ()
    _, meshes = pin_meshes(d)
    assert all(m.profile.lobe_rotations is None for m in meshes)
    z = d.replace(wheels={"lobe_pitch_deviations": [[0.0] * 39] * 2})
    p0, pz = wheel_profile(d, 1), wheel_profile(z, 1)
    assert pz.lobe_rotations == (0.0,) * 39
    for x, y in zip(p0.table(8 * 39), pz.table(8 * 39)):
        assert np.array_equal(x, y)
    assert pz.analytic_parameters()[:5] == p0.analytic_parameters()


@pytest.mark.parametrize("rows, match", [
    ([[0.0] * 39], r"wheels\.lobe_pitch_deviations has 1 rows; valid: 0 or one row per wheel \(2"),
    ([[0.0] * 38] * 2, r"wheels\.lobe_pitch_deviations\[0\] has 38 entries; valid: one per lobe, z_g = 39"),
    ([[1e-6] + [0.0] * 38] * 2, r"wheels\.lobe_pitch_deviations\[0\] sum to 1e-06 m; valid: sum 0"),
    ([[float("nan")] + [0.0] * 38] * 2, r"wheels\.lobe_pitch_deviations.* must be finite"),
])
def test_bad_lobe_pitch_deviations_name_the_key(rv80e, rows, match):
    with pytest.raises(RvtoolInputError, match=match):
        rv80e.replace(wheels={"lobe_pitch_deviations": rows})


def test_lobe_rotations_out_of_range_are_refused():
    with pytest.raises(RvtoolInputError, match=r"lobe_rotations = .* outside the valid range"):
        _profile(lobe_rotations=(0.02,) * 39)


def test_the_tolerance_field_is_drawn_last_per_wheel_and_closes_each_circle(rv80e):
    d = rv80e
    i = RV_FIELDS.index("wheel_lobe_pitch_deviation")          # the fields after it: tests/test_te_coaxiality.py
    assert i == 12
    full = load_rv_tolerances(designs.path("rv80e_tolerances"))
    full = RvToleranceSpec(**{k: getattr(full, k) for k in RV_FIELDS[:i + 1]})
    assert isinstance(full.wheel_lobe_pitch_deviation, Normal)
    dv, drawn = sample_rv_design(full, d, 3, 2026)
    f = np.asarray(dv.wheels.lobe_pitch_deviations)
    assert f.shape == (2, 39) and np.max(np.abs(f.sum(axis=1))) < 1e-18 and not np.array_equal(f[0], f[1])
    old = RvToleranceSpec(**{k: getattr(full, k) for k in RV_FIELDS[:i]})
    do, drawn_o = sample_rv_design(old, d, 3, 2026)
    for k in RV_FIELDS[:i]:
        assert np.array_equal(np.asarray(drawn[k], float), np.asarray(drawn_o[k], float)), k
    assert do.wheels == d.wheels
    # the contact meshes of the variant carry each wheel's own lobe rotations
    _, meshes = pin_meshes(dv)
    for k, m in enumerate(meshes):
        assert m.profile.lobe_rotations == lobe_pitch_rotations(m.profile, f[k])


def test_once_around_pitch_deviation_gives_the_closed_form_te(rv80e):
    """Closed form (task 3 of the brief). A rigid wheel on its eccentric, rigid pins, linear contact law of equal
    stiffness k, output torque T: a pin at angle phi from the line of centres has the lever arm
    r = e z_g sin(phi) / S, S = sqrt(1 - 2 K1 cos(phi) + K1^2) (the normal passes through the pitch point), and
    a wheel rotation theta moves its gap by -theta r; a lobe turned by d_j moves it by -d_j r. With every pin of
    r > 0 loaded, T = k sum r^2 (theta + d_j) so the TE moves by -sum r^2 d_j / sum r^2 (the lobe j of each pin is
    that of its generating angle a_k - chi / z_g at input angle chi, the rotation there the profile's
    lobe_turn: its unit's, blended near the tips). For an accumulated pitch s_j = A sin(2 pi j / z_g + psi) (d_j = -s_j / r_ref, r_ref = R_z z_g / z_b) the first harmonic of the TE, at z_b / z_g
    per input revolution, has the amplitude (A / r_ref) sinc(pi / z_g) C1 in the continuum of pins, with
    C1 = |I_c + i I_s| / (pi / 2), I_c = pi K1 / 4, I_s = (1 + K1^2) / (2 K1^2) - (1 - K1^2)^2 / (4 K1^3)
    ln((1 + K1) / (1 - K1)) (the integrals of r^2 cos(phi), r^2 sin(phi) over the loaded half; -> 8 / (3 pi) for
    K1 -> 0). Measured: pointwise within 1e-3 of A / r_ref (8e-4 measured; the rest is the second order in theta),
    the first harmonic within 2 % of the continuum (0.9 % measured: 20 discrete loaded pins)."""
    # rv80e's conjugate profile (its equidistant and offset modifications left out: with their clearance the pins
    # near the line of centres would leave the loaded set)
    pr = dataclasses.replace(rv80e.profile, equidistant_mod=0.0, offset_mod=0.0)
    R, zb, e = pr.pin_circle_radius, pr.n_pins, pr.generating_eccentricity
    zg, K1 = zb - 1, pr.K1
    r_ref = R * zg / zb
    A, psi, k, T = 1e-7, 0.7, 2e8, 50.0
    j = np.arange(zg)
    s = A * np.sin(2 * np.pi * j / zg + psi)                         # at each unit's root
    f = s - np.roll(s, 1)                                             # f_j = s_j - s_(j-1)
    lob = np.asarray(lobe_pitch_rotations(pr, f))
    np.testing.assert_allclose(lob, -s / r_ref, rtol=0, atol=1e-12 * A / r_ref)

    chis = np.linspace(0.0, 2 * np.pi * zg / zb, 64, endpoint=False)   # one turn of the load zone on the wheel

    def te(prof):
        mesh = WheelPinMesh(profile=prof, wheel_body=0, face_width=0.01,
                            normal=NormalLaw(law="line", stiffness=k, damping=0.0, ramp_depth=1e-9))
        st = CycloidPinSet([mesh], 1, backend="warp", search="analytic")
        out = []
        for chi in chis:
            x, y = journal_centre(e, 0.0, chi)
            th = -chi / zg + 5e-6        # a little into the load (~T / (k sum r^2)): some contact carries stiffness
            for _ in range(30):
                ev = st.evaluate(np.array([[x, y, th]]), np.zeros((1, 3)))
                step = -(ev.Q[2] - T) / ev.dQdq[2, 2]
                th += step
                if abs(step) < 1e-16:
                    break
            assert abs(ev.Q[2] - T) < 1e-8 * T
            out.append(th + chi / zg)
        return np.array(out)

    prof_dev = dataclasses.replace(pr, lobe_rotations=tuple(lob))
    d_te = te(prof_dev) - te(pr)
    a = 2 * np.pi * np.arange(zb) / zb
    pred = []
    for chi in chis:
        phi = a + chi
        r = e * zg * np.sin(phi) / np.sqrt(1 - 2 * K1 * np.cos(phi) + K1 ** 2)
        turn = prof_dev.lobe_turn(np.mod(a - chi / zg, 2 * np.pi))[0]        # the input field at each contact
        on = r > 0
        pred.append(-np.sum(r[on] ** 2 * turn[on]) / np.sum(r[on] ** 2))
    assert np.max(np.abs(d_te - np.array(pred))) < 1e-3 * A / r_ref
    w = zb / zg
    c = np.linalg.lstsq(np.column_stack([np.cos(w * chis), np.sin(w * chis), np.ones_like(chis)]), d_te, rcond=None)[0]
    Ic = np.pi * K1 / 4
    Is = (1 + K1 ** 2) / (2 * K1 ** 2) - (1 - K1 ** 2) ** 2 / (4 * K1 ** 3) * np.log((1 + K1) / (1 - K1))
    closed = A / r_ref * np.sinc(1.0 / zg) * np.hypot(Ic, Is) / (np.pi / 2)
    assert abs(np.hypot(c[0], c[1]) / closed - 1.0) < 0.02


def test_lobe_rotations_are_not_a_design_file_key(rv80e):
    """The design gives wheels.lobe_pitch_deviations [m]; the profile's lobe_rotations [rad] are the code's (no
    angle key without _deg in a file, nor in the format doc)."""
    from rvtool.designs.format import format_doc
    with pytest.raises(RvtoolInputError, match=r"\[profile\] has unknown keys \['lobe_rotations'\]"):
        rv80e.replace(profile={"lobe_rotations": [0.0] * 39})
    doc = format_doc()
    assert "`lobe_rotations`" not in doc and "`lobe_pitch_deviations` | m |" in doc


def test_device_profile_tables_leave_lobed_profiles_to_the_host():
    """The device table kernels (warp_contacts.profile_tables) compute no lobe rotations: a deferred table of a
    lobed profile is left to the host (computed where read, with its lobes), a plain one is computed on the
    device; nothing is dropped silently."""
    from rvtool.contact.cycloid_set import ProfileTable, _shared_entry, compute_profile_tables
    pr = _profile()
    lobed = dataclasses.replace(pr, lobe_rotations=_lobes(pr.n_teeth))
    tabs = [ProfileTable(p, 8 * pr.n_teeth, "analytic", 0.05, 0.01) for p in (pr, lobed)]
    assert not any(t.computed for t in tabs)
    assert compute_profile_tables(tabs, "cpu") == 1
    assert tabs[0].computed and not tabs[1].computed
    host = _shared_entry(*tabs[1].key)
    assert all(np.array_equal(a, b) for a, b in zip(tabs[1].entry[0], host[0]))
    assert len(tabs[1].entry[1]) == 6 and tabs[1].entry[1][5] == lobed.lobe_rotations      # the analytic row's lobes


def test_lobe_pitch_grade_follows_the_cited_formula(rv80e):
    """wheel_lobe_pitch_deviation of rv80e_tolerances.toml: 3 std = f_pT of ISO 1328-1:2013 class 5, (0.001 d + 0.4 m
    + 5) um rounded to 0.5 um, of the analogue gear m = 2 R_z / z_b, z = z_g (std written to 4 digits)."""
    import tomllib
    with open(designs.path("rv80e_tolerances"), "rb") as fh:
        t = tomllib.load(fh)["tolerances"]["wheel_lobe_pitch_deviation"]
    m = 2e3 * rv80e.pins.pin_circle_radius / rv80e.pins.n_pins
    d = m * (rv80e.pins.n_pins - 1)
    f_pt = round(2 * (0.001 * d + 0.4 * m + 5.0)) / 2
    assert t["dist"] == "normal" and t["mean"] == 0.0
    assert 3 * t["std"] * 1e6 == pytest.approx(f_pt, abs=2e-3) and f_pt == 6.5
