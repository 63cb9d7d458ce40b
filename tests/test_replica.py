"""The topology-neutral angle-batched path (rvtool.solver.replica, rvtool.batched.sequence) on
an RV reducer: the same equilibria as the sequential quasi-static TE, and its named limits."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.rv import load_design
from rvtool.solver.replica import replicate
from rvtool.batched.sequence import batched_quasi_static_te
from rvtool.errors import RvtoolInputError
from rvtool.protocols.precision import quasi_static_te
from rvtool.units import ARCSEC_PER_RAD

DESIGN = load_design(designs.path("rv40e"))


@pytest.fixture(scope="module")
def rv():
    return build(DESIGN)


@pytest.fixture(scope="module")
def sequential(rv):
    # 1.5 cycloid mesh cycles at 40 points per cycle (the involute mesh turns through 1.5 / 3 ... of
    # a tooth per point: segments cross contact activations of both meshes)
    angles = np.arange(60) * rv.mesh_period / 40
    return angles, quasi_static_te(rv, torque=DESIGN.rated_torque, input_angles=angles)


def test_rv_batched_equals_sequential(sequential):
    """Each copy solves the sequential path's residual (every family of the RV: pins, involute
    stage, needles, tapered pairs, main bearing) to the same tolerance, 1e-6 N: the TE agrees to
    1e-6 arcsec (measured 1.6e-9: the two Newton sequences stop at different iterates inside the
    tolerance, 1e-6 N over the ~1e8 N/m of the stiffest path is 1e-14 m, i.e. ~1e-9 arcsec at the
    output), the solved angles are identical and each family's peak agrees to 1e-7 relative."""
    angles, s = sequential
    r = batched_quasi_static_te(DESIGN, torque=DESIGN.rated_torque, input_angles=angles, copies=7, abs_tol=1e-6)
    np.testing.assert_array_equal(r["theta_in"], s["theta_in"])
    assert np.max(np.abs(r["te"] - s["te"])) * ARCSEC_PER_RAD < 1e-6
    assert r["peak_loads"].keys() == s["peak_loads"].keys()
    for fam, f in s["peak_loads"].items():
        assert abs(r["peak_loads"][fam] - f) <= 1e-7 * max(f, 1.0), fam
    assert r["stats"]["failed_copies"] == 0 and r["stats"]["fallbacks"] == 0


def test_replica_forces_equal_the_source_model(rv):
    """The copied families evaluate each copy as the source model's elements do: at three
    different states (rated loads, shifted poses) the per-copy forces and tangents equal the
    source's assembled element sums (same kernels, same rows: to round-off, 1e-9 relative)."""
    B = 3
    rep = replicate(rv, B)
    rng = np.random.default_rng(3)
    kin = rep.kinematic_vectors(np.array([0.0, 0.01, 0.02]))
    q = kin + 1e-6 * rng.standard_normal(kin.shape) * np.tile([1, 1, 1e-3], rep.nb)
    ev = rep.elements.evaluate_state(q, np.zeros_like(q))
    n = rv.mbs.systemData.ODE2Size()
    idx = np.concatenate([np.asarray(rv.mbs.systemData.GetNodeLTGODE2(nd), int) for nd in rv.nodes])
    for c in range(B):
        qg = np.zeros(n)
        qg[idx] = q[c]
        Q, K = np.zeros(n), np.zeros((n, n))
        for el in rv.contact_elements():
            e = el.evaluation_at(qg)
            ci = el.coordinate_indices
            Q[ci] += e.Q
            K[np.ix_(ci, ci)] += e.dQdq
        scale = np.max(np.abs(Q[idx]))
        assert np.max(np.abs(ev.Q[c] - Q[idx])) <= 1e-9 * scale
        assert np.max(np.abs(ev.dQdq[c] - K[np.ix_(idx, idx)])) <= 1e-9 * np.max(np.abs(K))


def test_replica_refuses_what_it_cannot_copy(rv):
    with pytest.raises(RvtoolInputError, match=r"copies = 0 is outside the valid range"):
        replicate(rv, 0)
    from rvtool.assembly.spec import load_design as load_cycloid
    ported = build(load_cycloid(designs.path("rd40")), bearing_model="lumped")
    ported.structures["housing"] = object()          # an elastic structure declared by the model
    with pytest.raises(RvtoolInputError, match=r"elastic structures \['housing'\]"):
        replicate(ported, 2)
