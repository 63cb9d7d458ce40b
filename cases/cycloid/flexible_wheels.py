"""RD-40 with flexible wheels as floating bodies (issue 33, Deliver 2): [wheels.dynamics] model = "flexible".

Checks and figures:

(a) frozen modal coordinates reproduce the rigid model: quasi-static TE over one mesh cycle
    (bound 1e-6 arcsec and 1e-9 relative, the issue's);
(b) the mounted wheels, linearized at the rated torque (input angle 0), against a full FE of the
    same assembly (every mesh coordinate of both wheels, the same contact tangents and port
    operators; rvtool.protocols.flexible_modes): the first in-plane modes (--quick: the mounted
    modes alone, positive; the full FE's shift-invert solve runs in the full run);
(c) the dynamic TE spectrum against the number of retained modes (driven runs over the same window);
(d) spectra of the output torsion with the mesh, bearing and wheel-mode markers (figure);
(e) a driven RD-40 run at rated speed and torque with flexible wheels on the Exudyn path over one
    input revolution (--quick: 0.05 of one, on a coarser wheel mesh), with its cost against the
    rigid run's.
"""
import time

import numpy as np

from rvtool import build, casekit, designs, load_design
from rvtool.assembly.spec import replace as replace_design
from rvtool.protocols import flexible_modes as F
from rvtool.protocols.precision import quasi_static_te
from rvtool.units import ARCSEC_PER_RAD

DESIGN = designs.path("rd40")
N_MODES = 8                 # retained in-plane modes per wheel in the driven run (e)
STATIC_ORDERS = 8           # static correction of the basis (FloatingDynamics.static_orders, its default)
STEP = 2e-5                 # s, as cases/cycloid/vibration.py
MODES_COMPARED = 6          # (b): the first in-plane modes of the mounted assembly
MODE_BOUND = 0.01           # (b): the target, relative frequency difference
QUICK_STRUCTURE = {"mesh_size": 0.006, "samples_per_tooth": 4}
"""--quick: a coarser wheel body (issue 30's mesh); the full run takes [wheels.structure]'s defaults."""


def flexible(design, n_modes, static_orders=STATIC_ORDERS, structure=None, **kw):
    wheels = {"dynamics": {"model": "flexible", "n_modes": n_modes, "static_orders": static_orders, **kw}}
    if structure:
        wheels["structure"] = structure
    return replace_design(design, wheels=wheels)


def driven(design, revs):
    """(run, protocol, model, wall_s) of a driven run at rated speed and torque over ``revs`` input revolutions."""
    model = build(design)
    run, proto, wall = F.driven_run(model, design.input_speed_rpm, design.rated_torque, revs, STEP,
                                    {"wheel0_x": (1, 0)})
    return run, proto, model, wall


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    a = r["frozen"]
    return {
        "frozen_te_abs": casekit.check(a["te_max_abs_diff_arcsec"], 1e-6, "<=", why="issue 33: frozen = rigid, 1e-6 arcsec"),
        "frozen_states_rel": casekit.check(a["states_max_rel_diff"], 1e-9, "<=",
                                           why="issue 33: frozen = rigid, equilibria 1e-9 relative (the golden "
                                               "backends' bound on states)"),
        # (b) the mounted wheels: the contact tangents, their modes, and the target on the first modes
        # against the full FE with the default basis
        "mode_comparison_symmetric": casekit.check(r["modes"]["contact_tangent_asymmetry"], 1e-6, "<=",
                                                   why="frictionless contact tangents are symmetric (both models "
                                                       "take the symmetric part)"),
        **{k: casekit.check(*v)
           for k, v in F.wheel_criteria(r, n_compared=MODES_COMPARED, bound=MODE_BOUND).items()},
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_start = time.perf_counter()
    d = load_design(DESIGN)
    zp = d.pins.n_pins
    mesh = 2 * np.pi / zp
    st = QUICK_STRUCTURE if args.quick else None
    results = {}

    # (a) frozen vs rigid, quasi-static TE over one mesh cycle
    n_pts = 8 if args.quick else 24
    angles = np.arange(n_pts) * mesh / n_pts
    rigid = F.te_and_states(build(d), d.rated_torque, angles)
    frozen = F.te_and_states(build(flexible(d, N_MODES, structure=st, frozen=True)), d.rated_torque, angles)
    flex_qs = np.asarray(quasi_static_te(build(flexible(d, N_MODES, structure=st)), torque=d.rated_torque,
                                         input_angles=angles)["te"])
    results["frozen"] = {
        **F.frozen_differences(rigid, frozen),
        "te_pp_rigid_arcsec": float(np.ptp(rigid[0]) * ARCSEC_PER_RAD),
        "te_pp_flexible_arcsec": float(np.ptp(flex_qs) * ARCSEC_PER_RAD),
        "points": n_pts,
    }

    # (b) mounted modes vs the full FE of the same linearized assembly, per basis (n_modes, static_orders)
    bases = ((N_MODES, STATIC_ORDERS),) if args.quick else ((8, -1), (8, 4), (8, 8))
    modes, m = F.mode_comparison(lambda nm, J: build(flexible(d, nm, J, structure=st)), bases, d.rated_torque,
                                 n=MODES_COMPARED, bound=MODE_BOUND, default=(N_MODES, STATIC_ORDERS),
                                 full=not args.quick)
    summary = m.flexible.summary()
    modes["wheel_mesh"] = summary["mesh"]
    modes["wheel_source"] = summary["source"]
    results["modes"] = modes

    # (e) the driven run with flexible wheels and its cost against the rigid run
    revs = 0.05 if args.quick else 1.0
    run_r, proto, model_r, wall_r = driven(d, revs)
    run_f, _, model_f, wall_f = driven(flexible(d, N_MODES, structure=st), revs)
    results["driven"] = {
        "n_modes": N_MODES, "static_orders": STATIC_ORDERS,
        "n_coordinates_per_wheel": model_f.flexible.summary()["n_coordinates"],
        **F.driven_cost((run_f, wall_f), (run_r, wall_r), revs, d.input_speed_rpm, STEP),
        # (Omega_wheel / omega_1)^2: the relative size of the quadratic-velocity coupling the mean-axis frame leaves out
        "neglected_coupling": model_f.flexible.bodies[0].neglected_coupling(2 * np.pi * d.input_speed_rpm / 60.0 / (zp - 1)),
    }

    # (c) the dynamic TE spectrum against the number of modes over one window
    conv_revs = revs if args.quick else 0.1
    conv_bases = (4, 8) if args.quick else (4, 8, 16)
    runs = [run_f if (nm == N_MODES and conv_revs == revs) else driven(flexible(d, nm, structure=st), conv_revs)[0]
            for nm in conv_bases]
    spectra, change = F.spectrum_convergence(runs, F.driven_protocol(d.input_speed_rpm, d.rated_torque, conv_revs, STEP))
    results["convergence"] = {
        "n_modes": list(conv_bases), "static_orders": STATIC_ORDERS, "input_revolutions": conv_revs,
        "spectrum_change_vs_peak": change,
        "torsion_pp_arcsec": [float(np.ptp(s["x_uniform"]) * ARCSEC_PER_RAD) for s in spectra],
    }

    # (d) spectra with mesh, bearing and wheel-mode markers
    results["spectra"], markers, sp = F.spectra_and_markers(run_f, run_r, proto, model_f, d.input_speed_rpm,
                                                            modes["reduced_hz"][bases.index((N_MODES, STATIC_ORDERS))])
    results["markers_hz"] = markers
    _plot(args.out, sp, markers)
    settings = {"design": d.name, "n_modes": N_MODES, "static_orders": STATIC_ORDERS, "step_s": STEP,
                "quick": args.quick, "wheel_structure": st or "defaults", "mode_bases": [list(b) for b in bases]}
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_start)


def _plot(out, spectra, markers):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.6))
    F.draw_spectra(ax, spectra, markers, meshes=(("mesh_hz", "mesh", "r"),),
                   bearings=("eccentric_bearing", "main_bearing", "input_bearing"))
    casekit.save_figure(fig, out, "flexible_wheels")


if __name__ == "__main__":
    main()
