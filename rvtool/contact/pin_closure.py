"""Elastic pins as an exact per-pin static condensation (issue 21): each pin's beam is allocated
once with its full station compliance matrix (Eq. (series_contact); paper, "each elastic region
is allocated once"; the coupling of Eq. (pin_compliance) without its one-step linearization).

A contact set whose pins are rigid (the ring pins of a :class:`~rvtool.contact.cycloid_set.CycloidPinSet`,
the plain output pins of an :class:`~rvtool.output_pins.evaluator.OutputPinEvaluator`) is built
with one *station body* per (pin, station): the pin's carrier (ground, or the flange) translated by
the beam deflection u_ps (2,) [m] at station s (a wheel's contact width). The contacts of wheel s
with pin p act on that body only, so the set evaluates every contact at the deflected pin. The
beam closes the station bodies: per pin, with the station compliance C (n_s, n_s) of
:meth:`rvtool.structure.pin_beam.PinBeam.station_compliance` and K_b = C^-1 (isotropic, so it
applies to x and y alike),

    R_p(q, u_p) = Q_u(q, u_p) - (K_b (x) I_2) u_p = 0,

the contact forces on the stations equal the beam's elastic forces. :class:`ElasticPinClosure`
solves this by Newton's method per pin for every evaluation (warm-started from the last solution;
at most ``max_iterations`` steps, each halved until the residual decreases) and returns the
condensed generalized forces and the exact condensed tangent

    dQ/dq = K_qq - K_qu (K_uu - K_b)^-1 K_uq

(the derivative of the forces along the solution manifold u(q); the velocity tangent likewise).
The station bodies are massless (quasi-static beam): the deflection rate does not enter the
contact velocities. Because the beam energy (1/2) u^T K_b u is invariant under rotations of u, the
stations translate in the global frame while the carrier rotates; at R_p = 0 the condensed
forces do not depend on that choice of coordinates.

The observations are the set's at the solution: the gap is the contact gap at the deflected pin
(the beam's deflection is not part of the observed approach), the force the final force.

Two generalizations use the same closure (issue 30, the compliance members of the torque path):
``dofs`` names the station body's coordinates the deflection moves ((0, 1): a translation, the
default; (2,): a rotation about the carrier's centre, a crank's torsion between its spur gear and
its eccentrics, :mod:`rvtool.structure.crank_torsion`), with K_b (x) I_{n_d}; and ``support``
replaces the linear K_b u by a nonlinear station law s(u) with its tangent ds/du (a ring pin's
conformal contact in its housing groove, :mod:`rvtool.contact.groove`): R_p = Q_u - s(u_p) = 0 and
dQ/dq = K_qq - K_qu (K_uu - ds/du)^-1 K_uq.
"""
import contextlib

import numpy as np
import scipy.sparse as sp

from ..errors import RvtoolInputError
from .evaluator import Evaluation, all_finite, check_finite_state

GROUND = -1

FALLBACKS = ("nested", "reject")
"""What a ``joint`` closure does where its network does not converge (:meth:`ElasticPinClosure.solve`)."""

RELATIVE_TOLERANCE = 1e-13
"""Station residual accepted relative to the largest contact force (about 500 machine epsilons: the
round-off of a sum of a few contact forces of that size)."""


class ElasticPinClosure:
    """Contact evaluator of elastic pins over ``n_bodies`` real bodies (module docstring).

    inner: the rigid-pin contact set over n_bodies + n_pins n_s bodies whose body
    n_bodies + station[p, s] is pin p at station s (``evaluate(pose, vel, check=False)`` ->
    :class:`~rvtool.contact.evaluator.Evaluation`, ``ids``, ``commit``, ``history``).
    carrier: real body index carrying the pins, or GROUND (-1); or one such index per pin (n_pins,)
    (the RV cranks: each crank carries its own stations); or one per station (n_pins, n_s) (a crank's
    twisting journals on its bending stations).
    station_compliance: C (n_s, n_s) [m/N], symmetric positive definite.
    station: (n_pins, n_s) station index of every (pin, station) (row of the station bodies).
    tolerance: largest station force residual accepted [N] (1e-8 N: 1e-16 m of approach at a
    contact stiffness of 1e8 N/m, the round-off of the approaches), or ``RELATIVE_TOLERANCE`` times
    the largest contact force where that is larger (the residual is a difference of forces of that
    size: at the 1e8-1e9 N forces of a diverging solver trial 1e-8 N is below their round-off).
    Attributes the model's observers read (``mesh_of``, ``pin_of``, ``meshes``, ...) are the
    inner set's: the rows are the inner set's rows.
    """

    def __init__(self, inner, *, n_bodies, carrier, station_compliance, station, tolerance=1e-8,
                 max_iterations=40, dofs=(0, 1), support=None, coupled=False, joint=False,
                 fallback="nested"):
        dofs = tuple(int(c) for c in dofs)
        if fallback not in FALLBACKS:
            raise RvtoolInputError(f"fallback = {fallback!r}; valid: {list(FALLBACKS)}")
        if not dofs or len(set(dofs)) != len(dofs) or any(c not in (0, 1, 2) for c in dofs):
            raise RvtoolInputError(f"dofs = {dofs!r}; valid: distinct station coordinates among (0, 1, 2) = (x, y, theta)")
        station = np.asarray(station, int)
        if support is not None and station_compliance is None:
            # a nonlinear station law alone: its zero-load tangent stands for the beam where a
            # linear stiffness is needed (the rigid view of ``condense`` is not offered)
            station_compliance = np.eye(station.shape[-1]) / support.zero_load_stiffness
        C = np.asarray(station_compliance, float)
        if C.ndim != 2 or C.shape[0] != C.shape[1] or station.ndim != 2 or station.shape[1] != C.shape[0]:
            raise RvtoolInputError(f"station_compliance {C.shape} and station {station.shape} must be (n_s, n_s) "
                                   "and (n_pins, n_s)")
        if not np.allclose(C, C.T, rtol=1e-10, atol=0.0) or np.linalg.eigvalsh(0.5 * (C + C.T)).min() <= 0:
            raise RvtoolInputError("station_compliance must be symmetric positive definite (a supported beam); "
                                   f"eigenvalues {np.linalg.eigvalsh(0.5 * (C + C.T))}")
        self.inner = inner
        self.name = inner.name
        self.ids = inner.ids
        self.n_bodies = int(n_bodies)
        self.station = station
        self.n_pins, self.n_stations = station.shape
        carriers = np.asarray(carrier, int)
        if carriers.ndim == 0:
            self.carrier = int(carrier)
        elif carriers.shape == (self.n_pins,):
            self.carrier = tuple(int(c) for c in carriers)
        elif carriers.shape == (self.n_pins, self.n_stations):
            self.carrier = tuple(tuple(int(c) for c in row) for row in carriers)
        else:
            raise RvtoolInputError(f"carrier has shape {carriers.shape}; valid: one body index, one per pin "
                                   f"({self.n_pins},) or one per station ({self.n_pins}, {self.n_stations})")
        carriers = (carriers if carriers.ndim == 2 else
                    np.broadcast_to(np.broadcast_to(carriers, (self.n_pins,))[:, None], (self.n_pins, self.n_stations)))
        if np.any((carriers < GROUND) | (carriers >= self.n_bodies)):
            raise RvtoolInputError(f"carrier = {carrier!r}; valid: body indices in [0, {self.n_bodies - 1}] or "
                                   "GROUND (-1)")
        nv = station.size
        if inner.n_bodies != self.n_bodies + nv:
            raise RvtoolInputError(f"inner.n_bodies = {inner.n_bodies}; it must be n_bodies + n_pins n_s = "
                                   f"{self.n_bodies + nv}")
        self.compliance = C
        self.beam_stiffness = np.linalg.inv(C)
        self.dofs = dofs
        self.support = support
        nd = len(dofs)
        self.tolerance = float(tolerance)
        self.max_iterations = int(max_iterations)
        self.history = inner.history
        nr = 3 * self.n_bodies
        # q_ext = M [q; u]: real bodies as they are; station body = carrier pose + u on ``dofs``
        self._n_u = nd * nv
        M = np.zeros((3 * (self.n_bodies + nv), nr + self._n_u))
        M[:nr, :nr] = np.eye(nr)
        # u ordered per pin, then station, then dofs: pin p's block is contiguous
        self._u_index = np.zeros((self.n_pins, self.n_stations, nd), int)
        for p in range(self.n_pins):
            for s in range(self.n_stations):
                b = 3 * (self.n_bodies + station[p, s])
                k = nr + nd * (p * self.n_stations + s)
                self._u_index[p, s] = np.arange(k - nr, k - nr + nd)
                for j, c in enumerate(dofs):
                    M[b + c, k + j] = 1.0
                c = int(carriers[p, s])
                if c != GROUND:
                    M[b:b + 3, 3 * c:3 * c + 3] += np.eye(3)
        self._M = sp.csr_matrix(M)
        self._MT = self._M.T.tocsr()
        self._Kb = np.kron(np.eye(self.n_pins), np.kron(self.beam_stiffness, np.eye(nd)))
        self._u = np.zeros(self._n_u)
        self.last_iterations = 0
        self.coupled = bool(coupled)
        self._condense_factor = 1.0
        self.joint = bool(joint)
        self.fallback = fallback
        self._network = None          # the JointNetwork of a joint closure, built on its first solve
        #: evaluations of the inner set made by this closure's solves (of the leaf contact set where this is the
        #: innermost closure, by a joint network above it included): the cost counter of the nesting
        self.inner_evaluations = 0
        #: solves of a ``joint`` closure whose network did not converge and that fell back to the nested solve
        #: (:meth:`solve`; each costs the nested solve's product of the levels' iterations)
        self.fallbacks = 0

    def __getattr__(self, name):
        # row attributes of the inner set (mesh_of, pin_of, meshes, pin_forces, ...); only reached
        # for names this class does not define
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    # -- the closure -------------------------------------------------------------------
    def _extended(self, pose, vel, u):
        ext = (self._M @ np.concatenate([np.asarray(pose, float).ravel(), u])).reshape(-1, 3)
        vext = (self._M @ np.concatenate([np.asarray(vel, float).ravel(), np.zeros_like(u)])).reshape(-1, 3)
        return ext, vext

    def _reduced(self, ev, u):
        """(Q_red (3 nb + 2 nv,), K_red, D_red or None) of an inner evaluation at station
        deflections u, the beam's elastic forces included."""
        Q = self._MT @ ev.Q
        K = self._project(ev.dQdq)
        if self.support is None:
            Q[3 * self.n_bodies:] -= self._Kb @ u
            K[3 * self.n_bodies:, 3 * self.n_bodies:] -= self._Kb
        else:
            F, G = self.support.forces(u.reshape(self.n_pins, self.n_stations, len(self.dofs)))
            Q[3 * self.n_bodies:] -= F.ravel()
            m = self.n_stations * len(self.dofs)
            for p in range(self.n_pins):
                sl = slice(3 * self.n_bodies + p * m, 3 * self.n_bodies + (p + 1) * m)
                K[sl, sl] -= G[p]
        D = None if ev.dQdv is None else self._project(ev.dQdv)
        return Q, K, D

    def _project(self, A):
        """M^T A M for a dense A (M sparse: one or two ones per row)."""
        return np.ascontiguousarray((self._MT @ (self._MT @ np.asarray(A)).T).T)

    def solve(self, pose, vel, u0=None):
        """Station deflections u (2 n_pins n_s,) [m] at poses/velocities (nb, 3), the inner
        evaluation there and the reduced (Q, K, D). Raises nothing: ``converged`` says.

        ``joint`` (and the inner set another closure): one Newton over the stations of every closure
        nested below (:class:`JointNetwork`), the inner closures' stations condensed out of the
        reduced system; where it does not converge (counted in :attr:`fallbacks`), by ``fallback``:
        ``"nested"``, the nested solve below (each inner closure solved for every evaluation of this
        one; at a far trial state of an outer solver the inner closures' own networks fail as well and
        the nested solves cascade: minutes of CPU for one evaluation, measured on rv40e), or
        ``"reject"``, the reduced system NaN: the trial state is answered as non-finite, which the
        outer solver rejects (the element's answer to a diverged trial,
        :meth:`exudyn_user_elements.contact_element.ContactElement.evaluate`), as it would any
        evaluation without a converged station equilibrium."""
        if self.joint and isinstance(self.inner, ElasticPinClosure):
            if self._network is None or self._network.chain[0] is not self:
                # (built on the first solve; rebuilt for a copy of the closure, e.g. a model snapshot's, whose
                # copied __dict__ still names the original's network)
                self._network = JointNetwork(self)
            out = self._network.solve(pose, vel, u0)
            if out[3]:
                return out
            self.fallbacks += 1
            if self.fallback == "reject":
                u, ev, red, _ = out
                return u, ev, tuple(None if a is None else np.full_like(a, np.nan) for a in red), False
        return self.nested_solve(pose, vel, u0)

    def nested_solve(self, pose, vel, u0=None):
        """:meth:`solve` by Newton over this closure's stations, the inner set evaluated (an inner
        closure solved) at every iterate."""
        nr = 3 * self.n_bodies
        u = self._u.copy() if u0 is None else np.asarray(u0, float).copy()
        for restart in (False, True):
            if restart:
                u = np.zeros(self._n_u)
            ext, vext = self._extended(pose, vel, u)
            ev = self.inner.evaluate(ext, vext, check=False)
            self.inner_evaluations += 1
            Q, K, D = self._reduced(ev, u)
            r = np.abs(Q[nr:]).max(initial=0.0)
            for it in range(self.max_iterations):
                if self._accepted(r, ev) or not np.isfinite(r):
                    break
                du = -self._solve_uu(K[nr:, nr:], Q[nr:])
                step = 1.0
                for _ in range(12):
                    un = u + step * du
                    ext, vext = self._extended(pose, vel, un)
                    evn = self.inner.evaluate(ext, vext, check=False)
                    self.inner_evaluations += 1
                    Qn, Kn, Dn = self._reduced(evn, un)
                    rn = np.abs(Qn[nr:]).max(initial=0.0)
                    if rn < r or self._accepted(rn, evn):
                        break
                    step *= 0.5
                u, ev, Q, K, D, r = un, evn, Qn, Kn, Dn, rn
                self.last_iterations = it + 1
            if self._accepted(r, ev):
                return u, ev, (Q, K, D), True
        return u, ev, (Q, K, D), False

    def _accepted(self, r, ev):
        """Residual r [N] within the tolerance (class docstring) at the inner evaluation ev."""
        return r <= self.tolerance or r <= RELATIVE_TOLERANCE * np.abs(ev.Q).max(initial=0.0)

    def _solve_uu(self, Kuu, rhs):
        """Kuu^-1 rhs with Kuu block diagonal per pin (n_d n_s square blocks); the full Kuu where
        ``coupled`` (an inner closure couples the pins: its condensed tangent links stations of
        different pins, e.g. the cranks' journals through an elastic wheel)."""
        if self.coupled:
            return np.linalg.solve(Kuu, rhs)
        m = len(self.dofs) * self.n_stations
        n = self.n_pins
        blocks = Kuu.reshape(n, m, n, m)[np.arange(n), :, np.arange(n), :]
        x = np.linalg.solve(blocks, np.asarray(rhs).reshape(n, m, -1))
        return x.reshape(n * m, -1) if np.ndim(rhs) == 2 else x.reshape(-1)

    def station_forces(self, pose, u):
        """(F, dF/du, dF/dq or None): the station law's forces F (n_u,) on the stations at deflections
        u (n_u,) and real-body poses ``pose`` (n_bodies, 3), its tangent along u and, where the law
        depends on the poses (:class:`~rvtool.contact.wheel_closure.WheelBodyClosure`), along the
        real coordinates (n_u, 3 n_bodies) (the terms :meth:`_reduced` subtracts)."""
        u = np.asarray(u, float)
        if self.support is None:
            return self._Kb @ u, self._Kb, None
        F, G = self.support.forces(u.reshape(self.n_pins, self.n_stations, len(self.dofs)))
        return F.ravel(), self._block_diagonal(G), None

    @property
    def network(self):
        """The :class:`JointNetwork` of a ``joint`` closure (None before its first solve or where not joint)."""
        return self._network

    @property
    def extension(self):
        """M (sparse, 3 (n_bodies + n_pins n_s) x (3 n_bodies + n_u)): the poses of the real and the
        station bodies the inner set is evaluated on, from [real poses; station deflections]."""
        return self._M

    @property
    def n_u(self):
        """Number of station deflection coordinates (n_pins n_s n_d)."""
        return self._n_u

    @property
    def condense_factor(self):
        """The station stiffness factor of the condensation (1; another inside :meth:`stiffened_view`)."""
        return self._condense_factor

    def support_tangent(self, u):
        """The station law's tangent ds/du (n_u, n_u) at deflections u (block diagonal per pin);
        K_b for the linear beam."""
        if self.support is None:
            return self._Kb
        _, G = self.support.forces(np.asarray(u, float).reshape(self.n_pins, self.n_stations, len(self.dofs)))
        return self._block_diagonal(G)

    def _block_diagonal(self, G):
        """(n_u, n_u) from the per-pin blocks G (n_pins, m, m)."""
        m = self.n_stations * len(self.dofs)
        out = np.zeros((self._n_u, self._n_u))
        for p in range(self.n_pins):
            out[p * m:(p + 1) * m, p * m:(p + 1) * m] = G[p]
        return out

    def condense(self, red, beam_factor=1.0, u=None):
        """(Q, dQ/dq, dQ/dv) on the real coordinates from reduced (Q, K, D); ``beam_factor``
        scales K_b (a nonlinear station law: its tangent at the solved deflections ``u``) in the
        condensation only (the budget's switch-to-rigid view of the beam)."""
        Q, K, D = red
        nr = 3 * self.n_bodies
        Kuu = K[nr:, nr:]
        if beam_factor != 1.0:
            if self.support is not None and u is None:
                raise RvtoolInputError("beam_factor != 1 with a nonlinear station law (support) needs the solved "
                                       "deflections u")
            Kuu = Kuu - (beam_factor - 1.0) * (self._Kb if self.support is None else self.support_tangent(u))
        X = self._solve_uu(Kuu, K[nr:, :nr])
        dQdq = K[:nr, :nr] - K[:nr, nr:] @ X
        dQdv = None
        if D is not None:
            dQdv = D[:nr, :nr] - K[:nr, nr:] @ self._solve_uu(Kuu, D[nr:, :nr])
        return Q[:nr], dQdq, dQdv

    @contextlib.contextmanager
    def stiffened_view(self, factor):
        """Within the block, :meth:`evaluate` condenses with the station stiffness times ``factor``
        (the solved deflections unchanged: only the tangent it returns differs): the switch-to-rigid
        and sensitivity views of a closure nested inside another one (the budget's series paths,
        :class:`rvtool.assembly.rv.builder.NestedSeries`)."""
        old = self._condense_factor
        self._condense_factor = float(factor)
        try:
            yield self
        finally:
            self._condense_factor = old

    def station_energy(self, du, u):
        """du^T (ds/du) du [N m]: twice the station law's strain energy along station deflection
        increments du (n_pins, n_s, n_d) at solved deflections u (the beam: du^T K_b du)."""
        du = np.asarray(du, float).ravel()
        return float(du @ self.support_tangent(u) @ du)

    # -- evaluator protocol --------------------------------------------------------------
    def evaluate(self, pose, vel, history=None, check=True):
        if check:
            check_finite_state(pose, vel, self.n_bodies)
        u, ev, red, ok = self.solve(pose, vel)
        if ok:
            self._u = u
        Q, dQdq, dQdv = self.condense(red, beam_factor=self._condense_factor, u=u)
        finite = ok and ev.finite and all_finite(Q, dQdq) and (dQdv is None or all_finite(dQdv))
        return Evaluation(Q, dQdq, dQdv, ev.obs, ev.trial_history, finite)

    def commit(self, pose, vel, evaluation=None):
        if evaluation is not None:
            return np.array(evaluation.obs, float)
        u, ev, _, _ = self.solve(pose, vel)
        return np.array(ev.obs, float)

    def extended_pose(self, pose):
        """Poses (n_bodies + n_pins n_s, 3) of the real and the station bodies at the solved
        deflections, static poses (nb, 3): the state the inner set's contacts are evaluated at."""
        pose = np.asarray(pose, float)
        u = self.solve(pose, np.zeros_like(pose))[0]
        return self._extended(pose, np.zeros_like(pose), u)[0]

    def deflections(self, pose):
        """Station deflections (n_pins, n_s, n_d) [m or rad] at static poses (nb, 3)."""
        u = self.solve(pose, np.zeros_like(np.asarray(pose, float)))[0]
        return u[self._u_index]


LINE_SEARCH_HALVINGS = 8
"""Step halvings of one Newton iteration's line search (a step of 1/256 of the Newton step is the shortest
tried); where none decreases the merit the attempt stops (an increase is never accepted) and the next start
(zero deflections, the continuation) is tried."""

ARMIJO = 1e-4
"""Sufficient decrease of the merit per unit step (Armijo's constant; the usual 1e-4)."""

CONTINUATION_ITERATIONS = 8
"""Newton iterations of one continuation step of :meth:`JointNetwork.solve` (a step the predictor brought
near its solution converges in 2-5; more means the step is too long and it is shortened)."""

CONTINUATION_EVALUATIONS = 60
"""Contact evaluations one continuation may spend (about six ordinary network solves; a trial state it cannot
reach within that is left to the fallback: at rv40e's far trial states of Exudyn's Newton, turns of 1.5-12 rad
and 0.3 m from the last converged state, the continuation stalls below 1e-3 of the way, and 240 evaluations
there were 40 % of one b/a's evaluations)."""

SHORTEST_CONTINUATION_STEP = 1.0 / 1024
"""Shortest continuation step [-] (a fraction of the pose change from the last converged state)."""


class JointNetwork:
    """The closures nested in a ``joint`` :class:`ElasticPinClosure` (``top``; each inner set another
    closure down to a contact set, the *leaf*) solved as one series network: one Newton over the
    station deflections of every closure at once, the leaf evaluated once per iterate, instead of
    every inner closure solved to convergence at every iterate of the one outside it (whose cost
    grows as the product of the levels' iteration counts).

    Coordinates x = [q (3 n_bodies); u_0; u_1; ...] (u_k the stations of closure k, 0 the top). The
    poses each closure is evaluated on are linear in x, p_{k+1} = M_k [p_k; u_k] (M_k its
    :attr:`~ElasticPinClosure.extension`), composed once into sparse maps P_k. The residual on u_k
    is the leaf's generalized force through P_leaf minus closure k's station forces
    (:meth:`ElasticPinClosure.station_forces`): the equations the nested solve satisfies level by
    level (at an inner closure's solution its condensed force is the leaf's force through the maps
    below it), so the solution is the nested one within the closures' tolerance. The inner stations
    are then condensed out (each closure's block of the station tangent times its
    :attr:`~ElasticPinClosure.condense_factor`, as its own condensation would), which leaves the
    top's reduced system (Q, K, D) over [q; u_0]: the Schur complements of a nested condensation
    compose to the one of the whole network. D's station columns (unused by the condensation) are
    zero.

    **The Newton** (:meth:`solve`; the equations and the tolerance are the closures', so a converged
    answer is the same whichever way it was reached):

    * the step solves the station tangent scaled by its diagonal (the levels mix N/m and N m/rad and
      stiffnesses 1e5-1e10: the scaling keeps the direction accurate at the far, badly conditioned
      trial states of an outer solver);
    * a backtracking line search on the merit |D^-1 R|^2 (D the square root of the tangent's diagonal,
      R the station residual) with Armijo's condition (:data:`ARMIJO`, :data:`LINE_SEARCH_HALVINGS`);
      a step that does not decrease it is never taken: the attempt stops;
    * stations of a closure whose law is *isolated* (``support.isolated_stations``: each station's
      force its own and zero only at zero deflection, the pins' grooves) that carry no contact force
      and no contact tangent (an open contact) are set to zero deflection, their exact solution (Newton
      approaches it only linearly on the groove's logarithmic law: 4-8 iterations of every solve were
      spent so); the line search guards the step, and a contact that closes again at zero is back in
      the Newton at the next iterate;
    * from the warm start (the last converged solve), else from zero deflections, else by a
      continuation in the poses from the last converged solve to the trial state (Euler predictor
      along the exact tangent dU/dlambda = -K_uu^-1 K_uq dq, steps halved on failure and doubled on
      success, :data:`CONTINUATION_ITERATIONS`, :data:`CONTINUATION_EVALUATIONS`,
      :data:`SHORTEST_CONTINUATION_STEP`).

    Counters: ``solves``, ``continued`` (solves the continuation converged), ``failures`` (solves that
    did not converge: the closure then falls back to its nested solve, :attr:`ElasticPinClosure.fallbacks`)."""

    def __init__(self, top):
        chain = [top]
        while isinstance(chain[-1].inner, ElasticPinClosure):
            chain.append(chain[-1].inner)
        self.chain = chain
        self.leaf = chain[-1].inner
        nr = 3 * top.n_bodies
        sizes = [c.n_u for c in chain]
        self.offsets = np.cumsum([nr] + sizes)          # x rows of u_k: offsets[k]:offsets[k + 1]
        nx = int(self.offsets[-1])
        self.nx, self.nr = nx, nr
        P = sp.identity(nx, format="csr")[:nr]
        self.maps = []
        for k, c in enumerate(chain):
            self.maps.append(P)
            E = sp.identity(nx, format="csr")[self.offsets[k]:self.offsets[k + 1]]
            P = (c.extension @ sp.vstack([P, E])).tocsr()
        self.P, self.PT = P, P.T.tocsr()
        self._isolated = [c.support is not None and bool(getattr(c.support, "isolated_stations", False))
                          for c in chain]
        self._U = np.zeros(nx - nr)
        self._last = None            # (pose, vel, U, K) of the last converged solve: the continuation's start
        self.last_iterations = 0
        #: network solves, solves converged by the continuation, solves that did not converge (class docstring)
        self.solves = 0
        self.continued = 0
        self.failures = 0

    @property
    def stations(self):
        """The station deflections [u_0; u_1; ...] (nx - 3 n_bodies,) of the last converged solve (the warm start)."""
        return self._U.copy()

    def _reduced(self, pose, vel, U):
        """(leaf evaluation, Q (nx,), K (nx, nx), D (nx, nx) or None, the closures' station tangents
        [dF_k/du_k], the free stations: indices into U of the isolated laws' stations without contact
        force or tangent) at stations U."""
        x = np.concatenate([np.asarray(pose, float).ravel(), U])
        v = np.concatenate([np.asarray(vel, float).ravel(), np.zeros_like(U)])
        ev = self.leaf.evaluate((self.P @ x).reshape(-1, 3), (self.P @ v).reshape(-1, 3), check=False)
        self.chain[-1].inner_evaluations += 1
        Q = self.PT @ ev.Q
        K = np.ascontiguousarray((self.PT @ (self.PT @ np.asarray(ev.dQdq)).T).T)
        D = None if ev.dQdv is None else np.ascontiguousarray((self.PT @ (self.PT @ np.asarray(ev.dQdv)).T).T)
        Gs, free = [], []
        for k, c in enumerate(self.chain):
            sl = slice(self.offsets[k], self.offsets[k + 1])
            if self._isolated[k]:
                nd = len(c.dofs)
                z = (Q[sl] == 0.0) & ~np.any(K[sl] != 0.0, axis=1)
                free.append(np.flatnonzero(np.repeat(z.reshape(-1, nd).all(axis=1), nd)) + (sl.start - self.nr))
            F, G, Gq = c.station_forces((self.maps[k] @ x).reshape(-1, 3), U[sl.start - self.nr:sl.stop - self.nr])
            Q[sl] -= F
            K[sl, sl] -= G
            if Gq is not None:
                K[sl] -= (self.maps[k].T @ Gq.T).T
            Gs.append(G)
        return ev, Q, K, D, Gs, (np.concatenate(free) if free else np.zeros(0, int))

    def _accepted(self, r, ev):
        tol = min(c.tolerance for c in self.chain)
        return r <= tol or r <= RELATIVE_TOLERANCE * np.abs(ev.Q).max(initial=0.0)

    @staticmethod
    def _scaled_solve(Kuu, rhs):
        """Kuu^-1 rhs with Kuu scaled by the square root of its diagonal on both sides (class docstring);
        raises numpy.linalg.LinAlgError where singular."""
        d = np.sqrt(np.abs(np.diag(Kuu)))
        d[~(np.isfinite(d) & (d > 0))] = 1.0
        return np.linalg.solve(Kuu / d[:, None] / d[None, :], (rhs.T / d).T) / (d if np.ndim(rhs) == 1 else d[:, None])

    def _newton(self, pose, vel, U, max_iterations):
        """(converged, iterations, (U, ev, Q, K, D, G)): Newton from stations U at the poses (class docstring)."""
        nr = self.nr
        ev, Q, K, D, G, free = self._reduced(pose, vel, U)
        state = (U, ev, Q, K, D, G)
        for it in range(max_iterations):
            R = Q[nr:]
            r = np.abs(R).max(initial=0.0)
            if self._accepted(r, ev):
                return True, it, state
            if not np.isfinite(r):
                return False, it, state
            Kuu = K[nr:, nr:]
            d = np.sqrt(np.abs(np.diag(Kuu)))
            d[~(np.isfinite(d) & (d > 0))] = 1.0
            try:
                dU = -self._scaled_solve(Kuu, R)
            except np.linalg.LinAlgError:
                return False, it, state
            if not np.all(np.isfinite(dU)):
                return False, it, state
            dU[free] = -U[free]
            m0 = float(np.sum((R / d) ** 2))
            step = 1.0
            for _ in range(LINE_SEARCH_HALVINGS + 1):
                Un = U + step * dU
                evn, Qn, Kn, Dn, Gn, fn = self._reduced(pose, vel, Un)
                Rn = Qn[nr:]
                mn = float(np.sum((Rn / d) ** 2))
                if self._accepted(np.abs(Rn).max(initial=0.0), evn) or mn <= (1.0 - ARMIJO * step) * m0:
                    break
                step *= 0.5
            else:
                return False, it, state
            U, ev, Q, K, D, G, free = Un, evn, Qn, Kn, Dn, Gn, fn
            state = (U, ev, Q, K, D, G)
            self.last_iterations = it + 1
        return self._accepted(np.abs(Q[nr:]).max(initial=0.0), ev), max_iterations, state

    def _continuation(self, pose, vel):
        """(converged, state) by a continuation in the poses from the last converged solve (class docstring)."""
        nr = self.nr
        p0, v0, U, K = self._last
        p1, v1 = np.asarray(pose, float), np.asarray(vel, float)
        dq = (p1 - p0).ravel()
        e0 = self.chain[-1].inner_evaluations
        lam, h, state = 0.0, 1.0, None
        while lam < 1.0:
            lt = min(1.0, lam + h)
            try:
                dU = -self._scaled_solve(K[nr:, nr:], K[nr:, :nr] @ dq)
            except np.linalg.LinAlgError:
                return False, state
            ok, _, st = self._newton(p0 + lt * (p1 - p0), v0 + lt * (v1 - v0), U + (lt - lam) * dU,
                                     CONTINUATION_ITERATIONS)
            if ok:
                lam, U, K, state = lt, st[0], st[3], st
                h = min(2.0 * h, 1.0)
            else:
                h *= 0.5
                if h < SHORTEST_CONTINUATION_STEP or self.chain[-1].inner_evaluations - e0 > CONTINUATION_EVALUATIONS:
                    return False, state
        return True, state

    def solve(self, pose, vel, u0=None):
        """As :meth:`ElasticPinClosure.solve` of the top (its stations u_0, the leaf evaluation, the
        top's reduced system with the inner stations condensed, converged); class docstring."""
        nr, n0 = self.nr, self.chain[0].n_u
        self.solves += 1
        U = self._U.copy()
        if u0 is not None:
            U[:n0] = u0
        n_it = max(c.max_iterations for c in self.chain)
        ok, _, state = self._newton(pose, vel, U, n_it)
        if not ok and np.any(U != 0.0):
            ok, _, state0 = self._newton(pose, vel, np.zeros_like(U), n_it)
            state = state0 if ok else state
        if not ok and self._last is not None:
            ok, cstate = self._continuation(pose, vel)
            if ok:
                self.continued += 1
                state = cstate
        U, ev, Q, K, D, G = state
        if ok:
            self._U = U.copy()
            self._last = (np.array(pose, float), np.array(vel, float), self._U, K)
        else:
            self.failures += 1
        return U[:n0].copy(), ev, self._condensed(Q, K, D, G), ok

    def _condensed(self, Q, K, D, G):
        """The top's reduced (Q, K, D) over [q; u_0]: the inner stations condensed (class docstring)."""
        a = int(self.offsets[1])
        Kbb = K[a:, a:].copy()
        for k, c in enumerate(self.chain[1:], start=1):
            f = c.condense_factor
            if f != 1.0:
                sl = slice(self.offsets[k] - a, self.offsets[k + 1] - a)
                Kbb[sl, sl] -= (f - 1.0) * G[k]
        X = np.linalg.solve(Kbb, np.hstack([K[a:, :a]] + ([] if D is None else [D[a:, :self.nr]])))
        Kr = K[:a, :a] - K[:a, a:] @ X[:, :a]
        Dr = None
        if D is not None:
            Dr = np.zeros((a, a))
            Dr[:, :self.nr] = D[:a, :self.nr] - K[:a, a:] @ X[:, a:]
        return Q[:a].copy(), Kr, Dr
