"""All contact families of B independent reducer copies, one kernel launch per family.

The copies are numbered c = 0..B-1 and own the bodies c nb .. c nb + nb - 1 of one
body list (nb bodies per copy, the layout of :func:`rvtool.assembly.cycloid.build`).
Each family is one evaluator over all B nb bodies, so one launch evaluates every
contact of every copy. No contact couples two copies, so the tangent of the whole
batch is block diagonal: :class:`CopyBlockAssembler` scatters the per-contact rows
(Q (N, 3m), dQ/dq (N, 3m, 3m) for m bodies per row, Eq. (contact_mapping)) straight
into per-copy blocks (B, 3 nb) and (B, 3 nb, 3 nb) instead of a dense (3 nb B)^2
matrix (which at B = 1000 and nb = 4 would be 1.1 GB per family).

Pure NumPy/Warp: testable without Exudyn (:mod:`exudyn_user_elements.batched_element`
puts it into an Exudyn system).
"""
import time

import numpy as np

from warp_contacts import circle_pairs_ref, cycloid_pins_ref

from ..contact.assembly import RowScatter, pair_index
from ..errors import RvtoolInputError


class RowBlockAssembler:
    """Sum per-row generalized forces and tangents into per-copy blocks of ``n`` coordinates.

    local: (N, k) the coordinate of every row entry within its copy (-1: dropped, e.g. the
    ground); row_copy: (N,) the copy of every row; n_copies: B. The device row sums
    (:class:`warp_contacts.block_scatter.BlockScatter`) read ``local`` and ``row_copy``.
    """

    def __init__(self, local, row_copy, n, n_copies):
        self.local = np.asarray(local, np.int64)
        self.row_copy = np.asarray(row_copy, np.int64)
        self.n, self.n_copies = int(n), int(n_copies)
        self._vec = RowScatter(np.where(self.local >= 0, self.row_copy[:, None] * self.n + self.local, -1),
                               self.n_copies * self.n)
        # the block map (N k^2 indices) is made on the first blocks(): the device row sum reads
        # only local and row_copy
        self._mat = None

    def vector(self, Q):
        """(B, n) from per-row forces (N, k)."""
        return self._vec(Q).reshape(self.n_copies, self.n)

    def blocks(self, K):
        """(B, n, n) from per-row tangents (N, k, k)."""
        if self._mat is None:
            n = self.n
            pos = pair_index(self.local, n)
            self._mat = RowScatter(np.where(pos >= 0, self.row_copy[:, None, None] * n * n + pos, -1),
                                   self.n_copies * n * n)
        return self._mat(K).reshape(self.n_copies, self.n, self.n)


class CopyBlockAssembler(RowBlockAssembler):
    """:class:`RowBlockAssembler` of rows over the bodies of B copies (n = 3 nb coordinates per copy).

    bodies: (N, m) global body indices of each row's m bodies (``n_copies * nb`` or more
    = the ground row of the kernels' padded pose array: dropped). Every row must couple
    bodies of one copy only (raises :class:`RvtoolInputError` otherwise): that is what
    makes the batch tangent block diagonal.
    """

    def __init__(self, bodies, nb, n_copies):
        bodies = np.asarray(bodies, dtype=np.int64)
        n_rows, m = bodies.shape
        ground = bodies >= nb * n_copies
        copy = np.where(ground, -1, bodies // nb)
        row_copy = copy.max(axis=1)
        if np.any(row_copy < 0):
            raise RvtoolInputError("a contact row couples only ground; every row needs a body of one copy")
        if np.any((copy >= 0) & (copy != row_copy[:, None])):
            bad = int(np.flatnonzero(np.any((copy >= 0) & (copy != row_copy[:, None]), axis=1))[0])
            raise RvtoolInputError(f"contact row {bad} couples bodies {bodies[bad].tolist()} of different copies "
                                   f"(nb = {nb} bodies per copy); copies must be independent")
        self.nb = nb
        local = 3 * (bodies % nb)[:, :, None] + np.arange(3)            # (N, m, 3)
        local = np.where(ground[:, :, None], -1, local).reshape(n_rows, 3 * m)
        super().__init__(local, row_copy, 3 * nb, n_copies)


class BatchEvaluation:
    """Result of one batch evaluation: per-copy forces Q (B, 3 nb) [N, N m], tangents
    dQ/dq and dQ/dv (B, 3 nb, 3 nb), per-copy finiteness (B,), and the cycloid-pin
    observation rows (N_pins, 8) (for pin forces). dQ/dv is assembled on first access:
    the static solver never asks for it (its velocity factor is zero)."""

    def __init__(self, Q, dQdq, dQdv, finite, pin_obs, normal_forces=None):
        self.Q, self.dQdq, self.finite, self.pin_obs = Q, dQdq, finite, pin_obs
        self._dQdv = dQdv
        # per-row normal forces [N] of the output-pin and bearing families (family peaks)
        self.normal_forces = normal_forces or {}

    @property
    def dQdv(self):
        if callable(self._dQdv):
            self._dQdv = self._dQdv()
        return self._dQdv


class BatchContactEvaluator:
    """Evaluate the families (pins, output pins, bearings) of all copies at global body
    poses/velocities (B nb, 3).

    pin_set: :class:`rvtool.contact.cycloid_set.CycloidPinSet` over all B nb bodies;
    output_kernel: :class:`warp_contacts.output_pins.OutputPinKernel` (plain mode) over
    the concatenated rows of all copies; bearings:
    :class:`rvtool.contact.evaluator.ContactSetEvaluator` over all B nb bodies.
    ``timing`` accumulates the wall time [s] spent in the three launches ("kernels")
    and in the block scatter ("scatter").
    """

    def __init__(self, pin_set, output_kernel, output_bodies, bearings, nb, n_copies):
        self.pin_set, self.output_kernel, self.bearings = pin_set, output_kernel, bearings
        self.nb, self.n_copies = nb, n_copies
        nt = nb * n_copies
        for nm, n in (("pin_set", pin_set.n_bodies), ("bearings", bearings.n_bodies)):
            if n != nt:
                raise RvtoolInputError(f"{nm}.n_bodies = {n}; the batch has {n_copies} x {nb} = {nt} bodies")
        self.pin_asm = CopyBlockAssembler(
            pin_set.iparams[:, [cycloid_pins_ref.J_BODY_A, cycloid_pins_ref.J_BODY_B]], nb, n_copies)
        self.op_asm = CopyBlockAssembler(output_bodies, nb, n_copies)
        self.brg_asm = CopyBlockAssembler(
            bearings.iparams[:, [circle_pairs_ref.I_BODY_A, circle_pairs_ref.I_BODY_B]], nb, n_copies)
        self._pose = np.zeros((nt + 1, 3))       # ground row last (the kernels' padding)
        self.pin_copy = self.pin_asm.row_copy
        self.timing = {"kernels": 0.0, "scatter": 0.0, "launches": 0}
        self.inject_nan = {}                      # fault injection (tests): {copy: set of evaluation counters}
        # parked copies contribute no contact forces (their results are ignored; see protocol)
        self.masked = np.zeros(n_copies, bool)
        self.n_evaluations = 0
        self._scatter = None
        self.device_scatter = False
        # row masks of the peak-load families (names as rvtool.model.ReducerModel.family_peaks)
        fam = [cid.split("/")[-1] for cid in bearings.ids]
        self.bearing_families = {f + "s": np.array([c.startswith(f) for c in fam])
                                 for f in ("eccentric_bearing", "main_bearing", "input_bearing")}
        self.bearing_families = {k: v for k, v in self.bearing_families.items() if v.any()}

    def evaluate(self, pose, vel):
        """:class:`BatchEvaluation` at absolute poses and velocities (B nb, 3)."""
        t0 = time.perf_counter()
        Qp, Kp, Dp, obs = self.pin_set.raw(pose, vel)
        self._pose[:-1] = pose
        r = self.output_kernel.evaluate(self._pose)
        Qb, Kb, Db, brg_obs, _ = self.bearings.raw(pose, vel)
        t1 = time.perf_counter()
        A, O, Bg = self.pin_asm, self.op_asm, self.brg_asm
        if self.device_scatter:
            pk, ok, bk = self._device_kernels()
            Q, K = self._scatter([(k.device_array("q"), k.device_array("dqdq")) for k in (pk, ok, bk)])
        else:
            Q = A.vector(Qp) + O.vector(r["Q"]) + Bg.vector(Qb)
            K = A.blocks(Kp) + O.blocks(r["dQdq"]) + Bg.blocks(Kb)
        # a NaN or inf of one copy stays in that copy's block: per-copy finiteness (the
        # damping rows are checked per row here, their blocks are assembled on demand)
        finite = np.isfinite(Q.sum(axis=1) + K.sum(axis=(1, 2)))
        masked = self.masked.copy()
        if Dp is None:
            def damping():
                raise RuntimeError("dQ/dv was not computed: the batch evaluator is in static mode "
                                   "(set_static(False) for solves that need the velocity tangent)")
        else:
            d_bad = ~np.isfinite(Dp.reshape(len(Dp), -1).sum(axis=1))
            b_bad = ~np.isfinite(Db.reshape(len(Db), -1).sum(axis=1))
            finite[A.row_copy[d_bad]] = False
            finite[Bg.row_copy[b_bad]] = False
            Dp, Db = np.array(Dp, np.float64), np.array(Db, np.float64)   # kernel buffers are reused next call

            def damping():
                # the output-pin family has no damping
                D = A.blocks(Dp) + Bg.blocks(Db)
                D[masked] = 0.0
                return D
        self.n_evaluations += 1
        for c, when in self.inject_nan.items():
            if self.n_evaluations in when:
                Q[c] = np.nan
                finite[c] = False
        if np.any(masked):
            Q[masked], K[masked], finite[masked] = 0.0, 0.0, True
        self.timing["kernels"] += t1 - t0
        self.timing["scatter"] += time.perf_counter() - t1
        self.timing["launches"] += 3
        from warp_contacts.circle_pairs_ref import O_FN
        from warp_contacts.output_pins_ref import S_FORCE
        forces = {"output_pins": np.max(np.asarray(r["slices"])[..., S_FORCE], axis=1),
                  "bearings": np.array(np.asarray(brg_obs)[:, O_FN])}
        return BatchEvaluation(Q, K, damping, finite, np.array(obs, np.float64), forces)

    def set_static(self, on):
        """Static mode: no velocity tangent (the cycloid-pin kernel skips its velocity seeds and
        :attr:`BatchEvaluation.dQdv` raises). Static solves never need it (velocity factor 0).
        On a GPU, static mode also sums the per-row forces and tangents into the per-copy
        blocks on the device (:class:`warp_contacts.block_scatter.BlockScatter`): only B
        blocks cross to the host instead of every row's tangent."""
        self.pin_set.set_velocity_tangent(not on)
        kernels = self._device_kernels()
        if kernels is None:
            return
        if on and self._scatter is None:
            from warp_contacts.block_scatter import BlockScatter
            pk = kernels[0]
            self._scatter = BlockScatter([(a.local, a.row_copy) for a in (self.pin_asm, self.op_asm, self.brg_asm)],
                                         self.n_copies, self.pin_asm.n, pk.wdtype, pk.device)
        self.device_scatter = bool(on)
        for k, names in zip(kernels, ({"q", "dqdq"}, {"q", "dqdq"}, {"q", "dqdq", "dqdv"})):
            k.keep_on_device = frozenset(names) if on else frozenset()

    def _device_kernels(self):
        """(pin, output-pin, bearing) kernels if all three run on a GPU, else None."""
        import warp as wp
        ks = (getattr(self.pin_set, "_kernel", None), self.output_kernel, getattr(self.bearings, "_kernel", None))
        if any(k is None or not hasattr(k, "device_array") for k in ks):
            return None
        if any(wp.get_device(k.device).is_cpu for k in ks):
            return None
        return ks

    def family_peaks(self, ev):
        """{family: (B,) peak normal force [N]} of a :class:`BatchEvaluation` (zero velocity
        states: families as :func:`rvtool.model.ReducerModel.family_peaks`)."""
        from warp_contacts.circle_pairs_ref import O_FN

        def per_copy(rows_copy, f):
            out = np.zeros(self.n_copies)
            np.maximum.at(out, rows_copy, f)
            return out
        out = {"pins": per_copy(self.pin_asm.row_copy, ev.pin_obs[:, O_FN]),
               "output_pins": per_copy(self.op_asm.row_copy, ev.normal_forces["output_pins"])}
        fb = ev.normal_forces["bearings"]
        for name, m in self.bearing_families.items():
            out[name] = per_copy(self.brg_asm.row_copy[m], fb[m])
        return out

    def pin_forces(self, pin_obs):
        """(B, n_wheels, z_b) pin normal forces [N] (slices summed) from pin observation rows."""
        pf = self.pin_set.pin_forces(pin_obs)                  # (B n_wheels, z_b), meshes copy-major
        return pf.reshape(self.n_copies, -1, pf.shape[1])


