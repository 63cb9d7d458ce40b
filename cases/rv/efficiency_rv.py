"""RV-40E class: efficiency over input speed at rated torque by quasi-static energy accounting
(rvtool.protocols.efficiency; issue 30, item 2, first part).

At the frictionless static state of the rated output torque, the bodies move at their kinematic
velocities; the loss per family is mu F_n |v_t| at the cycloid--pin and involute contacts (mu =
0.05 each, assumed: lubricated steel in mixed lubrication, 0.03-0.08) and Palmgren's moment times the
relative speed on every rolling set (the design's [bearing_friction] factors, ISO VG 32 at 40 degC).
Averaged over 16 input angles spread over one cycloid mesh period (--quick: 8), at input speeds
500 ... 3000 r/min (--quick: 500, 1500, 3000). Checks: the frictionless power balance (the
kinematic velocities consistent with the static states; its mean over the period, where the stored
elastic energy's rate averages out) and every efficiency in (0, 1] and finite.
Not compared with a catalogue curve (no seals or churning, no temperature or low-load correction:
the rest of issue 30, item 2).
"""
import time

import numpy as np

import rvtool
from rvtool import casekit, designs
from rvtool.protocols.efficiency import SlidingFriction, efficiency

SPEEDS = (500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0)


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    c = casekit.check
    out = {"power_balance": c(max(p["frictionless_power_balance_rel_err"] for p in r["points"]), 1e-4,
                              why="mean over one mesh period (the elastic energy's rate averages out; 3e-5 measured "
                                  "at 8 and 16 angles); a wrong rate or sign gives O(1)")}
    for p in r["points"]:
        out[f"efficiency_{p['input_speed_rpm']:g}rpm"] = c(p["efficiency"], (0.0, 1.0), "in",
                                                          why="losses are nonnegative")
    return out


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    d = rvtool.load_design(designs.path("rv40e"))
    model = rvtool.build(d)
    n_ang = 8 if args.quick else 16
    angles = tuple(float(a) for a in np.arange(n_ang) * model.mesh_period / n_ang)
    speeds = (500.0, 1500.0, 3000.0) if args.quick else SPEEDS
    results = efficiency(model, d.rated_torque, speeds, friction=SlidingFriction(), input_angles=angles)
    casekit.verdict(results, judge)
    _plot(results, args.out)
    return casekit.write_results(args.out, results, settings={"design": d.name, "quick": args.quick},
                                 wall_s=time.perf_counter() - t0)


def _plot(r, out):
    import matplotlib.pyplot as plt
    pts = r["points"]
    n = [p["input_speed_rpm"] for p in pts]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(n, [100 * p["efficiency"] for p in pts], "o-")
    ax[0].set(xlabel="input speed [r/min]", ylabel="efficiency [%]", title="rv40e at rated torque (quasi-static)")
    for fam in pts[0]["loss_by_family_W"]:
        ax[1].plot(n, [p["loss_by_family_W"][fam] for p in pts], "o-", label=fam)
    ax[1].set(xlabel="input speed [r/min]", ylabel="loss [W]")
    ax[1].legend()
    casekit.save_figure(fig, out, "efficiency")


if __name__ == "__main__":
    main()
