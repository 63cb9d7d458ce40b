"""Evaluation of a contact set with committed (accepted-step) history.

Trial evaluations (every Newton residual and tangent) read only the committed
history z_n and return a trial history that is *not* stored (Eq.
(trial_state)). :meth:`ContactSetEvaluator.commit` is called once per
accepted step, at the accepted evaluation state, and is the only place where
the committed history changes (Fig. (accepted_state)).
"""
import copy
from dataclasses import dataclass

import numpy as np

from warp_contacts import anchor_ref
from warp_contacts import circle_pairs_ref
from warp_contacts.circle_pairs_ref import I_BODY_A, I_BODY_B

from ..errors import RvtoolInputError
from .assembly import PairAssembler
from .circle_set import CircleContactSet
from ..validation import check_body_state

BACKENDS = ("warp", "numpy")


@dataclass
class Evaluation:
    """Result of one evaluation of a contact set at element coordinates."""
    Q: np.ndarray          # (n,) generalized forces [N, N m]
    dQdq: np.ndarray       # (n, n) dQ/dq
    dQdv: np.ndarray       # (n, n) dQ/dv
    obs: np.ndarray        # (N, 8) per-contact observation values (circle_pairs_ref.O_*)
    trial_history: tuple   # (active, anchor_a, anchor_b), not committed
    finite: bool


FIELDS = ("Q", "dQdq", "dQdv", "obs", "trial_history", "finite")


class LaunchedEvaluation(Evaluation):
    """The :class:`Evaluation` of a family's kernel launch whose rows were not assembled on the
    host (the merged element sums them on the device, :mod:`warp_contacts.segment_sum`): each
    field is made by ``family.launched_field(name)`` from the launch buffers when first read (a
    history commit reads only the observations and the trial history) and kept. The buffers hold
    this launch until the family launches again (``family.launches`` counts launches); a field
    first read after that comes from a fresh ``family.evaluate`` at the same state from the
    committed history, which gives the same values as long as that history was not committed
    since (trial evaluations are read before their step's commit)."""

    def __init__(self, family, pose, vel):
        self._family, self._pose, self._vel = family, pose, vel
        self._stamp = family.launches
        self._made = {}

    def _get(self, name):
        made = self._made
        if name not in made:
            if self._family.launches == self._stamp:
                made[name] = self._family.launched_field(name)
            else:
                full = self._family.evaluate(self._pose, self._vel, check=False)
                for f in FIELDS:
                    made.setdefault(f, getattr(full, f))
        return made[name]

    def _set(self, name, value):
        self._made[name] = value

    @property
    def state(self):
        """(pose, vel) (nb, 3) of the launch: the absolute state this evaluation is at."""
        return self._pose, self._vel


for _f in FIELDS:
    setattr(LaunchedEvaluation, _f, property(lambda self, _n=_f: self._get(_n),
                                             lambda self, v, _n=_f: self._set(_n, v)))


class StagedLaunch:
    """Launch without host assembly, for a family whose rows the merged element sums on the device
    (:mod:`warp_contacts.segment_sum`): the kernel's row buffers, staging of the poses, velocities
    and committed history into its inputs, its recorded launch, and the lazily assembled
    :class:`LaunchedEvaluation`. The family keeps ``_kernel`` (backend "warp"), ``_staged`` (None
    until the first stage), ``assembler``, ``history``, ``launches`` and ``launched_field``; it
    says whether its kernel reads velocities (``stages_velocity``; False: no velocity input or
    velocity tangent rows) and the committed history (``stages_history()``)."""

    stages_velocity = True

    def stages_history(self):
        """True if the kernel reads the committed history (anchor rows)."""
        return False

    def row_buffers(self):
        """(index (N, 6) element coordinate of every row entry, -1 dropped; the Warp arrays q,
        dqdq, dqdv that every launch overwrites, dqdv None without a velocity tangent). Backend
        "warp" only."""
        k = self._kernel
        return (self.assembler.index, k.device_array("q"), k.device_array("dqdq"),
                k.device_array("dqdv") if self.stages_velocity else None)

    def stage(self, pose, vel):
        """Write poses/velocities (nb, 3) and, where the kernel reads it, the committed history into
        the kernel's inputs (no launch: :meth:`launch_staged`, alone or inside a captured graph)."""
        st = self._staged
        if st is None:
            from warp_contacts.staged import Staged
            st = self._staged = Staged(self._kernel)
        st.write_rows("pose", pose)
        if self.stages_velocity:
            st.write_rows("vel", vel)
        if self.stages_history():
            for nm, a in zip(("h_act_in", "h_a_in", "h_b_in"), self.history.as_tuple()):
                st.write(nm, a)

    def launch_staged(self):
        """The kernel's recorded launch on the staged inputs (capturable)."""
        self._kernel.launch_recorded()

    def pose_buffers(self):
        """(pose, vel or None): the Warp input arrays ((n_bodies + 1, 3), the ground's row last) that
        :meth:`stage` fills and :meth:`launch_staged` reads, for a caller that writes the poses on
        the device (:mod:`rvtool.solver.device_rows`). Backend "warp" only."""
        k = self._kernel
        return k.device_array("pose"), (k.device_array("vel") if self.stages_velocity else None)

    def launched(self, pose, vel):
        """The :class:`LaunchedEvaluation` of the launch just made at poses/velocities (nb, 3): its
        fields are assembled from the kernel's outputs when read. Increments ``launches``."""
        self.launches += 1
        return LaunchedEvaluation(self, pose, vel)

    def launched_anchor_history(self):
        """The trial anchor history of the last launch, (active, anchor_a, anchor_b, slip distance)
        with the slip distance grown by the anchors' shift on slip (the tangential sliding of the
        increment); () where the kernel has no anchors."""
        if not self.stages_history():
            return ()
        r = self._staged.read
        flag, a, b = (np.array(r(nm)) for nm in ("h_act_out", "h_a_out", "h_b_out"))
        hist = self.history
        return flag, a, b, hist.slip_distance + anchor_ref.slip_increment(hist.active, flag, hist.anchor_a, a)

    def launch(self, pose, vel):
        """Kernel launch at poses/velocities (nb, 3) from the committed history without assembly
        (:meth:`stage`, :meth:`launch_staged`, :meth:`launched`): the rows stay in the kernel's
        buffers (:meth:`row_buffers`) until the next launch."""
        self.stage(pose, vel)
        self.launch_staged()
        return self.launched(pose, vel)


def check_finite_state(pose, vel, n_bodies):
    """Raise :class:`RvtoolInputError` unless pose and vel are finite arrays of shape (n_bodies, 3)
    (x, y, theta per body): the state check of the evaluators built on other evaluators' rows."""
    for nm, arr in (("pose", pose), ("vel", vel)):
        a = np.asarray(arr)
        if a.shape != (n_bodies, 3) or not np.all(np.isfinite(a)):
            raise RvtoolInputError(f"{nm} must be a finite array of shape ({n_bodies}, 3); got {a.shape}")


def gap_offset_rows(offsets, n, name):
    """Checked per-row gap offsets [m] (shape (n,), finite) of the contact set ``name``."""
    off = np.array(offsets, dtype=np.float64)
    if off.shape != (n,):
        raise RvtoolInputError(f"gap offsets of contact set {name!r} must have shape ({n},), one per observation "
                               f"row; got {off.shape}")
    if not np.all(np.isfinite(off)):
        raise RvtoolInputError(f"gap offsets of contact set {name!r} must be finite [m] (valid range: finite reals); "
                               f"non-finite at rows {np.flatnonzero(~np.isfinite(off))[:4].tolist()}")
    return off


def all_finite(*arrays):
    """True if every entry is finite; one summation per array (a NaN or inf propagates into
    the sum, and overflow of a finite sum is impossible at contact-force magnitudes)."""
    return all(np.isfinite(np.sum(a)) for a in arrays)


class ContactHistory:
    """Committed history of a set: anchor active flags, anchors in body
    coordinates [m], and the accumulated slip distance per contact [m] (the
    sliding distance consumed by wear models; it must grow once per accepted
    step, never once per trial)."""

    def __init__(self, n):
        self.active = np.zeros(n, dtype=np.int32)
        self.anchor_a = np.zeros((n, 2))
        self.anchor_b = np.zeros((n, 2))
        self.slip_distance = np.zeros(n)

    def as_tuple(self):
        """The kernel's history inputs (active, anchor_a, anchor_b)."""
        return self.active, self.anchor_a, self.anchor_b

    def assign(self, trial):
        act, a, b, slip = trial
        self.active = np.array(act, dtype=np.int32)
        self.anchor_a = np.array(a, dtype=np.float64)
        self.anchor_b = np.array(b, dtype=np.float64)
        self.slip_distance = np.array(slip, dtype=np.float64)

    def copy(self):
        h = ContactHistory(len(self.active))
        h.assign((*self.as_tuple(), self.slip_distance))
        return h


class ContactSetEvaluator(StagedLaunch):
    """Evaluates a :class:`CircleContactSet` at absolute body poses.

    backend: "warp" (one batched kernel launch, default) or "numpy" (the
    reference implementation). precision: "float64" (default) or "float32".
    """

    def __init__(self, contact_set: CircleContactSet, backend="warp", precision="float64", device="cpu", *,
                 packed=None):
        """packed: the set's ``packed()`` rows (fparams, iparams) where the caller has them already (a
        copier: the copies' built rows with their body columns moved), else packed here."""
        if backend not in BACKENDS:
            raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are {list(BACKENDS)}")
        self.set = contact_set
        self.name = contact_set.name
        self.ids = contact_set.ids
        self.backend = backend
        self.precision = precision
        self.fparams, self.iparams = contact_set.packed() if packed is None else packed
        self.n_contacts = len(contact_set.contacts)
        self.n_bodies = contact_set.n_bodies
        self.history = ContactHistory(self.n_contacts)
        self.assembler = PairAssembler(self.iparams[:, I_BODY_A], self.iparams[:, I_BODY_B], self.n_bodies)
        if backend == "warp":
            from warp_contacts.circle_pairs import CirclePairKernel
            self._kernel = CirclePairKernel(self.fparams, self.iparams, self.n_bodies, precision, device)
        elif precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")
        self._pose = np.zeros((self.n_bodies + 1, 3))
        self._vel = np.zeros((self.n_bodies + 1, 3))
        self.launches = 0
        self._staged = None
        # the kernel reads the committed history only for anchor rows (CirclePairKernel uploads it so)
        self.history_rows = bool(np.any(self.iparams[:, circle_pairs_ref.I_FRICTION] == circle_pairs_ref.FRICTION_ANCHOR))

    def raw(self, pose, vel, history=None):
        """Per-contact results (Q (N,6), dQdq, dQdv, obs, trial history) at poses (nb, 3).

        The trial history is (active, anchor_a, anchor_b, slip_distance); the slip
        distance grows by the anchor's projection shift on slip, which is the
        tangential sliding of this increment.
        """
        hist = history or self.history
        Qc, dq, dv, obs, trial = self._rows(pose, vel, hist)
        return Qc, dq, dv, obs, self._slip(trial, hist)

    def _rows(self, pose, vel, hist):
        self.launches += 1      # the kernel's buffers change: launched evaluations read afresh
        self._pose[:-1] = pose
        self._vel[:-1] = vel
        if self.backend == "warp":
            return self._kernel.evaluate(self._pose, self._vel, *hist.as_tuple())
        return circle_pairs_ref.evaluate(self._pose, self._vel, self.fparams, self.iparams, *hist.as_tuple())

    @staticmethod
    def _slip(trial, hist):
        act, a, b = trial
        kept = (hist.active != 0) & (act != 0)
        if not kept.any():      # no anchor kept (every row of a set without anchor friction)
            return act, a, b, hist.slip_distance + 0.0
        slip = hist.slip_distance + np.where(kept, np.linalg.norm(a - hist.anchor_a, axis=1), 0.0)
        return act, a, b, slip

    # -- rows summed on the device (the merged element: warp_contacts.segment_sum) ----------
    velocity_rows = True
    """The velocity tangent rows are written at every launch."""

    def stages_history(self):
        """True if the kernel reads the committed history (anchor rows only)."""
        return self.history_rows

    def launched_field(self, name):
        """Field ``name`` of :class:`Evaluation` from the outputs of the last launch."""
        r = self._staged.read
        if name == "Q":
            return self.assembler.vector(np.asarray(r("q"), np.float64))
        if name in ("dQdq", "dQdv"):
            return self.assembler.matrix(np.asarray(r("dqdq" if name == "dQdq" else "dqdv"), np.float64))
        if name == "obs":
            return np.array(r("obs"), np.float64)
        if name == "trial_history":
            return tuple(np.array(a) for a in self._slip((r("h_act_out"), r("h_a_out"), r("h_b_out")), self.history))
        return all_finite(r("q"), r("dqdq"), r("dqdv"))

    def _evaluation(self, Qc, dq, dv, obs, trial):
        Q = self.assembler.vector(np.asarray(Qc, np.float64))
        finite = all_finite(Qc, dq, dv)
        # copies: the kernel's output buffers are reused by the next launch
        return Evaluation(Q, self.assembler.matrix(np.asarray(dq, np.float64)),
                          self.assembler.matrix(np.asarray(dv, np.float64)), np.array(obs, np.float64),
                          tuple(np.array(a) for a in trial), finite)

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"contact set '{self.name}'", pose, vel, (self.n_bodies, 3))

    def evaluate(self, pose, vel, history=None, check=True):
        """Assembled :class:`Evaluation` at absolute poses/velocities (nb, 3) with the committed history.

        ``check=False`` skips the input checks (the contact element checks once per call itself).
        """
        if check:
            self.check_state(pose, vel)
        return self._evaluation(*self.raw(pose, vel, history))

    def set_gap_offsets(self, offsets):
        """Gap offsets [m] per contact (positive opens the gap), absolute over the built
        parameters: the enclosing radius R_B of an internal contact grows by the offset, the
        radius r_B of an external one shrinks by it. Zeros restore the built rows bit for bit."""
        off = gap_offset_rows(offsets, self.n_contacts, self.name)
        if not hasattr(self, "_built_fparams"):
            self._built_fparams = self.fparams.copy()
        fp = self._built_fparams.copy()
        sign = np.where(self.iparams[:, circle_pairs_ref.I_INTERNAL] != 0, 1.0, -1.0)
        fp[:, circle_pairs_ref.P_RB] += sign * off
        self.fparams = fp
        if self.backend == "warp":
            self._kernel.set_parameters(fp)

    def commit(self, pose, vel, evaluation=None):
        """Evaluate at the accepted state from the committed history and commit the result.

        ``evaluation``: a trial :class:`Evaluation` made at exactly this state
        from the current committed history (the element's cached last Newton
        evaluation); it is reused instead of a second launch.
        Returns the observation array (N, 8) at the accepted state.
        """
        if evaluation is not None:
            self.history.assign(evaluation.trial_history)
            return np.array(evaluation.obs, np.float64)
        Qc, dq, dv, obs, trial = self.raw(pose, vel, self.history)
        self.history.assign(trial)
        return np.array(obs, np.float64)


_ID_PARTS = {}
"""ids tuple -> its ids split at the first "/" (:func:`renamed_ids`; at most 17 kept)."""


def renamed_ids(ids, rename):
    """The row ids ``"member/rest"`` of a built set with each member's name replaced by
    ``rename[member]`` (a copier's ids: B copies of one family, ~1,000 rows each). Bit for bit
    ``rename[x.split("/", 1)[0]] + "/" + x.split("/", 1)[1]`` per id; the split of an ids tuple is
    kept for the next set with equal ids (the variant copies of one topology: ~1 s of string
    splitting at 1,000 RV-40E copies)."""
    parts = _ID_PARTS.get(ids)
    if parts is None:
        if len(_ID_PARTS) > 16:
            _ID_PARTS.clear()
        parts = _ID_PARTS[ids] = tuple((h, "/" + t) for h, _, t in (x.partition("/") for x in ids))
    return [rename[h] + t for h, t in parts]


def moved_member(member, **changes):
    """A copy of the built, frozen member ``member`` (a mesh or mounting) with ``changes`` (its name,
    its bodies) set, without running its validation again: a copier (``concatenated`` of the sets)
    puts validated members on other bodies under other names, B times per family, and
    ``dataclasses.replace`` would check every field again (~0.25 ms a member)."""
    out = copy.copy(member)
    for k, v in changes.items():
        object.__setattr__(out, k, v)
    return out
