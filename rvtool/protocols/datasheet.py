"""Datasheet with declared allowables (issue 21): the figures a catalogue or a design review asks
for, each with its unit, the declared allowable, pass/fail and a one-line reason. Topology-neutral:
the caller hands in figures computed through the ReducerModel interface; entries that need a
result that was not computed say so ("not computed") instead of a number.

Allowables are a component spec (:class:`rvtool.designs.allowables.Allowables`, a design-review
table such as ``rvtool/designs/rd40_allowables.toml``, loaded with
:func:`rvtool.designs.allowables.load_allowables`).
"""


def entry(value, unit, *, allowable=None, kind=None, reason=""):
    """One datasheet row. kind "max": passes when value <= allowable; "min": value >= allowable;
    None: informative (meets_allowable None). A value None is "not computed" and never passes."""
    if value is None:
        return {"value": None, "unit": unit, "allowable": allowable, "meets_allowable": None, "reason": reason}
    if kind is None:
        return {"value": value, "unit": unit, "allowable": None, "meets_allowable": None, "reason": reason or "declared"}
    ok = bool(value <= allowable) if kind == "max" else bool(value >= allowable)
    word = ("<=" if ok else ">") if kind == "max" else (">=" if ok else "<")
    return {"value": value, "unit": unit, "allowable": allowable, "meets_allowable": ok,
            "reason": reason or f"{value:.4g} {word} {'max' if kind == 'max' else 'min'} {allowable:.4g} {unit}"}


def _declared(value, unit, allowable, kind, reason):
    """A row against an allowable that the review may leave undeclared (None: informative)."""
    if allowable is None:
        return entry(value, unit, reason=f"{reason}; no allowable declared" if value is not None else reason)
    e = entry(value, unit, allowable=allowable, kind=kind)
    if value is not None:
        e["reason"] = f"{e['reason']}: {reason}"
    else:
        e["reason"] = reason
    return e


def datasheet(*, rated_torque, ratio, branch_slopes, secant, lost_motion_arcmin, hertz_peaks, pin_bending_stress,
              bearing_loads, resolution_error, allowables, hysteresis=None, bearing_life=None):
    """The datasheet dict. hertz_peaks: {"pins", "output_pins", "needles"} -> Pa; pin_bending_stress:
    {"pins", "output_pins"} -> the model's ``pin_bending`` dict or None (rigid pins, no assumed
    support); bearing_loads: family -> largest per-contact load [N]; resolution_error: relative
    error of the rated peak pin force at the default resolution. hysteresis: None (not computed)
    or {"loss_arcmin", "repeat_arcmin", "note"} of a closed +-T_rated cycle
    (:mod:`rvtool.protocols.hysteresis_cycles`); bearing_life: None (not computed) or bearing
    name -> {"L10_h" (None: no radial load), "P_m_N", "C_r_N", ...} ({}: no rolling-element loads; ISO 281,
    :func:`rvtool.slow.fatigue.rating_life`). allowables: an :class:`rvtool.designs.allowables.Allowables`."""
    a = allowables
    out = {"rated_torque": entry(rated_torque, "N m"), "ratio": entry(ratio, "-", reason="from the topology")}
    for b, k in branch_slopes.items():
        out[f"stiffness_{b}"] = entry(k, "N m/arcmin", reason="branch fit over 50-100 % T_rated (Eq. stiffness_fit)")
    out["stiffness_secant"] = entry(secant, "N m/arcmin", allowable=a.min_torsional_stiffness, kind="min")
    out["lost_motion"] = entry(lost_motion_arcmin, "arcmin", allowable=a.max_lost_motion, kind="max")
    if hysteresis is None:
        out["hysteresis"] = entry(None, "arcmin", reason="not computed")
    else:
        out["hysteresis"] = _declared(hysteresis["loss_arcmin"], "arcmin", a.max_hysteresis_loss, "max",
                                      f"loop width at zero torque of the second +-T_rated cycle (repeats the first "
                                      f"to {hysteresis['repeat_arcmin']:.2g} arcmin); {hysteresis['note']}")
    for fam, allow in (("pins", a.max_hertz_pins), ("output_pins", a.max_hertz_output_pins),
                       ("needles", a.max_hertz_needles)):
        out[f"hertz_{fam}"] = entry(hertz_peaks.get(fam), "Pa", allowable=allow, kind="max")
    governing = None
    for fam, label in (("pins", "ring pins"), ("output_pins", "output pins")):
        b = (pin_bending_stress or {}).get(fam)
        if b is None:
            out[f"pin_bending_stress_{fam}"] = entry(None, "Pa", allowable=a.max_pin_bending_stress,
                                                     reason=f"not computed: {label} rigid and no support assumed")
            continue
        sup = b["support"]
        e = entry(b["sigma_max_Pa"], "Pa", allowable=a.max_pin_bending_stress, kind="max")
        e["reason"] = (f"{label}: sigma = M/W {b['sigma_max_Pa'] / 1e6:.4g} MPa "
                       f"{'<=' if e['meets_allowable'] else '>'} {a.max_pin_bending_stress / 1e6:.4g} MPa at pin "
                       f"{b['pin']}, z = {1e3 * (b['z_m'] or 0.0):.3g} mm, {sup['model']} at {sup['ends']} m "
                       f"({b['support_source']}); shear stress {b['tau_max_Pa'] / 1e6:.3g} MPa"
                       + (f"; largest over {b['n_states']} states of the TE sequence, at input angle "
                          f"{b['input_angle_deg']:.4g} deg" if "n_states" in b else ""))
        e["shear_stress_Pa"] = b["tau_max_Pa"]
        out[f"pin_bending_stress_{fam}"] = e
        if governing is None or b["sigma_max_Pa"] > out[governing]["value"]:
            governing = f"pin_bending_stress_{fam}"
    out["pin_bending_stress"] = (dict(out[governing]) if governing is not None else
                                 entry(None, "Pa", allowable=a.max_pin_bending_stress,
                                       reason="not computed: rigid pins and no support assumed"))
    for fam, f in bearing_loads.items():
        out[f"load_{fam}"] = entry(f, "N", reason="largest per-contact load at the rated state")
    rated_lives = {b: v for b, v in (bearing_life or {}).items() if v.get("L10_h") is not None}
    if bearing_life is None:
        out["L10"] = entry(None, "h", reason="not computed")
    elif not bearing_life:
        out["L10"] = entry(None, "h", reason="not computed: no rolling-element loads (lumped bearings, or a "
                                            "topology without ISO 281 bearing geometries)")
    elif not rated_lives:
        out["L10"] = entry(None, "h", reason="no bearing carries a radial load at the rated state")
    else:
        b, v = min(rated_lives.items(), key=lambda kv: kv[1]["L10_h"])
        unloaded = sorted(set(bearing_life) - set(rated_lives))
        out["L10"] = _declared(v["L10_h"], "h", a.min_bearing_life, "min",
                               f"ISO 281 rating life of the governing bearing {b} (C_r {v['C_r_N']:.4g} N, mean load "
                               f"P_m {v['P_m_N']:.4g} N over the TE sequence at the rated torque, "
                               f"{v['speed_rpm']:.4g} rpm relative)"
                               + (f"; no radial load on {', '.join(unloaded)} under pure torque" if unloaded else ""))
        out["L10"]["per_bearing_h"] = {k: v["L10_h"] for k, v in bearing_life.items()}
    out["resolution_error"] = entry(resolution_error, "-", allowable=a.max_resolution_error, kind="max",
                                    reason="" if resolution_error <= a.max_resolution_error else
                                    f"rated peak pin force {100 * resolution_error:.3g} % off the refined "
                                    f"resolution (> {100 * a.max_resolution_error:g} %)")
    return out
