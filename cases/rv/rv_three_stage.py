"""Three-stage RV reducer: offset input pinion -> compound gear -> sun -> 3 floating cranks; ratio, TE, torque balance, peak loads.

Design rvtool/designs/rv_three_stage.toml (chosen numbers, declared in the file). The same
builder and protocols as the two-stage case: the signed ratio from the gear graph (negative:
the external offset stage reverses the rotation) against the closed form
-(z_compound / z_pinion) (1 + (z_crank gear / z_sun) z_pins); the quasi-static TE over one crank
revolution at 40 points per cycloid mesh cycle (--quick: 12 points); the torque balance
|T_out - i T_in| / T_out at the rated state (input angle 0); the largest normal force per
physical contact of every family over the TE sequence. The TE resolution error (settings
``te_resolution``): one cycloid mesh cycle at the design's settings against the refined reference
(``RVDesign.resolution_reference``), as in cases/rv_two_stage.py.
"""
import time

import numpy as np

from rvtool import build, casekit, designs, load_design
from rvtool.protocols.load_sharing import contact_peaks, torque_balance_error, torque_balance_term
from rvtool.protocols.precision import quasi_static_te, te_metrics
from rvtool.analysis.resolution import te_resolution_error
from rvtool.solver.static import StaticSolver
from rvtool.units import ARCSEC_PER_RAD

DESIGN = designs.path("rv_three_stage")


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    return {
        "ratio_vs_closed_form": casekit.check(r["ratio_closed_form_rel_err"], 1e-9, "<=",
                                              why="-(z_c/z_p)(1 + z_cg/z_s z_pins); round-off of the gear graph"),
        # the design's settings against design.resolution_reference() over one cycloid mesh cycle: 1 %
        "te_resolution": casekit.check(r["te_resolution_rel_err"], 0.01, "<=",
                                       why="refined reference (2x samples and slices, analytic search)"),
        # pointwise i T_in / T_out - 1 = i TE' + i U'/T for conservative contacts (README, RV section): the
        # local TE slope, not a model error; measured 3.3e-3 here, at most 1.0e-2 over the crank revolution
        "torque_balance": casekit.check(r["torque_balance_rel_err"], 1e-2, "<=",
                                        why="pointwise balance = TE slope term, <= 1.0e-2 over the revolution"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    d = load_design(DESIGN)
    T = d.rated_torque
    wall = {}
    t0 = time.perf_counter()
    model = build(d)
    wall["build"] = time.perf_counter() - t0
    closed = -(d.compound_gear.n_teeth / d.input_pinion.n_teeth) * (1 + d.crank_gear.n_teeth / d.sun_gear.n_teeth
                                                                       * d.pins.n_pins)
    t0 = time.perf_counter()
    solver = StaticSolver(model)
    model.set_output_torque(-np.sign(model.ratio) * T)
    q_rated = solver.solve(0.0)
    tb0 = torque_balance_error(model, q_rated, T)
    wall["rated_state"] = time.perf_counter() - t0

    crank_rev = 2 * np.pi / abs(model.graph.crank_rate)
    n_pts = 12 if args.quick else int(round(crank_rev / model.mesh_period)) * 40
    angles = np.arange(n_pts) * crank_rev / n_pts
    peaks, balance, shares = {}, [], []

    def record(k, a, q):
        contact_peaks(model, q, peaks)
        balance.append(torque_balance_term(model, q, T))
        shares.append(model.crank_load_share(q))

    qs = quasi_static_te(model, torque=T, input_angles=angles, record=record)
    wall["quasi_static_te_with_observations"] = qs["wall_s"]
    revs = 1.0 / (abs(model.graph.crank_rate) * abs(model.ratio))
    met = te_metrics(qs["te"], n_revolutions=revs)
    res = te_resolution_error(d, d.resolution_reference(), points_per_mesh=20 if args.quick else 40)
    wall["te_resolution"] = res["wall_s"] + res["reference_wall_s"]
    results = {"ratio_nominal": float(d.ratio_target), "ratio_from_gear_graph": float(model.ratio),
               "te_pp_arcsec": met["pp"] * ARCSEC_PER_RAD, "torque_balance_rel_err": tb0, "peak_loads_N": peaks,
               "ratio_closed_form_rel_err": abs(model.ratio - closed) / abs(closed),
               "te_resolution_rel_err": res["te_rel_err"]}
    settings = {"design": d.name, "quick": args.quick, "ratio_closed_form": closed,
                "ratio_closed_form_rel_err": abs(model.ratio - closed) / abs(closed),
                "te_interval": {"input_angle_rad": float(crank_rev), "points": n_pts, "output_revolutions": revs,
                                "definition": "one crank revolution"},
                "te_rms_arcsec": met["rms"] * ARCSEC_PER_RAD,
                "torque_balance_over_te_sequence": {"max_abs": float(np.max(np.abs(balance))),
                                                     "mean_signed": float(np.mean(balance))},
                "crank_share_mean_over_crank_revolution": np.mean(shares, axis=0),
                "peak_loads_definition": "largest normal force per physical contact over the TE sequence [N]",
                "wall_s": wall, "ms_per_quasistatic_point": 1e3 * qs["wall_s"] / n_pts,
                "solver_stats": qs["stats"], **model.resolution_settings(),
                "te_resolution": {**res, "reference": "design.resolution_reference(): 2x profile samples and "
                                                      "involute slices, analytic profile search"}}
    _plots(model, q_rated, qs, met, revs, args.out)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


def _plots(model, q, qs, met, revs, out):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 7))
    model.draw_section(ax, q)
    ax.set_title(f"{model.design.name}: contact forces at {model.design.rated_torque:g} N m")
    casekit.save_figure(fig, out, "section_contacts")
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    ax[0].plot(np.rad2deg(qs["theta_in"] / abs(model.ratio)), (qs["te"] - np.mean(qs["te"])) * ARCSEC_PER_RAD, lw=0.8)
    ax[0].set(xlabel="output angle [deg]", ylabel="TE - mean [arcsec]", title="quasi-static TE at rated load")
    ax[1].semilogy(met["orders"][1:], np.maximum(met["amplitudes"][1:] * ARCSEC_PER_RAD, 1e-8), lw=0.8)
    ax[1].set(xlabel="output-shaft order", ylabel="amplitude [arcsec]", title=f"order spectrum ({revs:.3g} output rev)")
    casekit.save_figure(fig, out, "transmission_error")


if __name__ == "__main__":
    main()
