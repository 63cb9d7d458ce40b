"""Involute gear-mesh contact sets: specification (data) and evaluator.

One :class:`GearMesh` describes the engagement of an external gear A (body ``body_a``) with
an external or internal gear B (body ``body_b``): the pair geometry
(:class:`~rvtool.geometry.involute.InvolutePair`, modifications and pitch deviations
included), the face-width slices with their axial stations, the declared relative tilt and
skew of Eq. (skew), a clearance, damping and friction. The bodies' poses place the gears:
a gear's body frame is its own frame (centre at the body origin, tooth 0 on the body's
x axis), so the same set serves fixed centres, floating centres (bearing-supported) and an
eccentric wheel in a ring gear of a small-tooth-difference stage. The normal law is the
series relation of Eq. (series_contact) with the potential-energy tooth compliance of
:mod:`rvtool.contact.tooth_stiffness`.

:class:`InvoluteContactSet` evaluates any number of meshes in one kernel launch and follows
the evaluator protocol of :class:`exudyn_user_elements.contact_element.ContactElement`.
"""
import dataclasses
from dataclasses import dataclass, field
import functools
import math

import numpy as np

from warp_contacts import anchor_ref
from warp_contacts import involute_pairs_ref as ref

from ..errors import RvtoolInputError
from ..geometry.involute import InvolutePair
from ..validation import check_finite, check_nonnegative, check_positive
from .circle_set import GROUND, FrictionLaw, FrictionModel
from .evaluator import moved_member, renamed_ids
from .pair_set import PairFamilySet, check_backend
from .tooth_stiffness import POLY_DEGREE, ToothCompliance

assert POLY_DEGREE + 1 == ref.POLY_TERMS


@dataclass(frozen=True, kw_only=True)
class GearMesh:
    """Engagement of gear A (body ``body_a``) with gear B (body ``body_b``, default ground).

    pair: :class:`InvolutePair` (its centre distance is the nominal one; the contact uses the
    actual body positions). n_slices: equal face-width slices (face width of gear A).
    window: teeth of A evaluated on either side of the one nearest the pitch point (default
    ceil(epsilon_alpha / 2) + 1). lines: lines of action evaluated (0, 1 or both: both flanks).
    clearance: uniform added gap [m]. tilt_x, tilt_y: relative tilt of A and B [rad];
    skew: psi [rad] (Eq. (skew)); gear_z: axial station of the mesh midplane [m].
    damping: c [N s/m] of the whole mesh (divided among the slices); ramp_depth: delta_r [m].
    friction: NONE, REGULARIZED (element-wise coefficient) or ANCHOR (stick--slip anchors per row,
    Eq. (friction) anchor model, k_t of the whole mesh divided among the slices; mu = 0: the
    frictionless code). anchor_release_distance: d_rel [m] of :mod:`warp_contacts.anchor_ref`;
    None: 10 % of gear A's base pitch (a row's next tooth pair starts a base pitch away).
    phase_a, phase_b: angle [rad] of tooth 0 of gear A (B) from its body's x axis: a rigid turn
    of the tooth pattern against the body frame (e.g. a wheel's teeth against its output holes).
    Default 0; a turn by whole pitches renumbers the teeth (tooth k carries the pitch deviation
    of tooth k - n), so only the remainder within +-half a pitch enters the tooth-angle table.
    """
    pair: InvolutePair
    body_a: int
    body_b: int = GROUND
    n_slices: int = 1
    window: int | None = None
    lines: tuple = (0, 1)
    clearance: float = 0.0
    tilt_x: float = 0.0
    tilt_y: float = 0.0
    skew: float = 0.0
    gear_z: float = 0.0
    damping: float = 0.0
    ramp_depth: float = 1e-6
    friction: FrictionLaw = field(default_factory=FrictionLaw)
    phase_a: float = 0.0
    phase_b: float = 0.0
    name: str = "mesh"
    anchor_release_distance: float | None = None

    def __post_init__(self):
        if isinstance(self.n_slices, bool) or not isinstance(self.n_slices, (int, np.integer)) or self.n_slices < 1:
            raise RvtoolInputError(f"{self.name}.n_slices = {self.n_slices!r} is outside the valid range [1, inf) (integer)")
        if self.window is not None and (not isinstance(self.window, (int, np.integer)) or self.window < 0):
            raise RvtoolInputError(f"{self.name}.window = {self.window!r} is outside the valid range [0, inf) (integer)")
        if not self.lines or any(ln not in (0, 1) for ln in self.lines) or len(set(self.lines)) != len(self.lines):
            raise RvtoolInputError(f"{self.name}.lines = {self.lines!r} is not valid; valid: a non-empty subset of (0, 1)")
        for nm in ("clearance", "tilt_x", "tilt_y", "skew", "gear_z", "phase_a", "phase_b"):
            check_finite(f"{self.name}.{nm}", getattr(self, nm))
        check_nonnegative(f"{self.name}.damping", self.damping)
        check_positive(f"{self.name}.ramp_depth", self.ramp_depth)
        if self.anchor_release_distance is not None:
            check_positive(f"{self.name}.anchor_release_distance", self.anchor_release_distance)

    @property
    def anchors(self):
        """True where the mesh carries anchors (ANCHOR law with mu > 0)."""
        return self.friction.model == FrictionModel.ANCHOR and self.friction.mu_kinetic > 0.0

    @property
    def face_width(self):
        return self.pair.gear_a.face_width

    @property
    def slice_z(self):
        """Axial stations of the slice midpoints relative to the mesh midplane [m]."""
        b, n = self.face_width, self.n_slices
        return (np.arange(n) + 0.5) * b / n - 0.5 * b

    def tooth_angle_table(self):
        """(gear A, gear B) tooth-angle deviations [rad] per tooth: pitch deviations plus the
        mounting phase, whole pitches of the phase taken out by renumbering the teeth."""
        out = []
        for gear, phase in ((self.pair.gear_a, self.phase_a), (self.pair.gear_b, self.phase_b)):
            pitch = 2 * np.pi / gear.n_teeth
            n = int(np.floor(phase / pitch + 0.5))
            out.append(np.roll(gear.pitch_deviation_angles(), n) + (phase - n * pitch))
        return tuple(out)

    @property
    def window_teeth(self):
        return int(math.ceil(0.5 * self.pair.transverse_contact_ratio)) + 1 if self.window is None else int(self.window)


def gear_block(gear, compliance: ToothCompliance, u_ref):
    """The N_GEAR float parameters of one gear (columns G_* of the reference)."""
    blk = np.zeros(ref.N_GEAR)
    blk[ref.G_RB] = gear.base_radius
    blk[ref.G_PSI] = gear.base_half_angle
    blk[ref.G_EPS] = gear.eps
    blk[ref.G_ULO], blk[ref.G_UHI] = gear.involute_range
    blk[ref.G_UREF] = u_ref
    ue, rho_c, chi = gear.edge
    blk[ref.G_RHO_C], blk[ref.G_CHI], blk[ref.G_RHO_E], blk[ref.G_UEDGE] = rho_c, chi, gear.edge_radius, ue
    blk[ref.G_UTIP:ref.G_B + 1] = gear.modification_parameters()
    blk[ref.G_PMID], blk[ref.G_PHALF] = compliance.u_mid, compliance.u_half
    blk[ref.G_E], blk[ref.G_NU] = gear.youngs_modulus, gear.poisson_ratio
    blk[ref.G_PC:ref.G_PC + ref.POLY_TERMS] = compliance.compliance_coefficients
    blk[ref.G_PH:ref.G_PH + ref.POLY_TERMS] = compliance.depth_coefficients
    return blk


@functools.lru_cache(maxsize=256)
def _compliance_of(gear):
    return ToothCompliance.of(gear)


def tooth_compliance(gear):
    """:meth:`ToothCompliance.of` computed once per tooth geometry in a process (~8 ms per gear): the
    key is the frozen gear without its single pitch deviations, which turn teeth rigidly
    (:meth:`InvoluteGear.pitch_deviation_angles`) and do not enter the tooth compliance, so Monte
    Carlo variants that draw them share one fit; an unhashable gear is fitted each time."""
    key = gear if gear.single_pitch_deviations is None else dataclasses.replace(gear, single_pitch_deviations=None)
    try:
        hash(key)
    except TypeError:
        return ToothCompliance.of(gear)
    return _compliance_of(key)


def pair_secant_stiffness(pair: InvolutePair, force, compliance=None):
    """Normal secant stiffness F / delta(F) [N/m] of one tooth pair of ``pair`` over its face width
    at the middle of the path of contact, Eq. (series_contact) with delta(F) = C F + delta_H(F)
    explicit in F (tooth compliances of :mod:`rvtool.contact.tooth_stiffness`, Weber's approach).
    force: F [N] > 0; compliance: optional {gear: ToothCompliance} already computed."""
    check_positive("force", force)
    A, B = pair.gear_a, pair.gear_b
    compliance = compliance or {}
    ua = 0.5 * sum(pair.path_of_contact()) / A.base_radius
    ub = float(pair.roll_b(ua))
    b = A.face_width
    blocks = [gear_block(g, compliance.get(g) or ToothCompliance.of(g), u)[None] for g, u in ((A, ua), (B, ub))]
    u = (np.array([ua]), np.array([ub]))
    c = sum(ref.poly(blk, ref.G_PC, ui)[0] for blk, ui in zip(blocks, u)) / b
    hA, hB = (ref.poly(blk, ref.G_PH, ui)[0] for blk, ui in zip(blocks, u))
    K = 1.0 / (A.base_radius * ua) + B.eps / (B.base_radius * ub)
    F = np.array([float(force)])
    dH = ref.weber_approach(F, hA, hB, K, A.youngs_modulus, A.poisson_ratio, B.youngs_modulus, B.poisson_ratio, b)[0]
    return float(F[0] / (c[0] * F[0] + dH[0]))


class InvoluteContactSet(PairFamilySet):
    """Evaluator of involute gear meshes between ``n_bodies`` planar bodies.

    backend "warp" (default, one launch) or "numpy" (the reference); precision "float64"
    (default) or "float32"; device "cpu", "cuda" or "auto".
    Per-row observations: columns O_* of :mod:`warp_contacts.involute_pairs_ref` (normal and
    friction force, sliding and rolling speed, gap, contact point and normal, roll angles,
    contact mode, teeth and the series-law tangent k_t).
    """

    def __init__(self, meshes, n_bodies, *, backend="warp", precision="float64", device="cpu", name="gears",
                 compliance=None):
        if len(meshes) == 0:
            raise RvtoolInputError("meshes must contain at least one GearMesh")
        check_backend(backend, precision)
        self.name = name
        self.meshes = tuple(meshes)
        self.backend = backend
        self.precision = precision
        # tooth compliances computed before ({gear: ToothCompliance}, e.g. the ``compliance`` of
        # built sets that are copied): reused, the other gears' computed
        self.compliance = {} if compliance is None else dict(compliance)
        fp, ip, ids, mesh_of, dev, ap = [], [], [], [], [], []
        offset = 0
        for m_i, m in enumerate(self.meshes):
            for nm, b in (("body_a", m.body_a), ("body_b", m.body_b)):
                if not (b == GROUND or 0 <= b < n_bodies):
                    raise RvtoolInputError(f"meshes[{m_i}].{nm} = {b} is outside the valid range [0, {n_bodies - 1}] or GROUND")
            pr = m.pair
            A, B = pr.gear_a, pr.gear_b
            for g in (A, B):
                if g not in self.compliance:
                    self.compliance[g] = tooth_compliance(g)
            u_ref_a = 0.5 * sum(pr.path_of_contact()) / A.base_radius
            ga = gear_block(A, self.compliance[A], u_ref_a)
            gb = gear_block(B, self.compliance[B], float(pr.roll_b(u_ref_a)))
            off_a, off_b = offset, offset + A.n_teeth
            dev.extend(m.tooth_angle_table())
            offset += A.n_teeth + B.n_teeth
            bs = m.face_width / m.n_slices
            f = m.friction
            W = m.window_teeth
            for line in m.lines:
                for w in range(-W, W + 1):
                    for s_i, z in enumerate(m.slice_z):
                        row = np.zeros(ref.N_FLOAT)
                        row[ref.GEAR_A:ref.GEAR_A + ref.N_GEAR] = ga
                        row[ref.GEAR_B:ref.GEAR_B + ref.N_GEAR] = gb
                        row[ref.C_Z], row[ref.C_BS], row[ref.C_E] = z, bs, m.clearance
                        row[ref.C_TX], row[ref.C_TY], row[ref.C_TANPSI] = m.tilt_x, m.tilt_y, math.tan(m.skew)
                        row[ref.C_C], row[ref.C_DR] = m.damping / m.n_slices, m.ramp_depth
                        row[ref.C_MUK], row[ref.C_MUS], row[ref.C_VS], row[ref.C_VREG] = (
                            f.mu_kinetic, f.mu_s, f.stribeck_speed, f.regularization_speed)
                        fp.append(row)
                        g = n_bodies
                        # mu = 0 under the anchor law is the frictionless mesh (its code path, its figures)
                        model = f.model if (f.model != FrictionModel.ANCHOR or m.anchors) else FrictionModel.NONE
                        ip.append((g if m.body_a == GROUND else m.body_a, g if m.body_b == GROUND else m.body_b,
                                   int(model), line, w, off_a, A.n_teeth, off_b, B.n_teeth))
                        arow = np.zeros(anchor_ref.N_ANCHOR)
                        if m.anchors:
                            arow[anchor_ref.ANCHOR_KT] = f.tangential_stiffness / m.n_slices
                            arow[anchor_ref.ANCHOR_MU] = f.mu_kinetic
                            arow[anchor_ref.ANCHOR_RELEASE] = (0.1 * 2 * math.pi * A.base_radius / A.n_teeth
                                                               if m.anchor_release_distance is None
                                                               else m.anchor_release_distance)
                        ap.append(arow)
                        ids.append(f"{m.name}/line{line}/w{w:+d}/s{s_i}")
                        mesh_of.append(m_i)
        self._finish(np.array(fp), np.array(ip, dtype=np.int32), np.concatenate(dev), ids, np.array(mesh_of),
                     np.array(ap), n_bodies, backend, precision, device)

    @classmethod
    def concatenated(cls, sets, nb, *, names=None, precision="float64", device="cpu"):
        """The set of B built sets side by side (copy c's bodies offset by c nb, the ground at
        B nb; mesh names ``names[c][k]``, default the built ones): rows, tooth-angle tables and
        compliances concatenated, equal to the set built from the renamed, shifted meshes
        (tests/test_device_rows.py) without the per-row loop. Sets with stick--slip anchors are built
        from the meshes."""
        s, B = sets[0], len(sets)
        names = names or [[m.name for m in sc.meshes] for sc in sets]
        shift = lambda b, c: b if b == GROUND else int(b) + c * nb
        meshes = [moved_member(m, name=nm, body_a=shift(m.body_a, c), body_b=shift(m.body_b, c))
                  for c, sc in enumerate(sets) for m, nm in zip(sc.meshes, names[c])]
        compliance = {}
        for sc in sets:
            compliance.update(sc.compliance)
        if any(sc.anchor for sc in sets) or any(sc.backend != s.backend for sc in sets):
            return cls(meshes, B * nb, backend=s.backend, precision=precision, device=device, name=s.name,
                       compliance=compliance)
        self = object.__new__(cls)
        self.name, self.meshes, self.backend, self.precision = s.name, tuple(meshes), s.backend, precision
        self.compliance = compliance
        ip, ids, mesh_of = [], [], []
        n_mesh = n_dev = 0
        for c, sc in enumerate(sets):
            i = sc.iparams.copy()
            for col in (ref.J_BODY_A, ref.J_BODY_B):
                i[:, col] = np.where(i[:, col] >= sc.n_bodies, B * nb, i[:, col] + c * nb)
            i[:, (ref.J_TOOTH_A, ref.J_TOOTH_B)] += n_dev
            ip.append(i)
            rename = {m.name: nm for m, nm in zip(sc.meshes, names[c])}
            ids += renamed_ids(sc.ids, rename)
            mesh_of.append(sc.mesh_of + n_mesh)
            n_mesh += len(sc.meshes)
            n_dev += len(sc.deviations)
        self._finish(np.concatenate([sc.fparams for sc in sets]), np.concatenate(ip),
                     np.concatenate([sc.deviations for sc in sets]), ids, np.concatenate(mesh_of),
                     np.zeros((sum(sc.n_contacts for sc in sets), anchor_ref.N_ANCHOR)), B * nb, s.backend,
                     precision, device)
        return self

    def _finish(self, fparams, iparams, deviations, ids, mesh_of, anchor_params, n_bodies, backend, precision, device):
        self.fparams = fparams
        self.iparams = iparams
        self.deviations = deviations
        self._tooth_offsets = None
        self.ids = tuple(ids)
        self.mesh_of = mesh_of
        self.n_contacts = len(fparams)
        anchor = bool(np.any(self.iparams[:, ref.J_FRICTION] == FrictionModel.ANCHOR))
        # committed anchors (A and B coordinates) and slip distance per row
        self.init_evaluation(self.iparams[:, ref.J_BODY_A], self.iparams[:, ref.J_BODY_B], n_bodies,
                             anchor_params=anchor_params if anchor else None)
        if backend == "warp":
            from warp_contacts.involute_pairs import InvolutePairKernel
            self._kernel = InvolutePairKernel(self.fparams, self.iparams, self.deviations, n_bodies, precision, device,
                                              anchor_params=self.anchor_params)

    @property
    def _flank_index(self):
        """Slow-state gap offsets per tooth flank: identity -> index of ref.flank_offset's layout, made on
        first use (one entry per tooth, flank and mesh: ~0.7 ms a copy of RV-40E, which the device copies
        of a Monte Carlo never read)."""
        flank = self.__dict__.get("_flank_cache")
        if flank is None:
            n_teeth, flank, base = len(self.deviations), {}, 0
            for m in self.meshes:
                za, zb = m.pair.gear_a.n_teeth, m.pair.gear_b.n_teeth
                for line in m.lines:
                    for gear, z, first in (("gear_a", za, base), ("gear_b", zb, base + za)):
                        for k in range(z):
                            flank[f"{m.name}/{gear}/tooth{k}/line{line}"] = line * n_teeth + first + k
                base += za + zb
            self._flank_cache = flank
        return flank

    def reference(self, pose, vel, anchor=None):
        return ref.evaluate(pose, vel, self.fparams, self.iparams, self.deviations, tooth_offsets=self._tooth_offsets,
                            **({} if anchor is None else {"anchor": anchor}))

    @property
    def gap_offset_ids(self):
        """Identities that carry slow-state gap offsets: the tooth flanks
        ``"<mesh>/gear_a/tooth<k>/line<l>"`` and ``"<mesh>/gear_b/tooth<j>/line<l>"`` (tooth numbers
        of the tooth-angle table, line l = the flank side), not the rows: a row is a window slot
        whose teeth change as the gears turn, and an offset (wear of a flank, a thermal growth)
        belongs to a tooth."""
        return tuple(self._flank_index)

    def set_gap_offsets(self, offsets):
        """Gap offsets [m] per tooth flank (order of :attr:`gap_offset_ids`; positive opens the gap):
        the gap of a tooth pair on a line gets the offsets of both of its flanks
        (:func:`warp_contacts.involute_pairs_ref.flank_offset`). Absolute, not increments; all zeros
        restore the built evaluation bit for bit."""
        off = np.array(offsets, dtype=np.float64)
        if off.shape != (len(self._flank_index),):
            raise RvtoolInputError(f"gap offsets of contact set {self.name!r} must have shape "
                                   f"({len(self._flank_index)},), one per tooth flank; got {off.shape}")
        if not np.all(np.isfinite(off)):
            raise RvtoolInputError(f"gap offsets of contact set {self.name!r} are outside the valid range: finite [m]")
        table = np.zeros(2 * len(self.deviations))
        table[list(self._flank_index.values())] = off
        self._tooth_offsets = table if np.any(table != 0.0) else None
        if self.backend == "warp":
            self._kernel.set_tooth_offsets(table)

    def tooth_gap_offsets(self):
        """{tooth flank id: gap offset [m]} in force."""
        t = self._tooth_offsets
        return {c: 0.0 if t is None else float(t[i]) for c, i in self._flank_index.items()}

    def flank_ids(self, obs):
        """(flank id of gear A, flank id of gear B) of every row of ``obs`` (the teeth the row's slot
        holds at that state; :attr:`gap_offset_ids`)."""
        out_a, out_b = [], []
        for r, m_i in enumerate(self.mesh_of):
            m = self.meshes[m_i]
            line = int(self.iparams[r, ref.J_LINE])
            out_a.append(f"{m.name}/gear_a/tooth{int(obs[r, ref.O_TOOTH_A])}/line{line}")
            out_b.append(f"{m.name}/gear_b/tooth{int(obs[r, ref.O_TOOTH_B])}/line{line}")
        return out_a, out_b

    def mesh_stiffness(self, obs):
        """Per mesh: sum of the loaded rows' series tangents k_t [N/m] (the mesh stiffness along
        the line of action at this state, bodies held)."""
        out = np.zeros(len(self.meshes))
        np.add.at(out, self.mesh_of, obs[:, ref.O_KT])
        return out

    def width_moments(self, obs):
        """Eq. (width_resultant): per mesh, the moments (M_x, M_y) [N m] of the slice forces on
        gear A about the mesh midplane (x_s - O has the axial component z_s)."""
        z = self.fparams[:, ref.C_Z]
        f = -obs[:, ref.O_FN][:, None] * obs[:, ref.O_NX:ref.O_NY + 1] + obs[:, ref.O_FT][:, None] * np.column_stack(
            [-obs[:, ref.O_NY], obs[:, ref.O_NX]])
        M = np.zeros((len(self.meshes), 2))
        np.add.at(M, self.mesh_of, np.column_stack([-z * f[:, 1], z * f[:, 0]]))
        return M

    def energy_law(self):
        """The per-row constants of the energy account (:class:`rvtool.observe.energy.ContactEnergyLaw`):
        the series law's elastic force and potential in closed form
        (:func:`warp_contacts.involute_pairs_ref.elastic_state`, read from the current parameter
        rows), anchor stiffness and friction code."""
        from ..observe.energy import ContactEnergyLaw
        kt = self.anchor_params[:, anchor_ref.ANCHOR_KT] if self.anchor else np.zeros(self.n_contacts)
        return ContactEnergyLaw(tangential_stiffness=kt, friction_model=self.iparams[:, ref.J_FRICTION].copy(),
                                normal_potential=self.elastic_energy)

    def elastic_energy(self, obs):
        """(elastic normal force [N], potential [J]) per row from observation rows (N, N_OBS)."""
        _, F, V = ref.elastic_state(self.fparams, obs)
        return F, V
