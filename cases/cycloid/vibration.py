"""RD-40 (double wheel) vibration: driven rotation at rated speed and torque; spectra of the output torsion.

Responses: output torsion (TE, Eq. obs_te) and the x translation of wheel 1,
recorded at every accepted step of the implicit run; spectra on a uniform time
grid and shaft-order spectra from the unwrapped input phase; mesh (z_p f_in) and
bearing markers. Reference: the quasi-static TE at the same input angles (the
low-speed limit); its mesh-order amplitude is reported beside the dynamic one.
"""
import time

import numpy as np

from rvtool import casekit
from rvtool import build
from rvtool import load_design
from rvtool.protocols import vibration as V
from rvtool.units import ARCSEC_PER_RAD
from rvtool.protocols.precision import quasi_static_te
from rvtool.solver import RunSpec
from rvtool import designs

DESIGN = designs.path("rd40")


def _amp_at(x, a, x0):
    i = int(np.argmin(np.abs(np.asarray(x) - x0)))
    return float(a[i]), float(x[i])


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    m = r["markers_hz"]
    return {
        # kinematics: the pin-mesh frequency is z_p times the input frequency, exactly
        "mesh_marker": casekit.check(abs(m["mesh_hz"] / (r["mesh_order"] * m["input_hz"]) - 1), 1e-12, "<=",
                                     why="f_mesh = z_p f_in"),
        # the low-speed limit: the driven torsion's strongest order is the quasi-static TE's strongest order,
        # within the order resolution of the window (1 / input revolutions)
        "dominant_order_vs_quasistatic": casekit.check(abs(r["dominant_orders"][0] - r["dominant_order_quasistatic"]),
                                                       r["order_resolution"], "<=",
                                                       why="quasi-static TE at the same angles (low-speed limit)"),
        "accepted_steps_converged": casekit.check(r["max_residual"], r["run_abs_tol"], "<=",
                                                  why="every accepted step meets the run's absolute tolerance"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_start = time.perf_counter()
    design = load_design(DESIGN)
    revs = 0.25 if args.quick else 2.0
    speed = design.input_speed_rpm
    duration = revs * 60.0 / speed
    step = 2e-5
    proto = V.VibrationProtocol(speed_rpm=speed, torque=design.rated_torque, duration=duration, sample_step=step)
    spec = RunSpec(end_time=duration, step=step, abs_tol=1e-6, rel_tol=1e-8)
    model = build(design)
    run = V.driven_response(model, proto, spec, coordinates={"wheel1_x": (1, 0)}, out_dir=args.out)
    sp = V.vibration_spectra(run, proto, "torsion")
    sw = V.vibration_spectra(run, proto, "wheel1_x")
    markers = V.marker_frequencies(model, speed)
    zp = design.pins.n_pins
    dom_o, dom_a = V.dominant(sp["orders"], sp["order_spectrum"], 6)

    # reference: quasi-static TE over the same input angles (8 points per mesh period)
    t0 = time.perf_counter()
    n_qs = int(round(revs * zp * 8))
    angles = np.arange(n_qs) * 2 * np.pi / (zp * 8)
    qs = quasi_static_te(build(design), torque=design.rated_torque, input_angles=angles)
    wall_qs = time.perf_counter() - t0
    o_qs, a_qs = V.order_spectrum(angles, qs["te"], samples_per_rev=zp * 8)
    a_dyn_mesh, o_dyn = _amp_at(sp["orders"], sp["order_spectrum"], zp)
    a_qs_mesh, _ = _amp_at(o_qs, a_qs, zp)
    rec = run["record"]
    results = {
        "frequencies_hz": sp["frequencies_hz"], "spectrum": sp["spectrum"] * ARCSEC_PER_RAD,
        "spectrum_unit": "arcsec (torsion amplitude)",
        "orders": sp["orders"], "order_spectrum": sp["order_spectrum"] * ARCSEC_PER_RAD,
        "mesh_frequency_hz": markers["mesh_hz"], "mesh_order": zp,
        "dominant_orders": dom_o, "dominant_order_amplitudes_arcsec": dom_a * ARCSEC_PER_RAD,
        "markers_hz": markers,
        "wheel1_x_spectrum_m": sw["spectrum"], "wheel1_x_dominant_hz": V.dominant(sw["frequencies_hz"], sw["spectrum"], 4)[0],
        "torsion_pp_arcsec": float(np.ptp(run["responses"]["torsion"])) * ARCSEC_PER_RAD,
        "mesh_order_amplitude_arcsec": a_dyn_mesh * ARCSEC_PER_RAD,
        "mesh_order_amplitude_quasistatic_arcsec": a_qs_mesh * ARCSEC_PER_RAD,
        "mesh_order_rel_diff_vs_quasistatic": abs(a_dyn_mesh - a_qs_mesh) / max(a_qs_mesh, 1e-30),
        "dominant_order_quasistatic": float(o_qs[int(np.argmax(np.where(np.asarray(o_qs) > 0, a_qs, 0.0)))]),
        "order_resolution": 1.0 / revs,
        "run_abs_tol": spec.abs_tol,
        "wall_s_dynamic": run["wall_s"], "wall_s_quasistatic_reference": wall_qs,
        "accepted_steps": rec.accepted_steps, "rejected_steps": rec.rejected_steps,
        "max_residual": rec.max_residual,
    }
    settings = {"design": design.name, "input_revolutions": revs, "speed_rpm": speed, "torque_Nm": design.rated_torque,
                "run_spec": spec.to_dict(), "protocol": proto.__dict__, "quick": args.quick}
    _plot(args.out, sp, markers, zp)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_start)


def _plot(out, sp, markers, zp):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.5))
    ax[0].semilogy(sp["frequencies_hz"][1:], sp["spectrum"][1:] * ARCSEC_PER_RAD + 1e-12)
    ax[0].axvline(markers["mesh_hz"], color="r", ls="--", lw=0.8, label="mesh")
    for k, name in enumerate(("eccentric_bearing", "main_bearing", "input_bearing")):
        ax[0].axvline(markers[name]["bpfo"], color=f"C{k + 1}", ls=":", lw=0.8, label=f"{name} BPFO")
    V.body_mode_markers(ax[0], markers)      # flexible wheels' modes (wheels.dynamics.model = "flexible")
    ax[0].set_xlabel("frequency [Hz]")
    ax[0].set_ylabel("torsion amplitude [arcsec]")
    ax[0].legend(fontsize=6)
    ax[1].semilogy(sp["orders"][1:], sp["order_spectrum"][1:] * ARCSEC_PER_RAD + 1e-12)
    ax[1].axvline(zp, color="r", ls="--", lw=0.8)
    ax[1].set_xlabel("input shaft order [-]")
    casekit.save_figure(fig, out, "vibration")


if __name__ == "__main__":
    main()
