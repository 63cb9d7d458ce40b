"""A set of tapered roller bearings (rows or pairs), evaluated in one kernel
launch, in two uses:

* 5-DOF: :meth:`TaperedBearingSet.relative` takes each mounting's relative
  displacement of the inner ring (cone) with respect to the outer ring (cup),
  q = (delta_x, delta_y, delta_z, gamma_x, gamma_y) at the mounting's axial
  centre in the cup's frame, and returns the wrench on the cone
  (F_x, F_y, F_z, M_x, M_y), its analytic 5 x 5 tangents and the row-resolved
  wrenches (Eq. (width_resultant) summed over laminae and rollers).
* planar: :meth:`TaperedBearingSet.evaluate` follows the evaluator protocol of
  :class:`exudyn_user_elements.contact_element.ContactElement` for bodies with
  (x, y, theta): the ring centres give (delta_x, delta_y), the axial and tilt
  coordinates are held at zero (by the pair itself or locked), the cage
  advances with the ring rotations as in :mod:`warp_contacts.rolling_elements_ref`
  (psi_j = psi_0j + [(1 - gamma) theta_in + (1 + gamma) theta_out] / 2,
  gamma = D_m cos(alpha_m) / d_m); the axial force and tilting moment are
  observations (:meth:`TaperedBearingSet.resultants`).

Row ids: ``"<mounting>/row<k>/roller<j>/slice<s>"`` (k = 0 for a single row).

Example (an RV crank on a tapered pair in the carrier, bodies 0 = crank, 1 = carrier)::

    s = TaperedBearingSet([TaperedMounting(name="crank_bearing0", bearing=crank_pair, inner=0, outer=1,
                                           outer_centre=(0.0, 0.047))], n_bodies=2)
    ev = s.evaluate(pose, vel)            # Evaluation(Q, dQdq, dQdv, obs, (), finite)
    loads = s.resultants(pose)            # per mounting: TaperedLoads
"""
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from warp_contacts import roller_slices_ref as sref
from warp_contacts import tapered_rollers_ref as ref
from warp_contacts.circle_pairs_ref import N_OBS, O_FN, O_GAP, O_NX, O_NY, O_PX, O_PY

from ..contact.assembly import PairAssembler
from ..contact.circle_set import GROUND
from ..contact.evaluator import BACKENDS, Evaluation, all_finite, gap_offset_rows, moved_member, renamed_ids
from ..errors import RvtoolInputError
from .influence import RollerSlices, SliceLaw, bearing_slice_parameters
from .set import Placement
from .tapered import TaperedPair, TaperedRollerBearing
from ..validation import check_body_state

N_Q = ref.N_Q


@dataclass(frozen=True, kw_only=True)
class TaperedMounting(Placement):
    """Where a tapered row or pair sits (fields: :class:`rvtool.bearings.set.Placement`; inner,
    outer: the cone and cup bodies; cage_phase: the azimuth of roller 0)."""
    bearing_types = (TaperedRollerBearing, TaperedPair)
    bearing_noun = "a tapered bearing"
    bearing_kinds = "TaperedRollerBearing, TaperedPair"

    def rows(self):
        """((row, axial station z [m], sense sigma, axial pre-displacement [m]), ...) of the mounting."""
        b = self.bearing
        if isinstance(b, TaperedPair):
            return tuple(zip(b.rows, b.stations, b.senses, b.axial_predisplacements))
        return ((b, 0.0, 1.0, 0.0),)


@dataclass(frozen=True, kw_only=True)
class RelativeEvaluation:
    """Result of :meth:`TaperedBearingSet.relative`, per mounting (M of them).

    wrench (M, 5): (F_x, F_y, F_z [N], M_x, M_y [N m]) on the cone about the mounting centre;
    stiffness, damping (M, 5, 5): d wrench / dq, d wrench / dq_dot;
    cage_sensitivity, cage_rate_sensitivity (M, 5): d wrench / d(cage angle), d / d(cage rate);
    row_wrench (M, 2, 5): the same per row (zeros for the missing row of a single row);
    rib_force (R,) [N] per roller; roller_axial_position (R,) [m]; lamina_force (L,) [N];
    lamina_approach (L,) [m].
    """
    wrench: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    cage_sensitivity: np.ndarray
    cage_rate_sensitivity: np.ndarray
    row_wrench: np.ndarray
    rib_force: np.ndarray
    roller_axial_position: np.ndarray
    lamina_force: np.ndarray
    lamina_approach: np.ndarray


@dataclass(frozen=True, kw_only=True)
class TaperedLoads:
    """Resultant of one mounting's rollers on its cone about the mounting centre (planar state):
    force (2,) [N], axial_force [N], tilting_moment (M_x, M_y) [N m], row_wrenches (n_rows, 5)
    and rib_forces (n_rows,) [N] (summed over the row's rollers). In planar use the axial
    force and moment are observations (the axial and tilt coordinates are held)."""
    force: np.ndarray
    axial_force: float
    tilting_moment: np.ndarray
    row_wrenches: np.ndarray
    rib_forces: np.ndarray


class NoHistory:
    """Rolling elements carry no contact memory."""


class TaperedBearingSet:
    """Any number of mounted tapered rows or pairs between ``n_bodies`` planar bodies, one launch.

    mountings: sequence of :class:`TaperedMounting`. name: element name. backend: "warp" (default)
    or "numpy" (the reference). precision: "float64" or "float32" (warp only). device: Warp device.
    """

    def __init__(self, mountings, n_bodies, *, name="tapered_bearings", backend="warp", precision="float64",
                 device="cpu"):
        if backend not in BACKENDS:
            raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are {list(BACKENDS)}")
        if isinstance(n_bodies, bool) or not isinstance(n_bodies, (int, np.integer)) or n_bodies < 1:
            raise RvtoolInputError(f"n_bodies = {n_bodies!r} is outside the valid range [1, inf)")
        if len(mountings) == 0:
            raise RvtoolInputError("mountings must contain at least one TaperedMounting (got 0)")
        self.name, self.n_bodies, self.backend, self.precision = name, int(n_bodies), backend, precision
        self.mountings = tuple(mountings)
        names = [getattr(m, "name", None) for m in self.mountings]
        if len(set(names)) != len(names):
            raise RvtoolInputError(f"mounting names must be unique; got {names}")
        self.history = NoHistory()
        rf, ri, lf, ids, owner, row_of, psi0, gamma, lam_roller = [], [], [], [], [], [], [], [], []
        slice_rollers, slice_fp, slice_ip = [], [], []
        n_lam = 0
        bodies = []
        for k, m in enumerate(self.mountings):
            if not isinstance(m, TaperedMounting):
                raise RvtoolInputError(f"mountings[{k}] must be a TaperedMounting; got {type(m).__name__}")
            for nm in ("inner", "outer"):
                b = getattr(m, nm)
                if not (b == GROUND or (isinstance(b, (int, np.integer)) and 0 <= b < n_bodies)):
                    raise RvtoolInputError(f"mountings[{k}].{nm} = {b!r} is outside the valid range "
                                           f"[0, {n_bodies - 1}] or GROUND (-1)")
            bodies.append((n_bodies if m.inner == GROUND else m.inner, n_bodies if m.outer == GROUND else m.outer))
            for r, (row, station, sigma, zpre) in enumerate(m.rows()):
                a, b, c = row.pack(station=station, sigma=sigma, axial_predisplacement=zpre)
                b[:, ref.RI_FIRST] += n_lam
                n_lam += len(c)
                rf.append(a)
                ri.append(b)
                lf.append(c)
                Z = row.n_rollers
                if row.slices == SliceLaw.INFLUENCE:
                    sf, si = bearing_slice_parameters(row)
                    slice_rollers += list(len(psi0) + np.arange(Z))
                    slice_fp += [sf] * Z
                    slice_ip += [si] * Z
                owner += [k] * Z
                row_of += [r] * Z
                psi0 += list(m.cage_phase + 2 * math.pi * np.arange(Z) / Z)
                gamma += [row.roller_diameter * math.cos(row.roller_axis_angle) / row.pitch_diameter] * Z
                lam_roller += list(np.repeat(len(psi0) - Z + np.arange(Z), row.n_slices))
                ids += [f"{m.name}/row{r}/roller{j}/slice{s}" for j in range(Z) for s in range(row.n_slices)]
        self._finish(np.vstack(rf), np.vstack(ri), np.vstack(lf), ids, np.array(owner), np.array(row_of),
                     np.array(psi0), np.array(gamma), np.array(lam_roller, dtype=int), np.array(bodies, dtype=np.int32),
                     slice_rollers, slice_fp, slice_ip, backend, precision, device)

    @classmethod
    def concatenated(cls, sets, nb, *, names=None, precision="float64", device="cpu"):
        """The set of B built sets side by side (copy c's bodies offset by c nb, the ground at
        B nb; mounting names ``names[c][k]``, default the built ones): rows, laminae and per-roller
        data concatenated, equal to the set built from the renamed, shifted mountings
        (tests/test_device_rows.py) without packing every row again. Sets with influence-coefficient
        rollers are built from the mountings."""
        s, B = sets[0], len(sets)
        names = names or [[m.name for m in sc.mountings] for sc in sets]
        mounts = [moved_member(m, name=nm, inner=m.inner if m.inner == GROUND else m.inner + c * nb,
                                      outer=m.outer if m.outer == GROUND else m.outer + c * nb)
                  for c, sc in enumerate(sets) for m, nm in zip(sc.mountings, names[c])]
        if any(sc._slices is not None or sc.backend != s.backend for sc in sets):
            return cls(mounts, B * nb, name=s.name, backend=s.backend, precision=precision, device=device)
        self = object.__new__(cls)
        self.name, self.n_bodies, self.backend, self.precision = s.name, int(B * nb), s.backend, precision
        self.mountings = tuple(mounts)
        self.history = NoHistory()
        ri, ids, owner, lam_roller, bodies = [], [], [], [], []
        n_lam = n_rol = n_m = 0
        for c, sc in enumerate(sets):
            i = sc.roller_ip.copy()
            i[:, ref.RI_FIRST] += n_lam
            ri.append(i)
            rename = {m.name: nm for m, nm in zip(sc.mountings, names[c])}
            ids += renamed_ids(sc.ids, rename)
            owner.append(sc.roller_owner + n_m)
            lam_roller.append(sc.lamina_roller + n_rol)
            bodies.append(np.where(sc._bodies >= sc.n_bodies, B * nb, sc._bodies + c * nb))
            n_lam += len(sc.lamina_fp)
            n_rol += len(sc.roller_fp)
            n_m += len(sc.mountings)
        cat = lambda nm: np.concatenate([getattr(sc, nm) for sc in sets])
        # the built laminae (a slow-state gap offset of a built set is not copied, as a set built from the mountings)
        self._finish(np.vstack([sc.roller_fp for sc in sets]), np.vstack(ri),
                     np.vstack([getattr(sc, "_built_lamina_fp", sc.lamina_fp) for sc in sets]),
                     ids, np.concatenate(owner), cat("roller_row"), cat("roller_phase"), cat("roller_gamma"),
                     np.concatenate(lam_roller), np.concatenate(bodies).astype(np.int32), [], [], [], s.backend,
                     precision, device)
        return self

    def _finish(self, roller_fp, roller_ip, lamina_fp, ids, owner, row_of, psi0, gamma, lam_roller, bodies,
                slice_rollers, slice_fp, slice_ip, backend, precision, device):
        n_bodies = self.n_bodies
        self.roller_fp, self.roller_ip, self.lamina_fp = roller_fp, roller_ip, lamina_fp
        self.ids = tuple(ids)
        #: per roller: mounting index, row index (0 or 1), azimuth at zero ring rotation [rad], cage ratio gamma
        self.roller_owner, self.roller_row = owner, row_of
        self.roller_phase, self.roller_gamma = psi0, gamma
        #: per lamina: its roller
        self.lamina_roller = lam_roller
        # per-mounting sums of per-roller values as 0/1 CSR products: each mounting's rollers are
        # added in roller order starting from zero, the order of np.add.at (same sums bit for bit),
        # one pass over all columns of a quantity instead of one unbuffered np.add.at
        R = len(self.roller_owner)
        self._mounting_sum = sp.csr_matrix((np.ones(R), (self.roller_owner, np.arange(R))),
                                           shape=(len(self.mountings), R))
        # the cage angle moves with theta_in by (1 - gamma)/2 and with theta_out by (1 + gamma)/2
        self._cage_weights = (0.5 * (1 - self.roller_gamma))[:, None], (0.5 * (1 + self.roller_gamma))[:, None]
        self._bodies = bodies
        self.assembler = PairAssembler(self._bodies[:, 0], self._bodies[:, 1], n_bodies)
        self._pose = np.zeros((n_bodies + 1, 3))
        self._vel = np.zeros((n_bodies + 1, 3))
        M = len(self.mountings)
        self._centres = np.array([[m.inner_centre, m.outer_centre] for m in self.mountings], float).reshape(M, 2, 2)
        #: influence-coefficient rollers (slices = "influence"): their indices, their lamina rows (-1 padded)
        self.slice_rollers = np.array(slice_rollers, dtype=int)
        self._slices = None
        self._device_rows = None
        if slice_rollers:
            n_max = int(max(self.roller_ip[r, ref.RI_COUNT] for r in slice_rollers))
            self.slice_rows = np.full((len(slice_rollers), n_max), -1)
            for k, r in enumerate(slice_rollers):
                first, count = self.roller_ip[r, ref.RI_FIRST], self.roller_ip[r, ref.RI_COUNT]
                self.slice_rows[k, :count] = first + np.arange(count)
            self._slices = RollerSlices(np.array(slice_fp), np.array(slice_ip), backend=backend, device=device)
        if backend == "warp":
            from warp_contacts.tapered_rollers import TaperedRollerKernel
            self._kernel = TaperedRollerKernel(self.roller_fp, self.roller_ip, self.lamina_fp, precision, device)
        elif precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")

    # -- 5-DOF use ---------------------------------------------------------
    def _rollers(self, q, qdot, psi, psidot):
        """Per-roller kernel results at per-roller states; influence-coefficient rollers replaced by
        their slice solve (:func:`warp_contacts.tapered_rollers_ref.influence_wrench`)."""
        if self.backend == "warp":
            out = self._kernel.evaluate(q, qdot, psi, psidot)
        else:
            out = ref.evaluate(q, qdot, psi, psidot, self.roller_fp, self.roller_ip, self.lamina_fp)
        if self._slices is None:
            return out
        f, K, C, fpsi, fpsid, rib, lam = (np.array(a, float) for a in out)
        ir, rows = self.slice_rollers, self.slice_rows
        s, g, h, qe, bf = ref.influence_approaches(q[ir], psi[ir], self.roller_fp[ir], self.lamina_fp, rows)
        F, J, _, _ = (np.array(a) for a in self._slices.solve(s))
        pad = rows < 0
        L = self.lamina_fp[np.where(pad, 0, rows)]
        damping = (s, qdot[ir], psidot[ir], np.where(pad, 0.0, L[..., ref.LA_DAMP]), np.where(pad, 1.0, L[..., ref.LA_RAMP]))
        f[ir], K[ir], C[ir], fpsi[ir], fpsid[ir], rib[ir], Ft = ref.influence_wrench(
            F, J, g, h, qe, self.roller_fp[ir, ref.RL_KAPPA], bf, damping)
        lam[rows[~pad], ref.LAM_F], lam[rows[~pad], ref.LAM_DELTA] = Ft[~pad], s[~pad]
        return f, K, C, fpsi, fpsid, rib, lam

    def _per_mounting(self, x):
        """Sum per-roller values (R, ...) into per-mounting values (M, ...)."""
        x = np.asarray(x, float)
        return (self._mounting_sum @ x.reshape(len(x), -1)).reshape((len(self.mountings),) + x.shape[1:])

    def relative(self, q, qdot=None, cage_angle=None, cage_rate=None):
        """Evaluate every mounting at relative displacements ``q`` (M, 5) (and rates ``qdot``),
        cage rotation angles ``cage_angle`` (M,) [rad] and rates ``cage_rate`` (M,) [rad/s]
        (roller j of a row sits at cage_phase + 2 pi j / Z + cage angle). Returns a
        :class:`RelativeEvaluation`."""
        M = len(self.mountings)
        q = self._check_array("q", q, (M, N_Q))
        qdot = np.zeros((M, N_Q)) if qdot is None else self._check_array("qdot", qdot, (M, N_Q))
        ca = np.zeros(M) if cage_angle is None else self._check_array("cage_angle", cage_angle, (M,))
        cr = np.zeros(M) if cage_rate is None else self._check_array("cage_rate", cage_rate, (M,))
        o = self.roller_owner
        f, K, C, fpsi, fpsid, rib, lam = (np.array(a, float) for a in self._rollers(
            q[o], qdot[o], self.roller_phase + ca[o], cr[o]))
        row_wrench = np.zeros((M, 2, N_Q))
        np.add.at(row_wrench, (o, self.roller_row), f)
        return RelativeEvaluation(
            wrench=self._per_mounting(f), stiffness=self._per_mounting(K), damping=self._per_mounting(C),
            cage_sensitivity=self._per_mounting(fpsi), cage_rate_sensitivity=self._per_mounting(fpsid),
            row_wrench=row_wrench, rib_force=rib[:, ref.RIB_F], roller_axial_position=rib[:, ref.RIB_A],
            lamina_force=lam[:, ref.LAM_F], lamina_approach=lam[:, ref.LAM_DELTA])

    @staticmethod
    def _check_array(name, value, shape):
        a = np.asarray(value, dtype=float)
        if a.shape != shape:
            raise RvtoolInputError(f"{name} must have shape {shape}; got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise RvtoolInputError(f"{name} contains non-finite values (NaN or inf); valid: finite reals")
        return a

    # -- planar use ----------------------------------------------------------
    def _planar_state(self, pose, vel):
        """Ring-centre arms a, b (M, 2), relative displacement and rate (M, 2), cage angle and rate per roller."""
        self._pose[:-1] = pose
        self._vel[:-1] = 0.0 if vel is None else vel
        pa, pb = self._pose[self._bodies[:, 0]], self._pose[self._bodies[:, 1]]
        va, vb = self._vel[self._bodies[:, 0]], self._vel[self._bodies[:, 1]]
        a = _rot(pa[:, 2], self._centres[:, 0])
        b = _rot(pb[:, 2], self._centres[:, 1])
        r = (pa[:, :2] + a) - (pb[:, :2] + b)
        rdot = (va[:, :2] + va[:, 2:3] * _perp(a)) - (vb[:, :2] + vb[:, 2:3] * _perp(b))
        o, g = self.roller_owner, self.roller_gamma
        psi = self.roller_phase + 0.5 * ((1 - g) * pa[o, 2] + (1 + g) * pb[o, 2])
        psid = 0.5 * ((1 - g) * va[o, 2] + (1 + g) * vb[o, 2])
        return a, b, r, rdot, psi, psid, va, vb

    def raw(self, pose, vel=None):
        """Per-mounting planar results: Q (M, 6), dQ/dq (M, 6, 6), dQ/dv (M, 6, 6) on (x, y, theta) of
        the inner and outer bodies, the per-roller kernel results and the planar state."""
        a, b, r, rdot, psi, psid, va, vb = self._planar_state(pose, vel)
        o = self.roller_owner
        R = len(o)
        q5, qd5 = np.zeros((R, N_Q)), np.zeros((R, N_Q))
        q5[:, :2], qd5[:, :2] = r[o], rdot[o]
        f, K, C, fpsi, fpsid, rib, lam = self._rollers(q5, qd5, psi, psid)
        # the tangents are read at once (the kernel's buffers are reused by the next call); the
        # returned per-roller values are copies
        f, rib, lam = (np.array(x, float) for x in (f, rib, lam))
        M = len(self.mountings)
        wA, wB = self._cage_weights
        # per-mounting sums of whole per-roller rows (contiguous: no column copies; the unused
        # columns cost less to sum than to cut out)
        S = self._mounting_sum
        F = (S @ f)[:, :2]
        K2 = np.ascontiguousarray((S @ K.reshape(R, -1)).reshape(M, N_Q, N_Q)[:, :2, :2])
        C2 = np.ascontiguousarray((S @ C.reshape(R, -1)).reshape(M, N_Q, N_Q)[:, :2, :2])
        FpA, FpB = (S @ (fpsi * wA))[:, :2], (S @ (fpsi * wB))[:, :2]
        FdA, FdB = (S @ (fpsid * wA))[:, :2], (S @ (fpsid * wB))[:, :2]
        I2 = np.broadcast_to(np.eye(2), (M, 2, 2))
        # dr/dq and drdot/dq, drdot/dv over (x_A, y_A, th_A, x_B, y_B, th_B): (M, 2, 6)
        dr = np.concatenate([I2, _perp(a)[:, :, None], -I2, -_perp(b)[:, :, None]], axis=2)
        drd_q = np.zeros((M, 2, 6))
        drd_q[:, :, 2] = -va[:, 2:3] * a
        drd_q[:, :, 5] = vb[:, 2:3] * b
        dF = K2 @ dr + C2 @ drd_q
        dF[:, :, 2] += FpA
        dF[:, :, 5] += FpB
        dFv = C2 @ dr
        dFv[:, :, 2] += FdA
        dFv[:, :, 5] += FdB
        Q = np.zeros((M, 6))
        Q[:, 0:2], Q[:, 2] = F, _cross(a, F)
        Q[:, 3:5], Q[:, 5] = -F, -_cross(b, F)
        dQ, dQv = np.zeros((M, 6, 6)), np.zeros((M, 6, 6))
        for D, dFx in ((dQ, dF), (dQv, dFv)):
            D[:, 0:2] = dFx
            D[:, 2] = _cross(a[:, :, None], dFx)
            D[:, 3:5] = -dFx
            D[:, 5] = -_cross(b[:, :, None], dFx)
        # the arms turn with their bodies: d(a x F)/d theta_A = perp(a) x F
        dQ[:, 2, 2] += _cross(_perp(a), F)
        dQ[:, 5, 5] -= _cross(_perp(b), F)
        return Q, dQ, dQv, (f, rib, lam), (b, psi)

    @property
    def rows_on_device(self):
        """Whether :meth:`device_rows` / :meth:`launch_device_rows` are available (as :attr:`planar_on_device`)."""
        return self.planar_on_device

    @property
    def planar_on_device(self):
        """Whether :meth:`device_rows` is available (Warp backend, no influence-coefficient rows)."""
        return self.backend == "warp" and self._slices is None

    def device_rows(self, pose, vel=None):
        """:meth:`raw`'s Q (M, 6) and dQ/dq (M, 6, 6) as Warp device arrays, the planar mapping and
        the per-mounting sums on the device too (:class:`warp_contacts.tapered_planar.TaperedPlanarRows`;
        no per-roller transfer; overwritten by the next call)."""
        return self._planar_rows().rows(pose, vel)

    def device_pose_buffers(self):
        """(pose, vel): the device arrays ((n_bodies + 1, 3), the ground's row last) that
        :meth:`launch_device_rows` reads (written on the device by the caller)."""
        pr = self._planar_rows()
        return pr.pose, pr.vel

    def launch_device_rows(self):
        """:meth:`device_rows` at the poses in :meth:`device_pose_buffers` as they are."""
        return self._planar_rows().launch()

    def launch_device_velocity_rows(self):
        """:meth:`launch_device_rows` with dQ/dv: (Q (M, 6), dQ/dq, dQ/dv (M, 6, 6)) device arrays at
        the poses and velocities in :meth:`device_pose_buffers` (driven runs; :meth:`raw`'s dQ/dv)."""
        return self._planar_rows().launch_velocity()

    def _planar_rows(self):
        if not self.planar_on_device:
            raise RvtoolInputError(f"tapered set {self.name!r}: the device rows need backend 'warp' and laminae "
                                   "rows (slices = 'laminae')")
        if self._device_rows is None:
            from warp_contacts.tapered_planar import TaperedPlanarRows
            self._device_rows = TaperedPlanarRows(self._kernel, self._bodies, self._centres.reshape(-1, 4),
                                                  self.roller_owner, self.roller_phase, self.roller_gamma,
                                                  self.n_bodies)
        return self._device_rows

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"bearing set '{self.name}'", pose, vel, (self.n_bodies, 3))

    def _observations(self, pose, lam, b, psi):
        """(L, 8) observation columns of :mod:`warp_contacts.circle_pairs_ref` per lamina: normal force,
        gap = -approach, the lamina's point projected on the plane, the radial direction."""
        lr = self.lamina_roller
        u = np.column_stack([np.cos(psi[lr]), np.sin(psi[lr])])
        po = self._pose[self._bodies[:, 1]]
        centre = (po[:, :2] + b)[self.roller_owner[lr]]
        obs = np.zeros((len(lr), N_OBS))
        obs[:, O_FN] = lam[:, ref.LAM_F]
        obs[:, O_GAP] = -lam[:, ref.LAM_DELTA]
        obs[:, O_PX:O_PY + 1] = centre + self.lamina_fp[:, ref.LA_RHO][:, None] * u
        obs[:, O_NX:O_NY + 1] = u
        return obs

    def evaluate(self, pose, vel=None, history=None, check=True):
        """Assembled :class:`Evaluation` at absolute poses/velocities (nb, 3) (no history)."""
        if check:
            self.check_state(pose, vel)
        Q, dQ, dQv, (_, _, lam), (b, psi) = self.raw(pose, vel)
        return Evaluation(self.assembler.vector(Q), self.assembler.matrix(dQ), self.assembler.matrix(dQv),
                          self._observations(pose, lam, b, psi), (), all_finite(Q, dQ, dQv))

    def set_gap_offsets(self, offsets):
        """Gap offsets [m] per lamina row (positive opens the gap: a clearance increment along the
        lamina's normal, e.g. the thermal one of Eq. (obs_thermal_gap)), added to the lamina offset
        o_s (clearance + crowning) of the approach, absolute over the built rows; zeros restore the
        built rows bit for bit."""
        off = gap_offset_rows(offsets, len(self.ids), self.name)
        if not hasattr(self, "_built_lamina_fp"):
            self._built_lamina_fp = self.lamina_fp.copy()
        fp = self._built_lamina_fp.copy()
        fp[:, ref.LA_OFF] += off
        self.lamina_fp = fp
        if self.backend == "warp":
            self._kernel.set_lamina_parameters(fp)

    def commit(self, pose, vel=None, evaluation=None):
        """Observations (L, 8) at the accepted state (nothing to commit)."""
        if evaluation is not None:
            return np.array(evaluation.obs, float)
        return self.evaluate(pose, vel, check=False).obs

    def resultants(self, pose, vel=None):
        """{mounting name: :class:`TaperedLoads`} on the cones at a planar state."""
        _, _, _, (f, rib, _), _ = self.raw(pose, vel)
        M = len(self.mountings)
        rows = np.zeros((M, 2, N_Q))
        np.add.at(rows, (self.roller_owner, self.roller_row), f)
        ribs = np.zeros((M, 2))
        np.add.at(ribs, (self.roller_owner, self.roller_row), rib[:, ref.RIB_F])
        out = {}
        for k, m in enumerate(self.mountings):
            n_rows = len(m.rows())
            w = rows[k].sum(axis=0)
            out[m.name] = TaperedLoads(force=w[:2], axial_force=float(w[2]), tilting_moment=w[3:5],
                                       row_wrenches=rows[k, :n_rows], rib_forces=ribs[k, :n_rows])
        return out

    def energy_law(self):
        """The per-lamina constants of the energy account (:class:`rvtool.observe.energy.ContactEnergyLaw`):
        no friction, the lamina's power law k delta^p (potential k delta^(p+1)/(p+1); with the rigid rib
        the approach is linear in the ring displacement, so this is the exact potential of the
        rollers' wrench). The elastic rib stores energy in the rib contact too, which the lamina
        observations do not carry: refused by name. Influence rows with the fixed half-width:
        1/2 f_s delta_s per slice (:meth:`elastic_energy`); load-dependent half-widths: refused by name."""
        from ..observe.energy import ContactEnergyLaw
        if self._slices is not None and np.any(self._slices.iparams[:, sref.SI_MODE] != sref.HALF_WIDTH_FIXED):
            raise RvtoolInputError(f"the energy account needs half_width = 'fixed' influence rows in {self.name!r}: "
                                   "with a load-dependent half-width the slice law has no potential")
        if np.any(self.roller_ip[:, ref.RI_RIB]):
            elastic = sorted({self.mountings[k].name for k in self.roller_owner[self.roller_ip[:, ref.RI_RIB] != 0]})
            raise RvtoolInputError(f"the energy account needs rib_contact = false tapered rows; {elastic} of "
                                   f"{self.name!r} have an elastic rib, whose contact energy is not observed")
        n = len(self.ids)
        if self._slices is not None:
            return ContactEnergyLaw(tangential_stiffness=np.zeros(n), friction_model=np.zeros(n, np.int32),
                                    normal_potential=self.elastic_energy)
        return ContactEnergyLaw(normal_stiffness=self.lamina_fp[:, ref.LA_K], normal_exponent=self.lamina_fp[:, ref.LA_P],
                                tangential_stiffness=np.zeros(n), friction_model=np.zeros(n, np.int32))

    def elastic_energy(self, obs):
        """(elastic normal force [N], potential [J]) per lamina from observation rows (L, 8): the power law
        k delta^p, k delta^(p+1)/(p+1) of a lamina; an influence slice's force from its roller's solve at the
        observed approaches and 1/2 f_s delta_s (the roller's 1/2 f^T C_l f)."""
        from warp_contacts import laws_ref
        delta = -np.asarray(obs, float)[:, O_GAP]
        F, _ = laws_ref.power_law(self.lamina_fp[:, ref.LA_K], self.lamina_fp[:, ref.LA_P], delta)
        V = np.where(delta > 0, F * np.where(delta > 0, delta, 0.0) / (self.lamina_fp[:, ref.LA_P] + 1.0), 0.0)
        if self._slices is not None:
            rows = self.slice_rows
            pad = rows < 0
            f = np.asarray(self._slices.solve(np.where(pad, 0.0, delta[np.where(pad, 0, rows)]))[0])
            F[rows[~pad]] = f[~pad]
            V[rows[~pad]] = 0.5 * f[~pad] * delta[rows[~pad]]
        return F, V

    def element_loads(self, obs):
        """{mounting name: normal force of each roller [N], laminae summed} (roller order as in the ids)."""
        per_roller = np.zeros(len(self.roller_owner))
        np.add.at(per_roller, self.lamina_roller, np.asarray(obs)[:, O_FN])
        return {m.name: per_roller[self.roller_owner == k] for k, m in enumerate(self.mountings)}


def _perp(v):
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _cross(a, b):
    """z-component of a x b, the 2 components along axis 1 ((M, 2) or stacked columns (M, 2, k))."""
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _rot(theta, xi):
    c, s = np.cos(theta), np.sin(theta)
    return np.column_stack([c * xi[:, 0] - s * xi[:, 1], s * xi[:, 0] + c * xi[:, 1]])
