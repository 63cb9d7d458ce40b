"""Ideal pin load sharing of RD-40 against the classical closed-form distribution.

Unmodified profile, zero clearance, linearized contact law, wheel centres held
on their journals (rigid bodies apart from the contacts), 140 N m at the
output at zero input angle. Classical result for an ideal cycloid drive (Li
Lixing; Blagojevic et al. 2011): every contact normal passes through the
pitch point P on the line of centres (r'_c = e z_g from the wheel centre), so
the normal of pin i has the lever arm l_i = r'_c sin(phi_i) / S(phi_i),
S = sqrt(1 + K1^2 - 2 K1 cos(phi_i)), about the wheel centre, phi_i the pin
angle from the line of centres and K1 = e z_b / R_z. A rigid wheel rotating by
dtheta compresses pin i by l_i dtheta; with a linear law F_i = T_w l_i /
sum_j l_j^2 over the loaded half (T_w the torque on one wheel). The common
approximation F_max = 4 T_w / (K1 z_g R_z) (from S = 1, a sine distribution)
is reported beside it.
"""
import time

import numpy as np

import rvtool
from rvtool import casekit
from rvtool.solver.static import StaticSolver
from rvtool.protocols.precision import mesh_forces

DESIGN = "rd40"


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    n = r["samples_per_tooth"]
    # the wheel profile is a sampled table: its error falls as n^-2 (0.42 % of F_max at 240 samples, full run;
    # 6.7 % at 60, quick: the 16x of (240/60)^2); the bound is 1.5x that law
    bound = 1.5 * 0.0042 * (240 / n) ** 2
    return {"distribution_vs_classical": casekit.check(r["distribution_max_rel_err"], bound, "<=",
                                                       why="classical ideal distribution; profile-table error ~ n^-2")}


def closed_form(design, wheel, torque_per_wheel):
    """Classical ideal distribution F_i = T_w l_i / sum l_j^2 [N] per pin index, and the
    sine approximation of F_max."""
    zb = design.pins.n_pins
    zg = zb - 1
    e = design.wheels.eccentricity
    K1 = e * zb / design.pins.pin_circle_radius
    a = 2 * np.pi * np.arange(zb) / zb                       # pin angle from +y, clockwise
    phase = design.wheels.phases[wheel]                      # journal direction of this wheel
    phi = a + phase                                          # angle from the line of centres
    lever = e * zg * np.maximum(-np.sin(phi), 0.0) / np.sqrt(1 + K1 ** 2 - 2 * K1 * np.cos(phi))
    forces = torque_per_wheel * lever / np.sum(lever ** 2)
    return forces.max(), forces, 4 * torque_per_wheel / (K1 * zg * design.pins.pin_circle_radius)


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    base = rvtool.load_design(DESIGN)
    design = rvtool.replace_design(base, wheels={"clearance": 0.0, "samples_per_tooth": 60 if args.quick else 240},
                     profile={"equidistant_mod": 0.0, "offset_mod": 0.0, "rotation_mod_deg": 0.0},
                     pin_contact={"law": "line", "damping": 0.0, "mu": 0.0})
    model = rvtool.build(design, rigid_supports=True)
    solver = StaticSolver(model)
    T = design.rated_torque
    model.set_output_torque(-np.sign(design.ratio) * T)
    q = solver.solve(0.0)
    F = mesh_forces(model, q)
    rows, cf_all = [], []
    for w in range(design.n_wheels):
        fmax_cf, cf, fmax_sin = closed_form(design, w, T / design.n_wheels)
        cf_all.append(cf)
        rows.append((fmax_cf, float(F[w].max()), float(np.max(np.abs(F[w] - cf)) / fmax_cf), fmax_sin))
    results = {
        "fmax_closed_form_N": [r[0] for r in rows],
        "fmax_sim_N": [r[1] for r in rows],
        "distribution_max_rel_err": max(r[2] for r in rows),
        "distribution_max_rel_err_per_wheel": [r[2] for r in rows],
        "fmax_sine_approximation_N": [r[3] for r in rows],
        "pin_forces_sim_N": F, "pin_forces_closed_form_N": np.array(cf_all),
        "wall_s": time.perf_counter() - t0,
        "newton_iterations": solver.stats.newton_iterations,
        "samples_per_tooth": design.wheels.samples_per_tooth,
        "reference": "classical ideal distribution F_i = T_w l_i / sum l_j^2, l_i = e z_g sin(phi_i) / S(phi_i)",
    }
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 3.8))
    idx = np.arange(F.shape[1])
    for w in range(F.shape[0]):
        ax.plot(idx, F[w], "o", ms=4, label=f"simulation wheel {w}")
        ax.plot(idx, cf_all[w], "-", lw=1, label=f"closed form wheel {w}")
    ax.set(xlabel="pin index", ylabel="pin force [N]", title=f"ideal load sharing at {T} N m")
    ax.legend(fontsize=7)
    casekit.save_figure(fig, args.out, "ideal_load_sharing")
    settings = {"samples_per_tooth": design.wheels.samples_per_tooth, "law": "line",
                "supports": "rigid: shaft and flange on the axis, wheels on their journals (100 x bearing stiffness)"}
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
