"""Dask sweep of RD-40: eccentricity error x pin clearance (5 x 5) on a LocalCluster, TE p-p heat map.

The grid and the per-point protocol come from rvtool/designs/sweep_rd40.toml (the file
`rvtool sweep` reads): each of the 25 points is one Dask task running
rvtool.variants.variant_figures (quasi-static TE over one output revolution, max pin
force, lost motion) on a LocalCluster of 2 worker processes with one thread each. A
failed task is a row with status "failed"; the sweep goes on. --quick: the 2 x 2 corner
points. Writes the tidy table (results.csv, results.json: one row per run) and a heat
map of TE p-p over the grid (failed points blank and marked x).
"""
import dataclasses
import os
import time

import numpy as np

from rvtool import casekit
from rvtool.variants.sweep import load_sweep_spec, run_sweep
from rvtool import designs

HERE = os.path.dirname(os.path.abspath(__file__))
SPEC = designs.path("sweep_rd40")


def heat_map(rows, spec, out_dir, key="te_pp_arcsec", label="TE p-p [arcsec]"):
    """Heat map of ``key`` over the two swept parameters (first: rows, second: columns) [um]."""
    import matplotlib.pyplot as plt
    p1, p2 = list(spec.parameters)
    v1, v2 = spec.parameters[p1], spec.parameters[p2]
    grid = np.full((len(v1), len(v2)), np.nan)
    for r in rows:
        if r["status"] == "ok":
            grid[v1.index(r[p1]), v2.index(r[p2])] = r[key]
    fig, ax = plt.subplots(figsize=(5.6, 4.4))
    im = ax.imshow(grid, origin="lower", cmap="viridis", aspect="auto")
    ax.set_xticks(range(len(v2)), [f"{v * 1e6:g}" for v in v2])
    ax.set_yticks(range(len(v1)), [f"{v * 1e6:g}" for v in v1])
    ax.set(xlabel=f"{p2} [um]", ylabel=f"{p1} [um]", title=f"RD-40 sweep: {label}")
    for i in range(len(v1)):
        for j in range(len(v2)):
            ax.text(j, i, "x" if np.isnan(grid[i, j]) else f"{grid[i, j]:.2f}", ha="center", va="center",
                    color="w", fontsize=7)
    fig.colorbar(im, ax=ax, label=label)
    return casekit.save_figure(fig, out_dir, "te_pp_heatmap")


MAX_FAILED = 0
"""Failed grid points allowed: the full 5 x 5 grid measured none (a failed point is a row, not a crash)."""


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    p1, p2 = list(r["parameters"])
    n_grid = len(r["parameters"][p1]) * len(r["parameters"][p2])
    ok = [row for row in r["table_rows"] if row["status"] == "ok"]
    # pin clearance adds free play: at each eccentricity error the lost motion grows with the clearance
    growth = []
    for e in r["parameters"][p1]:
        lm = [row["lost_motion_arcmin"] for row in sorted((x for x in ok if x[p1] == e), key=lambda x: x[p2])]
        growth += [b - a for a, b in zip(lm, lm[1:])]
    return {
        "failures": casekit.check(r["failed"], MAX_FAILED, "<=", why="stated maximum MAX_FAILED"),
        "every_point_reported": casekit.check(r["rows"], n_grid, "==", why="one row per grid point, failed or not"),
        "clearance_adds_lost_motion": casekit.check(min(growth, default=None), 0.0, ">",
                                                    why="free play at the pins adds to the lost motion"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    spec = load_sweep_spec(SPEC)
    if args.quick:
        spec = dataclasses.replace(spec, parameters={k: [v[0], v[-1]] for k, v in spec.parameters.items()})
    res = run_sweep(spec, out_dir=args.out)
    rows = res["rows"]
    heat_map(rows, spec, args.out)
    ok = [r for r in rows if r["status"] == "ok"]
    results = {
        "rows": len(rows),
        "failed": res["failed"],
        "wall_s": res["wall_s"],
        "runs_per_s": len(rows) / res["wall_s"],
        "cluster": dataclasses.asdict(spec.cluster),
        "parameters": spec.parameters,
        "n_te_points": spec.protocol.n_te_points,
        "te_pp_arcsec_range": [min((r["te_pp_arcsec"] for r in ok), default=None),
                               max((r["te_pp_arcsec"] for r in ok), default=None)],
        "lost_motion_arcmin_range": [min((r["lost_motion_arcmin"] for r in ok), default=None),
                                     max((r["lost_motion_arcmin"] for r in ok), default=None)],
        "failures": [{k: r[k] for k in ("point", *spec.parameters, "error")} for r in rows if r["status"] != "ok"],
        "table": [os.path.basename(p) for p in res["table"]],
        "table_rows": rows,
    }
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"spec": os.path.relpath(SPEC, HERE), "quick": args.quick,
                                                              "protocol": repr(spec.protocol), "build": spec.build},
                                 wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
