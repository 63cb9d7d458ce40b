"""``rvtool validate [DESIGN]``: a shipped design against its catalogue (issue 28).

For every shipped design with catalogue data (``rvtool/designs/<design>_catalogue.toml``, and its
`assumed` ranges ``<design>_assumed.toml``; :mod:`rvtool.designs.catalogue`) a table predicted vs
catalogue -- value, source with edition and page, the catalogue's test conditions -- for:

* torsional rigidity b/a, lost motion and hysteresis loss by the catalogue's own definitions
  (:mod:`rvtool.protocols.catalogue`) on one repeating loop over the catalogue's limits +-T_R;
* the rated life at T_R: ISO 281 L10 of the needle bearings (eccentric journals) and of the
  crank bearings (each tapered row) at the catalogue's rated output speed, against the
  catalogue's rated life (radial loads of the rated static state at input angle 0);
* contact pressures against the allowables of ``<design>_allowables.toml`` where the model
  declares Hertz peaks;

and: the hysteresis curve (PNG), the compliance budget at the rated state
(:func:`rvtool.protocols.budget.stiffness_budget`), the rigidity of another ratio variant (the
same frame with another first stage of the same centre distance: the catalogue lists one
rigidity per frame), an uncertainty band from a Latin hypercube (:mod:`scipy.stats.qmc`) over the
`assumed` ranges with a one-at-a-time tornado, the fraction of those variants within the
catalogue's lost-motion maximum, and the ``assumptions_commit`` (the last commit that touched the
design or its assumed ranges: the values are fixed before the comparison, issue 28).

Nothing here is tuned: the catalogue's figures are read, compared and reported, pass or miss.
"""
import json
import math
import os
import subprocess
import time
from pathlib import Path

import numpy as np

from ..errors import RvtoolInputError
from ..units import RAD_PER_ARCMIN

SAMPLES = 64
"""Latin-hypercube samples of the full run (issue 28: >= 64)."""

QUICK_SAMPLES = 4
"""Samples under ``quick`` (the machinery, not the band's convergence)."""

REPEAT_TOLERANCE_ARCMIN = 1e-4
"""Declared bound on the difference of the two loops [arcmin] (the Newton tolerance moves a level
by ~1e-7 arcmin; cases/cycloid/hysteresis_friction.py)."""

DEFAULT_RIGIDITY_POINTS = (0.5, 1.0)
"""b/a torque points [fraction of T_R] where the catalogue file gives none: a STATED CONVENTION
(rvtool's datasheet secant, rd40_allowables.toml: "catalogue secant (50-100 % T_R)"), not the
catalogue's own points, which were not read (rv40e/rv80e_catalogue.toml say so); every result
names the points it used and where they come from."""

QUICK_TORNADO_KEYS = 1
"""Under quick the tornado covers the first this many `assumed` keys of the file (2 loops each)."""

FULL_STEP, QUICK_STEP, SAMPLE_STEP = 0.0625, 0.5, 0.5
"""Level spacing of the central loop (full, quick) and of each sample's loop [fraction of T_R]
(the catalogue's points and the +-3 %, 2 %, 1 % levels are added to every one; b/a and the
mid-points are read at levels, so the spacing changes only the curve's plot; measured on rv40e:
the figures at 0.25 and 0.0625 agree to 1e-11 arcmin). A sample runs the preload and one cycle
(the central loop shows the cycles repeat: Masing)."""


def validated_designs():
    """Shipped designs with a catalogue file."""
    from .. import designs
    return [n for n in designs.design_names() if designs.catalogue_of(n)]


def assumptions_commit(paths):
    """(commit hash, date) of the last commit that touched any of ``paths``, or (None, reason)."""
    try:
        root = Path(paths[0]).resolve().parent
        out = subprocess.run(["git", "log", "-1", "--format=%H %cI", "--", *[str(Path(p).resolve()) for p in paths]],
                             cwd=root, capture_output=True, text=True, timeout=30)
        if out.returncode != 0 or not out.stdout.strip():
            return None, "not in a git checkout (or the files are not committed)"
        h, d = out.stdout.split()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", *[str(Path(p).resolve()) for p in paths]],
                               cwd=root, capture_output=True, text=True, timeout=30).stdout.strip()
        return h, d + ("; UNCOMMITTED changes to the design or its assumed ranges" if dirty else "")
    except (OSError, subprocess.SubprocessError) as exc:
        return None, f"git unavailable: {exc}"


def rigidity_points(catalogue):
    """(points [fraction of T_R], where they come from)."""
    pts = catalogue.test.rigidity_torque_points
    if pts is not None:
        return pts, f"the catalogue's own points ({os.path.basename(catalogue.path)}, test.rigidity_torque_points)"
    return DEFAULT_RIGIDITY_POINTS, ("NOT the catalogue's points (the catalogue file gives none): the stated "
                                     "convention 50-100 % T_R (rvtool.analysis.validate.DEFAULT_RIGIDITY_POINTS)")


def _loop(design, catalogue, step, *, repeat=True):
    """The catalogue loop of ``design``: two cycles with the repeatability check (``repeat``), or
    the first cycle only (:func:`rvtool.protocols.catalogue.catalogue_loop`, for the samples)."""
    from ..assembly import build
    from ..protocols import catalogue as C
    t = catalogue.test
    pts, _ = rigidity_points(catalogue)
    seq = C.catalogue_sequence(t.rated_torque, rigidity_points=pts,
                               lost_motion_fraction=t.lost_motion_torque_fraction, step=step)
    path = C.ContinuationPath(build(design))
    if not repeat:
        return C.catalogue_loop(path, seq, rigidity_points=pts, lost_motion_fraction=t.lost_motion_torque_fraction)
    return C.catalogue_loops(path, seq, rigidity_points=pts, lost_motion_fraction=t.lost_motion_torque_fraction,
                             repeat_tolerance=REPEAT_TOLERANCE_ARCMIN * RAD_PER_ARCMIN)


def _figures(r):
    m = r["metrics"]
    return {"torsional_rigidity": m.rigidity.value * RAD_PER_ARCMIN, "lost_motion": m.lost_motion / RAD_PER_ARCMIN,
            "hysteresis_loss": m.hysteresis_loss.value / RAD_PER_ARCMIN}


def _sample(args):
    """One Latin-hypercube or tornado point: (figures, None) or (None, error message)."""
    table, catalogue = args
    from ..assembly.topologies import design_from_table
    try:
        return _figures(_loop(design_from_table(table), catalogue, SAMPLE_STEP, repeat=False)), None
    except Exception as exc:       # a failed variant is counted and reported, never dropped silently
        return None, f"{type(exc).__name__}: {exc}"


def _map(fn, items, workers, log=None):
    """fn over items (in order), in ``workers`` processes; ``log`` gets a line per finished item."""
    if workers <= 1 or len(items) < 2:
        it = (fn(i) for i in items)
        pool = None
    else:
        from concurrent.futures import ProcessPoolExecutor
        pool = ProcessPoolExecutor(max_workers=workers)
        it = pool.map(fn, items)
    try:
        return _collect(it, len(items), log)
    finally:
        if pool is not None:
            pool.shutdown()


def _collect(results, n, log=None, checkpoint=None):
    """``results`` (an iterable of (figures, error) of ``n`` items, in order) as a list: a line per finished item
    to ``log``, ``checkpoint`` (JSON) rewritten with the results so far after each (:func:`_map`, :func:`_gather`)."""
    out = []
    t0 = time.perf_counter()
    for k, r in enumerate(results):
        out.append(r)
        if log is not None:
            err = "" if r[1] is None else ": " + r[1]
            log(f"  {k + 1}/{n} done ({time.perf_counter() - t0:.0f} s){err}")
        if checkpoint is not None:
            with open(checkpoint, "w") as fh:
                json.dump(_jsonable({"done": len(out), "of": n, "results": out,
                                     "wall_s": time.perf_counter() - t0}), fh)
    return out


def ratio_variant(table):
    """(table, ratio) of the same frame with another first stage: the sun gains 6 teeth and the
    crank gear loses 6 (the centre distance and the divisibility of z_sun + z_crank by the crank
    count are kept), ratio 1 + z_crank / z_sun z_pins."""
    from ..designs.catalogue import set_key
    zs, zc = int(table["sun_gear"]["n_teeth"]), int(table["crank_gear"]["n_teeth"])
    zb = int(table["pins"]["n_pins"])
    zs2, zc2 = zs + 6, zc - 6
    ratio = 1.0 + zc2 / zs2 * zb
    t = set_key(set_key(table, "sun_gear.n_teeth", zs2), "crank_gear.n_teeth", zc2)
    return set_key(t, "ratio_target", ratio), ratio


LIFE_STATES, QUICK_LIFE_STATES = 8, 3
"""Rated states (input angles equally spaced over one crank revolution relative to the carrier) of the
ISO 281 mean load: a needle bearing's radial load turns and varies with the crank (measured on rv80e at
one state: 0.55 to 5.6 kN over its six needle bearings)."""


def crank_revolution_input_angle(design, model):
    """Input angle [rad] of one crank revolution relative to the carrier: the input turns by
    (i / (i - 1)) z_crank / z_sun revolutions relative to the ground while the crank turns once
    relative to the carrier (ratio i = omega_in / omega_out)."""
    i = abs(float(model.ratio))
    return 2 * math.pi * design.crank_gear.n_teeth / design.sun_gear.n_teeth * i / (i - 1.0)


def bearing_lives(design, model, states, catalogue):
    """ISO 281 L10 [h] of each needle bearing (eccentric journal) and crank-bearing row at the rated
    ``states`` (input angles equally spaced over one crank revolution, equal times at constant
    speed: the mean load P_m = (mean P^p)^(1/p), ISO 281), at the catalogue's rated output speed:
    both turn with the crank relative to the carrier (and the wheel), at (i - 1) z_sun / z_crank
    times the output speed. Radial load of a bearing: |sum F_j n_j| over its observed rows (the
    tapered rows' axial preload is not in P: a lower bound of P, an upper bound of the life)."""
    from ..slow import fatigue as Fa
    from ..slow.fatigue import RatingGeometry
    eb, cb = design.eccentric_bearing, design.crank_bearing
    crank_speed = (abs(float(model.ratio)) - 1.0) * design.sun_gear.n_teeth / design.crank_gear.n_teeth \
        * catalogue.test.rated_output_speed
    needle = RatingGeometry(element="roller", n_elements=eb.n_rollers, element_diameter=eb.roller_diameter,
                            pitch_diameter=2 * eb.inner_radius + eb.roller_diameter, roller_length=eb.roller_length)
    rows = {}
    for r_i, row in enumerate(cb.rows):
        rows[f"row{r_i}"] = RatingGeometry(element="roller", n_elements=row.n_rollers,
                                           element_diameter=row.roller_diameter, pitch_diameter=row.pitch_diameter,
                                           roller_length=row.roller_length, contact_angle=float(row.cup_angle))
    loads = {}
    for q in states:
        for fam, key_of in (("eccentric_bearings", lambda i: i.split("/")[0]),
                            ("crank_bearings", lambda i: "/".join(i.split("/")[:2]))):
            ob = model.observe(q, model_family(model, fam))
            groups = {}
            for j, rid in enumerate(ob.ids):
                groups.setdefault(key_of(rid), []).append(j)
            for name, idx in groups.items():
                loads.setdefault((fam, name), []).append(
                    Fa.radial_load_from_elements(ob.normal_force[idx], ob.normal[idx]))
    out = {}
    for (fam, name), P in sorted(loads.items()):
        g = needle if fam == "eccentric_bearings" else rows[name.split("/")[1]]
        P = np.asarray(P)
        Pm = Fa.mean_equivalent_load(float(np.sum(P ** g.life_exponent)), float(P.size), g.life_exponent)
        row = {"family": fam, "C_r_N": g.dynamic_load_rating(), "P_m_N": Pm, "P_max_N": float(P.max()),
               "P_min_N": float(P.min()), "states": int(P.size), "speed_rpm": crank_speed * 30 / math.pi,
               "L10_h": None}
        if Pm > 0:
            row["L10_h"] = Fa.rating_life(g, Pm, crank_speed).L10_hours
        out[name] = row
    return out


def contact_pressures(design, model, q):
    """Largest Hertz line-contact peak p0 [Pa] at state q: ring pins (the wheel profile's local
    curvature, :func:`rvtool.pressure.state.candidates`) and needle rollers on the eccentric journal
    (the higher-pressure race: roller and journal both convex, R = 1 / (1/r_roller + 1/r_journal)),
    per observed slice p0^2 = F E* / (pi R b) with b the slice length and E* = E / (2 (1 - nu^2))
    (equal steels; the convention of :mod:`rvtool.pressure`)."""
    from ..pressure.state import candidates
    out = {}
    try:
        out["pins"] = max(c.hertz_peak for w in range(design.n_wheels) for c in candidates(model, q, "pins", w))
    except (RvtoolInputError, ValueError, AttributeError):
        pass
    eb, mat = design.eccentric_bearing, design.material
    ob = model.observe(q, model_family(model, "eccentric_bearings"))
    r_roll, r_j = 0.5 * eb.roller_diameter, eb.inner_radius
    R = 1.0 / (1.0 / r_roll + 1.0 / r_j)
    b = eb.roller_length / eb.n_slices
    e_star = mat.youngs_modulus / (2.0 * (1.0 - mat.poisson_ratio ** 2))
    out["needles"] = float(math.sqrt(float(ob.normal_force.max()) * e_star / (math.pi * R * b)))
    return out


def model_family(model, value):
    for f in model.families:
        if f.value == value:
            return f
    raise RvtoolInputError(f"the model has no contact family {value!r} (valid: {[f.value for f in model.families]})")


MOMENT_SAMPLES, QUICK_MOMENT_SAMPLES = 16, 4
"""Latin-hypercube samples of the moment-rigidity band over the main bearing's `assumed` ranges."""


def tilting_bodies_rigidity(design, test):
    """The moment rigidity [N m/arcmin] with the wheels and the cranks tilting as well
    (``bodies.wheel_coordinates`` / ``crank_coordinates = "spatial"``, issue 32): the moment then also
    passes through the cranks and wheels to the ring pins. Returns {"bodies",
    "moment_rigidity_Nm_per_arcmin", "convention"} or {"bodies", "error"} (a side figure)."""
    from ..assembly import build
    from ..assembly.spec import replace as replace_design
    from ..errors import RvtoolInputError
    from ..protocols.moment_rigidity import moment_rigidity
    bodies = {"carrier_coordinates": "spatial", "wheel_coordinates": "spatial", "crank_coordinates": "spatial"}
    try:
        try:
            model = build(replace_design(design, bodies=bodies))
        except RvtoolInputError:       # a design whose cranks cannot tilt (named in the builder): planar cranks
            bodies.pop("crank_coordinates")
            model = build(replace_design(design, bodies=bodies))
        res = moment_rigidity(model, test)
        return {"bodies": sorted(bodies), "moment_rigidity_Nm_per_arcmin": res.rigidity_arcmin,
                "convention": res.convention}
    except Exception as exc:           # reported, not fatal
        return {"bodies": sorted(bodies), "error": f"{type(exc).__name__}: {exc}"}


def moment_rigidity_figure(design, catalogue, assumed, *, quick=False):
    """The moment-rigidity row (issue 32): :func:`rvtool.protocols.moment_rigidity.moment_rigidity`
    on the design with a spatial carrier (a ported housing replaced by the rigid one: the main-bearing
    seats are grounded in both; a ported carrier likewise by the rigid one: its seats are planar ports,
    :mod:`rvtool.assembly.carrier`), the reference moment the catalogue's allowable moment (else T_R),
    the band over the main bearing's `assumed` ranges (bearing alone, rigid housing). Returns
    {"rows", "result", "band", "reference_moment_Nm", "note"}; an error is reported in the row, not raised
    (a side figure, as the ratio variant)."""
    from ..assembly.spec import replace as replace_design
    from ..assembly import build
    from ..protocols.moment_rigidity import MomentRigidityTest, main_bearing_band, moment_rigidity, spatial_design
    allow = catalogue.figure("allowable_moment")
    m_ref = allow.value_si if allow is not None else catalogue.test.rated_torque
    ref_note = (f"reference moment {m_ref:g} N m: {catalogue.citation(allow)}" if allow is not None else
                f"reference moment T_R = {m_ref:g} N m (the catalogue file prints no allowable moment)")
    try:
        d = design if getattr(design.housing, "model", "rigid") != "ports" else replace_design(design,
                                                                                               housing={"model": "rigid"})
        if getattr(getattr(d, "carrier", None), "body", "rigid") != "rigid":
            d = replace_design(d, carrier={"body": "rigid"})
        test = MomentRigidityTest(reference_moment=m_ref, axial_force=2000.0)
        res = moment_rigidity(build(spatial_design(d)), test)
        band = None
        if assumed is not None:
            band = main_bearing_band(d.main_bearing, assumed, test,
                                     samples=QUICK_MOMENT_SAMPLES if quick else MOMENT_SAMPLES)
        value, note = res.rigidity_arcmin, f"{res.convention}; {ref_note}; axial stiffness {res.axial_stiffness:.4g} N/m"
        detail = {"result": res.to_dict(), "band": band, "tilting_bodies": tilting_bodies_rigidity(d, test)}
    except Exception as exc:           # reported in the table, not fatal
        value, note, band = None, f"not computed: {type(exc).__name__}: {exc}", None
        detail = {"result": None, "band": None, "error": note}
    rows = _rows("moment_rigidity", value, "N m/arcmin", catalogue,
                 None if band is None or band["band"] is None else list(band["band"]), note)
    for r in rows:
        if r["catalogue"] is None:
            r["verdict"] = "no catalogue value"
    return {"rows": rows, "reference_moment_Nm": m_ref, **detail}


def _rows(key, predicted, unit, catalogue, band=None, note=""):
    """One table row per catalogue figure of ``key`` (a max and a typical value are two rows). The
    figure's value is converted to ``unit`` through SI (the catalogue file's unit as printed)."""
    from ..designs.catalogue import UNITS
    figs = catalogue.figures_of(key)
    base = {"figure": key, "predicted": predicted, "unit": unit, "band": band, "note": note}
    if not figs:
        return [{**base, "catalogue": None, "kind": None, "source": "the catalogue file prints none", "conditions": "",
                 "status": None, "verdict": "no figure"}]
    out = []
    for f in figs:
        r = dict(base)
        value = f.value_si / UNITS[unit]
        r.update(catalogue=value, catalogue_unit=unit, kind=f.kind, source=catalogue.citation(f),
                 conditions=f.conditions, status=f.status,
                 catalogue_range=None if f.low is None else [f.low * UNITS[f.unit] / UNITS[unit],
                                                            f.high * UNITS[f.unit] / UNITS[unit]])
        if predicted is None or not np.isfinite(predicted):
            r["verdict"] = "not computed"
        elif f.kind == "max":
            r["verdict"] = "within max" if predicted <= value else "above max"
        elif f.kind == "min" or key == "rated_life":
            r["verdict"] = "meets" if predicted >= value else "short"
        else:
            r["ratio"] = predicted / value
            r["verdict"] = f"{100 * (predicted / value - 1):+.1f} % vs typical"
            if r["catalogue_range"] is not None:
                lo, hi = r["catalogue_range"]
                r["verdict"] += "; inside the printed range" if lo <= predicted <= hi else "; outside the printed range"
            if band is not None:
                r["verdict"] += "; catalogue in band" if band[0] <= value <= band[1] else "; catalogue outside band"
        if f.status == "not_reread":
            r["verdict"] += " (catalogue value not re-read from the page)"
        out.append(r)
    return out


def screening(keys, U, results):
    """(key indices ordered by importance, {key: max |Spearman rho|}) of the Latin-hypercube samples:
    each key's fraction of its range against the rigidity and the lost motion (failed samples left
    out); the order of a one-at-a-time tornado over fewer keys than the file has."""
    from scipy.stats import spearmanr
    ok = [i for i, (f, _) in enumerate(results) if f is not None]
    score = np.zeros(len(keys))
    if len(ok) >= 3:
        for fig in ("torsional_rigidity", "lost_motion"):
            y = np.array([results[i][0][fig] for i in ok])
            for j in range(len(keys)):
                rho = spearmanr(U[ok, j], y).statistic if np.ptp(y) > 0 else 0.0
                score[j] = max(score[j], abs(float(np.nan_to_num(rho))))
    order = [int(j) for j in np.argsort(-score, kind="stable")]
    return order, {keys[j]: float(score[j]) for j in order}


def validate(design="rv40e", *, quick=False, out_dir=None, samples=None, workers=1, seed=0, tornado_keys=None,
             assumed=None, band=True, variant=True, te=True, members=True, members_samples=None, members_workers=None,
             log=print, runner=None, members_checkpoint=None, members_quick_numerics=None, te_reuse=None):
    """Validate one shipped design against its catalogue; returns the results dict (and writes
    results.json, report.html and the PNGs to ``out_dir`` when given). samples: Latin-hypercube
    size (default :data:`SAMPLES`, :data:`QUICK_SAMPLES` under quick); workers: processes for the
    samples (the machine is shared: 1 or 2); tornado_keys: one-at-a-time low/high loops for this
    many keys, the most important first by :func:`screening` (None: every key; quick:
    :data:`QUICK_TORNADO_KEYS`); assumed: a ranges file to use instead of the shipped
    ``<design>_assumed.toml`` (its values must be the design's middles too); band, variant: False
    skips the uncertainty band or the ratio variant (said so in the results); te: False skips the TE
    comparison with a published measurement (:mod:`rvtool.analysis.validate_te`; it runs where the design
    ships a ``<design>_measured.toml`` and a tolerance file; over one output revolution, the measured definition,
    through :mod:`rvtool.analysis.te_revolution`'s units on ``runner``, or under ``quick`` over the
    sun/crank-gear window, a lower bound); members: False skips the all-members-on
    rigidity row (:mod:`rvtool.analysis.validate_members`; it runs where the design ships a
    ``<design>_members.toml``), members_samples its Latin-hypercube size (None: that module's default),
    members_workers its processes (None: ``workers``).

    runner: a :class:`rvtool.analysis.workunits.UnitRunner` through which every costly, independent part runs as a
    unit keyed by the digest of its inputs (the central loop, the rated state, the carrier's and the moment's side
    figures, the ratio variant, each Latin-hypercube and tornado loop, each all-members-on b/a, each TE variant,
    the efficiency curve): the full run spreads them over a process pool, stops starting them at a deadline and
    resumes them (cases/rv/validate_rv.py); all of one design's units are submitted before any is waited for,
    except the tornado's, which follow the band's screening. None: a runner of ``workers`` processes (today's
    serial path for 1). A unit not started before the runner's deadline raises
    :class:`~rvtool.analysis.workunits.DeadlineReached` out of this function (the finished units are stored).
    members_checkpoint: a checkpoint of cases/rv/members_band.py whose samples the all-members-on row takes where
    the draw digests match (:func:`rvtool.analysis.validate_members.members_rigidity`); members_quick_numerics:
    the all-members-on row on the quick meshes (None: as ``quick``; the full run of the case passes True, the
    meshes of members_band's band); te_reuse: results.json files of te_measured_rv80e whose TE comparison is taken
    where its inputs digest equals this one's (:func:`rvtool.analysis.validate_te.te_comparison`)."""
    from .workunits import UnitRunner, digest, file_digest
    own_runner = runner is None
    if own_runner:
        runner = UnitRunner(workers=workers, log=log)
    try:
        return _validate(design, quick=quick, out_dir=out_dir, samples=samples, workers=workers, seed=seed,
                         tornado_keys=tornado_keys, assumed=assumed, band=band, variant=variant, te=te,
                         members=members, members_samples=members_samples, members_workers=members_workers, log=log,
                         runner=runner, members_checkpoint=members_checkpoint,
                         members_quick_numerics=members_quick_numerics, te_reuse=te_reuse, digest=digest,
                         file_digest=file_digest)
    finally:
        if own_runner:
            runner.close()


def _central_unit(table, catalogue, step):
    """The central loop (two cycles, repeatability checked) of a design table: a unit."""
    from ..assembly.topologies import design_from_table
    return _loop(design_from_table(table), catalogue, step)


def _rated_unit(table, catalogue, quick):
    """The rated state of a design table (output torque -T_R sign(ratio), input angle 0): its compliance budget,
    Hertz peaks, the bearings' lives over a crank revolution and the model's ratio: a unit."""
    from ..assembly import build
    from ..assembly.topologies import design_from_table
    from ..protocols.budget import stiffness_budget
    from ..solver.static import StaticSolver
    d = design_from_table(table)
    model = build(d)
    model.set_output_torque(-np.sign(model.ratio) * catalogue.test.rated_torque)
    solver = StaticSolver(model)
    q = solver.solve(0.0)
    budget = stiffness_budget(model, q)
    peaks = contact_pressures(d, model, q)
    # the bearings' mean load over a crank revolution (after the budget and pressures of q: the model's
    # input angle moves)
    n_life = QUICK_LIFE_STATES if quick else LIFE_STATES
    span = crank_revolution_input_angle(d, model)
    life_angles = [k * span / n_life for k in range(n_life)]
    life_states = [q] + [solver.solve(a) for a in life_angles[1:]]
    lives = bearing_lives(d, model, life_states, catalogue)
    return {"budget": budget, "peaks": peaks, "lives": lives, "ratio": float(model.ratio), "n_life": n_life}


def _carrier_unit(table, T_R, quick):
    from ..assembly.topologies import design_from_table
    from .budget import carrier_share_figure
    return carrier_share_figure(design_from_table(table), T_R, quick=quick)


def _moment_unit(table, catalogue, assumed, quick):
    from ..assembly.topologies import design_from_table
    return moment_rigidity_figure(design_from_table(table), catalogue, assumed, quick=quick)


def _efficiency_unit(name, table, quick):
    from ..assembly.topologies import design_from_table
    from .losses import validate_efficiency
    return validate_efficiency(name, design_from_table(table), quick=quick)


def _validate(design, *, quick, out_dir, samples, workers, seed, tornado_keys, assumed, band, variant, te, members,
              members_samples, members_workers, log, runner, members_checkpoint, members_quick_numerics, te_reuse,
              digest, file_digest):
    if tornado_keys is None and quick:
        tornado_keys = QUICK_TORNADO_KEYS
    want_band, want_variant = bool(band), bool(variant)
    from .. import designs
    from ..assembly.topologies import design_from_table, read_table
    from ..designs.catalogue import check_assumed_middle, load_assumed, load_catalogue, set_key
    t0 = time.perf_counter()
    cat_name = designs.catalogue_of(design)
    if cat_name is None:
        raise RvtoolInputError(f"design = {design!r} has no catalogue file; valid choices are {validated_designs()}")
    catalogue = load_catalogue(cat_name)
    design_path = designs.path(design)
    table = read_table(design_path)
    assumed_name = assumed or designs.assumed_of(design)
    assumed = load_assumed(assumed_name) if (assumed_name and want_band) else None
    if assumed is not None:
        check_assumed_middle(assumed, table)
    files = [design_path] + ([assumed.path] if assumed else [])
    last_commit, last_date = assumptions_commit(files)
    # the commit that fixed the assumed inputs, as the catalogue file records it (issue 28: made before the
    # first comparison); beside it the last commit that touched the design or its ranges (a later change
    # to an assumed value would show here)
    commit = catalogue.assumptions_commit or last_commit
    d = design_from_table(table)
    T_R = catalogue.test.rated_torque
    if abs(float(getattr(d, "rated_torque", T_R)) - T_R) > 1e-9 * T_R:
        log(f"note: the design's rated_torque {d.rated_torque} differs from the catalogue's T_R {T_R}; the "
            "catalogue's is used")
    n_samples = samples if samples is not None else (QUICK_SAMPLES if quick else SAMPLES)
    # every independent unit of this design is submitted first (a pool runs them together), then waited for
    cat_id = file_digest(catalogue.path)
    assumed_id = None if assumed is None else file_digest(assumed.path)

    def loop_key(t, step, repeat):
        return digest("validate.loop", {"table": t, "catalogue": cat_id, "step": step, "repeat": repeat})
    log(f"validate {design}: central loop, rated state, side figures")
    step_c = QUICK_STEP if quick else FULL_STEP
    f_central = runner.submit(_central_unit, table, catalogue, step_c, key=loop_key(table, step_c, True),
                              kind="central_loop")
    f_rated = runner.submit(_rated_unit, table, catalogue, quick, kind="rated_state",
                            key=digest("validate.rated", {"table": table, "catalogue": cat_id, "quick": quick}))
    f_carrier = runner.submit(_carrier_unit, table, T_R, quick, kind="carrier_share",
                              key=digest("validate.carrier", {"table": table, "T_R": T_R, "quick": quick}))
    f_moment = runner.submit(_moment_unit, table, catalogue, assumed, quick, kind="moment_rigidity",
                             key=digest("validate.moment", {"table": table, "catalogue": cat_id,
                                                            "assumed": assumed_id, "quick": quick}))
    f_variant = None
    if want_variant:
        vt, v_ratio = ratio_variant(table)
        f_variant = runner.submit(_sample, (vt, catalogue), key=loop_key(vt, SAMPLE_STEP, False), kind="loop")
    from .losses import load_efficiency_catalogue, load_friction_set
    f_eff = runner.submit(_efficiency_unit, design, table, quick, kind="efficiency",
                          key=digest("validate.efficiency", {
                              "design": design, "table": table, "quick": quick,
                              "efficiency_catalogue": file_digest(load_efficiency_catalogue().path),
                              "friction_set": file_digest(load_friction_set().path)}))
    # Latin hypercube over the assumed ranges (the tornado follows the band's screening)
    f_lhs = None
    if assumed is not None:
        from scipy.stats import qmc
        keys = [a.key for a in assumed.inputs]
        U = qmc.LatinHypercube(d=len(keys), seed=seed).random(n_samples)    # fractions of each range

        def table_of(u):
            t = table
            for a, uj in zip(assumed.inputs, u):
                t = set_key(t, a.key, a.at(uj))
            return t
        log(f"validate {design}: {n_samples} Latin-hypercube samples ({runner.workers} worker(s))")
        ts = time.perf_counter()
        f_lhs = [runner.submit(_sample, (t, catalogue), key=loop_key(t, SAMPLE_STEP, False), kind="loop")
                 for t in (table_of(u) for u in U)]
    members_row = None
    if members:
        from .validate_members import members_rigidity
        from ..designs.catalogue import load_assumed as _load_assumed
        # the members' band is over the design's OWN assumed ranges (as cases/rv/members_band.py draws it), not
        # over a ranges file given for the base band (rv40e's needle-clearance range)
        own = designs.assumed_of(design)
        base = _load_assumed(own) if own else None
        m_quick = quick if members_quick_numerics is None else bool(members_quick_numerics)
        f_members = members_rigidity(design, table, catalogue, base, quick=m_quick, samples=members_samples,
                                     seed=seed, workers=members_workers or workers, log=log, runner=runner,
                                     checkpoint=members_checkpoint, defer=True)
        from .validate_members import central_table, members_budget
        m_table = central_table(design, table, m_quick)
        f_mbudget = None if m_table is None else runner.submit(
            members_budget, m_table, T_R, kind="members_budget",
            key=digest("validate.members_budget", {"table": m_table, "T_R": T_R}))
    f_te = _te_measured(design, d, T_R, quick=quick, want=te, log=log, runner=runner, reuse=te_reuse)
    # waited for in the order they were submitted
    central = f_central.result()
    fig_c = _figures(central)
    rep = central["repeatability"]
    hl_err = central["metrics"].hysteresis_loss.error
    rated = f_rated.result()
    budget, peaks, lives, n_life = rated["budget"], rated["peaks"], rated["lives"], rated["n_life"]
    carrier_side = f_carrier.result()
    log(f"validate {design}: moment rigidity (spatial carrier)")
    moment = f_moment.result()
    # ratio variant
    log(f"validate {design}: ratio variant" + ("" if want_variant else " skipped"))
    try:
        if not want_variant:
            raise RuntimeError("skipped (variant=False: --quick of the case for a costly design)")
        v_res, v_err = f_variant.result()
        if v_res is None:
            raise RuntimeError(v_err)
        v_fig = v_res
        variant = {"ratio": v_ratio, "ratio_central": rated["ratio"], "rigidity": v_fig["torsional_rigidity"],
                   "rel_diff": v_fig["torsional_rigidity"] / fig_c["torsional_rigidity"] - 1.0,
                   "first_stage": {"sun_gear.n_teeth": vt["sun_gear"]["n_teeth"],
                                   "crank_gear.n_teeth": vt["crank_gear"]["n_teeth"]}}
    except Exception as exc:     # reported in the table, not fatal: the variant is a side check
        if type(exc).__name__ == "DeadlineReached":
            raise
        variant = {"error": f"{type(exc).__name__}: {exc}"}
    # Latin hypercube + tornado over the assumed ranges
    unc = None
    if assumed is not None:
        ck = None
        if out_dir is not None:
            os.makedirs(out_dir, exist_ok=True)
            with open(os.path.join(out_dir, "central_partial.json"), "w") as fh:
                json.dump(_jsonable({"central": fig_c, "repeat_arcmin": rep.max_angle_diff / RAD_PER_ARCMIN,
                                     "bearing_lives": lives, "budget_shares": budget["shares"],
                                     "K_t_Nm_per_arcmin": budget["K_t_Nm_per_arcmin"], "pressures_Pa": peaks,
                                     "ratio_variant": variant, "U": U, "keys": keys}), fh, indent=1)
            ck = os.path.join(out_dir, "samples_partial.json")
        lhs = _gather(f_lhs, log, ck)
        wall_lhs = time.perf_counter() - ts
        order, screen = screening(keys, U, lhs)
        n_tor = len(keys) if tornado_keys is None else min(len(keys), int(tornado_keys))
        chosen = order[:n_tor]
        tornado_pts = []
        for j in chosen:
            for v in (0.0, 1.0):
                x = np.full(len(keys), 0.5)
                x[j] = v
                tornado_pts.append(x)
        log(f"validate {design}: tornado over {n_tor} of {len(keys)} keys ({len(tornado_pts)} loops)")
        tor = _gather([runner.submit(_sample, (t, catalogue), key=loop_key(t, SAMPLE_STEP, False), kind="loop")
                       for t in (table_of(x) for x in tornado_pts)], log,
                      None if ck is None else os.path.join(out_dir, "tornado_partial.json"))
        wall_samples = time.perf_counter() - ts
        res = lhs + tor
        failures = [e for f, e in lhs if f is None]
        ok = [f for f, e in lhs if f is not None]
        band = {k: ([float(min(f[k] for f in ok)), float(max(f[k] for f in ok))] if ok else None)
                for k in ("torsional_rigidity", "lost_motion", "hysteresis_loss")}
        lm_max = catalogue.figure("lost_motion", "max")
        frac = (float(np.mean([f["lost_motion"] <= lm_max.value_si / RAD_PER_ARCMIN for f in ok]))
                if (ok and lm_max) else None)
        tornado = {}
        for i, j in enumerate(chosen):
            a_in = assumed.inputs[j]
            (a, ea), (b, eb_) = tor[2 * i], tor[2 * i + 1]
            tornado[a_in.key] = {"low": a_in.low, "high": a_in.high, "at_low": a, "at_high": b,
                                 "errors": [e for e in (ea, eb_) if e]}
        unc = {"samples": n_samples, "keys": keys, "U": U.tolist(), "figures": [f for f, _ in lhs],
               "tornado_keys": n_tor, "tornado_failures": sum(len(v["errors"]) for v in tornado.values()),
               "screening_abs_spearman": screen, "wall_lhs_s": wall_lhs,
               "tornado_selection": ("all keys" if n_tor == len(keys) else
                                     f"the {n_tor} keys of largest |Spearman rank correlation| with rigidity or lost "
                                     f"motion over the {n_samples} Latin-hypercube samples (screening)"),
               "failures": failures, "band": band, "tornado": tornado, "seed": seed,
               "fraction_within_lost_motion_max": frac, "wall_s": wall_samples,
               "per_sample_s": wall_samples / max(1, len(res)) * runner.workers}
    band = (unc or {}).get("band") or {}
    pts, pts_source = rigidity_points(catalogue)
    rows = (
        _rows("torsional_rigidity", fig_c["torsional_rigidity"], "N m/arcmin", catalogue,
              band.get("torsional_rigidity"),
              f"b/a on the loading branches at {pts} T_R: {pts_source}")
        + _rows("lost_motion", fig_c["lost_motion"], "arcmin", catalogue, band.get("lost_motion"),
                f"mid-points at +-{catalogue.test.lost_motion_torque_fraction:g} T_R")
        + _rows("hysteresis_loss", fig_c["hysteresis_loss"], "arcmin", catalogue, band.get("hysteresis_loss"),
                f"zero-torque width along the unloading branches (extrapolation error "
                f"{(hl_err or 0) / RAD_PER_ARCMIN:.2g} arcmin)"))
    members_budget_row = None
    if members:
        members_row = f_members()
        if f_mbudget is not None:
            members_budget_row = {**f_mbudget.result(), "members_file": (members_row or {}).get("members_file"),
                                  "quick_meshes": bool(m_quick),
                                  "note": "every member of the torque path on (the all-members-on row's central "
                                          "design: its members at the middles of their ranges); energy shares of "
                                          "the output compliance at T_R, input angle 0 (tangent K_t, not b/a)"}
    at = sum(r["figure"] == "torsional_rigidity" for r in rows)               # beside the file's rigidity rows
    rows[at:at] = [] if members_row is None else members_row.pop("rows")
    rows += moment["rows"]
    te_measured = None if f_te is None else f_te()
    rows += (te_measured or {}).get("rows", [])
    log(f"validate {design}: efficiency and no-load running torque (rvtool.analysis.losses)")
    efficiency = dict(f_eff.result())
    rows += efficiency.pop("rows")
    for fam in ("eccentric_bearings", "crank_bearings"):
        vals = [v["L10_h"] for k, v in lives.items() if v["family"] == fam and v["L10_h"] is not None]
        rows += _rows("rated_life", min(vals) if vals else None, "h", catalogue,
                      note=f"{fam}: smallest ISO 281 L10h at T_R, {next(iter(lives.values()))['speed_rpm']:.4g} rpm "
                           f"relative speed, mean load over {n_life} states of a crank revolution (radial load "
                           "only)")
    from ..designs.allowables import load_allowables
    allow_name = f"{design}_allowables" if f"{design}_allowables" in designs.names() else "rd40_allowables"
    al = load_allowables(designs.path(allow_name))
    pressures = {"hertz_peaks_Pa": peaks, "allowables_file": allow_name,
                 "allowables_note": ("the design's own review allowables" if allow_name.startswith(design) else
                                     "no allowables file of this design: rd40_allowables.toml's declared limits "
                                     "(4.0 GPa rolling contacts, ISO 76 static limit; 2.5 GPa case-hardened pins, "
                                     "design practice)"),
                 "rows": {}}
    for k, p in peaks.items():
        lim = getattr(al, f"max_hertz_{k}", None)
        pressures["rows"][k] = {"p0_MPa": p / 1e6, "allowable_MPa": None if lim is None else lim / 1e6,
                                "meets": None if lim is None else bool(p <= lim)}
        rows.append({"figure": f"contact_pressure_{k}", "predicted": p / 1e6, "unit": "MPa", "band": None,
                     "catalogue": None if lim is None else lim / 1e6, "catalogue_unit": "MPa",
                     "kind": "max (allowable)", "status": None,
                     "source": f"{allow_name}.toml (declared allowable, not a catalogue figure)",
                     "conditions": "Hertz line-contact peak at T_R, input angle 0",
                     "verdict": ("no allowable" if lim is None else
                                 "within allowable" if p <= lim else "above allowable"),
                     "note": pressures["allowables_note"]})
    out = {
        "design": design, "catalogue": {"title": catalogue.source.title, "edition": catalogue.source.edition,
                                         "url": catalogue.source.url, "file": os.path.basename(catalogue.path)},
        "test": {"rated_torque_Nm": T_R, "rated_output_speed_rpm": catalogue.test.rated_output_speed_rpm,
                 "rated_life_h": catalogue.test.rated_life_h,
                 "lost_motion_torque_fraction": catalogue.test.lost_motion_torque_fraction,
                 "rigidity_torque_points": catalogue.test.rigidity_torque_points},
        "assumptions_commit": commit,
        "assumptions_commit_source": ("the catalogue file's assumptions_commit" if catalogue.assumptions_commit
                                      else "git: last commit touching the design or its assumed file"),
        "last_commit_touching_inputs": last_commit, "last_commit_date": last_date,
        "uncertainty_note": None if assumed else ("band skipped (band=False)" if not want_band else
                                                  f"no {design}_assumed.toml: the design's inputs are chosen, not "
                                                  "assumed with cited ranges, so no band is computed"),
        "assumed_file": os.path.basename(assumed.path) if assumed else None,
        "table": rows,
        "central": {**fig_c, "repeat_arcmin": rep.max_angle_diff / RAD_PER_ARCMIN, "repeat_passed": bool(rep.passed),
                    "hysteresis_extrapolation_error_arcmin": None if hl_err is None else hl_err / RAD_PER_ARCMIN,
                    "rigidity_per_branch_Nm_per_arcmin": {k: v * RAD_PER_ARCMIN for k, v in
                                                          central["metrics"].rigidity.per_branch.items()},
                    "solver": central["stats"]},
        "bearing_lives": lives, "pressures": pressures,
        "moment_rigidity": {k: v for k, v in moment.items() if k != "rows"},
        "compliance_budget": {"shares": budget["shares"], "K_t_Nm_per_arcmin": budget["K_t_Nm_per_arcmin"],
                              "configuration": {"cranks.shaft.model": d.cranks.shaft.model if d.cranks.shaft else None,
                                                "housing.model": getattr(d.housing, "model", None)
                                                if d.housing else None}},
        "ratio_variant": variant, "uncertainty": unc, "te_measured": te_measured, "efficiency": efficiency,
        "all_members_on": members_row,
        "settings": {"quick": quick, "samples": n_samples, "workers": runner.workers,
                     "central_step": QUICK_STEP if quick else FULL_STEP, "sample_step": SAMPLE_STEP,
                     "rigidity_points": list(rigidity_points(catalogue)[0]),
                     "rigidity_points_source": rigidity_points(catalogue)[1],
                     "repeat_tolerance_arcmin": REPEAT_TOLERANCE_ARCMIN},
        "wall_s": time.perf_counter() - t0,
    }
    # issue 30: the carrier's switch and the ported carrier's share beside the budget of the file's switches
    out["compliance_budget"]["configuration"]["carrier.body"] = getattr(getattr(d, "carrier", None), "body", None)
    out["compliance_budget"]["with_ported_carrier"] = carrier_side
    out["compliance_budget"]["all_members_on"] = members_budget_row
    out["loop"] = {"torque_Nm": central["cycles"][-1]["torque_Nm"].tolist(),
                   "angle_arcmin": (central["cycles"][-1]["angle_rad"] / RAD_PER_ARCMIN).tolist(),
                   "labels": central["cycles"][-1]["labels"],
                   "angle_arcmin_previous": (central["cycles"][-2]["angle_rad"] / RAD_PER_ARCMIN).tolist()}
    if out_dir is not None:
        write(out, out_dir, catalogue)
    return out


def _te_measured(design, d, rated_torque, *, quick, want, log, runner=None, reuse=None):
    """The TE comparison with a published measurement (:func:`rvtool.analysis.validate_te.te_comparison`) as a
    callable returning it (its variants submitted to ``runner`` now), None where ``want`` is False."""
    if not want:
        return None
    from .validate_te import te_comparison
    return te_comparison(design, d, rated_torque, quick=quick, log=log, runner=runner, defer=True, reuse=reuse)


def _gather(futures, log=None, checkpoint=None):
    """The results of ``futures`` in order (as :func:`_map`: a line per item, the checkpoint rewritten)."""
    return _collect((f.result() for f in futures), len(futures), log, checkpoint)


def checks(out):
    """The stated criteria of a run (not agreement with the catalogue): the machinery ran (no
    failed sample), no NaN, the loops repeat, the band contains the central value."""
    c = out["central"]
    vals = [c["torsional_rigidity"], c["lost_motion"], c["hysteresis_loss"]]
    res = {"no_nan": bool(all(np.isfinite(v) for v in vals)), "loops_repeat": bool(c["repeat_passed"])}
    u = out["uncertainty"]
    if u is not None:
        res["no_failed_sample"] = not u["failures"] and not u["tornado_failures"]
        res["band_contains_central"] = bool(all(
            u["band"][k] is not None
            and u["band"][k][0] - 1e-9 * abs(c[k]) <= c[k] <= u["band"][k][1] + 1e-9 * abs(c[k])
            for k in ("torsional_rigidity", "lost_motion", "hysteresis_loss")))
    if out.get("te_measured") is not None:
        res["te_no_failed_variant"] = out["te_measured"]["n_failed"] == 0
    m = out.get("all_members_on")
    if m is not None:
        res["all_members_no_nan"] = bool(np.isfinite(m["central"]["value"]))
        res["all_members_no_failed_sample"] = not m["failures"]
    return res


def write(out, out_dir, catalogue):
    """results.json, hysteresis.png, tornado.png and report.html in ``out_dir``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "results.json"), "w") as fh:      # first: the figures outlive a plot failure
        json.dump(_jsonable(out), fh, indent=1)
    T_R = out["test"]["rated_torque_Nm"]
    lp = out["loop"]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    T, th, lab = np.asarray(lp["torque_Nm"]), np.asarray(lp["angle_arcmin"]), lp["labels"]
    for k, b in enumerate(("neg_unloading", "pos_loading", "pos_unloading", "neg_loading")):
        idx = [i for i, l in enumerate(lab) if l == b]     # one line per branch: none across the free play
        ax.plot(th[idx], T[idx], ".-", lw=0.8, color=f"C{k}", label=f"{b} (second loop)")
    ax.plot(lp["angle_arcmin_previous"], lp["torque_Nm"], "x", ms=4, color="k", label="first loop")
    t = out["test"]["lost_motion_torque_fraction"] * T_R
    for s in (1, -1):
        ax.axhline(s * t, color="gray", lw=0.5, ls=":")
        ax.axhline(s * T_R, color="gray", lw=0.5, ls="--")
    c = out["central"]
    ax.set(xlabel="output torsion angle [arcmin] (input fixed)", ylabel="output torque [N m]",
           title=f"{out['design']}: K {c['torsional_rigidity']:.1f} N m/arcmin, LM {c['lost_motion']:.3f}, "
                 f"HL {c['hysteresis_loss']:.3f} arcmin", ylim=(-1.1 * T_R, 1.1 * T_R))
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "hysteresis.png"), dpi=110)
    plt.close(fig)
    plots = ["hysteresis.png"]
    u = out["uncertainty"]
    if u is not None:
        fig, axs = plt.subplots(1, 3, figsize=(14, 3.2))
        for ax, k in zip(axs, ("torsional_rigidity", "lost_motion", "hysteresis_loss")):
            # largest swing first (the tornado's order)
            keys = sorted(u["tornado"], key=lambda key: -abs(
                (u["tornado"][key]["at_high"] or {}).get(k, c[k]) - (u["tornado"][key]["at_low"] or {}).get(k, c[k])))
            for j, key in enumerate(keys):
                e = u["tornado"][key]
                a = e["at_low"][k] if e["at_low"] else np.nan
                b = e["at_high"][k] if e["at_high"] else np.nan
                ax.barh(j, a - c[k], left=c[k], color="tab:blue", alpha=0.7, label="low" if j == 0 else None)
                ax.barh(j, b - c[k], left=c[k], color="tab:red", alpha=0.7, label="high" if j == 0 else None)
            ax.set_yticks(range(len(keys)), keys, fontsize=6)
            ax.invert_yaxis()
            ax.axvline(c[k], color="k", lw=0.8)
            for f, ls in zip(catalogue.figures_of(k), ("--", ":", "-.")):
                v = f.value_si * (RAD_PER_ARCMIN if k == "torsional_rigidity" else 1.0 / RAD_PER_ARCMIN)
                ax.axvline(v, color="g", lw=1.0, ls=ls, label=f"catalogue ({f.kind})")
            ax.set(title=k, xlabel="N m/arcmin" if k == "torsional_rigidity" else "arcmin")
            ax.legend(fontsize=6)
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, "tornado.png"), dpi=110)
        plt.close(fig)
        plots.append("tornado.png")
    if out.get("te_measured") is not None:
        from .validate_te import te_plot
        plots.append(te_plot(out["te_measured"], out_dir))
    from .losses import efficiency_plot
    plots += efficiency_plot(out, out_dir)
    plots += budget_plot(out, out_dir)
    with open(os.path.join(out_dir, "report.html"), "w") as fh:
        fh.write(report_html(out, out_dir, plots))


def budget_columns(out):
    """{column title: {path: energy share}} of a validate result: the design as its file has it, with the ported
    carrier (side figure) and with every member on, where each was computed."""
    cb = out.get("compliance_budget") or {}
    cols = {}
    if cb.get("shares"):
        cols[f"as the file has it (K_t {cb['K_t_Nm_per_arcmin']:.4g} N m/arcmin)"] = cb["shares"]
    pc = cb.get("with_ported_carrier") or {}
    if pc.get("shares"):
        cols[f"with the ported carrier (K_t {pc['K_t_Nm_per_arcmin']:.4g})"] = pc["shares"]
    am = cb.get("all_members_on") or {}
    if am.get("shares"):
        cols[f"every member on (K_t {am['K_t_Nm_per_arcmin']:.4g})"] = am["shares"]
    return cols


def budget_plot(out, out_dir):
    """budget.png: each path's share of the output compliance at T_R in every budget of the result (the design's
    file, the ported carrier, every member on); returns the file names written."""
    cols = budget_columns(out)
    if not cols:
        return []
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = sorted({p for c in cols.values() for p in c}, key=lambda p: -max(c.get(p, 0.0) for c in cols.values()))
    fig, ax = plt.subplots(figsize=(7.5, 0.3 * len(paths) + 1.8))
    h = 0.8 / len(cols)
    for i, (title, sh) in enumerate(cols.items()):
        ax.barh([j + i * h for j in range(len(paths))], [100 * sh.get(p, 0.0) for p in paths], height=h,
                label=title)
    ax.set_yticks([j + 0.4 - h / 2 for j in range(len(paths))], paths, fontsize=7)
    ax.invert_yaxis()
    ax.axvline(5.0, color="gray", lw=0.6, ls=":", label="5 % (issue 30: a member below may be skipped)")
    ax.set(xlabel="share of the output compliance at T_R [%]", title=f"{out['design']}: compliance budget")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "budget.png"), dpi=110)
    plt.close(fig)
    return ["budget.png"]


def _jsonable(o):
    if isinstance(o, dict):
        return {str(k): _jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_jsonable(v) for v in o]
    if isinstance(o, np.ndarray):
        return _jsonable(o.tolist())
    if isinstance(o, (np.floating, float)):
        return float(o) if np.isfinite(o) else None
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    return o


def table_text(out):
    """The predicted-vs-catalogue table as plain text."""
    lines = [f"{out['design']} vs {out['catalogue']['title']} ({out['catalogue']['edition']}); "
             f"assumptions_commit {out['assumptions_commit']}"]
    for r in out["table"]:
        band = f" band [{r['band'][0]:.4g}, {r['band'][1]:.4g}]" if r.get("band") else ""
        pred = "-" if r["predicted"] is None else f"{r['predicted']:.4g}"
        cat = "-" if r["catalogue"] is None else f"{r['catalogue']:.4g} ({r['kind']})"
        lines.append(f"  {r['figure']:<20} predicted {pred} {r['unit']}{band} | catalogue {cat} | {r['verdict']} | "
                     f"{r['source']} | {r['note']}")
    v = out["ratio_variant"]
    if "rigidity" in v:
        lines.append(f"  ratio variant i = {v['ratio']:.4g}: rigidity {v['rigidity']:.4g} N m/arcmin "
                     f"({100 * v['rel_diff']:+.2f} % vs i = {v['ratio_central']:.4g})")
    pc = out.get("compliance_budget", {}).get("with_ported_carrier")
    if pc and "carrier_share" in pc:
        lines.append(f"  with the ported carrier: K_t {pc['K_t_Nm_per_arcmin']:.4g} N m/arcmin at T_R, carrier share "
                     f"{100 * pc['carrier_share']:.1f} % (tangent budget; the file keeps carrier.body = 'rigid')")
    am = out.get("compliance_budget", {}).get("all_members_on")
    if am and am.get("shares"):
        top = sorted(am["shares"].items(), key=lambda kv: -kv[1])
        lines.append(f"  every member on: K_t {am['K_t_Nm_per_arcmin']:.4g} N m/arcmin at T_R; shares "
                     + ", ".join(f"{k} {100 * v:.1f} %" for k, v in top))
    u = out["uncertainty"]
    if u is not None and u["fraction_within_lost_motion_max"] is not None:
        lines.append(f"  {u['samples']} LHS samples: fraction within the catalogue's lost-motion maximum "
                     f"{u['fraction_within_lost_motion_max']:.3f}; failed samples {len(u['failures'])}")
    return "\n".join(lines)


def report_html(out, out_dir, plots):
    import base64
    import html
    e = html.escape
    rows = "".join(f"<tr><td>{e(r['figure'])}</td><td>{e(_f(r['predicted']))} {e(r['unit'])}</td>"
                   f"<td>{e(_f(r['band'][0]) + ' .. ' + _f(r['band'][1])) if r.get('band') else '-'}</td>"
                   f"<td>{e(_f(r['catalogue']))} {e(r.get('catalogue_unit', ''))} ({e(str(r['kind']))})</td>"
                   f"<td>{e(r['verdict'])}</td><td>{e(r['source'])}</td><td>{e(r['conditions'])}</td>"
                   f"<td>{e(r['note'])}</td></tr>" for r in out["table"])
    imgs = ""
    for p in plots:
        with open(os.path.join(out_dir, p), "rb") as fh:
            imgs += f'<img style="max-width:100%" alt="{e(p)}" src="data:image/png;base64,' \
                    f'{base64.b64encode(fh.read()).decode()}">'
    cols = budget_columns(out)
    budget = ""
    if cols:
        paths = sorted({p for c in cols.values() for p in c}, key=lambda p: -max(c.get(p, 0.0) for c in cols.values()))
        budget = ("<h2>Compliance budget at T_R (energy share of the output compliance, %)</h2>"
                  "<table border=1 cellpadding=3 style='border-collapse:collapse'><tr><th>path</th>"
                  + "".join(f"<th>{e(t)}</th>" for t in cols) + "</tr>"
                  + "".join(f"<tr><td>{e(p)}</td>" + "".join(
                      f"<td>{'-' if p not in c else f'{100 * c[p]:.2f}'}</td>" for c in cols.values()) + "</tr>"
                      for p in paths) + "</table>")
    extra = {k: out[k] for k in ("central", "bearing_lives", "pressures", "compliance_budget", "ratio_variant",
                                 "assumptions_commit", "settings")}
    if out.get("te_measured") is not None:
        extra["te_measured"] = {k: v for k, v in out["te_measured"].items() if k not in ("rows", "records")}
    if out["uncertainty"] is not None:
        extra["uncertainty"] = {k: v for k, v in out["uncertainty"].items() if k not in ("U", "figures")}
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>validate {e(out['design'])}</title></head>"
            f"<body style='font-family:sans-serif;max-width:1200px;margin:2em auto'>"
            f"<h1>{e(out['design'])} against {e(out['catalogue']['title'])}</h1>"
            f"<p>{e(out['catalogue']['edition'])}; assumptions_commit {e(str(out['assumptions_commit']))}</p>"
            "<table border=1 cellpadding=3 style='border-collapse:collapse'><tr><th>figure</th><th>predicted</th>"
            "<th>band (LHS)</th><th>catalogue</th><th>verdict</th><th>source</th><th>test conditions</th>"
            f"<th>note</th></tr>{rows}</table>{budget}{imgs}"
            f"<pre>{e(json.dumps(_jsonable(extra), indent=1))}</pre></body></html>")


def _f(v):
    return "-" if v is None else f"{v:.4g}"


#: public names of the table-row and sample-map helpers (:mod:`rvtool.analysis.validate_members` builds its
#: all-members-on row with them)
catalogue_rows = _rows
map_samples = _map
