"""Elastic pins: one pin under a line load on each support against the beam closed forms, and
RD-40's torsional stiffness with rigid versus elastic pins (issue 21).

Beam check (rvtool/structure/pin_beam.py): an RD-40 output pin (r = 4 mm, steel) of span
L = 24 mm under a uniform line load over the whole span, deflection at the tip (cantilever) or at
midspan (simply supported, clamped--clamped), and under a point load at 0.3 L (cantilever and
simply supported) or midspan (clamped--clamped), Euler--Bernoulli and Timoshenko, against
  cantilever        q L^4/(8 EI) + q L^2/(2 kGA);   P a^3/(3 EI) + P a/kGA (at the load)
  simply supported  5 q L^4/(384 EI) + q L^2/(8 kGA); P a^2 b^2/(3 L EI) + P a b/(L kGA)
  clamped--clamped  q L^4/(384 EI) + q L^2/(8 kGA);  P L^3/(192 EI) + P L/(4 kGA)
(kGA = inf for Euler--Bernoulli). ``beam_rel_err`` is the largest relative error.

Stiffness: condensed tangent K_t (Eq. obs_condensed_stiffness) at the rated torque (140 N m,
zero input angle, rolling-element bearings) with rigid pins (rd40.toml) and with the declared
supports (chosen here; RD-40 does not give them): ring pins simply supported in the two end
covers at z = +-15 mm (the housing height), output pins cantilevered from the flange, clamped at
z = -12 mm with the free end at +12 mm; each elastic pin closed exactly per pin with its full station
compliance (rvtool/contact/pin_closure.py). Beside them (in the settings): the largest pin bending
stress at the rated state of each variant (the same supports assumed where the pins are rigid) and
the stiffness budget of the elastic-pin variant (energy, switch-to-rigid and sensitivity shares).
--quick runs the same (it is a few static solves).
"""
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build
from rvtool import load_design, replace_design as replace
from rvtool.protocols.budget import stiffness_budget
from rvtool.protocols.stiffness import condensed_tangent
from rvtool.solver.static import StaticSolver
from rvtool.structure.pin_beam import PinBeam, PinSupport
from rvtool.units import RAD_PER_ARCMIN

RING_SUPPORT = {"model": "simply_supported", "ends": [-0.015, 0.015]}
OUTPUT_SUPPORT = {"model": "cantilever", "ends": [-0.012, 0.012]}


def beam_checks(radius=0.004, span=0.024, E=206e9, nu=0.3):
    """[(support, theory, load, computed [m/N or m per N/m], closed form, rel. error)]."""
    L, a = span, 0.3 * span
    b = L - a
    out = []
    for shear in (False, True):
        for model in ("cantilever", "simply_supported", "clamped_clamped"):
            beam = PinBeam(PinSupport(model=model, ends=(0.0, L), shear=shear), radius, E, nu)
            EI, kGA = beam.EI, beam.kGA
            x = L if model == "cantilever" else 0.5 * L
            line = {"cantilever": L ** 4 / (8 * EI) + L ** 2 / (2 * kGA),
                    "simply_supported": 5 * L ** 4 / (384 * EI) + L ** 2 / (8 * kGA),
                    "clamped_clamped": L ** 4 / (384 * EI) + L ** 2 / (8 * kGA)}[model]
            num = float(beam.line_load_deflection(x, 0.0, L)[0])
            theory = "Timoshenko" if shear else "Euler-Bernoulli"
            out.append((model, theory, "uniform line load", num, line, abs(num / line - 1)))
            xp, point = {"cantilever": (a, a ** 3 / (3 * EI) + a / kGA),
                         "simply_supported": (a, a * a * b * b / (3 * L * EI) + a * b / (L * kGA)),
                         "clamped_clamped": (0.5 * L, L ** 3 / (192 * EI) + L / (4 * kGA))}[model]
            num = float(beam.influence([xp], [xp])[0, 0])
            out.append((model, theory, "point load", num, point, abs(num / point - 1)))
    return out


def rated_stiffness(design):
    """(K_t [N m/arcmin], model, state) at the rated torque and zero input angle."""
    model = build(design, bearing_model="rolling")
    model.set_output_torque(-np.sign(model.ratio) * design.rated_torque)
    q = StaticSolver(model).solve(0.0)
    return condensed_tangent(model, q) * RAD_PER_ARCMIN, model, q


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    K = r["K_by_variant_Nm_per_arcmin"]
    return {
        # the beam code evaluates the closed forms' own integrals (line load by quadrature): measured 2e-8
        "beam_vs_closed_forms": casekit.check(r["beam_rel_err"], 1e-6, "<=",
                                              why="Euler-Bernoulli / Timoshenko closed forms; quadrature of the line load"),
        # elastic pins add compliance in series: each elastic variant is softer than the rigid one, and both
        # elastic together softer than either alone
        "ring_pins_soften": casekit.check(K["elastic ring pins"] / K["rigid pins"], 1.0, "<", why="series compliance"),
        "output_pins_soften": casekit.check(K["elastic output pins"] / K["rigid pins"], 1.0, "<",
                                            why="series compliance"),
        "both_softest": casekit.check(K["elastic pins"] / min(K["elastic ring pins"], K["elastic output pins"]), 1.0,
                                      "<", why="series compliance"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    checks = beam_checks()
    t_beam = time.perf_counter() - t0
    d = load_design(designs.path("rd40"))
    variants = {"rigid pins": d,
                "elastic ring pins": replace(d, pins={"support": RING_SUPPORT}),
                "elastic output pins": replace(d, output_pins={"support": OUTPUT_SUPPORT}),
                "elastic pins": replace(d, pins={"support": RING_SUPPORT}, output_pins={"support": OUTPUT_SUPPORT})}
    K, stress = {}, {}
    supports = {"pins": PinSupport(**RING_SUPPORT), "output_pins": PinSupport(**OUTPUT_SUPPORT)}
    for name, dv in variants.items():
        K[name], model, q = rated_stiffness(dv)
        # largest pin bending stress at the rated state: the declared supports where elastic, the
        # same supports assumed where the pins are rigid
        stress[name] = {f: model.pin_bending(q, f, supports[f])["sigma_max_Pa"] / 1e6 for f in supports}
        if name == "elastic pins":
            budget = stiffness_budget(model, q)
    results = {"beam_rel_err": max(c[-1] for c in checks),
               "K_rigid_pins_Nm_per_arcmin": K["rigid pins"],
               "K_elastic_pins_Nm_per_arcmin": K["elastic pins"],
               "K_by_variant_Nm_per_arcmin": K}
    casekit.verdict(results, judge)
    _plots(checks, K, budget, args.out)
    settings = {"design": d.name, "bearing_model": "rolling", "torque_Nm": d.rated_torque, "input_angle_rad": 0.0,
                "ring_pin_support": RING_SUPPORT, "output_pin_support": OUTPUT_SUPPORT,
                "pin_bending_stress_MPa_by_variant": stress,
                "stiffness_budget_elastic_pins": {k: budget[k] for k in ("shares", "rigid_shares",
                                                                           "sensitivity_shares")},
                "beam_checks": [list(c) for c in checks], "beam_check_wall_s": t_beam, "quick": args.quick}
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


def _plots(checks, K, budget, out_dir):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(16, 3.8))
    labels = [f"{c[0]}\n{c[1][:5]}, {c[2].split()[0]}" for c in checks]
    ax[0].bar(range(len(checks)), [max(c[-1], 1e-17) for c in checks])
    ax[0].set_yscale("log")
    ax[0].set_xticks(range(len(checks)), labels, rotation=90, fontsize=6)
    ax[0].set(ylabel="relative error vs closed form", title="pin beam checks")
    ax[1].bar(range(len(K)), list(K.values()))
    ax[1].set_xticks(range(len(K)), list(K), rotation=20, fontsize=8)
    ax[1].set(ylabel="K_t at rated torque [N m/arcmin]", title="RD-40: rigid vs elastic pins")
    names = list(budget["shares"])
    ax[2].barh(names, [budget["shares"][n] for n in names], label="energy share (condensed tangent)")
    rig = [n for n in names if n in budget["rigid_shares"]]
    ax[2].barh(rig, [budget["rigid_shares"][n] for n in rig], height=0.4, label="switch to rigid")
    ax[2].set(xlabel="share of output compliance [-]", title="RD-40, elastic pins: stiffness budget")
    ax[2].legend(fontsize=7)
    casekit.save_figure(fig, out_dir, "pin_bending")


if __name__ == "__main__":
    main()
