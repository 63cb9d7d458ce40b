"""Moment rigidity and axial stiffness of the output flange on its main-bearing rows (issue 32).

Catalogue quantity. RV reducer catalogues list, beside the allowable moment, a "moment rigidity"
[N m/arc.min]: the external moment on the output flange (an arm's load about a diameter of the
main bearing) over the tilt angle of the flange it causes, read on the catalogue's moment--tilt
curve. The Nabtesco rating-table notes that give its measuring points were NOT read in the session
that wrote this module (rv40e/rv80e_catalogue.toml: the stored copy returned only the opening
pages), so the points are a STATED CONVENTION, named in every result: the secant between two moment
levels given as fractions of a reference moment (by default 0 and the catalogue's allowable moment:
the whole rated range, the catalogue's graph of tilt vs moment being nearly linear for a preloaded
pair). Nothing is tuned toward a catalogue value.

Definition search (issue 32, second session): the Nabtesco definition was again not reached. The
RD-E catalogue's contents list "Calculation of moment rigidity and torsion angle" (Nabtesco RD-E
series catalogue, p. 22; public transcription, scribd 497875543: only the contents page came back),
so the catalogue gives the tilt as a calculation from the moment rigidity, not its measuring points.
The nearest manufacturer definition found is Harmonic Drive's (LynxDrive engineering data, 1018856
08/2018 V04, sec. 7.3.4, Eq. 45.1): the angle of inclination of the output flange gamma [arcmin] =
M / K_B, M [N m] the tilting moment on the output bearing, K_B [N m/arcmin] its moment stiffness --
a secant from zero load, which is the default read points here (0 and the reference moment). The
convention stays stated, not cited as Nabtesco's.

Procedure (:class:`MomentRigidityTest`): the model with a spatial carrier
(``bodies.carrier_coordinates = "spatial"``), input held at angle 0, the output torque held at
``output_torque``; a moment M_x at the main bearing's axial centre at each level, a static
equilibrium per level (warm-started Newton, :class:`~rvtool.solver.static.StaticSolver`); the
flange's tilt gamma_x, the axial force of each main-bearing row and the working contact angles read
at each. Axial stiffness: the same with an axial force, k_a = dF / dz between its two levels.

:func:`pair_moment_rigidity` is the same test on the main bearing alone (flange on a rigid housing,
Newton on the 5-DOF wrench of :func:`rvtool.bearings.spatial_set.flange_wrench`): cheap, for
uncertainty bands over the main bearing's `assumed` ranges; with a rigid housing the reducer model
gives the same figure (the drive train carries no out-of-plane load; tests compare them).
"""
import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..units import RAD_PER_ARCMIN
from ..validation import check_finite, check_positive, check_range

NEWTON_DIAGONAL = (1.0, 1.0, 1.0, 1e-2, 1e-2)
"""Weak diagonal [N/m, N m/rad] added to the flange's tangent in :func:`flange_equilibrium`'s Newton
step (not to its residual: the equilibrium is the bearing's alone)."""

DEFAULT_READ_BETWEEN = (0.0, 1.0)
"""Moment points [fraction of the reference moment] of the secant where none are given: a stated
convention (the catalogue's own points were not read), named in every result."""


@dataclass(frozen=True, kw_only=True)
class MomentRigidityTest:
    """The moment-rigidity and axial-stiffness protocol as data.

    reference_moment: M_ref [N m] (the catalogue's allowable moment where it prints one).
    levels: moment levels [fraction of M_ref], ascending, including ``read_between``.
    read_between: (a, b) [fraction of M_ref]: rigidity = (M_b - M_a) / (gamma_b - gamma_a).
    axial_force: F_ref [N] of the axial-stiffness points (0, F_ref); 0 skips it.
    output_torque: torque [N m] held on the output during the test (reducer model only).
    """
    reference_moment: float
    levels: tuple = (0.0, 0.25, 0.5, 0.75, 1.0)
    read_between: tuple = DEFAULT_READ_BETWEEN
    axial_force: float = 0.0
    output_torque: float = 0.0

    def __post_init__(self):
        check_positive("reference_moment", self.reference_moment)
        lv = np.asarray(self.levels, float)
        check_range("levels", lv, 0.0, 2.0)
        if lv.ndim != 1 or len(lv) < 2 or np.any(np.diff(lv) <= 0):
            raise RvtoolInputError(f"levels = {self.levels!r} must be at least two ascending fractions")
        a, b = self.read_between
        if a not in self.levels or b not in self.levels or not a < b:
            raise RvtoolInputError(f"read_between = {self.read_between!r} must be two ascending members of "
                                   f"levels = {self.levels!r}")
        check_range("axial_force", self.axial_force, 0.0)
        check_finite("output_torque", self.output_torque)

    @property
    def moments(self):
        """Moment levels [N m]."""
        return np.asarray(self.levels, float) * self.reference_moment


@dataclass(frozen=True, kw_only=True)
class MomentRigidityResult:
    """moments (n,) [N m]; tilt (n,) [rad] about the moment's axis; row_axial_forces (n, 2) [N] on
    the flange per main-bearing row; working_angle_range (n, 2) [rad] (smallest, largest over the
    balls); rigidity [N m/rad] between the test's read points and rigidity_arcmin [N m/arcmin];
    axial_stiffness [N/m] (None if not run); read_between; convention (where the points come from)."""
    moments: np.ndarray
    tilt: np.ndarray
    row_axial_forces: np.ndarray
    working_angle_range: np.ndarray
    rigidity: float
    axial_stiffness: float | None
    read_between: tuple
    convention: str

    @property
    def rigidity_arcmin(self):
        return self.rigidity * RAD_PER_ARCMIN

    def to_dict(self):
        return {"moments_Nm": self.moments.tolist(), "tilt_arcmin": (self.tilt / RAD_PER_ARCMIN).tolist(),
                "row_axial_forces_N": self.row_axial_forces.tolist(),
                "working_angle_range_deg": np.degrees(self.working_angle_range).tolist(),
                "moment_rigidity_Nm_per_arcmin": self.rigidity_arcmin,
                "axial_stiffness_N_per_m": self.axial_stiffness, "read_between": list(self.read_between),
                "convention": self.convention}


def _convention(test):
    return (f"secant between {test.read_between[0]:g} and {test.read_between[1]:g} x {test.reference_moment:g} N m "
            + ("(stated convention: the catalogue's own points were not read)"
               if tuple(test.read_between) == DEFAULT_READ_BETWEEN else "(declared by the caller)"))


def _secant(test, moments, tilt):
    lv = list(test.levels)
    i, j = lv.index(test.read_between[0]), lv.index(test.read_between[1])
    return float((moments[j] - moments[i]) / (tilt[j] - tilt[i]))


def moment_rigidity(model, test: MomentRigidityTest):
    """:class:`MomentRigidityResult` of a built RV model with a spatial carrier (module docstring)."""
    from ..solver.static import StaticSolver
    if getattr(model, "carrier_tilt", None) is None:
        raise RvtoolInputError("moment rigidity needs the output body's tilt coordinates; valid: "
                               "bodies.carrier_coordinates (RV) or bodies.flange_coordinates (cycloid) = 'spatial' "
                               "in the design file")
    solver = StaticSolver(model)
    model.set_output_torque(float(test.output_torque))
    tilt, rows, angles = [], [], []

    def point(axial, moment):
        model.set_flange_load(axial, (moment, 0.0))
        q = solver.solve(0.0, previous_angle=0.0 if solver.q is not None else None)
        ev, pose = model.main_bearing_state(q)
        return q, model.main_bearing_loads(q), ev.working_angles(pose)["main_bearing"]

    try:
        for M in test.moments:
            q, loads, alw = point(0.0, M)
            tilt.append(model.flange_displacement(q)[1])
            rows.append(loads.row_axial_forces)
            angles.append((alw.min(), alw.max()))
        k_a = None
        if test.axial_force > 0:
            z = [model.flange_displacement(point(F, 0.0)[0])[0] for F in (0.0, test.axial_force)]
            k_a = float(test.axial_force / (z[1] - z[0]))
    finally:
        model.set_flange_load(0.0, (0.0, 0.0))
    tilt = np.array(tilt)
    return MomentRigidityResult(moments=test.moments, tilt=tilt, row_axial_forces=np.array(rows),
                                working_angle_range=np.array(angles), rigidity=_secant(test, test.moments, tilt),
                                axial_stiffness=k_a, read_between=tuple(test.read_between),
                                convention=_convention(test))


def flange_equilibrium(pair, load, q0=None, *, tol=1e-9, max_iterations=200):
    """Relative displacement q (5,) (delta_x, delta_y, delta_z, gamma_x, gamma_y) of a flange on
    ``pair`` against a rigid housing under the external wrench ``load`` (5,) (F_x, F_y, F_z [N],
    M_x, M_y [N m]) at the mounting centre: Newton on w(q) + load = 0 with the analytic tangent,
    converged when |w + load| <= tol (1 + |load|) component-wise. Raises SolverFailure."""
    from ..bearings.spatial_set import flange_wrench
    load = np.asarray(load, float)
    q = np.zeros(5) if q0 is None else np.array(q0, float)
    for _ in range(max_iterations):
        w, K, _ = flange_wrench(pair, q)
        r = w + load
        if np.all(np.abs(r) <= tol * (1.0 + np.abs(load))):
            return q
        # the tangent with a weak diagonal (1 N/m, 0.01 N m/rad against ~1e8): regular inside an end
        # play where no ball touches, a negligible change of the Newton step in contact
        step = -np.linalg.solve(K - np.diag(NEWTON_DIAGONAL), r)
        # steps are capped at a few ball approaches (5 um, 1e-4 rad): the first contact of a pair with
        # end play is approached in steps, not jumped deep into the Hertz law
        scale = max(np.max(np.abs(step[:3])) / 5e-6, np.max(np.abs(step[3:])) / 1e-4, 1.0)
        q = q + step / scale
    raise SolverFailure(f"flange on its main bearing: no equilibrium under the load {load.tolist()} "
                        f"in {max_iterations} Newton iterations")


def pair_moment_rigidity(pair, test: MomentRigidityTest):
    """:class:`MomentRigidityResult` of the flange on ``pair`` alone (rigid housing)."""
    from ..bearings.spatial_set import flange_set
    s = flange_set(pair)
    tilt, rows, angles = [], [], []
    q = np.zeros(5)
    for M in test.moments:
        q = flange_equilibrium(pair, (0.0, 0.0, 0.0, M, 0.0), q)
        pose = np.array([[q[0], q[1], 0.0], [q[2], q[3], q[4]]])
        tilt.append(q[3])
        rows.append(s.resultants(pose)["flange"].row_axial_forces)
        alw = s.working_angles(pose)["flange"]
        angles.append((alw.min(), alw.max()))
    k_a = None
    if test.axial_force > 0:
        z1 = flange_equilibrium(pair, (0.0, 0.0, test.axial_force, 0.0, 0.0))[2]
        k_a = float(test.axial_force / z1)
    tilt = np.array(tilt)
    return MomentRigidityResult(moments=test.moments, tilt=tilt, row_axial_forces=np.array(rows),
                                working_angle_range=np.array(angles), rigidity=_secant(test, test.moments, tilt),
                                axial_stiffness=k_a, read_between=tuple(test.read_between),
                                convention=_convention(test))


def spatial_design(design):
    """The design with a spatial carrier (``bodies.carrier_coordinates = "spatial"``)."""
    return dataclasses.replace(design, bodies=dataclasses.replace(design.bodies, carrier_coordinates="spatial"))


def main_bearing_keys(assumed):
    """The `assumed` inputs of a design (:class:`~rvtool.designs.catalogue.AssumedRanges`) that set its
    main bearing (``main_bearing.*`` keys): the ones that move the moment rigidity."""
    return tuple(a for a in assumed.inputs if a.key.startswith("main_bearing."))


def pair_with(pair, key, value):
    """``pair`` with the design-file ``key`` (``main_bearing.row_spacing``, ``main_bearing.row.FIELD``
    or ``main_bearing.row.FIELD_deg``: both rows) set to ``value`` (the file's unit), validated."""
    from ..bearings.spec import AngularContactPair
    parts = key.split(".")
    if parts[0] != "main_bearing" or not isinstance(pair, AngularContactPair):
        raise RvtoolInputError(f"key = {key!r}: valid keys are main_bearing.row_spacing, main_bearing.row.FIELD")
    if len(parts) == 2:
        return dataclasses.replace(pair, **{parts[1]: value})
    if len(parts) != 3 or parts[1] != "row":
        raise RvtoolInputError(f"key = {key!r}: valid keys are main_bearing.row_spacing, main_bearing.row.FIELD "
                               "(both rows; main_bearing.rows[k] tables are not varied here)")
    field = parts[2]
    if field.endswith("_deg"):
        field, value = field[:-4], np.radians(value)
    rows = tuple(dataclasses.replace(r, **{field: value}) for r in pair.rows)
    return dataclasses.replace(pair, rows=rows)


def main_bearing_band(pair, assumed, test, *, samples=16, seed=0):
    """Moment rigidity [N m/arcmin] over the main bearing's `assumed` ranges: a one-at-a-time
    tornado (each key at its low and high end) and ``samples`` Latin-hypercube samples
    (:mod:`scipy.stats.qmc`) over all of them, each by :func:`pair_moment_rigidity`. Returns
    {"keys", "tornado": {key: (at low, at high)}, "samples": [...], "band": (min, max) over all}."""
    from scipy.stats import qmc
    inputs = main_bearing_keys(assumed)
    if not inputs:
        return {"keys": [], "tornado": {}, "samples": [], "band": None}

    def rigidity(p):
        return pair_moment_rigidity(p, test).rigidity_arcmin

    tornado = {a.key: (rigidity(pair_with(pair, a.key, a.at(0.0))), rigidity(pair_with(pair, a.key, a.at(1.0))))
               for a in inputs}
    U = qmc.LatinHypercube(d=len(inputs), seed=seed).random(samples) if samples else np.zeros((0, len(inputs)))
    lhs = []
    for u in U:
        p = pair
        for a, x in zip(inputs, u):
            p = pair_with(p, a.key, a.at(x))
        lhs.append(rigidity(p))
    vals = [v for pr in tornado.values() for v in pr] + lhs
    return {"keys": [a.key for a in inputs], "tornado": tornado, "samples": lhs, "band": (min(vals), max(vals))}


@dataclass(frozen=True, kw_only=True)
class CombinedLoadTest:
    """TE and torsional stiffness under a tilting moment and the torque together (issue 32), as data.

    moment: (M_x, M_y) [N m] on the output flange at the main bearing's axial centre (an arm's load),
    held through the whole test; torques: output torque levels [N m], ascending, at least two (the
    stiffness is the secant between the first and the last); te_torque: torque [N m] of the TE sweep;
    te_angles: input angles [rad] of the TE sweep (ascending, e.g. one mesh period)."""
    moment: tuple
    torques: tuple
    te_torque: float
    te_angles: tuple

    def __post_init__(self):
        check_finite("moment", self.moment)
        if np.shape(self.moment) != (2,):
            raise RvtoolInputError(f"moment = {self.moment!r} must hold (M_x, M_y) [N m]")
        t = np.asarray(self.torques, float)
        check_range("torques", t, 0.0)
        if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0):
            raise RvtoolInputError(f"torques = {self.torques!r} must be at least two ascending levels [N m]")
        check_range("te_torque", self.te_torque, 0.0)
        a = np.asarray(self.te_angles, float)
        check_finite("te_angles", a)
        if a.ndim != 1 or len(a) < 2 or np.any(np.diff(a) <= 0):
            raise RvtoolInputError(f"te_angles = {self.te_angles!r} must be at least two ascending input angles [rad]")


@dataclass(frozen=True, kw_only=True)
class CombinedLoadResult:
    """torques (n,) [N m]; output_angle (n,) [rad] (the output's wind-up at input angle 0);
    torsional_stiffness [N m/rad] (secant, first to last level); tilts: {body: (n, 3) (z [m],
    gamma_x, gamma_y [rad])} per level of every spatial body; main_row_axial_forces (n, rows) [N];
    crank_row_axial_forces (n, cranks, rows) [N] (spatial cranks; else the planar observation);
    te (m,) [rad] over the sweep's input angles at te_torque; te_peak_to_peak [rad];
    width_load_ratio: {element: (n,)} per level, :func:`width_load_ratios` (the peak slice line load
    over the peak row load: 1 uniform across the width, more where a tilt loads one edge)."""
    moment: tuple
    torques: np.ndarray
    output_angle: np.ndarray
    torsional_stiffness: float
    tilts: dict
    main_row_axial_forces: np.ndarray
    crank_row_axial_forces: np.ndarray | None
    te_angles: np.ndarray
    te: np.ndarray
    width_load_ratio: dict

    @property
    def te_peak_to_peak(self):
        return float(np.ptp(self.te))

    def to_dict(self):
        arcmin = 1.0 / RAD_PER_ARCMIN
        return {"moment_Nm": list(self.moment), "torques_Nm": self.torques.tolist(),
                "output_angle_arcmin": (self.output_angle * arcmin).tolist(),
                "torsional_stiffness_Nm_per_arcmin": self.torsional_stiffness * RAD_PER_ARCMIN,
                "tilts_arcmin": {k: (np.asarray(v)[:, 1:] * arcmin).tolist() for k, v in self.tilts.items()},
                "axial_displacement_um": {k: (np.asarray(v)[:, 0] * 1e6).tolist() for k, v in self.tilts.items()},
                "main_row_axial_forces_N": self.main_row_axial_forces.tolist(),
                "crank_row_axial_forces_N": None if self.crank_row_axial_forces is None
                else self.crank_row_axial_forces.tolist(),
                "te_arcsec": (self.te * 60 * arcmin).tolist(), "te_peak_to_peak_arcsec": self.te_peak_to_peak * 60 * arcmin,
                "width_load_ratio": {k: np.asarray(v).tolist() for k, v in self.width_load_ratio.items()}}


def _sliced(ev, pose):
    """[(SkewSlices, its poses)] inside an element's evaluator at the element's poses: the evaluator
    itself, the parts of a stacked set, the inner set of a series closure at its extended (station)
    poses, recursively."""
    from ..contact.skew import SkewSlices
    from ..contact.stacked import StackedContactSet
    if isinstance(ev, SkewSlices):
        return [(ev, pose)]
    if isinstance(ev, StackedContactSet):
        return [x for p in ev.parts for x in _sliced(p, pose)]
    if callable(getattr(type(ev), "extended_pose", None)):         # a series closure (pin / crank beam)
        return _sliced(ev.inner, ev.extended_pose(pose))
    return []


def width_load_ratios(model, q):
    """{element: the largest slice line load over the largest row load} of every family sliced across
    the width at the static state q (:class:`~rvtool.contact.skew.SkewSlices`, also inside a stacked
    set or a series closure): max over slices s and rows r of f_sr / w_s, over max over rows of
    sum_s f_sr (1: the most loaded contact is loaded uniformly; up to 1 / min w_s when one slice
    carries it all)."""
    out = {}
    for name, el in model.elements.items():
        ql = el.local(q)
        ratios = []
        for p, pose in _sliced(el.evaluator, el.pose_velocity(ql, np.zeros_like(ql))[0]):
            f = p.slice_forces(pose)
            peak = float(f.sum(axis=0).max())
            if peak > 0:
                ratios.append(float((f / p.weights[:, None]).max() / peak))
        if ratios:
            out[name] = max(ratios)
    return out


def _crank_rows(model, q):
    """(cranks, rows) axial force [N] of each tapered crank row on its crank (RV only; fed back with
    spatial cranks, the planar observation otherwise), or None."""
    el = model.elements.get("crank_bearings")
    if el is None:
        return None
    ql = el.local(q)
    res = el.evaluator.resultants(el.pose_velocity(ql, np.zeros_like(ql))[0])
    return np.array([np.asarray(r.row_wrenches)[:, 2] for r in res.values()])


def combined_moment_torque(model, test: CombinedLoadTest):
    """:class:`CombinedLoadResult` of a built model with a spatial carrier / flange: the flange moment
    held, the output torque stepped through ``test.torques`` at input angle 0 (static equilibria,
    warm-started), then the TE sweep at ``test.te_torque`` over ``test.te_angles``. The load and
    moment are removed afterwards. Torques act against the drive (the output torque is
    -sign(ratio) T, as the stiffness protocol loads)."""
    from ..solver.static import StaticSolver
    if getattr(model, "carrier_tilt", None) is None:
        raise RvtoolInputError("the combined moment + torque test needs the output body's tilt coordinates; valid: "
                               "bodies.carrier_coordinates (RV) or bodies.flange_coordinates (cycloid) = 'spatial'")
    solver = StaticSolver(model)
    sign = -np.sign(model.ratio)
    out = model.body_index(model.output.body)
    ref = model.reference[out, 2]
    outs, tilts, main_rows, crank_rows, widths = [], [], [], [], []
    try:
        model.set_flange_load(0.0, tuple(float(m) for m in test.moment))
        for T in test.torques:
            model.set_output_torque(sign * float(T))
            q = solver.solve(0.0, previous_angle=0.0 if solver.q is not None else None)
            outs.append(q[model.output_index])
            tilts.append(model.tilts(q))
            main_rows.append(model.main_bearing_loads(q).row_axial_forces)
            crank_rows.append(_crank_rows(model, q))
            widths.append(width_load_ratios(model, q))
        model.set_output_torque(sign * float(test.te_torque))
        te, prev = [], None
        for s in test.te_angles:
            q = solver.solve(float(s), previous_angle=prev)
            prev = float(s)
            kin = model.kinematic_state(float(s)).poses[out, 2] - ref
            te.append(q[model.output_index] - kin)
    finally:
        model.set_flange_load(0.0, (0.0, 0.0))
        model.set_output_torque(0.0)
    outs = np.array(outs)
    T = np.asarray(test.torques, float)
    return CombinedLoadResult(
        moment=tuple(test.moment), torques=T, output_angle=outs,
        torsional_stiffness=float(abs((T[-1] - T[0]) / (outs[-1] - outs[0]))),
        tilts={k: np.array([t[k] for t in tilts]) for k in tilts[0]},
        main_row_axial_forces=np.array(main_rows, float),
        crank_row_axial_forces=None if crank_rows[0] is None else np.array(crank_rows),
        te_angles=np.asarray(test.te_angles, float), te=np.array(te),
        width_load_ratio={k: np.array([w[k] for w in widths]) for k in widths[0]})
