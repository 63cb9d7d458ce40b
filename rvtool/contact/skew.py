"""A planar contact family across the face width of bodies that tilt (issue 32; paper Eq. (skew)
and Eq. (width_resultant)).

A body with retained out-of-plane coordinates (z, gamma_x, gamma_y) about its centre
(:class:`exudyn_user_elements.out_of_plane.RetainedTilt`) moves the material point at axial arm
a from its centre by gamma x (0, 0, a) = a (gamma_y, -gamma_x, 0) in the plane (small tilts). A
contact slice at arm a_A on body A and a_B on body B with in-plane normal n thus sees the planar
approach plus the skew term of Eq. (skew),

    delta_s = delta_planar + n . (a_A (gamma_yA, -gamma_xA) - a_B (gamma_yB, -gamma_xB))
            = delta_planar + a (Delta gamma_y n_x - Delta gamma_x n_y)   (a_A = a_B = a),

which is exactly the planar family evaluated at the slice's poses: each body translated in its
plane by its arm times its tilt. :class:`SkewSlices` evaluates the planar family (any evaluator of
the element protocol, its own law, search and laminae untouched) once per width slice s at the
poses x_s = T_s x, T_s linear in the planar and out-of-plane coordinates, weights the slice by its
width fraction w_s (sum 1) and returns

    Q = sum_s w_s T_s^T Q_s(T_s x),    dQ/dx = sum_s w_s T_s^T K_s T_s,

the width resultant of Eq. (width_resultant): each slice's in-plane force f_s at arm a gives the
bodies the tilting moments (-a f_y, a f_x) on (gamma_x, gamma_y). Line contacts with in-plane
normals carry no axial force; a slice that opens carries none (activation per slice: an edge can
load while the mid-plane is open). T_s is constant, so the tangent is the family's own analytic
tangent mapped (its central-difference check carries over; tests check it again).

At zero tilt every slice sits at the planar pose and the sum is the planar family's result times
sum_s w_s = 1 (round-off): a spatial model without out-of-plane load reproduces the planar
figures. Slices whose poses coincide are evaluated once. The slices multiply any face-width
slices the family has of its own (each wrapped slice evaluates the whole family at its poses;
crowning across the width stays the family's). The family must carry no contact history (friction
anchors would need one history per slice): refused by name.

One launch per family (issue 32's cost target): where the family's type can stack copies of itself
(``concatenated``: the S slices' rows over S copies of its bodies, copy s offset by s n, in one
kernel), :class:`SkewSlices` evaluates every slice in one launch at the stacked poses x_st = T x
(T = [T_1; ...; T_S]) and maps the stacked result with one constant operator each,

    Q = T^T W Q_st,    dQ/dx = T^T W K_st T      (W = diag(w_s), K_st block diagonal),

and, for a Warp family, its rows reach the merged element's device sums
(:mod:`warp_contacts.segment_sum`) through the sparse maps C = T^T W A of the forces and D = T^T A
of the displacements (A the stacked family's row scatter), so the sliced family is summed in the merged element's captured launch like a planar one.
The per-slice path stays for families without ``concatenated`` and for the observers' views.
"""
import dataclasses

import numpy as np
from scipy import sparse

from ..errors import RvtoolInputError
from .evaluator import Evaluation, LaunchedEvaluation, all_finite
from ..validation import check_body_state, SPATIAL_LAYOUT
from warp_contacts.circle_pairs_ref import O_FN, O_GAP


def slice_stations(width, n_slices):
    """(arms (n,) [m] about the centre of ``width``, weights (n,), summing to 1): the Gauss--Legendre
    stations and weights of ``n_slices`` points over the width. n >= 2 points integrate the force and
    the moment of a linear load distribution exactly (the width resultant of a uniform contact under
    a tilt: sum_s w_s a_s^2 = b^2 / 12), so two slices already give the exact tilt stiffness of a
    contact closed across its width; more slices resolve a contact that opens over part of it."""
    if isinstance(n_slices, bool) or not isinstance(n_slices, (int, np.integer)) or n_slices < 2:
        raise RvtoolInputError(f"n_slices = {n_slices!r} is outside the valid range [2, inf) (integer)")
    if not (np.isfinite(width) and width > 0):
        raise RvtoolInputError(f"width = {width!r} m is outside the valid range (0, inf)")
    x, w = np.polynomial.legendre.leggauss(int(n_slices))
    return 0.5 * width * x, 0.5 * w


class SkewSlices:
    """The planar evaluator ``inner`` (``n_bodies`` = n planar bodies) over width slices with the
    tilts of its bodies (module docstring).

    n_virtual: out-of-plane pose rows appended after the planar bodies (the element's
    :class:`~exudyn_user_elements.out_of_plane.RetainedTilt`, all its bodies); tilt_rows: {planar body
    index: its out-of-plane row (0-based among the n_virtual)}; arms (S, n) [m]: the axial arm of each
    planar body in slice s (a body not in ``tilt_rows`` does not move with it); weights (S,): width
    fractions, positive, summing to 1; name: element name (default the inner family's).
    tilt_offset: None (the out-of-plane rows appended after the inner family's bodies) or the pose row
    of out-of-plane row 0 among the inner family's own bodies (rows it carries as bodies without
    contacts: a series closure around the sliced family passes them through).
    stack: True (default) evaluates all slices in one launch of a stacked copy of ``inner`` where its
    type has ``concatenated`` (module docstring); False keeps the per-slice evaluation.
    """

    def __init__(self, inner, n_virtual, tilt_rows, arms, weights, *, name=None, tilt_offset=None, stack=True):
        for attr in ("n_bodies", "ids", "evaluate", "history"):
            if not hasattr(inner, attr):
                raise RvtoolInputError(f"inner must be a contact evaluator; {type(inner).__name__} lacks {attr!r}")
        if any(isinstance(v, np.ndarray) for v in vars(inner.history).values()):
            raise RvtoolInputError(f"contact set {inner.name!r} carries a contact history (friction anchors); tilting "
                                   "bodies slice it across the width, one history per slice is not carried (valid: "
                                   "frictionless or regularized friction, or planar wheel/crank coordinates)")
        n = int(inner.n_bodies)
        arms = np.atleast_2d(np.asarray(arms, float))
        w = np.asarray(weights, float)
        if arms.shape != (len(w), n):
            raise RvtoolInputError(f"arms must have shape (n_slices, n_bodies) = ({len(w)}, {n}); got {arms.shape}")
        if not (np.all(np.isfinite(arms)) and np.all(w > 0) and abs(w.sum() - 1.0) <= 1e-12):
            raise RvtoolInputError(f"weights = {w.tolist()} must be positive fractions summing to 1 and the arms finite")
        for b, r in tilt_rows.items():
            if not (0 <= b < n and 0 <= r < n_virtual):
                raise RvtoolInputError(f"tilt_rows {{{b}: {r}}} is outside the valid range: body in [0, {n - 1}], "
                                       f"row in [0, {n_virtual - 1}]")
        if tilt_offset is not None and not (0 <= tilt_offset and tilt_offset + n_virtual <= n):
            raise RvtoolInputError(f"tilt_offset = {tilt_offset!r}: the out-of-plane rows must lie among the inner "
                                   f"family's {n} bodies")
        self.inner, self.name = inner, name or inner.name
        self.n_planar, self.n_virtual = n, int(n_virtual)
        self.n_bodies = n + self.n_virtual if tilt_offset is None else n
        base = n if tilt_offset is None else int(tilt_offset)
        self.ids, self.history = inner.ids, inner.history
        self.tilt_rows, self.arms, self.weights = dict(tilt_rows), arms, w
        # T_s = [I | A_s] (3n, 3n + 3 n_virtual): x_b += a gamma_y, y_b -= a gamma_x; A_s held as its
        # entries: planar rows, tilt columns (both absolute) and the values per slice
        rows_, cols_, vals = [], [], []
        for b, r in self.tilt_rows.items():
            c = 3 * (base + r)
            rows_ += [3 * b, 3 * b + 1]
            cols_ += [c + 2, c + 1]
            vals += [arms[:, b], -arms[:, b]]
        self._rows, self._cols = np.array(rows_, int), np.array(cols_, int)
        self._vals = np.array(vals, float).T.reshape(len(w), len(rows_))        # (S, 2 n_tilted)
        m = 3 * self.n_bodies
        T = np.zeros((len(w), 3 * n, m))
        T[:, np.arange(3 * n), np.arange(3 * n)] = 1.0
        T[:, self._rows, self._cols] = self._vals
        self.maps = T
        self._maps_t = np.ascontiguousarray(T.transpose(0, 2, 1))
        # the width resultant as one sparse product per evaluation over all slices (row-major vec):
        # Q = [w_1 T_1^T ... w_S T_S^T] [Q_1; ...; Q_S] and vec(sum_s w_s T_s^T X_s T_s) =
        # [w_1 T_1^T (x) T_1^T ... ] [vec X_1; ...] (vec(A X B) = (A (x) B^T) vec X); the "_one" forms
        # take a single X shared by every slice (slices at equal poses: sum_s w_s T_s^T (x) T_s^T)
        Tt = [sparse.csr_matrix(T[s].T) for s in range(len(w))]
        self._q_all = sparse.hstack([w[s] * Tt[s] for s in range(len(w))], format="csr")
        kr = [w[s] * sparse.kron(Tt[s], Tt[s], format="csr") for s in range(len(w))]
        self._k_all = sparse.hstack(kr, format="csr")
        self._q_one = sum(w[s] * Tt[s] for s in range(len(w))).tocsr()
        self._k_one = sum(kr[1:], kr[0]).tocsr()
        self.stacked = stacked_copy(inner, len(w)) if stack and tilt_offset is None else None
        if self.stacked is not None:
            # the stacked operators: T (S 3n, m) and T^T W (m, S 3n)
            self._T_all = T.reshape(len(w) * 3 * n, m)
            self._TW = np.ascontiguousarray((T * w[:, None, None]).reshape(len(w) * 3 * n, m).T)

    @property
    def n_slices(self):
        return len(self.weights)

    def slice_poses(self, pose):
        """(S, n, 3) planar poses of every slice at element poses (n + n_virtual, 3) (or velocities)."""
        x = np.asarray(pose, float).ravel()
        return (self.maps @ x).reshape(self.n_slices, self.n_planar, 3)

    def _groups(self, poses):
        """[slice indices] of slices at bitwise-equal poses (all slices in one where no body tilts)."""
        if (poses == poses[0]).all():
            return [list(range(self.n_slices))]
        groups = {}
        for s in range(self.n_slices):
            groups.setdefault(poses[s].tobytes(), []).append(s)
        return list(groups.values())

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"contact set '{self.name}'", pose, vel, (self.n_bodies, 3), SPATIAL_LAYOUT)

    def slice_evaluations(self, pose, vel=None, check=True):
        """[(slice indices, the inner :class:`Evaluation` at their common poses)]."""
        if check:
            self.check_state(pose, vel)
        P = self.slice_poses(pose)
        V = None if vel is None else self.slice_poses(vel)
        out = []
        for g in self._groups(P if V is None else np.concatenate([P, V], axis=1)):
            s = g[0]
            out.append((g, self.inner.evaluate(P[s], None if V is None else V[s], check=False)))
        return out

    def evaluate(self, pose, vel=None, history=None, check=True):
        """The slices' :class:`Evaluation` summed (module docstring); observations: the width resultant of
        each row (normal force sum_s w_s f_s, the other columns width-weighted means, the gap the smallest
        over the slices)."""
        if self.stacked is not None:
            if check:
                self.check_state(pose, vel)
            P = self.slice_poses(pose)
            V = np.zeros_like(P) if vel is None else self.slice_poses(vel)
            S, n = self.n_slices, self.n_planar
            e = self.stacked.evaluate(P.reshape(S * n, 3), V.reshape(S * n, 3), check=False)
            return self._stacked_evaluation(P, V, e.Q, e.dQdq, e.dQdv, e.obs, e.finite)
        groups = self.slice_evaluations(pose, vel, check)
        S = self.n_slices
        ev_of = [None] * S
        for g, ev in groups:
            for s in g:
                ev_of[s] = ev
        w = self.weights
        m = 3 * self.n_bodies
        # sum_s w_s T_s^T Q_s and sum_s w_s T_s^T X_s T_s: one sparse product each over all slices
        if len(groups) == 1:
            e = groups[0][1]
            Q = self._q_one @ e.Q
            K = (self._k_one @ np.ravel(e.dQdq)).reshape(m, m)
            C = None if e.dQdv is None else (self._k_one @ np.ravel(e.dQdv)).reshape(m, m)
        else:
            Q = self._q_all @ np.concatenate([e.Q for e in ev_of])
            K = (self._k_all @ np.concatenate([np.ravel(e.dQdq) for e in ev_of])).reshape(m, m)
            damped = all(e.dQdv is not None for _, e in groups)
            C = (self._k_all @ np.concatenate([np.ravel(e.dQdv) for e in ev_of])).reshape(m, m) if damped else None
        if len(groups) == 1:
            obs = np.array(groups[0][1].obs, float)      # no tilt: the planar rows
        else:
            obs = sum(float(np.sum(w[g])) * np.asarray(e.obs, float) for g, e in groups)
            obs[:, O_GAP] = np.min([e.obs[:, O_GAP] for _, e in groups], axis=0)
        finite = all(e.finite for _, e in groups) and bool(np.all(np.isfinite(Q)))
        return Evaluation(Q, K, C, obs, (), finite)

    def _stacked_evaluation(self, P, V, Q_st, K_st, C_st, obs_st, finite):
        """The :class:`Evaluation` from the stacked family's results at slice poses P, velocities V (S, n, 3)."""
        TW, T = self._TW, self._T_all
        Q = TW @ Q_st
        K = TW @ K_st @ T
        C = None if C_st is None else TW @ C_st @ T
        return Evaluation(Q, K, C, self._stacked_obs(P, V, obs_st), (),
                          bool(finite) and bool(np.all(np.isfinite(Q))))

    def _stacked_obs(self, P, V, obs_st):
        """The width resultant of the observation rows (see :meth:`evaluate`) from the stacked rows
        (S N, 8): the planar rows themselves where every slice sits at the same poses and velocities."""
        o = np.asarray(obs_st, float).reshape(self.n_slices, -1, np.shape(obs_st)[-1])
        if (P == P[0]).all() and (V == V[0]).all():
            return np.array(o[0])
        obs = np.tensordot(self.weights, o, axes=1)
        obs[:, O_GAP] = np.min(o[:, :, O_GAP], axis=0)
        return obs

    # -- every slice in one launch, rows summed on the device (the merged element) -----------------
    @property
    def backend(self):
        """The stacked family's backend ("warp": the merged element may sum this family's rows on the
        device), or "host" (evaluated slice by slice)."""
        return "host" if self.stacked is None else self.stacked.backend

    @property
    def launches(self):
        """The stacked family's launch count (a launched evaluation made before reads afresh)."""
        return self.stacked.launches

    @property
    def velocity_rows(self):
        return self.stacked.velocity_rows

    def _stacked_state(self, pose, vel):
        P = self.slice_poses(pose)
        V = np.zeros_like(P) if vel is None else self.slice_poses(vel)
        return P, V

    def stage(self, pose, vel):
        """Write the stacked slice poses/velocities into the stacked family's kernel inputs (no launch)."""
        P, V = self._staged_state = self._stacked_state(pose, vel)
        S, n = self.n_slices, self.n_planar
        self.stacked.stage(P.reshape(S * n, 3), V.reshape(S * n, 3))

    def launch_staged(self):
        """The stacked family's recorded launch on the staged inputs (capturable)."""
        self.stacked.launch_staged()

    def launched(self, pose, vel):
        """The :class:`~rvtool.contact.evaluator.LaunchedEvaluation` of the launch just made at element
        poses/velocities (n_bodies, 3) (the ones :meth:`stage` was given)."""
        P, V = self._staged_state
        S, n = self.n_slices, self.n_planar
        self.stacked.launched(P.reshape(S * n, 3), V.reshape(S * n, 3))
        self._launched_state = (P, V)
        return LaunchedEvaluation(self, pose, vel)

    def launched_field(self, name):
        """Field ``name`` of the :class:`Evaluation` from the stacked family's last launch."""
        st = self.stacked
        if name == "Q":
            return self._TW @ st.launched_field("Q")
        if name in ("dQdq", "dQdv"):
            return self._TW @ st.launched_field(name) @ self._T_all
        if name == "obs":
            return self._stacked_obs(*self._launched_state, st.launched_field("obs"))
        if name == "trial_history":
            return ()
        return bool(st.launched_field("finite"))

    def row_buffers(self):
        """((C, D), q, dqdq, dqdv): the stacked family's row buffers and the sparse maps through which
        its row entries reach this family's coordinates (:func:`warp_contacts.segment_sum_ref.weighted_segments`),
        forces C = T^T W A and displacements D = T^T A (m, N_st k), A the stacked rows' scatter:
        Q = C vec(q), K = sum_i C_i K_i D_i^T (module docstring)."""
        index, q, dqdq, dqdv = self.stacked.row_buffers()
        flat = np.asarray(index).ravel()
        keep = np.flatnonzero(flat >= 0)
        A = sparse.csr_matrix((np.ones(len(keep)), (flat[keep], keep)), shape=(self._TW.shape[1], flat.size))
        return (sparse.csr_matrix(self._TW) @ A, sparse.csr_matrix(self._T_all.T) @ A), q, dqdq, dqdv

    def commit(self, pose, vel=None, evaluation=None):
        """Observation rows at the accepted state (no history to commit)."""
        if evaluation is not None:
            return np.array(evaluation.obs, float)
        return self.evaluate(pose, vel, check=False).obs

    def slice_forces(self, pose):
        """(S, N) normal force [N] of every inner row in every slice (the slice's weight applied): the load
        along the face width."""
        out = np.zeros((self.n_slices, len(self.ids)))
        pose = np.asarray(pose, float)
        for g, ev in self.slice_evaluations(pose, np.zeros_like(pose), check=True):   # at rest
            for s in g:
                out[s] = self.weights[s] * np.asarray(ev.obs, float)[:, O_FN]
        return out

    def planar_pose(self, pose):
        """The inner family's poses (n, 3) at the mid-plane (without the skew)."""
        return np.asarray(pose, float)[:self.n_planar]

    def resultants(self, pose, vel=None):
        """The inner family's ``resultants`` (e.g. :class:`~rvtool.bearings.set.BearingLoads` per mounting)
        summed over the slices with their weights (each slice's at its skewed poses)."""
        out = {}
        pose = np.asarray(pose, float)
        for g, _ in self.slice_evaluations(pose, np.zeros_like(pose), check=True):     # at rest
            w = float(np.sum(self.weights[g]))
            res = self.inner.resultants(self.slice_poses(pose)[g[0]])
            for name, r in res.items():
                f = {k: w * np.asarray(v, float) for k, v in vars(r).items()}
                if name in out:
                    f = {k: out[name][k] + v for k, v in f.items()}
                out[name] = f
        ref = self.inner.resultants(self.planar_pose(pose))
        return {name: dataclasses.replace(ref[name], **{k: (float(v) if np.ndim(v) == 0 else
                                                            (tuple(v.tolist()) if isinstance(getattr(ref[name], k), tuple)
                                                             else v)) for k, v in f.items()})
                for name, f in out.items()}

    def set_gap_offsets(self, offsets):
        """Gap offsets [m] per row, passed to the inner family (the same in every slice)."""
        if not callable(getattr(self.inner, "set_gap_offsets", None)):
            if np.any(np.asarray(offsets) != 0.0):
                raise RvtoolInputError(f"contact set {self.name!r} takes no gap offsets; valid: zero offsets")
            return
        self.inner.set_gap_offsets(offsets)
        if self.stacked is not None:
            self.stacked.set_gap_offsets(np.tile(np.asarray(offsets, float), self.n_slices))


def stacked_copy(family, n_copies):
    """``family`` stacked ``n_copies`` times over as many copies of its bodies (copy c's bodies
    offset by c n_bodies: its ``concatenated``), or None where its type defines no ``concatenated`` of its
    own (the per-slice path then evaluates it)."""
    # the type's own concatenated only: a subclass that inherits its parent's builds its copies as the parent
    conc = type(family).__dict__.get("concatenated")
    if conc is None or getattr(family, "backend", None) not in ("warp", "numpy"):
        return None
    conc = getattr(type(family), "concatenated")
    device = "cpu"
    if family.backend == "warp":
        if not callable(getattr(family, "row_buffers", None)):
            return None         # its kernel's device is not exposed: the per-slice path
        device = str(family.row_buffers()[1].device)
    return conc([family] * n_copies, family.n_bodies, names=[[f"slice{c}_{m}" for m in _member_names(family)]
                                                              for c in range(n_copies)],
                precision=getattr(family, "precision", "float64"), device=device)


def _member_names(family):
    """The names of the members (meshes or mountings) a family's ``concatenated`` renames."""
    members = getattr(family, "meshes", None)
    if members is None:
        members = getattr(family, "mountings", None)
    return [family.name] if members is None else [m.name for m in members]


def planar_view(evaluator, pose=None):
    """(the planar family, its mid-plane poses) of an evaluator that may be sliced with tilts
    (:class:`SkewSlices`); any other evaluator and ``pose`` unchanged."""
    if isinstance(evaluator, SkewSlices):
        return evaluator.inner, None if pose is None else evaluator.planar_pose(pose)
    return evaluator, pose
