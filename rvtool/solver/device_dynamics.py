"""Device dynamics: driven runs of B copies of a cycloid reducer with the fused stepper.

The fused stepper (:mod:`warp_contacts.fused_step`) advances every copy by whole
generalized-alpha steps inside one Warp launch (one thread per copy, ``steps_per_launch``
accepted steps per launch), on ``cpu`` or ``cuda`` from the same code. The model side is
:class:`rvtool.solver.device_copies.CopyParameters` (per-copy contact rows without an Exudyn
build); this module adds the bodies' masses and inertias (:func:`rvtool.assembly.cycloid.body_masses`,
as the Exudyn build), the prescribed input motion, the output load and the integrator
settings, and records at every accepted step what the dynamic TE protocol needs: time, input
and output angle, the drive torque, the peak pin, output-pin and bearing loads, the step and
its Newton iterations.

:func:`dynamic_te_fused` is the single-system driven run with the result structure of
:func:`rvtool.protocols.precision.dynamic_te` (Exudyn is its oracle in the tests). Its start is
the same: the quasi-static loaded state at input angle 0 (solved here by the device Newton,
:class:`rvtool.solver.device_newton.DeviceNewton`, the oracle of which is Exudyn's
StaticSolver), the kinematic velocities, constant input speed, constant output torque, no
regularization springs (``set_input_motion`` switches them off in the Exudyn run).

Failure (documented choice): a copy whose step would fall below ``min_step`` is FAILED and
stops without changing the others. :func:`dynamic_te_fused` then fails loudly: it raises
:class:`rvtool.errors.SolverFailure` with the copy's last accepted state saved to
``out_dir/fused_failure_state.npz`` (as :func:`rvtool.solver.driver.simulate` does); it does
not hand over to the Exudyn path (a silent change of solver would change the figure's meaning).

Supported models (others raise :class:`RvtoolInputError`): the device Newton's set (cycloid,
rigid housing, lumped bearings, plain output pins), without friction anchors.
"""
import os
import time
from dataclasses import dataclass, field

import numpy as np

from warp_contacts import circle_pairs_ref as cref
from warp_contacts import cycloid_pins_ref as pref
from warp_contacts.batched_newton_ref import gather_bodies, gather_rows
from warp_contacts.fused_step_ref import (ACTIVE, C_ACCEPTED, C_NEWTON, C_REJECTED, DONE, FAILED, H_BEARING, H_INPUT,
                                          H_NEWTON, H_OUTPUT, H_OUTPUT_PIN, H_PIN, H_STEP, H_TIME, H_TORQUE, M_ANGLE,
                                          M_SPEED, N_MOTION, N_SETTINGS, S_ABS_TOL, S_ALPHA_F, S_ALPHA_M, S_BETA,
                                          S_GAMMA, S_H_MIN, S_H_NOM, S_MAX_IT, S_RECOVERY, S_RECOVERY_ITERATIONS,
                                          S_REL_TOL, S_T_END,
                                          alpha_parameters)

from ..errors import RvtoolInputError, SolverFailure
from ..validation import check_integer, check_positive, check_range


@dataclass(frozen=True, kw_only=True)
class DeviceDynamicsSettings:
    """Integrator settings of the fused stepper (SI units).

    step [s]: nominal (maximum) step. min_step [s]: the smallest step a rejected copy may
    retry with before it fails (None: step 1e-4, as RunSpec.minimum_step).
    spectral_radius [-]: rho_inf of Eq. (alpha_parameters), in [0, 1].
    abs_tol [N], rel_tol [-]: Exudyn's Newton criterion (residual norm, relative to the
    initial residual). max_newton_iterations: per attempt.
    recovery_steps, recovery_iterations: a reduced step doubles again after recovery_steps
    accepted steps when the step took fewer than recovery_iterations - 1 Newton iterations
    (Exudyn's adaptiveStepRecoverySteps, adaptiveStepRecoveryIterations; defaults Exudyn's).
    steps_per_launch: accepted steps per copy in one launch (one host read of the history each).
    """
    step: float
    min_step: float | None = None
    spectral_radius: float = 0.8
    abs_tol: float = 1e-8
    rel_tol: float = 1e-9
    max_newton_iterations: int = 12
    recovery_steps: int = 10
    recovery_iterations: int = 7
    steps_per_launch: int = 64

    def __post_init__(self):
        check_positive("device_dynamics.step", self.step)
        if self.min_step is not None:
            check_range("device_dynamics.min_step", self.min_step, 0.0, self.step, low_open=True)
        check_range("device_dynamics.spectral_radius", self.spectral_radius, 0.0, 1.0)
        check_positive("device_dynamics.abs_tol", self.abs_tol)
        check_range("device_dynamics.rel_tol", self.rel_tol, 0.0, 1.0, low_open=True)
        for nm in ("max_newton_iterations", "recovery_steps", "recovery_iterations", "steps_per_launch"):
            check_integer(f"device_dynamics.{nm}", getattr(self, nm), 1)

    @property
    def minimum_step(self):
        return self.min_step if self.min_step is not None else self.step * 1e-4

    @classmethod
    def from_run_spec(cls, spec, **kw):
        """The settings of a :class:`rvtool.solver.run_spec.RunSpec` (step, minimum step, spectral
        radius, tolerances, Newton iterations); full Newton only."""
        if spec.newton_mode != "full":
            raise RvtoolInputError(f"run_spec.newton_mode = {spec.newton_mode!r}; the fused stepper runs ['full']")
        return cls(step=spec.step, min_step=spec.minimum_step, spectral_radius=spec.spectral_radius,
                   abs_tol=spec.abs_tol, rel_tol=spec.rel_tol, max_newton_iterations=spec.max_newton_iterations, **kw)

    def vector(self, end_time):
        """The stepper's settings vector (columns S_* of :mod:`warp_contacts.fused_step_ref`)."""
        s = np.zeros(N_SETTINGS)
        s[[S_ALPHA_M, S_ALPHA_F, S_BETA, S_GAMMA]] = alpha_parameters(self.spectral_radius)
        s[S_ABS_TOL], s[S_REL_TOL], s[S_MAX_IT] = self.abs_tol, self.rel_tol, self.max_newton_iterations
        s[S_H_NOM], s[S_H_MIN], s[S_T_END], s[S_RECOVERY] = self.step, self.minimum_step, end_time, self.recovery_steps
        s[S_RECOVERY_ITERATIONS] = self.recovery_iterations
        return s


def check_supported(params):
    """RvtoolInputError for models outside the fused stepper's set (see the module docstring)."""
    if np.any(params.pin_i[:, :, pref.J_FRICTION] == cref.FRICTION_ANCHOR):
        raise RvtoolInputError("pin_contact friction model 'anchor' is not supported by the fused stepper; valid: "
                               "frictionless or regularized pin friction")
    if np.any(params.brg_i[:, cref.I_FRICTION] == cref.FRICTION_ANCHOR):
        raise RvtoolInputError("bearing friction anchors are not supported by the fused stepper; valid: frictionless "
                               "or regularized lumped bearings")


FUSED_ELEMENTS = ("pins", "output_pins", "bearings")
"""The contact elements of a built model the fused stepper carries (no loss elements)."""


@dataclass(frozen=True)
class FusedSupport:
    """Whether the fused stepper can run a built model: ``reasons`` (empty: it can) and ``params``,
    the :class:`CopyParameters` of ``[Variant()]`` of the model's design, checked equal to the
    model (None where a reason was found before they could be built or compared)."""
    reasons: tuple
    params: object = None

    @property
    def eligible(self):
        return not self.reasons


FUSED_SET_TYPES = {"CycloidPinSet": "cycloid pins", "OutputPinEvaluator": "plain output pins",
                   "ContactSetEvaluator": "lumped circle-pair bearings"}
"""Contact-set types whose rows the fused kernel evaluates (:mod:`warp_contacts.fused_step`)."""


def unfused_element_reasons(model):
    """A named reason for every contact element of ``model`` whose rows the fused kernel does not
    evaluate (its set type is not in :data:`FUSED_SET_TYPES`): what a fused stepper for that
    topology would still have to carry (issue 31: RV-40E's involute pairs, needle and ball rolling
    elements, tapered crank bearings)."""
    out = []
    for el in model.contact_elements():
        tname = type(el.evaluator).__name__
        if tname not in FUSED_SET_TYPES:
            out.append(f"contact element {el.evaluator.name!r} ({tname}): no rows of this set type in the fused "
                       f"kernel (it evaluates {', '.join(f'{v} ({k})' for k, v in FUSED_SET_TYPES.items())})")
    return out


def fused_support(model, run_spec=None):
    """:class:`FusedSupport` of a built ``model`` (and ``run_spec``, when given) for the fused stepper.

    The fused path rebuilds the model from ``model.design`` (:func:`copy_parameters`); the build
    options that are not part of the design are checked against the model through its public
    fields, and the rebuilt contact rows against the model's: the topology (a cycloid design
    and kinematics), the contact elements (pins, output pins, bearings: no bearing-friction
    loss element), no journal locks (``rigid_supports=False``), float64 contacts, the same
    fixed coordinates and body reference poses, the cycloid-pin rows bit for bit, the same
    number of output-pin and bearing rows (the lumped bearings: one row per bearing; a
    rolling-element set has one per element), no gap offsets set on the pins after the build,
    no friction anchors (:func:`check_supported`); a housing other than rigid and elastic pin
    supports are refused by :func:`copy_parameters`. Not seen from outside the model (documented
    assumption): friction coefficients changed after the build with ``set_friction``.
    Run settings: full Newton, no strict acceptance or rotational residual scaling, adaptive
    steps, float64 (the fused stepper's integrator is Exudyn's with these settings)."""
    from ..assembly.cycloid import CycloidKinematics
    from ..assembly.spec import CycloidDesign
    from .device_copies import copy_parameters
    from ..model.reducer import Family
    from ..assembly.variant import Variant
    reasons = []
    if run_spec is not None:
        for key, val, ok in (("newton_mode", run_spec.newton_mode, "'full'"),
                             ("strict_abs_tol", run_spec.strict_abs_tol, "None"),
                             ("reference_length", run_spec.reference_length, "None"),
                             ("adaptive", run_spec.adaptive, "True"),
                             ("precision", run_spec.precision, "'float64'")):
            if repr(val) != ok:
                reasons.append(f"run_spec.{key} = {val!r} (the fused stepper runs {ok})")
    if not (isinstance(model.design, CycloidDesign) and isinstance(model.kinematics, CycloidKinematics)):
        reasons.append(f"topology {type(model.design).__name__}: the fused stepper runs cycloid reducers only "
                       f"(its kernel, warp_contacts.fused_step, carries a cycloid drive's input shaft, wheels and "
                       f"output flange; this model's bodies are {list(model.body_names)})")
        reasons.extend(unfused_element_reasons(model))
        return FusedSupport(tuple(reasons))
    from .backends.base import flexible_body_reasons
    if flexible_body_reasons(model):
        reasons.extend(flexible_body_reasons(model))
        return FusedSupport(tuple(reasons))
    extra = sorted(set(model.elements) - set(FUSED_ELEMENTS))
    if extra:
        reasons.append(f"contact elements {extra} (bearing_friction.model = {model.design.bearing_friction.model!r}); "
                       f"the fused stepper carries {list(FUSED_ELEMENTS)} only (valid: bearing_friction.model 'none')")
    if model.journal_locks:
        reasons.append("rigid_supports=True (journal locks); the fused stepper runs rigid_supports=False")
    precision = getattr(model.pin_set, "precision", "float64")
    if precision != "float64":
        reasons.append(f"precision = {precision!r}; the fused stepper runs 'float64'")
    try:
        params = copy_parameters(model.design, [Variant()])
        check_supported(params)
    except RvtoolInputError as e:
        reasons.append(str(e))
        return FusedSupport(tuple(reasons))
    if set(np.flatnonzero(~params.free)) != set(model.fixed_coordinates()):
        reasons.append("the model's fixed coordinates differ from the design's (drive and bodies.* locks)")
    if not np.array_equal(model.reference, params.reference[0]):
        reasons.append("the model's body reference poses differ from the design's")
    if not (np.array_equal(model.pin_set.fparams, params.pin_f[0])
            and np.array_equal(model.pin_set.iparams, params.pin_i[0])):
        reasons.append("the model's cycloid-pin rows differ from those rebuilt from model.design")
    n_brg = sum(len(model.family_rows(f)[1]) for f in (Family.ECCENTRIC_BEARINGS, Family.MAIN_BEARINGS,
                                                        Family.INPUT_BEARINGS) if f in model.families)
    if n_brg != len(params.brg_i):
        reasons.append(f"{n_brg} bearing rows against {len(params.brg_i)} lumped bearings: the fused stepper runs "
                       "bearing_model='lumped' (valid: 'lumped')")
    if Family.OUTPUT_PINS not in model.families:
        reasons.append("the model has no output pins")
    if any(v != 0.0 for v in model.gap_offsets(Family.PINS).values()):
        reasons.append("gap offsets set on the pins after the build (set_gap_offsets) are not in model.design")
    return FusedSupport(tuple(reasons), None if reasons else params)


def model_arrays(params, variant_index, *, torque, motion, settings_vector):
    """The :class:`warp_contacts.fused_step.FusedStepper` / :class:`ReferenceModel` keyword arrays
    of copies ``variant_index`` (B,) of ``params``: global rows, masses, motion (B, N_MOTION)
    and output torques (B,) [N m]."""
    from ..assembly.cycloid import body_masses
    check_supported(params)
    vi = np.asarray(variant_index, np.int64)
    B, nb = len(vi), params.nb
    ground = B * nb
    masses = np.array(body_masses(params.design), float)            # (nb, 2): mass, polar inertia
    mass = np.repeat(masses[:, [0, 0, 1]].reshape(1, -1), B, axis=0)
    motion = np.ascontiguousarray(np.broadcast_to(motion, (B, N_MOTION)), float)
    return dict(
        pin_f=gather_rows(params.pin_f, vi),
        pin_i=gather_bodies(params.pin_i, vi, [pref.J_BODY_A, pref.J_BODY_B], nb, ground),
        tables=params.tables, window=params.window, analytic=params.analytic,
        op_f=gather_rows(np.broadcast_to(params.op_f, (1,) + params.op_f.shape), np.zeros(B, int)),
        op_i=gather_bodies(params.op_i[None], np.zeros(B, int), [0, 1], nb, ground),
        stations=params.stations,
        brg_f=gather_rows(params.brg_f, vi),
        brg_i=gather_bodies(params.brg_i[None], np.zeros(B, int), [cref.I_BODY_A, cref.I_BODY_B], nb, ground),
        loc_pin=params.loc_pin, loc_op=params.loc_op, loc_brg=params.loc_brg,
        reference=params.reference[vi].reshape(B, -1), mass=mass, free=params.free,
        input_index=params.input_index, output_index=params.output_index, motion=motion,
        torque=np.broadcast_to(np.asarray(torque, float), (B,)).copy(), settings=settings_vector)


def kinematic_velocities(params, variant_index, angle, speed):
    """(B, n) kinematic velocities [m/s, rad/s] of the copies at input angle [rad] and input
    speed [rad/s] (the builder's :meth:`CycloidKinematics.velocities` with each copy's
    eccentricity); the fixed coordinates other than the drive are held at zero."""
    from ..assembly.cycloid import CycloidKinematics
    from ..geometry.eccentric import journal_velocity
    vi = np.asarray(variant_index, np.int64)
    kin = CycloidKinematics(params.design)
    nb, nw = params.nb, params.nb - 2
    v = np.zeros((len(vi), nb, 3))
    v[:, 0, 2] = speed
    vx, vy = journal_velocity(params.eccentricity[vi][:, None], kin.phases[None, :], angle, speed)
    v[:, 1:nw + 1, 0], v[:, 1:nw + 1, 1] = vx, vy
    v[:, 1:, 2] = -speed / kin.z_g
    v = v.reshape(len(vi), -1)
    fixed = ~params.free
    fixed[params.input_index] = False
    v[:, fixed] = 0.0
    return v


@dataclass
class DeviceRun:
    """Histories of B copies (lists of arrays, one per copy, the accepted steps in order; the
    start state at t = 0 first): t [s], theta_in, theta_out [rad], torque_in [N m], peak loads
    pin / output_pin / bearing [N], step [s], newton; status (B,); accepted, rejected, newton
    (B,) totals; wall, kernel and host times [s]; launches and host reads."""
    t: list
    theta_in: list
    theta_out: list
    torque_in: list
    peak_pin: list
    peak_output_pin: list
    peak_bearing: list
    step: list
    newton: list
    status: np.ndarray
    accepted: np.ndarray
    rejected: np.ndarray
    newton_total: np.ndarray
    wall_s: float = 0.0
    kernel_s: float = 0.0
    host_s: float = 0.0
    launches: int = 0
    host_reads: int = 0
    state: dict = field(default_factory=dict)


class DeviceDynamics:
    """B copies (variant_index into ``params``) under a prescribed input motion and output torque
    on one Warp device (model: ``params``; solver: :class:`warp_contacts.fused_step.FusedStepper`)."""

    def __init__(self, params, variant_index, *, torque, motion, end_time, device="cpu",
                 settings: DeviceDynamicsSettings):
        from warp_contacts.fused_step import FusedStepper
        check_positive("device_dynamics.end_time", end_time)
        if not isinstance(settings, DeviceDynamicsSettings):
            raise RvtoolInputError("settings must be a DeviceDynamicsSettings")
        self.params, self.settings, self.end_time = params, settings, float(end_time)
        self.variant_index = np.asarray(variant_index, np.int64)
        self.arrays = model_arrays(params, self.variant_index, torque=torque, motion=motion,
                                   settings_vector=settings.vector(end_time))
        self.stepper = FusedStepper(device=device, **self.arrays)
        self.device = self.stepper.device

    def start(self, q0, v0):
        """Initial state (B, n) displacements q0 and velocities v0 at t = 0; the fixed coordinates
        take the prescribed motion; the initial accelerations are Exudyn's (one launch)."""
        B, n = self.stepper.B, self.stepper.n
        q0 = np.array(np.broadcast_to(q0, (B, n)), float)
        v0 = np.array(np.broadcast_to(v0, (B, n)), float)
        if not (np.all(np.isfinite(q0)) and np.all(np.isfinite(v0))):
            raise RvtoolInputError("device_dynamics start state must be finite (valid: finite q0, v0)")
        fixed = ~self.params.free
        mo = self.arrays["motion"]
        q0[:, fixed] = 0.0
        v0[:, fixed] = 0.0
        q0[:, self.params.input_index] = mo[:, M_ANGLE]
        v0[:, self.params.input_index] = mo[:, M_SPEED]
        z = np.zeros((B, n))
        self.stepper.set_state(q=q0, v=v0, a=z, abar=z, t=np.zeros(B), h=np.full(B, self.settings.step))
        self.stepper.initialize_accelerations()
        self._q0, self._v0 = q0, v0

    def run(self, on_launch=None):
        """Launch until every copy is DONE or FAILED; returns a :class:`DeviceRun`. on_launch(t_min):
        called after each launch with the smallest copy time [s] (progress)."""
        import warp as wp
        B = self.stepper.B
        K = self.settings.steps_per_launch
        pi, po = self.params.input_index, self.params.output_index
        ref_out = self.arrays["reference"][:, po]
        cols = [H_TIME, H_INPUT, H_OUTPUT, H_TORQUE, H_PIN, H_OUTPUT_PIN, H_BEARING, H_STEP, H_NEWTON]
        start = [np.zeros(B), self._q0[:, pi], ref_out + self._q0[:, po], np.full(B, np.nan), np.full(B, np.nan),
                 np.full(B, np.nan), np.full(B, np.nan), np.zeros(B), np.zeros(B)]
        chunks = [[[s[p]] for s in start] for p in range(B)]
        kernel_s = host_s = 0.0
        launches = reads = 0
        t0 = time.perf_counter()
        status = np.full(B, ACTIVE)
        while np.any(status == ACTIVE):
            c = time.perf_counter()
            hist = self.stepper.launch(K)
            wp.synchronize_device(self.device)
            c1 = time.perf_counter()
            h = hist.numpy().copy()          # on the CPU numpy() aliases the buffer the next launch overwrites
            cnt = self.stepper.recorded()
            status = self.stepper.status()
            reads += 3
            for p in range(B):
                k = cnt[p]
                for j, col in enumerate(cols):
                    chunks[p][j].append(h[p, :k, col])
            launches += 1
            kernel_s += c1 - c
            host_s += time.perf_counter() - c1
            if on_launch is not None:
                on_launch(float(np.min([chunks[p][0][-1][-1] if len(chunks[p][0][-1]) else 0.0 for p in range(B)])))
        wall = time.perf_counter() - t0
        st = self.stepper.state()
        cat = [[np.concatenate([np.atleast_1d(x) for x in chunks[p][j]]) for p in range(B)] for j in range(len(cols))]
        return DeviceRun(t=cat[0], theta_in=cat[1], theta_out=cat[2], torque_in=cat[3], peak_pin=cat[4],
                         peak_output_pin=cat[5], peak_bearing=cat[6], step=cat[7], newton=cat[8], status=status,
                         accepted=st["counters"][:, C_ACCEPTED], rejected=st["counters"][:, C_REJECTED],
                         newton_total=st["counters"][:, C_NEWTON], wall_s=wall, kernel_s=kernel_s,
                         host_s=wall - kernel_s, launches=launches, host_reads=reads, state=st)


def _save_failure(out_dir, run, p):
    """The failed copy's last accepted state as ``out_dir/fused_failure_state.npz``; its path or None."""
    if out_dir is None:
        return None
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "fused_failure_state.npz")
    st = run.state
    np.savez(path, time=st["t"][p], step=st["h"][p], q=st["q"][p], v=st["v"][p], a=st["a"][p], abar=st["abar"][p])
    return path


def driven_copies(params, variant_index, *, torque, speed_rpm, duration, settings: DeviceDynamicsSettings,
                  device="cpu", on_launch=None):
    """The dynamic TE protocol's driven run for copies ``variant_index`` (B,) of ``params`` in one
    batched run: each copy's quasi-static loaded state at input angle 0 (the device Newton, from
    the copy's kinematic state), its kinematic velocities, constant input speed [rpm], constant
    output torque [N m] (resisting the nominal rotation, as the protocol), ``duration`` [s].
    Copies whose static start does not converge are not run. Returns a dict: "static"
    (:class:`DeviceSolve` of all B), "started" (B,) bool, "run" (:class:`DeviceRun` of the started
    copies, in order), "te" (B,) list of Eq. (obs_te) histories [rad] on each copy's accepted steps
    (None: not started), "omega_in" [rad/s]."""
    from ..observe.transmission import transmission_error
    from .device_newton import DeviceNewton
    check_positive("duration", duration)
    check_positive("speed_rpm", speed_rpm)
    vi = np.asarray(variant_index, np.int64)
    B = len(vi)
    omega = speed_rpm * 2 * np.pi / 60.0
    ratio = params.design.ratio
    t_out = -np.sign(ratio) * torque
    kin = params.kinematic(vi, np.zeros(B))
    static = DeviceNewton(params, device=device).solve(vi, np.zeros(B), np.full(B, t_out), kin)
    started = np.asarray(static.converged, bool)
    te, run = [None] * B, None
    if np.any(started):
        vs = vi[started]
        motion = np.zeros((len(vs), N_MOTION))
        motion[:, M_SPEED] = omega
        dyn = DeviceDynamics(params, vs, torque=np.full(len(vs), t_out), motion=motion, end_time=duration,
                             device=device, settings=settings)
        dyn.start(static.q[started], kinematic_velocities(params, vs, 0.0, omega))
        run = dyn.run(on_launch=on_launch)
        for p, b in enumerate(np.flatnonzero(started)):
            te[b] = transmission_error(run.theta_in[p], run.theta_out[p], ratio)
    return {"static": static, "started": started, "run": run, "te": te, "omega_in": omega}


def dynamic_te_fused(design, *, torque, speed_rpm, duration, settings: DeviceDynamicsSettings, device="cpu",
                     out_dir=None, params=None, on_launch=None):
    """Driven rotation of ``design`` at constant input speed [rpm] against the output torque
    [N m] over ``duration`` [s] with the fused stepper; the result structure of
    :func:`rvtool.protocols.precision.dynamic_te` ("t", "theta_in", "theta_out", "te",
    "record", "t_uniform", "te_uniform", "omega_in") plus "torque_in", "peak_loads",
    "device_run". params: a prebuilt :class:`CopyParameters` of ``[Variant()]`` (else built).
    Raises SolverFailure (state saved in out_dir) if the run fails."""
    from .device_copies import copy_parameters
    from ..assembly.variant import Variant
    from .driver import RunRecord
    if params is None:
        params = copy_parameters(design, [Variant()])
    res = driven_copies(params, [0], torque=torque, speed_rpm=speed_rpm, duration=duration, settings=settings,
                        device=device, on_launch=on_launch)
    static, run, omega = res["static"], res["run"], res["omega_in"]
    if not static.converged[0]:
        raise SolverFailure("fused dynamic TE: the quasi-static start at input angle 0 did not converge "
                            f"(residual {static.residual[0]:.3e} N)", None)
    if run.status[0] == FAILED:
        path = _save_failure(out_dir, run, 0)
        raise SolverFailure(f"fused stepper: step below min_step {settings.minimum_step:g} s at "
                            f"t = {run.state['t'][0]:.6g} s (copy 0); last accepted state: {path}", path)
    t, th_in, th_out = run.t[0], run.theta_in[0], run.theta_out[0]
    te = res["te"][0]
    steps = run.step[0][1:]
    rec = RunRecord(accepted_steps=int(run.accepted[0]), attempts=int(run.accepted[0] + run.rejected[0]),
                    rejected_steps=int(run.rejected[0]), newton_iterations=int(run.newton_total[0]),
                    jacobian_updates=int(run.newton_total[0]), min_step_s=float(np.min(steps)),
                    max_step_s=float(np.max(steps)), end_time=float(t[-1]), wall_s=run.wall_s)
    n_uniform = max(16, int(round(duration / settings.step)))
    t_u = np.linspace(0.0, duration, n_uniform, endpoint=False)
    peaks = {"pins": float(np.nanmax(run.peak_pin[0])), "output_pins": float(np.nanmax(run.peak_output_pin[0])),
             "bearings": float(np.nanmax(run.peak_bearing[0]))}
    return {"t": t, "theta_in": th_in, "theta_out": th_out, "te": te, "record": rec, "t_uniform": t_u,
            "te_uniform": np.interp(t_u, t, te), "omega_in": omega, "torque_in": run.torque_in[0],
            "peak_loads": peaks, "device_run": run}


__all__ = ["DeviceDynamics", "DeviceDynamicsSettings", "DeviceRun", "FusedSupport", "driven_copies", "dynamic_te_fused",
           "fused_support", "kinematic_velocities", "model_arrays", "check_supported", "ACTIVE", "DONE", "FAILED"]
