"""Quasi-static TE of many manufacturing variants: batched copies on one device versus a pool
of per-variant runs over all CPU cores (issue 8, performance).

For each batch size B the same B seeded RD-40 variants (``bench_batched.sample_variants``)
get the quasi-static TE of the Monte Carlo protocol (``VariantProtocol().n_te_points``
equally spaced input angles over one output revolution, rated torque):

(a) batched: one Exudyn system of B copies (:func:`rvtool.batched.build_batched`) on
    ``--device`` (Warp kernels there; Exudyn's sparse solve and the Python callbacks stay on
    the CPU), all copies at the same angle per batch Newton solve, secant warm starts;
(b) pool: per-variant :func:`rvtool.protocols.precision.quasi_static_te` in a process pool
    over all CPU cores, at most ``--pool-max`` variants (its rate does not depend on B); every
    worker first runs one TE point of the nominal design (imports, Warp kernel load, first
    build), so the timed rate is the steady state, like the batched rate without its build.

Reports variants per second of both (the batched rate with and without its build), the
winner, the time per batch Newton iteration split into Exudyn (assembly + sparse solve),
Python callbacks, kernel launches with transfers, and block scatter, and the largest TE
difference between the two paths on the variants both ran (the reference). --quick:
B = 4, 16 with 13 TE points.
"""
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from bench_batched import DESIGN_PATH, sample_variants  # noqa: E402
from rvtool import casekit  # noqa: E402
from rvtool.assembly.spec import load_design  # noqa: E402
from rvtool.units import ARCSEC_PER_RAD # noqa: E402
from rvtool.protocols.precision import te_metrics, transmission_error # noqa: E402
from rvtool.variants import VariantProtocol  # noqa: E402


def _per_variant_te(args):
    """TE p-p [arcsec] of one variant by the sequential path (None if it fails)."""
    from rvtool.assembly.cycloid import build
    from rvtool.solver.static import StaticSolver
    from rvtool.protocols.precision import quasi_static_te
    design, v, angles, max_it, reg, start = args
    d = v.apply(design)
    try:
        m = build(d, regularization=reg)
        r = quasi_static_te(m, torque=d.rated_torque, input_angles=angles,
                            solver=StaticSolver(m, max_iterations=max_it), warm_start=start == "warm")
    except Exception:                 # a failed variant is a row of the study, not the end of it
        return None
    return te_metrics(r["te"])["pp"] * ARCSEC_PER_RAD


def _warm_worker(args):
    """One TE point of the nominal design: imports, Warp's kernel load and the first build happen
    here, before the timed pool (the batched rate is quoted without its one-off build too)."""
    design, reg, pause = args
    from rvtool.assembly.cycloid import build
    from rvtool.protocols.precision import quasi_static_te
    quasi_static_te(build(design, regularization=reg), torque=design.rated_torque, input_angles=[0.0])
    time.sleep(pause)                 # keeps this worker busy so that every worker gets one
    return os.getpid()


def batched_te(design, variants, angles, device, max_it, reg, start):
    """TE p-p [arcsec] per variant (NaN: failed) and timing of the batched path."""
    from rvtool.batched import build_batched
    from rvtool.solver.batched import BatchedStaticSolver
    t0 = time.perf_counter()
    model = build_batched(design, variants, device=device, regularization=reg)
    solver = BatchedStaticSolver(model, max_iterations=max_it, build_kw={"regularization": reg})
    build_s = time.perf_counter() - t0
    ratio = np.array([m.design.ratio for m in model.copies])
    solver.set_torques(-np.sign(ratio) * np.array([m.design.rated_torque for m in model.copies]))
    i_out = 3 * (model.nb - 1) + 2
    ref_out = np.array([m.reference[-1, 2] for m in model.copies])
    th_out, prev = [], None
    t1 = time.perf_counter()
    for a in angles:
        q = solver.solve(a, prev if start == "warm" else None, predictor="secant")
        prev = a
        th_out.append(ref_out + q[:, i_out])
    solve_s = time.perf_counter() - t1
    th_out = np.array(th_out)
    pp = np.array([np.nan if solver.dead[c] else
                   te_metrics(transmission_error(angles, th_out[:, c], ratio[c], unwrap=False))["pp"] * ARCSEC_PER_RAD
                   for c in range(len(variants))])
    st = solver.stats
    ev = model.evaluator
    it, ne = max(st.newton_iterations, 1), max(ev.n_evaluations, 1)
    breakdown = {"B": len(variants), "build_s": build_s, "solve_s": solve_s, "batch_solves": st.solves,
                 "newton_iterations": st.newton_iterations, "evaluations": ev.n_evaluations,
                 "exudyn_assembly_solve_ms_per_it": 1e3 * (st.solve_s - st.callback_s) / it,
                 "python_callbacks_ms_per_it": 1e3 * (st.callback_s - st.kernel_s) / it,
                 "kernel_launch_and_transfer_ms_per_eval": 1e3 * ev.timing["kernels"] / ne,
                 "block_scatter_ms_per_eval": 1e3 * ev.timing["scatter"] / ne,
                 "outside_solves_s": solve_s - st.solve_s, "failed_copies": st.failed_copies,
                 "fallbacks": st.fallbacks}
    return pp, breakdown


def _extra(parser):
    parser.add_argument("--device", default="cpu", help="Warp device of the batched kernels (cpu, cuda:0)")
    parser.add_argument("--sizes", default=None, help="comma-separated batch sizes")
    parser.add_argument("--pool-max", type=int, default=64, help="largest number of variants run by the pool")
    parser.add_argument("--te-points", type=int, default=None, help="TE points per variant")
    parser.add_argument("--max-iterations", type=int, default=30, help="Newton iterations per solve (both paths)")
    parser.add_argument("--start", default="warm", choices=("homotopy", "warm"),
                        help="start of each TE point: the stiffness homotopy from the kinematic state, or the "
                             "previous point's equilibrium (both paths)")
    parser.add_argument("--regularization", default="1e4,100",
                        help="builder regularization springs [N/m],[N m/rad] (the Monte Carlo's; both paths)")


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=_extra)
    t_start = time.perf_counter()
    design = load_design(DESIGN_PATH)
    sizes = tuple(int(x) for x in args.sizes.split(",")) if args.sizes else ((4, 16) if args.quick else (16, 64, 256))
    n_te = args.te_points or (13 if args.quick else VariantProtocol().n_te_points)
    angles = VariantProtocol(n_te_points=n_te).input_angles(design)
    workers = os.cpu_count() or 1
    reg = tuple(float(x) for x in args.regularization.split(","))
    variants = sample_variants(max(sizes))
    n_pool = min(args.pool_max, max(sizes))
    with ProcessPoolExecutor(max_workers=workers) as ex:
        t0 = time.perf_counter()
        warmed = len(set(ex.map(_warm_worker, [(design, reg, 2.0)] * workers)))
        pool_warmup_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        pool_pp = list(ex.map(_per_variant_te, [(design, v, angles, args.max_iterations, reg, args.start) for v in variants[:n_pool]]))
    pool_s = time.perf_counter() - t0
    pool_rate = n_pool / pool_s
    out = {"batch_sizes": list(sizes), "device": args.device, "te_points": n_te, "pool_workers": workers,
           "pool_variants": n_pool, "pool_variants_per_s": pool_rate, "pool_failed": sum(p is None for p in pool_pp),
           "pool_warmup_s": pool_warmup_s, "pool_workers_warmed": warmed,
           "batched_variants_per_s": [], "batched_variants_per_s_with_build": [], "winner": [], "speedup_vs_pool": [],
           "breakdown": [], "te_pp_max_abs_diff_arcsec": 0.0}
    settings = {"te_points": n_te, "sizes": list(sizes), "pool_max": args.pool_max, "predictor": "secant",
                "abs_tol_N": 1e-6, "max_iterations": args.max_iterations, "regularization": list(reg),
                "start": args.start}
    for B in sizes:
        pp, br = batched_te(design, variants[:B], angles, args.device, args.max_iterations, reg, args.start)
        rate = B / br["solve_s"]
        out["batched_variants_per_s"].append(rate)
        out["batched_variants_per_s_with_build"].append(B / (br["solve_s"] + br["build_s"]))
        out["winner"].append("batched" if rate > pool_rate else "pool")
        out["speedup_vs_pool"].append(rate / pool_rate)
        out["breakdown"].append(br)
        for a, b in zip(pp[:n_pool], pool_pp):
            if b is not None and np.isfinite(a):
                out["te_pp_max_abs_diff_arcsec"] = max(out["te_pp_max_abs_diff_arcsec"], abs(a - b))
        print(f"B={B}: batched {rate:.1f} variants/s (+build {br['build_s']:.1f} s), pool {pool_rate:.1f} variants/s",
              flush=True)
        # written after every batch size: a long GPU run leaves its finished sizes behind
        out["wall_s"] = time.perf_counter() - t_start
        res = casekit.write_results(args.out, out, settings=settings, wall_s=out["wall_s"], device=args.device)
    return res


if __name__ == "__main__":
    main()
