"""The device backends: the device Newton (:class:`rvtool.solver.device_newton.DeviceNewton`) for
equilibria and the fused stepper (:mod:`rvtool.solver.device_dynamics`) for driven runs, on a
Warp device (``cpu`` or ``cuda``) from the same code.

Both run a model from its design's copy parameters (:func:`rvtool.solver.device_copies.copy_parameters`,
no Exudyn build), so they take what those parameters carry and nothing else: a cycloid design
with lumped bearings, a rigid housing, rigid pins, plain output pins, no friction anchors, and
a built model equal to its design's rebuild (:func:`rvtool.solver.device_dynamics.fused_support`
names every difference); the device Newton also needs the model's regularization springs to be
the parameters'. Every other model whose contact families can be copied
(:func:`rvtool.solver.device_rows.row_reasons`: RV, small-tooth-difference, cycloid designs
outside that set) runs on the device row Newton (:class:`rvtool.solver.device_rows.DeviceRowNewton`:
the families' own Warp kernels, the per-copy Newton step and, on a GPU, the row sums and the
tapered rows' planar mapping on the device; one read-back per iteration); ``stats["path"]``
says which ran. The row Newton takes the linear series closures (elastic ring and output pins,
the RV crank beam and torsion) and reduced structures on port bodies (the ported housing) as
extra unknowns with their constant stiffness blocks (:mod:`rvtool.solver.row_extension`); the
structure's modal coordinates of a result are recovered from its port unknowns. Stick--slip
anchors of the pair families (cycloid pins, involute pairs, circle pairs) run there too: the
committed history is staged into their kernels and committed once per level of a torque path
(:meth:`rvtool.solver.device_rows.DeviceRowNewton.commit`, as Exudyn's continuation; equilibria
never commit, as Exudyn's static solver). Not covered (named reasons): anchors inside a closure or
on plain output pins, closures with a station law (conformal grooves, the ported carrier's
seats), shared output pins, ported wheels.
Torque paths (task ``"torque_path"``): the row Newton's
:class:`~rvtool.solver.device_torque_path.DeviceTorquePath` on one copy, for every model the row
Newton takes (the cycloid included).
The resident path solves every point from its kinematic state (no warm start: the points are
independent); the row path does too up to ``copies`` points, and marches warm-started segments
beyond (``batch.warm_start``, :meth:`rvtool.solver.device_rows.DeviceRowNewton.solve_sequence`). A point the device Newton does not converge is solved by the Exudyn backend's
static solver on the same model, from the same kinematic start, and counted in
``stats["exudyn_points"]`` (the protocol reports it; never hidden).
"""
import time
from dataclasses import dataclass, field

import numpy as np

from ...errors import RvtoolInputError, SolverFailure
from .base import Backend, DrivenHistory, Equilibria, Support, flexible_body_reasons, spatial_body_reasons


COVERED = ("cycloid pins", "output pins (plain)", "involute pairs (external, internal)",
           "rolling elements (needle, cylindrical, ball)", "tapered rollers", "circle pairs (lumped bearings)",
           "elastic ring and output pins (linear closures)", "elastic crank beam and torsion (linear closures)",
           "ported housing (port unknowns)",
           "stick--slip anchors of cycloid pins, involute pairs, circle pairs (history committed per torque-path level)")
"""Contact families the device backend's equilibria cover (module docstring)."""

NOT_COVERED = ("stick--slip anchors inside a series closure or on plain output pins",
               "closures with a station law (pins.groove = 'conformal')",
               "shared output pins",
               "driven runs (fused backend) of models with journal locks or families without device rows "
               "(rvtool.solver.row_dynamics.row_stepper_reasons; the row stepper takes the row Newton's closures, "
               "ported housings and anchors: rvtool.solver.row_closures)",
               "ported carrier (carrier.body = 'ported': the seat closure)", "ported wheels (wheels.body = 'ported')",
               "elastic closures and ported housings on the resident (cycloid copy-parameter) path and the fused "
               "stepper")
"""What the device backends do not run (each is a named reason of :meth:`DeviceBackend.supports`)."""


def _device_reasons(model):
    """(reasons, params) of the copy parameters of ``model`` (see the module docstring)."""
    from ..device_dynamics import fused_support
    sup = fused_support(model)
    if sup.reasons:
        return list(sup.reasons), None
    params = sup.params
    springs = np.zeros(params.n)
    for i, k in model.regularization_stiffness():
        springs[i] = k
    if not np.array_equal(springs, params.spring_k):
        return ["the model's regularization springs differ from the device copies' (build with the default "
                "regularization)"], None
    return [], params


TORQUE_PATH_CYCLOID_REASON = ("on a cycloid drive the device torque path is slower than Exudyn's continuation on "
                              "a CPU (measured: RD-40's quick stiffness sequence 0.08-0.11 s against 0.05 s, "
                              "rvtool.solver.backends.TORQUE_PATH_ORDER); --backend device runs it")
"""Why auto does not take the device torque path of a cycloid model (it supports it)."""

TORQUE_PATH_EXTENDED_REASON = ("the model has elastic closures or a ported structure, which the device row Newton "
                               "takes as extra unknowns (rvtool.solver.row_extension: rv80e solves 119 coordinates "
                               "per copy instead of 21); their place in auto's order is not measured, so auto keeps "
                               "Exudyn's continuation (--backend device runs it)")
"""Why auto does not take the device torque path of a model with extra unknowns (it supports it)."""


#: default copies per device loop of :meth:`DeviceBackend.solve_variants`: bounded by memory (RD-40:
#: ~16 kB of contact rows and tangents per copy; 65,536 copies ~ 1 GB on a GPU) and, on the CPU, by cache
DEFAULT_CHUNK = {"cpu": 2048, "cuda": 65536}


@dataclass
class VariantEquilibria:
    """Equilibria of V variants at A input angles (:meth:`DeviceBackend.solve_variants`): solved
    input angles and flange rotations from the reference (V, A) [rad] (NaN: failed), ``failed``
    (V, A), the largest pin contact force per state (V, A) [N] (None: not asked for), device
    Newton iterations (V, A), points that fell back to Exudyn per variant (V,), and ``stats``."""
    theta_in: np.ndarray
    theta_out: np.ndarray
    failed: np.ndarray
    pin_force: np.ndarray | None
    iterations: np.ndarray
    fallback_points: np.ndarray
    stats: dict = field(default_factory=dict)


class _VariantFallback:
    """The per-variant Exudyn path for single failed (variant, angle) pairs (models cached)."""

    def __init__(self, design, variants, regularization, settings):
        self.design, self.variants, self.reg, self.settings = design, variants, regularization, settings
        self._models = {}

    def solve(self, v, angle, torque, q_guess):
        """(q (3 nb,), solved angle, max pin force) or None."""
        from ...assembly.cycloid import build
        from ..static import StaticSolver
        if v not in self._models:
            m = build(self.variants[v].apply(self.design), bearing_model="lumped", regularization=self.reg)
            idx = np.concatenate([np.asarray(m.mbs.systemData.GetNodeLTGODE2(n), int) for n in m.nodes])
            s = self.settings
            # the per-variant path with its own iteration limit and ladder (not the device budget)
            self._models[v] = (m, StaticSolver(m, abs_tol=s.abs_tol, max_translation=s.max_translation,
                                               max_rotation=s.max_rotation), idx)
        m, solver, idx = self._models[v]
        m.set_output_torque(float(torque))
        solver.q = np.zeros(m.mbs.systemData.ODE2Size())
        solver.q[idx] = q_guess
        try:
            q = solver.solve(float(angle), float(angle))
        except SolverFailure:
            return None
        forces = np.array(list(m.observe(q, m.main_mesh).per_member().values()))
        return q[idx], solver.last_angle, float(np.max(forces))


class DeviceBackend(Backend):
    """Device Newton for equilibria (module docstring). device: Warp device ("cpu", "cuda:0");
    settings: :class:`rvtool.solver.device_newton.DeviceNewtonSettings`; copies: the row Newton's
    batch (copies of the model evaluated per launch; None: min(64, points); measured before the
    variant copies reused their built profile tables: copying RV-40E's families took 1.6 s for
    64, 34 s for 512 copies on the development machine)."""
    name = "device"
    tasks = ("equilibria", "torque_path")

    def __init__(self, *, device="cpu", settings=None, copies=None):
        if copies is not None and (isinstance(copies, bool) or not isinstance(copies, (int, np.integer))
                                   or copies < 1):
            raise RvtoolInputError(f"copies = {copies!r} is outside the valid range [1, inf) (integer; None: "
                                   f"min(64, points), the row Newton's batch)")
        self.device, self.settings, self.copies = device, settings, copies
        self._params = {}

    def _params_of(self, model):
        key = id(model)
        if key not in self._params:
            try:
                self._params[key] = _device_reasons(model)
            except RvtoolInputError as exc:
                self._params[key] = [str(exc)], None
        return self._params[key]

    def path(self, model):
        """(path, reasons): "resident" (the cycloid copy parameters, CUDA graph on cuda), "rows"
        (:mod:`rvtool.solver.device_rows`) or None with the reasons of both."""
        from ..device_rows import row_reasons
        reasons, params = self._params_of(model)
        if not reasons:
            return "resident", []
        rows = row_reasons(model)
        if not rows:
            return "rows", []
        return None, [f"resident path: {r}" for r in reasons] + [f"row path: {r}" for r in rows]

    def supports(self, model, task, run=None):
        if not self._task(task):
            return Support.of([f"device does not implement {task!r} (equilibria and torque paths; driven runs: "
                               "'fused')"])
        spatial = spatial_body_reasons(model) + flexible_body_reasons(model)
        if spatial:
            return Support.of(spatial)
        if task == "torque_path":
            from ..device_rows import row_reasons
            return Support.of([f"device torque path (row Newton): {r}" for r in row_reasons(model)])
        return Support.of(self.path(model)[1])

    def torque_path(self, model, *, input_angle=0.0, initial_torque=None):
        """The device torque path (:class:`rvtool.solver.device_torque_path.DeviceTorquePath`) on one
        copy of the device row Newton (every topology the row Newton runs, the cycloid included;
        a level the device does not reach continues on Exudyn's continuation, counted in
        ``stats()["exudyn_copies"]``)."""
        from ..device_rows import DeviceRowNewton
        from ..device_torque_path import DeviceTorquePath
        sup = self.supports(model, "torque_path")
        if not sup.ok:
            raise RvtoolInputError(f"backend 'device' cannot run a torque path on this model: {'; '.join(sup.reasons)}")
        return DeviceTorquePath(DeviceRowNewton(model, 1, device=self.device), input_angle=input_angle,
                                initial_torque=initial_torque)

    def auto_reason(self, model, task):
        """Equilibria: auto takes the resident path only: the row path's place in auto's measured
        order is not measured yet (on a CPU it is no faster than Exudyn for one model's points; on
        CUDA not measured). Torque paths: auto leaves the cycloid to Exudyn's continuation (measured
        faster there, :data:`rvtool.solver.backends.TORQUE_PATH_ORDER`), and a model with extra
        unknowns (elastic closures, ported structures: not measured). --backend device runs both."""
        if task == "torque_path":
            from ...assembly.spec import CycloidDesign
            from ..device_rows import needs_extension
            if isinstance(getattr(model, "design", None), CycloidDesign):
                return TORQUE_PATH_CYCLOID_REASON
            if needs_extension(model):
                return TORQUE_PATH_EXTENDED_REASON
            return None
        if task == "equilibria" and self.path(model)[0] == "rows":
            return ("the device row path (non-cycloid topology) has no measured place in auto's order yet "
                    "(name --backend device to run it)")
        return None

    def _solve_rows(self, model, batch):
        """Equilibria of a non-cycloid model on the row Newton (module docstring)."""
        from ..device_newton import DeviceNewtonSettings
        from ..device_rows import CONVERGED, DeviceRowNewton
        from ..static import StaticSolver
        angles = np.asarray(batch.input_angles)
        A = len(angles)
        tq = -np.sign(model.ratio) * batch.torque
        copies = min(A, self.copies or 64)
        newton = DeviceRowNewton(model, copies, device=self.device,
                                 settings=self.settings or DeviceNewtonSettings())
        # warm-started segments where the batch asks for it and there are more points than copies
        r = (newton.solve_sequence(angles, tq) if batch.warm_start and A > copies
             else newton.solve(angles, np.full(A, tq)))
        from ..row_extension import model_states
        idx = np.concatenate([np.asarray(model.mbs.systemData.GetNodeLTGODE2(n), int) for n in model.nodes])
        # a reduced structure's coordinates from its port unknowns (row_extension; the closures' stations are
        # condensed in the model: no coordinates of their own)
        qs = model_states(model, r.q, newton.extension)
        theta_in = angles.copy()
        failed = np.flatnonzero(r.status != CONVERGED)
        model.set_output_torque(tq)
        static = None
        for p in failed:
            static = static or StaticSolver(model)
            static.q = np.zeros(qs.shape[1])
            static.q[idx] = newton.kinematic(angles[p:p + 1])[0][:len(idx)]
            try:
                qs[p] = static.solve(float(angles[p]), float(angles[p]))
            except SolverFailure as exc:
                raise SolverFailure(f"device backend: no equilibrium at input angle {angles[p]:.9g} rad (device "
                                    f"row Newton and the Exudyn static solver's ladder failed: {exc})") from None
            theta_in[p] = static.last_angle
        stats = {"points": A, "newton_iterations": int(r.iterations.sum()), "sweeps": int(r.sweeps),
                 "device_loop_s": r.kernels_s + r.scatter_s + r.solve_s, "exudyn_points": int(len(failed)),
                 "path": "rows", "device": str(self.device), "copies": copies,
                 "split": {"setup_s": r.setup_s, "kernels_s": r.kernels_s, "scatter_s": r.scatter_s,
                           "step_s": r.solve_s}}
        return theta_in, qs, stats

    def solve_equilibria(self, model, batch, *, record=None):
        from ..device_newton import CONVERGED, DeviceNewton, DeviceNewtonSettings
        from ..static import StaticSolver
        sup = self.supports(model, "equilibria")
        if not sup.ok:
            raise RvtoolInputError(f"backend 'device' cannot run this model: {'; '.join(sup.reasons)}")
        if record is not None:
            raise RvtoolInputError("the device backend returns no per-point states (record=None; valid: the "
                                   "exudyn backend)")
        t0 = time.perf_counter()
        if self.path(model)[0] == "rows":
            theta_in, qs, stats = self._solve_rows(model, batch)
            return self._equilibria(model, theta_in, qs, stats, t0)
        _, params = self._params_of(model)
        angles = np.asarray(batch.input_angles)
        A = len(angles)
        tq = -np.sign(model.ratio) * batch.torque
        newton = DeviceNewton(params, device=self.device, settings=self.settings or DeviceNewtonSettings())
        vi = np.zeros(A, int)
        kin = params.kinematic(vi, angles)
        r = newton.solve(vi, angles, np.full(A, tq), kin)
        # the model's coordinates of each body (the device copy's local order)
        idx = np.concatenate([np.asarray(model.mbs.systemData.GetNodeLTGODE2(n), int) for n in model.nodes])
        n_model = model.mbs.systemData.ODE2Size()
        model.set_output_torque(tq)
        theta_in = angles.copy()
        qs = np.zeros((A, n_model))
        qs[:, idx] = r.q
        failed = np.flatnonzero(r.status != CONVERGED)
        static = None
        for p in failed:
            static = static or StaticSolver(model)
            static.q = np.zeros(n_model)
            static.q[idx] = kin[p]
            try:
                qs[p] = static.solve(float(angles[p]), float(angles[p]))
            except SolverFailure as exc:
                raise SolverFailure(f"device backend: no equilibrium at input angle {angles[p]:.9g} rad (device "
                                    f"Newton and the Exudyn static solver's ladder failed: {exc})") from None
            theta_in[p] = static.last_angle
        stats = {"points": A, "newton_iterations": int(r.iterations.sum()), "sweeps": int(r.sweeps),
                 "device_loop_s": r.loop_s, "exudyn_points": int(len(failed)), "path": newton.last_path,
                 "device": newton.device}
        return self._equilibria(model, theta_in, qs, stats, t0)

    @staticmethod
    def _equilibria(model, theta_in, qs, stats, t0):
        """:class:`Equilibria` with the model's family peaks of the states qs (model coordinates)."""
        peaks, contact_peaks = {}, {}
        for q in qs:
            for fam, f in model.family_peaks(q).items():
                peaks[fam] = max(peaks.get(fam, 0.0), f)
            for fam, f in model.family_contact_peaks(q).items():
                contact_peaks[fam] = max(contact_peaks.get(fam, 0.0), f)
        ref_out = model.reference_value(model.output)
        return Equilibria(theta_in=theta_in, theta_out=ref_out + qs[:, model.output_index], peak_loads=peaks,
                          peak_contact_loads=contact_peaks, regularization_max=model.regularization_force(qs[-1]),
                          stats=stats, wall_s=time.perf_counter() - t0, q=qs)

    def solve_variants(self, design, variants, batch, *, regularization=(1e4, 100.0), chunk_pairs=None, fallback=True,
                       pin_forces=True, params=None):
        """Equilibria of every (variant, input angle) pair of ``variants`` of the cycloid ``design``
        at ``batch``'s states (a batch of designs: the Monte Carlo's device path). Every pair is one
        copy of the device Newton, in chunks of ``chunk_pairs`` copies (default :data:`DEFAULT_CHUNK`),
        warm-started from the NOMINAL design's equilibrium at the same angle (its elastic deviation
        added to the variant's kinematic state: micrometre tolerances move the equilibrium by
        micrometres, far less than the input angle between two TE points); a copy that fails runs
        the regularization homotopy on the device, and one that still fails goes to the per-variant
        Exudyn path (StaticSolver with its ladder on the variant's build) when ``fallback``, counted
        in ``fallback_points`` and ``stats["fallback_copies"]``. params: the
        :class:`~rvtool.solver.device_copies.CopyParameters` of ``[Variant()] + variants`` with this
        ``regularization`` to reuse (built here if None). Returns :class:`VariantEquilibria`."""
        from ...assembly.variant import Variant
        from ..device_copies import copy_parameters
        from ..device_newton import CONVERGED, DeviceNewton, DeviceNewtonSettings
        t0 = time.perf_counter()
        variants = list(variants)
        angles = np.asarray(batch.input_angles, float)
        V, A = len(variants), len(angles)
        if V < 1:
            raise RvtoolInputError(f"solve_variants needs at least one variant; got {V}")
        tq = -np.sign(design.ratio) * batch.torque
        settings = self.settings or DeviceNewtonSettings()
        # index 0: the nominal design (warm starts); variants at 1..V
        if params is None:
            params = copy_parameters(design, [Variant()] + variants, regularization=regularization)
        elif len(params.variants) != V + 1:
            raise RvtoolInputError(f"params must hold [Variant()] + variants ({V + 1} copies); "
                                   f"got {len(params.variants)}")
        newton = DeviceNewton(params, device=self.device, settings=settings)
        kind = "cpu" if newton.device == "cpu" else "cuda"
        chunk = int(chunk_pairs or DEFAULT_CHUNK[kind])
        if chunk < 1:
            raise RvtoolInputError(f"chunk_pairs = {chunk_pairs!r} is outside the valid range [1, inf)")
        setup_s = time.perf_counter() - t0

        nom = newton.solve(np.zeros(A, int), angles, np.full(A, tq), params.kinematic(np.zeros(A, int), angles))
        nominal_dev = np.where((nom.status == CONVERGED)[:, None], nom.q - params.kinematic(np.zeros(A, int), angles), 0.0)
        vi = 1 + np.repeat(np.arange(V), A)
        ai = np.tile(np.arange(A), V)
        P = V * A
        q = np.empty((P, params.n))
        status = np.empty(P, int)
        iters = np.empty(P, int)
        forces = np.zeros(P)
        loop_s, sweeps, copy_sweeps = nom.loop_s, nom.sweeps, nom.copy_sweeps
        for s0 in range(0, P, chunk):
            sl = slice(s0, min(P, s0 + chunk))
            guess = params.kinematic(vi[sl], angles[ai[sl]]) + nominal_dev[ai[sl]]
            r = newton.solve(vi[sl], angles[ai[sl]], np.full(sl.stop - sl.start, tq), guess, pin_forces=pin_forces)
            q[sl], status[sl], iters[sl] = r.q, r.status, r.iterations
            loop_s += r.loop_s
            sweeps += r.sweeps
            copy_sweeps += r.copy_sweeps
            if pin_forces:
                nw, zb = params.nb - 2, design.pins.n_pins
                forces[sl] = r.pin_forces.reshape(len(r.q), nw, zb, -1).sum(axis=3).max(axis=(1, 2))
        device_s = time.perf_counter() - t0
        theta_in = angles[ai].copy()
        failed = status != CONVERGED
        n_fallback = int(failed.sum())
        fallback_points = failed.reshape(V, A).sum(axis=1)
        if np.any(failed) and fallback:
            fb = _VariantFallback(design, variants, regularization, settings)
            for p in np.flatnonzero(failed):
                guess = params.kinematic(vi[p:p + 1], angles[ai[p:p + 1]])[0] + nominal_dev[ai[p]]
                res = fb.solve(vi[p] - 1, angles[ai[p]], tq, guess)
                if res is not None:
                    q[p], theta_in[p], forces[p] = res
                    failed[p] = False
        q[failed] = np.nan
        forces[failed] = np.nan
        stats = {"pairs": P, "chunks": -(-P // chunk), "chunk_pairs": chunk,
                 "newton_iterations_per_point": float(iters.mean()),
                 "sweeps": int(sweeps), "copy_sweeps": int(copy_sweeps), "device_loop_s": loop_s,
                 "us_per_copy_iteration": 1e6 * loop_s / max(copy_sweeps, 1),
                 "fallback_copies": n_fallback, "failed_copies": int(failed.sum()),
                 "nominal_failed_points": int(np.sum(nom.status != CONVERGED)),
                 "path": newton.last_path, "device": newton.device, "setup_s": setup_s,
                 "device_s": device_s, "wall_s": time.perf_counter() - t0}
        return VariantEquilibria(theta_in=theta_in.reshape(V, A), theta_out=q[:, params.output_index].reshape(V, A),
                                 failed=failed.reshape(V, A), pin_force=forces.reshape(V, A) if pin_forces else None,
                                 iterations=iters.reshape(V, A), fallback_points=fallback_points, stats=stats)


FUSED_PATHS = ("fused_stepper", "row_stepper")
"""The driven-run paths of :class:`FusedBackend` (``stats["path"]`` of a run, :meth:`FusedBackend.path`)."""

ROW_STEPPER_AUTO_REASON = ("the model runs on the row stepper (rvtool.solver.row_dynamics), whose place in auto's "
                           "order is measured on rv40e only (one CPU core, cases/benchmarks/bench_fused_rv.py), so auto "
                           "keeps Exudyn's path for driven runs of models the fused stepper does not take "
                           "(--backend fused runs it)")
"""Why auto does not take the fused backend's row stepper (it supports the model)."""


class FusedBackend(Backend):
    """Driven runs off Exudyn (module docstring), on one of two paths (:meth:`path`):

    * ``"fused_stepper"``: the whole generalized-alpha step of every copy in one Warp launch per
      ``steps_per_launch`` steps (:mod:`rvtool.solver.device_dynamics`; the cycloid copy-parameter
      set: lumped bearings, rigid housing, plain output pins, no anchors). A failed run raises
      :class:`SolverFailure` with its state saved;
    * ``"row_stepper"``: every other model whose contact families all have device rows (RV,
      small-tooth-difference, a cycloid with rolling elements; with the device row Newton's
      closures and ported housings as unknowns of the step and anchors committed per accepted
      step, :mod:`rvtool.solver.row_closures`;
      :func:`rvtool.solver.row_dynamics.row_stepper_reasons` names what it refuses): Exudyn's
      generalized-alpha step on the device families' rows, summed on the device, the Newton
      iterations one captured graph each (:func:`rvtool.solver.row_dynamics.row_driven_run`). Its
      static start is Exudyn's StaticSolver, as the Exudyn path's. A failed run raises
      :class:`SolverFailure` (no state saved).

    Neither hands over to Exudyn. ``auto`` takes the fused stepper only (:meth:`auto_reason`)."""
    name = "fused"
    tasks = ("dynamic",)

    def __init__(self, *, device=None):
        self.device = device

    def path(self, model, run=None):
        """(path, reasons): the path of :data:`FUSED_PATHS` that runs ``model`` (and the
        :class:`DrivenRun` ``run``, when given), the fused stepper first; None with the reasons of
        both."""
        from ..device_dynamics import fused_support
        from ..row_dynamics import row_stepper_reasons
        spec = run.run_spec if run is not None else None
        # neither path: planar rigid copies only (floating flexible bodies, any topology, named first)
        spatial = spatial_body_reasons(model) + flexible_body_reasons(model)
        if spatial:
            return None, spatial
        try:
            reasons = list(fused_support(model, spec).reasons)
        except RvtoolInputError as exc:
            reasons = [str(exc)]
        if not reasons:
            return "fused_stepper", []
        rows = row_stepper_reasons(model, spec)
        if not rows:
            return "row_stepper", []
        return None, [f"fused stepper: {r}" for r in reasons] + [f"row stepper: {r}" for r in rows]

    def supports(self, model, task, run=None):
        if not self._task(task):
            return Support.of([f"fused does not implement {task!r} (driven runs only; equilibria: 'device')"])
        reasons = list(self.path(model, run)[1])
        if run is not None and run.observers:
            reasons.append("observers are recorded by the Exudyn driver only")
        return Support.of(reasons)

    def auto_reason(self, model, task):
        """auto takes the fused stepper; a model on the row stepper stays on Exudyn
        (:data:`ROW_STEPPER_AUTO_REASON`), and the reason names why the fused stepper does not take
        it (the figures ``rvtool analyze`` writes by default do not change)."""
        if task != "dynamic" or self.path(model)[0] != "row_stepper":
            return None
        from ..device_dynamics import fused_support
        try:
            fused = list(fused_support(model).reasons)
        except RvtoolInputError as exc:
            fused = [str(exc)]
        return "; ".join([ROW_STEPPER_AUTO_REASON] + [f"fused stepper: {r}" for r in fused])

    def step_dynamic(self, model, run):
        from ..device_dynamics import DeviceDynamicsSettings, dynamic_te_fused, fused_support
        reasons = self.supports(model, "dynamic", run).reasons
        if reasons:
            raise RvtoolInputError(f"backend 'fused' cannot run this model: {'; '.join(reasons)}")
        path = self.path(model, run)[0]
        device = run.device or self.device or run.run_spec.device
        settings = DeviceDynamicsSettings.from_run_spec(run.run_spec)
        if path == "row_stepper":
            return self._row_stepper(model, run, settings, device)
        sup = fused_support(model, run.run_spec)
        if run.on_start is not None:
            run.on_start()
        out = dynamic_te_fused(model.design, torque=run.torque, speed_rpm=run.speed_rpm, duration=run.duration,
                               settings=settings, device=device, out_dir=run.out_dir, params=sup.params)
        return DrivenHistory(t=out["t"], theta_in=out["theta_in"], theta_out=out["theta_out"], record=out["record"],
                             omega_in=out["omega_in"], extras={"torque_in": out["torque_in"],
                                                               "peak_loads": out["peak_loads"],
                                                               "device_run": out["device_run"],
                                                               "stats": {"path": "fused_stepper",
                                                                         "device": str(device)}})

    @staticmethod
    def _row_stepper(model, run, settings, device):
        """The driven run on :func:`rvtool.solver.row_dynamics.row_driven_run` from Exudyn's static
        start (``run.on_start`` after it, as on the Exudyn path)."""
        from ..driver import RunRecord
        from ..row_dynamics import row_driven_run
        from ..static import StaticSolver
        model.set_output_torque(-np.sign(model.ratio) * float(run.torque))
        q0 = StaticSolver(model).solve(0.0)
        if run.on_start is not None:
            run.on_start()
        out = row_driven_run(model, torque=run.torque, speed_rpm=run.speed_rpm, duration=run.duration,
                             settings=settings, device=device, q0=q0)
        steps = out["step"][1:]
        rec = RunRecord(accepted_steps=out["accepted"], attempts=out["accepted"] + out["rejected"],
                        rejected_steps=out["rejected"], newton_iterations=out["newton"],
                        jacobian_updates=out["newton"], min_step_s=float(np.min(steps)) if len(steps) else np.inf,
                        max_step_s=float(np.max(steps)) if len(steps) else 0.0, end_time=float(out["t"][-1]),
                        wall_s=out["wall_s"], cpu_s=out["cpu_s"])
        stats = {"path": "row_stepper", "device": str(device), "evaluations": out["evaluations"],
                 "tangent_gathers": out["tangent_gathers"], "device_step": out["device_step"],
                 "split_cpu_s": {"evaluate": out["evaluate_cpu_s"], "tangents": out["tangents_cpu_s"],
                                 "step": out["step_cpu_s"]}}
        return DrivenHistory(t=out["t"], theta_in=out["theta_in"], theta_out=out["theta_out"], record=rec,
                             omega_in=out["omega_in"], extras={"torque_in": out["torque_in"], "stats": stats})
