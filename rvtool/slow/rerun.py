"""Matched-protocol re-runs after a slow update, with the origin of each change
(Section "Slow feedback through shared mechanical channels", deliverable 7 of issue 18).

A :class:`MatchedProtocol` fixes the mounting (input angle of the stiffness and
lost-motion runs, fixed housing), the load schedule (TE torque, lost-motion level,
stiffness torque levels) and the reference phase (first TE angle, the state
of the contact-load comparison). :func:`run_matched` runs the quasi-static
precision protocol (TE, Eq. (obs_te)), the spring-controlled lost motion and the
loaded stiffness (fit of Eq. (stiffness_fit) over load-controlled equilibria at 50-100 %
of the rated torque on the positive loading branch; a torque continuation from zero load
stalls in the free play of a design with pin clearance) on a model with the
gap offsets in force; the same protocol object before and after a slow update
is what makes the runs matched.

:func:`attribute` re-runs the protocol with each channel's offsets alone
(thermal envelope, bearing clearance, wear, ...) and reports per channel the
change of every figure and the contacts whose load at the reference phase
changed most: which channel changed which contact. The remainder (all channels
together minus the sum of single channels) is the interaction of channels
through the shared contact set.
"""
import time
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..protocols import stiffness as S
from ..protocols.lost_motion import lost_motion
from ..protocols.precision import te_metrics, transmission_error
from ..solver.static import StaticSolver
from ..units import ARCSEC_PER_RAD, RAD_PER_ARCMIN
from ..validation import check_finite, check_positive, check_range
from .offsets import GapOffsets
from .reducer_windows import loaded_start

#: Control spring [N m/rad] of the lost-motion retry (ten times the protocol's default).
LOST_MOTION_SPRING_RETRY = 1e6

FIGURES = ("te_pp_arcsec", "te_rms_arcsec", "lost_motion_arcmin", "K_Nm_per_arcmin")
#: Figures of the vibration protocol (present where ``MatchedProtocol.vibration_revolutions`` is set).
VIBRATION_FIGURES = ("torsion_pp_arcsec", "mesh_order_amplitude_arcsec", "mesh_order_amplitude_quasistatic_arcsec")


@dataclass(frozen=True, kw_only=True, eq=False)
class MatchedProtocol:
    """Mounting, load schedule and reference phase shared by the runs before and after an update.

    torque: TE output torque [N m] (> 0). te_angles: input angles of the TE sequence [rad]
    (increasing; the first is the reference phase). output_revolutions: output revolutions
    the TE angles span (order spacing of the spectrum) [-]. lost_motion_torque: level
    +-T of the lost motion [N m] (> 0). rated_torque [N m] (> 0) and stiffness_fractions: the
    loaded stiffness levels [fraction of rated_torque] (at least 2, in (0, 1]). input_angle: input angle of the stiffness and lost-motion runs [rad] (the mounting).
    vibration_revolutions: input revolutions of the driven vibration run (None: no vibration
    run; it starts loaded at the mounting's input angle, which must then be 0, the driven
    run's phase origin), at vibration_speed_rpm [rpm] (> 0) under ``torque``, nominal
    step vibration_step [s] (> 0).
    """
    torque: float
    te_angles: tuple
    output_revolutions: float
    lost_motion_torque: float
    rated_torque: float
    stiffness_fractions: tuple = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
    input_angle: float = 0.0
    vibration_revolutions: float | None = None
    vibration_speed_rpm: float | None = None
    vibration_step: float = 2e-5

    def __post_init__(self):
        a = np.array(self.te_angles, dtype=np.float64)
        if a.ndim != 1 or a.size < 2 or np.any(np.diff(a) <= 0.0):
            raise RvtoolInputError("te_angles must be at least 2 increasing input angles [rad]")
        check_finite("te_angles", a)
        object.__setattr__(self, "te_angles", tuple(a.tolist()))
        for name in ("torque", "output_revolutions", "lost_motion_torque", "rated_torque"):
            check_finite(name, getattr(self, name))
            check_positive(name, getattr(self, name))
        check_finite("input_angle", self.input_angle)
        f = np.array(self.stiffness_fractions, dtype=np.float64)
        if f.ndim != 1 or f.size < 2:
            raise RvtoolInputError("stiffness_fractions must hold at least 2 levels (a fit needs two points)")
        check_finite("stiffness_fractions", f)
        check_range("stiffness_fractions", f, 0.0, 1.0, low_open=True)
        object.__setattr__(self, "stiffness_fractions", tuple(f.tolist()))
        if self.vibration_revolutions is not None:
            for name in ("vibration_revolutions", "vibration_speed_rpm", "vibration_step"):
                if getattr(self, name) is None:
                    raise RvtoolInputError(f"{name} must be given with vibration_revolutions (valid: > 0)")
                check_finite(name, getattr(self, name))
                check_positive(name, getattr(self, name))
            if self.input_angle != 0.0:
                raise RvtoolInputError(f"input_angle = {self.input_angle} with a vibration run; valid: 0 (the driven "
                                       "run starts at input angle 0)")

    @property
    def reference_angle(self) -> float:
        return self.te_angles[0]

    def to_dict(self) -> dict:
        return {"torque_Nm": self.torque, "te_points": len(self.te_angles), "reference_angle_rad": self.te_angles[0],
                "te_span_rad": self.te_angles[-1] - self.te_angles[0], "output_revolutions": self.output_revolutions,
                "lost_motion_torque_Nm": self.lost_motion_torque, "input_angle_rad": self.input_angle,
                "stiffness_fractions": self.stiffness_fractions, "rated_torque_Nm": self.rated_torque,
                "vibration_revolutions": self.vibration_revolutions, "vibration_speed_rpm": self.vibration_speed_rpm,
                "vibration_step_s": self.vibration_step}


def contact_loads_at(model, q) -> dict:
    """{"<family>/<contact>": normal force [N]} at the static state q."""
    out = {}
    for fam in model.families:
        names, F = model.observe(q, fam).per_contact()
        out.update({f"{fam.value}/{c}": float(f) for c, f in zip(names, F)})
    return out


def loaded_stiffness(model, protocol: MatchedProtocol) -> float:
    """K [N m/arcmin] of Eq. (stiffness_fit): least-squares slope of the output torque over the output
    rotation (from its kinematic position) at the protocol's levels, at the mounting's input angle."""
    fractions = sorted(protocol.stiffness_fractions)
    solver = loaded_start(model, fractions[0] * protocol.rated_torque, protocol.input_angle)
    th_kin = model.kinematic_output(protocol.input_angle)
    i_out = model.output_index
    torques, angles = [], []
    for f in fractions:
        T = f * protocol.rated_torque
        model.set_output_torque(-np.sign(model.ratio) * T)
        q = solver.solve(protocol.input_angle, protocol.input_angle)
        torques.append(T)
        angles.append(abs(q[i_out] - th_kin) / RAD_PER_ARCMIN)
    model.set_output_torque(0.0)
    return S.linear_fit(angles, torques)[0]


def run_matched(model, protocol: MatchedProtocol) -> dict:
    """The matched figures of ``model`` with the offsets in force: TE pp and RMS [arcsec],
    lost motion [arcmin] (spring control at +-lost_motion_torque), the stiffness branch fit of
    the positive loading branch [N m/arcmin], the contact loads at the reference phase [N],
    and the wall time [s]."""
    if not isinstance(protocol, MatchedProtocol):
        raise RvtoolInputError(f"protocol must be a MatchedProtocol; got {type(protocol).__name__}")
    t0 = time.perf_counter()
    # TE (Eq. (obs_te)) over the protocol's angles, warm-started from the loaded start
    solver = loaded_start(model, protocol.torque, protocol.reference_angle)
    loads = contact_loads_at(model, solver.q)
    i_out, ref_out = model.output_index, model.reference_value(model.output)
    th_in, th_out, prev = [], [], protocol.reference_angle
    for a in protocol.te_angles:
        q = solver.solve(a, prev)
        prev = solver.last_angle
        th_in.append(prev)
        th_out.append(ref_out + q[i_out])
    te = transmission_error(np.array(th_in), np.array(th_out), model.ratio, unwrap=False)
    met = te_metrics(te, n_revolutions=protocol.output_revolutions)
    model.set_output_torque(0.0)
    try:
        lm = lost_motion(model, torque_level=protocol.lost_motion_torque, input_angle=protocol.input_angle)
    except SolverFailure:   # measured after wear: the march's regula falsi stalls with the default spring
        model.set_output_torque(0.0)
        lm = lost_motion(model, torque_level=protocol.lost_motion_torque, input_angle=protocol.input_angle,
                         k_s=LOST_MOTION_SPRING_RETRY)
    K = loaded_stiffness(model, protocol)
    out = {"te_pp_arcsec": met["pp"] * ARCSEC_PER_RAD, "te_rms_arcsec": met["rms"] * ARCSEC_PER_RAD,
           "te_arcsec": (te - np.mean(te)) * ARCSEC_PER_RAD,
           "lost_motion_arcmin": lm["lost_motion_rad"] / RAD_PER_ARCMIN,
           "K_Nm_per_arcmin": K, "contact_loads_N": loads}
    if protocol.vibration_revolutions is not None:
        out.update(matched_vibration(model, protocol))
    out["wall_s"] = time.perf_counter() - t0
    return out


def _restore_static(model, springs, histories):
    """The model as the static protocols need it after a driven run: prescribed input angle (the
    drive's user function removed), regularization springs at their built stiffness, zero
    velocities, the contact histories committed before the run, no cached trial."""
    import exudyn as exu
    mbs = model.mbs
    mbs.SetObjectParameter(model.drive, "offsetUserFunction", 0)
    for (_, _, _, obj), k in zip(model.reg_springs, springs):
        mbs.SetObjectParameter(obj, "stiffness", k)
    mbs.Assemble()
    n = mbs.systemData.ODE2Size()
    mbs.systemData.SetODE2Coordinates_t(np.zeros(n), configuration=exu.ConfigurationType.Initial)
    for el, h in zip(model.contact_elements(), histories):
        for key, value in h.items():
            setattr(el.evaluator.history, key, value)
    model.set_prescribed_velocity(None)        # drops every element's cached trial
    model.set_output_torque(0.0)


def matched_vibration(model, protocol: MatchedProtocol) -> dict:
    """The vibration protocol (:func:`rvtool.protocols.vibration.driven_response`) with the offsets in
    force: driven rotation at ``vibration_speed_rpm`` under ``torque`` from the loaded equilibrium at
    input angle 0 (the mounting), output torsion (TE of Eq. (obs_te)) recorded at every accepted step.
    Returns its peak-to-peak [arcsec], the amplitude at the mesh order z_p of the shaft-order
    spectrum [arcsec], the same amplitude of the quasi-static TE at the same angles (the low-speed
    reference), the accepted/rejected steps and the wall time [s]. The model is restored for the
    static protocols afterwards (the driven run replaces the drive's prescribed angle by a function
    of time and switches the regularization springs off)."""
    from ..protocols import vibration as V
    from ..solver import RunSpec
    p = protocol
    springs = [model.mbs.GetObjectParameter(obj, "stiffness") for _, _, _, obj in model.reg_springs]
    histories = [el.history_state() for el in model.contact_elements()]
    duration = p.vibration_revolutions * 60.0 / p.vibration_speed_rpm
    vp = V.VibrationProtocol(speed_rpm=p.vibration_speed_rpm, torque=p.torque, duration=duration,
                             sample_step=p.vibration_step)
    spec = RunSpec(end_time=duration, step=p.vibration_step, abs_tol=1e-6, rel_tol=1e-8)
    t0 = time.perf_counter()
    try:
        q0 = loaded_start(model, p.torque, 0.0).q.copy()
        run = V.driven_response(model, vp, spec, initial_state=q0)
    finally:
        _restore_static(model, springs, histories)
    wall = time.perf_counter() - t0
    sp = V.vibration_spectra(run, vp, "torsion")
    order = 2 * np.pi / model.mesh_period         # mesh order in input-shaft orders (z_p for the cycloid)
    i = int(np.argmin(np.abs(sp["orders"] - order)))
    # quasi-static TE at the same input angles (8 per mesh period): the low-speed limit
    n_qs = int(round(p.vibration_revolutions * order * 8))
    angles = np.arange(n_qs) * model.mesh_period / 8
    solver = loaded_start(model, p.torque, 0.0)
    i_out, prev, th_out = model.output_index, 0.0, []
    for a in angles:
        q = solver.solve(a, prev)
        prev = solver.last_angle
        th_out.append(q[i_out] - model.kinematic_output(prev))
    model.set_output_torque(0.0)
    o_qs, a_qs = V.order_spectrum(angles, np.array(th_out), samples_per_rev=int(round(order * 8)))
    j = int(np.argmin(np.abs(o_qs - order)))
    rec = run["record"]
    return {"torsion_pp_arcsec": float(np.ptp(run["responses"]["torsion"])) * ARCSEC_PER_RAD,
            "mesh_order_amplitude_arcsec": float(sp["order_spectrum"][i]) * ARCSEC_PER_RAD,
            "mesh_order_amplitude_quasistatic_arcsec": float(a_qs[j]) * ARCSEC_PER_RAD,
            "mesh_order": float(sp["orders"][i]), "vibration_accepted_steps": rec.accepted_steps,
            "vibration_rejected_steps": rec.rejected_steps, "vibration_wall_s": wall}


def figure_changes(before: dict, after: dict) -> dict:
    """after - before of each of :data:`FIGURES` and of the :data:`VIBRATION_FIGURES` both carry."""
    return {k: after[k] - before[k] for k in FIGURES + VIBRATION_FIGURES if k in before and k in after}


def load_changes(before: dict, after: dict, n: int = 5) -> dict:
    """The ``n`` contacts with the largest |load change| at the reference phase: id -> dF [N]."""
    b, a = before["contact_loads_N"], after["contact_loads_N"]
    d = {c: a[c] - b[c] for c in b}
    top = sorted(d, key=lambda c: -abs(d[c]))[:n]
    return {c: d[c] for c in top if d[c] != 0.0}


def attribute(windows, protocol: MatchedProtocol, before: dict, after: dict, *, n_contacts: int = 5) -> dict:
    """Origin of the changes from ``before`` (no offsets) to ``after`` (the offsets in force on
    ``windows``, a :class:`rvtool.slow.reducer_windows.ReducerWindows`): per channel, the
    figures re-run with that channel alone, their changes, the contacts it offsets (count and
    largest |offset| [um]) and the contacts whose reference-phase load it changed most [N];
    ``interaction``: total change minus the sum of the single-channel changes. The offsets in
    force are restored afterwards."""
    full, friction = windows.offsets, windows.friction
    per_channel = windows.offsets_by_channel()
    out = {}
    try:
        for ch, table in per_channel.items():
            windows.apply_offsets(GapOffsets(by_channel={ch: full.by_channel[ch]}), friction)
            fig = run_matched(windows.model, protocol)
            vals = np.array(list(table.values())) if table else np.zeros(1)
            out[ch] = {"changes": figure_changes(before, fig),
                       "contacts_offset": len(table), "max_abs_offset_um": float(np.max(np.abs(vals))) * 1e6,
                       "mean_offset_um": float(np.mean(vals)) * 1e6,
                       "largest_load_changes_N": load_changes(before, fig, n_contacts)}
    finally:
        windows.apply_offsets(full, friction)
    total = figure_changes(before, after)
    interaction = {k: total[k] - sum(o["changes"][k] for o in out.values()) for k in total}
    return {"channels": out, "total": total, "interaction": interaction,
            "largest_load_changes_N": load_changes(before, after, n_contacts)}
