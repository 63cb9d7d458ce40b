"""A set of rolling-element bearings between planar bodies, evaluated in one
kernel launch; follows the evaluator protocol of
:class:`exudyn_user_elements.contact_element.ContactElement`.

Each :class:`Mounting` puts one bearing between an inner-ring body and an
outer-ring body (``GROUND`` allowed for either). Every ball, and every lamina
of every roller, is one row of the packed parameters
(:mod:`warp_contacts.rolling_elements_ref`). Row ids:

* ball bearings: ``"<mounting>/row<k>/ball<j>"`` (k = 0 for a single row, 0 and 1 for a pair),
* roller bearings (cylindrical, needle, crossed): ``"<mounting>/roller<j>/slice<s>"``.

Example (RD-40, bodies 0 = shaft, 1 = wheel, 3 = flange)::

    s = BearingSet([Mounting(name="eccentric_bearing0", bearing=needle, inner=0, outer=1,
                             inner_centre=(0.0, 8e-4)),
                    Mounting(name="main_bearing", bearing=main, inner=3, outer=GROUND)], n_bodies=4)
    ev = s.evaluate(pose, vel)          # Evaluation(Q, dQdq, dQdv, obs, (), finite)
    loads = s.resultants(pose)          # per mounting: force, axial force, tilting moment
"""
import math
from dataclasses import dataclass

import numpy as np

from warp_contacts import roller_slices_ref as sref
from warp_contacts import rolling_elements_ref as ref

from ..contact.assembly import PairAssembler
from ..contact.circle_set import GROUND
from ..contact.evaluator import (BACKENDS, Evaluation, StagedLaunch, all_finite, gap_offset_rows, moved_member,
                                 renamed_ids)
from ..errors import RvtoolInputError
from ..validation import check_finite, check_body_state
from .influence import RollerSlices, SliceLaw, bearing_slice_parameters, slice_mean_crowning
from .spec import AngularContactPair, BallBearing, CylindricalRollerBearing


@dataclass(frozen=True, kw_only=True)
class Placement:
    """Where a bearing sits; the fields and checks shared by :class:`Mounting` and
    :class:`rvtool.bearings.tapered_set.TaperedMounting`, which name the bearing types they
    take (``bearing_types``, ``bearing_noun``, ``bearing_kinds``).

    name: prefix of its row ids (no "/"). bearing: a bearing specification.
    inner, outer: body indices of the inner- and outer-ring bodies (``GROUND`` = -1).
    inner_centre, outer_centre: ring centres in body coordinates [m] (ground: global).
    cage_phase: psi_0 [rad], the angle of element 0 at zero ring rotations.
    """
    name: str
    bearing: object
    inner: int
    outer: int
    inner_centre: tuple = (0.0, 0.0)
    outer_centre: tuple = (0.0, 0.0)
    cage_phase: float = 0.0

    bearing_types = ()
    bearing_noun = "a bearing specification"
    bearing_kinds = ""

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or "/" in self.name:
            raise RvtoolInputError(f"name = {self.name!r} must be a non-empty string without '/'")
        if not isinstance(self.bearing, self.bearing_types):
            raise RvtoolInputError(f"{self.name}.bearing of type {type(self.bearing).__name__} is not "
                                   f"{self.bearing_noun}; valid: {self.bearing_kinds}")
        for nm in ("inner_centre", "outer_centre"):
            v = np.asarray(getattr(self, nm), dtype=float)
            if v.shape != (2,):
                raise RvtoolInputError(f"{self.name}.{nm} must have 2 components [m]; got shape {v.shape}")
            check_finite(f"{self.name}.{nm}", v)
        check_finite(f"{self.name}.cage_phase", self.cage_phase)
        if self.inner == self.outer:
            raise RvtoolInputError(f"{self.name}: inner and outer must be different bodies; both are {self.inner}")


@dataclass(frozen=True, kw_only=True)
class Mounting(Placement):
    """Where a radial, needle, crossed-roller or ball bearing sits (fields: :class:`Placement`)."""
    bearing_types = (CylindricalRollerBearing, BallBearing, AngularContactPair)
    bearing_kinds = "CylindricalRollerBearing, NeedleBearing, CrossedRollerBearing, BallBearing, AngularContactPair"


@dataclass(frozen=True, kw_only=True)
class BearingLoads:
    """Resultant of one mounting's elements on its inner ring, about the inner-ring centre
    at the mounting's axial centre: force (2,) [N], axial_force [N], tilting_moment
    (M_x, M_y) [N m], row_axial_forces (one per ball row) [N]. The axial force and moment
    are observations (the planar model holds the axial and tilt coordinates)."""
    force: np.ndarray
    axial_force: float
    tilting_moment: np.ndarray
    row_axial_forces: tuple


class NoHistory:
    """Rolling elements carry no contact memory."""


def _base_row(m, psi0, gamma, pitch, alpha, sigma):
    r = np.zeros(ref.N_FLOAT)
    r[ref.R_XI_A:ref.R_XI_A + 2] = m.inner_centre
    r[ref.R_XI_B:ref.R_XI_B + 2] = m.outer_centre
    r[ref.R_PSI0], r[ref.R_GAMMA], r[ref.R_PITCH] = psi0, gamma, pitch
    r[ref.R_ALPHA], r[ref.R_SIGMA] = alpha, sigma
    return r


def pack_mounting(m):
    """Rows of one mounting: (float rows, kinds, ids, element radius rho [m], axial station z [m], row index)."""
    b = m.bearing
    rows, kinds, ids, rho, z, row_of = [], [], [], [], [], []
    if isinstance(b, CylindricalRollerBearing):
        alpha = b.contact_angle
        gamma = b.roller_diameter * math.cos(alpha) / b.pitch_diameter
        k, crown, zeta = b.slice_stiffness, b.slice_crowning, b.slice_positions
        crossed = alpha > 0
        kind = ref.KIND_LAMINA
        if b.slices == SliceLaw.INFLUENCE:
            kind, crown = ref.KIND_SLICE, slice_mean_crowning(b)
        for j in range(b.n_rollers):
            sigma = -1.0 if (crossed and j % 2) else 1.0
            for s in range(b.n_slices):
                r = _base_row(m, m.cage_phase + 2 * math.pi * j / b.n_rollers, gamma, b.pitch_diameter, alpha, sigma)
                r[ref.R_K], r[ref.R_P], r[ref.R_CLEAR], r[ref.R_CROWN] = k[s], b.exponent, b.radial_clearance, crown[s]
                r[ref.R_DAMP], r[ref.R_RAMP] = b.damping / b.n_slices, b.ramp_depth
                rows.append(r)
                kinds.append(kind)
                ids.append(f"{m.name}/roller{j}/slice{s}")
                # lamina centre: along the generator (-sigma sin(alpha), cos(alpha)) from the roller centre
                rho.append(0.5 * b.pitch_diameter - sigma * zeta[s] * math.sin(alpha))
                z.append(zeta[s] * math.cos(alpha))
                row_of.append(0)
        return rows, kinds, ids, rho, z, row_of
    stations = b.stations() if isinstance(b, AngularContactPair) else ((0.0, 1.0),)
    ball_rows = b.rows if isinstance(b, AngularContactPair) else (b,)
    offsets = b.axial_offsets if isinstance(b, AngularContactPair) else (b.axial_preload_offset,)
    for k, (row, (zr, sigma)) in enumerate(zip(ball_rows, stations)):
        gamma = row.ball_diameter * math.cos(row.contact_angle) / row.pitch_diameter
        for j in range(row.n_balls):
            r = _base_row(m, m.cage_phase + 2 * math.pi * j / row.n_balls, gamma, row.pitch_diameter,
                          row.contact_angle, sigma)
            r[ref.R_A], r[ref.R_SAX], r[ref.R_CLEAR] = (row.groove_centre_distance, offsets[k],
                                                        row.radial_clearance)
            r[ref.R_DAMP], r[ref.R_RAMP] = row.damping, row.ramp_depth
            r[ref.R_DBALL], r[ref.R_FI], r[ref.R_FO], r[ref.R_EMOD] = (row.ball_diameter, row.inner_curvature,
                                                                      row.outer_curvature, row.effective_modulus)
            r[ref.R_KSCALE] = row.stiffness_scale
            rows.append(r)
            kinds.append(ref.KIND_BALL)
            ids.append(f"{m.name}/row{k}/ball{j}")
            rho.append(0.5 * row.pitch_diameter)
            z.append(zr)
            row_of.append(k)
    return rows, kinds, ids, rho, z, row_of


class BearingSet(StagedLaunch):
    """Any number of mounted bearings between ``n_bodies`` planar bodies, one kernel launch.

    mountings: sequence of :class:`Mounting`. name: element name. backend: "warp"
    (default) or "numpy" (the reference). precision: "float64" or "float32" (warp
    only). device: Warp device ("cpu", "cuda:N", "auto").
    With backend "warp" the set's rows can be summed on the device by the merged contact
    element (:class:`~rvtool.contact.evaluator.StagedLaunch`: staged inputs, the recorded
    launch, fields assembled when read); the kernel always writes the velocity tangent rows.
    """

    velocity_rows = True

    def __new__(cls, *args, **kwargs):
        # a set with influence-coefficient rollers is host-assembled (InfluenceBearingSet)
        mountings = args[0] if args else kwargs.get("mountings", ())
        if cls is BearingSet and any(isinstance(getattr(m, "bearing", None), CylindricalRollerBearing)
                                     and m.bearing.slices == SliceLaw.INFLUENCE for m in mountings):
            cls = InfluenceBearingSet
        return super().__new__(cls)

    def __init__(self, mountings, n_bodies, *, name="bearings", backend="warp", precision="float64", device="cpu"):
        if backend not in BACKENDS:
            raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are {list(BACKENDS)}")
        if isinstance(n_bodies, bool) or not isinstance(n_bodies, (int, np.integer)) or n_bodies < 1:
            raise RvtoolInputError(f"n_bodies = {n_bodies!r} is outside the valid range [1, inf)")
        if len(mountings) == 0:
            raise RvtoolInputError("mountings must contain at least one Mounting (got 0)")
        self.name, self.n_bodies, self.backend, self.precision = name, int(n_bodies), backend, precision
        self.mountings = tuple(mountings)
        names = [m.name for m in self.mountings]
        if len(set(names)) != len(names):
            raise RvtoolInputError(f"mounting names must be unique; got {names}")
        self.history = NoHistory()
        fp, ip, ids, owner, rho, z, row_of = [], [], [], [], [], [], []
        g = n_bodies
        for k, m in enumerate(self.mountings):
            if not isinstance(m, Mounting):
                raise RvtoolInputError(f"mountings[{k}] must be a Mounting; got {type(m).__name__}")
            for nm in ("inner", "outer"):
                b = getattr(m, nm)
                if not (b == GROUND or (isinstance(b, (int, np.integer)) and 0 <= b < n_bodies)):
                    raise RvtoolInputError(f"mountings[{k}].{nm} = {b!r} is outside the valid range "
                                           f"[0, {n_bodies - 1}] or GROUND (-1)")
            rows, kinds, rid, r_rho, r_z, r_row = pack_mounting(m)
            fp += rows
            irows = np.zeros((len(kinds), ref.N_INT), np.int32)
            irows[:, ref.K_BODY_A] = g if m.inner == GROUND else m.inner
            irows[:, ref.K_BODY_B] = g if m.outer == GROUND else m.outer
            irows[:, ref.K_KIND] = kinds
            ip += list(irows)
            ids += rid
            owner += [k] * len(rows)
            rho += r_rho
            z += r_z
            row_of += r_row
        self._finish(np.array(fp), np.array(ip, dtype=np.int32), ids, np.array(owner), np.array(rho), np.array(z),
                     np.array(row_of), backend, precision, device)

    @classmethod
    def concatenated(cls, sets, nb, *, names=None, precision="float64", device="cpu"):
        """The set of B built sets side by side (copy c's bodies offset by c nb, the ground row at
        B nb; mounting names ``names[c][k]``, default the built ones): their rows concatenated,
        equal to the set built from the renamed, shifted mountings (tests/test_device_rows.py),
        without packing every mounting again. Sets with influence-coefficient rollers are built."""
        s, B = sets[0], len(sets)
        names = names or [[m.name for m in sc.mountings] for sc in sets]
        mounts = [moved_member(m, name=nm, inner=m.inner if m.inner == GROUND else m.inner + c * nb,
                                      outer=m.outer if m.outer == GROUND else m.outer + c * nb)
                  for c, sc in enumerate(sets) for m, nm in zip(sc.mountings, names[c])]
        if any(sc._slices is not None for sc in sets) or any(type(sc) is not type(s) for sc in sets):
            return cls(mounts, B * nb, name=s.name, backend=s.backend, precision=precision, device=device)
        self = object.__new__(cls)
        self.name, self.n_bodies, self.backend, self.precision = s.name, int(B * nb), s.backend, precision
        self.mountings = tuple(mounts)
        self.history = NoHistory()
        ip = []
        for c, sc in enumerate(sets):
            i = sc.iparams.copy()
            for col in (ref.K_BODY_A, ref.K_BODY_B):
                i[:, col] = np.where(i[:, col] >= sc.n_bodies, B * nb, i[:, col] + c * nb)
            ip.append(i)
        ids = []
        for c, sc in enumerate(sets):
            rename = {m.name: nm for m, nm in zip(sc.mountings, names[c])}
            ids += renamed_ids(sc.ids, rename)
        n_m = np.cumsum([0] + [len(sc.mountings) for sc in sets])
        # the built rows (a slow-state gap offset of a built set is not copied, as a set built from the mountings)
        self._finish(np.concatenate([getattr(sc, "_built_fparams", sc.fparams) for sc in sets]), np.concatenate(ip),
                     ids,
                     np.concatenate([sc.owner + n_m[c] for c, sc in enumerate(sets)]),
                     np.concatenate([sc.element_radius for sc in sets]),
                     np.concatenate([sc.element_station for sc in sets]),
                     np.concatenate([sc.element_row for sc in sets]), s.backend, precision, device)
        return self

    def _finish(self, fparams, iparams, ids, owner, rho, z, row_of, backend, precision, device):
        n_bodies = self.n_bodies
        self.fparams = fparams
        self.iparams = iparams
        self.ids = tuple(ids)
        self.owner = owner
        #: per element: radius [m] and axial station [m] of its centre, ball-row index
        self.element_radius, self.element_station, self.element_row = rho, z, row_of
        self.assembler = PairAssembler(self.iparams[:, ref.K_BODY_A], self.iparams[:, ref.K_BODY_B], n_bodies)
        self._init_slices(backend, device)
        self._pose = np.zeros((n_bodies + 1, 3))
        self._vel = np.zeros((n_bodies + 1, 3))
        self.launches = 0
        self._staged = None
        if backend == "warp":
            from warp_contacts.rolling_elements import RollingElementKernel
            self._kernel = RollingElementKernel(self.fparams, self.iparams, n_bodies, precision, device)
        elif precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")

    def _init_slices(self, backend, device):
        """The influence-coefficient rollers (slices = "influence"): their slice rows (R, n_max), -1
        padded, and the batched slice solve (:class:`rvtool.bearings.influence.RollerSlices`)."""
        self._slices = None
        rows = np.flatnonzero(self.iparams[:, ref.K_KIND] == ref.KIND_SLICE)
        if rows.size == 0:
            return
        fp, ip, groups = [], [], []
        start = 0
        for m in self.mountings:
            n = len(pack_mounting(m)[0])
            b = m.bearing
            if isinstance(b, CylindricalRollerBearing) and b.slices == SliceLaw.INFLUENCE:
                f, i = bearing_slice_parameters(b)
                for j in range(b.n_rollers):
                    fp.append(f)
                    ip.append(i)
                    groups.append(start + j * b.n_slices + np.arange(b.n_slices))
            start += n
        n_max = max(len(g) for g in groups)
        self.slice_rows = np.full((len(groups), n_max), -1)
        for k, g in enumerate(groups):
            self.slice_rows[k, :len(g)] = g
        self._slices = RollerSlices(np.array(fp), np.array(ip), backend=backend, device=device)

    def _evaluate_rows(self):
        if self.backend == "warp":
            return self._kernel.evaluate(self._pose, self._vel)
        return ref.evaluate(self._pose, self._vel, self.fparams, self.iparams)

    def raw(self, pose, vel=None):
        """Per-element results (Q (N,6), dQdq, dQdv, obs (N,8), aux (N,3)) at poses and
        velocities (nb, 3); ``vel=None`` means at rest. With influence-coefficient rollers, a first
        launch gives the slices' approaches, the rollers' slice solve their forces and dF/d delta,
        and a second launch assembles."""
        self.launches += 1      # the kernel's buffers change: launched evaluations read afresh
        self._pose[:-1] = pose
        self._vel[:-1] = 0.0 if vel is None else vel
        if self._slices is not None:
            delta = -np.asarray(self._evaluate_rows()[3], float)[:, ref.O_GAP]
            pad = self.slice_rows < 0
            s = np.where(pad, 0.0, delta[self.slice_rows])
            f, J, _, _ = self._slices.solve(s)
            sel = self.slice_rows[~pad]
            fp = self.fparams
            fp[sel, ref.R_SLICE_F] = np.asarray(f)[~pad]
            # every slice of a roller moves by the same cos(alpha) dr: dF_i/d delta = sum_k J_ik
            fp[sel, ref.R_SLICE_DF] = np.asarray(J).sum(axis=2)[~pad]
            if self.backend == "warp":
                self._kernel.set_parameters(fp)
        return self._evaluate_rows()

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"bearing set '{self.name}'", pose, vel, (self.n_bodies, 3))

    def evaluate(self, pose, vel=None, history=None, check=True):
        """Assembled :class:`Evaluation` at absolute poses/velocities (nb, 3) (no history)."""
        if check:
            self.check_state(pose, vel)
        Qc, dq, dv, obs, _ = self.raw(pose, vel)
        finite = all_finite(Qc, dq, dv)
        return Evaluation(self.assembler.vector(np.asarray(Qc, float)), self.assembler.matrix(np.asarray(dq, float)),
                          self.assembler.matrix(np.asarray(dv, float)), np.array(obs, float), (), finite)

    def launched_field(self, name):
        """Field ``name`` of :class:`Evaluation` from the outputs of the last launch (as :meth:`evaluate`
        assembles them; no history)."""
        r = self._staged.read
        if name == "Q":
            return self.assembler.vector(np.asarray(r("q"), float))
        if name in ("dQdq", "dQdv"):
            return self.assembler.matrix(np.asarray(r("dqdq" if name == "dQdq" else "dqdv"), float))
        if name == "obs":
            return np.array(r("obs"), float)
        if name == "trial_history":
            return ()
        return all_finite(r("q"), r("dqdq"), r("dqdv"))

    def set_gap_offsets(self, offsets):
        """Clearance offsets [m] per element row (positive opens the gap: a clearance increment, e.g.
        the thermal one of Eq. (obs_thermal_gap) or wear of a race zone), added to the clearance c of
        the element law (roller laminae: the radial clearance; balls: along the line of action,
        the radial clearance of a radial bearing), absolute over the built rows; zeros restore the
        built rows bit for bit."""
        off = gap_offset_rows(offsets, len(self.ids), self.name)
        if not hasattr(self, "_built_fparams"):
            self._built_fparams = self.fparams.copy()
        fp = self._built_fparams.copy()
        fp[:, ref.R_CLEAR] += off
        self.fparams = fp
        if self.backend == "warp":
            self._kernel.set_parameters(fp)

    def energy_law(self):
        """The per-element constants of the energy account (:class:`rvtool.observe.energy.ContactEnergyLaw`):
        no friction (rolling without a declared loss), the elastic force and potential of each row
        (:func:`warp_contacts.rolling_elements_ref.elastic_state`: k delta^(p+1)/(p+1) per lamina,
        the ball's by quadrature), read from the current parameter rows (gap offsets included).
        Influence slices with the fixed half-width: 1/2 f_i delta_i per slice (the roller's
        1/2 f^T C_l f, since f_i w_i = 0); the load-dependent half-widths are refused by name (C_l
        then depends on f and the slice law has no potential)."""
        from ..observe.energy import ContactEnergyLaw
        if self._slices is not None and np.any(self._slices.iparams[:, sref.SI_MODE] != sref.HALF_WIDTH_FIXED):
            raise RvtoolInputError(f"the energy account needs half_width = 'fixed' influence slices in bearing set "
                                   f"{self.name!r}: with a load-dependent half-width the slice law has no potential")
        n = len(self.ids)
        return ContactEnergyLaw(tangential_stiffness=np.zeros(n), friction_model=np.zeros(n, np.int32),
                                normal_potential=self.elastic_energy)

    def elastic_energy(self, obs):
        """(elastic normal force [N], potential [J]) per element from observation rows (N, 8)."""
        obs = np.asarray(obs, float)
        delta = -obs[:, ref.O_GAP]
        F, V = ref.elastic_state(self.iparams[:, ref.K_KIND], delta, self.fparams)
        slices = self.iparams[:, ref.K_KIND] == ref.KIND_SLICE
        if np.any(slices):
            # the elastic slice forces: the rollers' solve at the observed approaches (the observed force
            # holds the viscous term too); 1/2 f_i delta_i (f_i = 0 off contact)
            pad = self.slice_rows < 0
            f = np.asarray(self._slices.solve(np.where(pad, 0.0, delta[self.slice_rows]))[0])
            fel = np.zeros(len(delta))
            fel[self.slice_rows[~pad]] = f[~pad]
            F = np.where(slices, fel, F)
            V = np.where(slices, 0.5 * fel * delta, V)
        return F, V

    def commit(self, pose, vel=None, evaluation=None):
        """Observations (N, 8) at the accepted state (nothing to commit)."""
        return np.array(evaluation.obs if evaluation is not None else self.raw(pose, vel)[3], float)

    def resultants(self, pose, vel=None):
        """{mounting name: :class:`BearingLoads`} on the inner rings at the given state.

        Element force on the inner ring f = f_u u + f_z e_z acts at its centre
        rho u + z e_z, so the moment about the mounting centre is
        M = (rho f_z - z f_u) (u x e_z), summed as Eq. (width_resultant).
        """
        _, _, _, obs, aux = self.raw(pose, vel)
        obs, aux = np.asarray(obs, float), np.asarray(aux, float)
        u = obs[:, ref.O_NX:ref.O_NY + 1]
        fu, fz = aux[:, ref.AUX_FU], aux[:, ref.AUX_FZ]
        arm = self.element_radius * fz - self.element_station * fu
        out = {}
        for k, m in enumerate(self.mountings):
            sel = self.owner == k
            rows = self.element_row[sel]
            n_rows = 2 if isinstance(m.bearing, AngularContactPair) else 1
            out[m.name] = BearingLoads(
                force=np.sum(fu[sel, None] * u[sel], axis=0), axial_force=float(np.sum(fz[sel])),
                tilting_moment=np.sum(arm[sel, None] * np.column_stack([u[sel, 1], -u[sel, 0]]), axis=0),
                row_axial_forces=tuple(float(np.sum(fz[sel][rows == r])) for r in range(n_rows))
                if not isinstance(m.bearing, CylindricalRollerBearing) else ())
        return out

    def element_loads(self, obs):
        """{mounting name: normal force of each rolling element [N]} from observations (N, 8):
        balls as they are, rollers summed over their laminae (element order as in the ids)."""
        fn = np.asarray(obs)[:, ref.O_FN]
        out = {}
        for k, m in enumerate(self.mountings):
            f = fn[self.owner == k]
            b = m.bearing
            out[m.name] = f.reshape(b.n_rollers, b.n_slices).sum(axis=1) if isinstance(b, CylindricalRollerBearing) else f
        return out


class InfluenceBearingSet(BearingSet):
    """A :class:`BearingSet` with influence-coefficient rollers (``slices = "influence"``), made by
    ``BearingSet(...)`` itself. Host-assembled: the rollers' slice solve sits between two launches
    (:meth:`BearingSet.raw`), so the merged element cannot sum its rows on the device from staged
    poses (it finds no staging methods and evaluates the set on the host)."""
    stage = launch_staged = launched = launched_field = row_buffers = None
