"""Local reduced radius of the film contacts (rvtool.slow.contact_radius)."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.pressure.state import pin_contact
from rvtool.slow import cycloid as C
from rvtool.slow.contact_radius import ContactCurvature, ProfileLocator, window_radii
from rvtool.slow.reducer_windows import ReducerWindows, WindowProtocol
from rvtool.solver.static import StaticSolver
from warp_contacts import involute_pairs_ref as iref

RD40 = load_design(designs.path("rd40"))


@pytest.fixture(scope="module")
def rd40_window():
    m = build(RD40)
    w = ReducerWindows(m, WindowProtocol(torque=RD40.rated_torque, input_speed=RD40.input_speed_rpm * np.pi / 30,
                                         window_angle=m.mesh_period, steps=4))
    x = w.window()
    return m, w, x


def test_profile_locator_finds_the_foot_point_curvature(rd40_window):
    m, _, _ = rd40_window
    prof = m.family_spec(Family.PINS)[0].profile
    loc = ProfileLocator(prof)
    rng = np.random.default_rng(3)
    phi = rng.uniform(0, 2 * np.pi, 40)
    p = prof.points(phi)
    # a point 1 um off the profile along its normal has the same foot point (the contact point of an
    # observation lies within the approach of a few um of the profile)
    d = prof.points(phi + 1e-7) - prof.points(phi - 1e-7)
    n = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
    for q in (p, p + 1e-6 * n):
        # Newton on the foot point converges to round-off; the curvature's phi derivative times the
        # residual foot error (< 1e-9 rad) gives < 1e-6 relative
        assert np.allclose(loc.curvature_at(q), prof.curvature_of_points(phi), rtol=1e-6, atol=1e-3)


def test_pin_radius_matches_the_pressure_module_gap_curvature(rd40_window):
    """1/R = 1/r_p + kappa_flank at the peak contact against the pressure module's R, the second
    difference of the tabulated gap (spline of 20,001 profile points, probe 2 % of 1 mm): an
    independent numerical route; they agree to its truncation (measured 2.5e-4)."""
    m, w, _ = rd40_window
    _, _, q = w.last_states[1]
    ob, kap = ContactCurvature(m).rows(q, Family.PINS)
    names, F = ob.per_contact()
    c = names[int(np.argmax(F))]
    wheel, pin = c.split("/")
    R_ref = pin_contact(m, q, int(wheel[5:]), int(pin[3:])).radius
    rows = [i for i, r in enumerate(ob.ids) if r.startswith(c + "/")]
    assert abs(1.0 / np.mean(kap[rows]) - R_ref) <= 1e-3 * R_ref


def test_window_radii_and_the_film_they_give(rd40_window):
    m, w, x = rd40_window
    R = window_radii(m, w.last_states)
    rp = RD40.pins.pin_radius
    assert R and all(k.startswith("pins/") for k in R)
    loaded = {c for c, f in zip(x.ids, x.I_F) if c.startswith("pins/") and f > 0}
    assert set(R) == loaded
    # RD-40's flank is convex where most pins are loaded (R below r_p) and concave near the root,
    # where a few pins start their engagement (R above r_p)
    v = np.array(list(R.values()))
    assert np.all(v > 0) and 0.3 * rp < np.median(v) < rp and np.max(v) > rp
    lub0 = C.lubrication(RD40, C.CycloidSlowInputs(), x)
    lub1 = C.lubrication(RD40, C.CycloidSlowInputs(), x, radii=R)
    T = {n: 330.0 for n in C.NODES}
    f0, f1 = lub0.evaluate(x, T), lub1.evaluate(x, T)
    k = x.ids.index(next(iter(R)))
    # Dowson--Higginson: h ~ R^(1 - 0.70 + 0.13) at fixed load, speed and lubricant
    assert f1.h_min[k] / f0.h_min[k] == pytest.approx((R[x.ids[k]] / rp) ** 0.43, rel=1e-12)
    with pytest.raises(RvtoolInputError, match="output_pins"):
        C.lubrication(RD40, C.CycloidSlowInputs(), x, radii={"output_pins/output_pins/pin0/wheel0": 1e-3})
    with pytest.raises(RvtoolInputError, match="output_pins"):
        window_radii(m, w.last_states, families=[Family.OUTPUT_PINS])


def test_involute_curvature_is_the_roll_length_of_both_flanks():
    """Involute flank at radius r: curvature radius sqrt(r^2 - r_b^2) (the tangent length to the base
    circle); internal ring: 1/R = 1/rho_A - 1/rho_B. The observed contact point is the mid point
    of both flank points, which lie on the line of action |g| apart (the series law's approach), so
    rho_A = rho_A(mid) - g / 2 and rho_B = rho_B(mid) + g / 2; the comparison is then to round-off
    amplified by rho_A rho_B / (rho_B - rho_A) ~ 300 of the conformal small-tooth-difference pair."""
    d = load_design(designs.path("std_involute"))
    m = build(d)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    ob, kap = ContactCurvature(m).rows(q, Family.INVOLUTE_STAGE)
    mesh = {mm.name: mm for mm in m.family_element(Family.INVOLUTE_STAGE).evaluator.meshes}
    line = np.flatnonzero((ob.normal_force > 0) & (ob.obs[:, iref.O_MODE] == iref.MODE_LINE))
    assert line.size > 0
    for r in line:
        mm = mesh[ob.ids[r].split("/")[0]]
        A, B = mm.pair.gear_a, mm.pair.gear_b
        OA = m.body_pose(q, mm.body_a)[:2]
        OB = m.body_pose(q, mm.body_b)[:2] if mm.body_b >= 0 else np.zeros(2)
        p = ob.position[r]
        g = ob.obs[r, iref.O_GAP]
        rho_a = np.sqrt(np.sum((p - OA) ** 2) - A.base_radius ** 2) - 0.5 * g
        rho_b = np.sqrt(np.sum((p - OB) ** 2) - B.base_radius ** 2) + 0.5 * g
        assert kap[r] == pytest.approx(1 / rho_a + mm.pair.eps / rho_b, rel=1e-6)


def test_ball_bearing_films_are_point_contacts_at_the_inner_race(rd40_window):
    """Main bearing (angular-contact pair) of RD-40: R_x = D (1 - gamma) / 2, R_y = f_i D / (2 f_i - 1),
    gamma = D cos(alpha) / d_m, u = omega_rel d_m (1 - gamma^2) / 4 by hand; the lumped film load is
    the most loaded ball's 5 / (Z_total cos alpha) of the bearing force, the rolling one the ball's own."""
    _, _, x = rd40_window
    row = RD40.main_bearing.rows[0]
    D, dm, a, fi = row.ball_diameter, row.pitch_diameter, row.contact_angle, row.inner_curvature
    g = D * np.cos(a) / dm
    w_out = RD40.input_speed_rpm * np.pi / 30 / (RD40.pins.n_pins - 1)
    for model, share in (("lumped", 5.0 / (2 * row.n_balls * np.cos(a))), ("rolling", 1.0)):
        c = C.lubrication(RD40, C.CycloidSlowInputs(), x, bearing_model=model).contacts["main_bearings"]
        assert c.kind.value == "point" and c.node == "flange"
        assert c.radius_x == pytest.approx(0.5 * D * (1 - g), rel=1e-14)
        assert c.radius_y == pytest.approx(fi * D / (2 * fi - 1), rel=1e-14)
        assert c.entrainment_speed == pytest.approx(0.25 * w_out * dm * (1 - g * g), rel=1e-14)
        assert c.load_share == pytest.approx(share, rel=1e-14)
    needle = C.lubrication(RD40, C.CycloidSlowInputs(), x, bearing_model="rolling").contacts["eccentric_bearings"]
    assert needle.length == RD40.eccentric_bearing.roller_length
    with pytest.raises(RvtoolInputError, match="bearing_model"):
        C.lubrication(RD40, C.CycloidSlowInputs(), x, bearing_model="ideal")
