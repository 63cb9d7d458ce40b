"""RV-40E class two-stage RV reducer: ratio from the gear graph, rated state, TE, crank load sharing, stiffness.

Design rvtool/designs/rv40e.toml (catalogue: 412 N m, i = 121, 3 cranks; the rest chosen and
declared in the file). Protocols, unchanged from the cycloid drive: the quasi-static TE
sequence (rvtool.protocols.precision.quasi_static_te) over one crank revolution (1/39 output
revolution: the period of the crank order; the nominal meshes repeat within it) at 40 points
per cycloid mesh cycle (--quick: 12 points over the crank revolution), and the 74-level
torque sequence by continuation (rvtool.protocols.stiffness, path (b); --quick: 25 % steps)
with the four branch fits and the +-3 % lost motion. Crank load shares (fraction of the summed
crank torque about the carrier axis) and the torque balance |T_out - i T_in| / T_out at the
rated state (input angle 0); shares and the balance term are also recorded at every TE point.
Peak loads: the largest normal force per physical contact (pin, tooth pair, roller, ball) of
each family over the TE sequence (input angle 0 included).

Stiffness budget (issue 21 Deliver 3, rvtool.protocols.budget.stiffness_budget) at the rated
state (input angle 0) of rv40e as published (rigid cranks, ``cranks.shaft.model = "rigid"``) and
with elastic cranks (``"simply_supported"``: each crank a Timoshenko beam on its tapered rows,
rvtool.structure.crank_beam, closed per crank in series with the needle and involute contacts):
the share of the output compliance per family and path (``cranks`` = crank bending and shear),
from the condensed tangent's energy and by switching each to rigid; the tangent stiffness of
both and the branch fits of the same torque sequence with elastic cranks; the budget also with the
cranks tilting on their pairs (``tilt = true``: the pair's tilting compliance at the rated load,
condensed, in the ``cranks`` path). The published
figures above stay those of the rigid cranks.
TE resolution (``te_resolution_rel_err``): the quasi-static TE over one cycloid mesh cycle (40
points; --quick 20) at the design's settings against the refined reference
(``RVDesign.resolution_reference``: twice the profile samples and involute slices, the analytic
profile search), rvtool.protocols.resolution.te_error (the larger of the pointwise and the
peak-to-peak error over the reference's peak-to-peak).
Free play: rv40e carries a 1.5 um needle clearance and a 10 um tooth thickness allowance on the
crank gears (declared in the design file). At zero load the cranks, wheels and carrier are then
held only by the regularization springs; the continuation crosses that free play by the
guide-spring homotopy from the previous equilibrium (rvtool/solver/guide.py; the accepted
states carry no guide force; counted in the stiffness stats' ``guided_levels``). Recorded in the
settings next to the figures: the lost motion by the spring-controlled march (an independent
path through the free play), the lost motion and branch fits of the clearance-free variant
(rvtool.assembly.rv.free_play.without_free_play, the model rv40e was before), and the bound on
the regularization springs' effect: the +-3 % lost motion re-solved with springs ten times
weaker, |LM(k) - LM(k/10)| / 0.9 (the effect is linear in k to first order).
"""
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build, load_design
from rvtool.protocols.budget import stiffness_budget
from rvtool.assembly.rv.free_play import free_play, without_free_play
from rvtool.protocols.lost_motion import lost_motion
from rvtool.protocols.load_sharing import contact_peaks, torque_balance_error, torque_balance_term
from rvtool.protocols.precision import quasi_static_te, te_metrics
from rvtool.analysis.resolution import te_resolution_error
from rvtool.protocols.stiffness import TorqueSequence, branch_fits, lost_motion_from_levels, quasi_static_stiffness
from rvtool.solver.continuation import Continuation
from rvtool.solver.static import StaticSolver
from rvtool.units import ARCSEC_PER_RAD, RAD_PER_ARCMIN

DESIGN = designs.path("rv40e")


def order_markers(model):
    """Output-shaft orders of the RV's excitations (per output revolution)."""
    d, g = model.design, model.graph
    i = abs(model.ratio)
    return {"input": i, "crank": abs(g.crank_rate) * i, "cycloid_mesh": d.pins.n_pins * abs(g.crank_rate) * i,
            "involute_mesh": d.sun_gear.n_teeth * abs(g.sun_ratio - g.rates["carrier"]) * i}


REGULARIZATION = (100.0, 0.1)
"""The RV builder's regularization springs (k_translation [N/m], k_rotation [N m/rad])."""


def lost_motion_continuation(design, fraction=0.03, regularization=REGULARIZATION):
    """Output angle [arcmin] at +fraction minus at -fraction of T_rated by the continuation from zero
    (the sequence's definition without the loading branches between: a frictionless level is
    path-independent) and the largest regularization force there [N or N m]."""
    m = build(design, regularization=regularization)
    cont = Continuation(m)
    t = fraction * design.rated_torque
    qp = cont.go_to(t).copy()
    fp = m.regularization_force(qp)
    qm = cont.go_to(-t).copy()
    i = m.output_index
    return (qp[i] - qm[i]) / RAD_PER_ARCMIN, max(fp, m.regularization_force(qm))


def free_play_study(design, seq, lm_sequence):
    """Settings record of the free play (module docstring): spring-march lost motion, the
    clearance-free variant's figures, the regularization bound."""
    T = design.rated_torque
    t0 = time.perf_counter()
    sm = lost_motion(build(design), torque_level=0.03 * T)
    lm_k, reg_k = lost_motion_continuation(design)
    lm_k10, _ = lost_motion_continuation(design, regularization=tuple(0.1 * k for k in REGULARIZATION))
    bound = abs(lm_k - lm_k10) / 0.9
    zero = without_free_play(design)
    st0 = quasi_static_stiffness(build(zero), seq)
    fits0 = branch_fits(st0["torque_Nm"], st0["angle_arcmin"], st0["labels"], T)
    return {"free_play": free_play(design),
            "lost_motion_spring_march_arcmin": sm["lost_motion_rad"] / RAD_PER_ARCMIN,
            "lost_motion_spring_march_minus_sequence_arcmin": sm["lost_motion_rad"] / RAD_PER_ARCMIN - lm_sequence,
            "regularization_bound": {"lost_motion_arcmin": lm_k, "lost_motion_weak_springs_arcmin": lm_k10,
                                     "effect_bound_arcmin": bound, "effect_bound_rel": bound / abs(lm_k),
                                     "max_spring_force_at_3pct": reg_k,
                                     "output_spring_vs_branch_stiffness": "k_rot = 0.1 N m/rad = 2.9e-5 N m/arcmin "
                                                                          "in parallel with the output rotation"},
            "without_free_play": {"lost_motion_arcmin": lost_motion_from_levels(st0["torque_Nm"], st0["angle_arcmin"],
                                                                                T),
                                  "K_Nm_per_arcmin": {b: f["K_Nm_per_arcmin"] for b, f in fits0.items()}},
            "wall_s": time.perf_counter() - t0}


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    sb = r["stiffness_budget"]
    sh = r["crank_load_share"]
    checks = {
        "ratio_vs_closed_form": casekit.check(r["ratio_closed_form_rel_err"], 1e-9, "<=",
                                              why="1 + (z_cg / z_s) z_pins; round-off of the gear graph"),
        "te_resolution": casekit.check(r["te_resolution_rel_err"], 0.01, "<=",
                                       why="refined reference (2x samples and slices, analytic search)"),
        # pointwise i T_in / T_out - 1 = i TE' + i U'/T (README, RV section): the TE slope term, up to 3.7e-3
        # over a crank revolution (measured); 1e-2 bounds it at the rated state
        "torque_balance": casekit.check(r["torque_balance_rel_err"], 1e-2, "<=",
                                        why="pointwise balance = TE slope term (not a model error)"),
        # three equal cranks: over a crank revolution each carries a third on average (README: 0.33328 ...
        # 0.33338 at 1,600 points); a 12-point quick sample of the +-0.012 swing: within 2e-3
        "crank_share_mean": casekit.check(max(abs(v - 1 / 3) for v in sh["fraction_mean_over_crank_revolution"]),
                                          2e-3, "<=", why="equal cranks share equally on average"),
        # elastic crank shafts add compliance in series
        "elastic_cranks_softer": casekit.check(sb["elastic_cranks"]["K_tangent_Nm_per_arcmin"]
                                               / sb["rigid_cranks"]["K_tangent_Nm_per_arcmin"], 1.0, "<",
                                               why="series compliance of the crank shafts"),
    }
    for name, b in sb.items():
        if isinstance(b, dict) and "sensitivity_shares" in b:
            checks[f"{name}_budget_energy_vs_sensitivity"] = casekit.check(
                max(abs(v - b["sensitivity_shares"][k]) for k, v in b["shares"].items() if k in b["sensitivity_shares"]),
                1e-4, "<=", why="energy shares = sensitivity shares (springs in series)")
    return checks


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    design = load_design(DESIGN)
    T = design.rated_torque
    wall = {}

    t0 = time.perf_counter()
    model = build(design)
    wall["build"] = time.perf_counter() - t0
    g = model.graph
    closed_form = 1 + design.crank_gear.n_teeth / design.sun_gear.n_teeth * design.pins.n_pins

    # rated state at input angle 0
    t0 = time.perf_counter()
    solver = StaticSolver(model)
    model.set_output_torque(-np.sign(model.ratio) * T)
    q_rated = solver.solve(0.0)
    share0 = model.crank_load_share(q_rated)
    ecc0 = model.eccentric_bearing_resultants(q_rated)
    tb0 = torque_balance_error(model, q_rated, T)
    wall["rated_state"] = time.perf_counter() - t0

    # quasi-static TE over one crank revolution, shares and balance at every point
    crank_rev = 2 * np.pi / abs(g.crank_rate)                  # input angle of one crank revolution
    n_pts = 12 if args.quick else int(round(crank_rev / model.mesh_period)) * 40
    angles = np.arange(n_pts) * crank_rev / n_pts
    shares, balance, peaks = [], [], {}

    def record(k, a, q):
        shares.append(model.crank_load_share(q))
        balance.append(torque_balance_term(model, q, T))
        contact_peaks(model, q, peaks)

    qs = quasi_static_te(build(design), torque=T, input_angles=angles, record=None)
    wall["quasi_static_te"] = qs["wall_s"]
    # the shares and balance are recorded on a second pass over the same points (their observation
    # cost is kept out of the TE wall time)
    t0 = time.perf_counter()
    quasi_static_te(model, torque=T, input_angles=angles, record=record)
    wall["crank_sharing_sequence"] = time.perf_counter() - t0
    shares, balance = np.array(shares), np.array(balance)
    revs = 1.0 / (abs(g.crank_rate) * abs(model.ratio))
    met = te_metrics(qs["te"], n_revolutions=revs)

    # resolution error of the TE (issue 21 Deliver 6): one mesh cycle at the design's settings against
    # the refined reference (twice the profile samples and involute slices, analytic profile search)
    res = te_resolution_error(design, design.resolution_reference(), points_per_mesh=20 if args.quick else 40)
    wall["te_resolution"] = res["wall_s"] + res["reference_wall_s"]

    # stiffness and lost motion (path (b), continuation at input angle 0)
    t0 = time.perf_counter()
    seq = TorqueSequence(rated_torque=T, loading_step=0.25, other_step=0.25) if args.quick else TorqueSequence(rated_torque=T)
    st = quasi_static_stiffness(build(design), seq)
    fits = branch_fits(st["torque_Nm"], st["angle_arcmin"], st["labels"], T)
    lm = lost_motion_from_levels(st["torque_Nm"], st["angle_arcmin"], T)
    wall["stiffness_sequence"] = time.perf_counter() - t0
    fp = free_play_study(design, seq, lm)
    wall["free_play_study"] = fp["wall_s"]

    # stiffness budget: rigid cranks (as published) and elastic cranks, at the rated state
    t0 = time.perf_counter()
    budget = {"rigid_cranks": stiffness_budget(model, q_rated)}
    d_el = elastic_cranks(design)
    m_el = build(d_el)
    m_el.set_output_torque(-np.sign(m_el.ratio) * T)
    q_el = StaticSolver(m_el).solve(0.0)
    budget["elastic_cranks"] = stiffness_budget(m_el, q_el)
    m_tl = build(elastic_cranks(design, tilt=True))
    m_tl.set_output_torque(-np.sign(m_tl.ratio) * T)
    budget["elastic_cranks_with_tilt"] = stiffness_budget(m_tl, StaticSolver(m_tl).solve(0.0))
    wall["stiffness_budget"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    st_el = quasi_static_stiffness(build(d_el), seq)
    fits_el = branch_fits(st_el["torque_Nm"], st_el["angle_arcmin"], st_el["labels"], T)
    wall["stiffness_sequence_elastic_cranks"] = time.perf_counter() - t0

    ratio_closed_err = abs(model.ratio - closed_form) / closed_form
    names = list(ecc0)
    results = {
        "ratio_nominal": float(design.ratio_target),
        "ratio_from_gear_graph": float(model.ratio),
        "te_pp_arcsec": met["pp"] * ARCSEC_PER_RAD,
        "te_rms_arcsec": met["rms"] * ARCSEC_PER_RAD,
        "te_orders": met["peak_orders"],
        "te_order_amplitudes_arcsec": met["peak_amplitudes"] * ARCSEC_PER_RAD,
        "te_resolution_rel_err": res["te_rel_err"],
        "crank_load_share": {
            "fraction_at_rated": share0,
            "fraction_mean_over_crank_revolution": shares.mean(axis=0),
            "fraction_min_over_crank_revolution": shares.min(axis=0),
            "fraction_max_over_crank_revolution": shares.max(axis=0),
            "eccentric_bearing_resultant_N": {f"crank{k}": {f"wheel{j}": ecc0[f"eccentric_bearing_c{k}w{j}"]
                                                             for j in range(2)} for k in range(design.cranks.count)},
        },
        "torque_balance_rel_err": tb0,
        "ratio_closed_form_rel_err": ratio_closed_err,
        "peak_loads_N": peaks,
        "K_Nm_per_arcmin": {b: f["K_Nm_per_arcmin"] for b, f in fits.items()},
        "lost_motion_arcmin": lm,
        "wall_s": wall,
        "stiffness_budget": budget_figures(budget, fits, fits_el, m_el.crank_deflections(q_el)),
    }
    settings = {"design": design.name, "quick": args.quick, "backend": "warp", "device": "cpu",
                **model.resolution_settings(),
                "te_interval": {"input_angle_rad": float(crank_rev), "output_revolutions": revs, "points": n_pts,
                                "definition": "one crank revolution (1/z_g output revolution)"},
                "order_markers": order_markers(model),
                "te_resolution": {**res, "reference": "design.resolution_reference(): 2x profile samples and "
                                                      "involute slices, analytic profile search"},
                "ratio_closed_form": closed_form, "ratio_closed_form_rel_err": ratio_closed_err,
                "torque_balance_over_te_sequence": {"max_abs": float(np.max(np.abs(balance))),
                                                     "mean_signed": float(np.mean(balance))},
                "stiffness_fits": fits, "stiffness_levels": len(st["torque_Nm"]),
                "regularization_max_N": {"te": qs["regularization_max"], "stiffness": st["regularization_max"]},
                "solver_stats": {"te": qs["stats"], "stiffness": st["stats"]},
                "ms_per_quasistatic_point": 1e3 * qs["wall_s"] / n_pts,
                "eccentric_bearing_names": names, "free_play_study": fp,
                "guide_force_max_before_release": st["continuation"].guide_force_max}
    _plots(model, q_rated, qs, met, angles, shares, st, args.out, revs)
    _budget_plot(results["stiffness_budget"], st, st_el, args.out)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


def elastic_cranks(design, tilt=False):
    """The design with its crankshafts as beams on their tapered rows (the geometry declared in
    ``[cranks.shaft]``); ``tilt``: also tilting on their pairs (condensed, linear)."""
    return design.replace(cranks={"shaft": {"model": "simply_supported", "tilt": tilt}})


def budget_figures(budget, fits_rigid, fits_elastic, deflections):
    """results.json ``stiffness_budget``: per crank variant, family/path -> share of the output
    compliance (energy view; sums to one), the switch-to-rigid shares and their difference from
    the energy shares, the tangent stiffness; the branch fits of both; the largest crank deflection."""
    out = {}
    for key, b in budget.items():
        out[key] = {"shares": b["shares"], "rigid_switch_shares": b["rigid_shares"],
                    "rigid_switch_minus_energy": {k: v - b["shares"][k] for k, v in b["rigid_shares"].items()},
                    "sensitivity_shares": b["sensitivity_shares"], "K_tangent_Nm_per_arcmin": b["K_t_Nm_per_arcmin"]}
    out["K_Nm_per_arcmin"] = {"rigid_cranks": {br: f["K_Nm_per_arcmin"] for br, f in fits_rigid.items()},
                              "elastic_cranks": {br: f["K_Nm_per_arcmin"] for br, f in fits_elastic.items()}}
    out["crank_deflection_max_um"] = float(1e6 * np.abs(deflections).max())
    out["residual"] = budget["elastic_cranks"]["residual"]
    out["note"] = ("energy and switch views agree for paths in series (cranks, crank_bearings, involute_stage); "
                   "the needle rows' switch also stiffens the crank beams they close with (their approach "
                   "Jacobian follows the condensed deflection), so with elastic cranks it is about the needle "
                   "plus the crank share; the pins' switch also removes the wheels' relaxation on the needles")
    return out


def _budget_plot(b, st, st_el, out):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    keys = [k for k in b["elastic_cranks"]["shares"] if k != "geometric_and_regularization"]
    x = np.arange(len(keys))
    for off, var in ((-0.27, "rigid_cranks"), (0.0, "elastic_cranks"), (0.27, "elastic_cranks_with_tilt")):
        ax[0].bar(x + off, [b[var]["shares"].get(k, 0.0) for k in keys], width=0.27,
                  label=f"{var.replace('_', ' ')}: K_t = {b[var]['K_tangent_Nm_per_arcmin']:.0f} N m/arcmin")
    ax[0].set_xticks(x, keys, rotation=30, ha="right", fontsize=8)
    ax[0].set(ylabel="share of output compliance", title="stiffness budget at rated torque")
    ax[0].legend(fontsize=7, loc="upper left")
    ax[1].plot(st["angle_arcmin"], st["torque_Nm"], ".-", lw=0.8, label="rigid cranks")
    ax[1].plot(st_el["angle_arcmin"], st_el["torque_Nm"], ".-", lw=0.8, label="elastic cranks")
    ax[1].set(xlabel="output rotation [arcmin]", ylabel="output torque [N m]", title="torque sequence")
    ax[1].legend(fontsize=8)
    casekit.save_figure(fig, out, "stiffness_budget")


def _plots(model, q, qs, met, angles, shares, st, out, revs):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 7))
    model.draw_section(ax, q)
    ax.set_title(f"{model.design.name}: contact forces at {model.design.rated_torque:g} N m (input angle 0)")
    casekit.save_figure(fig, out, "section_contacts")

    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    out_deg = np.rad2deg(qs["theta_in"] / abs(model.ratio))
    ax[0].plot(out_deg, (qs["te"] - np.mean(qs["te"])) * ARCSEC_PER_RAD, lw=0.8)
    ax[0].set(xlabel="output angle [deg]", ylabel="TE - mean [arcsec]", title="quasi-static TE at rated load")
    o, a = met["orders"], met["amplitudes"] * ARCSEC_PER_RAD
    ax[1].semilogy(o[1:], np.maximum(a[1:], 1e-8), lw=0.8)
    ax[1].set(xlabel="output-shaft order", ylabel="amplitude [arcsec]", title=f"order spectrum ({revs:.3g} output rev)")
    casekit.save_figure(fig, out, "transmission_error")

    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    crank_deg = np.rad2deg(angles * abs(model.graph.crank_rate))
    for k in range(shares.shape[1]):
        ax[0].plot(crank_deg, shares[:, k], lw=0.9, label=f"crank {k}")
    ax[0].axhline(1 / shares.shape[1], color="k", lw=0.5)
    ax[0].set(xlabel="crank angle [deg]", ylabel="share of the crank torque on the carrier", title="crank load shares")
    ax[0].legend(fontsize=8)
    ax[1].bar(np.arange(shares.shape[1]), shares.mean(axis=0))
    ax[1].set(xlabel="crank", ylabel="mean share over a crank revolution", ylim=(0, 0.5))
    casekit.save_figure(fig, out, "crank_shares")

    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.plot(st["angle_arcmin"], st["torque_Nm"], ".-", lw=0.8)
    ax.set(xlabel="output rotation [arcmin]", ylabel="output torque [N m]", title="torsional stiffness (continuation)")
    casekit.save_figure(fig, out, "stiffness")


if __name__ == "__main__":
    main()
