"""RD-40 double wheel with the housing represented through ports: precision protocol and rigid-housing comparison.

The housing is an elastic steel annulus (bore 54.5 mm, outer radius 75 mm,
30 mm high, 4 mm tetrahedra; 12 mount springs of 2e8 N/m per direction on
its lower face) carrying each ring pin at one planar port; Craig--Bampton
parent with 20 fixed-interface modes, port reduction to 12 modes plus one
residual attachment mode per port row (static port compliance exact). The
same precision study as cycloid_double_wheel (issue 5 keys) runs on it over
one input revolution at 40 points per mesh cycle (--quick: 4 points) plus a
driven run at the rated speed over one input revolution (--quick: four mesh cycles); the comparison block gives the rated-state flange angle, pin
forces and active pins with the rigid and the elastic housing, the largest
port displacement and the reduction's static error against the parent.

Contact element (issue 19): every model of the case is built with
``--contact-element`` (default ``merged``: all families in one Exudyn element
whose port contraction works on the pins in contact and whose tangent goes to
Exudyn as sparse triplets; ``per_family`` is the former layout with the dense
92-coordinate pin element, kept for comparison).
"""
import os
import time

import numpy as np

import rvtool
from rvtool import casekit
from rvtool.assembly.housing import housing_ports
from rvtool.solver.static import StaticSolver
from rvtool.protocols.precision import mesh_forces
from rvtool.units import ARCMIN_PER_RAD
from rvtool.analysis.precision_study import precision_study

DESIGN = "rd40"


def judge(r):
    """The precision study's checks (cycloid_double_wheel) and the housing's."""
    checks = casekit.import_case("cycloid/cycloid_double_wheel").judge(r)
    h = r["housing"]
    checks.update({
        # one residual attachment mode per port row makes the static port compliance exact: round-off of
        # the Craig--Bampton parent's solve (measured 6.6e-13)
        "housing_static_compliance": casekit.check(h["reduction"]["static_compliance_rel_err_vs_parent"], 1e-9, "<=",
                                                   why="exact static port compliance by construction; round-off"),
        # a compliant housing cannot stiffen the reducer: the flange turns further at the rated torque
        "elastic_housing_softer": casekit.check(h["flange_angle_increase_arcmin"], 0.0, ">",
                                                why="the ported housing adds compliance in series"),
    })
    return checks


def rated_state(design, bearing_model):
    m = rvtool.build(design, bearing_model=bearing_model)
    m.set_output_torque(-np.sign(design.ratio) * design.rated_torque)
    solver = StaticSolver(m)
    t = time.perf_counter()
    q = solver.solve(0.0)
    wall = time.perf_counter() - t
    F = mesh_forces(m, q)
    th = q[m.output_index] - m.kinematic_output(0.0)
    out = {"flange_angle_arcmin": float(th * ARCMIN_PER_RAD), "pin_forces_N": F, "peak_pin_force_N": float(F.max()),
           "n_active_pins": (F > 1e-6 * F.max()).sum(axis=1), "solve_s": wall,
           "newton_iterations": solver.stats.newton_iterations}
    if m.housing is not None:
        u = m.housing.port_displacements().reshape(-1, 2)
        out["port_displacement_max_um"] = float(np.linalg.norm(u, axis=1).max() * 1e6)
    return out


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=lambda p: p.add_argument(
        "--contact-element", choices=("merged", "per_family"), default="merged",
        help="contact-element layout of every model built (rvtool.assembly.cycloid.build)"))
    # the build option for every model of the case, also those the protocols build
    os.environ["RVTOOL_CONTACT_ELEMENT"] = args.contact_element
    t0 = time.perf_counter()
    base = rvtool.load_design(DESIGN)
    design = rvtool.replace_design(base, housing={"model": "ports"})
    bearing_model = "rolling"
    t = time.perf_counter()
    reduced, C_ref, info = housing_ports(design)
    reduction_s = time.perf_counter() - t
    C = reduced.static_compliance()
    static_err = float(np.linalg.norm(C - C_ref) / np.linalg.norm(C_ref))

    rigid = rated_state(base, bearing_model)
    ported = rated_state(design, bearing_model)
    results, settings = precision_study(design, quick=args.quick, out_dir=args.out, bearing_model=bearing_model,
                                        points_per_mesh=4 if args.quick else 40,
                                        output_revolutions=1.0 / (design.pins.n_pins - 1),
                                        dynamic_duration=None if args.quick else 60.0 / design.input_speed_rpm)
    results["housing"] = {
        "reduction": {**info, "wall_s": reduction_s, "static_compliance_rel_err_vs_parent": static_err,
                      "port_compliance_diag_m_per_N": [float(C_ref.diagonal().min()), float(C_ref.diagonal().max())]},
        "rated_rigid_housing": rigid,
        "rated_ported_housing": ported,
        "flange_angle_increase_arcmin": ported["flange_angle_arcmin"] - rigid["flange_angle_arcmin"],
        "peak_pin_force_change_pct": 100 * (ported["peak_pin_force_N"] / rigid["peak_pin_force_N"] - 1),
    }
    settings["housing"] = design.source["housing"]            # the file-form [housing] table of the design
    settings["contact_element"] = args.contact_element
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
