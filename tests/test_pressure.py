"""Verification of the panel contact solver and the half-space stress field."""
import numpy as np
import pytest
import scipy.integrate

from rvtool.pressure import PanelContact, influence_column, panel_integral, solve_panels, subsurface_stress

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


def test_influence_symmetric_positive():
    import scipy.linalg
    A = scipy.linalg.toeplitz(influence_column(65, 5e-6, B, E_STAR))
    assert np.allclose(A, A.T)
    assert np.all(A > 0)
    assert np.all(np.linalg.eigvalsh(A) > 0)


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
    from rvtool.protocols.equilibrium import StaticSolver
    m = build(load_design("cases/designs/rd40.toml"))
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
