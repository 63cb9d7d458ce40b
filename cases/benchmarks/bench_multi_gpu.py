"""Benchmark of the device Monte Carlo on several GPUs of one host against one GPU (issue 31: 8,192 variants, 2 GPUs >= 1.8x one).

Workload per variant (fixed, the Exudyn reference run's settings):
* rd40 (default): cases/cycloid/monte_carlo_te.py's protocol: quasi-static TE over one output
  revolution at 53 points under the rated torque, the maximum pin force, the lost motion at
  +-3 % of the rated torque; tolerances rd40_tolerances.toml, seed 2026; the device Newton
  (rvtool.variants.device: TE and lost motion on the device, failed copies on the per-variant
  Exudyn path inside the timing);
* rv40e (--design rv40e): cases/rv/monte_carlo_rv.py's: TE at the rated torque over one crank
  revolution at 37 points, lost motion at +-3 %; rv40e_tolerances.toml, seed 20261124; each
  variant built in its worker, then the device row Newton (rvtool.batched.device_rows_variants).
--quick: 2 variants at 13 (rd40) / 3 (rv40e) TE points on two cpu workers (CI).

Placement (rvtool.variants.multi_device): a LocalCluster of one single-threaded worker process per
device, each started with CUDA_VISIBLE_DEVICES = its GPU (cpu workers: none visible); the variants
are split into one contiguous batch per device, each batch cut into chunks of --chunk variants run
one after another on that device's worker (default: 1,024 for rd40 on cuda, the single-GPU study's
chunk CHUNK_DEVICE_GPU; 64 for rv40e, the row Newton's copy cost grows faster than linearly; the
whole batch on cpu). Host work (per-copy parameters, Exudyn fallbacks) runs on each GPU worker's
helper pool, the host's cores shared out: the one-GPU run on a cluster of one worker with
cpu_count - 1 helpers, the N-GPU run on a cluster of N workers with cpu_count / N - 1 each
(--host-workers overrides; cpu workers: none), so both runs use the whole host.

Warm-up (excluded from both timings, reported as ``warm_up_s``): one variant on every worker of
each cluster first (imports, Warp kernel compilation and module loading on each device, the helper
pools started). Starting the clusters is excluded too (``cluster_start_s``). Fallbacks and
failures are inside the timings.

Judged (``passed``): the N-device records equal the one-device records (every figure within 1e-12
relative: the copies are independent), the same variants failed in both, failed variants
<= 0.2 % (issue 31), and, for a full run on cuda, the speed-up N devices / one >= 1.8 (issue 31's
target for 2 GPUs; quick and cpu runs report it only: two workers on a shared 2-core machine
measure nothing). Split of the time: per worker, its tasks' wall time (busy_s), the study's wall
time, Dask's share (wall minus the busiest worker) and the load imbalance (busiest / mean busy).
"""
import time

import numpy as np

from rvtool import casekit, designs, load_design
from rvtool.variants.multi_device import (RvVariantProtocol, default_host_workers, device_cluster,
                                          multi_device_monte_carlo, warm_up)
from rvtool.variants.rv_tolerances import load_rv_tolerances
from rvtool.variants.tolerances import load_tolerances
from rvtool.variants.variant import VariantProtocol

FIGS = ("te_pp_arcsec", "te_rms_arcsec", "max_pin_force_N", "lost_motion_arcmin")
EQUAL_REL = 1e-12               # the same independent copies on equal devices: equal records
MAX_FAILURE_SHARE = 0.002       # issue 31: failures < 0.2 %
TARGET_SPEEDUP = 1.8            # issue 31: 8,192 variants on 2 GPUs >= 1.8x one GPU
CASES = {
    # design, tolerances loader, tolerances, seed, protocol (full, quick), chunk on cuda
    "rd40": ("rd40", load_tolerances, "rd40_tolerances", 2026,
             (VariantProtocol(n_te_points=53), VariantProtocol(n_te_points=13)), 1024),
    "rv40e": ("rv40e", load_rv_tolerances, "rv40e_tolerances", 20261124,
              (RvVariantProtocol(n_te_points=37), RvVariantProtocol(n_te_points=3)), 64),
}


def judge(r):
    b = r["settings_echo"]["variants"]
    checks = {
        "records_equal": casekit.check(r["agreement"]["max_rel_diff"], EQUAL_REL,
                                       why="the N-device records equal the one-device records (independent copies)"),
        "same_failures": casekit.check(r["agreement"]["status_mismatches"], 0, "==",
                                       why="the same variants fail on one and on N devices"),
        "failed_variants": casekit.check(r["n_devices"]["failed"], int(MAX_FAILURE_SHARE * b), "<=",
                                         why="issue 31: failures < 0.2 % of the variants"),
    }
    if r["settings_echo"]["judge_speedup"]:
        checks["speedup"] = casekit.check(r["speedup"], TARGET_SPEEDUP, ">=",
                                          why="issue 31: 2 GPUs >= 1.8x one GPU (8,192 variants)")
    return checks


def split(res, wall):
    """Per-worker busy time, Dask's share and the imbalance of one study."""
    busy = {}
    for b in res["batches"]:
        busy[b["worker"]] = busy.get(b["worker"], 0.0) + (b["wall_s"] or 0.0)
    top = max(busy.values())
    return {"wall_s": wall, "busy_s": busy, "dask_s": wall - top,
            "imbalance": top / float(np.mean(list(busy.values()))), "tasks": len(res["batches"])}


def fallbacks(records):
    return {"te_fallback_points": sum(int(r.get("te_fallback_points") or 0) for r in records)
            + sum(int(r.get("exudyn_points") or 0) for r in records),
            "lost_motion_fallback_copies": sum(bool(r.get("lost_motion_fallback")) for r in records)
            + sum(int(r.get("exudyn_copies") or 0) for r in records)}


def compare(one, two):
    worst, mism = 0.0, 0
    for x, y in zip(one, two):
        if x["status"] != y["status"] or x["index"] != y["index"]:
            mism += 1
            continue
        if x["status"] != "ok":
            continue
        for f in FIGS:
            if x.get(f) is None:
                continue
            worst = max(worst, abs(x[f] - y[f]) / max(abs(x[f]), 1e-300))
    return {"max_rel_diff": worst, "status_mismatches": mism + abs(len(one) - len(two))}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=lambda p: (
        p.add_argument("--design", default="rd40", choices=sorted(CASES), help="the study's design"),
        p.add_argument("--variants", type=int, default=None, help="variants (default 8192; --quick 2)"),
        p.add_argument("--device", default="cpu", choices=("cpu", "cuda"),
                       help="cuda: one worker per GPU (cuda:0 .. cuda:N-1); cpu: N cpu workers"),
        p.add_argument("--gpus", type=int, default=2, help="N devices (workers) of the N-device run"),
        p.add_argument("--chunk", type=int, default=None, help="variants per task (default: see the docstring)"),
        p.add_argument("--host-workers", type=int, default=None,
                       help="helper processes per worker (default: the host's cores shared out; cpu: 0)")))
    t_all = time.perf_counter()
    name, loader, tol_name, seed, protocols, cuda_chunk = CASES[args.design]
    design = load_design(designs.path(name))
    tol = loader(designs.path(tol_name))
    protocol = protocols[1] if args.quick else protocols[0]
    B = args.variants or (2 if args.quick else 8192)
    devices = [f"cuda:{k}" for k in range(args.gpus)] if args.device == "cuda" else ["cpu"] * args.gpus
    chunk = args.chunk or (cuda_chunk if args.device == "cuda" or args.design == "rv40e" else None)
    def study(devs):
        """(result, wall, cluster start, warm-up, helpers per worker) on a cluster of ``devs``."""
        t = time.perf_counter()
        with device_cluster(devs) as (client, slots):
            start = time.perf_counter() - t
            hw = default_host_workers(slots) if args.host_workers is None else args.host_workers
            warm = warm_up(client, slots, design, tol, protocol, seed, host_workers=hw)
            t = time.perf_counter()
            res = multi_device_monte_carlo(design, tol, B, protocol=protocol, seed=seed, client=client, slots=slots,
                                           chunk=chunk, host_workers=hw)
            return res, time.perf_counter() - t, start, warm, hw, [s.device for s in slots]

    one, one_s, c1, w1, hw1, _ = study(devices[:1])
    many, many_s, cn, wn, hwn, worker_device = study(devices)
    ok = [r for r in many["records"] if r["status"] == "ok"]
    results = {
        "settings_echo": {"design": name, "variants": B, "te_points": protocol.n_te_points, "devices": devices,
                          "worker_device": worker_device, "chunk": chunk,
                          "host_workers": {"one_device": hw1, "n_devices": hwn},
                          "judge_speedup": (not args.quick) and args.device == "cuda"},
        "cluster_start_s": {"one_device": c1, "n_devices": cn},
        "warm_up_s": {"one_device": w1, "n_devices": wn},
        "timing_note": ("warm-up (one variant on every worker) and the cluster starts are excluded from both "
                        "timings; fallbacks and failures are inside them"),
        "one_device": {"failed": one["failed"], **split(one, one_s), **fallbacks(one["records"])},
        "n_devices": {"failed": many["failed"], **split(many, many_s), **fallbacks(many["records"])},
        "variants_per_s": {"one_device": B / one_s, "n_devices": B / many_s},
        "speedup": one_s / many_s,
        "agreement": compare(one["records"], many["records"]),
        "te_pp_arcsec_mean": float(np.mean([r["te_pp_arcsec"] for r in ok])) if ok else None,
        "lost_motion_arcmin_mean": float(np.mean([r["lost_motion_arcmin"] for r in ok])) if ok else None,
        "wall_s": time.perf_counter() - t_all,
    }
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"quick": args.quick, "seed": seed, "variants": B,
                                                              "design": name, "devices": devices,
                                                              "te_points": protocol.n_te_points},
                                 wall_s=results["wall_s"], device=args.device)


if __name__ == "__main__":
    main()
