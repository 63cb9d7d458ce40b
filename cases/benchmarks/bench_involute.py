"""Benchmark of the involute tooth-pair contact family: microseconds per pair-slice evaluation
(forces, the analytic tangent dQ/dq and dQ/dv, observations), Warp CPU and CUDA (when a GPU
is present) against the NumPy reference, float64; and the cost of the std_involute reducer's
quasi-static equilibria next to RD-40's, measured in the same run.

Scene: copies of the FZG type C mesh (cases/involute_pair.py) side by side, each with 8
face-width slices on both lines of action (5 tooth windows): 80 rows per mesh, loaded at a
position with line and tip-edge contacts. The time of one evaluation is the mean of repeated
calls (rvtool.casekit.time_call) including the host-device copies of the state in and the
results out, as the contact element calls it; the per-row time is that divided by the rows.
"""
import time

import numpy as np
import warp as wp

from rvtool import casekit, designs
from rvtool import build
from rvtool import load_design
from rvtool.protocols.precision import quasi_static_te
from rvtool.solver.static import StaticSolver
from rvtool.units import ARCSEC_PER_RAD
from rvtool.contact.involute_set import GearMesh, InvoluteContactSet
from warp_contacts.precision import resolve_device

involute_pair = casekit.import_case("verification/involute_pair")


def scene(n_meshes, backend, device="cpu", precision="float64"):
    pair = involute_pair.fzg_c()
    meshes = [GearMesh(pair=pair, body_a=2 * k, body_b=2 * k + 1, n_slices=8, name=f"mesh{k}") for k in range(n_meshes)]
    cs = InvoluteContactSet(meshes, 2 * n_meshes, backend=backend, precision=precision, device=device)
    th = 0.02
    pose = np.zeros((2 * n_meshes, 3))
    pose[0::2, 2] = th
    pose[1::2, 0] = pair.a
    pose[1::2, 2] = pair.mesh_phase(0) + pair.ratio * th - 6e-4
    vel = np.zeros((2 * n_meshes, 3))
    vel[0::2, 2] = 10.0
    vel[1::2, 2] = 10.0 * pair.ratio
    return cs, pose, vel


def equilibrium_cost(model, torque, repeats):
    """ms of one quasi-static equilibrium at rated torque: from the kinematic state (the static
    solver's ladder) and warm-started from the equilibrium one 1/20 mesh cycle before; medians."""
    model.set_output_torque(-np.sign(model.ratio) * torque)
    cold, warm = [], []
    for k in range(repeats):
        a = k * model.mesh_period / 3
        s = StaticSolver(model)
        t0 = time.perf_counter()
        s.solve(a)
        cold.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        s.solve(a + model.mesh_period / 20, a)
        warm.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(cold)), 1e3 * float(np.median(warm))


def te_cost(design, input_revolutions, points_per_mesh=20):
    """Quasi-static TE (rvtool.protocols.precision.quasi_static_te, lumped bearings) over
    ``input_revolutions`` at ``points_per_mesh`` points per mesh cycle: points, wall [s], ms per point."""
    model = build(design, bearing_model="lumped")
    n = int(round(input_revolutions * 2 * np.pi / model.mesh_period * points_per_mesh))
    angles = np.arange(n) * model.mesh_period / points_per_mesh
    quasi_static_te(model, torque=design.rated_torque, input_angles=angles[:2])      # warm-up (kernel load)
    r = quasi_static_te(model, torque=design.rated_torque, input_angles=angles)
    return {"points": n, "input_revolutions": input_revolutions, "points_per_mesh_cycle": points_per_mesh,
            "wall_s": r["wall_s"], "ms_per_point": 1e3 * r["wall_s"] / n,
            "newton_iterations_per_point": r["stats"]["newton_iterations"] / n, "te_pp_arcsec": float(np.ptp(r["te"])) * ARCSEC_PER_RAD}


def reducer_costs(quick):
    """std_involute: one equilibrium and quasi-static TE over one output revolution at 20 points per
    mesh cycle (quick: two mesh cycles); RD-40's per-point cost in the same run (quick: two mesh
    cycles; full: five input revolutions, 4,000 points, enough for a per-point mean)."""
    std = load_design(designs.path("std_involute"))
    rd40 = load_design(designs.path("rd40"))
    cold, warm = equilibrium_cost(build(std, bearing_model="lumped"), std.rated_torque, 3 if quick else 10)
    rd_cold, rd_warm = equilibrium_cost(build(rd40, bearing_model="lumped"), rd40.rated_torque, 3 if quick else 10)
    std_revs = 2 / std.ring.n_teeth if quick else abs(std.ratio)
    rd_revs = 2 / rd40.pins.n_pins if quick else 5.0
    te_std, te_rd = te_cost(std, std_revs), te_cost(rd40, rd_revs)
    ratio = te_std["ms_per_point"] / te_rd["ms_per_point"]
    out = {"std_involute_equilibrium_ms": {"from_kinematic_state": cold, "warm_started": warm},
            "rd40_equilibrium_ms": {"from_kinematic_state": rd_cold, "warm_started": rd_warm},
            "std_involute_te_one_output_revolution": te_std, "rd40_te_reference": te_rd,
            "per_point_cost_ratio_std_over_rd40": ratio, "target_ratio": 2.0,
            "judged": "not judged (quick: 40 points, timing noise)" if quick else "full run",
            "bearing_model": "lumped (both)"}
    if not quick:   # the target is judged on the full run only: 40 points of ~3 ms are timing noise on a shared machine
        out["passed"] = bool(ratio <= 2.0)
    return out


def judge(r):
    """The benchmark's correctness checks (see casekit.verdict); the full run also judges its cost target
    (reducer.passed)."""
    return {f"warp_{dev}_vs_numpy_{n}_meshes": casekit.check(v, 1e-12, "<=", why="float64: round-off")
            for n, entry in r["us_per_pair_slice"].items()
            for dev, v in ((k[len("warp_"):-len("_max_rel_diff")], v) for k, v in entry.items()
                           if k.endswith("_max_rel_diff"))}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    sizes = (1, 8) if args.quick else (1, 8, 64)
    resolve_device("cpu")
    devices = ["cpu"] + (["cuda:0"] if wp.get_cuda_device_count() > 0 else [])
    rows, table = [], {}
    for n in sizes:
        entry = {}
        cs_ref, pose, vel = scene(n, "numpy")
        entry["rows"] = cs_ref.n_contacts
        entry["numpy_us_per_row"] = casekit.time_call(lambda: cs_ref.raw(pose, vel)) / cs_ref.n_contacts * 1e6
        ref_q = np.array(cs_ref.raw(pose, vel)[0])
        for d in devices:
            cs, _, _ = scene(n, "warp", d)
            q = np.array(cs.raw(pose, vel)[0])
            entry[f"warp_{d.split(':')[0]}_us_per_row"] = casekit.time_call(lambda: cs.raw(pose, vel)) / cs.n_contacts * 1e6
            entry[f"warp_{d.split(':')[0]}_max_rel_diff"] = float(np.max(np.abs(q - ref_q)) / np.max(np.abs(ref_q)))
        table[str(n)] = entry
        rows.append(entry["rows"])
    results = {"us_per_pair_slice": table, "rows": rows, "reducer": reducer_costs(args.quick),
               "wall_s": time.perf_counter() - t0}
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"meshes": sizes, "slices_per_mesh": 8,
                                                              "lines": 2, "devices": devices},
                                 wall_s=time.perf_counter() - t0, device=devices[-1])


if __name__ == "__main__":
    main()
