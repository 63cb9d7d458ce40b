"""The TE row of ``rvtool validate``: the tolerance Monte Carlo of a shipped design against a published
measured TE of the same series (issue 30, Deliver 3).

For a design with a measurement file (``<design>_measured.toml``, :mod:`rvtool.designs.measured`)
and a tolerance file (``<design>_tolerances.toml``, :mod:`rvtool.variants.rv_tolerances`, the grades
cited in its comments) every variant k (``sample_rv_design(spec, design, k, SEED)``) runs the
quasi-static TE at :data:`TE_TORQUE_FRACTION` x T_R over :func:`te_window` input revolutions; the
distribution of the variants' peak-to-peak TE is compared with each measured specimen's
peak-to-peak (high - low of the printed range). Nothing is tuned: the grades are chosen and cited
before the comparison, and the verdict says where the measurement falls.

The window: the first-stage pattern repeats after every pairing of sun and crank-gear teeth,
lcm(z_sun, z_crank) / z_sun input revolutions (19 for the RV-80E-153: 10 and 38 teeth, 5 crank
revolutions), during which the eccentric direction sweeps the pin ring several times (the crank
revolutions plus the carrier's rotation). A full output revolution (153 input revolutions) costs
8x more; the window's peak-to-peak is a lower bound of the output revolution's (the carrier's slow
drift against the pin ring is left out), stated with every result. The comparison over the output
revolution, the measured definition, is :mod:`rvtool.analysis.te_revolution` (the full mode of
cases/rv/te_measured_rv80e.py), which reads every window off the same curves.
"""
import json
import math
import os
import time

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..units import ARCSEC_PER_RAD

COMMITTED_RESULTS = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "case_results", "rv",
                                 "te_measured_rv80e", "results.json")
"""The committed full results of cases/rv/te_measured_rv80e.py in a checkout (absent from an installed package: then
passed over): ``rvtool validate`` (full) takes its TE rows from them where the inputs digest matches."""

SEED = 2026
"""Seed of the variants (the tolerance Monte Carlo of ``rvtool analyze``, ``MC_SEED``)."""

VARIANTS = (2, 16)
"""Variants under quick and in the full run: 16 resolve the spread of the peak-to-peak well enough to place a
measurement several times above it; a variant costs about 1 min on the shared 2-core machine (measured 68 s at
2 points per mesh under load 9), so the analyze Monte Carlo's 40 would cost most of an hour."""

POINTS_PER_MESH = (2, 4)
"""TE points per first-stage mesh cycle under quick and full: the compared figure is the peak-to-peak of the
low-order error pattern (pitch, eccentricity, pin-seat errors), not the meshing ripple of the nominal reducer
(0.38 arcsec peak-to-peak for rv80e at T_R, 12 points per mesh)."""

TE_TORQUE_FRACTION = 0.1
"""Output torque of the TE [fraction of T_R]: the measurement is a low-speed, low-load test (the paper's load not
transcribed, rv80e_measured.toml); 10 % T_R is a STATED CHOICE that keeps every contact set regular."""


def te_window(design):
    """Input revolutions of the TE window: lcm(z_sun, z_crank_gear) / z_sun (every sun tooth meets every
    crank-gear tooth once)."""
    z1, z2 = int(design.sun_gear.n_teeth), int(design.crank_gear.n_teeth)
    return math.lcm(z1, z2) // z1


def te_angles(design, points_per_mesh):
    """(input angles [rad] of the TE window at ``points_per_mesh`` per first-stage mesh cycle, the model's mesh
    period [rad])."""
    from ..assembly import build
    mesh = float(build(design).mesh_period)
    n_pts = int(round(te_window(design) * 2 * np.pi / mesh * points_per_mesh))
    return np.arange(n_pts) * mesh / points_per_mesh


def te_nominal(design, *, angles, torque):
    """Peak-to-peak TE [rad] of the nominal design over ``angles`` (a unit of the full run)."""
    from ..assembly import build
    from ..protocols.precision import quasi_static_te
    return float(np.ptp(quasi_static_te(build(design), torque=torque, input_angles=angles)["te"]))


def te_variant(design, tolerances, k, *, angles, torque, seed=SEED):
    """The record of tolerance variant ``k`` (index, status, te_pp_rad, error, deviations: largest |draw| per
    field, wall_s): a failed variant is recorded, never dropped (a unit of the full run)."""
    from ..assembly import build
    from ..protocols.precision import quasi_static_te
    from ..variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    spec = load_rv_tolerances(tolerances)
    t0 = time.perf_counter()
    rec = {"index": k, "status": "ok", "error": None, "te_pp_rad": None, "deviations": {}}
    try:
        dv, drawn = sample_rv_design(spec, design, k, seed)
        rec["deviations"] = {f: float(np.max(np.abs(np.asarray(v, float)))) for f, v in drawn.items()}
        qs = quasi_static_te(build(dv), torque=torque, input_angles=angles)
        rec["te_pp_rad"] = float(np.ptp(qs["te"]))
        if not np.isfinite(rec["te_pp_rad"]):
            raise RvtoolInputError("TE is not finite")
    except (SolverFailure, RvtoolInputError) as exc:       # recorded, never dropped silently
        rec.update(status="failed", error=f"{type(exc).__name__}: {exc}", te_pp_rad=None)
    rec["wall_s"] = time.perf_counter() - t0
    return rec


def te_inputs_digest(design, tolerances, measured_path, *, n, points_per_mesh, torque, seed=SEED,
                     input_revolutions=None):
    """SHA-256 of everything a TE comparison depends on (the design's data, the tolerance and measurement files'
    bytes, the variant count, resolution, torque and seed, and the run length: None, the window of
    :func:`te_window`; else the input revolutions of :mod:`rvtool.analysis.te_revolution`'s runs): a run whose
    results carry the same digest computed the same figures (``rvtool validate`` takes them from the committed
    te_measured_rv80e results)."""
    import dataclasses
    from .workunits import digest, file_digest
    payload = {"design": dataclasses.asdict(design), "tolerances": file_digest(tolerances),
               "measured": None if measured_path is None else file_digest(measured_path), "n": int(n),
               "points_per_mesh": points_per_mesh, "torque": float(torque), "seed": seed}
    if input_revolutions is not None:        # the output revolution (the window's digest is unchanged)
        payload.update(over="output revolution", input_revolutions=float(input_revolutions))
    return digest("te.comparison", payload)


WINDOW_TEXT = ("the {n}-input-revolution sun/crank-gear window (--quick: a lower bound of the measured output "
               "revolution's peak-to-peak)")
"""How the quick rows name their window (the full rows: one output revolution, the measured definition)."""


def te_variants(design, tolerances, *, n, points_per_mesh, torque, seed=SEED, log=None, runner=None, defer=False):
    """Peak-to-peak TE [rad] of n tolerance variants (and of the nominal design): a dict with ``nominal_pp``,
    ``records`` (:func:`te_variant`) and ``angles``. ``runner`` (a :class:`rvtool.analysis.workunits.UnitRunner`):
    the nominal TE and each variant are units of it, keyed by the digest of their inputs; ``defer``: return a
    callable that waits for them (they are submitted now)."""
    import dataclasses
    from .workunits import UnitRunner, digest, file_digest
    angles = te_angles(design, points_per_mesh)
    own = runner is None
    if own:
        runner = UnitRunner(workers=1, log=log)
    base = {"design": dataclasses.asdict(design), "tolerances": file_digest(tolerances), "angles": angles,
            "torque": float(torque), "seed": seed}
    f_nom = runner.submit(te_nominal, design, angles=angles, torque=torque, kind="te_nominal",
                          key=digest("te.nominal", {k: v for k, v in base.items() if k not in ("tolerances", "seed")}))
    f_var = [runner.submit(te_variant, design, tolerances, k, angles=angles, torque=torque, seed=seed,
                           kind="te_variant", key=digest("te.variant", {**base, "k": k})) for k in range(n)]

    def finish():
        records = []
        for f in f_var:
            rec = f.result()
            records.append(rec)
            if log:
                pp = "failed" if rec["te_pp_rad"] is None else f"{rec['te_pp_rad'] * ARCSEC_PER_RAD:.3f} arcsec"
                log(f"  TE variant {rec['index'] + 1}/{n}: {pp} ({rec['wall_s']:.1f} s)")
        return {"nominal_pp": f_nom.result(), "records": records, "n_points": len(angles), "angles": angles}
    if own:
        runner.close()
    return finish if defer else finish()


def te_sensitivity(design, tolerances, *, points_per_mesh, torque, draws=1, seed=SEED, log=None, fields=None):
    """One-at-a-time sensitivity of the TE peak-to-peak to each error source at its tolerance: for every field
    of the tolerance file, ``draws`` variants carrying that field alone (``sample_rv_design`` of a spec with only
    that field, variants 0 .. draws-1 of the same seed), the TE over the same window. Returns ``{"nominal_pp_arcsec",
    "fields": {field: {"te_pp_arcsec": [...], "median_arcsec", "excess_arcsec" (median minus nominal),
    "deviation": largest |draw|}}, "dominant"}`` (the field of the largest median excess); a variant that fails is
    recorded as None with its error. ``fields``: the names of the fields to run (None: every field of the file;
    a name the file does not carry is an error)."""
    from dataclasses import fields as dc_fields

    from ..assembly import build
    from ..protocols.precision import quasi_static_te
    from ..variants.rv_tolerances import RvToleranceSpec, load_rv_tolerances, sample_rv_design
    spec = load_rv_tolerances(tolerances)
    model = build(design)
    mesh = float(model.mesh_period)
    n_pts = int(round(te_window(design) * 2 * np.pi / mesh * points_per_mesh))
    angles = np.arange(n_pts) * mesh / points_per_mesh
    nominal = float(np.ptp(quasi_static_te(model, torque=torque, input_angles=angles)["te"])) * ARCSEC_PER_RAD
    out = {}
    if fields is not None:
        missing = [f for f in fields if getattr(spec, f, None) is None]
        if missing:
            raise RvtoolInputError(f"sensitivity fields {missing} are not in {tolerances}; valid: "
                                   f"{[f.name for f in dc_fields(spec) if getattr(spec, f.name) is not None]}")
    for f in dc_fields(spec):
        dist = getattr(spec, f.name)
        if dist is None or (fields is not None and f.name not in fields):
            continue
        one = RvToleranceSpec(**{f.name: dist})
        pps, errs, dev = [], [], 0.0
        for k in range(int(draws)):
            t0 = time.perf_counter()
            try:
                dv, drawn = sample_rv_design(one, design, k, seed)
                dev = max(dev, float(np.max(np.abs(np.asarray(drawn[f.name], float)))))
                pp = float(np.ptp(quasi_static_te(build(dv), torque=torque, input_angles=angles)["te"]))
                if not np.isfinite(pp):
                    raise RvtoolInputError("TE is not finite")
                pps.append(pp * ARCSEC_PER_RAD)
                errs.append(None)
            except (SolverFailure, RvtoolInputError) as exc:       # recorded, never dropped silently
                pps.append(None)
                errs.append(f"{type(exc).__name__}: {exc}")
            if log:
                v = "failed" if pps[-1] is None else f"{pps[-1]:.3f} arcsec"
                log(f"  sensitivity {f.name} draw {k}: {v} ({time.perf_counter() - t0:.1f} s)")
        ok = [x for x in pps if x is not None]
        med = float(np.median(ok)) if ok else None
        out[f.name] = {"te_pp_arcsec": pps, "errors": errs, "median_arcsec": med,
                       "excess_arcsec": None if med is None else med - nominal, "deviation": dev}
    ranked = sorted((v["excess_arcsec"], k) for k, v in out.items() if v["excess_arcsec"] is not None)
    return {"nominal_pp_arcsec": nominal, "draws": int(draws), "points_per_mesh": points_per_mesh,
            "fields": out, "dominant": ranked[-1][1] if ranked else None,
            "ranking": [k for _, k in reversed(ranked)]}


def te_distribution(records):
    """min, p5, median, p95, max [arcsec] of the variants' peak-to-peak (None where no variant ran)."""
    x = np.sort([r["te_pp_rad"] * ARCSEC_PER_RAD for r in records if r["te_pp_rad"] is not None])
    if not len(x):
        return None
    return {"n": int(len(x)), "min": float(x[0]), "p5": float(np.percentile(x, 5)), "median": float(np.median(x)),
            "p95": float(np.percentile(x, 95)), "max": float(x[-1])}


def te_rows(measured, dist, note, over=None):
    """One validate-table row per measured specimen: the predicted median peak-to-peak with the variants' range
    as band, against the specimen's measured peak-to-peak; ``over``: the model's TE window, named in the row's
    conditions."""
    rows = []
    for m in measured.transmission_error:
        meas = m.peak_to_peak * ARCSEC_PER_RAD
        r = {"figure": f"te_peak_to_peak ({m.specimen})", "predicted": None if dist is None else dist["median"],
             "unit": "arcsec", "band": None if dist is None else [dist["min"], dist["max"]], "catalogue": meas,
             "catalogue_unit": "arcsec", "kind": "measured", "status": measured.source.status,
             "source": measured.source.citation(),
             "conditions": f"measured range [{m.low_printed:g}, {m.high_printed:g}] {m.unit}; {m.conditions}"
                           + ("" if over is None else f"; model TE over {over}"),
             "note": note}
        if m.model_low is not None:
            r["paper_model_pp"] = (m.model_high - m.model_low) * ARCSEC_PER_RAD
        if dist is None:
            r["verdict"] = "not computed (no variant ran)"
        else:
            r["ratio"] = dist["median"] / meas
            where = ("inside the predicted band" if dist["min"] <= meas <= dist["max"] else
                     "above the predicted band" if meas > dist["max"] else "below the predicted band")
            r["verdict"] = f"measured {where}; predicted median {100 * (r['ratio'] - 1):+.1f} % vs measured"
        if measured.source.status == "transcribed":
            r["verdict"] += " (measurement read through a transcription, not the printed page)"
        rows.append(r)
    return rows


def measured_summary(measured):
    """The measurement file's figures for results.json: source, reading status and each specimen's range [arcsec]."""
    return {"source": measured.source.citation(), "status": measured.source.status,
            "specimens": [{"specimen": m.specimen, "low_arcsec": m.low * ARCSEC_PER_RAD,
                           "high_arcsec": m.high * ARCSEC_PER_RAD,
                           "peak_to_peak_arcsec": m.peak_to_peak * ARCSEC_PER_RAD,
                           "paper_model_pp_arcsec": None if m.model_low is None else
                           (m.model_high - m.model_low) * ARCSEC_PER_RAD, "conditions": m.conditions}
                          for m in measured.transmission_error]}


def te_comparison(design_name, design, rated_torque, *, quick=False, log=print, variants=None, runner=None,
                  defer=False, reuse=None, input_revolutions=None):
    """The TE comparison of a shipped design, or None where it has no measurement or tolerance file: a dict
    with ``rows`` (for the validate table), ``distribution``, ``nominal_pp_arcsec``, ``records``,
    ``settings`` (with ``inputs_digest``, :func:`te_inputs_digest`) and ``measured`` (the file's figures).
    quick: over the window of :func:`te_window` (a lower bound, said in the rows' conditions); else over one
    output revolution, the measured definition, through :mod:`rvtool.analysis.te_revolution`'s units (the nominal
    design and the variants of te_measured_rv80e's full mode, the same unit keys: a ``--resume`` folder of either
    case serves both; ``input_revolutions`` shortens the runs for a smoke test only).
    runner / defer: as :func:`te_variants`. reuse: paths of results.json files of earlier comparisons (the
    committed te_measured_rv80e results): the first whose ``settings.inputs_digest`` equals this comparison's is
    returned instead of computing (``reused_from`` names it); a file that is missing, differs or is not complete
    is passed over."""
    from .. import designs
    from ..designs.measured import load_measured
    meas_name, tol_name = designs.measured_of(design_name), designs.tolerances_of(design_name)
    if meas_name is None or tol_name is None:
        return (lambda: None) if defer else None
    measured = load_measured(meas_name)
    if not measured.transmission_error:
        return (lambda: None) if defer else None
    n = variants if variants is not None else VARIANTS[0 if quick else 1]
    ppm = POINTS_PER_MESH[0 if quick else 1]
    torque = TE_TORQUE_FRACTION * rated_torque
    if quick:
        inputs_digest = te_inputs_digest(design, designs.path(tol_name), designs.path(meas_name), n=n,
                                         points_per_mesh=ppm, torque=torque)
    else:
        from . import te_revolution as TR
        inputs_digest = TR.revolution_inputs_digest(design_name, design, rated_torque, variants=n,
                                                    input_revolutions=input_revolutions)
    for path in reuse or ():
        if not os.path.exists(path):
            continue
        with open(path) as fh:
            prev = json.load(fh)
        if (prev.get("settings", {}).get("inputs_digest") == inputs_digest and "rows" in prev
                and prev.get("complete", True)):
            log(f"validate {design_name}: TE comparison taken from {path} (the same inputs digest)")
            keep = {k: prev[k] for k in ("rows", "distribution", "nominal_pp_arcsec", "records", "n_failed",
                                         "settings", "measured", "wall_s", "mode", "distribution_window",
                                         "complete") if k in prev}
            out = {**keep, "reused_from": {"path": path, "provenance": prev.get("provenance")}}
            return (lambda: out) if defer else out
    t0 = time.perf_counter()
    if not quick:
        return _revolution(design_name, design, rated_torque, n=n, runner=runner, defer=defer, log=log,
                           input_revolutions=input_revolutions, inputs_digest=inputs_digest, t0=t0)
    log(f"validate {design_name}: TE of {n} tolerance variants over {te_window(design)} input revolutions "
        f"({tol_name}.toml) against {meas_name}.toml")
    pending = te_variants(design, designs.path(tol_name), n=n, points_per_mesh=ppm, torque=torque, log=log,
                          runner=runner, defer=True)

    def finish():
        return _te_result(pending(), n, ppm, torque, tol_name, meas_name, measured, design, inputs_digest, t0)
    return finish if defer else finish()


def _revolution(design_name, design, rated_torque, *, n, runner, defer, log, input_revolutions, inputs_digest, t0):
    """The full mode of :func:`te_comparison`: the nominal design and ``n`` variants over the output revolution as
    units of :mod:`rvtool.analysis.te_revolution` on ``runner`` (one of its own where None), assembled as
    te_measured_rv80e's full mode assembles them (its resolution check and sensitivity are that case's)."""
    from . import te_revolution as TR
    from .workunits import UnitRunner
    plan = TR.plan_revolution(design_name, design, rated_torque, variants=n, draws=0, resolution=False,
                              input_revolutions=input_revolutions)
    if plan["settings"]["inputs_digest"] != inputs_digest:      # one definition of the digest: never reached
        raise RuntimeError("te_revolution's plan and validate's TE row disagree on the inputs digest")
    s = plan["settings"]
    log(f"validate {design_name}: TE of {n} tolerance variants over {s['input_revolutions']:g} input revolutions "
        f"(the output revolution: {s['units']} units of te_revolution) against {s['tolerances']}")
    own = runner is None
    if own:
        runner = UnitRunner(workers=1, log=log)
    pending = TR.submit_units(plan["jobs"], runner)
    if own:
        runner.close()

    def finish():
        r = TR.assemble(plan, pending())
        r.pop("curves", None)
        return {**r, "wall_s": time.perf_counter() - t0}
    return finish if defer else finish()


def _te_result(res, n, ppm, torque, tol_name, meas_name, measured, design, inputs_digest, t0):
    dist = te_distribution(res["records"])
    fields = sorted({f for r in res["records"] for f in r["deviations"]})
    note = (f"{n} variants ({tol_name}.toml: {', '.join(fields)}), seed {SEED}; quasi-static TE at "
            f"{TE_TORQUE_FRACTION:g} T_R over {te_window(design)} input revolutions (every sun/crank-gear tooth "
            f"pairing; a lower bound of the output revolution's peak-to-peak), {ppm} points per mesh cycle; "
            f"nominal design {res['nominal_pp'] * ARCSEC_PER_RAD:.3g} arcsec. Error sources the tolerance file "
            "does not carry (the lobes' profile form beyond their pitch, the two wheels' profiles differing in "
            "form, bore and seat form errors) are absent from the prediction; the output side's hole "
            "positions are the carrier's crank-bearing seats (the RV output is the carrier, reached through the "
            "crank bearings only; the wheels' pillar holes carry no load)")
    return {"rows": te_rows(measured, dist, note, over=WINDOW_TEXT.format(n=te_window(design))),
            "mode": "window", "distribution": dist,
            "nominal_pp_arcsec": res["nominal_pp"] * ARCSEC_PER_RAD,
            "records": [{**r, "te_pp_arcsec": None if r["te_pp_rad"] is None else r["te_pp_rad"] * ARCSEC_PER_RAD}
                        for r in res["records"]],
            "n_failed": sum(r["status"] != "ok" for r in res["records"]),
            "settings": {"tolerances": f"{tol_name}.toml", "measured": f"{meas_name}.toml", "variants": n,
                         "tolerances_commit": measured.tolerances_commit,
                         "seed": SEED, "torque_fraction": TE_TORQUE_FRACTION, "torque_Nm": torque,
                         "window_input_revolutions": te_window(design), "points_per_mesh": ppm,
                         "n_points": res["n_points"], "inputs_digest": inputs_digest},
            "measured": measured_summary(measured),
            "wall_s": time.perf_counter() - t0}


def te_plot(te, out_dir):
    """te_measured.png in ``out_dir``: the variants' peak-to-peak histogram with each specimen's measured value
    (and the paper's own model); returns the file name."""
    import os

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x = [r["te_pp_arcsec"] for r in te["records"] if r["te_pp_arcsec"] is not None]
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    w = [r["window_pp_arcsec"] for r in te["records"] if r.get("window_pp_arcsec") is not None]
    bins = np.histogram_bin_edges(x + w, bins=max(3, min(20, len(x) // 2))) if x else None
    if w:           # the output-revolution run: its variants' first 19-revolution window beside it
        ax.hist(w, bins=bins, color="none", edgecolor="C0", hatch="//", lw=0.8,
                label=f"tolerance variants, {te['settings']['window_input_revolutions']}-revolution window")
    if x:
        ax.hist(x, bins=bins, color="0.6", edgecolor="k", lw=0.5, alpha=0.8,
                label="tolerance variants" + (", output revolution" if w else ""))
    if te["nominal_pp_arcsec"] is not None:
        ax.axvline(te["nominal_pp_arcsec"], color="k", ls=":", lw=1, label="nominal design")
    for k, m in enumerate(te["measured"]["specimens"]):
        ax.axvline(m["peak_to_peak_arcsec"], color=f"C{k + 1}", lw=1.5, label=f"measured, {m['specimen']}")
        if m["paper_model_pp_arcsec"] is not None:
            ax.axvline(m["paper_model_pp_arcsec"], color=f"C{k + 1}", lw=1, ls="--",
                       label=f"paper's model, {m['specimen']}")
    ax.set(xlabel="TE peak-to-peak [arcsec]", ylabel="variants",
           title=f"TE: {te['settings']['variants']} variants vs measured ({te['measured']['status']})")
    ax.legend(fontsize=6)
    from matplotlib.ticker import MaxNLocator
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))           # a count: no 0.5 variant
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "te_measured.png"), dpi=110)
    plt.close(fig)
    return "te_measured.png"
