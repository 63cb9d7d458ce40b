"""Contact set as an Exudyn ``ObjectGenericODE2`` with force and Jacobian user functions.

The element spans the nodes of the participating planar rigid bodies
(``NodeRigidBody2D``: x, y, theta). Its force callback gathers q and q_t once,
evaluates every contact of the set in one kernel launch and returns
Q = G^T f (Eq. (contact_mapping)); the Jacobian callback returns the analytic
tangent of Eq. (assembled_contact_tangent) in Exudyn's convention for
``ObjectGenericODE2``: J_user = -(f_ODE2 dQ/dq + f_ODE2_t dQ/dq_t).
The kernel result is cached per state, so the Jacobian at the state of the
preceding residual costs no second launch.

Elastic supports through ports: with ``ports=PortBodies(structure, rows)`` the
element also spans the structural coordinates eta of a
:class:`~exudyn_user_elements.reduced_structure.ReducedStructure`. The evaluator
then sees n_virtual extra planar bodies ("port bodies", appended after the rigid
ones) whose poses are the port displacements (u_x, u_y, 0) = (H_x eta, H_y eta, 0);
with T = blockdiag(I, P) (P stacks the x, y, theta rows per port body, theta rows
zero), the element returns Q = T^T Q_b and dQ/dq = T^T (dQ_b/dq_b) T: the
constant-map contraction of Eq. (port_runtime_transform), exact, with all
rigid--port and port--port blocks.
A state-dependent map (:class:`~exudyn_user_elements.floating_ports.FloatingPorts`, the
ports of floating flexible bodies) hands the element the virtual poses and their Jacobian T at
each state; the contraction is the same with that T.

The callbacks keep Exudyn's exact signatures and contain no physics; the
physics lives in :mod:`warp_contacts` and :mod:`rvtool.contact`.
"""
import numpy as np
import exudyn as exu
from exudyn.itemInterface import ObjectGenericODE2, VObjectGenericODE2

from rvtool.contact.circle_set import CircleContactSet
from rvtool.contact.evaluator import ContactSetEvaluator, Evaluation
from rvtool.errors import RvtoolInputError
from rvtool.observe.registry import ContactSnapshot
from warp_contacts import circle_pairs_ref as ref


class PortBodies:
    """Port bodies of a contact element on an elastic structure.

    structure: :class:`exudyn_user_elements.reduced_structure.ReducedStructure`;
    rows: (n_virtual, 2) row indices of the structure's port maps H giving the x and y
    displacement [m] of each port body (its rotation is zero: a nodal port carries
    translations only).
    """

    def __init__(self, structure, rows):
        rows = np.asarray(rows, dtype=int)
        H = np.asarray(structure.reduced.maps, float)
        if rows.ndim != 2 or rows.shape[1] != 2 or len(rows) < 1:
            raise RvtoolInputError(f"rows must have shape (n_virtual, 2) with n_virtual >= 1; got {rows.shape}")
        if rows.min() < 0 or rows.max() >= H.shape[0]:
            raise RvtoolInputError(f"rows must lie in [0, {H.shape[0] - 1}] (port-map rows); got [{rows.min()}, {rows.max()}]")
        self.structure = structure
        self.rows = rows
        self.n_virtual = len(rows)
        self.n_eta = H.shape[1]
        P = np.zeros((3 * self.n_virtual, self.n_eta))
        P[0::3] = H[rows[:, 0]]
        P[1::3] = H[rows[:, 1]]
        self.P = P

    @classmethod
    def rigid_fit(cls, structure, rows, angles, radius):
        """One port body that moves rigidly with the least-squares rigid motion of the ports
        ``rows`` (x, y rows per port) at polar ``angles`` [rad] on a circle of ``radius`` [m]
        (equally spaced): x, y the mean port translation, theta the mean tangential displacement
        over the radius. A ring gear carried by an elastic housing moves so (the housing's
        translation and torsion; ovalization of the bore is not represented). ``rows`` stays the
        fitted ports' rows; ``P`` is the one body's (x, y, theta) map."""
        rows = np.asarray(rows, dtype=int)
        out = cls(structure, rows)
        Hx, Hy = out.P[0::3], out.P[1::3]
        a = np.asarray(angles, float)[:, None]
        out.P = np.vstack([Hx.mean(axis=0), Hy.mean(axis=0), (-np.sin(a) * Hx + np.cos(a) * Hy).mean(axis=0) / radius])
        out.n_virtual = 1
        return out


class ContactElement:
    """A contact set attached to an Exudyn system.

    Parameters
    ----------
    mbs : exudyn MainSystem
    nodes : node numbers of the set's bodies, in the order of the set's body indices
    contact_set : :class:`rvtool.contact.circle_set.CircleContactSet`, or an
        evaluator object of any contact family following the evaluator protocol
        (attributes ``name``, ``ids``, ``n_bodies``, ``history``; methods
        ``evaluate(pose, vel, history=None, check=True) -> Evaluation`` and
        ``commit(pose, vel, evaluation=None) -> obs`` with the observation
        columns of :mod:`warp_contacts.circle_pairs_ref`; ``check=False`` skips
        input checks the element already made, and ``evaluation`` is a trial
        evaluation at exactly the accepted state that commit may reuse)
    backend, precision, device : evaluation options (see ContactSetEvaluator),
        used when ``contact_set`` is a CircleContactSet
    ports : :class:`PortBodies` or None; the set's bodies are then the rigid ``nodes``
        followed by the port bodies (``contact_set.n_bodies = len(nodes) + n_virtual``)
    """

    def __init__(self, mbs, nodes, contact_set, *, backend="warp", precision="float64", device="cpu", ports=None):
        nodes = [int(n) for n in nodes]
        if isinstance(contact_set, CircleContactSet):
            evaluator = ContactSetEvaluator(contact_set, backend=backend, precision=precision, device=device)
        else:
            evaluator = contact_set
            for attr in ("name", "ids", "n_bodies", "history", "evaluate", "commit"):
                if not hasattr(evaluator, attr):
                    raise RvtoolInputError(f"contact_set must be a CircleContactSet or a contact evaluator; "
                                           f"{type(contact_set).__name__} lacks '{attr}'")
        n_virtual = 0 if ports is None else ports.n_virtual
        if len(nodes) + n_virtual != evaluator.n_bodies:
            raise RvtoolInputError(f"nodes has {len(nodes)} entries and ports {n_virtual} bodies but contact_set.n_bodies = "
                                   f"{evaluator.n_bodies}; they must add up")
        ref_coords = []
        for n in nodes:
            if n < 0 or n >= mbs.systemData.NumberOfNodes():
                raise RvtoolInputError(f"nodes contains {n}, outside the valid range [0, {mbs.systemData.NumberOfNodes() - 1}]")
            r = np.asarray(mbs.GetNodeParameter(n, "referenceCoordinates"), dtype=float)
            if r.shape != (3,):
                raise RvtoolInputError(f"node {n} has {r.size} coordinates; the circle contact element needs "
                                       "planar rigid-body nodes with exactly 3 (x, y, theta)")
            ref_coords.append(r)
        self.name = evaluator.name
        self.ids = evaluator.ids
        self.nodes = nodes
        self.reference = np.array(ref_coords).reshape(-1, 3)
        self.evaluator = evaluator
        self.ports = ports
        self.n_rigid = 3 * len(nodes)
        self.n = self.n_rigid + (0 if ports is None else ports.n_eta)
        self.n_force_calls = 0
        self.n_jacobian_calls = 0
        self.n_evaluations = 0
        self.nonfinite = False          # set by a trial with non-finite output; reset by the driver per attempt
        self.inject_nan_at = set()      # fault injection (tests, hard cases): evaluation counters to poison
        self._key = None
        self._ev = None
        self.mbs = mbs
        self.object_number = self._attach(mbs, nodes, ports)
        self._ltg = None
        self.last_obs = None            # observation array (N, 8) of the last accepted state
        self.gap_offsets = np.zeros(len(self.ids))   # slow-state gap offsets per row [m] (set_gap_offsets)
        self.prescribed_velocity = None   # element-coordinate velocity of quasi-static windows at speed

    def _attach(self, mbs, nodes, ports):
        """Add this set's own ``ObjectGenericODE2`` to ``mbs``; returns its object number.
        (:class:`exudyn_user_elements.merged_element.HostedContactElement` adds none: its
        host element carries every family of the reducer.)"""
        return mbs.AddObject(ObjectGenericODE2(
            nodeNumbers=nodes + ([] if ports is None else [ports.structure.node]), massMatrix=np.zeros((self.n, self.n)),
            forceUserFunction=self.force_callback, jacobianUserFunction=self.jacobian_callback,
            visualization=VObjectGenericODE2(show=False)))

    # -- pure evaluation -------------------------------------------------
    def pose_velocity(self, q, q_t):
        """Absolute body poses and velocities (nb, 3) from element coordinates (port bodies last)."""
        q, q_t = np.asarray(q, float), np.asarray(q_t, float)
        nr = self.n_rigid
        pose = self.reference + q[:nr].reshape(-1, 3)
        vel = q_t[:nr].reshape(-1, 3)
        if self.ports is None:
            return pose, vel
        if getattr(self.ports, "state_dependent", False):
            # floating flexible bodies (exudyn_user_elements.floating_ports): the map depends on the state
            pv, T, T_load = self.ports.map(pose, q[nr:])
            self._port_jacobian = (T, T_load)
            return np.vstack([pose, pv]), np.vstack([vel, (T @ q_t).reshape(-1, 3)])
        P = self.ports.P
        return (np.vstack([pose, (P @ q[nr:]).reshape(-1, 3)]), np.vstack([vel, (P @ q_t[nr:]).reshape(-1, 3)]))

    def _contract(self, ev):
        """Q = T^T Q_b, dQ/dq = T^T (dQ_b/dq_b) T with T = blockdiag(I, P) (see module docstring)."""
        if getattr(self.ports, "state_dependent", False):
            from .floating_ports import contract
            T, T_load = self._port_jacobian
            return contract(ev, T, self.n_rigid, self.n, T_load)
        nr, P = self.n_rigid, self.ports.P

        def vec(Q):
            return np.concatenate([Q[:nr], P.T @ Q[nr:]])

        def mat(J):
            return np.block([[J[:nr, :nr], J[:nr, nr:] @ P], [P.T @ J[nr:, :nr], P.T @ J[nr:, nr:] @ P]])
        return Evaluation(vec(ev.Q), mat(ev.dQdq), mat(ev.dQdv), ev.obs, ev.trial_history, ev.finite)

    def element_tangent(self, dQdq):
        """dQ/dq (n, n) in the element's coordinates [q_r; eta] of a tangent dQ_b/dq_b of the contact
        set on its bodies (the rigid ones, then the port bodies): T^T (dQ_b/dq_b) T with the port map
        at the poses of the last :meth:`pose_velocity` (module docstring); ``dQdq`` itself without
        ports. A tangent the set's evaluator forms outside :meth:`evaluate` (the stiffness budget's
        stiffened view of an elastic closure, :mod:`rvtool.protocols.budget`) enters the element's
        coordinates so."""
        if self.ports is None:
            return dQdq
        J = np.asarray(dQdq, float)
        if J.shape != (3 * self.evaluator.n_bodies,) * 2:
            raise RvtoolInputError(f"dQdq has shape {J.shape}; the contact set's bodies give "
                                   f"{(3 * self.evaluator.n_bodies,) * 2}")
        return np.asarray(self._contract(Evaluation(np.zeros(len(J)), J, np.zeros_like(J), None, None, True)).dQdq)

    def evaluate(self, t, q, q_t):
        """Cached evaluation at element coordinates (trial: committed history is only read)."""
        q = np.asarray(q, dtype=float)
        q_t = np.asarray(q_t, dtype=float)
        if self.prescribed_velocity is not None:
            q_t = self.prescribed_velocity    # a quasi-static window at speed: see set_prescribed_velocity
        key = (float(t), q.tobytes(), q_t.tobytes())
        if key != self._key:
            pose, vel = self.pose_velocity(q, q_t)
            if not (np.all(np.isfinite(q)) and np.all(np.isfinite(q_t))):
                # a diverged Newton trial: answer with NaN so that the driver rejects the attempt
                self.nonfinite = True
                n = len(q)
                self._key, self._ev = key, Evaluation(np.full(n, np.nan), np.full((n, n), np.nan),
                                                      np.full((n, n), np.nan), None, None, False)
                return self._ev
            self._evaluate_fresh(key, pose, vel)
        return self._ev

    def _evaluate_fresh(self, key, pose, vel):
        """Evaluate the contact set at finite absolute poses/velocities, contract it to the ports,
        apply a requested NaN injection (hard cases), flag non-finite results and cache the
        evaluation under ``key``; returns it."""
        ev = self.evaluator.evaluate(pose, vel, check=False)
        if self.ports is not None:
            ev = self._contract(ev)
        self.n_evaluations += 1
        if self.n_evaluations in self.inject_nan_at:
            ev.Q = ev.Q * np.nan
            ev.finite = False
        if not ev.finite:
            self.nonfinite = True
        self._key, self._ev = key, ev
        return ev

    # -- Exudyn callbacks (exact signatures) ------------------------------
    def force_callback(self, mbs, t, itemNumber, q, q_t):
        self.n_force_calls += 1
        return self.evaluate(t, q, q_t).Q

    def jacobian_callback(self, mbs, t, itemNumber, q, q_t, fODE2, fODE2_t):
        self.n_jacobian_calls += 1
        ev = self.evaluate(t, q, q_t)
        return -(fODE2 * ev.dQdq + fODE2_t * ev.dQdv)

    # -- accepted-step interface -----------------------------------------
    @property
    def coordinate_indices(self):
        """Global ODE2 indices of the element's coordinates (local-to-global map, after Assemble)."""
        if self._ltg is None:
            self._ltg = np.asarray(self.mbs.systemData.GetObjectLTGODE2(self.object_number), dtype=int)
        return self._ltg

    def local(self, q_global):
        return np.asarray(q_global)[self.coordinate_indices]

    def evaluation_at(self, q_global):
        """The evaluation at global state ``q_global`` with zero velocity (static states; the
        prescribed velocity where one is set),
        reusing the last cached evaluation when it was made at exactly this state (the
        converged Newton residual of a static solve)."""
        ql = np.asarray(self.local(q_global), float)
        v = np.zeros(len(ql)) if self.prescribed_velocity is None else self.prescribed_velocity
        if self._key is not None and self._key[1] == ql.tobytes() and self._key[2] == v.tobytes():
            return self._ev
        return self.evaluate(0.0, ql, v)

    def commit(self, q_global, v_global, t=None):
        """Commit history at the accepted state ``t``; return the observation snapshot.

        The last Newton residual was evaluated at this state from the same
        committed history, so its cached evaluation is committed instead of
        launching the kernel again (identical by construction).
        """
        ql, vl = self.local(q_global), self.local(v_global)
        pose, vel = self.pose_velocity(ql, vl)
        cached = None
        if t is not None and self._key == (float(t), np.asarray(ql, float).tobytes(), np.asarray(vl, float).tobytes()):
            cached = self._ev
        obs = self.evaluator.commit(pose, vel, evaluation=cached) if cached is not None else self.evaluator.commit(pose, vel)
        self._key = None  # the committed history changed: no trial result may be reused
        self.last_obs = obs
        return ContactSnapshot(ids=self.ids, normal_force=obs[:, ref.O_FN], slip_speed=np.abs(obs[:, ref.O_VT]),
                               position=obs[:, ref.O_PX:ref.O_PY + 1], normal=obs[:, ref.O_NX:ref.O_NY + 1])

    def set_gap_offsets(self, offsets):
        """Slow-state gap offsets [m] per observation row (positive opens the gap), written into the
        evaluator's parameters for every following evaluation; the cached trial is dropped.
        Absolute, not increments: zeros restore the built element."""
        if not callable(getattr(self.evaluator, "set_gap_offsets", None)):
            raise RvtoolInputError(f"contact set {self.name!r} ({type(self.evaluator).__name__}) takes no gap "
                                   "offsets; valid: cycloid pins, circle contacts, output pins, rolling-element bearings")
        off = np.array(offsets, dtype=np.float64)
        self.evaluator.set_gap_offsets(off)
        self.gap_offsets = off
        self._key = None

    def set_friction_coefficients(self, mu):
        """Slow-state friction coefficient [-] per observation row (coupled lubrication), or None to
        restore the built coefficients; written into the evaluator, the cached trial is dropped."""
        if not callable(getattr(self.evaluator, "set_friction_coefficients", None)):
            raise RvtoolInputError(f"contact set {self.name!r} ({type(self.evaluator).__name__}) has no friction "
                                   "coefficient to write; valid: cycloid pins")
        self.evaluator.set_friction_coefficients(mu)
        self._key = None

    def set_prescribed_velocity(self, v_global):
        """Velocity [m/s, rad/s] (global ODE2 vector) at which every following evaluation is made
        instead of the solver's, or None (the solver's velocity; default). Static solves pass zero
        velocity, so the regularized friction of Eq. (friction) is zero there; a quasi-static window
        at input speed omega prescribes the kinematic velocities of its input angle, so the friction
        law sees the sliding speed of the steady motion (static solves only: a dynamic run must
        leave it None)."""
        if v_global is None:
            self.prescribed_velocity = None
        else:
            v = np.array(self.local(v_global), dtype=float)
            if not np.all(np.isfinite(v)):
                raise RvtoolInputError(f"prescribed velocity of contact set {self.name!r} must be finite; valid: "
                                       "finite reals")
            self.prescribed_velocity = v
        self._key = None

    def history_state(self):
        """Committed history arrays (for saving a failed run's state)."""
        h = self.evaluator.history
        return {k: np.array(v) for k, v in vars(h).items() if isinstance(v, np.ndarray)}
