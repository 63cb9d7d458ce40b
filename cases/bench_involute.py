"""Benchmark of the involute tooth-pair contact family: microseconds per pair-slice evaluation
(forces, the analytic tangent dQ/dq and dQ/dv, observations), Warp CPU and CUDA (when a GPU
is present) against the NumPy reference, float64.

Scene: copies of the FZG type C mesh (cases/involute_pair.py) side by side, each with 8
face-width slices on both lines of action (5 tooth windows): 80 rows per mesh, loaded at a
position with line and tip-edge contacts. The time of one evaluation is the mean of repeated
calls (rvtool.casekit.time_call) including the host-device copies of the state in and the
results out, as the contact element calls it; the per-row time is that divided by the rows.
"""
import time

import numpy as np
import warp as wp

from rvtool import casekit
from rvtool.contact.involute_set import GearMesh, InvoluteContactSet
from warp_contacts.precision import resolve_device

import involute_pair


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
    results = {"us_per_pair_slice": table, "rows": rows, "wall_s": time.perf_counter() - t0}
    return casekit.write_results(args.out, results, settings={"meshes": sizes, "slices_per_mesh": 8,
                                                              "lines": 2, "devices": devices},
                                 wall_s=time.perf_counter() - t0, device=devices[-1])


if __name__ == "__main__":
    main()
