"""The built-in protocols of ``rvtool analyze``, each composed from the library the cases
use, each figure with its error statement. Quick forms are short (seconds on a laptop core);
full forms follow the case scripts' settings.

* ``te`` -- quasi-static transmission error (Eq. obs_te) under the rated torque
  (:func:`rvtool.protocols.precision.quasi_static_te`), refinement error against the
  topology's refined resolution over one mesh cycle (as ``cases/cycloid/cycloid_double_wheel.py``);
* ``stiffness`` -- signed torque sequence by continuation, branch fits of Eq. (stiffness_fit),
  condensed tangent of Eq. (obs_condensed_stiffness) against a finite increment
  (as ``cases/cycloid/stiffness_hysteresis.py``);
* ``lost_motion`` -- at +-3 % of the rated torque from the stiffness sequence, checked
  against the spring-controlled march (:func:`rvtool.protocols.lost_motion.lost_motion`);
* ``hysteresis`` -- two loops -T -> +T -> -T after a virgin preload (no level at zero torque), the
  catalogue's hysteresis loss, lost motion and b/a (:mod:`rvtool.protocols.catalogue`), loop
  integral and the cycle-dissipation checks of :mod:`rvtool.protocols.hysteresis`;
* ``vibration`` -- driven rotation at the rated speed and torque, spectra of the output
  torsion, mesh-order amplitude against the quasi-static low-speed limit (as ``cases/cycloid/vibration.py``);
* ``pressure`` -- local pressure of the most loaded main-mesh contact per member at the rated
  state, resolution sequence with e1 against the finest field (as ``cases/cycloid/pressure_resolution.py``);
* ``monte_carlo`` -- tolerance Monte Carlo of TE p-p, lost motion and peak contact force when a
  tolerance file is given: the cycloid drive's batched variants
  (:func:`rvtool.variants.montecarlo.run_monte_carlo`), the RV and small-tooth-difference
  reducers' design variants on the CPU path (:mod:`rvtool.variants.rv_tolerances`,
  :mod:`rvtool.variants.std_tolerances`).
"""
import time

import numpy as np

from .. import progress
from ..errors import RvtoolInputError, SolverFailure
from ..model import Family
from ..units import ARCMIN_PER_RAD, ARCSEC_PER_RAD, RAD_PER_ARCMIN
from .registry import Outcome, Unsupported, register
from .results import Figure

REGULARIZATION_WARN_FRACTION = 1e-3
"""A regularization spring carrying more than this fraction of the rated torque (or of the
largest contact force) is reported as a warning: the figure then depends on a numerical setting."""

LOST_MOTION_FRACTION = 0.03
"""Lost motion is measured at +-3 % of the rated torque (the +-3 % definition of the cases)."""


def _mesh_period(model):
    if not model.mesh_period:
        raise Unsupported(f"{type(model).__name__} declares no mesh_period (input angle of one mesh cycle)")
    return float(model.mesh_period)


def _regularization_warning(out, force, rated):
    if force is not None and force > REGULARIZATION_WARN_FRACTION * rated:
        out.warnings.append(f"regularization springs carry up to {force:.3g} (N or N m), more than "
                            f"{REGULARIZATION_WARN_FRACTION:g} x rated torque: the figures depend on them")


def _solver_warnings(out, stats, what):
    for key in ("rejected_steps", "ramped_restarts", "substep_restarts", "shifted_points"):
        n = stats.get(key) if isinstance(stats, dict) else None
        if n:
            out.warnings.append(f"{what}: {n} {key.replace('_', ' ')} (solver fallbacks; figures converged)")


def _exudyn_copies_warning(out, stats):
    if stats.get("exudyn_copies"):
        out.warnings.append("device torque path: the continuation left the device and finished on Exudyn "
                            "(counted in continuation.exudyn_copies)")


# -- transmission error ----------------------------------------------------------------------

QUICK_POINTS_PER_MESH = 12
"""Points per mesh cycle of the quick TE: enough to resolve the mesh-order ripple (at 4 points the
rv40e trace was a jagged polygon through 4 samples per ripple); one input revolution keeps it short."""

def _te_angles(model, quick):
    mesh = _mesh_period(model)
    ppm = QUICK_POINTS_PER_MESH if quick else 40
    # quick: one input revolution; full: one output revolution (the declared interval of the cases)
    revs_out = 1.0 / abs(model.ratio) if quick else 1.0
    n = int(round(revs_out * abs(model.ratio) * (2 * np.pi / mesh) * ppm))
    return np.arange(n) * mesh / ppm, revs_out, ppm


def _backend(ctx, model, task, n_states=None):
    """(backend, choice) of ``ctx.backend`` for ``task`` on ``model``; a named backend that cannot
    run it skips the protocol with its reasons (:class:`Unsupported`; never a silent fallback)."""
    from ..solver.backends import choose
    try:
        return choose(ctx.backend, model, task, n_states=n_states, device=ctx.device)
    except RvtoolInputError as exc:
        raise Unsupported(str(exc)) from None


def _exudyn_only(ctx, what):
    """The backend record of a protocol that runs on Exudyn only (``what`` it needs that no other
    backend implements); a named other backend skips the protocol, with that reason."""
    from ..solver.backends import CHOICES
    if ctx.backend not in ("auto", "exudyn"):
        raise Unsupported(f"backend = {ctx.backend!r} runs no {what} (valid choices for this protocol: "
                          "'exudyn' or 'auto')")
    return {"requested": ctx.backend, "ran": "exudyn",
            "not_taken": {b: f"implements no {what}" for b in CHOICES if b not in ("auto", "exudyn")}}


def _torque_path(ctx, model, what):
    """(backend, choice) of the torque path (task ``"torque_path"``: Exudyn's load continuation,
    the device row Newton's torque path) of ``what`` on ``model``, as the TE's: auto takes the
    first supporting backend in the measured order (:func:`rvtool.solver.backends.auto_order`)
    and records the named reason of every other; the backends that implement no torque path are
    recorded with that reason; a named backend that cannot run it skips the protocol with the
    reasons (:class:`Unsupported`, never a silent fallback)."""
    from ..solver.backends import backends, choose
    try:
        backend, choice = choose(ctx.backend, model, "torque_path", device=ctx.device)
    except RvtoolInputError as exc:
        raise Unsupported(f"{what}: {exc}") from None
    for b in backends(ctx.device):
        if b.name != choice["ran"] and b.name not in choice["not_taken"]:
            choice["not_taken"][b.name] = ("implements no torque path (rvtool.solver.backends.Backend.torque_path)"
                                           if ctx.backend == "auto" else f"not requested (--backend {ctx.backend})")
    return backend, choice


@register("te", "quasi-static transmission error under the rated torque (Eq. obs_te), with its refinement error")
def run_te(ctx):
    from ..protocols.precision import mesh_forces, peak_to_peak_sampling_error, quasi_static_te, te_metrics
    rated = ctx.require("rated_torque")
    out = Outcome()
    model = ctx.build()                 # built once: the sequence, the coarse refinement run, the section
    angles, revs, ppm = _te_angles(model, ctx.quick)
    mesh = _mesh_period(model)
    backend, choice = _backend(ctx, model, "equilibria", len(angles))
    try:
        qs = quasi_static_te(model, torque=rated, input_angles=angles, backend=backend)
    except SolverFailure as exc:
        # the failed result records no settings: the message says which backend failed
        failure = SolverFailure(f"{exc} [backend {choice['ran']!r}, requested {choice['requested']!r}]")
        failure.state_file = exc.state_file
        raise failure from exc
    met = te_metrics(qs["te"], n_revolutions=revs)
    # refinement reference: one mesh cycle at the topology's refined resolution and twice the points
    window = np.arange(2 * ppm + 1) * mesh / (2 * ppm)
    err, err_note = None, ""
    err_pp, err_pp_note = None, ""
    try:
        fine = model.refined_design()
    except NotImplementedError as exc:
        out.warnings.append(f"no refinement error: {exc}")
        err_note = err_pp_note = "not available: the topology declares no refined resolution"
    else:
        fine_model = ctx.build(fine)
        ref_backend, ref_choice = _backend(ctx, fine_model, "equilibria", len(window))
        coarse = quasi_static_te(model, torque=rated, input_angles=window[::2], backend=ref_backend)
        fine_run = quasi_static_te(fine_model, torque=rated, input_angles=window, backend=ref_backend)
        err = float(np.max(np.abs(coarse["te"] - fine_run["te"][::2]))) * ARCSEC_PER_RAD
        err_note = ("max |TE - TE_refined| over one mesh cycle; reference: the topology's refined resolution "
                    f"({fine_model.resolution_settings()}) at twice the points (backend {ref_choice['ran']!r})")
        # the peak-to-peak also misses the extrema between the run's points: its sampling error over one mesh
        # cycle, estimated as the refined run's peak-to-peak at twice the points less at the run's points (the
        # points' own difference above compares values at common points only and cannot see it)
        sampling = peak_to_peak_sampling_error(fine_run["te"]) * ARCSEC_PER_RAD
        err_pp = err + abs(sampling)
        err_pp_note = (f"{err_note}, plus the peak-to-peak's sampling error over that cycle: its peak-to-peak at "
                       f"twice the points less at the run's points ({abs(sampling):.3g} arcsec)")
    _solver_warnings(out, qs["stats"], "quasi-static TE")
    _regularization_warning(out, qs["regularization_max"], rated)
    te_as = qs["te"] * ARCSEC_PER_RAD
    out.figures += [
        Figure("te_pp", float(np.ptp(te_as)), "arcsec", "TE peak-to-peak over the interval", err_pp, "arcsec",
               err_pp_note),
        Figure("te_rms", met["rms"] * ARCSEC_PER_RAD, "arcsec", "TE RMS about its mean", err, "arcsec", err_note),
        Figure("te_mean_offset", met["mean"] * ARCSEC_PER_RAD, "arcsec", "mean TE (loaded wind-up of the output)",
               err, "arcsec", err_note),
        Figure("ratio", float(model.ratio), "-", "signed nominal ratio i = omega_in / omega_out (from the topology)"),
    ]
    for fam, f in sorted(qs["peak_loads"].items()):
        out.figures.append(Figure(f"peak_load_{fam}", f, "N", f"largest {fam} contact-row force over the TE sequence"))
    out.data = {"input_angle_rad": qs["theta_in"], "te_arcsec": te_as, "te_orders": met["peak_orders"],
                "te_order_amplitudes_arcsec": met["peak_amplitudes"] * ARCSEC_PER_RAD,
                "regularization_max": qs["regularization_max"], "solver": qs["stats"], "wall_s_sequence": qs["wall_s"]}
    out.settings = {"torque_Nm": rated, "points": len(angles), "points_per_mesh_cycle": ppm,
                    "output_revolutions": revs, "mesh_period_rad": mesh, "backend": choice,
                    **model.resolution_settings()}
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    ax[0].plot(np.rad2deg(qs["theta_in"] / abs(model.ratio)), te_as - np.mean(te_as), ".-", lw=0.8, ms=2.5)
    ax[0].set(xlabel="output angle [deg]", ylabel="TE - mean [arcsec]",
              title=f"quasi-static TE at rated torque ({ppm} points per mesh cycle)")
    o, a = met["orders"], met["amplitudes"] * ARCSEC_PER_RAD
    ax[1].semilogy(o[1:], np.maximum(a[1:], 1e-8), lw=0.8)
    ax[1].set(xlabel="output-shaft order [-]", ylabel="amplitude [arcsec]", title="TE order spectrum")
    out.plots.append(ctx.save(fig, "te"))
    # contact forces at the rated state, zero input angle
    from ..solver.static import StaticSolver
    m0, q0 = ctx.cache.get("rated_state", (None, None))    # solved by the admissibility check
    if q0 is None:
        m0 = model
        m0.set_output_torque(-np.sign(m0.ratio) * rated)
        q0 = StaticSolver(m0).solve(0.0)
    out.data["mesh_forces_at_rated_N"] = mesh_forces(m0, q0)
    out.data["peak_loads_at_rated_N"] = m0.family_peaks(q0)
    out.data["hertz_peaks_at_rated_Pa"] = m0.hertz_peaks(q0)      # the report's summary checks them
    fig, ax = plt.subplots(figsize=(6, 6))
    m0.draw_section(ax, q0)
    ax.set_title(f"contact forces at {rated} N m, input angle 0")
    out.plots.append(ctx.save(fig, "section"))
    return out


# -- stiffness, lost motion, hysteresis ----------------------------------------------------------

def _sequence(ctx):
    from ..protocols.stiffness import TorqueSequence
    rated = ctx.require("rated_torque")
    if ctx.quick:   # the cases' coarse sequence: 25 % steps plus the 1.5 / 3 % levels
        return TorqueSequence(rated_torque=rated, loading_step=0.25, other_step=0.25)
    return TorqueSequence(rated_torque=rated)


def _stiffness_run(ctx):
    """(sequence, run, model, backend, choice): the signed torque sequence on the chosen backend's
    torque path, once per analysis (stiffness and lost motion share it; the model built once)."""
    if "stiffness_run" not in ctx.cache:
        from ..protocols.stiffness import quasi_static_stiffness
        model = ctx.build()
        backend, choice = _torque_path(ctx, model, "torque sequence")   # a named backend that cannot run it skips
        seq = _sequence(ctx)
        ctx.cache["stiffness_run"] = (seq, quasi_static_stiffness(model, seq, backend=backend, device=ctx.device),
                                      model, backend, choice)
    return ctx.cache["stiffness_run"]


@register("stiffness", "torsional stiffness: signed torque sequence, branch fits (Eq. stiffness_fit), condensed tangent")
def run_stiffness(ctx):
    from ..protocols import stiffness as S
    rated = ctx.require("rated_torque")
    out = Outcome()
    from ..solver.torque_path import stateful_reasons
    seq, qs, model, path_backend, backend = _stiffness_run(ctx)      # a named backend that cannot run it skips
    torque, angle, labels = qs["torque_Nm"], qs["angle_arcmin"], qs["labels"]
    fits = S.branch_fits(torque, angle, labels, rated)
    t_ref = 0.75 * rated
    # the model built once where the sequence leaves no state in it; else a fresh build (named why)
    stateful = stateful_reasons(model)
    tc = S.tangent_check(ctx.build() if stateful else model, t_ref, backend=path_backend, device=ctx.device)
    tc["model"] = ("a fresh build: " + "; ".join(stateful)) if stateful else "the torque sequence's model"
    note = (f"condensed tangent K_t at {t_ref:g} N m against the central finite increment "
            f"+-{tc['increment_Nm']:.3g} N m (relative difference)")
    out.figures.append(Figure("Kt_condensed", tc["Kt_condensed_Nm_per_arcmin"], "N m/arcmin",
                              "condensed tangent stiffness at 75 % of the rated torque", tc["rel_diff"], "-", note))
    for b, f in fits.items():
        if f["K_Nm_per_arcmin"] is None:
            out.warnings.append(f"branch {b}: {f['points']} points in 50-100 % of T_rated, no fit")
            continue
        rel = abs(f["K_Nm_per_arcmin"] - tc["Kt_condensed_Nm_per_arcmin"]) / abs(tc["Kt_condensed_Nm_per_arcmin"])
        out.figures.append(Figure(f"K_{b}", f["K_Nm_per_arcmin"], "N m/arcmin",
                                  f"secant fit over 50-100 % of T_rated, {b} ({f['points']} levels, R^2 = {f['R2']:.5f})",
                                  rel, "-", "relative difference to the condensed tangent at 75 % T_rated "
                                            "(the fit averages the curve's stiffening; R^2 < 1 measures it)"))
    out.figures.append(Figure("zero_load_return", S.zero_load_return(torque, angle), "arcmin",
                              "final minus first zero-load output angle"))
    _solver_warnings(out, qs["stats"], "continuation")
    _exudyn_copies_warning(out, qs["stats"])
    _regularization_warning(out, qs["regularization_max"], rated)
    out.data = {"torque_Nm": torque, "angle_arcmin": angle, "branch_labels": labels, "branch_fits": fits,
                "tangent_check": tc, "continuation": qs["stats"], "regularization_max": qs["regularization_max"],
                "wall_s_sequence": qs["wall_s"]}
    out.settings = {"sequence": seq.__dict__, "levels": len(torque), "input_angle_rad": 0.0,
                    "backend": backend}
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(angle, torque, ".-", lw=0.8, label="continuation levels")
    for b, f in fits.items():
        if f["K_Nm_per_arcmin"] is not None:
            x = np.array([np.min(angle), np.max(angle)])
            ax.plot(x, f["K_Nm_per_arcmin"] * x + f["b_Nm"], "--", lw=0.7, label=f"fit {b}")
    ax.set(xlabel="output angle [arcmin]", ylabel="output torque [N m]", ylim=(-1.15 * rated, 1.15 * rated),
           title="torsional stiffness")
    ax.legend(fontsize=7)
    out.plots.append(ctx.save(fig, "stiffness"))
    return out


@register("lost_motion", "lost motion at +-3 % of the rated torque, checked against the spring-controlled march")
def run_lost_motion(ctx):
    from ..protocols.lost_motion import lost_motion
    from ..protocols.stiffness import lost_motion_from_levels
    rated = ctx.require("rated_torque")
    out = Outcome()
    _, qs, _, _, backend = _stiffness_run(ctx)      # a named backend that cannot run it skips
    lm_cont = lost_motion_from_levels(qs["torque_Nm"], qs["angle_arcmin"], rated, LOST_MOTION_FRACTION)
    err, note = None, ""
    try:
        lm = lost_motion(ctx.build(), torque_level=LOST_MOTION_FRACTION * rated)
        lm_march = lm["lost_motion_rad"] * ARCMIN_PER_RAD
        err = abs(lm_cont - lm_march)
        note = "|continuation - spring-controlled march| (an independent path through the free play)"
        out.data["march"] = {"lost_motion_arcmin": lm_march, "start_torque_Nm": lm["start_torque"], "stats": lm["stats"]}
    except SolverFailure as exc:
        out.warnings.append(f"spring-controlled march failed ({exc}); no cross-check of the lost motion")
        note = "not available: the spring-controlled march failed"
    out.figures.append(Figure("lost_motion", lm_cont, "arcmin",
                              f"output angle between +{LOST_MOTION_FRACTION:.0%} and -{LOST_MOTION_FRACTION:.0%} "
                              "of T_rated on the first loading branches (continuation)", err, "arcmin", note))
    out.settings = {"torque_fraction": LOST_MOTION_FRACTION, "torque_Nm": LOST_MOTION_FRACTION * rated,
                    "backend": backend}
    return out


HYSTERESIS_RIGIDITY_POINTS = (0.5, 1.0)
"""b/a torque points of ``analyze`` [fraction of T_rated]: rvtool's datasheet secant range; ``rvtool
validate`` takes a catalogue's own points where its file gives them."""


@register("hysteresis", "two repeating loops -T -> +T -> -T after a virgin preload: the catalogue's hysteresis loss, "
                        "lost motion and b/a (rvtool.protocols.catalogue), loop integral, closure and repeatability")
def run_hysteresis(ctx):
    from ..protocols import catalogue as C
    from ..protocols import hysteresis as H
    rated = ctx.require("rated_torque")
    model = ctx.build()
    chosen, backend = _torque_path(ctx, model, "hysteresis loops")   # a named backend that cannot run it skips
    path = chosen.torque_path(model)
    out = Outcome()
    seq = C.catalogue_sequence(rated, rigidity_points=HYSTERESIS_RIGIDITY_POINTS, step=_sequence(ctx).other_step)
    tol = 1e-3 * RAD_PER_ARCMIN        # 0.001 arcmin: far below any reported angle, far above Newton's tolerance
    r = C.catalogue_loops(path, seq, rigidity_points=HYSTERESIS_RIGIDITY_POINTS, repeat_tolerance=tol)
    m, rep = r["metrics"], r["repeatability"]
    first, last = r["cycles"][-2], r["cycles"][-1]
    T = last["torque_Nm"]
    cycles = [H.Cycle(torque=T, angle=first["angle_rad"]), H.Cycle(torque=T, angle=last["angle_rad"])]
    note = (f"repeatability of the second loop against the first (max angle difference at equal torque); "
            f"declared tolerance {tol * ARCMIN_PER_RAD:g} arcmin")
    hl = m.hysteresis_loss
    out.figures.append(Figure("hysteresis_loss", hl.value * ARCMIN_PER_RAD, "arcmin",
                              "the catalogue's hysteresis loss: the loop's width at zero torque along the unloading "
                              "branches (each extrapolated from its own side, the free play included)",
                              None if hl.error is None else hl.error * ARCMIN_PER_RAD, "arcmin",
                              "linear against quadratic extrapolation of the unloading branches to zero torque"))
    out.figures.append(Figure("lost_motion_catalogue", m.lost_motion * ARCMIN_PER_RAD, "arcmin",
                              "the catalogue's lost motion: angle between the mid-points of the loop's width at "
                              "+-3 % T_rated", rep.max_angle_diff * ARCMIN_PER_RAD, "arcmin", note))
    out.figures.append(Figure("torsional_rigidity_b_over_a", m.rigidity.value * RAD_PER_ARCMIN, "N m/arcmin",
                              f"b/a on the loading branches between {HYSTERESIS_RIGIDITY_POINTS[0]:g} and "
                              f"{HYSTERESIS_RIGIDITY_POINTS[1]:g} T_rated (mean of {list(m.rigidity.per_branch)})"))
    try:
        diss = H.cycle_dissipation(cycles[0], cycles[1], angle_tolerance=tol, torque_tolerance=1e-9 * rated)
        out.figures.append(Figure("loop_dissipation", diss.loop_integral, "J", "closed-loop integral of T d(theta) "
                                  "of the second loop (a dissipation: the loop closes and repeats)",
                                  rep.max_angle_diff * rated, "J", "bound: repeatability angle x rated torque"))
    except RvtoolInputError as exc:
        out.warnings.append(f"no loop dissipation: {exc}")
        out.figures.append(Figure("loop_integral", H.loop_integral(cycles[1]), "J",
                                  "integral of T d(theta) over the second loop (NOT a dissipation: see warnings)"))
    if not rep.passed:
        out.warnings.append(f"the loops differ by {rep.max_angle_diff * ARCMIN_PER_RAD:.3g} arcmin (declared tolerance "
                            f"{tol * ARCMIN_PER_RAD:g} arcmin)")
    out.data = {"torque_Nm": T, "branch_labels": last["labels"], "angle_arcmin_loop1": first["angle_rad"] * ARCMIN_PER_RAD,
                "angle_arcmin_loop2": last["angle_rad"] * ARCMIN_PER_RAD,
                "rigidity_per_branch_Nm_per_arcmin": {k: v * RAD_PER_ARCMIN for k, v in m.rigidity.per_branch.items()},
                "continuation": r["stats"]}
    out.settings = {"loop_step_fraction": seq.step, "fine_levels": list(seq.fine_levels),
                    "angle_tolerance_arcmin": tol * ARCMIN_PER_RAD, "rigidity_points": list(HYSTERESIS_RIGIDITY_POINTS),
                    "backend": backend}
    _solver_warnings(out, r["stats"], "continuation")
    _exudyn_copies_warning(out, r["stats"])
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(first["angle_rad"] * ARCMIN_PER_RAD, T, ".-", lw=0.8, label="loop 1")
    ax.plot(last["angle_rad"] * ARCMIN_PER_RAD, T, "x--", lw=0.8, label="loop 2")
    ax.set(xlabel="output angle [arcmin]", ylabel="output torque [N m]", title="hysteresis loops")
    ax.legend(fontsize=7)
    out.plots.append(ctx.save(fig, "hysteresis"))
    return out


# -- vibration ---------------------------------------------------------------------------------

def _driven_run(ctx, model, proto, spec):
    """(run, backend record) of the vibration protocol's driven run. auto and exudyn: Exudyn's
    driven run (:func:`rvtool.protocols.vibration.driven_response`: loaded start by torque
    continuation, the torsion recorded at every accepted step); auto keeps it (the place of a
    device run for this protocol is not measured: the default figures do not change). A named
    device backend ("fused", or "device", whose driven runs are the fused backend's) runs the
    dynamic TE protocol's driven run on it (:func:`rvtool.protocols.precision.dynamic_te`: the
    same boundary conditions and RunSpec, the torsion is its TE on the accepted steps; the loaded
    start is the backend's static solve, :class:`rvtool.solver.backends.FusedBackend`); one that
    cannot run the model skips the protocol with the reasons."""
    from ..protocols import vibration as V
    from ..protocols.precision import dynamic_te
    from ..solver.backends import CHOICES, DrivenRun, choose
    if ctx.backend in ("auto", "exudyn"):
        why = ("auto keeps Exudyn's driven run for the vibration protocol (a device run's place here is not "
               "measured; --backend fused runs it)" if ctx.backend == "auto"
               else f"not requested (--backend {ctx.backend})")
        rec = {"requested": ctx.backend, "ran": "exudyn", "not_taken": {
            b: (why if b == "fused" else "implements no driven run") if ctx.backend == "auto" else why
            for b in CHOICES if b not in ("auto", "exudyn")}}
        return V.driven_response(model, proto, spec), rec
    run = DrivenRun(torque=proto.torque, speed_rpm=proto.speed_rpm, duration=proto.duration, run_spec=spec)
    try:
        backend, rec = choose(ctx.backend, model, "dynamic", run=run, device=ctx.device)
    except RvtoolInputError as exc:
        raise Unsupported(str(exc)) from None
    t0 = time.perf_counter()
    dyn = dynamic_te(model, torque=proto.torque, speed_rpm=proto.speed_rpm, duration=proto.duration, run_spec=spec,
                     solver=backend, device=None if ctx.device in (None, "auto") else ctx.device)
    rec = dict(rec, path=dyn.get("stats", {}).get("path"))
    return {"t": dyn["t"], "phase_in": dyn["theta_in"], "responses": {"torsion": dyn["te"]}, "record": dyn["record"],
            "wall_s": time.perf_counter() - t0}, rec


@register("vibration", "driven rotation at rated speed and torque: torsion spectra, mesh order vs the quasi-static limit")
def run_vibration(ctx):
    from ..protocols import vibration as V
    from ..protocols.precision import quasi_static_te
    from ..solver import RunSpec
    rated, speed = ctx.require("rated_torque", "input_speed_rpm")
    out = Outcome()
    model = ctx.build()
    mesh = _mesh_period(model)
    revs = 0.25 if ctx.quick else 2.0          # input revolutions (cases/cycloid/vibration.py)
    step = 2e-5
    duration = revs * 60.0 / speed
    proto = V.VibrationProtocol(speed_rpm=speed, torque=rated, duration=duration, sample_step=step)
    spec = RunSpec(end_time=duration, step=step, abs_tol=1e-6, rel_tol=1e-8)
    run, backend = _driven_run(ctx, model, proto, spec)
    sp = V.vibration_spectra(run, proto, "torsion")
    mesh_order = 2 * np.pi / mesh
    try:
        markers = model.marker_frequencies(speed)
    except (AttributeError, NotImplementedError) as exc:
        markers = {}
        out.warnings.append(f"no marker frequencies: {exc}")
    # reference: quasi-static TE at the same input angles, 8 points per mesh cycle (the low-speed limit)
    n_qs = int(round(revs * mesh_order * 8))
    angles = np.arange(n_qs) * mesh / 8
    qs = quasi_static_te(ctx.build(), torque=rated, input_angles=angles)
    o_qs, a_qs = V.order_spectrum(angles, qs["te"], samples_per_rev=int(round(mesh_order * 8)))
    i_d = int(np.argmin(np.abs(sp["orders"] - mesh_order)))
    i_q = int(np.argmin(np.abs(o_qs - mesh_order)))
    a_dyn, a_qs_mesh = float(sp["order_spectrum"][i_d]), float(a_qs[i_q])
    rel = abs(a_dyn - a_qs_mesh) / a_qs_mesh if a_qs_mesh > 0 else None
    rec = run["record"]
    dom_o, dom_a = V.dominant(sp["orders"], sp["order_spectrum"], 6)
    out.figures += [
        Figure("torsion_pp", float(np.ptp(run["responses"]["torsion"])) * ARCSEC_PER_RAD, "arcsec",
               "output torsion (dynamic TE) peak-to-peak over the run"),
        Figure("mesh_order_amplitude", a_dyn * ARCSEC_PER_RAD, "arcsec",
               f"torsion amplitude at the mesh order {mesh_order:.4g} (input-shaft orders)", rel, "-",
               "relative difference to the quasi-static TE at the same input angles (the low-speed limit; "
               "the difference is the dynamic amplification plus sampling error)"),
        Figure("mesh_frequency", speed / 60.0 * mesh_order, "Hz", "mesh frequency at the rated input speed"),
    ]
    if rec.rejected_steps:
        out.warnings.append(f"driven run: {rec.rejected_steps} rejected steps (step size halved and retried)")
    out.data = {"frequencies_hz": sp["frequencies_hz"], "spectrum_arcsec": sp["spectrum"] * ARCSEC_PER_RAD,
                "orders": sp["orders"], "order_spectrum_arcsec": sp["order_spectrum"] * ARCSEC_PER_RAD,
                "dominant_orders": dom_o, "dominant_order_amplitudes_arcsec": dom_a * ARCSEC_PER_RAD,
                "markers_hz": markers, "mesh_order_amplitude_quasistatic_arcsec": a_qs_mesh * ARCSEC_PER_RAD,
                "accepted_steps": rec.accepted_steps, "rejected_steps": rec.rejected_steps,
                "max_residual": rec.max_residual, "wall_s_run": run["wall_s"]}
    out.settings = {"input_revolutions": revs, "speed_rpm": speed, "torque_Nm": rated, "run_spec": spec.to_dict(),
                    "backend": backend}
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.6))
    ax[0].semilogy(sp["frequencies_hz"][1:], sp["spectrum"][1:] * ARCSEC_PER_RAD + 1e-12, lw=0.8)
    ax[0].axvline(speed / 60.0 * mesh_order, color="r", ls="--", lw=0.8, label="mesh")
    V.body_mode_markers(ax[0], markers)
    V.body_mode_markers(ax[0], markers, key="crank_modes_hz", label="crank modes", color="y")   # flexible RV cranks
    ax[0].set(xlabel="frequency [Hz]", ylabel="torsion amplitude [arcsec]")
    ax[0].legend(fontsize=7)
    ax[1].semilogy(sp["orders"][1:], sp["order_spectrum"][1:] * ARCSEC_PER_RAD + 1e-12, lw=0.8, label="dynamic")
    ax[1].semilogy(o_qs[1:], a_qs[1:] * ARCSEC_PER_RAD + 1e-12, lw=0.8, label="quasi-static")
    ax[1].axvline(mesh_order, color="r", ls="--", lw=0.8, label="mesh")
    ax[1].set(xlabel="input-shaft order [-]", ylabel="amplitude [arcsec]")
    ax[0].set_title(f"driven run at {speed:g} rpm, {rated:g} N m", fontsize=10)
    ax[1].set_title("order spectra, driven and quasi-static", fontsize=10)
    ax[1].legend(fontsize=7)
    out.plots.append(ctx.save(fig, "vibration"))
    return out


# -- pressure ----------------------------------------------------------------------------------

PRESSURE_WINDOW = 20e-6
"""Fixed window of the mean pressure [m] (cases/cycloid/pressure_resolution.py)."""


@register("pressure", "local pressure of the most loaded main-mesh contact per member at the rated state (panels)")
def run_pressure(ctx):
    from ..pressure.state import candidates
    from ..pressure.study import domain_halfwidth, resolution_study, select_contact
    from ..solver.static import StaticSolver
    rated = ctx.require("rated_torque")
    backend = _exudyn_only(ctx, "contact-state extraction at one equilibrium (panels need the Exudyn model's state)")
    out = Outcome()
    model = ctx.build()
    if model.main_mesh != Family.PINS:
        raise Unsupported(f"local pressure extraction is implemented for the cycloid-pin mesh; this model's main "
                          f"mesh is {model.main_mesh.value!r}")
    model.set_output_torque(-np.sign(model.ratio) * rated)
    q = StaticSolver(model).solve(0.0)
    members = model.observe(q, model.main_mesh).per_member()
    ns = [129, 257, 513] if ctx.quick else [129, 257, 513, 1025, 2049, 4097]
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for k, member in enumerate(progress.track(list(members), desc="pressure", unit="member")):
        cands = candidates(model, q, "pins", k)
        best, _ = select_contact(cands, n_select=257, window=PRESSURE_WINDOW)
        rec, fields = resolution_study(best, ns, half=domain_halfwidth(best), window=PRESSURE_WINDOW)
        e1 = rec["e1_vs_4097_pct"][-2]      # key named after the case's finest grid; the reference is ns[-1]
        out.figures.append(Figure(f"p_window_{member}", rec["p_window"][-1] / 1e6, "MPa",
                                  f"largest {PRESSURE_WINDOW * 1e6:g} um window-mean pressure, {member} ({best.name})",
                                  e1, "%", f"e1 field difference of N = {ns[-2]} against N = {ns[-1]} panels "
                                           "(Eq. pressure_field_difference)"))
        out.figures.append(Figure(f"hertz_p0_{member}", best.hertz_peak / 1e6, "MPa",
                                  "Hertz line-contact peak of the same contact (closed form, for comparison)"))
        if not rec.get("converged", True):
            out.warnings.append(f"{member}: pressure resolution not converged at N = {ns[-1]}")
        out.data[member] = rec
        x, p = fields[-1]
        ax.plot(x * 1e6, p / 1e6, drawstyle="steps-mid", lw=0.8, label=f"{member}: {best.name}")
    ax.set(xlabel="x, across the contact from its centre [\u00b5m]", ylabel="contact pressure [MPa]",
           title=f"highest-pressure pin contact per wheel at {rated} N m ({ns[-1]} panels)")
    ax.legend(fontsize=7)
    out.plots.append(ctx.save(fig, "pressure"))
    out.settings = {"torque_Nm": rated, "input_angle_rad": 0.0, "panels": ns, "window_m": PRESSURE_WINDOW,
                    "backend": backend}
    return out


# -- Monte Carlo ---------------------------------------------------------------------------------

MC_REGULARIZATION = (1.0e4, 100.0)
"""Builder regularization springs [N/m, N m/rad] of the Monte Carlo variants, as in
cases/cycloid/monte_carlo_te.py: with pin clearance the lost-motion continuation crosses free play,
where the default springs (100 N/m, 0.1 N m/rad) let it stall (measured here: 3 of 4 quick
variants of RD-40 failed with the defaults)."""


MC_SEED = 2026
"""Seed of the tolerance Monte Carlo (variant k draws from default_rng([MC_SEED, k]))."""
MC_CYCLOID_VARIANTS = (4, 200)
"""Variants of the cycloid Monte Carlo (one batched Exudyn system per chunk on a CPU) under --quick and in full."""
MC_DESIGN_VARIANTS = (4, 40)
"""Variants of the design-variant Monte Carlo (RV, small-tooth-difference involute) under --quick and in
full: each variant is a design built and solved on the CPU path (two solves), as cases/monte_carlo_rv.py."""


def _design_variant_sampler(design):
    """(load tolerances, sample variant k) of a topology whose variants are designs (the RV and the
    small-tooth-difference involute reducers), or None."""
    from ..assembly.rv.spec import RVDesign
    from ..assembly.std_spec import StdInvoluteDesign
    if isinstance(design, RVDesign):
        from ..variants.rv_tolerances import load_rv_tolerances, sample_rv_design
        return load_rv_tolerances, sample_rv_design
    if isinstance(design, StdInvoluteDesign):
        from ..variants.std_tolerances import load_std_tolerances, sample_std_design
        return load_std_tolerances, sample_std_design
    return None


def load_tolerance_spec(design, path):
    """The tolerance spec of ``design``'s Monte Carlo from the tolerance file ``path``, by the loader of the
    design's topology (cycloid: :func:`rvtool.variants.tolerances.load_tolerances` and its design check; RV:
    :func:`rvtool.variants.rv_tolerances.load_rv_tolerances`; small-tooth-difference involute:
    :func:`rvtool.variants.std_tolerances.load_std_tolerances`). A file that is not TOML, an unknown key, a
    distribution without its parameters or a parameter out of range raises
    :class:`~rvtool.errors.RvtoolInputError` naming the file, the key and the valid range."""
    import tomllib

    from ..assembly.spec import CycloidDesign
    from ..variants.tolerances import load_tolerances
    sampler = _design_variant_sampler(design)
    try:
        if sampler is not None:
            return sampler[0](path)
        if not isinstance(design, CycloidDesign):
            raise RvtoolInputError(f"no tolerance Monte Carlo for {type(design).__name__}: its topology has no "
                                   f"variant sampler")
        spec = load_tolerances(path)
        spec.check_design(design)
        return spec
    except RvtoolInputError as exc:
        text = str(exc)
        raise RvtoolInputError(text if text.startswith(str(path)) else f"{path}: {text}") from None
    except tomllib.TOMLDecodeError as exc:
        raise RvtoolInputError(f"{path}: not a valid TOML file: {exc}") from None


def _design_variant_monte_carlo(ctx, sampler, out):
    """The tolerance Monte Carlo of a topology whose variants are designs: per variant the quick TE
    interval of the te protocol (one input revolution, 4 points per mesh cycle) at the rated torque
    and the lost motion at +-3 % of it (spring-controlled march); returns (n, the run's figures)."""

    from ..protocols.lost_motion import lost_motion
    from ..protocols.precision import quasi_static_te
    from ..variants.montecarlo import summarize
    _, sample = sampler
    try:
        spec = load_tolerance_spec(ctx.design, ctx.tolerances)
    except RvtoolInputError as exc:
        raise Unsupported(f"the tolerances do not apply to this design: {exc}") from None
    rated = ctx.require("rated_torque")
    n = MC_DESIGN_VARIANTS[0] if ctx.quick else MC_DESIGN_VARIANTS[1]
    angles, _, _ = _te_angles(ctx.build(), quick=True)
    records = []
    tick = progress.callback("Monte Carlo", "variant")
    for k in range(n):
        t0 = time.perf_counter()
        rec = {"index": k, "status": "ok", "error": None}
        drawn = {}
        try:
            # a variant its deviations make inadmissible (e.g. tooth interference) is a failed variant
            design, drawn = sample(spec, ctx.design, k, MC_SEED)
            qs = quasi_static_te(ctx.build(design), torque=rated, input_angles=angles)
            lm = lost_motion(ctx.build(design), torque_level=LOST_MOTION_FRACTION * rated)
            rec.update(te_pp_arcsec=float(np.ptp(qs["te"])) * ARCSEC_PER_RAD,
                       lost_motion_arcmin=lm["lost_motion_rad"] * ARCMIN_PER_RAD,
                       max_contact_force_N=max(qs["peak_loads"].values()) if qs["peak_loads"] else None)
        except (SolverFailure, RvtoolInputError) as exc:         # recorded, never dropped silently
            rec.update(status="failed", error=str(exc), te_pp_arcsec=None, lost_motion_arcmin=None,
                       max_contact_force_N=None)
        # per-tooth and per-crank draws: their largest magnitude; scalars as drawn
        rec["deviations"] = {f: (float(np.max(np.abs(np.asarray(v, float)))) if np.ndim(v) else float(v))
                             for f, v in drawn.items()}
        rec["wall_s"] = time.perf_counter() - t0
        records.append(rec)
        if tick:
            tick(k + 1, n)
    figures = ("te_pp_arcsec", "lost_motion_arcmin", "max_contact_force_N")
    return n, {"summary": summarize(records, figures=figures), "records": records}, figures


MC_MODES = {"device": "device", "fused": "device", "replica": "batched", "exudyn": "pool"}
"""The Monte Carlo's mode (:data:`rvtool.variants.montecarlo.MODES`) of each named backend: the device
Newton's variant batches, one batched Exudyn system per chunk (the replica idea for a batch of
designs), or one Exudyn model per variant on the pool (the oracle)."""


def _mc_backend(ctx):
    """(mode, choice) of the Monte Carlo for ``ctx.backend``. auto: on a CUDA device the device
    Newton where the design's copies build (TE alone 2,000-2,800 variants/s on an H100 against 45.6
    for a 16-process pool, :func:`rvtool.variants.montecarlo.resolve_mode`); on a CPU one batched
    Exudyn system per chunk, as before (the device Newton was not faster there: RD-40 on the 2-core
    machine, 2026-11-27, 16 variants x 53 TE points 20.6 s against 18.8 s, 4 x 23 10.1-11.8 s
    against 9.0-14.1 s; the pool is 3.3x slower than the batched system for the TE, module
    docstring of :mod:`rvtool.variants.montecarlo`). A named backend that cannot run the design
    skips the protocol with the reason."""
    from ..assembly.variant import Variant
    from ..solver.device_copies import copy_parameters
    reasons = {}
    try:
        copy_parameters(ctx.design, [Variant()], regularization=MC_REGULARIZATION)
    except (RvtoolInputError, AttributeError, TypeError) as exc:
        reasons["device"] = reasons["fused"] = f"the device copies cannot be built from this design: {exc}"
    if ctx.bearing_model not in (None, "lumped"):
        for b in ("device", "fused", "replica"):   # their variant batches build lumped bearings only
            reasons[b] = (f"--bearing-model {ctx.bearing_model}: the {b} Monte Carlo builds lumped bearings only "
                          "(valid there: lumped); one Exudyn model per variant runs it")
    if ctx.backend != "auto":
        if ctx.backend in reasons:
            raise Unsupported(f"backend = {ctx.backend!r} cannot run the Monte Carlo of this design: "
                              f"{reasons[ctx.backend]}")
        return MC_MODES[ctx.backend], {"requested": ctx.backend, "ran": ctx.backend, "not_taken": {
            b: f"not requested (--backend {ctx.backend})" for b in MC_MODES if b != ctx.backend}}
    on_gpu = str(ctx.device).startswith("cuda")
    ran = "device" if on_gpu and "device" not in reasons else "replica" if "replica" not in reasons else "exudyn"
    slower = {"device": "on a CPU not faster than one batched Exudyn system per chunk (measured, see "
                        "rvtool.analysis.protocols._mc_backend)",
              "fused": "the fused stepper runs driven runs; the Monte Carlo's device mode is 'device'",
              "replica": "on a CUDA device slower than the device Newton's variant batches",
              "exudyn": "one Exudyn model per variant: 3.3x slower than the batched system for the TE"}
    not_taken = {b: reasons.get(b, slower[b]) for b in MC_MODES if b != ran}
    return MC_MODES[ran], {"requested": "auto", "ran": ran, "not_taken": not_taken}


@register("monte_carlo", "tolerance Monte Carlo: TE p-p, lost motion and peak contact force over sampled variants")
def run_monte_carlo(ctx):
    import os
    import tempfile

    from ..variants import VariantProtocol
    from ..variants.montecarlo import MonteCarloSettings
    from ..variants.montecarlo import run_monte_carlo as mc
    if ctx.tolerances is None:
        raise Unsupported("no tolerance file: pass --tolerances FILE or put NAME_tolerances.toml beside the "
                          "design file NAME.toml ('rvtool new' writes one, 'rvtool new --tolerances-for "
                          "NAME.toml' for a design file of one's own; a shipped design uses its "
                          "<name>_tolerances.toml)")
    from ..assembly.spec import CycloidDesign
    out = Outcome()
    sampler = _design_variant_sampler(ctx.design)
    if sampler is not None:
        if ctx.backend not in ("auto", "exudyn"):
            raise Unsupported(f"backend = {ctx.backend!r} cannot run the Monte Carlo of "
                              f"{type(ctx.design).__name__}: its variants are designs solved on the Exudyn CPU path")
        choice = {"requested": ctx.backend, "ran": "exudyn", "not_taken": {
            b: "the design-variant Monte Carlo of this topology runs on the Exudyn CPU path only"
            for b in MC_MODES if b != "exudyn"}}
        n, res, names = _design_variant_monte_carlo(ctx, sampler, out)
        if ctx.scheduler:
            out.warnings.append(f"--scheduler {ctx.scheduler} was not used: this topology's Monte Carlo solves its "
                                "design variants one after another in this process")
        settings = {"tolerances": str(ctx.tolerances), "n_variants": n, "seed": MC_SEED, "mode": "design variants (cpu)",
                    "te_interval": "one input revolution, 4 points per mesh cycle (the quick te protocol's)",
                    "lost_motion_torque_fraction": LOST_MOTION_FRACTION, "backend": choice}
    elif not isinstance(ctx.design, CycloidDesign):
        raise Unsupported(f"no tolerance Monte Carlo for {type(ctx.design).__name__}: its topology has no variant sampler")
    else:
        try:
            tol = load_tolerance_spec(ctx.design, ctx.tolerances)
        except (RvtoolInputError, AttributeError) as exc:
            raise Unsupported(f"the tolerances do not apply to this design: {exc}") from None
        mode, choice = _mc_backend(ctx)
        n = MC_CYCLOID_VARIANTS[0] if ctx.quick else MC_CYCLOID_VARIANTS[1]
        protocol = VariantProtocol(n_te_points=23 if ctx.quick else 53, bearing_model=ctx.bearing_model or "lumped")
        mc_settings = MonteCarloSettings(n_variants=n, seed=MC_SEED, chunk_size=n if ctx.quick else 10,
                                         mode=mode, workers=1 if ctx.quick else None, device=ctx.device,
                                         scheduler=ctx.scheduler or "")
        with tempfile.TemporaryDirectory() as tmp:
            chunk_dir = os.path.join(ctx.out_dir, "monte_carlo_chunks") if ctx.out_dir else tmp
            res = mc(ctx.design, tol, protocol, mc_settings, chunk_dir, build_kw={"regularization": MC_REGULARIZATION},
                     progress=progress.callback("Monte Carlo", "variant"))
        names = ("te_pp_arcsec", "lost_motion_arcmin", "max_pin_force_N")
        if ctx.scheduler and mode in ("batched", "device") and (str(ctx.device) != "cpu" or mc_settings.workers == 1):
            # rvtool.variants.montecarlo runs such batches in this process (a Dask pool only for several CPU workers)
            out.warnings.append(f"--scheduler {ctx.scheduler} was not used: the {mode} Monte Carlo ran its variant "
                                f"batches in this process ({'--quick: one worker' if ctx.quick else ctx.device})")
        settings = {"tolerances": str(ctx.tolerances), "n_variants": n, "seed": mc_settings.seed,
                    "mode": mc_settings.mode, "regularization": MC_REGULARIZATION, "backend": choice,
                    "protocol": protocol.__dict__}
    s = res["summary"]
    if s["n_failed"]:
        errs = sorted({r["error"] for r in res["records"] if r["status"] != "ok"})
        out.warnings.append(f"{s['n_failed']} of {n} variants failed: {errs[:3]}")
    units = {"te_pp_arcsec": "arcsec", "lost_motion_arcmin": "arcmin", "max_pin_force_N": "N", "max_contact_force_N": "N"}
    for nm, unit in ((nm, units[nm]) for nm in names):
        st = s.get(nm, {})
        if not st.get("n"):
            out.warnings.append(f"{nm}: no successful variant")
            continue
        half = (st["mean_ci"][1] - st["mean_ci"][0]) / 2 if st["n"] > 1 else None
        name = nm.rsplit("_", 1)[0]
        out.figures.append(Figure(f"{name}_mean", st["mean"], unit, f"mean of {nm} over {st['n']} variants", half, unit,
                                  "half-width of the 95 % Student-t confidence interval of the mean (sampling error)"))
        ci = ", ".join("none (too few variants)" if b is None else f"{b:.4g}" for b in st["p95_ci"])
        out.figures.append(Figure(f"{name}_p95", st["p95"], unit, f"95th percentile of {nm}", None, unit,
                                  f"95 % order-statistic interval [{ci}] {unit}"))
    out.data = {"summary": s, "records": res["records"]}
    out.settings = settings
    out.plots.append(ctx.save(monte_carlo_histograms(res["records"]), "monte_carlo"))
    return out


def monte_carlo_histograms(records):
    """The Monte Carlo plot: histograms of TE p-p and lost motion over the variants of ``records``
    (:func:`rvtool.variants.montecarlo.run_monte_carlo`'s, those with status "ok"); a matplotlib figure."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator
    ok = [r for r in records if r["status"] == "ok"]
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    for a, nm, label in ((ax[0], "te_pp_arcsec", "TE p-p [arcsec]"), (ax[1], "lost_motion_arcmin", "lost motion [arcmin]")):
        x = [r[nm] for r in ok if r.get(nm) is not None]
        a.hist(x, bins=max(3, min(40, len(x) // 5)), color="0.6", edgecolor="k", lw=0.5)
        a.set(xlabel=label, ylabel="variants [-]", title=f"{len(x)} of {len(records)} variants")
        a.yaxis.set_major_locator(MaxNLocator(integer=True))       # a count: no 0.5 variant
    return fig
