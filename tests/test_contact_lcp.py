"""rvtool.contact.lcp: the frictionless contact LCP by active sets (used by the wheel body's 2D reference)."""
import itertools

import numpy as np
import pytest

from rvtool.contact.lcp import active_set_contact, solve_contact_lcp
from rvtool.errors import RvtoolInputError


def _spd(n, seed, cond=1e3):
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return Q @ np.diag(np.geomspace(1.0, cond, n)) @ Q.T


def _brute_force(A, b, E, e):
    """The one active set whose bordered solution meets every condition, by enumeration (small n)."""
    n = len(b)
    hits = []
    for bits in itertools.product([False, True], repeat=n):
        act = np.array(bits)
        a = np.flatnonzero(act)
        k = E.shape[0]
        M = np.block([[A[np.ix_(a, a)], E[:, a].T], [E[:, a], np.zeros((k, k))]])
        if np.linalg.matrix_rank(M) < len(M):
            continue
        x = np.linalg.solve(M, np.concatenate([-b[a], e]))
        lam = np.zeros(n)
        lam[a] = x[:len(a)]
        g = A @ lam + b + E.T @ x[len(a):]
        if lam.min() >= -1e-12 and np.all(g[~act] >= -1e-12):
            hits.append(lam)
    return hits


@pytest.mark.parametrize("seed", range(6))
def test_lcp_equals_the_enumerated_solution(seed):
    # a strictly convex QP has one KKT point: the solver must find the same forces as the enumeration
    # (equal to round-off of an 8 x 8 solve, cond 1e3: 1e-9 relative)
    n = 8
    rng = np.random.default_rng(100 + seed)
    A = _spd(n, seed)
    b = rng.normal(size=n)
    E = rng.normal(size=(1, n))
    e = np.array([abs(rng.normal()) + 0.5]) * np.sign(E.sum())
    hits = _brute_force(A, b, E, e)
    if not hits:
        pytest.skip("no feasible point for this draw")
    sol = solve_contact_lcp(A, b, E, e)
    assert np.allclose(sol.lam, hits[0], rtol=1e-9, atol=1e-9 * np.abs(hits[0]).max())
    assert sol.lam.min() >= 0 and sol.gap.min() >= -1e-9 and abs(sol.lam @ sol.gap) < 1e-9
    assert np.allclose(E @ sol.lam, e)


def test_lcp_without_equality_rows_meets_the_conditions():
    n = 60
    A = _spd(n, 7, cond=1e4)
    b = np.random.default_rng(3).normal(size=n)
    sol = solve_contact_lcp(A, b)
    g = A @ sol.lam + b
    assert sol.lam.min() >= 0
    assert g.min() >= -1e-10 * np.abs(b).max()
    assert np.abs(sol.lam * g).max() <= 1e-10 * np.abs(b).max() * np.abs(sol.lam).max()
    assert 0 < sol.active.sum() < n          # a genuine mixed case, not all open or all closed


def test_two_springs_in_parallel_with_a_gap():
    # a rigid plate on two springs k1, k2 pushed down by d: the spring with the gap g2 carries only past g2
    k1, k2, g2 = 1e6, 2e6, 1e-6
    for d, expected in ((0.5e-6, (0.5, 0.0)), (3e-6, (3.0, 4.0))):
        A = np.diag([1 / k1, 1 / k2])
        b = np.array([0.0, g2]) - d
        sol = solve_contact_lcp(A, b)
        assert np.allclose(sol.lam, np.array(expected), rtol=1e-12)


def test_active_set_contact_is_the_same_iteration_for_any_body():
    # the callback form with the dense bordered solve gives solve_contact_lcp's answer
    n = 12
    A = _spd(n, 11)
    b = np.random.default_rng(5).normal(size=n)

    def solve_active(act):
        lam = np.zeros(n)
        a = np.flatnonzero(act)
        lam[a] = np.linalg.solve(A[np.ix_(a, a)], -b[a]) if len(a) else []
        return lam, A @ lam + b, None
    lam, gap, act, it, murty, _ = active_set_contact(solve_active, b <= 0, gap_tol=1e-12)
    assert np.allclose(lam, solve_contact_lcp(A, b).lam, rtol=1e-10, atol=1e-12)


def test_bad_input_is_refused():
    with pytest.raises(RvtoolInputError):
        solve_contact_lcp(np.eye(3), np.ones(2))
    with pytest.raises(RvtoolInputError):
        solve_contact_lcp(np.eye(2), np.array([np.nan, 1.0]))
    # two nodes that push the same way cannot balance a free body (E lam = 0 with a net force)
    with pytest.raises(RvtoolInputError):
        solve_contact_lcp(np.eye(2), -np.ones(2), E=np.ones((2, 2)), e=np.array([0.0, 1.0]))


def test_a_cycling_primal_dual_update_falls_back_to_murty():
    # found by a random search: from the empty set the primal-dual update returns to a set it has seen (A is
    # positive definite but not an M-matrix); the least-index rule must still end at the enumerated solution
    A = np.array([[2.085941, -0.964898, 3.100086, -1.239435], [-0.964898, 0.806822, -0.912789, 1.506943],
                  [3.100086, -0.912789, 5.981048, -0.041274], [-1.239435, 1.506943, -0.041274, 4.486762]])
    b = np.array([1.558347, -1.549628, 0.112725, -0.952991])
    sol = solve_contact_lcp(A, b, active=np.zeros(4, bool))
    assert sol.murty
    hits = _brute_force(A, b, np.zeros((0, 4)), np.zeros(0))
    assert len(hits) == 1
    assert np.allclose(sol.lam, hits[0], rtol=1e-10, atol=1e-12)
