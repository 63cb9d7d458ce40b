"""Dynamic TE of RD-40 tolerance variants: B variants in ONE batched run of the fused stepper, a
subset of the same variants on the Exudyn path as the reference.

Variants: drawn from rvtool/designs/rd40_tolerances.toml by the Monte Carlo's generator
(rvtool.variants.tolerances.sample_variants, seed 2026 as cases/monte_carlo_te.py, variant k
from default_rng([seed, k]), so variant k here is variant k there). Protocol (the dynamic TE
protocol, rvtool.protocols.precision.dynamic_te): rated torque, rated input speed, from each
variant's quasi-static loaded state at input angle 0 with its kinematic velocities, DURATION
seconds (--quick: DURATION_QUICK), generalized alpha with the RunSpec below.

Fused: rvtool.solver.device_dynamics.driven_copies on --device (cpu, cuda:0): the static starts
of all B variants in one device Newton solve, then all B copies in one DeviceDynamics run.
Reference: the first N_EXUDYN variants (--quick: 3), each built with
rvtool.assembly.cycloid.build(variant.apply(design)) and run by dynamic_te(solver="exudyn").

Reported: te_pp_arcsec per variant (p-p of Eq. (obs_te) over the run), te_pp_stats (mean,
p5/p50/p95), te_max_abs_diff_vs_exudyn_arcsec (largest |TE difference| over the reference
variants, on the Exudyn run's accepted times; the step sequences are equal when no copy rejects a
step), failed_copies (static start not converged, or step below min_step), copy_steps_per_s (the
accepted steps of all copies over the fused run's wall time, static starts excluded),
exudyn_steps_per_s (accepted steps over the Exudyn runs' wall time, static starts excluded),
speedup (their ratio), wall_s (fused: static start, run; exudyn: builds and runs; total).

Pass (honest): every copy ran, and the TE difference is within the Newton tolerance carried over
the steps (TE_TOL_PER_STEP_ARCSEC per step: abs_tol 1e-6 N over the pin stiffness ~2.6e8 N/m
gives 4e-15 m, 8e-14 rad = 1.6e-8 arcsec at the 50 mm pin circle; the errors could add up step by
step).
"""
import time

import numpy as np

from rvtool import casekit, designs
import rvtool
from rvtool.solver.device_copies import copy_parameters
from rvtool.protocols.precision import dynamic_te
from rvtool.solver import RunSpec
from rvtool.solver.device_dynamics import DONE, DeviceDynamicsSettings, driven_copies
from rvtool.units import ARCSEC_PER_RAD
from rvtool.variants.tolerances import load_tolerances, sample_variants

SEED = 2026
"""The Monte Carlo's seed (cases/monte_carlo_te.py): the same variants."""
STEP = 2e-5
"""Nominal step [s]: the README's dynamic RD-40 runs (one output revolution: 78,000 steps)."""
DURATION = 0.2
"""Full run [s]: 5 input revolutions at 1500 rpm (10,000 steps per copy)."""
DURATION_QUICK = 0.01
N_VARIANTS, N_VARIANTS_QUICK = 64, 12
"""Full: 64 x 10,000 copy-steps, ~1.5 min of fused stepper on one CPU core (130 us per copy-step
measured by cases/bench_cycloid.py); on a GPU pass --variants 1024 or more."""
N_EXUDYN, N_EXUDYN_QUICK = 4, 3
TE_TOL_PER_STEP_ARCSEC = 1.6e-8


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    return {
        # every variant's copy must finish: the fused stepper has no failure allowance (maximum 0)
        "failed_copies": casekit.check(r["failed_copies"], 0, "==", why="no copy may fail (maximum 0)"),
        "all_references_compared": casekit.check(r["exudyn_variants_compared"], r["exudyn_variants"], "==",
                                                 why="every Exudyn reference variant has its fused copy"),
        # same integrator, same steps: round-off accumulation only, TE_TOL_PER_STEP_ARCSEC per step
        "te_vs_exudyn": casekit.check(r["te_max_abs_diff_vs_exudyn_arcsec"], r["te_tolerance_arcsec"], "<=",
                                      why="round-off growth per step x steps (same step sequence)"),
    }


def _extra(parser):
    parser.add_argument("--device", default="cpu", help="Warp device of the fused stepper (cpu, cuda:0)")
    parser.add_argument("--variants", type=int, default=None,
                        help=f"number of variants B (default {N_VARIANTS}, --quick {N_VARIANTS_QUICK})")
    parser.add_argument("--duration", type=float, default=None,
                        help=f"simulated time [s] (default {DURATION}, --quick {DURATION_QUICK})")
    parser.add_argument("--exudyn", type=int, default=None,
                        help=f"variants run on the Exudyn path (default {N_EXUDYN}, --quick {N_EXUDYN_QUICK})")


def _stats(x):
    x = np.asarray(x, float)
    if len(x) == 0:
        return None
    p5, p50, p95 = np.percentile(x, [5, 50, 95])
    return {"mean": float(np.mean(x)), "p5": float(p5), "p50": float(p50), "p95": float(p95)}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=_extra)
    t_all = time.perf_counter()
    B = args.variants or (N_VARIANTS_QUICK if args.quick else N_VARIANTS)
    duration = args.duration or (DURATION_QUICK if args.quick else DURATION)
    n_exu = min(B, args.exudyn if args.exudyn is not None else (N_EXUDYN_QUICK if args.quick else N_EXUDYN))
    design = rvtool.load_design("rd40")
    variants = sample_variants(load_tolerances(designs.path("rd40_tolerances")), design, B, SEED)
    spec = RunSpec(end_time=duration, step=STEP, abs_tol=1e-6, rel_tol=1e-8)
    torque, rpm = design.rated_torque, design.input_speed_rpm

    # -- fused: all B variants in one batched run --------------------------------------------
    t0 = time.perf_counter()
    params = copy_parameters(design, variants)
    res = driven_copies(params, np.arange(B), torque=torque, speed_rpm=rpm, duration=duration,
                        settings=DeviceDynamicsSettings.from_run_spec(spec), device=args.device)
    fused_wall = time.perf_counter() - t0
    run, started = res["run"], res["started"]
    done = np.zeros(B, bool)
    if run is not None:
        done[np.flatnonzero(started)] = run.status == DONE
    te_pp = [float(np.ptp(te) * ARCSEC_PER_RAD) if ok else None for te, ok in zip(res["te"], done)]
    copy_steps = int(np.sum(run.accepted)) if run is not None else 0
    copy_rate = copy_steps / run.wall_s if run is not None and run.wall_s > 0 else None
    ti = {b: p for p, b in enumerate(np.flatnonzero(started))}      # variant -> row of the fused run

    # -- Exudyn reference: the first n_exu variants -------------------------------------------
    t1 = time.perf_counter()
    ref, diffs, exu_steps, exu_run_s = [], [], 0, 0.0
    for b in range(n_exu):
        model = rvtool.build(variants[b].apply(design))
        r = dynamic_te(model, torque=torque, speed_rpm=rpm, duration=duration, run_spec=spec, solver="exudyn")
        exu_steps += r["record"].accepted_steps
        exu_run_s += r["record"].wall_s
        d = None
        if done[b]:
            p = ti[b]
            d = float(np.max(np.abs(np.interp(r["t"], run.t[p], res["te"][b]) - r["te"])) * ARCSEC_PER_RAD)
            diffs.append(d)
        ref.append({"index": variants[b].index, "t": r["t"], "te": r["te"],
                    "te_pp_arcsec": float(np.ptp(r["te"]) * ARCSEC_PER_RAD), "diff_arcsec": d,
                    "same_steps": bool(done[b] and len(r["t"]) == len(run.t[ti[b]]))})
    exu_wall = time.perf_counter() - t1
    exu_rate = exu_steps / exu_run_s if exu_run_s > 0 else None

    failed = int(B - np.sum(done))
    max_diff = max(diffs) if diffs else None
    tol = TE_TOL_PER_STEP_ARCSEC * duration / STEP
    results = {
        "variants": B,
        "te_pp_arcsec": te_pp,
        "te_pp_stats": _stats([x for x in te_pp if x is not None]),
        "te_max_abs_diff_vs_exudyn_arcsec": max_diff,
        "failed_copies": failed,
        "copy_steps_per_s": copy_rate,
        "exudyn_steps_per_s": exu_rate,
        "speedup": copy_rate / exu_rate if copy_rate and exu_rate else None,
        "device": str(args.device),
        "wall_s": {"fused": fused_wall, "fused_run": run.wall_s if run is not None else None,
                   "exudyn": exu_wall, "exudyn_runs": exu_run_s, "total": time.perf_counter() - t_all},
        "te_tolerance_arcsec": tol,
        "exudyn_variants": n_exu,
        "exudyn_variants_compared": len(diffs),
    }
    casekit.verdict(results, judge)
    _plot(args.out, res, run, ti, done, ref, te_pp)
    settings = {"design": "rd40", "tolerances": "rd40_tolerances", "seed": SEED, "duration_s": duration,
                "torque_Nm": torque, "speed_rpm": rpm, "run_spec": spec.to_dict(), "exudyn_variants": n_exu,
                "te_tolerance_arcsec": tol, "exudyn_same_step_sequence": [r["same_steps"] for r in ref],
                "exudyn_te_pp_arcsec": [r["te_pp_arcsec"] for r in ref],
                "te_abs_diff_vs_exudyn_arcsec": [r["diff_arcsec"] for r in ref],
                "static_start_failures": int(B - np.sum(started))}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all,
                                 precision="float64", device=str(args.device))


def _plot(out, res, run, ti, done, ref, te_pp):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for b in np.flatnonzero(done)[:64]:
        p = ti[b]
        ax[0].plot(run.t[p] * 1e3, res["te"][b] * ARCSEC_PER_RAD, lw=0.5, color="0.55")
    for k, r in enumerate(ref):
        every = max(1, len(r["t"]) // 200)      # markers thin enough to show the fused line under them
        ax[0].plot(r["t"][::every] * 1e3, r["te"][::every] * ARCSEC_PER_RAD, "o", ms=2.5, mfc="none",
                   color=f"C{k}", label=f"Exudyn, variant {r['index']}")
    ax[0].set(xlabel="t [ms]", ylabel="TE [arcsec]",
              title="fused stepper (grey, up to 64 variants) vs Exudyn (markers)")
    ax[0].legend(fontsize=7)
    x = [v for v in te_pp if v is not None]
    ax[1].hist(x, bins=max(5, min(40, len(x) // 4)), color="0.6", edgecolor="k", lw=0.5)
    ax[1].set(xlabel="TE p-p over the run [arcsec]", ylabel="variants", title=f"{len(x)} variants, one batched run")
    casekit.save_figure(fig, out, "dynamic_te_variants")


if __name__ == "__main__":
    main()
