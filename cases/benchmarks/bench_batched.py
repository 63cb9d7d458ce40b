"""Batched variants in one Exudyn system versus a process pool of per-variant runs (issue 8 part 2).

For each batch size B, the same B seeded RD-40 manufacturing variants are run through
the quasi-static TE + lost-motion protocol (:class:`rvtool.variants.VariantProtocol`)
(a) batched: :func:`rvtool.batched.batched_variant_figures` (one Exudyn system, one
kernel launch per contact family for all copies) and (b) per variant:
:func:`rvtool.variants.variant_figures` in a ``ProcessPoolExecutor`` over all cores.
Reports variants per second of each, the winner per B, the time per batch Newton
iteration split into Exudyn (assembly + sparse solve), Python callbacks and kernels
(launch + block scatter), and the largest difference of the figures between the two
paths. Full: B = 1, 4, 16, 64, 256 with 7 TE points; --quick: B = 1, 4 with 5 points.

Options for a GPU machine: ``--device cuda:0`` runs the batched kernels there, ``--sizes
256,1024`` sets the batch sizes, ``--pool-max N`` runs the pool on at most N of the B
variants (its rate, variants per second over all cores, does not depend on B; the
figures are compared on those N).
"""
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from rvtool import casekit  # noqa: E402
from rvtool import load_design  # noqa: E402
from rvtool.variants.batched import batched_variant_figures  # noqa: E402
from rvtool.variants import Variant, VariantProtocol, variant_figures  # noqa: E402
from rvtool import designs

DESIGN_PATH = designs.path("rd40")
FIGURES = ("te_pp_arcsec", "max_pin_force_N", "lost_motion_arcmin")


def sample_variants(n, seed=0):
    """Seeded variants with micrometre-class tolerances (ISO IT5-6 class for these sizes)."""
    rng = np.random.default_rng(seed)
    return [Variant(index=i, eccentricity_error=rng.normal(0, 1e-6), pin_centre_errors=rng.normal(0, 2e-6, (40, 2)),
                    pin_radius_error=rng.normal(0, 1e-6), pin_clearance=abs(rng.normal(0, 2e-6))) for i in range(n)]


def _one(args):
    design, v, protocol = args
    try:
        return {**variant_figures(design, v, protocol), "status": "ok"}
    except Exception as exc:          # a failed variant is a row of the study, not the end of it
        return {"status": "failed", "error": str(exc)}


def _extra(parser):
    parser.add_argument("--device", default="cpu", help="Warp device of the batched kernels (cpu, cuda:0)")
    parser.add_argument("--sizes", default=None, help="comma-separated batch sizes")
    parser.add_argument("--pool-max", type=int, default=None, help="largest number of variants run by the pool")
    parser.add_argument("--te-points", type=int, default=None, help="TE points per variant")


def judge(r):
    """The benchmark's correctness checks (see casekit.verdict); its rates are reported, not judged."""
    d = r["max_abs_diff_vs_per_variant"]
    return {
        # no copy may fail on either path (maximum 0); a fallback is a copy redone per variant, not a failure
        "batched_failed_copies": casekit.check(sum(r["failed_copies"]), 0, "==", why="maximum 0"),
        "pool_failed_variants": casekit.check(sum(r["pool_failed"]), 0, "==", why="maximum 0"),
        # the same equilibria in one system or one per variant: Newton's tolerance apart (measured 1.5e-8
        # arcsec, 8e-8 N, 0 arcmin); bounds as the Monte Carlo's mode agreement
        "te_vs_per_variant": casekit.check(d["te_pp_arcsec"], 1e-6, "<=", why="Newton tolerance"),
        "pin_force_vs_per_variant": casekit.check(d["max_pin_force_N"], 1e-3, "<=", why="Newton tolerance"),
        "lost_motion_vs_per_variant": casekit.check(d["lost_motion_arcmin"], 1e-4, "<=",
                                                    why="Newton tolerance of the continuation"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=_extra)
    t_start = time.perf_counter()
    design = load_design(DESIGN_PATH)
    sizes = (1, 4) if args.quick else (1, 4, 16, 64, 256)
    if args.sizes:
        sizes = tuple(int(x) for x in args.sizes.split(","))
    protocol = VariantProtocol(n_te_points=args.te_points or (5 if args.quick else 7))
    workers = os.cpu_count() or 1
    out = {"batch_sizes": list(sizes), "batched_variants_per_s": [], "pool_variants_per_s": [], "winner": [],
           "breakdown": [], "max_abs_diff_vs_per_variant": {k: 0.0 for k in FIGURES}, "pool_workers": workers,
           "failed_copies": [], "fallbacks": []}
    for B in sizes:
        vs = sample_variants(B)
        t0 = time.perf_counter()
        res, model, solver = batched_variant_figures(design, vs, protocol, return_model=True, device=args.device)
        tb = time.perf_counter() - t0
        n_pool = B if args.pool_max is None else min(B, args.pool_max)
        t0 = time.perf_counter()
        with ProcessPoolExecutor(max_workers=workers) as ex:
            ref = list(ex.map(_one, [(design, v, protocol) for v in vs[:n_pool]]))
        tp = time.perf_counter() - t0
        out["batched_variants_per_s"].append(B / tb)
        out["pool_variants_per_s"].append(n_pool / tp)
        out["winner"].append("batched" if B / tb > n_pool / tp else "pool")
        st = solver.stats
        it = max(st.newton_iterations, 1)
        out["breakdown"].append({"B": B, "pool_variants": n_pool, "wall_batched_s": tb, "wall_pool_s": tp,
                                 "newton_iterations": st.newton_iterations,
                                 "batch_solves": st.solves,
                                 "exudyn_assembly_solve_ms_per_it": 1e3 * (st.solve_s - st.callback_s) / it,
                                 "python_callbacks_ms_per_it": 1e3 * (st.callback_s - st.kernel_s) / it,
                                 "kernels_ms_per_it": 1e3 * st.kernel_s / it,
                                 "kernel_launch_and_transfer_ms_per_eval": 1e3 * model.evaluator.timing["kernels"]
                                 / max(model.evaluator.n_evaluations, 1),
                                 "block_scatter_ms_per_eval": 1e3 * model.evaluator.timing["scatter"]
                                 / max(model.evaluator.n_evaluations, 1),
                                 "outside_solves_s": tb - st.solve_s})
        out["failed_copies"].append(st.failed_copies)
        out["fallbacks"].append(st.fallbacks)
        out.setdefault("pool_failed", []).append(sum(p["status"] != "ok" for p in ref))
        for r, p in zip(res, ref):
            if r["status"] != "ok" or p["status"] != "ok":
                continue
            for k in FIGURES:
                out["max_abs_diff_vs_per_variant"][k] = max(out["max_abs_diff_vs_per_variant"][k], abs(r[k] - p[k]))
        print(f"B={B}: batched {B / tb:.2f} variants/s ({tb:.1f} s), pool {n_pool / tp:.2f} variants/s ({tp:.1f} s)",
              flush=True)
    wall = time.perf_counter() - t_start
    out["wall_s"] = wall
    casekit.verdict(out, judge)
    return casekit.write_results(args.out, out, settings={"n_te_points": protocol.n_te_points, "sizes": list(sizes),
                                                          "device": args.device, "pool_max": args.pool_max},
                                 wall_s=wall, device=args.device)


if __name__ == "__main__":
    main()
