"""Compliance budget of the RV designs with every existing compliance switch on (issue 28, Deliver 3).

Designs: rvtool/designs/rv40e.toml (the class design; its file has every switch off) and rv80e.toml (the
validation design; its file has every physical switch on). For each design five variants are built from the file
by switching the three compliance switches of the RV model:

* ``all_rigid``: rigid crankshafts (``cranks.shaft.model = "rigid"``, no tilt), the ring pins on ground
  (``housing.model = "rigid"``) and the rigid carrier (``carrier.body = "rigid"``);
* ``elastic_cranks``: the crankshafts as Timoshenko beams on their tapered rows (``"simply_supported"``; rv80e also
  with the tilt of the tapered pair, as in its file);
* ``ported_housing``: the ring pins on the elastic steel annulus of ``[housing.structure]`` (one planar port per pin,
  Craig--Bampton with exact static port compliance);
* ``ported_carrier``: the carrier (output flange, pillars, end plate) as the reduced structure of
  ``[carrier.structure]`` (``carrier.body = "ported"``; the crank seats move relative to the output face);
* ``all_on``: all three.

The third switch the issue names, elastic ring pins (``pins.support``), is not implemented for the RV topology (the
builder rejects it); it is reported as such, not measured.

Per variant: the static state at rated torque T_R (input angle 0) and there the tangent output stiffness K_t [N m/
arcmin] with the stiffness budget of rvtool.protocols.budget.stiffness_budget (each member's strain-energy share of
the output compliance, summing to one with the residual entry ``geometric_and_regularization``). K_t is the tangent at
T_R, not the catalogue's b/a rigidity (that is ``rvtool validate``'s figure, helper "validate"). Per member switched
one at a time: the compliance it adds, dC_i = C_i - C_rigid, and its share dC_i / C_all_on.

Criteria (``passed``): every K_t and share finite; members in series add their compliances:
|C_all_on - (C_all_rigid + sum_i dC_i)| / C_all_on <= ADDITIVITY_TOL; the residual share |geometric_and_
regularization| <= RESIDUAL_TOL in every variant; each switched member's energy share in ``all_on`` agrees with its
switch-on share dC_i / C_all_on within SHARE_TOL.

--quick: the housing and the carrier meshed at 8 mm instead of the files' sizes (a smoke run: K_t moves by the mesh's error; the full
run's figures are the reported ones).
"""
import math
import time

import numpy as np

import rvtool
from rvtool import casekit, designs
from rvtool.protocols.budget import stiffness_budget
from rvtool.solver.static import StaticSolver

DESIGNS = ("rv40e", "rv80e")
QUICK_MESH_SIZE = 0.008
"""--quick: housing and carrier tetrahedra of 8 mm (the files give 4-6 mm)."""
ADDITIVITY_TOL = 0.02
"""Members in series add compliances exactly when the load path does not redistribute; an elastic member moves the
contact states of the others (load sharing among cranks and pins), a second-order effect: 2 % of C_all_on."""
RESIDUAL_TOL = 0.01
"""The residual entry is the geometric stiffness of loaded contacts and the regularization springs: 1 % of C."""
SHARE_TOL = 0.05
"""Energy share (infinitesimal view) vs switch-on share (finite view) of one member: they differ by the load
redistribution the switch causes (rvtool.protocols.budget docstring): 0.05 absolute."""
SWITCHES = ("elastic_cranks", "ported_housing", "ported_carrier")
MEMBER = {"elastic_cranks": "cranks", "ported_housing": "housing_ports", "ported_carrier": "carrier"}


def variants(name, quick):
    """The four switch settings of shipped design ``name`` (module docstring)."""
    d = rvtool.load_design(designs.path(name))
    sh = d.source["cranks"].get("shaft", {})
    tilt = bool(sh.get("tilt", False))
    cr_on = {"shaft": {"model": "simply_supported", "tilt": tilt}}
    cr_off = {"shaft": {"model": "rigid", "tilt": False}}
    h_on = {"model": "ports", **({"structure": {"mesh_size": QUICK_MESH_SIZE}} if quick else {})}
    h_off = {"model": "rigid"}
    c_on = {"body": "ported", **({"structure": {"mesh_size": QUICK_MESH_SIZE}} if quick else {})}
    c_off = {"body": "rigid"}
    return {"all_rigid": d.replace(cranks=cr_off, housing=h_off, carrier=c_off),
            "elastic_cranks": d.replace(cranks=cr_on, housing=h_off, carrier=c_off),
            "ported_housing": d.replace(cranks=cr_off, housing=h_on, carrier=c_off),
            "ported_carrier": d.replace(cranks=cr_off, housing=h_off, carrier=c_on),
            "all_on": d.replace(cranks=cr_on, housing=h_on, carrier=c_on)}


def rated_budget(design):
    """K_t [N m/arcmin], C [arcmin/(N m)] and the budget at T_R, input angle 0."""
    t0 = time.perf_counter()
    model = rvtool.build(design)
    model.set_output_torque(-np.sign(model.ratio) * design.rated_torque)
    q = StaticSolver(model).solve(0.0)
    b = stiffness_budget(model, q)
    K = float(b["K_t_Nm_per_arcmin"])
    return {"K_t_Nm_per_arcmin": K, "C_arcmin_per_Nm": 1.0 / K, "energy_shares": b["shares"],
            "rigid_switch_shares": b["rigid_shares"], "wall_s": time.perf_counter() - t0}


def budget_of(name, quick):
    out = {v: rated_budget(d) for v, d in variants(name, quick).items()}
    C0, C = out["all_rigid"]["C_arcmin_per_Nm"], out["all_on"]["C_arcmin_per_Nm"]
    added = {s: out[s]["C_arcmin_per_Nm"] - C0 for s in SWITCHES}
    additivity = abs(C - (C0 + sum(added.values()))) / C
    switch_share = {MEMBER[s]: added[s] / C for s in SWITCHES}
    energy = out["all_on"]["energy_shares"]
    share_gap = {m: abs(energy.get(m, 0.0) - v) for m, v in switch_share.items()}
    residual = max(abs(v["energy_shares"].get("geometric_and_regularization", 0.0)) for v in out.values())
    finite = all(math.isfinite(v["K_t_Nm_per_arcmin"]) and all(math.isfinite(x) for x in v["energy_shares"].values())
                 for v in out.values())
    checks = {"finite": finite, "additivity_rel_err": additivity, "additivity_ok": additivity <= ADDITIVITY_TOL,
              "max_residual_share": residual, "residual_ok": residual <= RESIDUAL_TOL,
              "energy_vs_switch_share_gap": share_gap,
              "share_ok": all(g <= SHARE_TOL for g in share_gap.values())}
    return {"variants": out, "added_compliance_arcmin_per_Nm": added, "switch_on_shares_of_all_on": switch_share,
            "member_energy_shares_all_on": energy, "K_t_all_on_Nm_per_arcmin": out["all_on"]["K_t_Nm_per_arcmin"],
            "K_t_all_rigid_Nm_per_arcmin": out["all_rigid"]["K_t_Nm_per_arcmin"], "checks": checks,
            "passed": bool(finite and checks["additivity_ok"] and checks["residual_ok"] and checks["share_ok"])}


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    per_design = {name: budget_of(name, args.quick) for name in DESIGNS}
    results = {"designs": per_design,
               "elastic_pins": "not measured: elastic ring pins (pins.support) are not implemented for the RV topology "
                               "(rvtool.assembly.rv.builder rejects them)",
               "stiffness_definition": "tangent output stiffness at rated torque, input angle 0 (not the catalogue's "
                                       "b/a rigidity)",
               "passed": all(v["passed"] for v in per_design.values())}
    settings = {"designs": list(DESIGNS), "quick": args.quick, "housing_mesh_size_quick_m": QUICK_MESH_SIZE,
                "criteria": {"additivity_tol": ADDITIVITY_TOL, "residual_tol": RESIDUAL_TOL, "share_tol": SHARE_TOL}}
    _plot(per_design, args.out)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


def _plot(per_design, out):
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(per_design), figsize=(7 * len(per_design), 3.8))
    for ax, (name, b) in zip(np.atleast_1d(axes), per_design.items()):
        sh = {k: v for k, v in b["member_energy_shares_all_on"].items() if k != "geometric_and_regularization"}
        ax.bar(range(len(sh)), list(sh.values()))
        ax.set_xticks(range(len(sh)), list(sh), rotation=30, ha="right", fontsize=8)
        ax.set(ylabel="share of output compliance",
               title=f"{name}: all switches on, K_t = {b['K_t_all_on_Nm_per_arcmin']:.0f} N m/arcmin at T_R")
    casekit.save_figure(fig, out, "rv_compliance_budget")


if __name__ == "__main__":
    main()
