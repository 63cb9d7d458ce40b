"""Audit of the RV E efficiency shortfall (issue 30, Deliver 2): every rolling set's relative speed against the
closed form of the RV kinematics, its d_m, Palmgren's f0 row and the viscosity, and a second, independent bearing
friction model (SKF's 2004 model, rvtool.bearings.skf_friction) beside the friction set's Palmgren, for rv40e and
rv80e at T_R over the catalogue's speed range.

The principal figures stay the pre-committed friction set's (rvtool/designs/friction_set.toml, Palmgren on every
rolling set; cases/rv/efficiency_rv.py). The SKF model replaces the rolling sets' losses only; every other part
(pins, teeth, seal, the churning share, which is defined on the bearings' Palmgren M0) is the same in both columns,
so the difference is the bearings' model-form spread. Nothing here is tuned to the catalogue: SKF's constants are
the catalogue's (status not_reread, rvtool/bearings/skf_friction.py), the loads and speeds the model's.

Reported per design:
- kinematics: each mounting's relative ring speed in the model against the closed form from the tooth numbers
  (rvtool.analysis.losses.closed_form_relative_speeds) at 60 r/min output;
- audit rows at T_R, 60 r/min, input angle 0: per mounting the type, rows, d_m, relative speed, P1, Palmgren's f0
  (summed over rows), M0, M1 and loss, and SKF's phi_ish, phi_rs (first row), M_rr, M_sl and loss;
- by speed: the efficiency with each bearing model, the catalogue's value, the losses by part, and the efficiency
  at the two ends of the churning share's assumed range [0, 1] (0 is the end SKF's statement on grease drag
  supports; the central 0.5 has no source);
- the catalogue's loss budget at each speed: the loss its efficiency implies, P_out (1/eta - 1), against the
  model's, and the excess;
- the no-load running torque with each model (input 1500 r/min);
- the SKF reference's uncertain constants at their other values (the needle set's R1 over the caged cylindrical
  series, the tapered rows' mu_EHL at 0.002): the bearing loss at the audit state and the efficiency at the top
  speed with that change;
- Palmgren's P1 by bearing type (rvtool.bearings.palmgren_load, the friction set's rolling.palmgren_load =
  "typed": ball rows max(0.9 F_a cot(alpha) - 0.1 F_r, F_r), tapered rows max(2 Y F_a, F_r), F_a the rows' declared
  preload) against the radial resultant alone (the form before the correction, "radial"): per rolling set at the
  audit state the two P1 and the loss the typed form adds; by speed the Palmgren column's efficiency with the
  radial form; the no-load running torque with it.

passed (stated criteria): every model relative speed equals its closed form (1e-9), SKF's factors in (0, 1], the
Palmgren column's bearing losses equal the sum of its audit rows (1e-12), the typed P1 of every rolling set at least
its radial resultant, every efficiency in (0, 1), no NaN.
"""
import math
import time
from dataclasses import replace

import numpy as np

import rvtool
from rvtool import casekit, designs
from rvtool.analysis import losses as L
from rvtool.protocols.efficiency import kinematic_velocity

AUDIT_SPEED_RPM = 60.0
DESIGNS = ("rv40e", "rv80e")
MODELS = ("palmgren", "skf")


def _audit_rows(m, d, fs):
    """Per-mounting rows at T_R, AUDIT_SPEED_RPM output, input angle 0, and the kinematics check."""
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    from rvtool.solver.static import StaticSolver
    q = StaticSolver(m).solve(0.0)
    cf = L.closed_form_relative_speeds(d, AUDIT_SPEED_RPM)
    v = kinematic_velocity(m, 0.0, cf["input_rpm"] * 2.0 * math.pi / 60.0)
    rows, kin = [], []
    for r in L.rolling_audit(m, d, fs, q, v):
        first = r["skf_rows"][0]
        rows.append({"mounting": r["mounting"], "element": r["element"], "bearing_type": r["bearing_type"],
                     "rows": r["rows"], "d_m_mm": 1e3 * r["pitch_diameter_m"], "n_rel_rpm": r["n_rel_rpm"],
                     "P1_N": r["P1_N"], "palmgren_f0": r["palmgren_f0"], "nu_n_mm2_s_rpm":
                     r["viscosity_m2_s"] * 1e6 * r["n_rel_rpm"], "palmgren_M0_Nm": r["palmgren_M0_Nm"],
                     "palmgren_M1_Nm": r["palmgren_M1_Nm"], "palmgren_loss_W": r["palmgren_loss_W"],
                     "skf_phi_ish": first["phi_ish"], "skf_phi_rs": first["phi_rs"],
                     "skf_M_rr_Nm": sum(x["M_rr"] for x in r["skf_rows"]),
                     "skf_M_rr_unreduced_Nm": sum(x["M_rr_full"] for x in r["skf_rows"]),
                     "skf_M_sl_Nm": sum(x["M_sl"] for x in r["skf_rows"]), "skf_loss_W": r["skf_loss_W"],
                     "skf_sliding_W": sum(x["M_sl"] for x in r["skf_rows"]) * r["omega_rel_rad_s"],
                     "skf_constants": first["constants"]})
        c = cf[r["element"]]
        kin.append({"mounting": r["mounting"], "n_model_rpm": r["n_rel_rpm"], "n_closed_form_rpm": c,
                    "rel_err": abs(r["n_rel_rpm"] - c) / c})
    # Palmgren's P1 by type against the radial resultant, per rolling set (sums over its mountings)
    correction = {}
    for r in L.rolling_audit(m, d, fs, q, v, skf=False):
        c = correction.setdefault(r["element"], {"P1_radial_N": 0.0, "P1_typed_N": 0.0, "loss_added_W": 0.0})
        typed = sum(x["P1_N"] for x in r["P1_rows"])
        c["P1_radial_N"] += r["P1_radial_N"]
        c["P1_typed_N"] += typed
        c["loss_added_W"] += r["palmgren_f1"] * r["pitch_diameter_m"] * (typed - r["P1_radial_N"]) * r["omega_rel_rad_s"]
    skf_sens = {}
    base = sum(r["skf_loss_W"] for r in rows)
    for key, consts in _skf_variants().items():
        tot = sum(r["skf_loss_W"] for r in L.rolling_audit(m, d, fs, q, v, skf_constants=consts))
        skf_sens[key] = {"bearing_loss_W": tot, "delta_W": tot - base}
    sums = {e: sum(r["palmgren_loss_W"] for r in rows if r["element"] == e) for e in L.ROLLING_ELEMENTS}
    pl = L.part_losses(m, d, fs, q, v)
    consistency = max(abs(pl[e] - sums[e]) / pl[e] for e in L.ROLLING_ELEMENTS)
    return rows, kin, cf, correction, consistency, skf_sens


def _skf_variants():
    """The SKF reference's `assumed` or uncertain constants at their other values: the needle set's R1 at
    either end of the caged cylindrical-roller series (0.96e-6, 1.48e-6) and the tapered rows' mu_EHL at
    0.002 (the value a public implementation of the 2018 catalogue uses)."""
    from rvtool.bearings.skf_friction import CONSTANTS as C
    return {"needle_R1_low": {"needle_roller": replace(C["needle_roller"], R1=0.96e-6)},
            "needle_R1_high": {"needle_roller": replace(C["needle_roller"], R1=1.48e-6)},
            "tapered_mu_ehl_0.002": {"tapered_roller_302": replace(C["tapered_roller_302"], mu_ehl=0.002)}}


def run_design(name, loaded, cat, speeds, n_ang):
    d, note = L.loss_design(rvtool.load_design(designs.path(name)))
    m = rvtool.build(d)
    fs = loaded.central
    rows, kin, cf, p1_correction, consistency, skf_sens = _audit_rows(m, d, fs)
    angles = L.mesh_angles(m, n_ang)
    maps = {mod: L.efficiency_map(m, d, fs, output_speeds_rpm=speeds, input_angles=angles, bearing_model=mod)
            for mod in MODELS}
    fs_radial = replace(fs, palmgren_load="radial")
    radial_map = L.efficiency_map(m, d, fs_radial, output_speeds_rpm=speeds, input_angles=angles)
    ends = {(mod, end): L.efficiency_map(m, d, loaded.at("churning_fraction", end), output_speeds_rpm=speeds,
                                         input_angles=angles, bearing_model=mod)
            for mod in MODELS for end in ("low", "high")}
    curve = cat.curves[name]
    by_speed = []
    for i, n in enumerate(speeds):
        p = {mod: maps[mod]["points"][i] for mod in MODELS}
        row = {"output_speed_rpm": n, "P_out_W": p["palmgren"]["P_out_W"],
               "eta_palmgren_radial_pct": 100 * radial_map["points"][i]["efficiency"]}
        for mod in MODELS:
            row[f"eta_{mod}_pct"] = 100 * p[mod]["efficiency"]
            row[f"loss_{mod}_W"] = p[mod]["loss_by_part_W"]
            row[f"total_loss_{mod}_W"] = p[mod]["P_loss_W"]
            row[f"eta_{mod}_churning0_pct"] = 100 * ends[(mod, "low")]["points"][i]["efficiency"]
            row[f"eta_{mod}_churning1_pct"] = 100 * ends[(mod, "high")]["points"][i]["efficiency"]
        if curve.output_speed_rpm[0] <= n <= curve.output_speed_rpm[-1]:
            c = L.catalogue_efficiency(curve, n)
            implied = row["P_out_W"] * (1.0 / c - 1.0)
            row.update({"catalogue_pct": 100 * c,
                        "difference_palmgren_pts": row["eta_palmgren_pct"] - 100 * c,
                        "difference_skf_pts": row["eta_skf_pct"] - 100 * c,
                        "catalogue_implied_loss_W": implied,
                        "excess_loss_palmgren_W": row["total_loss_palmgren_W"] - implied,
                        "excess_loss_skf_W": row["total_loss_skf_W"] - implied,
                        "churning_W": row["loss_palmgren_W"]["churning"]})
        by_speed.append(row)
    top = by_speed[-1]
    for v in skf_sens.values():
        # the variant's change at the audit state applied to the angle-averaged loss at the top speed (the
        # bearing loads move little over the mesh period)
        v["eta_skf_top_speed_pct"] = 100 * top["P_out_W"] / (top["P_out_W"] + top["total_loss_skf_W"] + v["delta_W"])
    fig = cat.no_load[name]
    no_load = {mod: L.no_load_torque(m, d, fs, fig.input_speed_rpm, input_angles=angles, bearing_model=mod)
               for mod in MODELS}
    no_load_radial = L.no_load_torque(m, d, fs_radial, fig.input_speed_rpm, input_angles=angles)
    return {"variant": note, "ratio": abs(float(m.ratio)), "viscosity_at_case_temperature_m2_s": fs.viscosity,
            "kinematics_60rpm": kin, "closed_form_60rpm": cf, "audit_rows_60rpm": rows, "by_speed": by_speed,
            "palmgren_load_correction_60rpm": p1_correction, "palmgren_rows_consistency_rel": consistency,
            "skf_sensitivity_60rpm": skf_sens,
            "no_load": {"input_speed_rpm": fig.input_speed_rpm, "catalogue_Nm": fig.torque,
                        "palmgren_Nm": no_load["palmgren"]["total_Nm"], "skf_Nm": no_load["skf"]["total_Nm"],
                        "palmgren_radial_Nm": no_load_radial["total_Nm"],
                        "palmgren_radial_by_part_Nm": no_load_radial["by_part_Nm"],
                        "palmgren_by_part_Nm": no_load["palmgren"]["by_part_Nm"],
                        "skf_by_part_Nm": no_load["skf"]["by_part_Nm"]},
            "catalogue_status": curve.status}


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    c = casekit.check
    out = {}
    for name, res in r["designs"].items():
        out[f"{name}_speeds_closed_form"] = c(max(k["rel_err"] for k in res["kinematics_60rpm"]), 1e-9,
                                              why="each rolling set's relative speed against Z_p n_out (needles, "
                                                  "crank rows) and n_out (main pair) from the tooth numbers; a wrong "
                                                  "body pair gives O(1)")
        phis = [x for row in res["audit_rows_60rpm"] for x in (row["skf_phi_ish"], row["skf_phi_rs"])]
        out[f"{name}_skf_factors"] = c(float(min(phis)) if max(phis) <= 1.0 else float("nan"), (1e-6, 1.0), "in",
                                       why="reduction factors of the SKF model lie in (0, 1]")
        out[f"{name}_palmgren_rows_sum"] = c(res["palmgren_rows_consistency_rel"], 1e-12,
                                             why="the audit rows are the loss accounting's own terms")
        corr = res["palmgren_load_correction_60rpm"]
        out[f"{name}_typed_P1_at_least_radial"] = c(min(x["P1_typed_N"] - x["P1_radial_N"] for x in corr.values()),
                                                    0.0, ">=", why="each typed form is max(..., F_r): never below "
                                                                   "the radial resultant")
        effs = [row[f"eta_{mod}_pct"] for row in res["by_speed"] for mod in MODELS]
        out[f"{name}_efficiency_range"] = c(float(min(effs)) if max(effs) < 100 else float("nan"), (0.0, 100.0),
                                            "in", why="losses are nonnegative and finite")
    return out


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    loaded, cat, speeds, n_ang = L.chart_inputs(args.quick)
    results = {"friction_set": "rvtool/designs/friction_set.toml (central values; churning ends from its range)",
               "skf_model": "rvtool/bearings/skf_friction.py (SKF General Catalogue 6000 EN friction model, "
                            "constants not_reread)",
               "catalogue": {"citation": cat.citation(), "case_temperature_K": cat.case_temperature},
               "designs": {name: run_design(name, loaded, cat, speeds, n_ang) for name in DESIGNS}}
    casekit.verdict(results, judge)
    _plot(results, args.out)
    for name, res in results["designs"].items():
        for p in res["by_speed"]:
            print(f"{name} {p['output_speed_rpm']:4g} rpm: Palmgren {p['eta_palmgren_pct']:.1f} %, SKF "
                  f"{p['eta_skf_pct']:.1f} %, catalogue {p.get('catalogue_pct', float('nan')):.1f} %")
    return casekit.write_results(args.out, results, settings={"designs": list(DESIGNS), "quick": args.quick,
                                                              "speeds_rpm": list(speeds), "input_angles": n_ang},
                                 wall_s=time.perf_counter() - t0)


def _plot(r, out):
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    for (name, res), col in zip(r["designs"].items(), ("C0", "C1")):
        rows = res["by_speed"]
        n = [p["output_speed_rpm"] for p in rows]
        axes[0].plot(n, [p["eta_palmgren_pct"] for p in rows], "o-", color=col, label=f"{name} Palmgren (set)")
        axes[0].plot(n, [p["eta_skf_pct"] for p in rows], "^--", color=col, label=f"{name} SKF 2004")
        cat = [(p["output_speed_rpm"], p["catalogue_pct"]) for p in rows if "catalogue_pct" in p]
        axes[0].plot(*zip(*cat), "s:", color=col, mfc="none", label=f"{name} catalogue ({res['catalogue_status']})")
        last = rows[-1]
        parts = list(last["loss_palmgren_W"])
        x = np.arange(len(parts))
        off = -0.3 if col == "C0" else 0.1
        axes[1].bar(x + off, [last["loss_palmgren_W"][k] for k in parts], 0.2, color=col, label=f"{name} Palmgren")
        axes[1].bar(x + off + 0.2, [last["loss_skf_W"][k] for k in parts], 0.2, color=col, alpha=0.45,
                    label=f"{name} SKF")
        axes[1].set_xticks(x, parts, rotation=30, ha="right")
    axes[0].set(xlabel="output speed [r/min]", ylabel="efficiency at T_R [%]", title="bearing model-form spread")
    axes[1].set(ylabel="loss [W]", title=f"losses by part at {r['designs']['rv40e']['by_speed'][-1]['output_speed_rpm']:g} r/min")
    for a in axes:
        a.legend(fontsize=7)
    fig.tight_layout()
    casekit.save_figure(fig, out, "efficiency_audit")


if __name__ == "__main__":
    main()
