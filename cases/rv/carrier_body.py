"""The carrier as a reduced structure (issue 30, ``[carrier] body = "ported"``): reduction error and three-mesh
convergence of the carrier's share of the torque-path compliance at T_R, rv40e and rv80e.

Per design and per mesh (three nominal tetrahedron sizes, each 1.5 times the next):

* the reduced structure's static port compliance against the parent FE's P K^-1 P^T (largest entry error
  relative to the largest entry; target 1e-6, issue 30);
* the design with only the carrier ported (cranks, housing rigid, as the design file's other keys) at T_R,
  input angle 0: the tangent output stiffness K_t [N m/arcmin], the carrier's energy share of the output
  compliance (``rvtool.protocols.budget.stiffness_budget``, path ``carrier``) and its switch-on share
  1 - K_t(ported) / K_t(rigid).

* the carrier's tilt stiffness between the output face and the main-bearing seats (their area-weighted rigid
  fit, ``info["main_seats_tilt_stiffness_Nm_per_rad"]`` of ``rvtool.assembly.carrier.carrier_ports``) [N m/
  arcmin]: the carrier's member of the moment path, which the spatial model (issue 32) does not take yet. Beside
  it, once per design, the moment rigidity of the spatial model with the rigid carrier (``rvtool.protocols.
  moment_rigidity``, reference moment T_R, read between its default points) and the carrier's share of the
  moment compliance if the two act in series (an estimate: the series sum, not a coupled solve).

Convergence: first-order tetrahedra are too stiff and converge from below in compliance, so the share rises as
the mesh is refined; with three meshes h1 > h2 > h3 the changes d12 = s2 - s1 and d23 = s3 - s2 give the
observed order p = log(d12 / d23) / log(1.5) and the Richardson estimate s3 + d23 / (1.5^p - 1) of the share at
h -> 0 (reported, with the estimated error of the finest mesh). Criteria (``passed``): the reduction error below
1e-6 on every mesh; the share's changes shrink (|d23| < |d12|: the meshes are in the asymptotic range); the
energy and switch-on shares agree within 0.05 (the compliance_budget case's SHARE_TOL: a member in series).

--quick: meshes of 12, 8 and 5.33 mm (the full run: 6, 4 and 2.67 mm).
"""
import math
import time

import numpy as np

import rvtool
from rvtool import casekit, designs
from rvtool.assembly.carrier import carrier_ports
from rvtool.protocols.budget import stiffness_budget
from rvtool.protocols.moment_rigidity import MomentRigidityTest, moment_rigidity, spatial_design
from rvtool.solver.static import StaticSolver
from rvtool.units import RAD_PER_ARCMIN

DESIGNS = ("rv40e", "rv80e")
MESHES = (0.006, 0.004, 0.004 / 1.5)
QUICK_MESHES = (0.012, 0.008, 0.008 / 1.5)
REDUCTION_TOL = 1e-6
"""Issue 30: a reduced structure's static port compliance within 1e-6 relative of its parent FE."""
SHARE_TOL = 0.05
"""Energy vs switch-on share of a member in series (cases/rv/compliance_budget.py)."""


def _at_rated(design):
    model = rvtool.build(design)
    model.set_output_torque(-np.sign(model.ratio) * design.rated_torque)
    q = StaticSolver(model).solve(0.0)
    return stiffness_budget(model, q)


def carrier_study(name, meshes):
    d = rvtool.load_design(designs.path(name))
    base = {"cranks": {"shaft": {"model": "rigid", "tilt": False}}, "housing": {"model": "rigid"}}
    rigid = _at_rated(d.replace(carrier={"body": "rigid"}, **base))
    K0 = float(rigid["K_t_Nm_per_arcmin"])
    rows = []
    for h in meshes:
        t0 = time.perf_counter()
        dp = d.replace(carrier={"body": "ported", "structure": {"mesh_size": h}}, **base)
        red, C_ref, info = carrier_ports(dp)
        err = float(np.abs(red.static_compliance() - C_ref).max() / np.abs(C_ref).max())
        b = _at_rated(dp)
        K = float(b["K_t_Nm_per_arcmin"])
        rows.append({"mesh_size_m": h, "vertices": info["vertices"], "dofs": info["dofs"],
                     "first_clamped_hz": info["first_clamped_hz"], "reduction_rel_err": err,
                     "K_t_Nm_per_arcmin": K, "carrier_energy_share": float(b["shares"]["carrier"]),
                     "carrier_switch_share": 1.0 - K / K0,
                     "seat_compliance_tangential_m_per_N": _tangential(red, dp),
                     "carrier_tilt_stiffness_Nm_per_arcmin": info["main_seats_tilt_stiffness_Nm_per_rad"]
                     * RAD_PER_ARCMIN,
                     "wall_s": time.perf_counter() - t0})
    ratio = meshes[0] / meshes[1]
    conv = _richardson([r["carrier_energy_share"] for r in rows], ratio, "share")
    tilt = _richardson([1.0 / r["carrier_tilt_stiffness_Nm_per_arcmin"] for r in rows], ratio,
                       "tilt_compliance_arcmin_per_Nm")
    K_m = moment_rigidity(rvtool.build(spatial_design(d.replace(carrier={"body": "rigid"}, **base))),
                          MomentRigidityTest(reference_moment=d.rated_torque)).rigidity_arcmin
    K_c = rows[-1]["carrier_tilt_stiffness_Nm_per_arcmin"]
    moment = {"spatial_moment_rigidity_rigid_carrier_Nm_per_arcmin": K_m,
              "carrier_tilt_stiffness_finest_Nm_per_arcmin": K_c, "tilt_convergence": tilt,
              "series_moment_rigidity_Nm_per_arcmin": 1.0 / (1.0 / K_m + 1.0 / K_c),
              "carrier_share_of_moment_compliance": (1.0 / K_c) / (1.0 / K_c + 1.0 / K_m)}
    return {"K_t_rigid_carrier_Nm_per_arcmin": K0, "meshes": rows, "convergence": conv, "moment_path": moment}


def _richardson(s, ratio, name):
    """Changes d12, d23 of a figure over three meshes refined by ``ratio``, its observed order and the Richardson
    estimate at h -> 0 (module docstring), where the changes shrink monotonically."""
    d12, d23 = s[1] - s[0], s[2] - s[1]
    conv = {"d12": d12, "d23": d23}
    if d12 != 0 and d23 != 0 and d12 / d23 > 1:
        p = math.log(d12 / d23) / math.log(ratio)
        extra = d23 / (ratio ** p - 1.0)
        conv.update({"observed_order": p, f"richardson_{name}": s[2] + extra, "finest_mesh_error_estimate": extra})
    return conv


def _tangential(red, design):
    """Mean tangential compliance [m/N] of a crank seat under its own tangential load (carrier frame)."""
    from rvtool.assembly.carrier import carrier_layout
    _, angles, _, _ = carrier_layout(design)
    C = red.static_compliance()
    t = [np.array([-math.sin(b), math.cos(b)]) for b in angles]
    return float(np.mean([t[k] @ C[2 * k:2 * k + 2, 2 * k:2 * k + 2] @ t[k] for k in range(len(angles))]))


def judge(r):
    checks = {}
    for name, v in r["designs"].items():
        rows = v["meshes"]
        checks[f"{name}_reduction"] = casekit.check(max(x["reduction_rel_err"] for x in rows), REDUCTION_TOL, "<=",
                                                    "issue 30: reduced static port compliance vs the parent FE")
        c = v["convergence"]
        checks[f"{name}_converging"] = casekit.check(abs(c["d23"]) / max(abs(c["d12"]), 1e-300), 1.0, "<",
                                                     "three meshes in the asymptotic range: the share's change "
                                                     "shrinks under refinement")
        checks[f"{name}_series"] = casekit.check(
            max(abs(x["carrier_energy_share"] - x["carrier_switch_share"]) for x in rows), SHARE_TOL, "<=",
            "energy vs switch-on share of a member in series (compliance_budget's SHARE_TOL)")
    return checks


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    meshes = QUICK_MESHES if args.quick else MESHES
    results = {"designs": {name: carrier_study(name, meshes) for name in DESIGNS},
               "share_definition": "carrier-only variant (cranks and housing rigid) at T_R, input angle 0: the "
                                   "carrier's energy share of the tangent output compliance"}
    casekit.verdict(results, judge)
    _plot(results, args.out)
    return casekit.write_results(args.out, results, settings={"designs": list(DESIGNS), "meshes_m": list(meshes),
                                                              "quick": args.quick},
                                 wall_s=time.perf_counter() - t0)


def _plot(results, out):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 3.8))
    for name, v in results["designs"].items():
        h = [x["mesh_size_m"] * 1e3 for x in v["meshes"]]
        ax.plot(h, [x["carrier_energy_share"] for x in v["meshes"]], "o-", label=name)
    ax.set(xlabel="nominal tetrahedron size [mm]", ylabel="carrier share of output compliance at T_R",
           title="ported carrier: three-mesh convergence")
    ax.invert_xaxis()
    ax.legend()
    casekit.save_figure(fig, out, "carrier_body_convergence")


if __name__ == "__main__":
    main()
