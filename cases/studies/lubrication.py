"""RD-40 lubrication (issue 18): eta(T) (Roelands), Dowson--Higginson line-contact minimum film,
lambda = h_min / sqrt(Rq1^2 + Rq2^2) and the declared mixed-friction law mu(lambda) per contact
from accepted quasi-static windows at the rated torque and speed, in observation mode (outputs
only) and in coupled mode (mu per contact written into the next window's contact law).

Friction in the equilibria: the ring-pin law is built with regularized friction at the declared
mu (``pin_contact.mu = CycloidSlowInputs.mu_pins``), and every window is solved with the
contacts evaluated at the kinematic velocities of its input angle (``WindowProtocol.
sliding_friction``), so mu enters the equilibria (a static solve has zero velocity and no
friction). The output-pin law is frictionless and the bearings roll: their mu is a heat source
only (declared).

Film radius of a ring-pin contact: the local reduced radius 1/R = 1/r_p + kappa_flank from the
flank curvature at the accepted contact points of the cold window (load-weighted;
:mod:`rvtool.slow.contact_radius`); output pins and needles are circles on circles.

Steps. Observation: one window (one input revolution) at the declared mu, the six-node network's
steady state from its sources mu I_s / tau_w (no thermal gap channels: the gaps stay as built, so
the change of the coupled run comes from friction alone), the film at those temperatures.
Coupled: mu(lambda) written per contact, window, steady temperatures, film, repeated until the
largest mu change of a loaded contact is <= 1e-4. Reported: the change of the friction dissipation
(sum mu I_s / tau_w) and of the TE (peak-to-peak over two mesh periods, and the mean wind-up)
from the declared to the coupled mu.
Reference: the friction work of the contact law itself (sum |F_t v_t| over the accepted steps of
the window) against the source model mu I_s / tau_w of the same window (equal up to the tanh
regularization and the load weighting of the sliding speed; tolerance 2 %).
results.json: the issue's keys and ``passed``; details.json: per-contact film, iterations,
references and wall times.
"""
import dataclasses
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build
from rvtool import load_design, replace_design as replace
from rvtool.slow import cycloid as C
from rvtool.slow.contact_radius import window_radii
from rvtool.slow.offsets import GapOffsets
from rvtool.slow.reducer_windows import ReducerWindows, WindowProtocol
from rvtool.slow.report import write_details
from rvtool.units import ARCSEC_PER_RAD

KELVIN_0C = 273.15
MU_TOL = 1e-4
"""Largest change of mu of a loaded contact between two coupled iterations at which they stop."""
WORK_REL_TOL = 0.02
"""|contact-law friction work - sum mu I_s| / sum mu I_s of the pin family: the tanh regularization
(v / v_reg > 100 at the pins) and the load-weighted sliding speed differ by well under 1 %."""
MAX_ITERATIONS = 12


def _family_table(film, exposure):
    """Per family with a loaded contact: the thinnest film's contact (h_min [um], lambda, mu)."""
    out = {}
    for fam in dict.fromkeys(C.family_of(c) for c in exposure.ids):
        rows = [k for k, c in enumerate(exposure.ids) if C.family_of(c) == fam and np.isfinite(film.h_min[k])]
        if not rows:
            continue
        k = min(rows, key=lambda r: film.h_min[r])
        out[fam] = {"contact": exposure.ids[k], "h_min_um": float(film.h_min[k]) * 1e6,
                    "lambda": float(film.film_parameter[k]), "mu_mixed": float(film.mu[k])}
    return out


def _state(windows, te_windows, th, lub, friction):
    """Window, steady temperatures and film at ``friction`` (None: declared mu)."""
    x = windows.window()
    Q = th.sources.node_sources(x, th.network, friction)
    T = th.network.steady(Q)
    temps = dict(zip(th.network.nodes, T.tolist()))
    film = lub.evaluate(x, temps)
    te_windows.window()
    P_source = float(np.sum(th.sources.power(x, friction)))
    pins = [k for k, c in enumerate(x.ids) if C.family_of(c) == "pins"]
    P_pins = float(np.sum(th.sources.power(x, friction)[pins]))
    return {"exposure": x, "T": T, "film": film, "power_W": P_source, "pin_source_W": P_pins,
            "pin_law_work_W": windows.last_friction_power, "te": te_windows.last_te.copy()}


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    return {
        "coupled_fixed_point": casekit.check(r["coupled_converged"], True, "==",
                                             why="the coupled mu fixed point converges within MAX_ITERATIONS"),
        "pin_friction_work": casekit.check(r["pin_work_rel_err"], WORK_REL_TOL, "<=",
                                           why="contact-law friction work vs sum mu I_s (WORK_REL_TOL)"),
        # lambda = h_min / composite roughness is positive and the film positive wherever reported
        "films_positive": casekit.check(min(v for v in r["h_min_um"].values() if v is not None), 0.0, ">",
                                        why="Dowson--Higginson film thickness is positive"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all, c_all = time.perf_counter(), time.process_time()
    inputs = C.CycloidSlowInputs()
    design = replace(load_design(designs.path("rd40")), pin_contact={"mu": inputs.mu_pins})
    model = build(design)
    omega = design.input_speed_rpm * np.pi / 30.0
    steps = 40 if args.quick else 160
    te_steps = 16 if args.quick else 48
    wp = WindowProtocol(torque=design.rated_torque, input_speed=omega, window_angle=2 * np.pi, steps=steps,
                        sliding_friction=True)
    windows = ReducerWindows(model, wp)
    te_windows = ReducerWindows(model, dataclasses.replace(wp, window_angle=2 * model.mesh_period, steps=te_steps))
    th = C.thermal_coupling(design, inputs, channels=False)

    # observation mode: declared mu; the film is output only
    t0 = time.perf_counter()
    cold = windows.window()            # entrainment speeds of the film contacts from the declared-mu window
    radii = window_radii(model, windows.last_states)   # local reduced radius of every loaded pin contact
    lub = C.lubrication(design, inputs, cold, radii=radii)
    declared = _state(windows, te_windows, th, lub, None)
    wall_obs = time.perf_counter() - t0

    # coupled mode: mu(lambda) per contact into the next window's contact law, to a fixed point
    t0 = time.perf_counter()
    history, state, friction = [], declared, None
    converged = False
    for _ in range(MAX_ITERATIONS):
        friction = state["film"].friction()
        windows.apply_offsets(GapOffsets.none(), friction)
        te_windows.apply_offsets(GapOffsets.none(), friction)
        state = _state(windows, te_windows, th, lub, friction)
        loaded = np.isfinite(state["film"].h_min)
        change = float(np.max(np.abs(state["film"].mu[loaded] - np.array([friction[c] for c in
                                                                          np.array(state["exposure"].ids)[loaded]]))))
        history.append({"max_mu_change": change, "power_W": state["power_W"],
                        "te_pp_arcsec": float(np.ptp(state["te"])) * ARCSEC_PER_RAD})
        if change <= MU_TOL:
            converged = True
            break
    coupled = state
    wall_coupled = time.perf_counter() - t0

    te_pp = {k: float(np.ptp(s["te"])) * ARCSEC_PER_RAD for k, s in (("declared", declared), ("coupled", coupled))}
    te_mean = {k: float(np.mean(np.abs(s["te"]))) * ARCSEC_PER_RAD for k, s in (("declared", declared), ("coupled", coupled))}
    work_err = {k: abs(s["pin_law_work_W"] - s["pin_source_W"]) / s["pin_source_W"]
                for k, s in (("declared", declared), ("coupled", coupled))}
    table = _family_table(declared["film"], declared["exposure"])
    table_c = _family_table(coupled["film"], coupled["exposure"])
    results = {
        "h_min_um": {f: r["h_min_um"] for f, r in table.items()},
        "lambda": {f: r["lambda"] for f, r in table.items()},
        "mu_mixed": {f: r["mu_mixed"] for f, r in table.items()},
        "friction_dissipation_change_W": coupled["power_W"] - declared["power_W"],
        "te_pp_change_arcsec": te_pp["coupled"] - te_pp["declared"],
        "coupled_converged": converged,
        "pin_work_rel_err": max(work_err.values()),
    }
    casekit.verdict(results, judge)
    x = declared["exposure"]
    details = {
        "observation": {"critical_contact": table, "temperature_C": dict(zip(th.network.nodes,
                                                                             (declared["T"] - KELVIN_0C).tolist())),
                        "per_contact": {c: {"h_min_um": h * 1e6, "lambda": lam, "mu": m, "mean_load_N": F}
                                        for c, h, lam, m, F in zip(x.ids, declared["film"].h_min,
                                                                   declared["film"].film_parameter, declared["film"].mu,
                                                                   x.mean_force) if np.isfinite(h)},
                        "wall_s": wall_obs},
        "coupled": {"critical_contact": table_c, "iterations": len(history), "converged": converged,
                    "history": history, "temperature_C": dict(zip(th.network.nodes,
                                                                  (coupled["T"] - KELVIN_0C).tolist())),
                    "wall_s": wall_coupled},
        "friction_dissipation_W": {"declared": declared["power_W"], "coupled": coupled["power_W"]},
        "te_pp_arcsec": te_pp, "te_mean_windup_arcsec": te_mean,
        "te_mean_windup_change_arcsec": te_mean["coupled"] - te_mean["declared"],
        "reference_pin_friction_work": {
            "law_W": {"declared": declared["pin_law_work_W"], "coupled": coupled["pin_law_work_W"]},
            "source_W": {"declared": declared["pin_source_W"], "coupled": coupled["pin_source_W"]},
            "rel_err": work_err, "tolerance": WORK_REL_TOL,
            "reference": "sum |F_t v_t| dt of the contact law over the window's accepted steps"},
        "pin_reduced_radius_m": {"min": min(radii.values()), "max": max(radii.values()),
                                 "pin_radius": design.pins.pin_radius},
        "cpu_s": time.process_time() - c_all,
    }
    write_details(args.out, details)
    _plot(args.out, declared, coupled, history)
    settings = {"design": design.name, "pin_contact_mu": inputs.mu_pins, "quick": args.quick,
                "inputs": dataclasses.asdict(inputs), "bearing_model": "lumped",
                "window": {"angle_rad": 2 * np.pi, "steps": steps, "sliding_friction": True},
                "te_window": {"angle_rad": 2 * model.mesh_period, "steps": te_steps},
                "thermal_gap_channels": False, "mu_tol": MU_TOL,
                "film": "Dowson-Higginson line contact at the window-mean load, Roelands eta(T); ring pins at their "
                        "local reduced radius 1/R = 1/r_p + kappa_flank (load-weighted over the window)"}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


def _plot(out, declared, coupled, history):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.6))
    x = declared["exposure"]
    for fam, mk in (("pins", "o"), ("output_pins", "s"), ("eccentric_bearings", "^")):
        rows = [k for k, c in enumerate(x.ids) if C.family_of(c) == fam and np.isfinite(declared["film"].h_min[k])]
        if rows:
            ax[0].semilogx(declared["film"].film_parameter[rows], declared["film"].mu[rows], mk, ms=4, label=fam)
    ax[0].set(xlabel="lambda [-]", ylabel="mu(lambda) [-]", title="film and mixed friction (observation)")
    ax[0].legend(fontsize=8)
    h = np.array([[r["max_mu_change"], r["power_W"]] for r in history])
    ax[1].semilogy(np.arange(1, len(h) + 1), h[:, 0], "o-")
    ax[1].set(xlabel="coupled iteration", ylabel="max |delta mu|", title="coupled fixed point")
    ax[2].plot(declared["te"] * ARCSEC_PER_RAD, label=f"declared mu ({declared['power_W']:.1f} W)")
    ax[2].plot(coupled["te"] * ARCSEC_PER_RAD, label=f"coupled mu ({coupled['power_W']:.1f} W)")
    ax[2].set(xlabel="step (two mesh periods)", ylabel="output - kinematic [arcsec]", title="TE with friction")
    ax[2].legend(fontsize=8)
    casekit.save_figure(fig, out, "lubrication")


if __name__ == "__main__":
    main()
