"""Verification of the panel contact solver and the half-space stress field."""
import numpy as np
import pytest
import scipy.integrate

from rvtool.pressure import PanelContact, influence_column, panel_integral, solve_panels, subsurface_stress
from rvtool import designs

E_STAR = 210e9 / (2 * (1 - 0.3 ** 2))
R, B, F = 3e-3, 8e-3, 1000.0
A_H = np.sqrt(4 * F / B * R / (np.pi * E_STAR))  # Hertz line-contact half-width
P0 = 2 * F / B / (np.pi * A_H)  # Hertz peak pressure


def test_self_panel_integral_matches_quadrature():
    for x1, x2 in [(-1e-5, 1e-5), (2e-5, 5e-5), (-3e-5, 1e-5)]:
        # split at the singular receiver point so that QAGS never samples it
        cuts = [x1, 0.0, x2] if x1 < 0 < x2 else [x1, x2]
        ref = sum(2 * scipy.integrate.dblquad(lambda y, xi: 1 / np.hypot(xi, y), lo, hi, 0, B / 2,
                                              epsabs=1e-14, epsrel=1e-10)[0] for lo, hi in zip(cuts[:-1], cuts[1:]))
        assert panel_integral(x1, x2, B / 2) == pytest.approx(ref, rel=1e-6)  # quadrature accuracy


def test_influence_column_against_boussinesq_far_field_and_quadrature():
    """The compliance column against two independent references (the matrix is Toeplitz, so
    symmetric by construction; what can be wrong is the column itself)."""
    import scipy.linalg
    # far field: a panel (dx x b) seen from d >> b is a point load, Boussinesq's w = F / (pi E* d) for two
    # elastic half-spaces; the mean of 1/r over the panel adds (2 dx^2 - b^2) / (24 d^2) (second-order
    # Taylor term of 1/r, <xi^2> = dx^2/12, <y^2> = b^2/12); the next term is O((b/d)^4) with a coefficient
    # below 0.01, so rel = (b/d)^4 separates the tested second-order term (4e-4 at d = 10 b) from it
    dx, n = 1e-3, 600
    col = influence_column(n, dx, B, E_STAR)
    d = np.arange(n) * dx
    far = d >= 10 * B
    expected = 1.0 + (2 * dx ** 2 - B ** 2) / (24 * d[far] ** 2)
    rel_err = np.abs(col[far] * np.pi * E_STAR * d[far] / expected - 1.0)
    assert np.all(rel_err <= (B / d[far]) ** 4), rel_err.max()
    # near field: the double integral of 1/r over panel k by quadrature (receiver off the panel, so regular)
    dx = 5e-6
    col = influence_column(8, dx, B, E_STAR)
    for k in (1, 2, 7):
        ref = scipy.integrate.dblquad(lambda y, xi: 1 / np.hypot(xi, y), (k - 0.5) * dx, (k + 0.5) * dx,
                                      -B / 2, B / 2, epsabs=0, epsrel=1e-11)[0]
        assert col[k] == pytest.approx(ref / (np.pi * E_STAR * B * dx), rel=1e-8)  # quadrature accuracy
    A = scipy.linalg.toeplitz(influence_column(65, 5e-6, B, E_STAR))
    assert np.all(A > 0)
    assert np.all(np.linalg.eigvalsh(A) > 0)  # a compliance is positive definite


@pytest.mark.parametrize("n", [257, 1025])
def test_hertz_line_contact(n):
    x = np.linspace(-0.3e-3, 0.3e-3, n)
    r = solve_panels(PanelContact(face_width=B, e_star=E_STAR, force=F), x, R - np.sqrt(R * R - x * x))
    # Hertz: p0 = 2F'/(pi a), a = sqrt(4 F' R / (pi E*)); panel error O(dx/a) at the edge, 3-D
    # face-width effect of the 1/r kernel ~ (a/b)^2 at the centre
    assert r.p_raw / P0 == pytest.approx(1.0, abs=2e-3)
    assert r.span / (2 * A_H) == pytest.approx(1.0, abs=2 * (x[1] - x[0]) / A_H)
    assert r.load_residual < 1e-12  # exact load balance of the bordered solve
    assert np.all(r.force >= 0) and np.all(r.gap >= -1e-15)
    z = np.linspace(1e-7, 2 * A_H, 80)
    s = subsurface_stress(x, r.pressure, z)
    i = np.unravel_index(s["tau_max"].argmax(), s["tau_max"].shape)
    # Hertz line contact: tau_max = 0.300 p0 at z = 0.786 a (Johnson 1985, Sec. 4.2)
    assert s["tau_max"].max() / P0 == pytest.approx(0.300, abs=3e-3)
    assert z[i[0]] / A_H == pytest.approx(0.786, abs=2 * (z[1] - z[0]) / A_H)


def test_gap_datum_resolution_invariant():
    """The gap at a fixed pin contact of the RD-40 rated state does not depend on the panel grid."""
    from rvtool.assembly.cycloid import build
    from rvtool.assembly.spec import load_design
    from rvtool.pressure.state import pin_contact_gap
    from rvtool.solver.static import StaticSolver
    m = build(load_design(designs.path("rd40")))
    m.set_output_torque(140.0)
    q = StaticSolver(m).solve(0.0)
    el = m.elements["pins"]
    ql = el.local(q)
    j = int(np.argmax(el.evaluate(0.0, ql, 0 * ql).obs[:, 0]))
    xc = np.linspace(-1e-4, 1e-4, 129)
    xf = np.linspace(-1e-4, 1e-4, 1025)
    gc, fc = pin_contact_gap(m, q, j, xc)
    gf, ff = pin_contact_gap(m, q, j, xf)
    assert fc == ff  # the load is never changed by the resolution
    # coarse centres are a subset of the fine ones (every 8th): same gap to profile-interpolation accuracy
    assert np.allclose(gc, gf[::8], atol=1e-9)


# -- tangential tractions ------------------------------------------------------------------

def _flamant(x, z, mu, a=1.0, p0=1.0):
    """sxx, szz, sxz under p = p0 sqrt(1 - s^2/a^2), q = mu p by quadrature of Flamant's normal and
    tangential line-load solutions (Johnson 1985, Eq. 2.23), independent of both the FFT path and
    the closed form; s = a sin(t) removes the square-root end points."""
    def integrand(t, i):
        s = a * np.sin(t)
        w = p0 * np.cos(t) * a * np.cos(t)
        u = x - s
        r4 = (u * u + z * z) ** 2
        return (-(2 * z / np.pi) * w * u * u / r4 - (2 / np.pi) * mu * w * u ** 3 / r4,
                -(2 * z ** 3 / np.pi) * w / r4 - (2 * z * z / np.pi) * mu * w * u / r4,
                -(2 * z * z / np.pi) * w * u / r4 - (2 * z / np.pi) * mu * w * u * u / r4)[i]
    return np.array([scipy.integrate.quad(integrand, -np.pi / 2, np.pi / 2, args=(i,), limit=400,
                                          epsabs=1e-12)[0] for i in range(3)])


def test_sliding_closed_form_matches_flamant_superposition():
    from rvtool.pressure import sliding_hertz_stress
    for x, z in [(0.3, 0.5), (-0.7, 0.2), (1.5, 0.4), (-1.2, 1.0), (0.0, 0.78)]:
        ref = _flamant(x, z, 0.3)
        c = sliding_hertz_stress([x], [z], 1.0, 1.0, 0.3)
        # quadrature accuracy (epsabs 1e-12 on O(1) stresses)
        assert np.allclose([c["sxx"][0, 0], c["szz"][0, 0], c["sxz"][0, 0]], ref, atol=1e-9)


@pytest.mark.parametrize("mu", [0.2, 0.3])
def test_sliding_stress_maxima_vs_closed_form(mu):
    """FFT transfer functions with q = mu p against the closed-form sliding Hertz field (McEwen 1949):
    mu = 0.2 has its maxima below the surface, mu = 0.3 at the surface (Johnson 1985, Sec. 7.2)."""
    from rvtool.pressure import sliding_hertz_stress
    a, p0 = 1.0, 1.0
    x = np.linspace(-3, 3, 1025)
    p = p0 * np.sqrt(np.maximum(1 - x * x, 0))
    z = np.linspace(0, 1.5, 301)
    s = subsurface_stress(x, p, z, mu=mu)
    xr = np.linspace(-1.5, 1.5, 3001)
    c = sliding_hertz_stress(xr, z, a, p0, mu)
    for key in ("tau_max", "von_mises"):
        i = np.unravel_index(s[key].argmax(), s[key].shape)
        j = np.unravel_index(c[key].argmax(), c[key].shape)
        # pad = 16: periodic images <= 5e-4 (pad^-2), sampling of p at dx = a/171
        assert s[key].max() == pytest.approx(c[key].max(), rel=1e-3)
        assert z[i[0]] == pytest.approx(z[j[0]], abs=2 * (z[1] - z[0]))
        assert x[i[1]] == pytest.approx(xr[j[1]], abs=2 * (x[1] - x[0]))
    if mu == 0.2:
        assert 0.5 < z[np.unravel_index(s["tau_max"].argmax(), s["tau_max"].shape)[0]] < 0.7
    else:
        assert np.unravel_index(s["tau_max"].argmax(), s["tau_max"].shape)[0] == 0


def test_trailing_edge_tension_two_mu_p0():
    """Surface sxx = -p - 2 mu p0 x/a inside the contact, 2 mu p0 at the trailing edge x = -a; the
    sampled square-root edge converges like sqrt(dx)."""
    mu = 0.3
    err = []
    for m in (64, 1024):
        dx = 1.0 / m
        x = dx * (np.arange(6 * m + 1) - 3 * m)       # a node exactly at x = -a
        p = np.sqrt(np.maximum(1 - x * x, 0))
        s = subsurface_stress(x, p, np.array([0.0]), mu=mu)
        err.append(abs(s["sxx"][0, 2 * m] - 2 * mu))
        inside = np.abs(x) < 0.9
        assert np.allclose(s["sxx"][0, inside], -p[inside] - 2 * mu * x[inside], atol=3e-3)
    assert err[1] < 0.05 * 2 * mu
    assert err[0] / err[1] == pytest.approx(4.0, rel=0.15)       # sqrt(16) for dx / 16


def test_explicit_traction_equals_coulomb_and_exclusive():
    from rvtool.errors import RvtoolInputError
    x = np.linspace(-2, 2, 257)
    p = np.sqrt(np.maximum(1 - x * x, 0))
    z = np.linspace(0, 1, 11)
    a = subsurface_stress(x, p, z, mu=-0.25)
    b = subsurface_stress(x, p, z, traction=-0.25 * p)
    assert np.array_equal(a["tau_max"], b["tau_max"])
    with pytest.raises(RvtoolInputError, match="not both"):
        subsurface_stress(x, p, z, mu=0.1, traction=p)
    with pytest.raises(RvtoolInputError, match="mu"):
        subsurface_stress(x, p, z, mu=2.0)


# -- observables --------------------------------------------------------------------------

def test_window_mean_exact_and_field_difference():
    from rvtool.pressure import field_difference, window_mean_max
    # uniform 1 Pa on [-1, 1]: a window inside the support averages 1, a wider one 2/w (denominator w)
    x = np.linspace(-1.5, 1.5, 31)[5:26]           # panels of 0.1 covering [-1.05, 1.05]
    p = np.ones_like(x)
    assert window_mean_max(x, p, 0.37) == pytest.approx(1.0, rel=1e-14)
    assert window_mean_max(x, p, 5.0) == pytest.approx(2.1 / 5.0, rel=1e-14)
    # a window not a multiple of the panel width: exact against brute-force sampling of s
    rng = np.random.default_rng(1)
    x = np.linspace(0, 1, 40)
    p = rng.random(40)
    w = 0.0917
    e = np.concatenate([x - 0.5 * (x[1] - x[0]), [x[-1] + 0.5 * (x[1] - x[0])]])
    u = np.linspace(e[0] - w, e[-1] + w, 200001)
    c = np.concatenate([[0], np.cumsum(p * np.diff(e))])
    brute = np.max(np.interp(u + w / 2, e, c, left=0, right=c[-1]) - np.interp(u - w / 2, e, c, left=0, right=c[-1])) / w
    assert window_mean_max(x, p, w) == pytest.approx(brute, rel=1e-5)   # brute-force s sampling
    assert window_mean_max(x, p, w) >= brute
    # e1: a field against itself refined by 3 (same function) is 0; a shifted box overlaps half
    xf = np.linspace(0, 1, 120)
    assert field_difference(np.repeat(x, 1), p, x, p) == 0.0
    xa = np.linspace(0.05, 0.95, 10)                # box [0, 1]
    xb = xa + 0.5                                  # box [0.5, 1.5]
    assert field_difference(xb, np.ones(10), xa, np.ones(10)) == pytest.approx(1.0, rel=1e-12)
    pf = np.interp(xf, x, p)
    assert 0 < field_difference(xf, pf, x, p) < 1


def test_two_lobe_active_set_dense_path_is_complementary():
    """A non-contiguous active set (two lobes) takes the dense bordered solve; check Eq.
    (obs_pressure_contact) with the explicit matrix."""
    import scipy.linalg
    x = np.linspace(-2e-4, 2e-4, 301)
    h = np.minimum((x - 1e-4) ** 2, (x + 1e-4) ** 2) / (2 * R)   # two valleys at +-0.1 mm, 3.3 um apart
    r = solve_panels(PanelContact(face_width=B, e_star=E_STAR, force=100.0), x, h)
    f = r.force
    act = np.flatnonzero(f > 0)
    assert np.any(np.diff(act) > 1)                     # two lobes
    A = scipy.linalg.toeplitz(influence_column(x.size, x[1] - x[0], B, E_STAR))
    g = h + A @ f - r.approach
    scale = np.ptp(h)
    assert np.all(f >= 0) and np.all(g >= -1e-12 * scale)
    assert np.max(np.abs(g[act])) < 1e-12 * scale
    assert r.load_residual < 1e-12


# -- contacts of an accepted state ----------------------------------------------------------

@pytest.fixture(scope="module")
def rated_rolling():
    from rvtool.assembly.cycloid import build
    from rvtool.assembly.spec import load_design
    from rvtool.solver.static import StaticSolver
    m = build(load_design(designs.path("rd40")), bearing_model="rolling")
    m.set_output_torque(140.0)
    return m, StaticSolver(m).solve(0.0)


def test_output_pin_and_needle_contacts_from_state(rated_rolling):
    from rvtool.pressure.state import candidates, needle_contact, output_pin_contact
    m, q = rated_rolling
    d = m.design
    obs = m.elements["output_pins"].evaluation_at(q).obs
    el = m.elements["output_pins"]
    c = output_pin_contact(m, q, 0, 2)
    rows = [i for i, cid in enumerate(el.ids) if cid.startswith("output_pins/pin2/wheel0/")]
    assert c.force == obs[rows, 0].sum() and c.force > 0            # the state's load, slices merged
    rp, rh = d.output_pins.pin_radius, d.output_pins.hole_radius
    x = np.linspace(-4e-4, 4e-4, 65)
    # conformal circles touching at x = 0
    assert np.allclose(c.gap(x), (rp - np.sqrt(rp ** 2 - x ** 2)) - (rh - np.sqrt(rh ** 2 - x ** 2)), atol=1e-18)
    assert c.radius == pytest.approx(rp * rh / (rh - rp))
    # needle: roller load = sum of its laminae
    elb = m.elements["bearings"]
    ob = elb.evaluation_at(q).obs
    nj = max(candidates(m, q, "needles", 0, "journal"), key=lambda k: k.force)
    j = int(nj.name.split("roller")[1].split("/")[0])
    rows = [i for i, cid in enumerate(elb.ids) if cid.startswith(f"eccentric_bearing0/roller{j}/")]
    assert nj.force == ob[rows, 0].sum()
    nb = needle_contact(m, q, 0, j, "bore")
    eb = d.eccentric_bearing
    rr, rj, rb = 0.5 * eb.roller_diameter, eb.inner_radius, eb.inner_radius + eb.roller_diameter + eb.radial_clearance
    assert nj.radius == pytest.approx(rr * rj / (rr + rj)) and nb.radius == pytest.approx(rr * rb / (rb - rr))
    assert nb.force == nj.force and nb.face_width == eb.roller_length
    # conformal line contact: panel peak and span vs Hertz with the equivalent radius
    from rvtool.pressure.study import domain_halfwidth, solve_contact
    for k in (c, nj, nb):
        r = solve_contact(k, 513, domain_halfwidth(k), 0.0)
        # panel edge error O(dx/a) on the span; finite-width kernel (a/b)^2 <= 1e-3 on the peak
        assert r.p_raw / k.hertz_peak == pytest.approx(1.0, abs=3e-3)
        assert r.span / (2 * k.hertz_halfwidth) == pytest.approx(1.0, abs=3 * (r.x[1] - r.x[0]) / k.hertz_halfwidth)


def test_lumped_needle_stribeck():
    from rvtool.assembly.cycloid import build
    from rvtool.assembly.spec import load_design
    from rvtool.pressure.state import needle_contact
    from rvtool.solver.static import StaticSolver
    from rvtool.errors import RvtoolInputError
    m = build(load_design(designs.path("rd40")), bearing_model="lumped")
    m.set_output_torque(140.0)
    q = StaticSolver(m).solve(0.0)
    el = m.elements["bearings"]
    fr = el.evaluation_at(q).obs[list(el.ids).index("eccentric_bearing1"), 0]
    c = needle_contact(m, q, 1, None, "journal")
    assert c.force == pytest.approx(4.08 * fr / m.design.eccentric_bearing.n_rollers, rel=1e-15)  # Stribeck
    with pytest.raises(RvtoolInputError, match="roller"):
        needle_contact(m, q, 1, 3, "journal")


def test_selection_fixed_and_resolution_never_changes_contact(rated_rolling):
    """Selection happens once at one resolution; the study keeps that contact's identity and load."""
    from rvtool.pressure.state import candidates
    from rvtool.pressure.study import domain_halfwidth, resolution_study, select_contact, solve_contact
    m, q = rated_rolling
    cands = candidates(m, q, "output_pins", 1)
    best, table = select_contact(cands, n_select=129, window=20e-6)
    # the largest fixed-window mean of the candidates, recomputed independently
    again = {c.name: solve_contact(c, 129, domain_halfwidth(c), 20e-6).p_window for c in cands}
    assert table == again and best.name == max(again, key=again.get)
    rec, fields = resolution_study(best, [129, 257, 513], half=domain_halfwidth(best), window=20e-6)
    assert rec["contact"] == best.name and rec["force_N"] == best.force
    # panel forces of every resolution sum to the frozen load
    for (x, p) in fields:
        assert np.sum(p) * best.face_width * (x[1] - x[0]) == pytest.approx(best.force, rel=1e-12)
    assert rec["e1_vs_4097_pct"][-1] == 0.0 and rec["e1_vs_4097_pct"][0] > rec["e1_vs_4097_pct"][1]


def test_rough_gaps_satisfy_complementarity():
    """Random rough gaps (many lobes, where block pivoting may cycle): Eq. (obs_pressure_contact)
    holds with the explicit matrix to round-off."""
    import scipy.linalg
    rng = np.random.default_rng(0)
    for _ in range(30):
        n = int(rng.integers(20, 200))
        x = np.linspace(-2e-4, 2e-4, n)
        h = rng.random(n) * 1e-6 * rng.random()
        r = solve_panels(PanelContact(face_width=B, e_star=E_STAR, force=float(rng.uniform(1, 500))), x, h)
        g = h + scipy.linalg.toeplitz(influence_column(n, x[1] - x[0], B, E_STAR)) @ r.force - r.approach
        scale = max(np.ptp(h), abs(r.approach))
        assert np.all(r.force >= 0) and g.min() > -1e-10 * scale
        assert np.max(np.abs(g[r.force > 0])) < 1e-10 * scale and r.load_residual < 1e-12
