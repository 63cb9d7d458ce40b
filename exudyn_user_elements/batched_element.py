"""B independent reducer copies as B Exudyn ``ObjectGenericODE2`` elements sharing one batch evaluation.

Element c spans the nodes of copy c (3 nb coordinates) and returns that copy's
contact forces Q_c = sum over families of G^T f (Eq. (contact_mapping)) and its
tangent block J_c = -(f_ODE2 dQ_c/dq_c + f_ODE2_t dQ_c/dq_t_c) (Exudyn's
convention for ``ObjectGenericODE2``, as in
:mod:`exudyn_user_elements.contact_element`). Exudyn assembles the B dense
3 nb x 3 nb blocks into its sparse system matrix: the batch tangent is block
diagonal and no entry couples two copies.

One launch per family and Newton state: the first callback of an evaluation
round whose q_c differs from the cached batch state reads the coordinates of
ALL copies from the system's current configuration
(``GetODE2Coordinates(configuration=Current)`` and ``_t``; Exudyn's static
solver and the generalized-alpha Newton write each trial iterate there before
calling user functions, verified against the q passed to the callback), evaluates
every copy in one launch per family, and caches the per-copy blocks; the other
B - 1 callbacks of the round find their q_c equal to the cached one and return
their block. Copies are independent, so a cached block is valid for element c
whenever q_c (and q_t_c) equal the cached values, whatever the other copies do.
If the current configuration ever disagreed with the callback's q_c, the
element's own q_c is written into the batch state and the batch re-evaluated
(correct in any case; counted in ``stale_reads``).

The callbacks keep Exudyn's exact signatures and contain no physics.
"""
import time

import numpy as np
import exudyn as exu
from exudyn.itemInterface import ObjectGenericODE2, VObjectGenericODE2


class BatchedContactElements:
    """The B per-copy elements of a batch and their shared evaluation cache.

    mbs: exudyn MainSystem; copy_nodes: list (B) of node lists (nb each, body order of the
    evaluator); evaluator: :class:`rvtool.batched.evaluator.BatchContactEvaluator`.
    ``timing["callbacks"]`` accumulates the wall time [s] inside the Python callbacks
    (including the batch evaluations), ``n_force_calls``/``n_jacobian_calls`` count them.
    """

    def __init__(self, mbs, copy_nodes, evaluator):
        self.mbs = mbs
        self.evaluator = evaluator
        self.B = len(copy_nodes)
        self.nb = len(copy_nodes[0])
        self.n = 3 * self.nb
        self.reference = np.array([[mbs.GetNodeParameter(n, "referenceCoordinates") for n in nodes]
                                   for nodes in copy_nodes], float).reshape(self.B, self.n)
        self.object_numbers = []
        for c, nodes in enumerate(copy_nodes):
            self.object_numbers.append(mbs.AddObject(ObjectGenericODE2(
                nodeNumbers=[int(n) for n in nodes], massMatrix=np.zeros((self.n, self.n)),
                forceUserFunction=self._make_force(c), jacobianUserFunction=self._make_jacobian(c),
                visualization=VObjectGenericODE2(show=False))))
        self.ltg = None
        self._q = None          # (B, 3 nb) batch state of the cached evaluation
        self._v = None
        self._ev = None
        self.timing = {"callbacks": 0.0}
        self.n_force_calls = 0
        self.n_jacobian_calls = 0
        self.n_batch_evaluations = 0
        self.stale_reads = 0

    def attach(self, ltg):
        """Global ODE2 indices (B, 3 nb) of each copy's coordinates (after ``mbs.Assemble``)."""
        self.ltg = np.asarray(ltg, int)
        self._q = None

    # -- batch evaluation ------------------------------------------------------
    def evaluate_state(self, q, v):
        """Batch evaluation at per-copy displacement coordinates q, v (B, 3 nb) (no caching)."""
        pose = (self.reference + q).reshape(-1, 3)
        return self.evaluator.evaluate(pose, np.asarray(v, float).reshape(-1, 3))

    def evaluation(self, q_global, v_global):
        """Batch evaluation at global coordinate vectors, reusing the cache when it matches."""
        q = np.asarray(q_global, float)[self.ltg]
        v = np.asarray(v_global, float)[self.ltg]
        if self._q is None or not (np.array_equal(q, self._q) and np.array_equal(v, self._v)):
            self._set(q, v)
        return self._ev

    def _set(self, q, v):
        self._ev = self.evaluate_state(q, v)
        self._q, self._v = q, v
        # per-copy byte keys: the callbacks' cache test is one bytes comparison (a few 100 ns)
        # instead of two array comparisons (~10 us per callback, 2 B callbacks per iteration)
        self._keys = [qc.tobytes() + vc.tobytes() for qc, vc in zip(q, v)]
        self.n_batch_evaluations += 1

    def invalidate(self):
        self._q = None

    def _block(self, c, q, q_t):
        q = np.asarray(q, float)
        q_t = np.asarray(q_t, float)
        if self._q is None or q.tobytes() + q_t.tobytes() != self._keys[c]:
            sd = self.mbs.systemData
            qa = np.asarray(sd.GetODE2Coordinates(configuration=exu.ConfigurationType.Current))[self.ltg]
            va = np.asarray(sd.GetODE2Coordinates_t(configuration=exu.ConfigurationType.Current))[self.ltg]
            if not (np.array_equal(qa[c], q) and np.array_equal(va[c], q_t)):
                self.stale_reads += 1
                qa[c], va[c] = q, q_t
            self._set(qa, va)
        return self._ev

    # -- Exudyn callbacks (exact signatures) -------------------------------------
    def _make_force(self, c):
        def force(mbs, t, itemNumber, q, q_t):
            t0 = time.perf_counter()
            self.n_force_calls += 1
            Q = self._block(c, q, q_t).Q[c]
            self.timing["callbacks"] += time.perf_counter() - t0
            return Q
        return force

    def _make_jacobian(self, c):
        def jacobian(mbs, t, itemNumber, q, q_t, fODE2, fODE2_t):
            t0 = time.perf_counter()
            self.n_jacobian_calls += 1
            ev = self._block(c, q, q_t)
            J = -fODE2 * ev.dQdq[c]
            if fODE2_t != 0.0:       # the static solver's velocity factor is zero: no damping blocks
                J -= fODE2_t * ev.dQdv[c]
            self.timing["callbacks"] += time.perf_counter() - t0
            return J
        return jacobian
