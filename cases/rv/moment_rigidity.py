"""Moment rigidity and axial stiffness of the output flange of rv40e and rv80e on their main-bearing rows (issue 32).

Protocol (rvtool.protocols.moment_rigidity): the design with a spatial carrier
(bodies.carrier_coordinates = "spatial"), input held, no output torque; a moment on the flange at the main
bearing's centre at 0, 25, 50, 75, 100 % of the reference moment (the catalogue file's allowable moment), a
static equilibrium per level; the flange tilt, each row's axial force and the working contact angles; the
moment rigidity as the secant between 0 and 100 % (a STATED CONVENTION: the catalogue's own measuring points
were not read) [N m/arcmin]; the axial stiffness between 0 and 2 kN. rv80e's ported housing is replaced by the
rigid one for this test (its main-bearing seats are not ported in either model, so the figure is the same:
tests/test_tilt.py builds the spatial carrier with the ported housing too). The same test on the main bearing alone (rigid
housing) gives the uncertainty band over the main bearing's `assumed` ranges (rv80e_assumed.toml: one-at-a-time
ends and Latin-hypercube samples; 16, --quick 4); rv40e has no assumed file (chosen geometry): no band.
The elastic carrier (issue 32, the carrier's member in the moment path): the same test with
``[carrier] body = "ported"`` (the design's carrier structure; --quick on a 10 mm mesh), whose output face and
main-bearing seats are closed by the carrier's out-of-plane seat compliance from its NGSolve parent; reported
beside the rigid carrier's figure, with the series check 1/K = 1/K_rigid + C_gamma (C_gamma the mean tilt
compliance of the seats relative to the face).
Catalogue: neither catalogue file prints a moment rigidity (not transcribed: it was not re-read), so every
design reports "no catalogue value"; nothing is compared or tuned.
passed (stated criteria): the reducer model's rigidity equals the bearing-alone figure within 1e-6 (the weak
regularization springs and the Newton tolerance), the tilt grows with the moment, a pure moment leaves no net
axial force (1e-9 of the row forces), the band contains the central value, the elastic carrier's rigidity is
the series sum within 1e-2 (the bearing's change over the moment range and the seats' small z--gamma
couplings), no NaN.
"""
import time

import numpy as np

import rvtool
from rvtool import casekit, designs
from rvtool.designs.catalogue import load_assumed, load_catalogue
from rvtool.protocols.moment_rigidity import (MomentRigidityTest, main_bearing_band, moment_rigidity,
                                              pair_moment_rigidity, spatial_design)

AXIAL_FORCE = 2000.0
"""Axial-stiffness load [N] (a round figure inside the rows' preload range)."""

QUICK_CARRIER_MESH = 0.010
"""Nominal tetrahedron size [m] of the ported carrier under --quick (tests/test_carrier_body.py's coarse mesh)."""


def judge(r):
    out = {}
    for name, d in r["designs"].items():
        out[f"{name}_model_equals_pair"] = casekit.check(d["model_vs_pair_rel_diff"], 1e-6, "<=",
                                                         "regularization springs (1e-6 of the tilt stiffness) and "
                                                         "Newton tolerance")
        out[f"{name}_tilt_grows"] = casekit.check(min(np.diff(d["model"]["tilt_arcmin"])), 0.0, ">",
                                                  "a preloaded pair stiffens monotonically")
        rows = np.asarray(d["model"]["row_axial_forces_N"])
        out[f"{name}_pure_moment_no_axial"] = casekit.check(
            float(np.max(np.abs(rows.sum(axis=1))) / np.max(np.abs(rows))), 1e-9, "<=",
            "the flange is free axially: the rows' axial forces balance")
        e = d["elastic_carrier"]
        out[f"{name}_elastic_carrier_in_series"] = casekit.check(
            e["series_rel_diff"], 1e-2, "<=", "1/K = 1/K_rigid + C_gamma: the bearing's change over the moment range "
            "and the seats' z--gamma couplings (measured ~1e-3)")
        if d["band"] is not None:
            out[f"{name}_band_contains_central"] = casekit.check(d["model"]["moment_rigidity_Nm_per_arcmin"],
                                                                 tuple(d["band"]["band"]), "in",
                                                                 "central inputs lie inside the ranges")
    return out


def main(argv=None):
    args = casekit.parse_args(argv, __doc__.splitlines()[0])
    t0 = time.perf_counter()
    per = {}
    for name in ("rv40e", "rv80e"):
        d = rvtool.load_design(name)
        if d.housing.model == "ports":
            d = rvtool.replace_design(d, housing={"model": "rigid"})
        cat = load_catalogue(designs.catalogue_of(name))
        m_ref = cat.figure("allowable_moment").value_si
        test = MomentRigidityTest(reference_moment=m_ref, axial_force=AXIAL_FORCE)
        model = rvtool.build(spatial_design(d))
        t1 = time.perf_counter()
        r_model = moment_rigidity(model, test)
        wall_model = time.perf_counter() - t1
        r_pair = pair_moment_rigidity(d.main_bearing, test)
        assumed = designs.assumed_of(name)
        band = None
        if assumed:
            band = main_bearing_band(d.main_bearing, load_assumed(assumed), test, samples=4 if args.quick else 16)
        figs = cat.figures_of("moment_rigidity")
        structure = {"mesh_size": QUICK_CARRIER_MESH} if args.quick else {}
        ported = rvtool.build(spatial_design(rvtool.replace_design(d, carrier={"body": "ported",
                                                                                "structure": structure})))
        r_ported = moment_rigidity(ported, test)
        C = ported.elements["carrier_seats"].evaluator.compliance
        c_gamma = 0.5 * (C[1, 1] + C[2, 2])
        series = 1.0 / r_model.rigidity + c_gamma
        per[name] = {
            "reference_moment_Nm": m_ref, "reference_moment_source": cat.citation(cat.figure("allowable_moment")),
            "model": r_model.to_dict(), "pair_alone": r_pair.to_dict(), "wall_model_s": wall_model,
            "model_vs_pair_rel_diff": abs(r_model.rigidity / r_pair.rigidity - 1.0),
            "axial_stiffness_model_vs_pair_rel_diff": abs(r_model.axial_stiffness / r_pair.axial_stiffness - 1.0),
            "band": band,
            "elastic_carrier": {"model": r_ported.to_dict(), "mesh_size_m": ported.design.carrier.structure.mesh_size,
                                "seat_tilt_compliance_rad_per_Nm": c_gamma,
                                "seat_axial_compliance_m_per_N": float(C[0, 0]),
                                "series_rel_diff": abs(1.0 / r_ported.rigidity / series - 1.0),
                                "rigid_over_ported": r_model.rigidity / r_ported.rigidity},
            "catalogue": ([{"value": f.value, "unit": f.unit, "kind": f.kind, "source": cat.citation(f)} for f in figs]
                          or "no catalogue value"),
            "housing_note": ("rigid housing for this test (the design's ported housing carries the ring pins only; "
                             "the main-bearing seats are grounded in both)") if name == "rv80e" else None,
        }
        print(f"{name}: elastic carrier {r_ported.rigidity_arcmin:.1f} N m/arcmin; "
              f"moment rigidity {r_model.rigidity_arcmin:.1f} N m/arcmin ({r_model.convention}); "
              f"axial stiffness {r_model.axial_stiffness:.4g} N/m; band "
              f"{None if band is None else [round(v, 1) for v in band['band']]}; catalogue: "
              f"{per[name]['catalogue'] if isinstance(per[name]['catalogue'], str) else 'see results'}")
    results = {"designs": per, "wall_s": time.perf_counter() - t0}
    casekit.verdict(results, judge)
    _plot(args.out, per)
    return casekit.write_results(args.out, results, settings={"quick": args.quick, "axial_force_N": AXIAL_FORCE,
                                                               "levels": list(MomentRigidityTest(reference_moment=1.0).levels)},
                                 wall_s=results["wall_s"])


def _plot(out, per):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 3.5))
    for name, d in per.items():
        ax.plot(d["model"]["tilt_arcmin"], d["model"]["moments_Nm"], "o-", label=name)
    ax.set(xlabel="flange tilt [arcmin]", ylabel="moment on the flange [N m]", title="moment rigidity (spatial carrier)")
    ax.grid(alpha=0.3)
    ax.legend()
    casekit.save_figure(fig, out, "moment_tilt")


if __name__ == "__main__":
    main()
