"""TE and torsional stiffness of rv40e and rv80e under a tilting moment and the torque together, with tilting wheels and cranks (issue 32).

Protocol (rvtool.protocols.moment_rigidity.combined_moment_torque): input held at angle 0, the output torque
stepped 50 % -> 100 % T_R (the stiffness secant between them), then a quasi-static TE sweep over one cycloid
mesh period at T_R; a tilting moment M_x on the output flange at the main bearing's centre held throughout,
at 0 and at 1000 N m (a round figure below the catalogue file's allowable moment, 1666 N m). Three models:
"carrier" (bodies.carrier_coordinates = "spatial": only the flange tilts), "wheels" (also the wheels,
bodies.wheel_coordinates) and "tilting" (also the cranks, bodies.crank_coordinates: the tapered crank pairs on
the 5-DOF roller law); and rv80e (the cited design: elastic crankshafts, its ported housing replaced by the
rigid one as in the moment-rigidity case) with all three tilting, "rv80e_tilting". Reported per level: the wind-up, the stiffness [N m/arcmin], the TE peak-to-peak
[arcsec], the tilts of every spatial body [arcmin] and their axial displacements, the axial force of each
main-bearing row and each tapered crank row; and the moment rigidity of each model (the secant 0 -> 1000 N m).
passed (stated criteria): the "carrier" and "wheels" models at zero moment reproduce the planar model's wind-up
(1e-9 relative) and TE (1e-9 of its peak-to-peak) -- nothing loads their bodies out of plane; after each test
every tilt is back at rounding (1e-12 rad: the loads removed); no NaN.
"""
import time

import numpy as np

import rvtool
from rvtool import casekit
from rvtool.protocols.moment_rigidity import (CombinedLoadTest, MomentRigidityTest, combined_moment_torque,
                                              moment_rigidity)
from rvtool.solver.static import StaticSolver
from rvtool.units import ARCSEC_PER_RAD

MOMENT = 1000.0
"""Tilting moment [N m] on the flange (a round figure below rv40e's allowable moment)."""

MODELS = {"carrier": {"carrier_coordinates": "spatial"},
          "wheels": {"carrier_coordinates": "spatial", "wheel_coordinates": "spatial"},
          "tilting": {"carrier_coordinates": "spatial", "wheel_coordinates": "spatial", "crank_coordinates": "spatial"}}


def judge(r):
    out = {}
    for name in ("carrier", "wheels"):
        c = r["models"][name]["reproduction"]
        out[f"{name}_windup_equals_planar"] = casekit.check(c["windup_rel_diff"], 1e-9, "<=",
                                                           "issue 32: spatial without out-of-plane load = planar")
        out[f"{name}_te_equals_planar"] = casekit.check(c["te_diff_over_pp"], 1e-9, "<=", "as above, on the TE")
    for name, m in r["models"].items():
        out[f"{name}_loads_removed"] = casekit.check(m["max_tilt_after_rad"], 1e-12, "<=",
                                                     "the test removes its moment and torque")
    return out


def planar_reference(design, test):
    """Wind-up at the last torque level and TE of the planar model (the same static points)."""
    m = rvtool.build(design)
    s = StaticSolver(m)
    m.set_output_torque(-np.sign(m.ratio) * test.torques[-1])
    windup = s.solve(0.0)[m.output_index]
    m.set_output_torque(-np.sign(m.ratio) * test.te_torque)
    out = m.body_index(m.output.body)
    te, prev = [], None
    for a in test.te_angles:
        q = s.solve(a, previous_angle=prev)
        prev = a
        te.append(q[m.output_index] - (m.kinematic_state(a).poses[out, 2] - m.reference[out, 2]))
    return windup, np.array(te)


def main(argv=None):
    args = casekit.parse_args(argv, __doc__.splitlines()[0])
    t0 = time.perf_counter()
    d = rvtool.load_design("rv40e")
    T = d.rated_torque
    period = rvtool.build(d).mesh_period
    n = 6 if args.quick else 24
    test = CombinedLoadTest(moment=(0.0, 0.0), torques=(0.5 * T, T), te_torque=T,
                            te_angles=tuple(np.arange(n) * period / n))
    windup_p, te_p = planar_reference(d, test)
    d80 = rvtool.replace_design(rvtool.load_design("rv80e"), housing={"model": "rigid"})
    runs = [(name, d, bodies) for name, bodies in MODELS.items()] + [("rv80e_tilting", d80, MODELS["tilting"])]
    models = {}
    for name, design, bodies in runs:
        if design is not d:
            T = design.rated_torque
            test = CombinedLoadTest(moment=(0.0, 0.0), torques=(0.5 * T, T), te_torque=T,
                                    te_angles=tuple(np.arange(n) * rvtool.build(design).mesh_period / n))
        model = rvtool.build(rvtool.replace_design(design, bodies=bodies))
        per = {}
        for M in (0.0, MOMENT):
            t1 = time.perf_counter()
            r = combined_moment_torque(model, CombinedLoadTest(moment=(M, 0.0), torques=test.torques,
                                                               te_torque=test.te_torque, te_angles=test.te_angles))
            per[f"M={M:g}"] = {**r.to_dict(), "wall_s": time.perf_counter() - t1}
            if M == 0.0:
                zero = r
        q0 = StaticSolver(model).solve(0.0)
        rig = moment_rigidity(model, MomentRigidityTest(reference_moment=MOMENT, levels=(0.0, 0.5, 1.0)))
        models[name] = {
            "bodies": bodies, "levels": per,
            "moment_rigidity_Nm_per_arcmin": rig.rigidity_arcmin, "moment_rigidity_convention": rig.convention,
            "stiffness_change_under_moment": (per[f"M={MOMENT:g}"]["torsional_stiffness_Nm_per_arcmin"]
                                              / per["M=0"]["torsional_stiffness_Nm_per_arcmin"] - 1.0),
            "design": design.name,
            "reproduction": None if design is not d else {
                "windup_rel_diff": float(abs(zero.output_angle[-1] / windup_p - 1.0)),
                "te_diff_over_pp": float(np.max(np.abs(zero.te - te_p)) / np.ptp(te_p))},
            "max_tilt_after_rad": float(max(np.max(np.abs(v[1:])) for v in model.tilts(q0).values())),
        }
        print(f"{name}: stiffness {per['M=0']['torsional_stiffness_Nm_per_arcmin']:.1f} -> "
              f"{per[f'M={MOMENT:g}']['torsional_stiffness_Nm_per_arcmin']:.1f} N m/arcmin, TE pp "
              f"{per['M=0']['te_peak_to_peak_arcsec']:.3f} -> {per[f'M={MOMENT:g}']['te_peak_to_peak_arcsec']:.3f} arcsec, "
              f"moment rigidity {rig.rigidity_arcmin:.0f} N m/arcmin")
    results = {"design": "rv40e", "moment_Nm": MOMENT, "rated_torque_Nm": d.rated_torque,
               "planar": {"windup_arcsec": float(windup_p * ARCSEC_PER_RAD), "te_pp_arcsec": float(np.ptp(te_p) * ARCSEC_PER_RAD)},
               "models": models, "wall_s": time.perf_counter() - t0}
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings={"quick": args.quick, "te_points": n,
                                                               "tilt_slices": d.bodies.tilt_slices},
                                 wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
