"""Benchmark of the shared-pin output mechanism (10 pins x 2 wheels x 4 slices; single, 1,000 batched; Warp vs NumPy).

One full mechanism (shared-pin closure with 16 sleeve updates, forces and
9x9 forward-mode tangent per pin) and 1,000 such mechanisms batched in one
Warp launch, Warp CPU versus the NumPy reference.

Keys: us_single (one mechanism, one Warp launch plus the sum over pins),
us_batched_1000 (1,000 mechanisms in one launch, total), numpy_us_single
(the NumPy reference for one mechanism). The Warp results are compared with
the NumPy reference (max relative difference of forces and tangents), which
is reported beside the times.
"""
import time

import numpy as np

from rvtool import casekit
from rvtool.output_pins import shared_pin_study_mechanism
from warp_contacts import output_pins_ref as ref
from warp_contacts.output_pins import OutputPinKernel

N_PINS = 10
N_BATCH = 1000


def mechanism_poses(rng, n):
    """Flange at rest and two wheels displaced and turned so that the pins load unevenly."""
    base = np.array([[0.0, 0.0, 0.0], [60e-6, 20e-6, 1.5e-3], [-50e-6, -10e-6, 1.2e-3]])
    poses = np.repeat(base[None], n, axis=0)
    poses[:, 1:] += rng.normal(0.0, [2e-6, 2e-6, 2e-5], size=(n, 2, 3))
    return poses.reshape(-1, 3)


def batched_params(fp, ip, n):
    """Stack one mechanism's pin rows n times with body indices offset by 3 per mechanism."""
    fpb = np.tile(fp, (n, 1))
    ipb = np.tile(ip, (n, 1))
    ipb[:, :3] += 3 * np.repeat(np.arange(n), fp.shape[0])[:, None]
    return fpb, ipb


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a, float) - b)) / np.max(np.abs(b)))


def _extra(parser):
    parser.add_argument("--device", default="cpu", help="Warp device (cpu, cuda:N)")
    parser.add_argument("--precision", default="float64", choices=("float64", "float32"))


def judge(r):
    """The benchmark's correctness checks (see casekit.verdict): Warp against the NumPy reference, float64."""
    return {f"{k}_vs_numpy": casekit.check(v, 1e-12, "<=", why="float64 round-off (measured 4e-16)")
            for k, v in r["max_rel_err_vs_numpy"].items() if k != "mechanisms_checked"}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=_extra)
    t_start = time.perf_counter()
    rng = np.random.default_rng(0)
    mech = shared_pin_study_mechanism(0.9e-9, n_pins=N_PINS)
    fp, ip = mech.packed(0, (1, 2))
    st = mech.stations
    min_time = 0.1 if args.quick else 0.5

    pose1 = mechanism_poses(rng, 1)
    k1 = OutputPinKernel(fp, ip, st, 3, "shared", args.precision, args.device)

    def warp_single():
        r = k1.evaluate(pose1)
        return r["Q"].sum(axis=0), r["dQdq"].sum(axis=0)

    def numpy_single():
        r = ref.evaluate_shared(pose1, fp, ip, st)
        return r["Q"].sum(axis=0), r["dQdq"].sum(axis=0)

    us_single = casekit.time_call(warp_single, min_time) * 1e6
    numpy_us_single = casekit.time_call(numpy_single, min_time, max_reps=200) * 1e6
    (Qw, Kw), (Qn, Kn) = warp_single(), numpy_single()
    loaded = int(np.sum(ref.evaluate_shared(pose1, fp, ip, st)["slices"][..., ref.S_FORCE] > 0))

    fpb, ipb = batched_params(fp, ip, N_BATCH)
    poseb = mechanism_poses(rng, N_BATCH)
    kb = OutputPinKernel(fpb, ipb, st, 3 * N_BATCH, "shared", args.precision, args.device)
    us_batched = casekit.time_call(lambda: kb.evaluate(poseb), min_time, max_reps=50) * 1e6
    rb = {k: np.array(v) for k, v in kb.evaluate(poseb).items()}
    n_check = 50 if args.quick else N_BATCH          # NumPy reference over the batch (subset in --quick)
    rows = slice(0, n_check * N_PINS)
    rn = ref.evaluate_shared(poseb, fpb[rows], ipb[rows], st)

    results = {
        "us_single": us_single,
        "us_batched_1000": us_batched,
        "numpy_us_single": numpy_us_single,
        "us_batched_per_mechanism": us_batched / N_BATCH,
        "max_rel_err_vs_numpy": {
            "single_Q": _rel(Qw, Qn), "single_dQdq": _rel(Kw, Kn),
            "batched_Q": _rel(rb["Q"][rows], rn["Q"]), "batched_dQdq": _rel(rb["dQdq"][rows], rn["dQdq"]),
            "mechanisms_checked": n_check},
        "mechanism": {"pins": N_PINS, "wheels": 2, "slices": int(st.size), "sleeve_updates": mech.sleeve.updates,
                      "loaded_slices_single": loaded},
    }
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"quick": args.quick, "min_time_s": min_time},
                                 wall_s=time.perf_counter() - t_start, precision=args.precision, device=args.device)


if __name__ == "__main__":
    main()
