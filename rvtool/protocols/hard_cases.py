"""Hard cases for the implicit driver: driven runs with prescribed input-angle and output-torque
histories, judged by declared pass/fail criteria.

Each case (:data:`CASES`) is a :class:`HardCase`: design changes, input angle history
theta_in(t) [rad], output torque history T(t) [N m], duration and run settings, and
optional fault injection. :func:`run_case` starts from the static equilibrium at
theta_in(0) under T(0) with kinematic velocities at the initial input speed, runs the
generalized-alpha driver, records per accepted step the input and output angles, the
pin-mesh normal-force sum and the kinetic energy, and returns a result dict with
``passed``, ``criteria`` (name -> {value, limit, passed}), ``rejected_steps``,
``min_step_s``, ``max_residual`` and ``message``. A run that fails returns the
driver's message and the saved-state path (never partial results as success).
"""
import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from warp_contacts.circle_pairs_ref import O_FN

from ..solver.continuation import Continuation
from ..units import ARCSEC_PER_RAD
from .precision import transmission_error


@dataclass(frozen=True, kw_only=True)
class HardCase:
    """A stress test: name, design changes, histories and settings.

    design_changes: dict of section -> {field: value} for :func:`rvtool.assembly.spec.replace`.
    speed_rpm: input speed [rpm] (constant, or the final speed of a run-up).
    run_up_s: linear speed ramp 0 -> speed_rpm over this time [s] (None: constant speed;
        0.0 with start_from_rest: a speed step at t = 0 from rest).
    start_from_rest: initial velocities zero (else kinematic at the initial speed).
    torque_fraction: output load before reversal [fraction of T_rated].
    reverse_at_s, reverse_over_s: load reversal T -> -T starting at / lasting [s] (None: no reversal).
    duration, quick_duration: simulated time [s] of the full / --quick run.
    step: nominal step [s]. stiffness_factor: pin-contact stiffness multiplier [-].
    nan_at_evaluation: evaluation counters of the pin element to poison (fault injection).
    wheel_kick: extra initial angular velocity [rad/s] of ``kick_body`` (excites rattle in the clearance).
    """
    name: str
    description: str
    design_changes: dict = field(default_factory=dict)
    speed_rpm: float = 1500.0
    run_up_s: float | None = None
    start_from_rest: bool = False
    torque_fraction: float = 1.0
    reverse_at_s: float | None = None
    reverse_over_s: float = 2e-4
    duration: float = 0.02
    quick_duration: float = 0.004
    step: float = 2e-5
    stiffness_factor: float = 1.0
    nan_at_evaluation: tuple = ()
    wheel_kick: float = 0.0
    kick_body: str = "wheel0"

    def input_angle(self, t):
        w = self.speed_rpm * np.pi / 30.0
        if self.run_up_s is None or self.run_up_s <= 0.0:
            return w * t
        a = w / self.run_up_s
        return 0.5 * a * t * t if t <= self.run_up_s else 0.5 * w * self.run_up_s + w * (t - self.run_up_s)

    def input_speed(self, t):
        w = self.speed_rpm * np.pi / 30.0
        if self.run_up_s is None or self.run_up_s <= 0.0:
            return w
        return w * min(t / self.run_up_s, 1.0)

    def torque(self, t, rated):
        t0 = self.torque_fraction * rated
        if self.reverse_at_s is None or t <= self.reverse_at_s:
            return t0
        s = min((t - self.reverse_at_s) / self.reverse_over_s, 1.0)
        return t0 * (1.0 - 2.0 * (3 * s * s - 2 * s ** 3))  # smooth step +T -> -T


def _body_masses(model):
    """Diagonal of the mass matrix over the ODE2 coordinates (planar rigid bodies)."""
    mbs = model.mbs
    m = np.zeros(mbs.systemData.ODE2Size())
    for i in range(mbs.systemData.NumberOfObjects()):
        o = mbs.GetObject(i)
        if o.get("objectType") == "RigidBody2D":
            idx = np.asarray(mbs.systemData.GetNodeLTGODE2(o["nodeNumber"]))
            m[idx] = (o["mass"], o["mass"], o["inertia"])
    return m


def case_design(case: HardCase, design):
    """The design of the case: ``design`` with the case's changes and mesh stiffness factor."""
    d = design.replace(**case.design_changes) if case.design_changes else design
    if case.stiffness_factor != 1.0:
        d = d.with_mesh_stiffness_factor(case.stiffness_factor)
    return d


def run_case(case: HardCase, model, *, quick=False, out_dir=None, criteria_fn=None, run_spec=None):
    """Run ``case`` on ``model``, the built :func:`case_design` of the case (a protocol is handed a
    ReducerModel, never a builder: :func:`rvtool.analysis.hard_cases.run_hard_case` builds it);
    returns the result dict (see module docstring) and the records."""
    import exudyn as exu

    from ..solver import RunSpec, simulate
    d = model.design
    rated = d.rated_torque
    sign = -np.sign(d.ratio)
    duration = case.quick_duration if quick else case.duration
    spec = run_spec or RunSpec(end_time=duration, step=case.step, abs_tol=1e-6, rel_tol=1e-8)
    spec = dataclasses.replace(spec, end_time=duration)
    mbs = model.mbs
    # loaded start by torque continuation (increment halving, jump guard): a full-load Newton
    # solve from the kinematic state can converge to a spurious far equilibrium
    q0 = Continuation(model, input_angle=case.input_angle(0.0)).go_to(sign * case.torque(0.0, rated))
    v0 = np.zeros_like(q0)
    if not case.start_from_rest:
        v0 = model.body_vector(model.kinematic_state(case.input_angle(0.0), case.input_speed(0.0)).velocities)
    if case.wheel_kick:
        v0[model.coordinate_index(case.kick_body, "theta")] += case.wheel_kick
    model.set_input_motion(case.input_angle)   # also switches the static regularization off
    model.set_output_torque_function(lambda t: sign * case.torque(t, rated))
    mbs.Assemble()
    mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
    mbs.systemData.SetODE2Coordinates_t(v0, configuration=exu.ConfigurationType.Initial)
    pins = model.family_element(model.main_mesh)
    if case.nan_at_evaluation:
        n0 = pins.n_evaluations
        pins.inject_nan_at = {n0 + int(k) for k in case.nan_at_evaluation}
    masses = _body_masses(model)
    i_in, i_out = model.input_index, model.output_index
    rec = {"t": [0.0], "theta_in": [q0[i_in]], "theta_out": [q0[i_out]],
           "pin_sum_N": [float(np.sum(pins.evaluate(0.0, pins.local(q0), pins.local(v0)).obs[:, O_FN]))],
           "kinetic_J": [0.5 * float(masses @ v0 ** 2)], "finite": [True]}

    def record(t, q, v):
        rec["t"].append(t)
        rec["theta_in"].append(q[i_in])
        rec["theta_out"].append(q[i_out])
        rec["pin_sum_N"].append(float(np.sum(pins.last_obs[:, O_FN])))
        rec["kinetic_J"].append(0.5 * float(masses @ v ** 2))
        rec["finite"].append(bool(np.all(np.isfinite(q)) and np.all(np.isfinite(v))))

    t0 = time.perf_counter()
    failure, saved = None, None
    try:
        run = simulate(mbs, spec, model.contact_elements(), None, before_accept=record, out_dir=out_dir)
        stats = run.to_dict()
    except SolverFailure as exc:
        failure = str(exc)
        saved = exc.state_file
        stats = None
    wall = time.perf_counter() - t0
    arr = {k: np.asarray(v) for k, v in rec.items()}
    arr["te"] = transmission_error(arr["theta_in"], arr["theta_out"], d.ratio)
    crit = {}
    if failure is None:
        crit["finished"] = criterion(arr["t"][-1], duration * (1 - 1e-9), ">=")
        crit["finite_state"] = criterion(int(np.all(arr["finite"])), 1, ">=")
        # no silent garbage: kinetic energy within 10x the rigid kinematic value at the top
        # speed and TE within 20 arcmin (several times lost motion plus rated wind-up, ~6 arcmin)
        kin = model.kinematic_state(0.0, case.speed_rpm * np.pi / 30.0).velocities
        ke_ref = 0.5 * float(masses @ model.body_vector(kin) ** 2)
        crit["kinetic_energy_bound"] = criterion(float(arr["kinetic_J"].max()) / ke_ref, 10.0, "<=")
        crit["te_bound_arcsec"] = criterion(float(np.max(np.abs(arr["te"] - arr["te"][0]))) * ARCSEC_PER_RAD, 1200.0, "<=")
        if criteria_fn is not None:
            crit.update(criteria_fn(arr, stats, d, case))
        passed = all(c["passed"] for c in crit.values())
        msg = ("finished: " if passed else "finished but failed: ") + \
              ", ".join(f"{k}={'ok' if c['passed'] else 'FAIL'}" for k, c in crit.items())
    else:
        crit["failed_with_saved_state"] = criterion(int(saved is not None), 1, ">=")
        passed = False
        msg = failure
    return {
        "passed": bool(passed), "criteria": crit,
        "rejected_steps": stats["rejected_steps"] if stats else None,
        "min_step_s": stats["min_step_s"] if stats else None,
        "max_residual": stats["max_residual"] if stats else None,
        "message": msg, "saved_state": saved, "accepted_steps": stats["accepted_steps"] if stats else None,
        "reject_reasons": stats["reject_reasons"] if stats else None, "wall_s": wall,
        "te_pp_arcsec": float(np.ptp(arr["te"])) * ARCSEC_PER_RAD, "kinetic_max_J": float(arr["kinetic_J"].max()),
        "pin_sum_min_N": float(arr["pin_sum_N"].min()), "pin_sum_max_N": float(arr["pin_sum_N"].max()),
    }, arr


def criterion(value, limit, op):
    """A pass/fail criterion: {value, limit ("<= x" or ">= x"), passed}."""
    ok = {"<=": value <= limit, ">=": value >= limit}[op]
    return {"value": value, "limit": f"{op} {limit}", "passed": bool(ok)}


def mean_output_speed_ratio(arr, frac=0.5):
    """Mean output/kinematic speed over the final ``frac`` of the run (from angle increments)."""
    n = len(arr["t"])
    i0 = int(n * (1 - frac))
    d_out = arr["theta_out"][-1] - arr["theta_out"][i0]
    d_in = arr["theta_in"][-1] - arr["theta_in"][i0]
    return d_out, d_in


def case_by_name(name):
    for c in CASES:
        if c.name == name:
            return c
    raise RvtoolInputError(f"hard case {name!r} unknown; valid choices are {[c.name for c in CASES]}")


CASES = (
    HardCase(name="reversal", description="load reversal +T_rated -> -T_rated in 0.2 ms at 1500 rpm through "
             "the backlash (output-pin hole clearance, lost motion ~3.4 arcmin): contact loss and re-impact",
             reverse_at_s=0.002, duration=0.01, quick_duration=0.004),
    HardCase(name="startup", description="start-up from rest at rated torque: input speed step 0 -> 1500 rpm at t = 0",
             start_from_rest=True, run_up_s=0.0, duration=0.02, quick_duration=0.004),
    HardCase(name="runup", description="run-up 0 -> 3000 rpm input at rated torque (linear speed ramp)",
             speed_rpm=3000.0, run_up_s=0.02, start_from_rest=True, duration=0.03, quick_duration=0.006),
    HardCase(name="rattle", description="zero-load rattle at 1500 rpm with 20 um profile clearance, wheel 1 "
             "spun by an extra 1 rad/s at t = 0 (the ideal symmetric assembly alone never touches the pins)",
             design_changes={"wheels": {"clearance": 20e-6}}, torque_fraction=0.0, wheel_kick=1.0, duration=0.02,
             quick_duration=0.004),
    HardCase(name="stiff100", description="pin-contact stiffness raised 100x at rated torque and 1500 rpm",
             stiffness_factor=100.0, duration=0.01, quick_duration=0.002),
    HardCase(name="nan", description="one forced NaN in a pin-contact evaluation mid-run (must be rejected and "
             "retried); a persistent NaN must fail with the state saved",
             nan_at_evaluation=(60,), duration=0.004, quick_duration=0.002),
)


# -- case-specific criteria ------------------------------------------------------------------

def _speed_follow(arr, d, frac):
    """|mean output speed / kinematic output speed - 1| over the final ``frac`` of the run."""
    d_out, d_in = mean_output_speed_ratio(arr, frac)
    return abs(d_out * d.ratio / d_in - 1.0)


def criteria_reversal(arr, stats, d, case):
    t = arr["t"]
    before = arr["pin_sum_N"][t <= case.reverse_at_s]
    after = t > case.reverse_at_s
    loaded = float(np.median(before))
    te = arr["te"] * ARCSEC_PER_RAD
    return {
        # the mesh unloads while the torque passes zero (contact loss) ...
        "contact_loss_min_over_loaded": criterion(float(arr["pin_sum_N"][after].min()) / loaded, 0.1, "<="),
        # ... and is loaded again on the other flank (re-impact)
        "reloaded_over_loaded": criterion(float(arr["pin_sum_N"][-1]) / loaded, 0.5, ">="),
        # the output crosses the backlash: TE moves by more than the wind-up of one side
        "te_shift_arcsec": criterion(float(abs(te[-1] - te[t <= case.reverse_at_s][-1])), 60.0, ">="),
    }


def criteria_startup(arr, stats, d, case):
    return {"output_speed_error_final_half": criterion(_speed_follow(arr, d, 0.5), 0.05, "<=")}


def criteria_runup(arr, stats, d, case):
    return {"output_speed_error_final_fifth": criterion(_speed_follow(arr, d, 0.2), 0.05, "<=")}


def criteria_rattle(arr, stats, d, case):
    # the kicked wheel crosses the clearance and hits the pins (impacts occur); contact damping
    # and the integrator may only remove energy: the kinetic energy stays below its initial value
    # plus the rigid drive share (no energy created by the impacts)
    ke0 = float(arr["kinetic_J"][0])
    return {"impacts_max_pin_sum_N": criterion(float(arr["pin_sum_N"].max()), 1.0, ">="),
            "kinetic_energy_over_initial": criterion(float(arr["kinetic_J"].max()) / ke0, 1.05, "<=")}
    # (no speed-following criterion: unloaded, the flange floats within the backlash)


def criteria_stiff100(arr, stats, d, case):
    return {"output_speed_error_final_half": criterion(_speed_follow(arr, d, 0.5), 0.05, "<=")}


def criteria_nan(arr, stats, d, case):
    reasons = stats.get("reject_reasons", {}) if stats else {}
    return {"nan_rejected_and_retried": criterion(int(reasons.get("non-finite contact force in a trial evaluation", 0)),
                                              1, ">=")}


CRITERIA = {"reversal": criteria_reversal, "startup": criteria_startup, "runup": criteria_runup,
            "rattle": criteria_rattle, "stiff100": criteria_stiff100, "nan": criteria_nan}
