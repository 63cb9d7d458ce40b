"""GPU benchmark: one evaluation of RD-40's contact families for 1 ... 65,536 batched variants on the CPU and on CUDA.

Each family (cycloid--pin slices, output pins, rolling elements) is
replicated for B variants (each variant its own bodies, slightly perturbed
poses) and evaluated in one launch: on the CPU (Warp, arrays aliasing NumPy),
on CUDA (pose copied in, generalized forces copied out, launch in between),
and on CUDA with the launch replayed from a captured CUDA graph. Forces are
compared with the CPU result (error reported beside the times). The crossover
is the smallest B at which CUDA beats the CPU. Without a CUDA device the cuda
rows are skipped and the results say so.
"""
import os
import time

import numpy as np
import warp as wp

from rvtool import casekit
from rvtool import build
from rvtool import load_design
from warp_contacts.precision import resolve_device
from rvtool import designs

DESIGN = designs.path("rd40")


def _replicate(fparams, iparams, body_cols, n_bodies, B):
    """B copies of the rows, body indices shifted per variant (ground row moved to the end)."""
    fp = np.tile(fparams, (B, 1))
    ip = np.tile(iparams, (B, 1)).astype(np.int32)
    shift = np.repeat(np.arange(B) * n_bodies, len(iparams))
    for c in body_cols:
        col = ip[:, c]
        ground = col >= n_bodies
        ip[:, c] = np.where(ground, B * n_bodies, col + shift)
    return fp, ip


def _kernels(model, B, device):
    """{family: (kernel, takes_velocity)} for B variants on ``device``."""
    from warp_contacts.cycloid_pins import CycloidPinKernel
    from warp_contacts.output_pins import OutputPinKernel
    from warp_contacts.rolling_elements import RollingElementKernel
    nb = len(model.nodes)
    ps = model.pin_set
    out = {}
    fp, ip = _replicate(ps.fparams, ps.iparams, (0, 1), nb, B)
    out["cycloid_pins"] = (CycloidPinKernel(fp, ip, ps.tables, ps.window, B * nb, "float64", device), True)
    ope = model.elements["output_pins"].evaluator
    fp, ip = _replicate(ope.fparams, ope.iparams, (0, 1), nb, B)
    out["output_pins"] = (OutputPinKernel(fp, ip, ope.stations, B * nb + 1, ope.mode.value, "float64", device), False)
    be = model.elements["bearings"].evaluator
    fp, ip = _replicate(be.fparams, be.iparams, (0, 1), nb, B)
    out["rolling_elements"] = (RollingElementKernel(fp, ip, B * nb, "float64", device), False)
    return out




def _time(fn, reps):
    fn()
    t = time.perf_counter()
    for _ in range(reps):
        fn()
    return (time.perf_counter() - t) / reps


def judge(r):
    """The benchmark's correctness checks (see casekit.verdict); its times are reported, not judged."""
    checks = {}
    for fam, rows in r["families"].items():
        # every batch size was evaluated on the CPU (the reference of the CUDA rows)
        checks[f"{fam}_cpu_rows"] = casekit.check(sum(t is not None and t > 0 for t in rows["us_per_eval_cpu"]),
                                                  len(rows["batch"]), "==", why="a CPU time for every batch size")
        if r["cuda_compared"]:
            # the same float64 kernel on another device: round-off of a different operation order
            checks[f"{fam}_cuda_vs_cpu"] = casekit.check(max(rows["max_rel_err_cuda_vs_cpu"]), 1e-12, "<=",
                                                         why="float64 round-off (FMA and ordering)")
    return checks


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    wp.init()
    has_cuda = any(d.is_cuda for d in wp.get_devices())
    batches = [1, 16, 256] if args.quick else [1, 16, 256, 4096, 65536]
    model = build(load_design(DESIGN), bearing_model="rolling")
    nb = len(model.nodes)
    base = model.kinematic_state(0.0).poses
    rng = np.random.default_rng(0)
    rows = {}
    for B in batches:
        pose = np.vstack([np.tile(base, (B, 1)) + rng.normal(0, 1e-6, (B * nb, 3)) * [1, 1, 1e-3], np.zeros((1, 3))])
        vel = np.zeros_like(pose)
        reps = max(3, min(200, int(2e5 / (B * 100))))
        cpu_k = _kernels(model, B, "cpu") if B <= 4096 or not args.quick else None
        gpu_k = _kernels(model, B, "cuda:0") if has_cuda else None
        for fam in ("cycloid_pins", "output_pins", "rolling_elements"):
            r = rows.setdefault(fam, {"batch": [], "contacts": [], "us_per_eval_cpu": [], "us_per_eval_cuda": [],
                                      "us_per_eval_cuda_graph": [], "contacts_per_s_cuda": [], "max_rel_err_cuda_vs_cpu": []})
            kc, with_vel = cpu_k[fam]
            args_ = (pose, vel) if with_vel else (pose,)
            out = kc.evaluate(*args_)
            q_cpu = np.array(out["Q"] if isinstance(out, dict) else out[0])
            n = q_cpu.shape[0]
            r["batch"].append(B)
            r["contacts"].append(n)
            r["us_per_eval_cpu"].append(1e6 * _time(lambda: kc.evaluate(*args_), reps))
            if gpu_k is None:
                for key in ("us_per_eval_cuda", "us_per_eval_cuda_graph", "contacts_per_s_cuda", "max_rel_err_cuda_vs_cpu"):
                    r[key].append(None)
                continue
            kg, _ = gpu_k[fam]

            def cuda_eval():
                kg.device_array("pose").assign(pose)
                if with_vel:
                    kg.device_array("vel").assign(vel)
                kg.launch_recorded()
                return kg.device_array("q").numpy()
            q_gpu = cuda_eval()
            r["max_rel_err_cuda_vs_cpu"].append(float(np.max(np.abs(q_gpu - q_cpu)) / max(np.max(np.abs(q_cpu)), 1e-30)))
            t = _time(cuda_eval, reps)
            r["us_per_eval_cuda"].append(1e6 * t)
            r["contacts_per_s_cuda"].append(n / t)
            with wp.ScopedCapture(device="cuda:0") as cap:
                kg.launch_recorded()
            graph = cap.graph

            def graph_eval():
                kg.device_array("pose").assign(pose)
                if with_vel:
                    kg.device_array("vel").assign(vel)
                wp.capture_launch(graph)
                return kg.device_array("q").numpy()
            r["us_per_eval_cuda_graph"].append(1e6 * _time(graph_eval, reps))
    for fam, r in rows.items():
        cross = None
        if has_cuda:
            for B, c, g in zip(r["batch"], r["us_per_eval_cpu"], r["us_per_eval_cuda"]):
                if g is not None and g < c:
                    cross = B
                    break
        r["crossover_batch"] = cross
    results = {"device_name": wp.get_device("cuda:0").name if has_cuda else "no CUDA device (cuda rows skipped)",
               "families": rows, "wall_s": time.perf_counter() - t_all,
               "note": "cuda times include the pose copy in and the generalized-force copy out"}
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4))
    for fam, r in rows.items():
        ax.loglog(r["batch"], r["us_per_eval_cpu"], "o-", label=f"{fam} cpu")
        if has_cuda:
            ax.loglog(r["batch"], r["us_per_eval_cuda"], "s--", label=f"{fam} cuda")
    ax.set(xlabel="variants B", ylabel="us per evaluation")
    ax.legend(fontsize=7)
    casekit.save_figure(fig, args.out, "bench_gpu")
    results["cuda_compared"] = has_cuda
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"batches": batches, "precision": "float64"},
                                 wall_s=results["wall_s"], device="cuda:0" if has_cuda else "cpu")


if __name__ == "__main__":
    main()
