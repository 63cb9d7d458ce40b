"""Per-copy parameters of many manufacturing variants of one cycloid design, generated vectorized.

The device Newton (:mod:`rvtool.solver.device_newton`) solves B independent copies of one
topology: every copy is one manufacturing variant (:class:`rvtool.variants.Variant`) at one
input angle. Its contact kernels need the parameter rows of every copy. Building them as
:func:`rvtool.batched.assembly.build_batched` does (the builder's pieces per copy, one Exudyn
system) costs ~60 ms per copy; here the rows of ONE nominal copy are built once by the
builder's own pieces (:func:`rvtool.assembly.copies.copy_contacts`) and the columns that a
variant changes are written for all variants at once with NumPy, with the same expressions and
the same order of floating-point operations as :meth:`Variant.apply` followed by the builder,
so that the rows are bit-identical (tested against ``build_batched``):

* cycloid pins: pin centre (nominal + the variant's centre errors), pin radius
  (r_p + radius error), gap offset (clearance + pin clearance + deviation + crowning + skew);
* eccentric bearings: journal centre (the variant's eccentricity e = e_g + error) and the
  enclosing radius (journal radius + the variant's radial clearance);
* body reference poses (the wheels sit on their journals).

Profile tables depend on the profile only (the generating eccentricity e_g is the design's):
one set of tables per distinct profile modification (equidistant, offset). A table's search
key is built with the design's pin radius; a variant's pin radius differs by micrometres,
far inside the search band of the key (5 % of r_p, :func:`rvtool.contact.cycloid_set.auto_window`).

Supported (raises :class:`RvtoolInputError` otherwise): lumped bearings, rigid housing, no
rigid supports (the builder's defaults for the Monte Carlo).
"""
from dataclasses import dataclass

import numpy as np

from warp_contacts import circle_pairs_ref as cref
from warp_contacts import cycloid_pins_ref as pref
from warp_contacts import output_pins_ref as oref

from ..assembly.cycloid import CycloidKinematics, lumped_bearing_contacts
from ..assembly.spec import CycloidDesign
from ..contact.circle_set import CircleContactSet
from ..contact.cycloid_set import CycloidPinSet
from ..errors import RvtoolInputError
from ..geometry.eccentric import journal_centre
from ..assembly.copies import copy_contacts


def _local_map(bodies, nb):
    """(R, 3 m) local coordinate index of each row entry (-1: ground) from (R, m) body indices
    of a copy whose bodies are 0..nb-1 and whose ground is nb."""
    bodies = np.asarray(bodies, np.int64)
    loc = 3 * bodies[:, :, None] + np.arange(3)
    return np.where(bodies[:, :, None] >= nb, -1, loc).reshape(len(bodies), -1).astype(np.int32)


@dataclass(frozen=True)
class CopyParameters:
    """Parameters of V variants of one design for the device Newton (SI units).

    pin_f (V, R_p, N_FLOAT), pin_i (V, R_p, N_INT): cycloid-pin rows of each variant, body
    columns local to the copy (0..nb-1, nb: ground); tables, window, analytic: the profile
    tables of :class:`~rvtool.contact.cycloid_set.CycloidPinSet`; brg_f (V, R_b, 15), brg_i
    (R_b, 4): lumped-bearing rows; op_f (R_o, 11), op_i (R_o, 2), stations: plain output-pin
    rows (the same for every variant); loc_* (R, 6): local coordinate of each row entry (-1:
    ground); reference (V, nb, 3) [m, rad]; eccentricity (V,) [m]; free (3 nb,) bool (all but
    the drive and the locks); spring_k (3 nb,) [N/m, N m/rad] regularization springs.
    """
    design: CycloidDesign
    variants: tuple
    nb: int
    pin_f: np.ndarray
    pin_i: np.ndarray
    tables: list
    window: int
    analytic: list
    search: str
    brg_f: np.ndarray
    brg_i: np.ndarray
    op_f: np.ndarray
    op_i: np.ndarray
    stations: np.ndarray
    loc_pin: np.ndarray
    loc_brg: np.ndarray
    loc_op: np.ndarray
    reference: np.ndarray
    eccentricity: np.ndarray
    free: np.ndarray
    spring_k: np.ndarray

    @property
    def n(self):
        """Coordinates per copy (3 nb)."""
        return 3 * self.nb

    @property
    def output_index(self):
        """Local index of the flange rotation (the output and the load coordinate)."""
        return 3 * (self.nb - 1) + 2

    @property
    def input_index(self):
        """Local index of the shaft rotation (the driven coordinate)."""
        return 2

    def kinematic(self, variant_index, angles):
        """(P, 3 nb) kinematic displacement coordinates of copies (variant, input angle [rad]) from
        their reference configurations (the builder's :class:`CycloidKinematics`, vectorized
        over the variants' eccentricities); locked coordinates are held at 0 like the locks."""
        vi = np.asarray(variant_index, np.int64)
        a = np.asarray(angles, float)
        kin_d = CycloidKinematics(self.design)
        nw = self.nb - 2
        poses = np.zeros((len(a), self.nb, 3))
        poses[:, 0, 2] = a
        x, y = journal_centre(self.eccentricity[vi][:, None], kin_d.phases[None, :], a[:, None])
        poses[:, 1:nw + 1, 0], poses[:, 1:nw + 1, 1] = x, y
        poses[:, 1:, 2] = -a[:, None] / kin_d.z_g
        q = (poses - self.reference[vi]).reshape(len(a), -1)
        fixed = ~self.free
        fixed[self.input_index] = False
        q[:, fixed] = 0.0
        return q


def _variant_columns(design, variants):
    """Per-variant scalars and arrays as :meth:`Variant.apply` computes them (checked)."""
    w, prof = design.wheels, design.profile
    V = len(variants)
    zb = design.pins.n_pins
    e_g = prof.generating_eccentricity
    ecc = np.array([e_g + v.eccentricity_error for v in variants])
    bad = np.flatnonzero(~(ecc > 0))
    if len(bad):
        raise RvtoolInputError(f"variants[{bad[0]}].eccentricity_error = {variants[bad[0]].eccentricity_error} m leaves "
                               f"a non-positive eccentricity; valid range ({-e_g}, inf) m")
    radius_error = np.array([design.pins.radius_error + v.pin_radius_error for v in variants])
    rp = design.pins.pin_radius + radius_error
    bad = np.flatnonzero(~(rp > 0))
    if len(bad):
        raise RvtoolInputError(f"variants[{bad[0]}].pin_radius_error = {variants[bad[0]].pin_radius_error} m; valid "
                               f"range ({-design.pins.pin_radius}, inf) m")
    clearance = np.array([w.clearance + v.pin_clearance for v in variants])
    errors = np.zeros((V, zb, 2))
    has_err = np.zeros(V, bool)
    base_err = design.pins.centre_errors
    for i, v in enumerate(variants):
        e = v.pin_centre_errors if v.pin_centre_errors is not None else base_err
        if e is not None:
            e = np.asarray(e, float)
            if e.shape != (zb, 2):
                raise RvtoolInputError(f"variants[{i}].pin_centre_errors must have shape ({zb}, 2); got {e.shape}")
            errors[i] = e
            has_err[i] = True
    eb = design.eccentric_bearing.radial_clearance
    brg_clr = np.array([eb if v.bearing_clearance is None else v.bearing_clearance for v in variants])
    mods = [(prof.equidistant_mod + v.equidistant_mod, prof.offset_mod + v.offset_mod) for v in variants]
    return ecc, rp, radius_error, clearance, errors, has_err, brg_clr, mods


def copy_parameters(design: CycloidDesign, variants, *, regularization=(100.0, 0.1)):
    """:class:`CopyParameters` of ``variants`` of ``design`` (see the module docstring).
    regularization: (k_translation [N/m], k_rotation [N m/rad]) as in
    :func:`rvtool.assembly.cycloid.build`."""
    variants = tuple(variants)
    if len(variants) < 1:
        raise RvtoolInputError("variants must contain at least one Variant (valid range of B: [1, inf))")
    if design.wheels.dynamics.flexible:
        raise RvtoolInputError("wheels.dynamics.model = 'flexible'; the device copies carry planar rigid wheels "
                               "(valid: 'rigid')")
    if design.housing.model != "rigid":
        raise RvtoolInputError(f"housing.model = {design.housing.model!r}; the device Newton supports ['rigid']")
    from ..assembly.spec import replace
    nw = design.n_wheels
    nb = nw + 2
    V = len(variants)
    ecc, rp, radius_error, clearance, errors, has_err, brg_clr, mods = _variant_columns(design, variants)

    # -- cycloid pins: one nominal row set per distinct profile modification ---------------
    groups = {}
    for i, m in enumerate(mods):
        groups.setdefault(m, []).append(i)
    tables, analytic, window = [], [] if design.wheels.search == "analytic" else None, 0
    pin_f = pin_i = None
    for (eq, off), members in groups.items():
        d_g = replace(design, profile={"equidistant_mod": eq, "offset_mod": off})
        meshes, _, _ = copy_contacts(d_g, 0)
        pset = CycloidPinSet(meshes, nb, samples_per_tooth=design.wheels.samples_per_tooth, backend="numpy",
                             name="pins", search=design.wheels.search)
        if pin_f is None:
            R = pset.n_contacts
            pin_f = np.empty((V, R, pref.N_FLOAT))
            pin_i = np.empty((V, R, pref.N_INT), np.int32)
            pin_of = pset.pin_of
            mesh_of = pset.mesh_of
            base_meshes = meshes
        ip = pset.iparams.copy()
        ip[:, pref.J_TABLE] += len(tables)
        tables += pset.tables
        if analytic is not None:
            analytic += pset.analytic
        window = max(window, pset.window)
        members = np.array(members)
        pin_f[members] = pset.fparams
        pin_i[members] = ip
    # variant columns, with the builder's expressions in the builder's order
    zb = design.pins.n_pins
    a = 2 * np.pi * np.arange(zb) / zb
    centres = design.pins.pin_circle_radius * np.column_stack([np.sin(a), np.cos(a)])
    centres = np.where(has_err[:, None, None], centres[None] + errors, centres[None])     # (V, zb, 2)
    pin_f[:, :, pref.C_XI_B:pref.C_XI_B + 2] = centres[:, pin_of]
    rp_rows = np.where(radius_error != 0.0, rp, design.pins.pin_radius)
    pin_f[:, :, pref.C_RP] = rp_rows[:, None]
    e_cols = np.empty((V, len(pin_of)))
    for m_i, m in enumerate(base_meshes):
        rows = np.flatnonzero(mesh_of == m_i)
        dev = np.zeros(zb) if m.normal_deviation is None else np.asarray(m.normal_deviation, float)
        zs = m.slice_z
        crown = m.crowning * (2 * zs / m.face_width) ** 2
        s_of = np.tile(np.arange(m.n_slices), zb)
        k_of = pin_of[rows]
        e_cols[:, rows] = clearance[:, None] + dev[k_of][None] + crown[s_of][None] + zs[s_of][None] * np.tan(m.skew)
    pin_f[:, :, pref.C_E] = e_cols

    # -- lumped bearings ---------------------------------------------------------------------
    bset = CircleContactSet(name="bearings", n_bodies=nb, contacts=tuple(lumped_bearing_contacts(design)))
    bf, bi = bset.packed()
    brg_f = np.broadcast_to(bf, (V,) + bf.shape).copy()
    phases = np.asarray(design.wheels.phases[:nw], float)
    r_j = design.eccentric_bearing.inner_radius
    for k in range(nw):
        jx, jy = journal_centre(ecc, phases[k])
        brg_f[:, k, cref.P_XI_A], brg_f[:, k, cref.P_XI_A + 1] = jx, jy
        brg_f[:, k, cref.P_RB] = r_j + brg_clr + 1e-12

    # -- output pins (plain; no variant column) ----------------------------------------------
    _, _, (op_f, op_i, stations) = copy_contacts(design, 0)

    # -- bodies ---------------------------------------------------------------------------------
    reference = np.zeros((V, nb, 3))
    for k in range(nw):
        reference[:, 1 + k, 0], reference[:, 1 + k, 1] = journal_centre(ecc, phases[k])
    n = 3 * nb
    free = np.ones(n, bool)
    free[2] = False                                    # the drive
    retained = {0: design.bodies.shaft, nb - 1: design.bodies.flange}
    retained.update({1 + k: design.bodies.wheel for k in range(nw)})
    for body, coords in retained.items():
        for c, name in enumerate(("x", "y", "theta")):
            if name not in coords:
                free[3 * body + c] = False
    k_t, k_r = regularization
    spring_k = np.where(np.arange(n) % 3 == 2, k_r, k_t).astype(float)
    spring_k[2] = 0.0                                  # no spring on the driven shaft rotation
    return CopyParameters(design=design, variants=variants, nb=nb, pin_f=pin_f, pin_i=pin_i, tables=tables,
                          window=window, analytic=analytic, search=design.wheels.search, brg_f=brg_f, brg_i=bi,
                          op_f=op_f, op_i=op_i, stations=np.asarray(stations, float),
                          loc_pin=_local_map(pin_i[0][:, [pref.J_BODY_A, pref.J_BODY_B]], nb),
                          loc_brg=_local_map(bi[:, [cref.I_BODY_A, cref.I_BODY_B]], nb),
                          loc_op=_local_map(op_i[:, [oref.J_FLANGE, oref.J_WHEEL]], nb), reference=reference, eccentricity=ecc, free=free,
                          spring_k=spring_k)


def _nominal_plus(design, variants, regularization):
    """copy_parameters of [Variant()] + variants (a picklable task for an executor)."""
    from ..assembly.variant import Variant
    return copy_parameters(design, [Variant()] + list(variants), regularization=regularization)


def merge_copy_parameters(parts):
    """One :class:`CopyParameters` of [Variant()] + the variants of ``parts`` (each the
    parameters of [Variant()] + a consecutive share of the variants, of one design and one
    regularization): the rows stacked, every part's nominal row after the first dropped, its
    profile-table indices shifted past the tables before it (a profile modification shared by
    two parts has a table in each: identical contents, so the rows read the same values)."""
    first = parts[0]
    keep = [slice(None)] + [slice(1, None)] * (len(parts) - 1)
    pin_i, tables, analytic, n_tab = [], [], [] if first.analytic is not None else None, 0
    for p, k in zip(parts, keep):
        ip = p.pin_i[k].copy()
        ip[:, :, pref.J_TABLE] += n_tab
        pin_i.append(ip)
        tables += p.tables
        if analytic is not None:
            analytic += p.analytic
        n_tab += len(p.tables)
    cat = lambda nm: np.concatenate([getattr(p, nm)[k] for p, k in zip(parts, keep)])
    return CopyParameters(design=first.design, variants=sum((p.variants[k] for p, k in zip(parts, keep)), ()),
                          nb=first.nb, pin_f=cat("pin_f"), pin_i=np.concatenate(pin_i), tables=tables,
                          window=max(p.window for p in parts), analytic=analytic, search=first.search,
                          brg_f=cat("brg_f"), brg_i=first.brg_i, op_f=first.op_f, op_i=first.op_i,
                          stations=first.stations, loc_pin=first.loc_pin, loc_brg=first.loc_brg,
                          loc_op=first.loc_op, reference=cat("reference"), eccentricity=cat("eccentricity"),
                          free=first.free, spring_k=first.spring_k)


def nominal_copy_parameters(design, variants, *, regularization=(100.0, 0.1), executor=None, share=64):
    """:class:`CopyParameters` of ``[Variant()] + variants`` (the layout of the device TE and lost
    motion: the nominal design at index 0). With a ``concurrent.futures.Executor``, the variants
    are split into consecutive shares of at most ``share`` and built side by side, then merged
    (:func:`merge_copy_parameters`): building is one profile-table set per distinct profile
    modification, ~0.13 s per Monte Carlo variant of RD-40 on one core (80 % in the tables), the
    largest serial cost of a device chunk on a GPU host."""
    variants = list(variants)
    if executor is None or len(variants) <= share:
        return _nominal_plus(design, variants, regularization)
    if not (isinstance(share, (int, np.integer)) and share >= 1):
        raise RvtoolInputError(f"share = {share!r} is outside the valid range [1, inf) (integer)")
    shares = [variants[s:s + share] for s in range(0, len(variants), share)]
    futures = [executor.submit(_nominal_plus, design, sh, regularization) for sh in shares]
    return merge_copy_parameters([f.result() for f in futures])
