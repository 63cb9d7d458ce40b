"""Benchmark of the device row Newton's step kernel (warp_contacts.block_newton) alone: the
copy-major working arrays (each copy's (n x n) block contiguous, the kernel before issue 31's step
work) against the copy-fastest ones (element (i, j) of copy b at [i, j, b]: the threads of a GPU
warp, one per copy, read neighbouring addresses), on --device, B copies of rv40e's block.

Inputs: rv40e (n = 3 nb coordinates, its step model: springs, fixed coordinates, rotations,
bounds) solved by the row Newton at P points of one crank revolution under the rated torque
(host step, cpu); the summed residual and tangent evaluated there and at a perturbed state,
tiled to B copies (real blocks: their sparsity and pivoting as in the study).

Correctness (judged, ``passed``): one step of every copy from the perturbed states, each layout
against the NumPy reference (warp_contacts.block_newton_ref.block_step): the same statuses,
stages and iterations, states within 1e-12 of the copy's largest coordinate (the LAPACK solve
against the kernel's elimination: a step of a well-conditioned block agrees to a few ulps of its
size); the two layouts against each other: the same statuses, states equal on cpu (the same
operations in the same order) and within 1e-12 on cuda (the compiler may contract differently).

Timing (reported, not judged): the step launch replayed ``--reps`` times after 3 warm-up launches,
between device synchronizations, on a model whose copies stay active (tolerance 0, no iteration
limit, no plausibility bound: every launch does the full assembly, elimination and update), per
launch [ms] for both layouts and their ratio. Then (--device cuda) the GPU time
per kernel name (Warp's CUDA activity timing) of one warmed rv40e row Newton solve of B points on
B nominal copies with the new step: how much of a sweep is the step, how much the families'
kernels and the row sums. Default B = 1,000 (the bench_device_mc study's
batch; its split: ~11 ms per step launch on an H200 inside the Newton loop), --reps 50; --quick:
B = 64, 3 reps.
"""
import dataclasses
import time

import numpy as np
import warp as wp

import rvtool
from rvtool import casekit, designs
from rvtool.solver.device_rows import DeviceRowNewton
from warp_contacts.block_newton import LAYOUTS, BlockNewtonStep
from warp_contacts.block_newton_ref import ACTIVE, WARM, block_step

REF_REL = 1e-12                 # states vs the NumPy step, relative to the copy's largest coordinate
LAYOUT_REL = 1e-12              # layout vs layout on cuda (cpu: bit-identical)


def judge(r):
    c = r["correctness"]
    checks = {
        "profiled_solve_converged": casekit.check(r["solve_profile"]["converged"], True, "==",
                                                  why="every point of the profiled solve converged"),
        "same_statuses_as_reference": casekit.check(c["status_mismatches"], 0, "==",
                                                    why="statuses, stages, iterations of both layouts vs NumPy"),
        "states_vs_reference": casekit.check(c["max_rel_diff_vs_reference"], REF_REL,
                                             why="LAPACK vs the kernel's elimination on rv40e's blocks"),
        "layouts_agree": casekit.check(c["max_rel_diff_layouts"], 0.0 if r["device"] == "cpu" else LAYOUT_REL,
                                       why="the same operations in the same order (cpu: the same bits)"),
    }
    return checks


def blocks(points):
    """rv40e's step model, n, and P real (Q, K, q, kin) from equilibria at P crank angles (perturbed)."""
    m = rvtool.build(rvtool.load_design(designs.path("rv40e")))
    nw = DeviceRowNewton(m, points, device="cpu", device_sum=False, device_step=False)
    angles = np.linspace(0.0, 2.0 * np.pi, points, endpoint=False)
    tq = np.full(points, -np.sign(m.ratio) * m.design.rated_torque)
    sol = nw.solve(angles, tq)
    kin = nw.kinematic(angles)
    rng = np.random.default_rng(31)
    q = sol.q + 1e-7 * rng.normal(size=sol.q.shape) * nw.free     # off the equilibrium: a real step
    ev = nw.evaluator
    r = ev.evaluate((nw.reference + q).reshape(points * nw.nb, 3), np.zeros((points * nw.nb, 3)))
    return m, nw.step_model(nw.settings), nw.n, np.asarray(r.Q), np.asarray(r.dQdq), q, np.asarray(kin), tq


def solve_profile(model, copies, device):
    """GPU time per kernel of one warmed rv40e row Newton solve of ``copies`` points on ``copies``
    nominal copies (the device Monte Carlo's TE batch: device sums and step, the resident loop,
    the step's default layout): {kernel name: [launches, ms]} from Warp's CUDA activity timing
    (None on cpu), the solve's wall time [s], its sweeps and whether every point converged. Tells
    how much of a sweep the step kernel is (bench_device_mc's "step" share is timed around the
    host's read of the active count: it also waits for the families' kernels and row sums queued
    before it)."""
    nw = DeviceRowNewton(model, copies, device=device)
    angles = np.linspace(0.0, 2.0 * np.pi, copies, endpoint=False)
    tq = np.full(copies, -np.sign(model.ratio) * model.design.rated_torque)
    nw.solve(angles, tq)                                  # warm-up: compiles, caches launches
    cuda = device != "cpu"
    if cuda:
        wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
    t0 = time.perf_counter()
    sol = nw.solve(angles, tq)
    wp.synchronize_device(device)
    wall = time.perf_counter() - t0
    per = None
    if cuda:
        per = {}
        for t in wp.timing_end():
            e = per.setdefault(t.name, [0, 0.0])
            e[0] += 1
            e[1] += t.elapsed
    return {"kernels_ms": per, "wall_s": wall, "sweeps": int(sol.sweeps), "converged": bool(np.all(sol.converged))}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=lambda p: (
        p.add_argument("--device", default="cpu", help="warp device (cpu, cuda:0)"),
        p.add_argument("--copies", type=int, default=None, help="B copies (default 1,000; --quick 64)"),
        p.add_argument("--reps", type=int, default=None, help="timed launches (default 50; --quick 3)")))
    t_start = time.perf_counter()
    wp.init()
    B = args.copies or (64 if args.quick else 1000)
    reps = args.reps or (3 if args.quick else 50)
    P = 4
    rv, model, n, Q0, K0, q0, kin0, tq0 = blocks(P)
    tile = lambda a: np.ascontiguousarray(np.concatenate([a] * (B // P + 1))[:B])
    Q, K, q, kin, tq = (tile(a) for a in (Q0, K0, q0, kin0, tq0))
    zi = lambda: np.zeros(B, np.int32)
    state = dict(q=q, kin=kin, torque=tq, status=np.full(B, ACTIVE, np.int32), stage=np.full(B, WARM, np.int32),
                 iters=zi(), total=zi())
    Qd = wp.array(Q, dtype=wp.float64, device=args.device)
    Kd = wp.array(K, dtype=wp.float64, device=args.device)

    # correctness: one step of each layout vs the NumPy reference
    ref = {k: np.array(v) for k, v in state.items()}
    ref["residual"] = np.zeros(B)
    block_step(Q, K, ref["q"], kin, tq, ref["status"], ref["stage"], ref["iters"], ref["total"], ref["residual"],
               model)
    scale = np.max(np.abs(ref["q"]), axis=1)
    out, mism, rel_ref = {}, 0, 0.0
    for lay in LAYOUTS:
        s = BlockNewtonStep(model, B, n, args.device, layout=lay)
        s.load(**state)
        s.step(Qd, Kd)
        got = dict(zip(("q", "status", "stage", "iters"), s.read("q", "status", "stage", "iters")))
        out[lay] = got
        mism += sum(int(np.sum(got[k] != ref[k])) for k in ("status", "stage", "iters"))
        rel_ref = max(rel_ref, float(np.max(np.abs(got["q"] - ref["q"]) / scale[:, None])))
    a, b = out["copy_major"], out["copy_fastest"]
    rel_lay = float(np.max(np.abs(a["q"] - b["q"]) / scale[:, None]))
    mism += int(np.sum(a["status"] != b["status"]))

    # timing: copies that stay active, every launch the full work
    busy = dataclasses.replace(model, abs_tol=0.0, max_iterations=2 ** 30, bound_translation=1e300,
                               bound_rotation=1e300, homotopy=False)
    # (layout, block_dim): the old launch (copy-major, Warp's default block), the new default, and
    # on a GPU the other combinations (which part of the gain is the layout, which the spread)
    old_cfg, new_cfg = ("copy_major", None), ("copy_fastest", 32)      # BlockNewtonStep's default on a GPU
    cfgs = [old_cfg, new_cfg]
    if args.device != "cpu":
        cfgs += [("copy_major", 32)] + [("copy_fastest", d) for d in (None, 64, 128) if d != new_cfg[1]]
    times = {}
    for lay, bd in cfgs:
        s = BlockNewtonStep(busy, B, n, args.device, layout=lay, block_dim=bd)
        s.load(**state)
        for _ in range(3):
            s.step(Qd, Kd)
        wp.synchronize_device(args.device)
        t0 = time.perf_counter()
        for _ in range(reps):
            s.step(Qd, Kd)
        wp.synchronize_device(args.device)
        times[f"{lay}/block_dim={bd or 'default'}"] = (time.perf_counter() - t0) / reps
        assert int(s.active.numpy()[0]) == B            # every copy stepped in every timed launch
    key = lambda c: f"{c[0]}/block_dim={c[1] or 'default'}"
    results = {
        "device": args.device, "copies": B, "n": n, "reps": reps, "points": P,
        "step_ms": {k: 1e3 * t for k, t in times.items()},
        "profile_points": min(B, 8) if args.quick else B,
        "old": key(old_cfg), "new": key(new_cfg),
        "speedup_new_vs_old": times[key(old_cfg)] / times[key(new_cfg)],
        "solve_profile": solve_profile(rv, min(B, 8) if args.quick else B, args.device),
        "correctness": {"status_mismatches": mism, "max_rel_diff_vs_reference": rel_ref,
                        "max_rel_diff_layouts": rel_lay,
                        "statuses": {int(k): int(v) for k, v in zip(*np.unique(ref["status"], return_counts=True))}},
        "wall_s": time.perf_counter() - t_start,
    }
    print(f"block step on {args.device}, B = {B}, n = {n}, per launch (after 3 warm-up, mean of {reps}):")
    for k, t in times.items():
        print(f"  {k:32s} {1e3 * t:9.3f} ms")
    prof = results["solve_profile"]
    print(f"rv40e solve of {results['profile_points']} points on as many copies (default step): "
          f"{prof['wall_s']:.3f} s, {prof['sweeps']} sweeps, all converged: {prof['converged']}")
    for k, (cnt, ms) in sorted((prof["kernels_ms"] or {}).items(), key=lambda kv: -kv[1][1]):
        print(f"  GPU {k[:60]:60s} {cnt:6d} launches {ms:10.3f} ms")
    print(f"  new ({key(new_cfg)}) vs old ({key(old_cfg)}): {results['speedup_new_vs_old']:.2f}x; "
          f"states vs reference {rel_ref:.2e}, layouts {rel_lay:.2e}")
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"copies": B, "reps": reps, "quick": args.quick},
                                 wall_s=results["wall_s"], precision="float64", device=args.device)


if __name__ == "__main__":
    main()
