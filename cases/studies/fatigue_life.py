"""RD-40 contact fatigue and bearing rating life (issue 18), downstream of accepted quasi-static
windows (damage writes nothing back).

Model: RD-40 with rolling-element bearings (``bearing_model="rolling"``: needle rollers of the
eccentric bearings, balls of the main pair and the input bearings), rated torque and speed; one
window = one input revolution (quick: 1 step per mesh period, full: 4).

1. Force--life path, Eq. (obs_damage): dD_c/dtau = nu_c I_m,c / (tau_w N_ref F_ref^m) per contact,
   with the declared Hertz-pressure S--N curve of every line contact turned into a force--life
   law (:func:`rvtool.slow.cycloid.life_laws`, m = 4) and declared cycle rates
   (:func:`rvtool.slow.cycloid.cycle_rates`). ``damage_per_hour``: the most damaged contact of each
   family (the ring pins' law at the local reduced radius of the selected pin at its peak load,
   from the pressure module: the flank curvature makes it well below r_p); ``life_h``: 1 / the
   largest damage per hour; ``mean_load_underestimate``: per family
   sum (I_F / tau_w)^m / sum I_m / tau_w (damage from the m-th power of the mean load over damage
   from I_m).
2. ISO 281 rating life per bearing from the accepted rolling-element loads: radial load
   |sum_j Q_j n_j| at every accepted step, ISO mean load P_m = (sum P^p dt / tau_w)^(1/p), C_r from
   the geometry, L10 at the relative ring speed (``None``: a bearing without radial load; under
   pure output torque the planar model loads the preloaded main pair and the input bearings with
   balanced element loads only, and their L10 needs the application's external loads).
3. Stress-spectrum path: the most loaded ring pin of wheel 0 (largest I_m); at each accepted
   step its local contact (:func:`rvtool.pressure.state.pin_contact`), the panel pressure and the
   plane-strain subsurface stress of :mod:`rvtool.pressure`, the peak Tresca stress as history;
   rainflow counting (``rainflow`` package) and Miner's sum on the same S--N curve in the Tresca
   amplitude (sigma_ref = 0.5 x 0.300 x p_ref for a 0-to-peak cycle at the reference pressure).

References: (a) the peak subsurface Tresca stress of the panel solution against the closed-form
Hertz value of the same force and radius (tolerance 3 %: the flank's curvature and the panel
resolution make the contact slightly non-Hertzian); (b) the needle bearing's radial load from
its roller loads against wheel 0's force balance (pin resultant minus output-pin resultant;
tolerance 1e-3 of the load: static residual and regularization springs).
results.json: the issue's keys and ``passed``; details.json: per-contact rates, the stress history,
the rainflow cycles, references and wall / CPU times.
"""
import dataclasses
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build
from rvtool import load_design
from rvtool.model import Family
from rvtool.pressure.state import pin_contact
from rvtool.slow import cycloid as C
from rvtool.slow import fatigue as Fa
from rvtool.slow.exposure import WindowExposure
from rvtool.slow.reducer_windows import ReducerWindows, WindowProtocol
from rvtool.slow.report import write_details

HOUR = 3600.0
STRESS_REL_TOL = 0.03
BALANCE_REL_TOL = 1e-3
RADIAL_ZERO = 1e-9


def _subset(x: WindowExposure, rows) -> WindowExposure:
    rows = list(rows)
    return WindowExposure(ids=tuple(x.ids[k] for k in rows), tau_w=x.tau_w, m=x.m, I_s=x.I_s[rows],
                          I_m=x.I_m[rows], I_F=x.I_F[rows], F_pk=x.F_pk[rows], position=x.position[rows])


def _resultant(model, q, family, select):
    ob = model.observe(q, family)
    rows = [i for i, r in enumerate(ob.ids) if select(r)]
    return ob.normal_force[rows], ob.normal[rows]


def force_life(x, laws, rates):
    """Per family: damage per hour of every contact [1/h] and the mean-load ratio."""
    out = {}
    for fam, law in laws.items():
        rows = [k for k, c in enumerate(x.ids) if C.family_of(c) == fam]
        sub = _subset(x, rows)
        rate = law.damage_rate(sub, rates[fam]) * HOUR
        loaded = sub.I_m > 0.0
        ratio = float(np.sum((sub.I_F[loaded] / sub.tau_w) ** law.exponent) / np.sum(sub.I_m[loaded] / sub.tau_w))
        out[fam] = {"ids": sub.ids, "damage_per_hour": rate, "mean_load_underestimate": ratio}
    return out


def bearing_lives(model, design, states, omega):
    """Bearing name -> ISO 281 figures from the radial loads at the accepted steps."""
    out = {}
    fam_of = {"eccentric_bearing": Family.ECCENTRIC_BEARINGS, "main_bearing": Family.MAIN_BEARINGS,
              "input_bearing": Family.INPUT_BEARINGS}
    for name, (geom, speed_factor) in C.rating_geometries(design).items():
        fam = fam_of[name.rstrip("0123456789")]
        P, dt, Qsum = [], [], 0.0
        for _, d, q in states:
            Q, n = _resultant(model, q, fam, lambda r, nm=name: r.startswith(nm + "/"))
            P.append(Fa.radial_load_from_elements(Q, n))
            dt.append(d)
            Qsum = max(Qsum, float(np.sum(Q)))
        P, dt = np.array(P), np.array(dt)
        # a resultant below 1e-9 of the element loads is round-off of a balanced preload ring, no radial load
        P = np.where(P > RADIAL_ZERO * Qsum, P, 0.0)
        p = geom.life_exponent
        Pm = Fa.mean_equivalent_load(float(np.sum(P ** p * dt)), float(np.sum(dt)), p)
        row = {"C_r_N": geom.dynamic_load_rating(), "P_m_N": Pm, "P_max_N": float(P.max()), "exponent": p,
               "speed_rpm": speed_factor * omega * 30 / np.pi}
        if Pm > 0.0:
            life = Fa.rating_life(geom, Pm, speed_factor * omega)
            row.update(L10_million_rev=life.L10_million_rev, L10_h=life.L10_hours)
        else:
            row.update(L10_million_rev=None, L10_h=None)
        out[name] = row
    return out


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    return {
        "peak_tresca_vs_hertz": casekit.check(r["peak_tresca_vs_hertz_rel_err"], STRESS_REL_TOL, "<=",
                                              why="subsurface Tresca peak vs Hertz 0.300 p0 (STRESS_REL_TOL)"),
        "bearing_load_balance": casekit.check(r["bearing_load_balance_rel_err"], BALANCE_REL_TOL, "<=",
                                              why="bearing element loads vs the wheel's resultant (BALANCE_REL_TOL)"),
        # a life is a positive finite number of hours (an unloaded family would give infinity)
        "life_positive": casekit.check(r["life_h"], 0.0, ">", why="finite damage rate of the critical contact"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all, c_all = time.perf_counter(), time.process_time()
    inputs = C.CycloidSlowInputs()
    design = load_design(designs.path("rd40"))
    model = build(design, bearing_model="rolling")
    omega = design.input_speed_rpm * np.pi / 30.0
    steps = 40 if args.quick else 160
    m = 0.5 * inputs.fatigue_pressure_exponent
    windows = ReducerWindows(model, WindowProtocol(torque=design.rated_torque, input_speed=omega,
                                                   window_angle=2 * np.pi, steps=steps, m=m))
    t0 = time.perf_counter()
    x = windows.window()
    states = windows.last_states
    wall_window = time.perf_counter() - t0

    # 2. ISO 281 per bearing
    t0 = time.perf_counter()
    lives = bearing_lives(model, design, states, omega)
    wall_iso = time.perf_counter() - t0
    # reference (b): eccentric bearing 0's radial load against wheel 0's force balance, every step
    bal = []
    for _, _, q in states:
        Qb, nb = _resultant(model, q, Family.ECCENTRIC_BEARINGS, lambda r: r.startswith("eccentric_bearing0/"))
        Fp, npin = _resultant(model, q, Family.PINS, lambda r: r.startswith("wheel0/"))
        Fo, nout = _resultant(model, q, Family.OUTPUT_PINS, lambda r: "/wheel0/" in r)
        wheel = Fp @ npin - Fo @ nout      # the output-pin observation normal points from the pin to the wheel
        bal.append(abs(Fa.radial_load_from_elements(Qb, nb) - np.linalg.norm(wheel)) / np.linalg.norm(wheel))
    balance_err = float(max(bal))

    # 3. stress-spectrum path on the most loaded ring pin of wheel 0
    t0 = time.perf_counter()
    pins = [k for k, c in enumerate(x.ids) if c.startswith("pins/wheel0/")]
    k_sel = max(pins, key=lambda k: x.I_m[k])
    pin = int(x.ids[k_sel].rsplit("pin", 1)[1])
    contacts = []
    for _, _, q in states:
        F, _ = _resultant(model, q, Family.PINS, lambda r, p=pin: r.startswith(f"wheel0/pin{p}/"))
        contacts.append(pin_contact(model, q, 0, pin) if F.sum() > 0.0 else None)
    panels = 161 if args.quick else 401
    hist = Fa.subsurface_stress_history(contacts, panels=panels, depths=41 if args.quick else 81)
    # the ring pin's reduced radius at its peak load: the flank's own curvature makes it well below r_p
    R_pin = contacts[int(np.argmax(hist.force))].radius

    # 1. force--life path (pins at R_pin, the other families at their declared radii)
    laws = C.life_laws(design, inputs, per_roller=True, radius={Family.PINS.value: R_pin})
    rates = C.cycle_rates(design, omega)
    fl = force_life(x, laws, rates)
    dph = {f: float(np.max(r["damage_per_hour"])) for f, r in fl.items()}
    critical = {f: r["ids"][int(np.argmax(r["damage_per_hour"]))] for f, r in fl.items()}
    ratio = Fa.hertz_line_tresca_ratio(design.material.poisson_ratio)
    curve = Fa.SNCurve(reference_amplitude=0.5 * ratio * inputs.fatigue_reference_pressure,
                       reference_life=inputs.fatigue_reference_cycles, exponent=inputs.fatigue_pressure_exponent)
    spec = Fa.miner_damage(hist.tau_max, curve, periodic=True)   # one input revolution = one repeated block
    f_in = omega / (2 * np.pi)
    spectrum_per_hour = spec.damage * f_in * HOUR
    pin_force_life = float(fl["pins"]["damage_per_hour"][fl["pins"]["ids"].index(x.ids[k_sel])])
    loaded = hist.force > 0
    stress_err = float(np.max(np.abs(hist.tau_max[loaded] - hist.hertz_tau[loaded]) / hist.hertz_tau[loaded]))
    wall_spec = time.perf_counter() - t0

    results = {
        "damage_per_hour": dph,
        "life_h": 1.0 / max(dph.values()),
        "bearing_L10_h": {b: r["L10_h"] for b, r in lives.items()},
        "mean_load_underestimate": {f: r["mean_load_underestimate"] for f, r in fl.items()},
        "peak_tresca_vs_hertz_rel_err": stress_err,
        "bearing_load_balance_rel_err": balance_err,
    }
    casekit.verdict(results, judge)
    details = {
        "force_life": {"critical_contact": critical, "pin_radius_at_peak_m": R_pin, "laws": {f: dataclasses.asdict(v) for f, v in laws.items()},
                       "cycle_rate_hz": rates,
                       "life_h_per_family": {f: 1.0 / v for f, v in dph.items()},
                       "per_contact_damage_per_hour": {f: dict(zip(r["ids"], r["damage_per_hour"].tolist()))
                                                       for f, r in fl.items()}},
        "bearings": lives,
        "stress_spectrum": {"contact": x.ids[k_sel], "panels": panels, "tau_max_MPa": (hist.tau_max / 1e6).tolist(),
                            "force_N": hist.force.tolist(), "depth_um": (hist.depth * 1e6).tolist(),
                            "hertz_tau_MPa": (hist.hertz_tau / 1e6).tolist(), "tresca_ratio": ratio,
                            "cycles": {"amplitude_MPa": (spec.amplitude / 1e6).tolist(), "count": spec.count.tolist()},
                            "damage_per_revolution": spec.damage, "damage_per_hour": spectrum_per_hour,
                            "force_life_damage_per_hour_same_contact": pin_force_life,
                            "spectrum_over_force_life": spectrum_per_hour / pin_force_life,
                            "life_h": 1.0 / spectrum_per_hour if spectrum_per_hour > 0 else None},
        "references": {"peak_tresca_vs_hertz_rel_err": stress_err, "tolerance": STRESS_REL_TOL,
                       "bearing_load_vs_wheel_balance_rel_err": balance_err, "balance_tolerance": BALANCE_REL_TOL},
        "wall_s": {"window": wall_window, "iso281": wall_iso, "stress_spectrum": wall_spec},
        "cpu_s": time.process_time() - c_all,
    }
    write_details(args.out, details)
    _plot(args.out, fl, hist, lives)
    settings = {"design": design.name, "bearing_model": "rolling", "quick": args.quick, "m": m,
                "window": {"angle_rad": 2 * np.pi, "steps": steps}, "inputs": dataclasses.asdict(inputs),
                "sn_curve_tresca": dataclasses.asdict(curve)}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


def _plot(out, fl, hist, lives):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.6))
    for fam, mk in (("pins", "o"), ("output_pins", "s"), ("eccentric_bearings", "^")):
        d = fl[fam]["damage_per_hour"]
        ax[0].semilogy(np.arange(d.size), np.where(d > 0, d, np.nan), mk, ms=3, label=fam)
    ax[0].set(xlabel="contact", ylabel="damage per hour [1/h]", title="Eq. (obs_damage)")
    ax[0].legend(fontsize=8)
    ax[1].plot(hist.tau_max / 1e6, "o-", ms=3, label="panel + half-space")
    ax[1].plot(hist.hertz_tau / 1e6, "k--", lw=0.8, label="Hertz closed form")
    ax[1].set(xlabel="accepted step (one input revolution)", ylabel="peak Tresca stress [MPa]",
              title="subsurface stress history")
    ax[1].legend(fontsize=8)
    names = [b for b, r in lives.items() if r["L10_h"] is not None]
    ax[2].bar(names, [lives[b]["L10_h"] for b in names])
    ax[2].set_yscale("log")
    ax[2].set(ylabel="L10 [h]", title="ISO 281")
    ax[2].tick_params(axis="x", labelrotation=30, labelsize=7)
    casekit.save_figure(fig, out, "fatigue_life")


if __name__ == "__main__":
    main()
