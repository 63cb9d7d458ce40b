"""Stribeck check: ball-bearing load distribution under a radial load at zero clearance.

A deep-groove ball bearing (16 balls of 7.938 mm on 68 mm, f = 0.52) with the
outer ring fixed carries a radial load F_r on the inner ring. The element
forces of the rolling-element family (Eq. (ball_bearing)) are brought to
equilibrium by Newton iterations with their analytic tangent. References:
the exact zero-clearance discrete sum F_r = Q_max sum cos^(5/2) psi_j (the
inner ring moves along the load line) and Stribeck's continuous result
Q_max = F_r / (Z J_r(0.5)) = 4.37 F_r / Z.
"""
import time

import numpy as np

from rvtool import casekit
from rvtool.bearings import BallBearing
from rvtool.bearings.checks import radial_load_distribution, sjovall_radial_integral, stribeck_exact_sum


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    bb = BallBearing(n_balls=16, ball_diameter=0.007938, pitch_diameter=0.068)
    Fr = 5000.0
    Q, psi, disp = radial_load_distribution(bb, Fr, backend="numpy" if args.quick else "warp")
    # element angle from the load line (load along -y: the loaded balls sit at psi = -pi/2)
    exact = Fr * stribeck_exact_sum(bb.n_balls, psi_loaded_line=np.pi / 2)
    Jr = sjovall_radial_integral(0.5)
    results = {
        "q_max_N": float(Q.max()),
        "q_max_stribeck_437_N": 4.37 * Fr / bb.n_balls,
        "q_max_exact_integral_N": Fr / (bb.n_balls * Jr),
        "q_max_exact_discrete_sum_N": float(exact),
        "rel_err_vs_exact": float(abs(Q.max() - exact) / exact),
        "rel_diff_vs_stribeck_437": float(Q.max() / (4.37 * Fr / bb.n_balls) - 1),
        "n_loaded": int(np.sum(Q > 0)),
        "load_distribution_N": Q,
        "ring_displacement_m": disp,
        "wall_s": time.perf_counter() - t0,
    }
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 3.6))
    order = np.argsort(np.mod(psi + np.pi / 2, 2 * np.pi))
    ax.bar(np.rad2deg(np.mod(psi[order] + np.pi / 2 + np.pi, 2 * np.pi) - np.pi), Q[order], width=8)
    ax.axhline(4.37 * Fr / bb.n_balls, color="k", ls=":", label="4.37 F_r / Z")
    ax.set(xlabel="ball angle from the load line [deg]", ylabel="ball load [N]", title=f"F_r = {Fr} N")
    ax.legend()
    casekit.save_figure(fig, args.out, "stribeck")
    return casekit.write_results(args.out, results, settings={"bearing": repr(bb), "radial_load_N": Fr},
                                 wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
