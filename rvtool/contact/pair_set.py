"""The evaluator scaffolding shared by the two-body contact families whose rows are evaluated
by one Warp launch (or their NumPy reference) and scattered by a
:class:`~rvtool.contact.assembly.PairAssembler`: cycloid--pin meshes
(:class:`~rvtool.contact.cycloid_set.CycloidPinSet`) and involute gear meshes
(:class:`~rvtool.contact.involute_set.InvoluteContactSet`).

A family builds its parameter rows, then calls :meth:`PairFamilySet.init_evaluation` with its
body pairs (and, for stick--slip rows, its anchor parameter columns of
:mod:`warp_contacts.anchor_ref`); it provides ``self._kernel`` (backend "warp":
``evaluate(pose, vel)``, with anchors ``evaluate_anchor(pose, vel, *history)``, and
``set_velocity_tangent(on)``) and :meth:`PairFamilySet.reference` (backend "numpy"; with
anchors it takes ``anchor=(params, *history)`` and returns the trial anchors as a fifth result).
Anchors follow the paper's "History ownership, retries, and acceptance": trials read the
committed history only, :meth:`PairFamilySet.commit` writes it once per accepted step. The
protocol of :class:`exudyn_user_elements.contact_element.ContactElement` (``raw``,
``evaluate``, ``commit``, ``set_velocity_tangent``, ``ids``, ``history``) is implemented here
once. The ground is the padded last row of the pose arrays (index ``n_bodies``).
"""
import numpy as np

from ..errors import RvtoolInputError
from .assembly import PairAssembler
from warp_contacts import anchor_ref

from .evaluator import ContactHistory, Evaluation, StagedLaunch, all_finite, check_finite_state

BACKENDS = ("warp", "numpy")
PRECISIONS = ("float64", "float32")


class NoHistory:
    """Committed history of a family without history variables (no arrays)."""


def check_backend(backend, precision):
    """Named errors for an unknown backend or precision."""
    if backend not in BACKENDS:
        raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are {list(BACKENDS)}")
    if precision not in PRECISIONS:
        raise RvtoolInputError(f"precision = {precision!r} is not valid; valid choices are {sorted(PRECISIONS)}")


class PairFamilySet(StagedLaunch):
    """Evaluator protocol of a two-body contact family (see the module docstring)."""

    velocity_tangent = True

    def init_evaluation(self, body_a, body_b, n_bodies, anchor_params=None):
        """Assembler of the rows' body pairs (ground = ``n_bodies``), the padded pose and velocity
        buffers and the committed history: per-row anchors and slip distance when
        ``anchor_params`` (N, N_ANCHOR) is given (stick--slip rows), else none."""
        self.n_bodies = n_bodies
        self.anchor = anchor_params is not None
        self.anchor_params = None if anchor_params is None else np.array(anchor_params)
        self.history = ContactHistory(len(body_a)) if self.anchor else NoHistory()
        self.assembler = PairAssembler(body_a, body_b, n_bodies)
        self._pose = np.zeros((n_bodies + 1, 3))
        self._vel = np.zeros((n_bodies + 1, 3))
        self.launches = 0
        self._staged = None

    def reference(self, pose, vel, anchor=None):
        """(Q, dQ/dq, dQ/dv, obs) per row from the NumPy reference at padded poses and velocities;
        with ``anchor`` = (params, *committed history) a fifth result, the trial (flags, anchor_A,
        anchor_B)."""
        raise NotImplementedError

    def set_velocity_tangent(self, on):
        """Velocity tangent dQ/dv on (default) or off (static solves: :meth:`raw` returns None for it
        and the kernel skips the velocity seeds)."""
        self.velocity_tangent = bool(on)
        self.launches += 1      # a launched evaluation made before reads its fields afresh
        if self.backend == "warp":
            self._kernel.set_velocity_tangent(on)

    def raw(self, pose, vel, history=None):
        """Per-row (Q (N, 6), dQdq (N, 6, 6), dQdv (N, 6, 6) or None, obs) at body poses (nb, 3);
        with anchors a fifth result, the trial history (flags, anchor_A, anchor_B, slip distance)
        from the committed ``history`` (default: the set's own); trials never change it."""
        self.launches += 1      # the kernel's buffers change: launched evaluations read afresh
        self._pose[:-1] = pose
        self._vel[:-1] = vel
        if not self.anchor:
            if self.backend == "warp":
                return self._kernel.evaluate(self._pose, self._vel)
            Q, dq, dv, obs = self.reference(self._pose, self._vel)
            return Q, dq, (dv if self.velocity_tangent else None), obs
        hist = history or self.history
        if self.backend == "warp":
            Q, dq, dv, obs, (flag, a, b) = self._kernel.evaluate_anchor(self._pose, self._vel, *hist.as_tuple())
        else:
            Q, dq, dv, obs, (flag, a, b) = self.reference(self._pose, self._vel,
                                                          anchor=(self.anchor_params, *hist.as_tuple()))
            dv = dv if self.velocity_tangent else None
        slip = hist.slip_distance + anchor_ref.slip_increment(hist.active, flag, hist.anchor_a, a)
        return Q, dq, dv, obs, (np.array(flag), np.array(a), np.array(b), slip)

    def evaluate(self, pose, vel, history=None, check=True):
        if check:
            check_finite_state(pose, vel, self.n_bodies)
        r = self.raw(pose, vel, history)
        Qc, dq, dv, obs = r[:4]
        dv = np.zeros_like(dq) if dv is None else dv
        finite = all_finite(Qc, dq, dv)
        return Evaluation(self.assembler.vector(np.asarray(Qc, float)), self.assembler.matrix(np.asarray(dq, float)),
                          self.assembler.matrix(np.asarray(dv, float)), np.array(obs, float),
                          r[4] if self.anchor else (), finite)

    # -- rows summed on the device (the merged element: warp_contacts.segment_sum) ----------
    @property
    def velocity_rows(self):
        """True if every launch writes the velocity tangent rows (off in static mode)."""
        return self.velocity_tangent

    def stages_history(self):
        """True if the kernel reads the committed history (anchor rows)."""
        return bool(self.anchor)

    def launched_field(self, name):
        """Field ``name`` of :class:`Evaluation` from the outputs of the last launch."""
        r = self._staged.read
        if name == "Q":
            return self.assembler.vector(np.asarray(r("q"), float))
        if name == "dQdq":
            return self.assembler.matrix(np.asarray(r("dqdq"), float))
        if name == "dQdv":
            n = self.assembler.n
            return self.assembler.matrix(np.asarray(r("dqdv"), float)) if self.velocity_tangent else np.zeros((n, n))
        if name == "obs":
            return np.array(r("obs"), float)
        if name == "trial_history":
            return self.launched_anchor_history()
        return all_finite(r("q"), r("dqdq"), *((r("dqdv"),) if self.velocity_tangent else ()))

    def commit(self, pose, vel, evaluation=None):
        """Commit the trial history at the accepted state (anchors only; ``evaluation``: the cached
        trial at exactly this state from the committed history) and return its observation rows."""
        if evaluation is None:
            r = self.raw(pose, vel)
            obs, trial = r[3], (r[4] if self.anchor else None)
        else:
            obs, trial = evaluation.obs, evaluation.trial_history
        if self.anchor:
            self.history.assign(trial)
        return np.array(obs, float)
