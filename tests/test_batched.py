"""Batched variants in one Exudyn system (issue 8 part 2) against the per-variant path."""
import numpy as np
import pytest

from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.batched import CopyBlockAssembler, build_batched
from rvtool.variants.batched import batched_variant_figures
from rvtool.errors import RvtoolInputError
from rvtool.solver.static import StaticSolver
from rvtool.protocols.precision import quasi_static_te
from rvtool.variants import Variant, VariantProtocol, variant_figures
from rvtool import designs

DESIGN = load_design(designs.path("rd40"))
PROTOCOL = VariantProtocol(n_te_points=5)


def _variants():
    rng = np.random.default_rng(0)
    return [Variant(index=0),
            Variant(index=1, eccentricity_error=2e-6, pin_centre_errors=rng.normal(0, 3e-6, (40, 2)),
                    pin_radius_error=-2e-6, pin_clearance=3e-6),
            Variant(index=2, offset_mod=5e-6, equidistant_mod=-3e-6, bearing_clearance=1e-5)]


@pytest.fixture(scope="module")
def batched():
    # the batched torque continuation, so that it is compared with the per-variant path
    return batched_variant_figures(DESIGN, _variants(), PROTOCOL, return_model=True, lost_motion="batched")


def _per_variant_states(v):
    d = v.apply(DESIGN)
    m = build(d)
    qs = []
    quasi_static_te(m, torque=d.rated_torque, input_angles=PROTOCOL.input_angles(d), solver=StaticSolver(m),
                    record=lambda k, a, q: qs.append(q.copy()))
    idx = np.concatenate([np.asarray(m.mbs.systemData.GetNodeLTGODE2(n), int) for n in m.nodes])
    return np.array(qs)[:, idx]


def test_batched_equals_per_variant(batched):
    res, model, solver = batched
    for v, r in zip(_variants(), res):
        ref = variant_figures(DESIGN, v, PROTOCOL)
        assert r["status"] == "ok"
        # Newton stops at Exudyn's tolerance (1e-6 N on ~1e3 N loads, contact stiffness ~1e8 N/m):
        # equilibria agree to ~1e-12 m, TE to ~1e-6 arcsec
        assert abs(r["te_pp_arcsec"] - ref["te_pp_arcsec"]) < 1e-4
        assert abs(r["max_pin_force_N"] - ref["max_pin_force_N"]) < 1e-6 * ref["max_pin_force_N"]
        assert abs(r["lost_motion_arcmin"] - ref["lost_motion_arcmin"]) < 1e-6
    q_ref = _per_variant_states(_variants()[1])
    assert np.max(np.abs(res[1]["q_te"] - q_ref)) < 1e-9


def test_batched_regularization_equals_per_variant():
    # the Monte Carlo's stiffer regularization (1e4 N/m, 100 N m/rad) must reach the batched build:
    # with the default (100, 0.1) the pin-clearance variant's lost motion differs by far more than 1e-6 arcmin
    reg = (1e4, 100.0)
    v = _variants()[1]
    r = batched_variant_figures(DESIGN, [v], PROTOCOL, regularization=reg)[0]
    ref = variant_figures(DESIGN, v, PROTOCOL, regularization=reg)
    assert r["status"] == "ok"
    assert abs(r["te_pp_arcsec"] - ref["te_pp_arcsec"]) < 1e-4
    assert abs(r["lost_motion_arcmin"] - ref["lost_motion_arcmin"]) < 1e-6


def test_block_structure_matches_per_variant_elements():
    vs = _variants()[:2]
    model = build_batched(DESIGN, vs)
    el = model.elements
    rng = np.random.default_rng(1)
    q = model.kinematic_vectors(0.3) + rng.normal(0, 2e-6, (2, 3 * model.nb))
    model.set_input_angle(0.3)
    ev = el.evaluate_state(q, np.zeros_like(q))
    # reference: the per-variant system's own contact elements at the same state, summed
    for c, v in enumerate(vs):
        d = v.apply(DESIGN)
        m = build(d)
        Q, K = np.zeros(3 * model.nb), np.zeros((3 * model.nb, 3 * model.nb))
        for e in m.elements.values():
            r = e.evaluate(0.0, q[c], np.zeros_like(q[c]))
            Q += r.Q
            K += r.dQdq
        assert np.allclose(ev.Q[c], Q, rtol=1e-12, atol=1e-9)
        assert np.allclose(ev.dQdq[c], K, rtol=1e-12, atol=1e-6 * np.max(np.abs(K)) * 1e-6)
    # no coupling: moving copy 1 leaves copy 0's forces and block bitwise unchanged
    q2 = q.copy()
    q2[1] += 1e-5
    ev2 = el.evaluate_state(q2, np.zeros_like(q2))
    assert np.array_equal(ev2.Q[0], ev.Q[0]) and np.array_equal(ev2.dQdq[0], ev.dQdq[0])
    assert not np.array_equal(ev2.Q[1], ev.Q[1])
    # Exudyn's system tangent has no entry between the copies' coordinates
    import exudyn as exu
    s = exu.MainSolverStatic()
    ss = exu.SimulationSettings()
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    model.mbs.systemData.SetODE2Coordinates(model.to_global(q), configuration=exu.ConfigurationType.Initial)
    s.InitializeSolver(model.mbs, ss)
    s.ComputeJacobianODE2RHS(model.mbs, scalarFactor_ODE2=1.0)
    J = s.GetSystemJacobian()
    assert np.max(np.abs(J[np.ix_(model.ltg[0], model.ltg[1])])) == 0.0
    assert np.max(np.abs(J[np.ix_(model.ltg[0], model.ltg[0])])) > 0.0


def test_assembler_rejects_coupled_copies():
    with pytest.raises(RvtoolInputError, match="different copies"):
        CopyBlockAssembler(np.array([[0, 5]]), 4, 2)


def test_failing_copy_does_not_corrupt_others(batched):
    res_ok = batched[0]
    vs = _variants()[:2]
    # copy 1 returns NaN forces at every evaluation: the batch Newton fails whenever it takes part
    res, _, solver = batched_variant_figures(DESIGN, vs, PROTOCOL, return_model=True,
                                             inject_nan={1: range(1, 10 ** 7)}, lost_motion="batched")
    assert res[0]["status"] == "ok"
    for k in ("te_pp_arcsec", "max_pin_force_N", "lost_motion_arcmin"):
        assert abs(res[0][k] - res_ok[0][k]) <= 1e-6 * max(1.0, abs(res_ok[0][k]))
    # copy 1 is rescued point by point by the per-variant path (its own model has no fault) ...
    assert solver.stats.fallbacks >= PROTOCOL.n_te_points
    assert np.max(np.abs(res[1]["q_te"] - _per_variant_states(vs[1]))) < 1e-9
    # ... its batched torque continuation stalls, and its lost motion comes from its own model
    # as in the per-variant path (load control there), not a wrong number from the faulty copy
    from rvtool.variants import variant_figures
    ref = variant_figures(DESIGN, vs[1], PROTOCOL)
    assert res[1]["status"] == "ok" and res[1]["lost_motion_method"] == ref["lost_motion_method"] == "load"
    assert abs(res[1]["lost_motion_arcmin"] - ref["lost_motion_arcmin"]) <= 1e-6


def test_bad_input():
    with pytest.raises(RvtoolInputError, match="variants"):
        build_batched(DESIGN, [])
    with pytest.raises(RvtoolInputError, match="bearing_model"):
        build_batched(DESIGN, [Variant()], bearing_model="rolling")
    with pytest.raises(RvtoolInputError, match="lost_motion"):
        batched_variant_figures(DESIGN, [Variant()], PROTOCOL, lost_motion="spring")
