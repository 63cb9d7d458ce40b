"""Benchmark of RD-40 (double wheel): per-step cost breakdown and the cost of TE over one output revolution.

Quasi-static TE over one output revolution at 40 points per mesh cycle
(62,400 equilibria) and dynamic TE over one output revolution at 1500 rpm
(1.56 s simulated, 2e-5 s steps). --quick measures one mesh cycle and 200
dynamic steps and reports the projected full-revolution times; the full run
measures the complete revolutions. The per-step breakdown splits the wall
time into Exudyn (solver, assembly, linear algebra), the contact callbacks
(Python side of the elements) and the kernel launches inside them.
"""
import time

import numpy as np

from rvtool import casekit
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.protocols.precision import ARCSEC, dynamic_te, quasi_static_te
from rvtool.solver import RunSpec

import os
DESIGN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "designs", "rd40.toml")


def _instrument(model):
    """Wrap each element's evaluate and each evaluator's raw with wall-time counters."""
    timers = {"callback_s": 0.0, "kernel_s": 0.0, "calls": 0}
    for el in model.elements.values():
        ev, raw = el.evaluate, el.evaluator.raw

        def timed_eval(*a, _f=ev, **k):
            t = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                timers["callback_s"] += time.perf_counter() - t
                timers["calls"] += 1

        def timed_raw(*a, _f=raw, **k):
            t = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                timers["kernel_s"] += time.perf_counter() - t
        el.evaluate = timed_eval
        el.evaluator.raw = timed_raw
    return timers


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    d = load_design(DESIGN)
    zb, zg = d.pins.n_pins, d.pins.n_pins - 1
    full_points = zb * zg * 40
    n_qs = 40 if args.quick else full_points
    angles = np.arange(n_qs) * (2 * np.pi / zb) / 40
    model = build(d)
    timers = _instrument(model)
    qs = quasi_static_te(model, torque=d.rated_torque, input_angles=angles)
    qs_per_point = qs["wall_s"] / n_qs
    qs_breakdown = {k: timers[k] for k in ("callback_s", "kernel_s")}
    duration_full = abs(d.ratio) * 60.0 / d.input_speed_rpm
    step = 2e-5
    dur = 200 * step if args.quick else duration_full
    dmodel = build(d)
    dtimers = _instrument(dmodel)
    spec = RunSpec(end_time=dur, step=step, abs_tol=1e-6, rel_tol=1e-8)
    dyn = dynamic_te(dmodel, torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=dur, run_spec=spec,
                     on_start=lambda: dtimers.update(callback_s=0.0, kernel_s=0.0, calls=0))
    rec = dyn["record"]
    per_step = rec.wall_s / rec.accepted_steps
    cb = dtimers["callback_s"] / rec.accepted_steps
    kn = dtimers["kernel_s"] / rec.accepted_steps
    results = {
        "quasistatic_points": n_qs,
        "quasistatic_ms_per_point": 1e3 * qs_per_point,
        "quasistatic_newton_per_point": qs["stats"]["newton_iterations"] / n_qs,
        "quasistatic_full_revolution_s": qs["wall_s"] if not args.quick else qs_per_point * full_points,
        "quasistatic_full_revolution_measured": not args.quick,
        "quasistatic_target_s": 20.0,
        "quasistatic_callback_share": qs_breakdown["callback_s"] / qs["wall_s"],
        "dynamic_steps": rec.accepted_steps,
        "dynamic_us_per_step": 1e6 * per_step,
        "dynamic_full_revolution_s": rec.wall_s if not args.quick else per_step * duration_full / step,
        "dynamic_full_revolution_measured": not args.quick,
        "dynamic_target_s": 300.0,
        "step_breakdown_us": {"total": 1e6 * per_step, "callbacks": 1e6 * cb, "kernels": 1e6 * kn,
                              "exudyn_and_driver": 1e6 * (per_step - cb)},
        "newton_per_step": rec.newton_iterations / rec.accepted_steps,
        "rejected_steps": rec.rejected_steps,
        "te_pp_quasistatic_arcsec": float(np.ptp(qs["te"]) * ARCSEC),
        "wall_s": time.perf_counter() - t_all,
    }
    settings = {"points_per_mesh_cycle": 40, "dynamic_step_s": step, "run_spec": spec.to_dict(), "bearing_model": "lumped"}
    return casekit.write_results(args.out, results, settings=settings, wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
