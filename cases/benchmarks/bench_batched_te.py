"""Quasi-static TE of many manufacturing variants: the device-resident batched Newton versus a
warmed process pool of per-variant runs over all CPU cores, in the same run (issue 19).

For each variant count V (``--variants``) the same V seeded RD-40 variants
(``bench_batched.sample_variants``) get the quasi-static TE of the Monte Carlo protocol
(``TE_POINTS`` = 53 equally spaced input angles over one output revolution,
rated torque, the Monte Carlo's regularization):

(a) device Newton: :func:`rvtool.batched.device_te.device_te` on ``--device``: every
    (variant, angle) pair is one copy of :class:`rvtool.solver.device_newton.DeviceNewton`,
    warm-started from the nominal equilibrium at its angle; copies that fail go to the
    per-variant Exudyn path (``fallback_copies``). Timed from the variants to the TE
    figures (parameters, nominal, device loop, fallbacks), after one small warm-up call that
    compiles the kernels.
(b) pool: per-variant :func:`rvtool.protocols.precision.quasi_static_te` (build included,
    StaticSolver, warm start from the previous angle) in a process pool over all CPU cores, at
    most ``--pool-max`` variants (its rate does not depend on V); every worker first runs one
    TE point of the nominal design (imports, Warp kernel load, first build).

Keys (lists per V): ``device_newton_variants_per_s``, ``ratio`` (device / pool),
``newton_iterations_per_point`` (mean per copy), ``us_per_copy_iteration`` (device loop wall
per copy and sweep), ``fallback_copies``; ``pool_variants_per_s``; ``te_max_abs_diff_arcsec``
(TE p-p, device vs pool, on the variants both ran). On the CPU, ``--device-workers N`` splits
the variants over N warmed processes (Warp's CPU kernels run on one core each), so that both
paths use all cores. ``--exudyn-batched SIZES`` adds the
earlier batched-Exudyn path (B copies in one Exudyn system) under ``exudyn_batched``.
--quick: V = 8 with 13 TE points.
"""
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from rvtool import casekit  # noqa: E402

DESIGN_PATH = casekit.import_case("bench_batched").DESIGN_PATH
sample_variants = casekit.import_case("bench_batched").sample_variants
from rvtool import load_design  # noqa: E402
from rvtool.units import ARCSEC_PER_RAD # noqa: E402
from rvtool.protocols.precision import te_metrics, transmission_error # noqa: E402
from rvtool.variants import VariantProtocol  # noqa: E402


TE_POINTS = 53
"""TE points per variant: the Monte Carlo's (cases/monte_carlo_te.py N_TE)."""


def _per_variant_te(args):
    """TE p-p [arcsec] of one variant by the sequential path (None if it fails)."""
    from rvtool import build
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
    from rvtool import build
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


def _device_share(args):
    """Device Newton TE of one share of the variants in a worker process (cpu: one core each)."""
    from rvtool.batched.device_te import device_te
    design, variants, angles, reg, device, settings, chunk = args
    r = device_te(design, variants, angles, regularization=reg, device=device, settings=settings, chunk_pairs=chunk,
                  pin_forces=False)
    return r.te_pp_arcsec, r.stats


def _warm_device(args):
    """Kernel load and compilation in a device worker, before the timed run."""
    from rvtool.batched.device_te import device_te
    design, variants, angles, reg, pause = args
    device_te(design, variants, angles, regularization=reg)
    time.sleep(pause)
    return os.getpid()


def _extra(parser):
    parser.add_argument("--device", default="cpu", help="Warp device of the device Newton (cpu, cuda:0)")
    parser.add_argument("--variants", default=None, help="comma-separated variant counts V")
    parser.add_argument("--pool-max", type=int, default=64, help="largest number of variants run by the pool")
    parser.add_argument("--te-points", type=int, default=None, help="TE points per variant")
    parser.add_argument("--max-iterations", type=int, default=30, help="Newton iterations per solve (both paths)")
    parser.add_argument("--chunk-pairs", type=int, default=None, help="copies per device loop (default per device)")
    parser.add_argument("--regularization", default="1e4,100",
                        help="builder regularization springs [N/m],[N m/rad] (the Monte Carlo's; both paths)")
    parser.add_argument("--device-workers", type=int, default=1,
                        help="cpu only: processes the device Newton's variants are split over (one core each)")
    parser.add_argument("--exudyn-batched", default=None,
                        help="also time the batched-Exudyn path at these comma-separated batch sizes")


def judge(r):
    """The benchmark's correctness checks (see casekit.verdict); its rates are reported, not judged."""
    return {
        "pool_failed_variants": casekit.check(r["pool_failed"], 0, "==", why="maximum 0 failed pool variants"),
        # every pool variant has its device TE (a device copy that fails goes to the Exudyn fallback, so a
        # missing value is a failure)
        "every_variant_compared": casekit.check(
            sum(a != b for a, b in zip(r["compared_variants"], r["compared_expected"])), 0, "==",
            why="a finite device TE for every successful pool variant"),
        # device Newton and Exudyn solve the same equilibria to abs_tol 1e-6 N: measured 1.8e-10 arcsec
        "te_vs_pool": casekit.check(r["te_max_abs_diff_arcsec"], 1e-6, "<=", why="Newton tolerance (1e-6 N)"),
    }


def main(argv=None):
    from rvtool.batched.device_te import device_te
    from rvtool.solver.device_newton import DeviceNewtonSettings
    args = casekit.parse_args(argv, __doc__, extra=_extra)
    t_start = time.perf_counter()
    design = load_design(DESIGN_PATH)
    on_gpu = args.device.startswith("cuda")
    sizes = (tuple(int(x) for x in args.variants.split(",")) if args.variants else
             (8,) if args.quick else (1024, 8192) if on_gpu else (64, 256))
    n_te = args.te_points or (13 if args.quick else TE_POINTS)
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
        pool_pp = list(ex.map(_per_variant_te, [(design, v, angles, args.max_iterations, reg, "warm")
                                                for v in variants[:n_pool]]))
    pool_s = time.perf_counter() - t0
    pool_rate = n_pool / pool_s
    settings = {"te_points": n_te, "variants": list(sizes), "device": args.device, "pool_workers": workers,
                "device_workers": args.device_workers if not on_gpu else 1,
                "pool_variants": n_pool, "pool_failed": sum(p is None for p in pool_pp), "pool_warmup_s": pool_warmup_s,
                "pool_workers_warmed": warmed, "abs_tol_N": 1e-6, "max_iterations": args.max_iterations,
                "regularization": list(reg), "chunk_pairs": args.chunk_pairs, "device_stats": []}
    out = {"pool_variants_per_s": pool_rate, "device_newton_variants_per_s": [], "ratio": [],
           "newton_iterations_per_point": [], "us_per_copy_iteration": [], "fallback_copies": [],
           "te_max_abs_diff_arcsec": 0.0, "pool_failed": settings["pool_failed"], "compared_variants": [],
           "compared_expected": []}
    dn_settings = DeviceNewtonSettings(max_iterations=args.max_iterations)
    # warm-up: kernel compilation (and the first CUDA context use) is not part of the rate
    device_te(design, variants[:1], angles[:2], regularization=reg, device=args.device, settings=dn_settings)
    nw = args.device_workers if not on_gpu else 1
    dex = None
    if nw > 1:
        dex = ProcessPoolExecutor(max_workers=nw)
        list(dex.map(_warm_device, [(design, variants[:1], angles[:2], reg, 2.0)] * nw))
    for V in sizes:
        t0 = time.perf_counter()
        if dex is None:
            r = device_te(design, variants[:V], angles, regularization=reg, device=args.device, settings=dn_settings,
                          chunk_pairs=args.chunk_pairs, pin_forces=False)
            pp, st = r.te_pp_arcsec, r.stats
        else:
            shares = np.array_split(np.arange(V), nw)
            res = list(dex.map(_device_share, [(design, [variants[i] for i in sh], angles, reg, args.device,
                                                dn_settings, args.chunk_pairs) for sh in shares]))
            pp = np.concatenate([x[0] for x in res])
            sts = [x[1] for x in res]
            st = dict(sts[0])
            for k in ("fallback_copies", "failed_copies", "copy_sweeps", "pairs"):
                st[k] = sum(x[k] for x in sts)
            st["device_loop_s"] = max(x["device_loop_s"] for x in sts)
            st["newton_iterations_per_point"] = sum(x["newton_iterations_per_point"] * x["pairs"] for x in sts) / st["pairs"]
            # per process: loop wall over the copies it iterated (the processes run side by side)
            st["us_per_copy_iteration"] = sum(1e6 * x["device_loop_s"] for x in sts) / st["copy_sweeps"]
            st["path"] = f"{sts[0]['path']} x {nw} processes"
        wall = time.perf_counter() - t0
        rate = V / wall
        out["device_newton_variants_per_s"].append(rate)
        out["ratio"].append(rate / pool_rate)
        out["newton_iterations_per_point"].append(st["newton_iterations_per_point"])
        out["us_per_copy_iteration"].append(st["us_per_copy_iteration"])
        out["fallback_copies"].append(st["fallback_copies"])
        settings["device_stats"].append({"V": V, **st})
        compared = 0
        for a, b in zip(pp[:n_pool], pool_pp):
            if b is not None and np.isfinite(a):
                out["te_max_abs_diff_arcsec"] = max(out["te_max_abs_diff_arcsec"], abs(a - b))
                compared += 1
        out["compared_variants"].append(compared)
        out["compared_expected"].append(sum(b is not None for b in pool_pp[:min(V, n_pool)]))
        print(f"V={V}: device Newton {rate:.1f} variants/s ({st['path']}, {st['newton_iterations_per_point']:.2f} "
              f"it/point, {st['us_per_copy_iteration']:.2f} us per copy iteration, {st['fallback_copies']} fallbacks), "
              f"pool {pool_rate:.1f} variants/s, ratio {rate / pool_rate:.2f}", flush=True)
        casekit.verdict(out, judge)
        res = casekit.write_results(args.out, out, settings=settings, wall_s=time.perf_counter() - t_start,
                                    device=args.device)
    if dex is not None:
        dex.shutdown()
    if args.exudyn_batched:
        out["exudyn_batched"] = []
        for B in (int(x) for x in args.exudyn_batched.split(",")):
            pp, br = batched_te(design, variants[:B], angles, args.device, args.max_iterations, reg, "warm")
            out["exudyn_batched"].append({"B": B, "variants_per_s": B / br["solve_s"], **br})
        casekit.verdict(out, judge)
        res = casekit.write_results(args.out, out, settings=settings, wall_s=time.perf_counter() - t_start,
                                    device=args.device)
    return res


if __name__ == "__main__":
    main()
