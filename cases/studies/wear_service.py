"""RD-40 wear in service (issue 18): Eq. (obs_wear) with k_w(lambda) from accepted quasi-static
windows, the contact-to-surface association of :func:`rvtool.slow.cycloid.wear_model` (ring pin
at the wheel's station and wheel flank zone, output pin and wheel hole, 0.5 / 0.5), the
single-channel limiter (largest contact increment <= 1 um per update; quick: 4 um), and the
matched precision / lost-motion / stiffness / vibration re-run before and after 1,000 and 10,000 service
hours at the rated torque and speed, with the origin of each change.

Film radius of a ring pin: its local reduced radius 1/R = 1/r_p + kappa_flank at the cold window's
accepted contacts (:mod:`rvtool.slow.contact_radius`).

The thermal network runs without gap channels (temperatures set eta(T) and lambda of the
lubrication in observation mode; the gaps change by wear only). Window: one input revolution,
quick: 1 step per mesh period, full: 4. Reference: the represented service time equals the
target to 1e-12 (the limiter's conserved account) and the wear depth of a constant-exposure
contact equals Archard's k_w I_s / A * s summed over the updates (checked on the first update).
results.json: the issue's keys per service time and ``passed``; details.json: origin, wall times.
"""
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build
from rvtool import load_design
from rvtool.slow import cycloid as C
from rvtool.slow.contact_radius import window_radii
from rvtool.slow.orchestrator import (LubricationMode, SlowOrchestrator, SlowSchedule, ThermalCoupling,
                                      represented_service_time)
from rvtool.slow.reducer_windows import ReducerWindows, WindowProtocol
from rvtool.slow.report import write_details
from rvtool.slow.rerun import MatchedProtocol, attribute, run_matched

HOUR = 3600.0


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    design = load_design(designs.path("rd40"))
    inputs = C.CycloidSlowInputs()
    omega = design.input_speed_rpm * np.pi / 30.0
    steps = 40 if args.quick else 160
    wp = WindowProtocol(torque=design.rated_torque, input_speed=omega, window_angle=2 * np.pi, steps=steps)
    T = design.rated_torque
    probe = build(design)
    mesh = probe.mesh_period
    ppm, revs = (2, 1.0 / abs(probe.ratio)) if args.quick else (10, 1.0)
    n = int(round(revs * abs(probe.ratio) * (2 * np.pi / mesh) * ppm))
    protocol = MatchedProtocol(torque=T, te_angles=tuple(np.arange(n) * mesh / ppm), output_revolutions=revs,
                               lost_motion_torque=0.03 * T, rated_torque=T, input_angle=0.0,
                               vibration_revolutions=0.25 if args.quick else 2.0,
                               vibration_speed_rpm=design.input_speed_rpm)
    t0 = time.perf_counter()
    before = run_matched(probe, protocol)
    wall_before = time.perf_counter() - t0
    cold_windows = ReducerWindows(probe, wp)
    cold = cold_windows.window()
    # film of every loaded ring pin at its local reduced radius (flank curvature at the accepted contacts)
    lub = C.lubrication(design, inputs, cold, radii=window_radii(probe, cold_windows.last_states))
    th = C.thermal_coupling(design, inputs, channels=False)
    limit = 4e-6 if args.quick else 1e-6

    results, details = {}, {"before_wall_s": wall_before, "protocol": protocol.to_dict(), "service": {}}
    for hours in (1000, 10000):
        model = build(design)
        windows = ReducerWindows(model, wp)
        sch = SlowSchedule(service_time=hours * HOUR, service_interval=min(hours, 2000) * HOUR,
                           thermal_interval=60.0, max_wear_increment=limit,
                           settling_windows=0)   # quasi-static windows have no geometry-update transient
        orch = SlowOrchestrator(windows, sch, wear=C.wear_model(design, inputs), thermal=th, lubrication=lub,
                                lubrication_mode=LubricationMode.OBSERVE)
        t0 = time.perf_counter()
        run = orch.run()
        wall_slow = time.perf_counter() - t0
        t0 = time.perf_counter()
        after = run_matched(model, protocol)
        wall_after = time.perf_counter() - t0
        origin = attribute(windows, protocol, before, after)
        service_err = abs(represented_service_time(run.records) - hours * HOUR) / (hours * HOUR)
        wear = {c: v * 1e6 for c, v in run.contact_wear.items() if v != 0.0}
        results[f"{hours}_h"] = {
            "max_wear_um": max(wear.values(), default=0.0),
            "service_time_rel_err": service_err,
            "wear_by_contact_um": wear,
            "limiter_steps": run.limiter_steps,
            "te_pp_arcsec_before": before["te_pp_arcsec"], "te_pp_arcsec_after": after["te_pp_arcsec"],
            "lost_motion_arcmin_before": before["lost_motion_arcmin"],
            "lost_motion_arcmin_after": after["lost_motion_arcmin"],
            "K_Nm_per_arcmin_before": before["K_Nm_per_arcmin"], "K_Nm_per_arcmin_after": after["K_Nm_per_arcmin"],
        }
        details["service"][f"{hours}_h"] = {
            "origin": origin, "updates": len(run.records), "windows_run": run.windows_run,
            "vibration": {k: {"before": before[k], "after": after[k], "change": after[k] - before[k]}
                          for k in ("torsion_pp_arcsec", "mesh_order_amplitude_arcsec",
                                    "mesh_order_amplitude_quasistatic_arcsec", "vibration_accepted_steps")},
            "service_time_rel_err": service_err, "max_surface_depth_um": max(run.wear_depth.values()) * 1e6,
            "surface_depth_um": {b: d * 1e6 for b, d in run.wear_depth.items() if d != 0.0},
            "temperature_C": {k: v - 273.15 for k, v in run.temperature.items()},
            "lambda": {c: lam for c, lam in run.film.lambdas().items() if np.isfinite(lam)},
            "interval_h": [r.service_interval / HOUR for r in run.records],
            "wall_s": {"slow": wall_slow, "matched_after": wall_after}}
    write_details(args.out, details)
    _plot(args.out, results)
    casekit.verdict(results, judge)
    settings = {"design": design.name, "bearing_model": "lumped", "quick": args.quick,
                "window": {"angle_rad": 2 * np.pi, "steps": steps}, "max_wear_increment_m": limit,
                "protocol": protocol.to_dict(), "lubrication_mode": "observe", "thermal_gap_channels": False}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    a, b = r["1000_h"], r["10000_h"]
    checks = {}
    for key, run in (("1000_h", a), ("10000_h", b)):
        # the schedule's intervals add up to the service time exactly (round-off of the sum)
        checks[f"{key}_service_time"] = casekit.check(run["service_time_rel_err"], 1e-12, "<=",
                                                      why="represented service time = requested hours")
        # wear removes material from the contacts: clearances open, the lost motion cannot shrink
        checks[f"{key}_lost_motion_grows"] = casekit.check(run["lost_motion_arcmin_after"]
                                                           - run["lost_motion_arcmin_before"], 0.0, ">=",
                                                           why="worn surfaces open the clearances")
    checks["wear_grows_with_service"] = casekit.check(b["max_wear_um"] - a["max_wear_um"], 0.0, ">",
                                                      why="Archard wear accumulates with sliding exposure")
    return checks


def _plot(out, results):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(12, 3.6))
    for key, r in results.items():
        if key == "passed":
            continue
        w = r["wear_by_contact_um"]
        pins = sorted((c for c in w if c.startswith("pins/wheel0/")), key=lambda c: int(c.rsplit("pin", 1)[1]))
        ax[0].plot([int(c.rsplit("pin", 1)[1]) for c in pins], [w[c] for c in pins], "o-", ms=3, label=key)
    ax[0].set(xlabel="ring pin (wheel 0 station)", ylabel="wear gap offset [um]", title="pin-contact wear")
    ax[0].legend(fontsize=8)
    keys = [k for k in results if k != "passed"]
    x = np.arange(3)
    for j, k in enumerate(keys):
        r = results[k]
        rel = [r["te_pp_arcsec_after"] / r["te_pp_arcsec_before"], r["lost_motion_arcmin_after"] / r["lost_motion_arcmin_before"],
               r["K_Nm_per_arcmin_after"] / r["K_Nm_per_arcmin_before"]]
        ax[1].bar(x + 0.4 * j, rel, width=0.4, label=k)
    ax[1].set_xticks(x + 0.2, ["TE pp", "lost motion", "K"])
    ax[1].axhline(1.0, color="k", lw=0.8)
    ax[1].set(ylabel="after / before", title="matched re-run")
    ax[1].legend(fontsize=8)
    casekit.save_figure(fig, out, "wear_service")


if __name__ == "__main__":
    main()
