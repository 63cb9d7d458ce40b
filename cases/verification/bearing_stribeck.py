"""Stribeck check: ball-bearing load distribution under a pure radial load at zero clearance.

A deep-groove row with the RD-40 ball set (16 balls of 7.938 mm on a 68 mm
pitch diameter, groove curvature ratio 0.52, steel, zero clearance) carries a
radial load F_r on its inner ring, outer ring fixed, a ball on the load line.
The element forces of the rolling-element family (Eq. (ball_bearing), Hertz
constants) are brought to equilibrium by Newton iterations with their
analytic tangent. References: Stribeck's Q_max = 4.37 F_r / (Z cos alpha),
the Sjoevall integral Q_max = F_r / (Z J_r(1/2) cos alpha), and the exact
discrete relation F_r = Q_max cos(alpha) sum cos^(5/2) psi_j.

The RD-40 main-bearing row (alpha_0 = 25 deg, axial position held) is solved
as well: its working angle falls as the ring moves radially, so its Q_max
departs from the constant-angle references as the load grows.
"""
import math
import time

import numpy as np

from rvtool import casekit
from rvtool.bearings import BallBearing
from rvtool.bearings.checks import radial_load_distribution, sjovall_radial_integral, stribeck_discrete_sum

RADIAL_LOAD = 5000.0   # N
RD40_BALLS = dict(n_balls=16, ball_diameter=7.938e-3, pitch_diameter=0.068, inner_curvature=0.52,
                  outer_curvature=0.52, youngs_modulus=206e9, poisson_ratio=0.3)


def _check(bearing, radial_load, backend, Jr):
    res = radial_load_distribution(bearing, radial_load, backend=backend)
    Z, ca = bearing.n_balls, math.cos(bearing.contact_angle)
    q = float(res.loads.max())
    exact = radial_load / (Z * Jr * ca)
    return res, {
        "q_max_N": q,
        "q_max_stribeck_437_N": 4.37 * radial_load / (Z * ca),
        "q_max_exact_integral_N": exact,
        "q_max_discrete_sum_N": radial_load / (ca * stribeck_discrete_sum(Z)),
        "rel_err_vs_exact": (q - exact) / exact,
        "n_loaded": int(np.sum(res.loads > 0)),
        "load_distribution_N": res.loads,
        "ball_angle_from_load_line_deg": np.degrees(res.angles),
        "working_angle_deg": np.degrees(res.working_angles),
        "ring_displacement_m": res.displacement,
        "newton_iterations": res.iterations,
    }


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    q = r["q_max_N"]
    return {
        # the exact discrete relation F_r = Q_max sum cos^(5/2) psi_j holds for the converged equilibrium:
        # Newton's residual only (measured 1e-15); 1e-9 is the solver's stopping tolerance with margin
        "q_max_vs_discrete_sum": casekit.check(abs(q / r["q_max_discrete_sum_N"] - 1), 1e-9, "<=",
                                               why="exact discrete relation; Newton tolerance"),
        # the Sjoevall integral replaces the 16-ball sum by an integral: 5e-4 apart (measured 4.6e-4);
        # 2e-3 is the quadrature error of a 16-point sum of cos^(5/2) over the loaded half
        "q_max_vs_sjoevall": casekit.check(abs(r["rel_err_vs_exact"]), 2e-3, "<=",
                                           why="integral vs 16-ball sum (discretisation of the load zone)"),
        # zero clearance: exactly the balls with cos psi > 0 carry load (psi = 0, +-22.5, +-45, +-67.5 deg)
        "loaded_balls": casekit.check(r["n_loaded"], 7, "==", why="half the ring at zero clearance, Z = 16"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    backend = "numpy" if args.quick else "warp"
    Jr = sjovall_radial_integral(0.5)
    deep = BallBearing(**RD40_BALLS)
    res, results = _check(deep, RADIAL_LOAD, backend, Jr)
    results["sjovall_J_r"] = Jr
    results["radial_load_N"] = RADIAL_LOAD
    ac = BallBearing(**RD40_BALLS, contact_angle=math.radians(25.0))
    loads = [RADIAL_LOAD] if args.quick else [100.0, 300.0, 1000.0, 3000.0, 5000.0, 10000.0]
    sweep = [_check(ac, F, backend, Jr)[1] for F in loads]
    results["angular_contact_25deg"] = {
        "radial_load_N": loads,
        "q_max_N": [s["q_max_N"] for s in sweep],
        "q_max_exact_integral_N": [s["q_max_exact_integral_N"] for s in sweep],
        "rel_err_vs_exact": [s["rel_err_vs_exact"] for s in sweep],
        "working_angle_max_load_deg": [float(s["working_angle_deg"][np.argmax(s["load_distribution_N"])]) for s in sweep]}
    results["wall_s"] = time.perf_counter() - t0

    import matplotlib.pyplot as plt
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 3.8))
    ang = np.degrees(res.angles)
    ax.bar(ang, res.loads, width=8, label="rolling elements")
    psi = np.linspace(-90, 90, 181)
    ax.plot(psi, results["q_max_exact_integral_N"] * np.cos(np.radians(psi)) ** 1.5, "k:",
            label="Stribeck: Q_max cos^(3/2) psi, Q_max = F_r/(Z J_r)")
    ax.set(xlabel="ball angle from the load line [deg]", ylabel="ball load [N]", xlim=(-185, 185),
           title=f"deep groove, F_r = {RADIAL_LOAD:.0f} N, zero clearance")
    ax.legend(fontsize=7)
    sw = results["angular_contact_25deg"]
    bx.semilogx(sw["radial_load_N"], 100 * np.array(sw["rel_err_vs_exact"]), "o-", label="alpha_0 = 25 deg row")
    bx.axhline(100 * results["rel_err_vs_exact"], color="k", ls=":", label="deep groove")
    bx.set(xlabel="radial load F_r [N]", ylabel="Q_max / Q_max,Stribeck - 1 [%]",
           title="departure from Stribeck (working angle)")
    bx.legend(fontsize=7)
    casekit.save_figure(fig, args.out, "stribeck")
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"bearing": repr(deep), "backend": backend,
                                                              "quick": args.quick}, wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
