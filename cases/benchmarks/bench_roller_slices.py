"""Benchmark of the influence-coefficient roller slices (Eq. bearing_ic) against the laminae law.

Cost per roller evaluation (forces and tangent) of:

* the RD-40 eccentric needle bearing (16 rollers, 8 slices) in the planar bearing set
  (:class:`rvtool.bearings.set.BearingSet`): laminae, influence with the fixed half-width and with
  the slice-load half-width (two launches of the rolling-element kernel plus the slice solve);
* the rv40e crank bearing pair (2 x 14 tapered rollers, 8 slices) in the 5-DOF tapered set;
* the slice solve alone (:class:`warp_contacts.roller_slices.RollerSliceKernel`) for 4,096 rollers
  of 8 slices in one launch.

All paths are warmed (compiled, one call) and timed in the same run; ratios are to the laminae law
of the same set on the same device. Keys: ``us_per_roller`` per set and law, ``ratio_to_laminae``.
Correctness (the benchmark's ``passed``): the Warp path of every influence set against its NumPy
reference, forces and tangents (float64 round-off), and no NaN.

--quick: the same sets, shorter timing windows, 512 rollers in the batched solve.
"""
import math
import time

import numpy as np

from rvtool import casekit
from rvtool.bearings.influence import bearing_slice_parameters
from rvtool.bearings.set import BearingSet, Mounting
from rvtool.bearings.spec import NeedleBearing
from rvtool.bearings.tapered import TaperedPair, TaperedRollerBearing
from rvtool.bearings.tapered_set import TaperedBearingSet, TaperedMounting
from warp_contacts import roller_slices_ref as sref

N_SLICES = 8
LAWS = {"laminae": {}, "influence_fixed": {"slices": "influence", "half_width": "fixed"},
        "influence_slice_load": {"slices": "influence", "half_width": "slice_load"}}


def _extra(parser):
    parser.add_argument("--device", default="cpu", help="Warp device (cpu, cuda:N)")


def needle(**kw):
    # RD-40 eccentric bearing (rvtool/designs/rd40.toml) with 8 slices and a 2 um crown (chosen)
    return NeedleBearing(inner_radius=0.012, n_rollers=16, roller_diameter=0.003, roller_length=0.008,
                         radial_clearance=5e-6, n_slices=N_SLICES, crowning=2e-6, **kw)


def tapered(**kw):
    # rv40e crank bearing row (rvtool/designs/rv40e.toml) with 8 slices and a 3 um crown (chosen)
    row = TaperedRollerBearing(n_rollers=14, pitch_diameter=0.0335, roller_diameter=0.0055, roller_length=0.010,
                               cup_angle=math.radians(14.0), cone_angle=math.radians(11.0), n_slices=N_SLICES,
                               crowning=3e-6, **kw)
    return TaperedPair(rows=(row, row), row_spacing=0.040, axial_preload=300.0)


def _rel(a, b):
    b = np.asarray(b, float)
    return float(np.max(np.abs(np.asarray(a, float) - b)) / max(np.max(np.abs(b)), 1e-300))


def judge(r):
    return {f"{k}_vs_numpy": casekit.check(v, 1e-10, "<=", why="float64 round-off of the same operations in "
                                            "another order (conditioning of C_AA ~1e3)")
            for k, v in r["max_rel_err_vs_numpy"].items()}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=_extra)
    t0 = time.perf_counter()
    min_time = 0.1 if args.quick else 0.5
    dev = args.device
    pose = np.array([[1.5e-5, 0.3e-5, 0.01], [0.0, 0.0, 0.02]])
    q = np.array([[8e-6, 3e-6, 1e-6, 2e-4, -1e-4]])
    us, errs = {"needle_planar": {}, "tapered_5dof": {}}, {}
    for law, kw in LAWS.items():
        sets = {b: BearingSet([Mounting(name="ecc", bearing=needle(**kw), inner=0, outer=1)], n_bodies=2,
                              backend=b, device=dev if b == "warp" else "cpu") for b in ("warp", "numpy")}
        ev = sets["warp"].evaluate(pose)
        us["needle_planar"][law] = 1e6 * casekit.time_call(lambda: sets["warp"].evaluate(pose), min_time) / 16
        if law != "laminae":
            ref = sets["numpy"].evaluate(pose)
            errs[f"needle_{law}_Q"] = _rel(ev.Q, ref.Q)
            errs[f"needle_{law}_dQdq"] = _rel(ev.dQdq, ref.dQdq)
        tsets = {b: TaperedBearingSet([TaperedMounting(name="c", bearing=tapered(**kw), inner=0, outer=1)], n_bodies=2,
                                      backend=b, device=dev if b == "warp" else "cpu") for b in ("warp", "numpy")}
        rw = tsets["warp"].relative(q)
        us["tapered_5dof"][law] = 1e6 * casekit.time_call(lambda: tsets["warp"].relative(q), min_time) / 28
        if law != "laminae":
            rn = tsets["numpy"].relative(q)
            errs[f"tapered_{law}_wrench"] = _rel(rw.wrench, rn.wrench)
            errs[f"tapered_{law}_stiffness"] = _rel(rw.stiffness, rn.stiffness)
    ratios = {s: {law: v / d["laminae"] for law, v in d.items()} for s, d in us.items()}

    # the slice solve alone, many rollers in one launch
    from warp_contacts.roller_slices import RollerSliceKernel
    R = 512 if args.quick else 4096
    rng = np.random.default_rng(0)
    fp, ip = bearing_slice_parameters(needle(slices="influence"))
    y = (np.arange(N_SLICES) + 0.5) / N_SLICES - 0.5
    s = rng.uniform(0, 8e-6, (R, 1)) + rng.uniform(-4e-6, 4e-6, (R, 1)) * y - 2e-6 * (2 * y) ** 2
    solve = {}
    for mode in ("fixed", "slice_load"):
        ipm = ip.copy()
        ipm[sref.SI_MODE] = sref.HALF_WIDTH_FIXED if mode == "fixed" else sref.HALF_WIDTH_SLICE_LOAD
        k = RollerSliceKernel(np.tile(fp, (R, 1)), np.tile(ipm, (R, 1)), dev)
        out = k.evaluate(s)
        solve[mode] = 1e6 * casekit.time_call(lambda: k.evaluate(s), min_time) / R
        n_ref = 64
        ref = sref.evaluate(s[:n_ref], np.tile(fp, (n_ref, 1)), np.tile(ipm, (n_ref, 1)))
        errs[f"solve_{mode}_f"] = _rel(out[0][:n_ref], ref[0])
        errs[f"solve_{mode}_J"] = _rel(out[1][:n_ref], ref[1])
    results = {"us_per_roller": us, "ratio_to_laminae": ratios, "slice_solve_us_per_roller": solve,
               "slice_solve_rollers": R, "n_slices": N_SLICES, "device": dev, "max_rel_err_vs_numpy": errs,
               "wall_s": time.perf_counter() - t0}
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"quick": args.quick, "device": dev,
                                                              "n_slices": N_SLICES}, wall_s=results["wall_s"],
                                 device=dev)


if __name__ == "__main__":
    main()
