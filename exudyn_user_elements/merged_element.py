"""All contact families of a reducer as one Exudyn element (issue 19, "one contact element per system").

One ``ObjectGenericODE2`` spans the planar rigid bodies of the reducer (x, y, theta
per node) and, for an elastic housing, the structural coordinates eta of its
:class:`~exudyn_user_elements.reduced_structure.ReducedStructure`. Every Newton
evaluation crosses into Python once for the residual and once for the tangent:

* the force callback evaluates every family (one kernel launch each, the
  evaluators of :mod:`rvtool.contact`, :mod:`rvtool.output_pins`,
  :mod:`rvtool.bearings`) at the gathered state and returns the summed
  Q = sum_f T_f^T G_f^T f_f (Eq. (contact_mapping); T_f the constant port map of
  Eq. (port_runtime_transform) where a family acts on port bodies, else the
  identity on its coordinates);
* the Jacobian callback returns the summed analytic tangent of Eq.
  (assembled_contact_tangent) as sparse triplets (``exudyn.MatrixContainer``) in
  Exudyn's convention J_user = -(f_ODE2 dQ/dq + f_ODE2_t dQ/dq_t); the evaluation
  of the preceding residual at the same state is reused (no second launch).

The families stay addressable one by one: :class:`HostedContactElement` is the
per-family :class:`~exudyn_user_elements.contact_element.ContactElement`
interface (ids, observation at a static state, history commit, gap offsets,
fault injection) without an Exudyn object of its own; the host calls its
evaluation so its per-state cache serves the observers and the static
protocols exactly as before.

Port contraction: a family on port bodies sees n_v extra bodies whose poses are
u = P eta. Its tangent in body coordinates is non-zero only on the rows and
columns of the port bodies in contact, so the contraction
dQ/dq = T^T (dQ_b/dq_b) T is formed on those rows only (an exact rewrite: the
dropped rows and columns are zero). The matrix products are split so that no
single BLAS call exceeds OpenBLAS's multithreading threshold: threaded GEMM on
these 10^2-sized operands cost 33 ms per product on the 2-core development
machine under load against 0.09 ms single-threaded (measured), which was the
79 ms per quasi-static point of the ported housing.

Accepted-step hooks: the host also carries the per-attempt controls that
would otherwise be Python user functions evaluated at every residual (the input
drive's offset, the output torque): :meth:`MergedContactElement.begin_attempt`
sets them once per step attempt at the attempt's end time, where Exudyn's
generalized-alpha evaluates them (Arnold--Bruls form: equations at t_{n+1}), so
the values the solver sees are identical.
"""
import numpy as np
import exudyn as exu
from exudyn.itemInterface import ObjectGenericODE2, VObjectGenericODE2

from rvtool.contact.evaluator import Evaluation, LaunchedEvaluation
from rvtool.errors import RvtoolInputError

from .contact_element import ContactElement

# OpenBLAS runs a GEMM multithreaded above m n k = 65536 x 4 (interface/gemm.c,
# SMP_THRESHOLD_MIN x GEMM_MULTITHREAD_THRESHOLD); below it the call stays on the caller's thread
_GEMM_SINGLE_THREAD = 65536 * 4 - 1
# up to this many element coordinates the tangent goes back dense: building an
# exudyn.MatrixContainer costs ~20 us per Jacobian call more than handing over a
# 12 x 12 array (measured, 2-core machine), while the system matrix gains nothing
DENSE_MAX_COORDINATES = 30
# key of the list of MergedContactElements in ``mbs.variables`` (Exudyn's user dictionary)
HOSTS_KEY = "rvtool.contact_hosts"


def small_matmul(A, B):
    """A @ B with the inner dimension split into chunks whose GEMM stays single-threaded
    (see the module docstring: threaded GEMM on small operands costs ~300x more under load).
    Exact up to the order of the inner sum."""
    m, k = A.shape
    n = B.shape[1]
    if m * n * k <= _GEMM_SINGLE_THREAD:
        return A @ B
    kc = max(1, _GEMM_SINGLE_THREAD // max(m * n, 1))
    out = A[:, :kc] @ B[:kc]
    for s in range(kc, k, kc):
        out += A[:, s:s + kc] @ B[s:s + kc]
    return out


def _sparse_container(J):
    """``exudyn.MatrixContainer`` in sparse triplet format of the non-zero entries of J."""
    rows, cols = np.nonzero(J)
    mc = exu.MatrixContainer()
    mc.SetWithSparseMatrixCSR(J.shape[0], J.shape[1], np.column_stack([rows, cols, J[rows, cols]]),
                              useDenseMatrix=False)
    return mc


class ContractedEvaluation(Evaluation):
    """:class:`~rvtool.contact.evaluator.Evaluation` whose tangents dQdq, dQdv are formed on first
    read (by the callables given for them) and kept."""

    def __init__(self, Q, dQdq, dQdv, obs, trial_history, finite):
        self._make = {"dQdq": dQdq, "dQdv": dQdv}
        self._made = {}
        self.Q, self.obs, self.trial_history, self.finite = Q, obs, trial_history, finite

    def _get(self, name):
        if name not in self._made:
            self._made[name] = self._make[name]()
        return self._made[name]

    dQdq = property(lambda self: self._get("dQdq"), lambda self, v: self._made.__setitem__("dQdq", v))
    dQdv = property(lambda self: self._get("dQdv"), lambda self, v: self._made.__setitem__("dQdv", v))


class HostedContactElement(ContactElement):
    """One contact family of a :class:`MergedContactElement`: the per-family interface of
    :class:`ContactElement` (ids, ``evaluation_at``, ``commit``, ``set_gap_offsets``,
    ``coordinate_indices``, ``inject_nan_at``), evaluated by its host; no Exudyn object of its own.

    host: the :class:`MergedContactElement`; positions: indices of this family's element
    coordinates among the host's (rigid coordinates first, then eta for a ported family);
    the other arguments as for :class:`ContactElement`.
    """

    def __init__(self, host, positions, nodes, contact_set, **kw):
        self.host = host
        self.positions = np.asarray(positions, dtype=int)
        self._cidx = None
        self._identity_ports = None     # set on first contraction (ports.P == I)
        super().__init__(host.mbs, nodes, contact_set, **kw)
        if len(self.positions) != self.n:
            raise RvtoolInputError(f"positions has {len(self.positions)} entries for a family with {self.n} coordinates")
        # a contiguous leading block (the rigid bodies) is gathered and scattered as a view
        self.prefix = self.n if (self.ports is None and np.array_equal(self.positions, np.arange(self.n))) else None

    def _attach(self, mbs, nodes, ports):
        return self.host.object_number

    # the family's parameters or evaluation velocity change: the host's cached sum is stale too
    def set_gap_offsets(self, offsets):
        super().set_gap_offsets(offsets)
        self.host.invalidate()

    def set_friction_coefficients(self, mu):
        super().set_friction_coefficients(mu)
        self.host.invalidate()

    def set_prescribed_velocity(self, v_global):
        super().set_prescribed_velocity(v_global)
        self.host.invalidate()

    def store(self, key, pose, vel):
        """Evaluate at absolute poses/velocities (state already checked finite by the host) and
        cache the result under ``key`` (the key :meth:`ContactElement.evaluate` forms), so that
        ``commit`` and ``evaluation_at`` at this state reuse it. A state this family already holds
        (evaluated on its own, e.g. by an observer) is not evaluated again, as in ContactElement."""
        if key == self._key:
            return self._ev
        return self._evaluate_fresh(key, pose, vel)

    @property
    def identity_ports(self):
        """True if this family's port bodies are the host's structural coordinates themselves (P = I:
        the retained out-of-plane rows of :class:`~exudyn_user_elements.out_of_plane.RetainedTilt`)
        and it spans every host coordinate: its coordinates are the host's."""
        if self.ports is None or getattr(self.ports, "state_dependent", False):
            return False
        if self._identity_ports is None:
            P = self.ports.P
            self._identity_ports = P.shape[0] == P.shape[1] and np.array_equal(P, np.eye(len(P)))
        return self._identity_ports and np.array_equal(self.positions, np.arange(self.host.n))

    @property
    def launchable(self):
        """True if the host may sum this family's rows on the device: a family on the host's rigid
        coordinates (or on all of them with identity ports, :attr:`identity_ports`) whose evaluator
        launches its Warp kernel without assembling (``launch``, ``row_buffers``)."""
        ev = self.evaluator
        # looked up on the class: a wrapper that forwards unknown attributes to an inner set (the
        # elastic pin closure) evaluates other bodies than the inner set's launch would
        cls = type(ev)
        return ((self.prefix is not None or self.identity_ports) and getattr(ev, "backend", None) == "warp"
                and all(callable(getattr(cls, nm, None)) for nm in ("stage", "launch_staged", "launched",
                                                                    "launched_field", "row_buffers")))

    def launched(self, key, pose, vel):
        """:meth:`store` without the host-side assembly, after the host launched this family's
        kernel on inputs staged by ``evaluator.stage(pose, vel)`` (its rows summed on the device):
        caches the :class:`~rvtool.contact.evaluator.LaunchedEvaluation`, which assembles a field
        when it is read (commit, observers, ``evaluation_at``)."""
        ev = self.evaluator.launched(pose, vel)
        self.n_evaluations += 1
        self._key, self._ev = key, ev
        return ev

    def commit(self, q_global, v_global, t=None, snapshot=True):
        """:meth:`ContactElement.commit`; ``snapshot=False`` commits the history and the last
        observation without building the observers' snapshot (the driver passes it when no
        observer is registered)."""
        # the committed history changes: the host's cached sum may not be reused either
        self.host.invalidate()
        if snapshot:
            return super().commit(q_global, v_global, t)
        ql, vl = self.local(q_global), self.local(v_global)
        if t is not None and self._key == (float(t), ql.tobytes(), vl.tobytes()):
            # the state goes with the evaluation: an evaluator may read more than the evaluation
            # at commit (the bearing friction element evaluates its load source there)
            ev = self._ev
            state = ev.state if isinstance(ev, LaunchedEvaluation) else self.pose_velocity(ql, vl)
            self.last_obs = self.evaluator.commit(*state, evaluation=ev)
        else:
            self.last_obs = self.evaluator.commit(*self.pose_velocity(ql, vl))
        self._key = None
        return None

    @property
    def coordinate_indices(self):
        if self._cidx is None:      # fixed once the system is assembled (read at every commit)
            self._cidx = self.host.coordinate_indices[self.positions]
        return self._cidx

    def _contract(self, ev):
        """Q = T^T Q_b, dQ/dq = T^T (dQ_b/dq_b) T on the port rows in contact only (module docstring).
        Ports with the identity map (P = I: the retained out-of-plane rows of
        :class:`~exudyn_user_elements.out_of_plane.RetainedTilt`) contract to the family's own result,
        copied (the products below give it exactly: every sum has one term times 1, the rest zeros).
        State-dependent ports (floating flexible bodies) contract in :meth:`ContactElement._contract`."""
        if getattr(self.ports, "state_dependent", False):
            return super()._contract(ev)
        nr, P = self.n_rigid, self.ports.P
        if self._identity_ports is None:
            self._identity_ports = P.shape[0] == P.shape[1] and np.array_equal(P, np.eye(len(P)))
        if self._identity_ports:
            return ContractedEvaluation(np.array(ev.Q, float), lambda: np.array(ev.dQdq, float),
                                        lambda: np.array(ev.dQdv, float), ev.obs, ev.trial_history, ev.finite)
        nb = len(ev.Q)

        def active(*Ms):
            mask = np.zeros(nb - nr, bool)
            for M in Ms:
                mask |= np.any(M[nr:] != 0, axis=1) | np.any(M[:, nr:] != 0, axis=0)
            return np.flatnonzero(mask)
        a = active(ev.dQdq, ev.dQdv)
        Pa = P[a]
        ia = nr + a

        def mat(J):
            out = np.zeros((self.n, self.n))
            out[:nr, :nr] = J[:nr, :nr]
            if len(a):
                out[:nr, nr:] = small_matmul(J[:nr][:, ia], Pa)
                out[nr:, :nr] = small_matmul(Pa.T, J[ia][:, :nr])
                out[nr:, nr:] = small_matmul(Pa.T, small_matmul(J[np.ix_(ia, ia)], Pa))
            return out
        Q = np.zeros(self.n)
        Q[:nr] = ev.Q[:nr]
        if np.any(np.delete(ev.Q[nr:], a) != 0):
            # a port row with force but no tangent (not a contact law of this code): contract all rows
            Q[nr:] = small_matmul(P.T, ev.Q[nr:, None])[:, 0]
        elif len(a):
            Q[nr:] = Pa.T @ ev.Q[ia]
        # the tangents are contracted when first read: a residual-only evaluation (the converged
        # Newton iterate) and the static solver (no velocity tangent) skip their share
        return ContractedEvaluation(Q, lambda: mat(ev.dQdq), lambda: mat(ev.dQdv), ev.obs, ev.trial_history,
                                    ev.finite)


class MergedContactElement:
    """Every contact family of one reducer in one Exudyn ``ObjectGenericODE2``.

    mbs: the MainSystem; nodes: the rigid-body node numbers (``NodeRigidBody2D``) every family
    is evaluated on, in body order; structure: a
    :class:`~exudyn_user_elements.reduced_structure.ReducedStructure` (or a
    :class:`~exudyn_user_elements.stacked_structure.StackedStructure` of several) whose eta follow the
    rigid coordinates (families with ``ports`` act on it), or None. Families are added with
    :meth:`add` before ``mbs.Assemble()``.
    """

    def __init__(self, mbs, nodes, *, structure=None, name="contacts"):
        nodes = [int(n) for n in nodes]
        self.mbs = mbs
        self.name = name
        self.nodes = nodes
        self.structure = structure
        self.n_rigid = 3 * len(nodes)
        self.n = self.n_rigid + (0 if structure is None else structure.n)
        self.members = []
        self.n_force_calls = 0
        self.n_jacobian_calls = 0
        self._key = None
        self._Q = None
        self._evs = None
        self._ltg = None
        self._drive = None
        self._load = None
        self._sums = None       # warp_contacts.segment_sum.ElementSums of the launchable families
        self._slot = {}         # member index -> slot in _sums
        self._used = None       # set once the device sums are built (row_sums)
        self._n_sums = self.n_rigid   # coordinates the device sums span (row_sums)
        self._fast = False      # the cached evaluation summed families on the device
        self._launched = frozenset()   # members summed on the device in the cached evaluation
        self._device_only = False
        # Exudyn requires the object's matrices and its Jacobian user function to agree in format
        self.sparse = self.n > DENSE_MAX_COORDINATES
        if self.sparse:
            empty = exu.MatrixContainer()
            empty.SetWithSparseMatrixCSR(self.n, self.n, np.zeros((0, 3)), useDenseMatrix=False)
            mats = dict(massMatrix=empty, stiffnessMatrix=empty, dampingMatrix=empty)
        else:
            mats = dict(massMatrix=np.zeros((self.n, self.n)))
        # registered with the system: the driver sets a host's per-attempt controls even when it
        # is called without the contact elements (a frozen drive would be wrong, not slow)
        mbs.variables.setdefault(HOSTS_KEY, []).append(self)
        self.object_number = mbs.AddObject(ObjectGenericODE2(
            name=name, nodeNumbers=nodes + ([] if structure is None else
                                            list(structure.nodes) if hasattr(structure, "nodes") else [structure.node]),
            **mats,
            forceUserFunction=self.force_callback, jacobianUserFunction=self.jacobian_callback,
            visualization=VObjectGenericODE2(show=False)))

    def add(self, contact_set, *, ports=None, **kw):
        """Add a family (a contact set or evaluator, as for :class:`ContactElement`); returns its
        :class:`HostedContactElement`. ``ports``: a
        :class:`~exudyn_user_elements.contact_element.PortBodies` on this host's structure."""
        positions = np.arange(self.n_rigid)
        if ports is not None:
            if self.structure is None or ports.structure is not self.structure:
                raise RvtoolInputError("ports must act on the structure the merged element was built with")
            positions = np.arange(self.n)
        m = HostedContactElement(self, positions, self.nodes, contact_set, ports=ports, **kw)
        if m.prefix is not None and m.prefix != self.n_rigid:
            raise RvtoolInputError("a family without ports spans exactly the host's rigid coordinates")
        if not self.members:
            self.reference = m.reference
        self.members.append(m)
        return m

    # -- evaluation ---------------------------------------------------------
    def invalidate(self):
        """Drop the cached evaluation (a family's history or parameters changed)."""
        self._key = None

    @property
    def nonfinite(self):
        return any(m.nonfinite for m in self.members)

    def evaluate(self, t, q, q_t):
        """(Q, per-family evaluations) at the host's coordinates, cached per state."""
        q = np.asarray(q, dtype=float)
        q_t = np.asarray(q_t, dtype=float)
        t = float(t)
        key = (t, q.tobytes(), q_t.tobytes())
        if key == self._key:
            return self._Q, self._evs
        s = q.sum() + q_t.sum()
        if s - s != 0.0:        # NaN or inf in the state (one sum; inf - inf is NaN)
            # a diverged Newton trial: every family answers NaN so that the driver rejects the attempt
            evs = [m.evaluate(t, q[m.positions], q_t[m.positions]) for m in self.members]
            self._key, self._Q, self._evs = key, np.full(self.n, np.nan), evs
            self._fast = self._device_only = False
            self._launched = frozenset()
            return self._Q, self._evs
        nr = self.n_rigid
        # the rigid poses once for every family (ContactElement.pose_velocity, shared)
        if nr == self.n:
            qr, vr, key_r = q, q_t, key
        else:
            qr, vr = q[:nr], q_t[:nr]
            key_r = (t, qr.tobytes(), vr.tobytes())
        pose_r = self.reference + qr.reshape(-1, 3)
        vel_r = vr.reshape(-1, 3)
        sums = self.row_sums()
        evs, host, launches, launched = [None] * len(self.members), [], [], []
        states = {}
        for i, m in enumerate(self.members):
            slot = self._slot.get(i)
            if m.prescribed_velocity is not None:
                # a quasi-static window at speed: the family is evaluated at its prescribed
                # velocity (ContactElement.evaluate), not at the solver's
                evs[i] = m.evaluate(t, q[m.positions], q_t[m.positions])
                host.append((m, evs[i]))
            elif (slot is not None and (key_r if m.prefix is not None else key) != m._key
                  and (m.n_evaluations + 1) not in m.inject_nan_at):
                # rows summed on the device (warp_contacts.segment_sum): no host assembly; a family
                # with identity ports on every host coordinate at its own poses (the planar bodies
                # and the retained out-of-plane rows)
                ev = m.evaluator
                if m.prefix is not None:
                    states[i] = (key_r, pose_r, vel_r)
                else:       # identity ports: every such family's poses are the same
                    full = states.get("full")
                    if full is None:
                        full = states["full"] = (key, *m.pose_velocity(q, q_t))
                    states[i] = full
                ev.stage(*states[i][1:])
                launches.append((slot, ev.launch_staged, ev.velocity_rows))
                launched.append(i)
            elif m.prefix is not None:
                evs[i] = m.store(key_r, pose_r, vel_r)
                host.append((m, evs[i]))
            else:
                qm, vm = q[m.positions], q_t[m.positions]
                evs[i] = m.store((t, qm.tobytes(), vm.tobytes()), *m.pose_velocity(qm, vm))
                host.append((m, evs[i]))
        self._fast = bool(launches)
        self._launched = frozenset(launched)
        # every family summed on the device and no structural coordinates: the sums' Jacobian is
        # the element's
        ns = self._n_sums
        self._device_only = self._fast and not host and self.n == ns
        if self._fast:
            sums.run(launches)
            for i in launched:
                evs[i] = self.members[i].launched(*states[i])
            sums.set_used(self._used_slots(launches))
            Qf, finite = sums.vector()
            if not finite:
                # one sum checked every launched force and tangent; name the families (rare path)
                for i in launched:
                    if not evs[i].finite:
                        self.members[i].nonfinite = True
            if self._device_only:
                Q = Qf.copy()
            else:
                Q = np.zeros(self.n)
                Q[:ns] = Qf
        else:
            Q = np.zeros(self.n)
        for m, ev in host:
            if m.prefix is not None:
                Q[:nr] += ev.Q
            else:
                Q[m.positions] += ev.Q
        self._key, self._Q, self._evs = key, Q, evs
        return Q, evs

    def _used_slots(self, launches):
        """Per slot of the device sums: summed in this evaluation (the launches' slots)."""
        if len(launches) == len(self._slot):
            return self._all_slots
        used = [False] * len(self._slot)
        for slot, _, _ in launches:
            used[slot] = True
        return tuple(used)

    def row_sums(self):
        """The device-side sums of the launchable families (built on first use, after every family
        was added; None if no family is launchable)."""
        if self._used is None:
            fams = [i for i, m in enumerate(self.members) if m.launchable]
            self._slot = {i: s for s, i in enumerate(fams)}
            self._all_slots = (True,) * len(fams)
            self._used = True
            # the sums span the rigid coordinates, or every host coordinate where a family with
            # identity ports (retained out-of-plane rows) is summed on the device
            self._n_sums = self.n if any(self.members[i].prefix is None for i in fams) else self.n_rigid
            if fams:
                from warp_contacts.segment_sum import ElementSums
                self._sums = ElementSums([self.members[i].evaluator.row_buffers() for i in fams], self._n_sums)
        return self._sums

    def user_jacobian(self, t, q, q_t, f_q, f_v):
        """Exudyn's J_user = -(f_q dQ/dq + f_v dQ/dq_t), dense (n, n), at the host's coordinates; the
        launched families' part from the device-side sums (a buffer of the sums where no other
        family adds: copy it to keep it)."""
        _, evs = self.evaluate(t, q, q_t)
        ns = self._n_sums
        if self._fast:
            Jf = self._sums.jacobian(f_q, f_v)
            if self._device_only:
                return Jf
            J = np.zeros((self.n, self.n))
            J[:ns, :ns] = Jf
        else:
            J = np.zeros((self.n, self.n))
        for i, (m, ev) in enumerate(zip(self.members, evs)):
            if i in self._launched:
                continue        # summed on the device
            blk = f_q * ev.dQdq if f_v == 0 else f_q * ev.dQdq + f_v * ev.dQdv
            if m.prefix is not None:
                J[:m.prefix, :m.prefix] -= blk
            else:
                J[np.ix_(m.positions, m.positions)] -= blk
        return J

    def tangent(self, t, q, q_t, f_q=1.0, f_v=0.0):
        """Dense f_q dQ/dq + f_v dQ/dq_t (n, n) at the host's coordinates (summed over families)."""
        return -self.user_jacobian(t, q, q_t, f_q, f_v)

    # -- Exudyn callbacks (exact signatures) --------------------------------
    def force_callback(self, mbs, t, itemNumber, q, q_t):
        self.n_force_calls += 1
        return self.evaluate(t, q, q_t)[0]

    def jacobian_callback(self, mbs, t, itemNumber, q, q_t, fODE2, fODE2_t):
        self.n_jacobian_calls += 1
        J = self.user_jacobian(t, q, q_t, fODE2, fODE2_t)
        return _sparse_container(J) if self.sparse else J

    # -- accepted-step interface ----------------------------------------------
    @property
    def coordinate_indices(self):
        """Global ODE2 indices of the host's coordinates (after Assemble)."""
        if self._ltg is None:
            self._ltg = np.asarray(self.mbs.systemData.GetObjectLTGODE2(self.object_number), dtype=int)
        return self._ltg

    def set_drive(self, constraint, angle_of_time):
        """Prescribed coordinate through a ``CoordinateConstraint``'s offset, set once per step attempt
        by :meth:`begin_attempt` instead of a Python offset user function evaluated at every residual
        and Jacobian (three crossings per Newton iteration); None removes it."""
        self._drive = None if angle_of_time is None else (int(constraint), angle_of_time)
        if self._drive is not None:
            self.mbs.SetObjectParameter(int(constraint), "offset", float(angle_of_time(0.0)))

    def set_load_function(self, load, value_of_time):
        """Load value [N or N m] of a ``LoadCoordinate`` as a function of time, set once per step attempt
        (see :meth:`set_drive`); None removes it."""
        if value_of_time is None:
            if self._load is not None:      # the constant load in force before the function returns
                self.mbs.SetLoadParameter(self._load[0], "load", self._load[2])
            self._load = None
            return
        constant = self._load[2] if self._load is not None else float(self.mbs.GetLoadParameter(int(load), "load"))
        self._load = (int(load), value_of_time, constant)
        self.mbs.SetLoadParameter(int(load), "load", float(value_of_time(0.0)))

    @property
    def has_controls(self):
        return self._drive is not None or self._load is not None

    def set_controls(self, t):
        """Per-attempt controls at time t (the driver sets them at the start time before solving)."""
        if self._drive is not None:
            self.mbs.SetObjectParameter(self._drive[0], "offset", float(self._drive[1](t)))
        if self._load is not None:
            self.mbs.SetLoadParameter(self._load[0], "load", float(self._load[1](t)))

    def begin_attempt(self, t):
        """Start of a step attempt ending at ``t``: reset the non-finite flags and set the
        per-attempt controls to their values at t."""
        for m in self.members:
            m.nonfinite = False
        self.set_controls(t)
