"""Benchmark of RD-40 (double wheel): per-step cost breakdown and the cost of TE over one output revolution.

Quasi-static TE over one output revolution at 40 points per mesh cycle
(62,400 equilibria), solved two ways: the sequential path (one Exudyn static
solve per point, rvtool.protocols.precision.quasi_static_te) and the
angle-batched path (rvtool.batched.sequence: 64 angle segments side by side in
one Exudyn system per worker, 2 workers); the sequential TE is the reference of
the batched one (max |TE difference|). Dynamic TE over one output revolution at
1500 rpm (1.56 s simulated, 2e-5 s steps). --quick measures one input
revolution (1,600 points) quasi-statically and 200 dynamic steps and reports
projected full-revolution times; the full run measures the complete revolutions. The per-step breakdown splits the wall
time into Exudyn (solver, assembly, linear algebra), the contact callbacks
(Python side of the elements) and the kernel launches inside them.
"""
import os
import time

import numpy as np

from rvtool import casekit
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.batched.sequence import batched_quasi_static_te
from rvtool.units import ARCSEC_PER_RAD
from rvtool.protocols.precision import dynamic_te, quasi_static_te
from rvtool.solver import RunSpec
from rvtool import designs

DESIGN = designs.path("rd40")


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
    n_qs = zb * 40 if args.quick else full_points
    angles = np.arange(n_qs) * (2 * np.pi / zb) / 40
    model = build(d)
    timers = _instrument(model)
    qs = quasi_static_te(model, torque=d.rated_torque, input_angles=angles)
    qs_per_point = qs["wall_s"] / n_qs
    qs_breakdown = {k: timers[k] for k in ("callback_s", "kernel_s")}
    workers = min(2, os.cpu_count() or 1)
    bq = batched_quasi_static_te(d, torque=d.rated_torque, input_angles=angles, workers=workers)
    # the batched path has a fixed start (worker spawn, build, one cold start per segment):
    # a per-point projection from a short run would overstate it, so --quick reports no full time
    bq_full = None if args.quick else bq["wall_s"]
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
        "quasistatic_batched_full_revolution_s": bq_full,
        "quasistatic_batched_wall_s": bq["wall_s"],
        "quasistatic_batched_ms_per_point": 1e3 * bq["wall_s"] / n_qs,
        "quasistatic_batched_build_s": bq["build_s"],
        "quasistatic_batched_copies": bq["copies"],
        "quasistatic_batched_workers": bq["workers"],
        "quasistatic_batched_newton_per_solve": bq["stats"]["newton_iterations"] / bq["stats"]["solves"],
        "quasistatic_batched_homotopy_copies": bq["stats"]["homotopy_copies"],
        "quasistatic_batched_te_max_abs_diff_arcsec": float(np.max(np.abs(bq["te"] - qs["te"])) * ARCSEC_PER_RAD),
        "quasistatic_batched_peak_load_max_rel_diff": max(
            abs(bq["peak_loads"][k] - v) / max(v, 1.0) for k, v in qs["peak_loads"].items()),
        "quasistatic_target_met": None if bq_full is None else bool(bq_full < 20.0),
        "dynamic_steps": rec.accepted_steps,
        "dynamic_us_per_step": 1e6 * per_step,
        "dynamic_full_revolution_s": rec.wall_s if not args.quick else per_step * duration_full / step,
        "dynamic_full_revolution_measured": not args.quick,
        "dynamic_target_s": 300.0,
        "step_breakdown_us": {"total": 1e6 * per_step, "callbacks": 1e6 * cb, "kernels": 1e6 * kn,
                              "exudyn_and_driver": 1e6 * (per_step - cb)},
        "newton_per_step": rec.newton_iterations / rec.accepted_steps,
        "rejected_steps": rec.rejected_steps,
        "te_pp_quasistatic_arcsec": float(np.ptp(qs["te"]) * ARCSEC_PER_RAD),
        "wall_s": time.perf_counter() - t_all,
    }
    settings = {"points_per_mesh_cycle": 40, "dynamic_step_s": step, "run_spec": spec.to_dict(), "bearing_model": "lumped",
                "quasistatic_points": n_qs, "batched": {"copies": bq["copies"], "workers": bq["workers"],
                                                        "abs_tol_N": 1e-4, "predictor": "secant"},
                "sequential_abs_tol_N": 1e-6}
    return casekit.write_results(args.out, results, settings=settings, wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
