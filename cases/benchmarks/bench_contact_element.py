"""Benchmark of the Exudyn contact element: cost per step and per callback versus contact count.

For 1 ... 10,000 circle contacts (random slightly compressed pairs among
planar rigid bodies), measures the wall time per implicit step of the full
driver, per force/Jacobian evaluation (one Warp CPU launch plus assembly), the
same evaluation with the NumPy reference, and the bare Exudyn step of the same
bodies without the contact element (the floor). Also checks that the Warp and
NumPy forces agree (the error is reported beside the times).
"""
import time

import numpy as np
import exudyn as exu
from exudyn.itemInterface import NodeRigidBody2D, ObjectRigidBody2D

from exudyn_user_elements.contact_element import ContactElement
from rvtool import casekit
from rvtool.contact.evaluator import ContactSetEvaluator
from exudyn_user_elements.scenes import random_pair_scene
from rvtool.solver import RunSpec, simulate


def _system(cset, poses, with_contacts, precision):
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = []
    for p in poses:
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(p)))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=1.0, inertia=1e-3))
        nodes.append(n)
    el = ContactElement(mbs, nodes, cset, precision=precision) if with_contacts else None
    mbs.Assemble()
    return SC, mbs, el


def bench(n_contacts, precision, steps):
    rng = np.random.default_rng(n_contacts)
    nb = int(np.clip(n_contacts // 10, 2, 100))
    cset, poses, vels = random_pair_scene(rng, nb, n_contacts, friction=True)
    spec = RunSpec(end_time=steps * 1e-6, step=1e-6, precision=precision, adaptive=True,
                   rel_tol=1e-9 if precision == "float64" else 1e-5)
    out = {}
    SC, mbs, el = _system(cset, poses, True, precision)
    q = np.zeros(3 * nb)
    v = vels.ravel()
    counter = [0]

    def callback():
        counter[0] += 1  # a new time value defeats the cache, as in a new Newton iterate
        el.force_callback(mbs, counter[0] * 1e-9, el.object_number, q, v)
        el.jacobian_callback(mbs, counter[0] * 1e-9, el.object_number, q, v, 1.0, 0.0)

    out["us_per_callback"] = 1e6 * casekit.time_call(callback)
    rec = simulate(mbs, spec, [el])
    out["us_per_step"] = 1e6 * rec.wall_s / rec.accepted_steps
    out["newton_per_step"] = rec.newton_iterations / rec.accepted_steps
    out["rejected_steps"] = rec.rejected_steps
    ev_np = ContactSetEvaluator(cset, backend="numpy")
    out["numpy_us_per_callback"] = 1e6 * casekit.time_call(lambda: ev_np.evaluate(poses, vels))
    ref = ev_np.evaluate(poses, vels).Q
    got = ContactSetEvaluator(cset, precision=precision).evaluate(poses, vels).Q
    out["force_rel_err_vs_numpy"] = float(np.max(np.abs(got - ref)) / np.max(np.abs(ref)))
    SC0, mbs0, _ = _system(cset, poses, False, precision)
    rec0 = simulate(mbs0, spec, [])
    out["bare_step_us"] = 1e6 * rec0.wall_s / rec0.accepted_steps
    out["bodies"] = nb
    return out


def judge(r):
    """The benchmark's correctness checks (see casekit.verdict); its times are reported, not judged."""
    checks = {
        # the same arithmetic in float64: round-off (measured 2e-16)
        "float64_forces_vs_numpy": casekit.check(max(r["float64.force_rel_err_vs_numpy"]), 1e-12, "<=",
                                                 why="float64 round-off"),
        # float32: circle geometry of up to 5e-2 m resolves gaps to eps32 x 5e-2 = 6e-9 m against the scene's
        # 2e-5 m compressions: 3e-4 relative, x 1.5 for the point law (measured 2.6e-4)
        "float32_forces_vs_numpy": casekit.check(max(r["float32.force_rel_err_vs_numpy"]), 1e-3, "<=",
                                                 why="float32 rounding of the positions"),
    }
    for prec in ("float64", "float32"):
        checks[f"{prec}_rejected_steps"] = casekit.check(sum(r[f"{prec}.rejected_steps"]), 0, "==",
                                                         why="maximum 0: slightly compressed pairs integrate smoothly")
    return checks


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    contacts = [1, 10, 100] if args.quick else [1, 10, 100, 1000, 10000]
    steps = 5 if args.quick else 20
    t0 = time.perf_counter()
    results = {"contacts": contacts}
    for precision in ("float64", "float32"):
        rows = [bench(n, precision, steps) for n in contacts]
        for key in ("us_per_step", "us_per_callback", "numpy_us_per_callback", "bare_step_us", "newton_per_step",
                    "force_rel_err_vs_numpy", "bodies", "rejected_steps"):
            results[f"{precision}.{key}"] = [r[key] for r in rows]
    # unprefixed keys (issue): the float64 default
    for key in ("us_per_step", "us_per_callback", "numpy_us_per_callback", "bare_step_us"):
        results[key] = results[f"float64.{key}"]
    # linear contact cost fitted on the callback times, for the "2 x bare + linear" target
    c = np.array(contacts, float)
    cb = np.array(results["us_per_callback"])
    slope = float(np.polyfit(c, cb, 1)[0])
    results["callback_us_per_contact"] = slope
    results["step_over_bare_minus_linear"] = [
        float((s - slope * n * nw) / b) for s, n, b, nw in zip(results["us_per_step"], contacts, results["bare_step_us"],
                                                                 results["float64.newton_per_step"])]
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    for key, lab in (("us_per_step", "step (driver, Warp CPU)"), ("us_per_callback", "callback (Warp CPU)"),
                     ("numpy_us_per_callback", "callback (NumPy)"), ("bare_step_us", "bare Exudyn step")):
        ax.loglog(contacts, results[key], "o-", label=lab)
    ax.set(xlabel="contacts", ylabel="wall time [us]", title="contact element cost (float64)")
    ax.legend()
    casekit.save_figure(fig, args.out, "bench_contact_element")
    run_spec = RunSpec(end_time=steps * 1e-6, step=1e-6, adaptive=True).to_dict()
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"steps": steps, "run_spec_float64": run_spec,
                                                              "float32_rel_tol": 1e-5, "device": "cpu"},
                                 wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
