"""Benchmark of RV-40E (rv40e) Monte Carlo variants on the device backend against the replica and Exudyn backends: the same per-variant work, failures counted in the timing, the split of the time.

Workload per variant (fixed, the Exudyn reference run's settings: cases/rv/monte_carlo_rv.py):
quasi-static TE at rated torque over one crank revolution at 37 points (--quick: 7), each point
warm-started from the previous equilibrium (quasi_static_te's default), and the lost motion at
+-3 % of the rated torque at input angle 0.
Variants: rv40e_tolerances.toml sampled by rvtool.variants.rv_tolerances (variant k from
default_rng([SEED, k])), B = 64 (--quick: 4; --variants N).

Backends, each on the same B built variant models (building them is shared by all three and
reported once, ``build_s``; the Exudyn lost motion runs on a second, fresh build of each variant,
as in the reference run):

* exudyn: quasi_static_te(backend="exudyn") and rvtool.protocols.lost_motion.lost_motion per
  variant (the oracle);
* replica: the TE on the replica backend (the variant's copies in one Exudyn system), the lost
  motion Exudyn's (the replica backend runs equilibria only: the Exudyn leg's lost-motion time is
  added, counted as a lost-motion fallback per variant);
* device: rvtool.batched.device_rows_variants: one row Newton (rvtool.solver.device_rows) with
  one copy per variant, the TE one batch solve of all B copies per angle (warm-started likewise;
  a copy whose warm start fails takes the regularization homotopy), the lost motion the device
  load continuation (rvtool.batched.device_rows_lost_motion); a point or copy the device does not converge is
  solved by Exudyn inside the timing and counted (``exudyn_points``, ``exudyn_copies``).

Correctness (``passed``): per variant, the device's and the replica's TE against Exudyn's within
1e-6 arcsec and the device's lost motion within 1e-6 arcmin (issue 31's targets), failed variants
<= MAX_FAILURE_SHARE x B (issue 31: < 0.2 %). Speed is reported, not judged: variants/s of each
backend (without the shared build), the device's speed-ups, and where the device's time goes
(copying the families, kernel launches, the rows' block scatter, the Newton step (a device kernel
by default), the rest: kinematics and bookkeeping, Exudyn fallbacks). --device cuda runs the device's kernels on a GPU.
"""
import time

import numpy as np

from rvtool import build, casekit, designs, load_design
from rvtool.batched.device_rows_variants import device_rows_variants
from rvtool.errors import SolverFailure
from rvtool.protocols.lost_motion import lost_motion
from rvtool.protocols.precision import quasi_static_te
from rvtool.solver.backends import ReplicaBackend
from rvtool.solver.device_rows import DeviceRowNewton
from rvtool.units import ARCMIN_PER_RAD, ARCSEC_PER_RAD
from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design

SEED = 20261124                 # cases/rv/monte_carlo_rv.py's seed: the same variants
LM_FRACTION = 0.03              # lost motion at +-3 % T_rated (monte_carlo_rv.py)
TE_TOL_ARCSEC = 1e-6            # issue 31: TE equal to 1e-6 arcsec
LM_TOL_ARCMIN = 1e-6            # tests/test_backends_golden.py's lost-motion bound
MAX_FAILURE_SHARE = 0.002       # issue 31: failures < 0.2 %


def judge(r):
    b = r["settings_echo"]["variants"]
    return {
        "device_te_vs_exudyn": casekit.check(r["agreement"]["device_te_max_arcsec"], TE_TOL_ARCSEC,
                                             why="issue 31: TE equal to 1e-6 arcsec (Exudyn is the oracle)"),
        "replica_te_vs_exudyn": casekit.check(r["agreement"]["replica_te_max_arcsec"], TE_TOL_ARCSEC,
                                              why="issue 31: TE equal to 1e-6 arcsec (Exudyn is the oracle)"),
        "device_lost_motion_vs_exudyn": casekit.check(r["agreement"]["device_lm_max_arcmin"], LM_TOL_ARCMIN,
                                                      why="lost motion to 1e-6 arcmin (tests/test_backends_golden.py)"),
        "failed_variants": casekit.check(max(r[k]["failed_variants"] for k in ("exudyn", "replica", "device")),
                                         int(MAX_FAILURE_SHARE * b), "<=",
                                         why="issue 31: failures < 0.2 % of the variants, per backend"),
    }


def run_exudyn(models, lm_models, design, angles):
    t0 = time.perf_counter()
    te, lm, failed = [], [], 0
    split = {"te_s": 0.0, "lost_motion_s": 0.0}
    for m, m_lm in zip(models, lm_models):
        try:
            t = time.perf_counter()
            r = quasi_static_te(m, torque=design.rated_torque, input_angles=angles, backend="exudyn")
            split["te_s"] += time.perf_counter() - t
            t = time.perf_counter()
            lm.append(lost_motion(m_lm, torque_level=LM_FRACTION * design.rated_torque)["lost_motion_rad"])
            split["lost_motion_s"] += time.perf_counter() - t
            te.append(r["te"])
        except SolverFailure:
            failed += 1
            te.append(np.full(len(angles), np.nan))
            lm.append(np.nan)
    return {"te": te, "lm": np.array(lm), "failed_variants": failed, "wall_s": time.perf_counter() - t0,
            "split": split}


def run_replica(models, design, angles, exudyn):
    """The TE on the replica; the lost motion is Exudyn's (the replica backend runs no lost motion):
    the Exudyn leg's lost-motion time is added to the wall time, not run twice."""
    t0 = time.perf_counter()
    te, failed = [], 0
    for m in models:
        try:
            te.append(quasi_static_te(m, torque=design.rated_torque, input_angles=angles,
                                      backend=ReplicaBackend())["te"])
        except SolverFailure:
            failed += 1
            te.append(np.full(len(angles), np.nan))
    te_s = time.perf_counter() - t0
    split = {"te_s": te_s, "lost_motion_exudyn_s": exudyn["split"]["lost_motion_s"]}
    return {"te": te, "failed_variants": failed + exudyn["failed_variants"], "wall_s": sum(split.values()),
            "split": split, "lost_motion_fallbacks": len(models)}


def run_device(models, design, angles, device):
    r = device_rows_variants(models, torque=design.rated_torque, input_angles=angles,
                             lost_motion_level=LM_FRACTION * design.rated_torque, device=device)
    return {"te": list(r.te), "lm": r.lost_motion_rad, "failed_variants": r.status.count("failed"),
            "wall_s": r.wall_s, "split": r.split, "te_s": r.te_s, "lost_motion_s": r.lost_motion_s,
            "exudyn_points": r.exudyn_points, "exudyn_copies": r.exudyn_copies, "stats": r.stats}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=lambda p: (
        p.add_argument("--variants", type=int, default=None, help="B variants (default 64, --quick 4)"),
        p.add_argument("--device", default="cpu", help="Warp device of the device backend (cpu, cuda:0)")))
    t_all = time.perf_counter()
    design = load_design(designs.path("rv40e"))
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    B = args.variants or (4 if args.quick else 64)
    n_pts = 7 if args.quick else 37
    t = time.perf_counter()
    probe = build(design)
    crank_rev = 2 * np.pi / abs(probe.graph.crank_rate)
    angles = np.arange(n_pts) * crank_rev / n_pts
    drawn = [sample_rv_design(tol, design, k, SEED)[0] for k in range(B)]
    models = [build(d) for d in drawn]
    # the Exudyn lost motion on a fresh build of each variant, as the reference run
    # (cases/rv/monte_carlo_rv.py): the spring-controlled march on a model that has run the TE
    # before ends up to 7e-6 arcmin elsewhere (measured on variants 0-3; the fresh build and the
    # device agree to 1e-10 arcmin)
    lm_models = [build(d) for d in drawn]
    build_s = time.perf_counter() - t
    # warm every path once (imports, kernel compilation) on the probe: not timed
    quasi_static_te(probe, torque=design.rated_torque, input_angles=angles[:2], backend=ReplicaBackend())
    DeviceRowNewton([probe], device=args.device).solve(np.zeros(1), np.zeros(1))
    dev = run_device(models, design, angles, args.device)
    exu = run_exudyn(models, lm_models, design, angles)
    rep = run_replica(models, design, angles, exu)
    diff = lambda a, b: float(np.nanmax([np.max(np.abs(x - y)) for x, y in zip(a, b)]) * ARCSEC_PER_RAD)
    agreement = {"device_te_max_arcsec": diff(dev["te"], exu["te"]),
                 "replica_te_max_arcsec": diff(rep["te"], exu["te"]),
                 "device_lm_max_arcmin": float(np.nanmax(np.abs(dev["lm"] - exu["lm"])) * ARCMIN_PER_RAD)}
    rates = {k: B / r["wall_s"] for k, r in (("exudyn", exu), ("replica", rep), ("device", dev))}
    results = {
        "settings_echo": {"variants": B, "te_points": n_pts, "lost_motion_fraction": LM_FRACTION,
                          "device": args.device},
        "build_s": build_s,
        "exudyn": {k: v for k, v in exu.items() if k not in ("te", "lm")},
        "replica": {k: v for k, v in rep.items() if k != "te"},
        "device": {k: v for k, v in dev.items() if k not in ("te", "lm")},
        "variants_per_s": rates,
        "speedup_device_vs_exudyn": rates["device"] / rates["exudyn"],
        "speedup_device_vs_replica": rates["device"] / rates["replica"],
        "agreement": agreement,
        "te_pp_arcsec": [float(np.ptp(x) * ARCSEC_PER_RAD) for x in exu["te"]],
        "lost_motion_arcmin": (exu["lm"] * ARCMIN_PER_RAD).tolist(),
        "wall_s": time.perf_counter() - t_all,
    }
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"quick": args.quick, "seed": SEED, "variants": B,
                                                              "te_points_per_crank_revolution": n_pts,
                                                              "tolerances": "rvtool/designs/rv40e_tolerances.toml"},
                                 wall_s=results["wall_s"], device=args.device)


if __name__ == "__main__":
    main()
