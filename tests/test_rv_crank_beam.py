"""Elastic RV crankshafts (issue 21 Deliver 2): the crank beam's compliance against beam closed
forms, the switch (rigid = the "nothing" variant, bit-identical), the closed crank element's
tangent against central differences, and the RV stiffness budget with a ``cranks`` path."""
import math

import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.rv import load_design
from rvtool.assembly.rv.builder import (CRANK_STATIONS, crank_pair_tilt_stiffness, crank_station_compliance,
                                        rated_crank_bearing_load)
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.protocols.budget import stiffness_budget
from rvtool.solver.static import StaticSolver
from rvtool.structure.crank_beam import CrankBeam, CrankShaft, determinate_influence, station_points

E, NU, R = 206e9, 0.3, 0.010
SUP = (-0.020, 0.020)


@pytest.mark.parametrize("shear", [True, False])
def test_influence_against_virtual_work(shear):
    # g(x, xi) of the Timoshenko discretization against the unit-load virtual work on the determinate
    # beam (overhangs on both sides included): both exact, so round-off of the 2n x 2n solve
    # (condition ~1e6 here) remains: 1e-9 relative
    b = CrankBeam(R, SUP, E, NU, shear=shear)
    x = np.array([-0.035, -0.03, -0.02, -0.0125, -0.0075, 0.0, 0.004, 0.0125, 0.02, 0.027])
    g = b.influence(x, x)
    ref = determinate_influence(x, x, SUP, b.EI, b.kGA)
    assert np.abs(g - ref).max() < 1e-9 * np.abs(ref).max()
    assert np.abs(g - g.T).max() < 1e-12 * np.abs(g).max()          # Maxwell--Betti


def test_textbook_formulas():
    b = CrankBeam(R, SUP, E, NU)
    L, c = SUP[1] - SUP[0], 0.015
    # centre load on a simply supported span: P L^3 / (48 EI) + P L / (4 kappa G A)
    assert b.influence(0.0, 0.0)[0, 0] == pytest.approx(L ** 3 / (48 * b.EI) + L / (4 * b.kGA), rel=1e-10)
    # tip of an overhang c: P c^2 (L + c) / (3 EI) + P c (1 + c / L) / (kappa G A)
    tip = SUP[0] - c
    assert b.influence(tip, tip)[0, 0] == pytest.approx(c * c * (L + c) / (3 * b.EI) + c * (1 + c / L) / b.kGA,
                                                        rel=1e-10)
    # a load in the span lifts the overhang by c theta_B (bending rotation at the support only: the
    # unloaded overhang carries no shear): theta_B = P a b (L + b) / (6 L EI) at a from the far support
    a = 0.012                      # load at SUP[1] - a; the overhang beyond SUP[0]
    bb = L - a
    theta = a * bb * (L + a) / (6 * L * b.EI)
    assert abs(b.influence(tip, SUP[1] - a)[0, 0]) == pytest.approx(c * theta, rel=1e-10)
    # Euler--Bernoulli drops only the shear terms
    eb = CrankBeam(R, SUP, E, NU, shear=False)
    assert eb.influence(0.0, 0.0)[0, 0] == pytest.approx(L ** 3 / (48 * eb.EI), rel=1e-10)


def test_station_compliance_against_the_closed_form():
    d = load_design(designs.path("rv40e"))
    sh = d.cranks.shaft
    b = CrankBeam(sh.radius, sh.supports, E, NU)
    centres = (*d.wheels.midplanes, sh.gear_position)
    widths = (d.eccentric_bearing.roller_length,) * 2 + (d.crank_gear.face_width,)
    # the same quadrature over the closed-form influence function: identical to round-off
    n_sub = 4
    pts, wts = station_points(np.array(centres), np.array(widths), n_sub)
    g = determinate_influence(pts.ravel(), pts.ravel(), sh.supports, b.EI, b.kGA)
    W = wts.ravel()
    ref = (W[:, None] * g * W[None, :]).reshape(3, 2 * n_sub, 3, 2 * n_sub).sum(axis=(1, 3))
    C4 = b.station_compliance(centres, widths, n_sub=n_sub)
    assert np.abs(C4 - ref).max() < 1e-9 * np.abs(ref).max()
    # quadrature convergence: only the diagonal sub-squares carry an error, where the shear part
    # of g (piecewise linear in x - xi) has its kink: second order in the sub-interval. Against
    # 128 sub-intervals: the error ratio of 8 to 16 is 4 (measured 4.01; bound [3.5, 4.5]) and the
    # default 16 is within 2.6e-5 relative (bound 5e-5)
    C8, C16 = b.station_compliance(centres, widths, n_sub=8), b.station_compliance(centres, widths)
    C128 = b.station_compliance(centres, widths, n_sub=128)
    e8, e16 = (np.abs(c - C128).max() / np.abs(C128).max() for c in (C8, C16))
    assert 3.5 < e8 / e16 < 4.5
    assert e16 < 5e-5
    assert np.all(np.linalg.eigvalsh(C16) > 0)
    # the gear overhangs the input-side row, the journals sit in the span: a journal load lifts
    # the gear (negative coupling), the two journals deflect together
    assert C16[0, 2] < 0 and C16[1, 2] < 0 and C16[0, 1] > 0
    assert np.array_equal(crank_station_compliance(d.replace(cranks={"shaft": {"model": "simply_supported"}})), C16)
    assert crank_station_compliance(d) is None
    assert CRANK_STATIONS == ("journal_wheel0", "journal_wheel1", "gear")


def test_shaft_errors_name_their_keys():
    d = load_design(designs.path("rv40e"))
    with pytest.raises(RvtoolInputError, match=r"cranks.shaft.model = 'cantilever'.*valid choices"):
        d.replace(cranks={"shaft": {"model": "cantilever"}})
    with pytest.raises(RvtoolInputError, match=r"cranks.shaft.supports = \(0.02, -0.02\).*z_a < z_b"):
        d.replace(cranks={"shaft": {"supports": [0.02, -0.02]}})
    with pytest.raises(RvtoolInputError, match=r"cranks.shaft.radius"):
        d.replace(cranks={"shaft": {"radius": -1.0}})
    with pytest.raises(RvtoolInputError, match=r"radius is required for model = 'simply_supported'"):
        CrankShaft(model="simply_supported", supports=SUP, gear_position=0.0)


@pytest.fixture(scope="module")
def rated_pair():
    """rv40e at rated torque, input angle 0, with rigid and with elastic cranks."""
    d = load_design(designs.path("rv40e"))
    out = {}
    for key, dd in (("rigid", d), ("elastic", d.replace(cranks={"shaft": {"model": "simply_supported"}}))):
        m = build(dd)
        m.set_output_torque(-np.sign(m.ratio) * dd.rated_torque)
        out[key] = (m, StaticSolver(m).solve(0.0))
    return out


def test_rigid_shaft_is_the_nothing_variant(rated_pair):
    # a [cranks.shaft] table with model = "rigid" builds exactly the elements of a design without it
    d = load_design(designs.path("rv40e"))
    src = {k: v for k, v in d.source.items()}
    src["cranks"] = {k: v for k, v in src["cranks"].items() if k != "shaft"}
    from rvtool.assembly.rv.spec import design_from_dict
    bare = design_from_dict(src)
    m = build(bare)
    m.set_output_torque(-np.sign(m.ratio) * bare.rated_torque)
    q = StaticSolver(m).solve(0.0)
    m0, q0 = rated_pair["rigid"]
    assert list(m.elements) == list(m0.elements) == ["pins", "gears", "eccentric_bearings", "crank_bearings",
                                                     "main_bearings"]
    assert np.array_equal(q, q0)


def test_elastic_crank_element(rated_pair):
    m, q = rated_pair["elastic"]
    el = m.elements["cranks"]
    assert m.families[Family.INVOLUTE_STAGE][0] == m.families[Family.ECCENTRIC_BEARINGS][0] == "cranks"
    # the closure balances every station: its deflection is the beam compliance times the contact
    # forces on the crank there (solved to 1e-8 N against C ~ 1e-9 m/N: 1e-17 m)
    closure = el.evaluator
    pose = m.elements["cranks"].pose_velocity(el.local(q), 0 * el.local(q))[0]
    ext = closure.extended_pose(pose)
    Qs = closure.inner.evaluate(ext, 0 * ext).Q.reshape(-1, 3)[m.layout.n_bodies:, :2].reshape(-1, 3, 2)
    u = m.crank_deflections(q)
    assert np.abs(u - np.einsum("st,ktx->ksx", m.crank_compliance, Qs)).max() < 1e-15
    assert 1e-7 < np.abs(u).max() < 1e-5          # microns under ~0.7 kN per needle bearing
    # the condensed tangent against central differences of the condensed forces (h as in
    # tests/test_rv.py: truncation and round-off ~1e-7 relative; the closure's own residual of
    # 1e-8 N over h = 1e-9 m adds 1e-6 relative at entries of ~1e9 N/m): 1e-5
    ql = el.local(q)
    v0 = np.zeros_like(ql)
    ev = el.evaluate(0.0, ql, v0)
    K = np.zeros_like(ev.dQdq)
    for j in range(len(ql)):
        h = 1e-9 if j % 3 < 2 else 1e-8
        qp, qm = ql.copy(), ql.copy()
        qp[j] += h
        qm[j] -= h
        K[:, j] = (el.evaluate(1.0 + j, qp, v0).Q - el.evaluate(2.0 + j, qm, v0).Q) / (2 * h)
    assert np.linalg.norm(ev.dQdq - K) / np.linalg.norm(K) < 1e-5


def test_budget_with_elastic_cranks(rated_pair):
    mr, qr = rated_pair["rigid"]
    me, qe = rated_pair["elastic"]
    br, be = stiffness_budget(mr, qr), stiffness_budget(me, qe)
    assert "cranks" not in br["shares"]
    s = be["shares"]
    assert sum(s.values()) == pytest.approx(1.0, abs=1e-12)
    # the rows and the beams carry the output compliance up to the geometric stiffness and the
    # regularization springs: measured 1e-4 for rv40e, bound 1e-2
    assert abs(s["geometric_and_regularization"]) < 1e-2
    # a beam in series with the needles and the crank bearings only adds compliance: the tangent
    # output stiffness falls by the crank share (springs in series; 27 % measured)
    assert s["cranks"] > 0.05
    assert be["K_t_Nm_per_arcmin"] < br["K_t_Nm_per_arcmin"]
    assert be["K_t_Nm_per_arcmin"] == pytest.approx(br["K_t_Nm_per_arcmin"] * (1 - s["cranks"]), rel=0.05)
    # the energy share against the element's own condensed tangent (Rayleigh: dC/dlambda =
    # -u^T K_b u) and the finite switch to a rigid beam: measured within 1e-4, bound 1e-3 (the
    # sensitivity's central-difference error is 1e-5; the finite switch adds the redistribution)
    assert be["sensitivity_shares"]["cranks"] == pytest.approx(s["cranks"], abs=1e-4)
    assert be["rigid_shares"]["cranks"] == pytest.approx(s["cranks"], abs=1e-3)
    assert math.isfinite(be["K_t_Nm_per_arcmin"])


def test_crank_tilt_on_its_pair(rated_pair):
    d = load_design(designs.path("rv40e"))
    with pytest.raises(RvtoolInputError, match=r"cranks.shaft.tilt = true needs model = 'simply_supported'"):
        d.replace(cranks={"shaft": {"tilt": True}})
    # the rated radial load of a pair by statics, T / (N_c r_c), against the model's pair forces at the
    # rated state (3.70-3.89 kN: the pins' phase makes the shares differ by +-2 %): 5 %
    F = rated_crank_bearing_load(d)
    m, q = rated_pair["elastic"]
    forces = np.linalg.norm(m.crank_bearing_forces(q)[0], axis=1)
    assert np.all(np.abs(forces / F - 1) < 0.05)
    # K_gamma is the pair's moment--tilt tangent: against central differences of the pair's moment
    # over +-1e-8 rad at the radial displacement carrying F (truncation of second order: measured
    # 4e-4 at 1e-6 rad, 4e-6 at 1e-7, 4e-8 at 1e-8; bound 1e-5)
    from rvtool.bearings.tapered_set import TaperedBearingSet, TaperedMounting
    s = TaperedBearingSet([TaperedMounting(name="p", bearing=d.crank_bearing, inner=0, outer=1)], 2, backend="numpy")
    K_g = crank_pair_tilt_stiffness(d, F)
    q0 = np.zeros((1, 5))
    for _ in range(50):              # the radial displacement carrying F (as the builder solves it)
        r = s.relative(q0)
        q0[0, 0] -= (-r.wrench[0, 0] - F) / -r.stiffness[0, 0, 0]
    # (the radial load makes the pair anisotropic: K_gamma is the mean of the two tilt directions,
    # the closure's beam compliance being isotropic; measured 8.5e5 and 6.7e5 N m/rad)
    g = 1e-8
    fd = []
    for c in (3, 4):
        dq = np.zeros((1, 5))
        dq[0, c] = g
        fd.append(-(s.relative(q0 + dq).wrench[0, c] - s.relative(q0 - dq).wrench[0, c]) / (2 * g))
    assert 0.5 * (fd[0] + fd[1]) == pytest.approx(K_g, rel=1e-5)
    # a preloaded back-to-back pair loses tilting stiffness as the radial load unloads one side
    assert K_g < crank_pair_tilt_stiffness(d)
    # the tilt adds z z^T / K_gamma (z from the pair's centre) to the beam's station compliance
    dt = d.replace(cranks={"shaft": {"model": "simply_supported", "tilt": True}})
    sh = dt.cranks.shaft
    z = np.array([*dt.wheels.midplanes, sh.gear_position]) - 0.5 * sum(sh.supports)
    C0 = crank_station_compliance(d.replace(cranks={"shaft": {"model": "simply_supported"}}))
    assert np.allclose(crank_station_compliance(dt) - C0, np.outer(z, z) / K_g, rtol=1e-12, atol=0)
    # and softens the output: the crank path's share grows, K_t falls (measured: share 0.271 -> 0.283, K_t 405.5 -> 399.3 N m/arcmin)
    mt = build(dt)
    mt.set_output_torque(-np.sign(mt.ratio) * dt.rated_torque)
    bt = stiffness_budget(mt, StaticSolver(mt).solve(0.0))
    be = stiffness_budget(m, q)
    assert bt["shares"]["cranks"] > be["shares"]["cranks"]
    assert bt["K_t_Nm_per_arcmin"] < be["K_t_Nm_per_arcmin"]
    assert sum(bt["shares"].values()) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("device", ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(
    __import__("warp").get_cuda_device_count() == 0, reason="no CUDA device"))])
def test_elastic_cranks_on_the_reference_backend_and_devices(device):
    """The closure and the stacked set are NumPy around the involute and needle kernels: the rated
    state with elastic cranks (and tilt) on the NumPy references and on the Warp kernels of
    ``device`` agree to round-off amplified by the closure's Newton (measured 1.8e-15 on cpu; bound
    1e-11 m / rad, as the rigid model's 1e-12 in tests/test_rv.py with the closure's tolerance)."""
    d = load_design(designs.path("rv40e")).replace(cranks={"shaft": {"model": "simply_supported", "tilt": True}})
    qs = []
    for backend in ("warp", "numpy"):
        m = build(d, backend=backend, device=device) if backend == "warp" else build(d, backend=backend)
        m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
        qs.append(StaticSolver(m).solve(0.3))
    assert np.max(np.abs(qs[0] - qs[1])) < 1e-11
