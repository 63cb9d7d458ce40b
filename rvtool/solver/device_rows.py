"""The device backend's row Newton: B independent equilibria of ANY replicable model (RV,
small-tooth-difference, cycloid) from the contact rows of its families, without an Exudyn system.

The fully device-resident Newton (:mod:`rvtool.solver.device_newton`) reads a cycloid design's
copy parameters (cycloid pins, plain output pins, lumped bearings: three families of two planar
bodies, the loop a CUDA graph). Other topologies have other families: RV-40E's merged element
holds cycloid pins, involute pairs, needle (eccentric) and ball (main) rolling elements and
tapered rollers (the crank bearings that carry the output carrier). This module solves those:

1. every contact element of the model is copied B times on the Warp device
   (:func:`rvtool.solver.replica.copy_families`, the copiers the replica backend uses: the same
   kernels, the same rows, no physics written again);
2. one Newton iteration of all B copies evaluates each family in one launch at the absolute
   poses reference + q of all copies, and sums its rows into per-copy residuals and dense tangent
   blocks (:class:`rvtool.solver.replica.ReplicaEvaluator`, the rows' block scatter);
3. the step of :mod:`warp_contacts.batched_newton_ref` (the reference of the device-resident
   kernel, the same bookkeeping) for every copy: regularization springs times the copy's homotopy
   factor, the output torque, the fixed coordinates (drive, coordinate locks, journal locks:
   identity rows at their prescribed values), a dense solve per copy, step limiting,
   plausibility bounds, warm start -> regularization homotopy -> failed; by default as one Warp
   kernel on the device (:mod:`warp_contacts.block_newton`, ``device_step``), else NumPy on the
   host (:func:`warp_contacts.block_newton_ref.block_step`, its reference).

Where it runs: the contact kernels, the step and (``device_sum``, default on a GPU) the rows'
per-copy sums and the tapered rollers' planar mapping (:mod:`warp_contacts.tapered_planar`) on
the Warp device (``cpu`` or ``cuda``). With the device sum every family launches from poses that
a kernel writes from the step's states, so an iteration moves nothing between host and device and
the host reads the count of active copies every ``sync_every`` iterations (device-resident loop);
else per iteration the host stages the poses and reads back the states and statuses (one round
trip). Without ``device_sum`` the rows are summed on the host
(:class:`rvtool.solver.replica.ReplicaEvaluator`, the tapered mapping NumPy in
:class:`rvtool.bearings.tapered_set.TaperedBearingSet`). The resident loop is not captured as a
CUDA graph yet (the cycloid path's is): each iteration is ~15 launches from Python.

Covered: every contact-set type of :data:`rvtool.solver.replica.COPIERS` (cycloid pins, involute
pairs external and internal, rolling-element bearings: needle, cylindrical, ball, tapered; circle
pairs, plain output pins), and on extended bodies (:mod:`rvtool.solver.row_extension`: extra
unknowns with constant stiffness blocks) the linear series closures (elastic ring and output pins,
the RV crank beam and torsion) and reduced structures on port bodies (the ported housing), and
stick--slip anchors of the pair families (the committed history staged into their kernels,
committed per torque-path level by :meth:`DeviceRowNewton.commit`). Not covered (named by
:func:`row_reasons`): anchors inside closures or on plain output pins, closures with a station
law (conformal grooves, the ported carrier), ported wheels, shared output pins.
"""
import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from warp_contacts.batched_newton_ref import ACTIVE, CONVERGED, WARM
from warp_contacts.block_newton_ref import StepModel, block_step

from ..errors import RvtoolInputError
from ..model.reducer import COORDINATES
from .device_newton import DeviceNewtonSettings


SUBSETS_KEPT = 8
"""Row Newtons of variant-copy subsets :meth:`DeviceRowNewton.subset` keeps for a repeated request."""

KINEMATICS_CACHE = 4096
"""Input angles whose variant copies' kinematic states :meth:`DeviceRowNewton.prime_kinematics` keeps."""


def row_reasons(model):
    """Every named reason why the row Newton cannot run ``model`` (empty: it can): the replica
    path's (:func:`rvtool.solver.replica.replica_reasons`), except elastic structures on port bodies
    and linear series closures, which the row Newton takes as extra unknowns
    (:mod:`rvtool.solver.row_extension`; its own reasons instead)."""
    from .replica import replica_reasons
    from .row_extension import extension_reasons
    reasons = [r.replace("the angle-batched path", "the device row Newton") for r in replica_reasons(model)]
    if not reasons:
        return reasons
    # named again (or taken) by the extension's walk of every contact set
    handled = ("has elastic structures", "(port or pin bodies)", "has no copier for the device row Newton",
               "stick--slip anchors", "output_pins.mode")
    kept = [r for r in reasons if not any(h in r for h in handled)]
    return kept + [r for r in extension_reasons(model) if r not in kept]


def needs_extension(model):
    """Whether ``model`` needs the row coordinates of :mod:`rvtool.solver.row_extension` (closures,
    port bodies), checked on its contact elements (cheap; the extension itself is built once)."""
    from ..contact.pin_closure import ElasticPinClosure
    from ..contact.stacked import StackedContactSet
    if getattr(model, "row_extension", None) is not None:      # a snapshot of such a model
        return True
    return any(getattr(el, "ports", None) is not None or isinstance(el.evaluator, (ElasticPinClosure,
                                                                                   StackedContactSet))
               for el in model.contact_elements())


@dataclass
class RowSolve:
    """Result of :meth:`DeviceRowNewton.solve` for P copies: q (P, 3 nb) displacement states [m,
    rad], status (P,) (CONVERGED / FAILED), the converged stage (-1 warm start, s homotopy stage),
    Newton iterations per copy, residual norms [N], sweeps (batch iterations) and the wall-time
    split [s]: ``kernels_s`` (the families' launches with their host transfers), ``scatter_s``
    (rows into per-copy blocks), ``solve_s`` (the step: the device kernel with its read-back, or the host
    step), ``setup_s`` (copying the families)."""
    q: np.ndarray
    status: np.ndarray
    stage: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    sweeps: int
    kernels_s: float
    scatter_s: float
    solve_s: float
    setup_s: float

    @property
    def converged(self):
        return self.status == CONVERGED


def _constraints(model):
    """(held, journal-locked, springs, input index, output index) of a model in copy coordinates."""
    from .replica import held_coordinates
    n = 3 * len(model.body_names)
    held, journal, spring_k = np.zeros(n, bool), np.zeros(n, bool), np.zeros(n)
    for b, k in held_coordinates(model):
        held[3 * b + k] = True
    for b, k, _ in model.journal_locks:
        journal[3 * b + k] = True
    for b, k, kk, _ in model.reg_springs:
        spring_k[3 * b + k] += kk
    i_in = 3 * model.body_index(model.input.body) + COORDINATES.index(model.input.coordinate)
    i_out = 3 * model.body_index(model.output.body) + COORDINATES.index(model.output.coordinate)
    return held, journal, spring_k, i_in, i_out


class DeviceRowSum:
    """Per-copy residuals and tangent blocks of the copied families summed ON the device
    (:class:`warp_contacts.block_scatter.BlockScatter`, one thread per row, atomics): a family
    with a staged launch (:class:`rvtool.contact.evaluator.StagedLaunch`: cycloid pins, involute
    pairs, rolling elements, circle pairs) is launched on the device and its row buffers are summed
    where they are, as the tapered rollers' planar rows (:meth:`TaperedBearingSet.device_rows`,
    laminae rows) and the plain output pins' rows (:class:`rvtool.solver.replica.PlainPinCopies`);
    the others (influence-coefficient tapered rows) are evaluated as in
    :class:`rvtool.solver.replica.ReplicaEvaluator` and their rows uploaded.
    Only B (n + n^2) numbers come back instead of every row (on a GPU the rows' transfer and the
    host scatter cost more than the kernels). The same sums as the host scatter up to the order of
    the additions (last bits). ``timing`` as ReplicaEvaluator's ("kernels": launches, host
    families and uploads; "scatter": the device sum and its download)."""

    def __init__(self, families, nb, n_copies, device, n=None):
        import warp as wp
        from warp_contacts.block_scatter import BlockScatter
        from ..contact.evaluator import StagedLaunch
        self.families, self.nb, self.B, self.device = families, nb, n_copies, device
        n = 3 * nb if n is None else int(n)         # row coordinates per copy (extra unknowns: row_extension)
        self.staged = [isinstance(f.set, StagedLaunch) and getattr(f.set, "backend", None) == "warp"
                       for f in families]
        # families whose rows are made on the device from device poses without a staged launch: tapered
        # rows (planar mapping, warp_contacts.tapered_planar), plain output pins (the pin kernel's launch)
        self.direct = [not s and bool(getattr(f.set, "rows_on_device", False)) for f, s in zip(families, self.staged)]
        self.scatter = BlockScatter([(f.scatter.local, f.scatter.row_copy) for f in families], n_copies, n,
                                    wp.float64, device)
        self._host_rows = {}
        self.masked = np.zeros(n_copies, bool)
        self.timing = {"kernels": 0.0, "scatter": 0.0, "launches": 0}

    def set_static(self, on):
        for f in self.families:
            if callable(getattr(f.set, "set_velocity_tangent", None)):
                f.set.set_velocity_tangent(not on)

    @property
    def resident(self):
        """Whether every family runs from device-written poses (:meth:`pose_buffers`, :meth:`launch_device`)."""
        return all(s or t for s, t in zip(self.staged, self.direct))

    def pose_buffers(self):
        """[(pose, vel or None)] device input arrays of every family ((B nb + 1, 3), the ground last)."""
        return [f.set.pose_buffers() if s else f.set.device_pose_buffers()
                for f, s in zip(self.families, self.staged)]

    def launch_device(self):
        """Every family launched at the poses in :meth:`pose_buffers` as they are, and the device sums
        Q (B, n), K (B, n, n) (no transfer; :attr:`resident` families only)."""
        t0 = time.perf_counter()
        rows = []
        for f, staged in zip(self.families, self.staged):
            if staged:
                f.set.launch_staged()
                _, q, K, _ = f.set.row_buffers()
            else:
                q, K = f.set.launch_device_rows()
            rows.append((q, K))
        return self._summed(rows, t0)

    def _summed(self, rows, t0):
        """The per-copy device sums of the families' ``rows`` launched since ``t0``, with the timing."""
        t1 = time.perf_counter()
        Q, K = self.scatter.sum(rows)
        self.timing["kernels"] += t1 - t0
        self.timing["scatter"] += time.perf_counter() - t1
        self.timing["launches"] += len(self.families)
        return Q, K

    def stage_history(self, pose, vel):
        """Write the committed history of every staged family with stick--slip anchors into its
        kernel's inputs (with the poses ``pose``, overwritten by the resident loop's pose writes):
        the resident loop launches without staging."""
        for f, staged in zip(self.families, self.staged):
            if staged and getattr(f.set, "anchor", False):
                f.set.stage(*f.poses(pose, vel))

    def evaluate(self, pose, vel):
        Q, K = self.evaluate_device(pose, vel)
        t1 = time.perf_counter()
        # .numpy() downloads a cuda array (implicit conversion is refused there); np.array copies the cpu view
        Q, K = np.array(Q.numpy()), np.array(K.numpy())
        Q[self.masked], K[self.masked] = 0.0, 0.0
        self.timing["scatter"] += time.perf_counter() - t1
        return _Blocks(Q, K)

    def evaluate_device(self, pose, vel):
        """The per-copy sums as device arrays Q (B, n), K (B, n, n) (no download; overwritten by
        the next evaluation; masked copies are not zeroed)."""
        import warp as wp
        from .replica import family_rows
        t0 = time.perf_counter()
        rows = []
        for i, (f, staged) in enumerate(zip(self.families, self.staged)):
            pf, vf = f.poses(pose, vel)
            if staged:
                f.set.stage(pf, vf)
                f.set.launch_staged()
                _, q, K, _ = f.set.row_buffers()
            elif self.direct[i]:
                q, K = f.set.device_rows(pf, vf)
            else:
                Qh, Kh = (np.ascontiguousarray(x, np.float64) for x in family_rows(f.set, pf, vf)[:2])
                if i not in self._host_rows:
                    self._host_rows[i] = (wp.empty(Qh.shape, dtype=wp.float64, device=self.device),
                                          wp.empty(Kh.shape, dtype=wp.float64, device=self.device))
                q, K = self._host_rows[i]
                q.assign(Qh)
                K.assign(Kh)
            rows.append((q, K))
        return self._summed(rows, t0)


@dataclass
class _Blocks:
    Q: np.ndarray
    dQdq: np.ndarray


def provide_profile_tables(models, device, timing=None, wait=True):
    """Compute the deferred cycloid profile tables of ``models`` (snapshots built with
    ``defer_tables``, :func:`rvtool.solver.variant_snapshots.cycloid_variant_snapshots`) on Warp
    ``device``, each distinct table once (:func:`rvtool.contact.cycloid_set.compute_profile_tables`).
    :class:`DeviceRowNewton` does this on a GPU (inside its ``setup_s``); on the cpu a deferred table is
    computed by the host where it is first read (the Warp kernels' serial parts are slower there than
    NumPy). Returns the number of tables computed. timing: None or a dict receiving the table kernels' stage
    times [s]; wait: False returns once the kernels are launched (the tables settle at their first use;
    :func:`~rvtool.contact.cycloid_set.compute_profile_tables`)."""
    from ..contact.cycloid_set import ProfileTable, compute_profile_tables
    tables = [t for m in models for e in m.contact_elements()
              for t in (getattr(e.evaluator, "tables", None) or ()) if isinstance(t, ProfileTable) and not t.computed]
    return compute_profile_tables(tables, device, timing=timing, wait=wait) if tables else 0


class DeviceRowNewton:
    """Batched static Newton of B copies of ``model`` from its families' rows (module docstring).

    model: a :class:`~rvtool.model.ReducerModel`, or a list of B models of one topology (Monte
    Carlo variants: copy c is ``model[c]``, its own rows, kinematics and reference; then every
    solve has one point per copy). copies: B, the number of equilibria one launch evaluates (a
    larger request of one model runs in chunks of B); device: Warp device of the contact kernels;
    settings: :class:`DeviceNewtonSettings` (the cycloid path's tolerances and bounds: abs_tol
    1e-6 N as Exudyn's static solver). device_sum: sum the rows into per-copy blocks on the device
    (:class:`DeviceRowSum`) instead of on the host; default on a CUDA device only (on the CPU the
    rows are host memory already and the host scatter is deterministic). device_step: the Newton
    step of every copy (assembly with springs, torque and fixed coordinates, the dense solve, step
    limiting, plausibility, stage bookkeeping) as one Warp kernel on the device
    (:class:`warp_contacts.block_newton.BlockNewtonStep`: the per-copy sums stay on the device,
    the states and statuses come back once per iteration) instead of NumPy on the host
    (:func:`warp_contacts.block_newton_ref.block_step`, its reference); default on. With
    both (and every family able to launch from device-written poses: staged launches, laminae
    tapered rows) the loop is device-resident: the step kernel's states are written into every
    family's pose array on the device (:func:`warp_contacts.block_newton.pose_kernel`), nothing is
    staged from the host, and the host reads the count of active copies every ``sync_every``
    iterations (default 1 on the CPU, 4 on a GPU: up to sync_every - 1 sweeps run after the last
    copy finished, where the step leaves every copy as it is)."""

    def __init__(self, model, copies=None, *, device="cpu", settings=None, device_sum=None, device_step=None,
                 sync_every=None):
        from .replica import ReplicaEvaluator, copy_families
        self.models = list(model) if isinstance(model, (list, tuple)) else None
        if self.models is not None:
            if not self.models:
                raise RvtoolInputError("model must be a model or a non-empty list of models")
            if copies is not None and copies != len(self.models):
                raise RvtoolInputError(f"copies = {copies!r}: a list of models has one copy per model "
                                       f"({len(self.models)})")
            copies = len(self.models)
            model = self.models[0]
        for m in self.models or [model]:
            reasons = row_reasons(m)
            if reasons:
                raise RvtoolInputError("; ".join(reasons))
        if isinstance(copies, bool) or not isinstance(copies, (int, np.integer)) or copies < 1:
            raise RvtoolInputError(f"copies = {copies!r} is outside the valid range [1, inf) (integer)")
        t0 = time.perf_counter()
        #: where the setup's time went [s]: "tables_s" (launching the deferred profile tables' kernels on the
        #: device; "table_stages": each kernel stage's device time and, in "read", the wait for them where the
        #: copies first read a table), "families_s" (the families copied, that wait included), "rest_s"
        self.setup_parts = {"tables_s": 0.0, "table_stages": {}, "families_s": 0.0, "rest_s": 0.0}
        if self.models is not None and not str(device).startswith("cpu"):
            # variant profile tables left to this process (deferred by the build helpers): on the GPU, all at once,
            # launched without waiting: the families without tables are copied while the device computes them
            provide_profile_tables(self.models, device, timing=self.setup_parts["table_stages"], wait=False)
        self.setup_parts["tables_s"] = time.perf_counter() - t0
        self.model, self.B, self.device = model, int(copies), device
        self.settings = settings or DeviceNewtonSettings()
        self.nb = nb = len(model.body_names)
        self.n = n = 3 * nb
        #: the extra unknowns (elastic closures, structure ports) of :mod:`rvtool.solver.row_extension`,
        #: None where the model has none (the rows on the model's bodies as they are: the path before them)
        self.extension = None
        if device_sum is None:
            device_sum = not str(device).startswith("cpu")
        self.device_sum = bool(device_sum)
        t_fam = time.perf_counter()
        if needs_extension(model):
            from .row_extension import copy_rows
            families, self.extension = copy_rows(self.models or model, self.B, device=device,
                                                 host_structure=not self.device_sum)
            self.n = n = self.extension.n
        else:
            families = copy_families(self.models or model, self.B, device=device)
        self.setup_parts["families_s"] = time.perf_counter() - t_fam
        self.families = families
        #: the copied families with stick--slip anchors: their committed history is read by every
        #: evaluation and changed only by :meth:`commit` (a level of a torque path, as Exudyn's continuation)
        self.history_families = [f for f in families if getattr(f.set, "anchor", False)]
        self.evaluator = (DeviceRowSum(families, nb, self.B, device, n=n) if self.device_sum
                          else ReplicaEvaluator(families, nb, self.B))
        self.evaluator.set_static(True)              # static residual: no velocity tangent
        cons = _constraints(model)
        for i, m in enumerate(self.models or []):
            other = _constraints(m)
            if not all(np.array_equal(a, b) for a, b in zip(cons, other)):
                raise RvtoolInputError(f"model {i} has other locks, springs, drive or load than model 0; the copies "
                                       "must be models of one topology")
        if self.extension is not None:            # the extra unknowns: free, no springs, no locks
            pad = n - 3 * nb
            cons = (np.concatenate([cons[0], np.zeros(pad, bool)]), np.concatenate([cons[1], np.zeros(pad, bool)]),
                    np.concatenate([cons[2], np.zeros(pad)]), cons[3], cons[4])
        self.held, self.journal, self.spring_k, self.input_local, self.output_local = cons
        free = np.ones(n, bool)
        free[self.held | self.journal] = False
        free[self.input_local] = False
        self.free = free
        self.rot = np.arange(n) % 3 == 2 if self.extension is None else self.extension.rot.copy()
        self.device_step = True if device_step is None else bool(device_step)
        self._steppers = {}
        self._QK = None                 # device copies of host-summed blocks (device step, host sum)
        self._kin_cache = {}            # angle -> (B, n) kinematic states of the variant copies
        self._reference_d = None        # the copies' reference poses on the device (resident loop)
        self._gather_d = {}             # family -> its pose map on the device (extended families)
        self._graphs = {}               # stepper -> its captured resident loop (CUDA), or None where capture failed
        self._subsets = {}              # copies -> their row Newton (subset(); SUBSETS_KEPT, the most recent last)
        #: how the last resident loop ran: "cuda_graph" (captured, replayed), "host_loop" or None (not resident)
        self.loop_path = None
        if sync_every is None:
            sync_every = 1 if str(device).startswith("cpu") else 4
        if isinstance(sync_every, bool) or not isinstance(sync_every, (int, np.integer)) or sync_every < 1:
            raise RvtoolInputError(f"sync_every = {sync_every!r} is outside the valid range [1, inf) (integer)")
        self.sync_every = int(sync_every)
        if self.models is None:
            self.reference = np.broadcast_to(self._extend(np.asarray(model.reference, float).reshape(-1)), (self.B, n))
        else:
            self.reference = self._extend(np.array([np.asarray(m.reference, float).reshape(-1) for m in self.models]))
        self.setup_s = time.perf_counter() - t0
        self.setup_parts["rest_s"] = self.setup_s - self.setup_parts["tables_s"] - self.setup_parts["families_s"]

    def subset(self, copies):
        """A row Newton of the variant copies ``copies`` only (their models, this one's device and
        settings): a solve of a few copies then launches the families over those copies instead of
        all B (a solve's sweeps cost the whole batch, active or not). The copies' rows are the
        same, so are their equilibria (bit for bit with host sums; with device sums up to the
        order of the atomic additions). The last :data:`SUBSETS_KEPT` subsets are kept and given again for the
        same copies (a lost motion's +f and -f starts compact the same few hard copies, and a start scale's
        homotopy stage the copies its warm start failed, often the ones before)."""
        if self.models is None:
            raise RvtoolInputError("subset() takes copies of variant models; one model's copies are all alike")
        cp = self._copies(len(copies), copies)
        key = tuple(int(c) for c in cp)
        sub = self._subsets.pop(key, None)
        if sub is None:
            sub = DeviceRowNewton([self.models[c] for c in cp], device=self.device, settings=self.settings,
                                  device_sum=self.device_sum, device_step=self.device_step, sync_every=self.sync_every)
        self._subsets[key] = sub                    # the most recent last
        while len(self._subsets) > SUBSETS_KEPT:
            self._subsets.pop(next(iter(self._subsets)))
        return sub

    def kinematic(self, angles, copies=None):
        """(P, 3 nb) kinematic displacement states at input angles (P,) [rad], with the values the
        model's constraints prescribe: drive = angle, coordinate locks 0, journal locks and springs
        at the kinematic positions (:meth:`ReducerModel.set_input_angle`). Variant copies: point p
        is copy ``copies[p]`` (default: point p on copy p)."""
        a = np.asarray(angles, float)
        if self.models is None:
            kin = self._extend((self.model.kinematics.poses(a) - self.model.reference).reshape(len(a), -1))
        else:
            cp = self._copies(len(a), copies)
            kin = np.empty((len(a), self.n))
            self.prime_kinematics(a)
            for x in np.unique(a):
                at = a == x
                kin[at] = self._kin_cache[float(x)][cp[at]]
        kin[:, self.held] = 0.0
        kin[:, self.input_local] = a
        return kin

    def prime_kinematics(self, angles):
        """Variant copies: the kinematic poses of every copy at ``angles`` [rad], one call of each
        copy's kinematics for all of them (each copy has its own kinematics object: one call per
        copy and angle costs ~40 us of Python, 1,000 copies x 37 TE angles twice ~3 s), kept for
        :meth:`kinematic` (at most KINEMATICS_CACHE angles; then the oldest are dropped)."""
        if self.models is None:
            return
        new = np.array([x for x in np.unique(np.asarray(angles, float)) if float(x) not in self._kin_cache])
        if len(new) == 0:
            return
        tab = np.empty((len(new), self.B, self.n))
        # one evaluation of all copies where their kinematics can stack them (e.g. CycloidKinematics.stacked_poses)
        stacked = getattr(type(self.models[0].kinematics), "stacked_poses", None)
        poses = None if stacked is None else stacked([m.kinematics for m in self.models], new)
        if poses is not None:
            ref = np.array([np.asarray(m.reference, float) for m in self.models])
            tab[:] = self._extend((poses - ref[:, None]).reshape(self.B, len(new), -1)).transpose(1, 0, 2)
        else:
            for c, m in enumerate(self.models):
                tab[:, c] = self._extend((m.kinematics.poses(new) - np.asarray(m.reference, float)).reshape(len(new),
                                                                                                           -1))
        while len(self._kin_cache) + len(new) > KINEMATICS_CACHE and self._kin_cache:
            self._kin_cache.pop(next(iter(self._kin_cache)))
        for i, x in enumerate(new):
            self._kin_cache[float(x)] = tab[i]

    def _extend(self, x):
        """Body-coordinate values (..., 3 nb) with the extra unknowns' appended (their sources')."""
        return x if self.extension is None else self.extension.extend(x)

    def _poses(self, a):
        """What the evaluator takes for absolute row coordinates ``a`` (B, n): the body poses (B nb, 3),
        or ``a`` itself for the extended families (each gathers its own poses)."""
        return a.reshape(self.B * self.nb, 3) if self.extension is None else a

    def _copies(self, P, copies):
        """The variant copies of P points (checked: distinct, in range)."""
        cp = np.arange(self.B) if copies is None else np.asarray(copies, np.int64)
        if cp.shape != (P,) or len(np.unique(cp)) != P or np.any((cp < 0) | (cp >= self.B)):
            raise RvtoolInputError(f"{P} points need {P} distinct variant copies in [0, {self.B - 1}] (copies=); "
                                   f"got {None if copies is None else cp.tolist()}")
        return cp

    def solve(self, angles, torques, q_start=None, *, copies=None, homotopy=None, settings=None):
        """Equilibria at input angles (P,) [rad] under output torques (P,) [N m] (on the output
        coordinate), from q_start (P, 3 nb) (None: the kinematic states). Variant copies: point p
        runs on copy ``copies[p]`` (distinct; default point p on copy p); a model's copies take any
        number of points (in chunks of B). homotopy: override ``settings.homotopy`` (False: a failed
        warm start fails, e.g. the steps of a load continuation); settings: other
        :class:`DeviceNewtonSettings` for this solve. Returns a :class:`RowSolve`."""
        a = np.asarray(angles, float)
        P = len(a)
        tq = np.broadcast_to(np.asarray(torques, float), (P,)).copy()
        kin = self.kinematic(a, copies)
        q = kin.copy() if q_start is None else np.array(q_start, float)
        if q.shape != (P, self.n) or not np.all(np.isfinite(q)):
            raise RvtoolInputError(f"q_start must be finite with shape ({P}, {self.n})")
        q[:, ~self.free] = kin[:, ~self.free]
        cfg = settings or self.settings
        if homotopy is not None:
            cfg = dataclasses.replace(cfg, homotopy=bool(homotopy))
        out = {"status": np.full(P, ACTIVE, np.int32), "stage": np.full(P, WARM, np.int32),
               "iters": np.zeros(P, np.int32), "total": np.zeros(P, np.int32), "residual": np.full(P, np.nan)}
        timing = {"kernels": 0.0, "scatter": 0.0, "solve": 0.0}
        sweeps = 0
        if self.models is not None:
            chunks = [(np.arange(P), self._copies(P, copies))]
        else:
            chunks = [(np.arange(s, min(P, s + self.B)), np.arange(min(P, s + self.B) - s)) for s in range(0, P, self.B)]
        for pts, slots in chunks:
            qc = q[pts]
            st = {k: v[pts] for k, v in out.items()}
            sweeps += self._chunk(slots, qc, kin[pts], tq[pts], st, timing, cfg)
            q[pts] = qc
            for k, v in st.items():
                out[k][pts] = v
        return RowSolve(q=q, status=out["status"], stage=out["stage"], iterations=out["total"],
                        residual=out["residual"], sweeps=sweeps, kernels_s=timing["kernels"],
                        scatter_s=timing["scatter"], solve_s=timing["solve"], setup_s=self.setup_s)

    def solve_sequence(self, angles, torque):
        """Equilibria of one model along a sequence of input angles (A,) [rad] under one output
        torque [N m] (on the output coordinate), warm-started: the points are cut into B contiguous
        segments (:func:`rvtool.solver.backends.replica.segments`) marched side by side, each point
        from its segment's previous equilibrium shifted by the kinematic increment (the first of a
        segment, and a point after a failed one, from the kinematic state; a failed warm start runs
        the regularization homotopy). Returns a :class:`RowSolve` of the A points (sweeps and
        times summed over the steps)."""
        from .backends.replica import segments
        if self.models is not None:
            raise RvtoolInputError("solve_sequence marches one model's points; variant copies take solve()")
        a = np.asarray(angles, float)
        A = len(a)
        B = min(self.B, A)
        seg, real = segments(A, B)
        out = RowSolve(q=np.zeros((A, self.n)), status=np.zeros(A, np.int32), stage=np.zeros(A, np.int32),
                       iterations=np.zeros(A, np.int32), residual=np.zeros(A), sweeps=0, kernels_s=0.0,
                       scatter_s=0.0, solve_s=0.0, setup_s=self.setup_s)
        prev = None
        for k in range(seg.shape[1]):
            pts = seg[:, k]
            kin = self.kinematic(a[pts])
            r = self.solve(a[pts], np.full(B, float(torque)), None if prev is None else prev[0] + kin - prev[1])
            keep = real[:, k]
            for nm in ("q", "status", "stage", "iterations", "residual"):
                getattr(out, nm)[pts[keep]] = getattr(r, nm)[keep]
            out.sweeps += r.sweeps
            out.kernels_s += r.kernels_s
            out.scatter_s += r.scatter_s
            out.solve_s += r.solve_s
            q_next = r.q.copy()
            q_next[~r.converged] = kin[~r.converged]
            prev = (q_next, kin)
        return out

    def commit(self, q, copies=None):
        """Commit the contact history (stick--slip anchors) of the points ``q`` (P, n) at their
        states (an accepted level; Exudyn commits once per level of its continuation): point p on
        copy ``copies[p]`` (default: point p on copy p); the other copies' history stays as it is.
        Without anchors nothing to do."""
        if not self.history_families:
            return
        q = np.atleast_2d(np.asarray(q, float))
        cp = self._copies(len(q), copies)
        qB = np.zeros((self.B, self.n))
        qB[cp] = q
        a = self._poses(self.reference + qB)
        vel = np.zeros((self.B * self.nb, 3))
        for f in self.history_families:
            h = f.set.history
            keep = ~np.isin(f.scatter.row_copy, cp)
            old = [np.array(x) for x in (h.active, h.anchor_a, h.anchor_b, h.slip_distance)]
            pf, vf = f.poses(a, vel)
            f.set.commit(pf, vf)
            h = f.set.history
            for nm, x in zip(("active", "anchor_a", "anchor_b", "slip_distance"), old):
                getattr(h, nm)[keep] = x[keep]

    def step_model(self, cfg):
        """The :class:`warp_contacts.block_newton_ref.StepModel` of this model under settings ``cfg``."""
        return StepModel(spring_k=self.spring_k, free=self.free, rot=self.rot, out_index=int(self.output_local),
                         stiffening=np.asarray(cfg.stiffening, float), abs_tol=float(cfg.abs_tol),
                         max_iterations=int(cfg.max_iterations), max_step_translation=float(cfg.max_step_translation),
                         max_step_rotation=float(cfg.max_step_rotation), bound_translation=float(cfg.max_translation),
                         bound_rotation=float(cfg.max_rotation), homotopy=bool(cfg.homotopy))

    def _chunk(self, slots, q, kin, tq, st, timing, cfg):
        """Iterate the points on copies ``slots`` until none is active (the other copies masked at
        a kinematic state); arrays in place."""
        if self.device_step:
            return self._chunk_device(slots, q, kin, tq, st, timing, cfg)
        B, n = self.B, self.n
        ev = self.evaluator
        ev.masked[:] = True
        ev.masked[slots] = False
        pose_q = np.zeros((B, n))
        if self.models is None:
            pose_q[:] = kin[0]
        vel = np.zeros((B * self.nb, 3))
        sweeps = 0
        while np.any(st["status"] == ACTIVE):
            pose_q[slots] = q
            k0, s0 = ev.timing["kernels"], ev.timing["scatter"]
            r = ev.evaluate(self._poses(self.reference + pose_q), vel)
            timing["kernels"] += ev.timing["kernels"] - k0
            timing["scatter"] += ev.timing["scatter"] - s0
            t0 = time.perf_counter()
            self._step(r.Q[slots], r.dQdq[slots], q, kin, tq, st, cfg)
            timing["solve"] += time.perf_counter() - t0
            sweeps += 1
        return sweeps

    def _step(self, Qc, Kc, q, kin, tq, st, cfg):
        """One step of every active copy on the host (:func:`warp_contacts.block_newton_ref.block_step`)."""
        block_step(Qc, Kc, q, kin, tq, st["status"], st["stage"], st["iters"], st["total"], st["residual"],
                   self.step_model(cfg))

    def _chunk_device(self, slots, q, kin, tq, st, timing, cfg):
        """:meth:`_chunk` with the step on the device (:class:`warp_contacts.block_newton.BlockNewtonStep`):
        per iteration the families' launches, the per-copy sums, the step kernel, and one read of
        the states and statuses (the next poses and the loop's end)."""
        import warp as wp
        from warp_contacts.block_newton import BlockNewtonStep
        B, n = self.B, self.n
        m = self.step_model(cfg)
        key = (m.abs_tol, m.max_iterations, m.max_step_translation, m.max_step_rotation, m.bound_translation,
               m.bound_rotation, m.homotopy, tuple(m.stiffening))
        stp = self._steppers.get(key)
        if stp is None:
            stp = self._steppers[key] = BlockNewtonStep(m, B, n, self.device)
        ev = self.evaluator
        ev.masked[:] = True
        ev.masked[slots] = False
        qB = np.zeros((B, n))
        if self.models is None:
            qB[:] = kin[0]
        kinB = qB.copy()
        qB[slots], kinB[slots] = q, kin
        status = np.full(B, CONVERGED, np.int32)            # the copies without a point: not stepped
        status[slots] = st["status"]
        tqB = np.zeros(B)
        tqB[slots] = tq
        stage, iters, total = (np.zeros(B, np.int32) for _ in range(3))
        stage[slots], iters[slots], total[slots] = st["stage"], st["iters"], st["total"]
        stp.load(q=qB, kin=kinB, torque=tqB, status=status, stage=stage, iters=iters, total=total)
        host_sum = not isinstance(ev, DeviceRowSum)
        if not host_sum and ev.resident:
            if self.history_families:
                ev.stage_history(self._poses(self.reference + qB), np.zeros((B * self.nb, 3)))
            return self._resident_loop(stp, slots, q, st, timing, m)
        if host_sum and self._QK is None:
            self._QK = (wp.zeros((B, n), dtype=wp.float64, device=self.device),
                        wp.zeros((B, n, n), dtype=wp.float64, device=self.device))
        vel = np.zeros((B * self.nb, 3))
        sweeps = 0
        while np.any(status[slots] == ACTIVE):
            k0, s0 = ev.timing["kernels"], ev.timing["scatter"]
            pose = self._poses(self.reference + qB)
            if host_sum:
                r = ev.evaluate(pose, vel)
                t1 = time.perf_counter()
                self._QK[0].assign(r.Q)
                self._QK[1].assign(r.dQdq)
                Q, K = self._QK
                ev.timing["scatter"] += time.perf_counter() - t1
            else:
                Q, K = ev.evaluate_device(pose, vel)
            timing["kernels"] += ev.timing["kernels"] - k0
            timing["scatter"] += ev.timing["scatter"] - s0
            t0 = time.perf_counter()
            stp.step(Q, K)
            qB, status = stp.read("q", "status")
            timing["solve"] += time.perf_counter() - t0
            sweeps += 1
        stage, iters, total, res = stp.read("stage", "iters", "total", "residual")
        q[...] = qB[slots]
        for nm, v in (("status", status), ("stage", stage), ("iters", iters), ("total", total), ("residual", res)):
            st[nm][...] = v[slots]
        return sweeps

    def _gather_index(self, f):
        """The device copy of family ``f``'s pose map (flat, int64; made once)."""
        import warp as wp
        key = id(f)
        if key not in self._gather_d:
            self._gather_d[key] = wp.array(np.ascontiguousarray(f.pose_map.reshape(-1), np.int64), dtype=wp.int64,
                                           device=self.device)
        return self._gather_d[key]

    def _resident_loop(self, stp, slots, q, st, timing, m):
        """The device-resident iterations of :meth:`_chunk_device` (class docstring): poses written
        on the device, the families launched, summed and stepped; the active count read every
        ``sync_every`` sweeps. On a CUDA device with ``settings.graph`` the loop is captured once per
        stepper (after its first run, which loads every module) as a conditional CUDA graph
        (``wp.capture_while`` on the active count, a sweep gate at the same cap, as
        :mod:`rvtool.solver.device_newton`) and replayed: no host round trip per iteration; the
        states are those of the host loop (its extra sweeps after the last copy ends leave every copy as
        it is), the time all in ``solve`` (step_s). On the cpu the host loop as before."""
        import warp as wp
        ev = self.evaluator
        if self._reference_d is None:
            self._reference_d = wp.array(np.ascontiguousarray(self.reference, np.float64), dtype=wp.float64,
                                         device=self.device)
        bufs = ev.pose_buffers()
        for _, vel in bufs:
            if vel is not None:
                vel.zero_()                             # static: zero velocities (the ground row too)
        # every copy ends within the stages' iteration budget; the cap only guards the loop
        cap = (len(m.stiffening) + 2) * m.max_iterations + self.sync_every

        def sweep():
            for f, (pose, _) in zip(self.families, bufs):
                if f.pose_map is None:
                    stp.write_poses(self._reference_d, pose)
                else:
                    stp.write_poses_gathered(self._reference_d, pose, self._gather_index(f))
            Q, K = ev.launch_device()
            stp.step(Q, K)

        graph = self._graph(stp, sweep, cap) if self._captures(stp) else None
        if graph is not None:
            t0 = time.perf_counter()
            counter, gr = graph
            counter.zero_()
            stp.active.fill_(1)
            wp.capture_launch(gr)
            sweeps = int(counter.numpy()[0])
            timing["solve"] += time.perf_counter() - t0
            self.loop_path = "cuda_graph"
            return self._resident_read(stp, slots, q, st, sweeps)
        self.loop_path = "host_loop"
        sweeps = 0
        while sweeps < cap:
            k0, s0 = ev.timing["kernels"], ev.timing["scatter"]
            t0 = time.perf_counter()
            for f, (pose, _) in zip(self.families, bufs):
                if f.pose_map is None:
                    stp.write_poses(self._reference_d, pose)
                else:
                    stp.write_poses_gathered(self._reference_d, pose, self._gather_index(f))
            timing["kernels"] += time.perf_counter() - t0
            Q, K = ev.launch_device()
            timing["kernels"] += ev.timing["kernels"] - k0
            timing["scatter"] += ev.timing["scatter"] - s0
            t0 = time.perf_counter()
            stp.step(Q, K)
            sweeps += 1
            done = False
            if sweeps % self.sync_every == 0:
                done = int(stp.active.numpy()[0]) == 0
            timing["solve"] += time.perf_counter() - t0
            if done:
                break
        if self._captures(stp) and id(stp) not in self._graphs:
            self._graphs[id(stp)] = "warm"          # its modules are loaded: the next loop captures
        return self._resident_read(stp, slots, q, st, sweeps)

    @staticmethod
    def _resident_read(stp, slots, q, st, sweeps):
        qB, status, stage, iters, total, res = stp.read("q", "status", "stage", "iters", "total", "residual")
        q[...] = qB[slots]
        for nm, v in (("status", status), ("stage", stage), ("iters", iters), ("total", total), ("residual", res)):
            st[nm][...] = v[slots]
        return sweeps

    def _captures(self, stp):
        """Whether the resident loop of stepper ``stp`` runs as a captured CUDA graph (CUDA device,
        ``settings.graph``, capture not failed before)."""
        import warp as wp
        return (not wp.get_device(self.device).is_cpu and bool(getattr(self.settings, "graph", False))
                and self._graphs.get(id(stp), "") is not None)

    def _graph(self, stp, sweep, cap):
        """(sweep counter, graph) of stepper ``stp``'s resident loop, captured on its second use (the first
        ran the host loop: every module loaded, every recorded launch made); None before that or where
        capture fails (conditional graph nodes need CUDA >= 12.4 drivers: the host loop then)."""
        import warp as wp
        from warp_contacts.batched_newton import kernels
        hit = self._graphs.get(id(stp))
        if hit is None or hit == "warm":
            if hit is None:
                return None
            gate = kernels(wp.float64)[2]
            counter = wp.zeros(1, dtype=wp.int32, device=self.device)

            def body():
                sweep()
                wp.launch(gate, dim=1, inputs=[int(cap)], outputs=[counter, stp.active], device=self.device)
            try:
                with wp.ScopedCapture(device=self.device) as capture:
                    wp.capture_while(stp.active, body)
                hit = self._graphs[id(stp)] = (counter, capture.graph)
            except Exception:  # no conditional nodes (older driver): the host loop from now on
                self._graphs[id(stp)] = None
                return None
        return hit


__all__ = ["DeviceRowNewton", "RowSolve", "needs_extension", "provide_profile_tables", "row_reasons"]
