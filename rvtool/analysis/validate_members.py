"""The "all members on" rigidity row of ``rvtool validate`` (issue 30): a design's torsional rigidity by the
catalogue's b/a with every member of the torque path switched on, beside the row of the design as its file has it.

The validation designs keep the members added after their inputs were frozen (issue 28, Deliver 4) off. Each such
member and the new inputs it needs are listed in ``rvtool/designs/<design>_members.toml``:

* ``[members]``: design-file tables merged into the design (the switches: the wheel bodies, the ring pins' grooves,
  the ported carrier, crank torsion, and the housing and crank bending where the file keeps them off);
* ``[members.derived]``: geometry that follows from the design: the wheels' pillar holes, one per carrier pillar,
  concentric with it (``carrier.structure.pillar_circle_radius``, at ``pillar_hole_angle_deg``), of radius
  pillar radius + eccentricity + ``members.pillar_running_gap`` (the wheel orbits the pillar without touching it);
* ``[[assumed]]``: the new inputs with their ranges and sources (the :mod:`rvtool.designs.catalogue` schema; keys
  ``members.*`` are inputs of the derivation above, every other key a dotted design-file key). The row takes
  every input at the MIDDLE of its range; the ranges were committed before any all-members-on figure was
  computed, and the file records that commit as ``assumptions_commit`` (:func:`members_commit`).

**Rigidity.** b/a on the catalogue's torque points T_1 < T_2 (:func:`rvtool.analysis.validate.rigidity_points`)
on both loading branches, as :func:`rvtool.protocols.catalogue.torsional_rigidity` reads the loop: the loading
path (:class:`~rvtool.solver.torque_path.ContinuationPath`) is driven to +T_1, +T_2, -T_1, -T_2 only. For a
frictionless model (every validation design: ``pin_contact.mu = 0`` and no bearing friction; checked, else
refused) the angle at a torque of one sign is the static equilibrium's, the same on the loop's loading branch
(the points lie clear of the free play), so this is the loop's b/a at four solves instead of a loop
(tests/test_validate_members.py checks it against the loop on rv40e).

**Band.** A Latin hypercube (:mod:`scipy.stats.qmc`) over the design's own assumed ranges (``<design>_assumed.toml``
or the ranges file ``validate`` was given) together with the members' ranges: ``SAMPLES`` (64) samples in the
full run, ``QUICK_SAMPLES`` under quick; failed samples are counted and reported, never dropped silently.

**Valid by construction** (:func:`sample_table`). The ranges are drawn independently, but with the carrier ported
some quantities depend on others, and every draw must be an assembly that exists:

* the carrier plates' inner faces follow the drawn wheels: ``carrier.structure.inner_face_position`` is the
  design's plus the drawn wheels' outer end (max |midplane| + width / 2) minus the design's, i.e. the design's
  axial gap between wheel and plate is kept (before, a draw could put a wheel face inside a plate; nothing
  checked it);
* the tapered rows and the main-bearing rows, at +- ``row_spacing`` / 2, lie axially inside both carrier plates
  (:meth:`rvtool.structure.carrier.CarrierStructure.check_layout`): ``row_spacing`` in
  [2 h, 2 (h + min(flange, end plate))] with h the inner-face position. A row spacing that has an assumed range
  is drawn at its Latin-hypercube fraction u of the part of its cited range [low, high] that this interval
  leaves, [max(low, 2 h), min(high, 2 (h + t_min))], after the plates are drawn: where the cited range lies
  inside the interval (every rv40e draw: its rows are not drawn) the value is ``low + u (high - low)``
  exactly as before; where it does not, it is the same fraction of the feasible part -- not a clamp (no mass
  piles up at the bound) and not a re-draw (every sample is kept). Ranges that leave no feasible part are
  refused naming both keys;
* the crank's stations ``cranks.shaft.supports`` are its tapered rows, +- ``crank_bearing.row_spacing`` / 2 (the
  relation rv40e.toml and rv80e.toml state, and rv80e_assumed.toml's source of the supports' range): where the
  design draws both, the supports follow the placed row spacing and their own Latin-hypercube column is unused
  (before, a draw put the crank's stations and the carrier's seats at independent, even asymmetric, positions:
  an element-wise list range moves both ends by the same fraction).

The central design takes every input at its middle (a feasible assembly; no placement). Before this, 2 of rv80e's
first 8 draws failed (a main row at 33.2 mm outside a 13 mm flange ending at 31.0 mm; cited ranges [50, 70] mm
spacing and [13, 20] mm plates) and 4 put a wheel face inside a plate unnoticed (64 draws: 10 and 21).

**Units, resume and the checkpoint** (:func:`members_rigidity`). Every b/a is a unit of
:class:`rvtool.analysis.workunits.UnitRunner` keyed by the digest of its draw's design table and the catalogue:
``rvtool validate``'s full run and cases/rv/members_band.py run the band on the same runner (a spawn pool of
``--workers``, the store ``<out>/units``, resume folders, the deadline) and share its units. Until session 8
members_band ran the band through a second mechanism of its own, an in-process loop that rewrote a checkpoint JSON
after each draw and checked a deadline before each: the same job (resume by draw digest, stop at a deadline) on one
core. What is left of it is the checkpoint file, now an export: :func:`write_checkpoint` writes the band's finished
draws with their digests (the format of the committed ``checkpoint_<design>.json``, unchanged), and
:func:`checkpoint_results` reads such files, old or new, as draws already solved. The checkpoint stays because it
is what gets committed (the units are pickles of a run folder): validate takes the committed band from it.
"""
import copy
import os
import time

import numpy as np

from ..errors import RvtoolInputError
from ..units import RAD_PER_ARCMIN

SAMPLES = 64
"""Latin-hypercube samples of the full run (issue 28: >= 64)."""

QUICK_SAMPLES = 2
"""Samples under quick (the machinery, not the band's convergence: a sample builds four FE structures)."""

QUICK_NUMERICS = {"wheels": {"structure": {"mesh_size": 0.006, "samples_per_tooth": 4}},
                  "housing": {"structure": {"mesh_size": 0.008}}, "carrier": {"structure": {"mesh_size": 0.008}}}
"""--quick: coarser FE meshes (numerics only; compliance_budget --quick uses the same): the wheels at 6 mm with 4
profile ports per tooth, housing and carrier at 8 mm."""

DERIVED_KEYS = ("members.pillar_running_gap",)

LAYOUT_KEYS = ("crank_bearing.row_spacing", "main_bearing.row_spacing")
"""Row spacings placed inside the carrier plates when drawn (module docstring, :func:`sample_table`)."""

PORT_DEPTH_KEY = "wheels.structure.port_depth"
"""The wheels' port depth, placed clear of the drawn crank bores when drawn (module docstring, :func:`sample_table`)."""

SUPPORTS_KEY = "cranks.shaft.supports"
"""The crank's stations, at its tapered rows: derived from the drawn row spacing (module docstring)."""


def members_name(design):
    """Name of the shipped members file of ``design`` (``<design>_members``), or None."""
    from .. import designs
    name = f"{design}_members"
    return name if name in designs.names() else None


def load_members(name):
    """(switch tables, derived settings, :class:`~rvtool.designs.catalogue.AssumedRanges`, recorded commit or
    None) of a members file (a path or a shipped name)."""
    from ..designs.catalogue import load_assumed, read_data_file
    table, _ = read_data_file(name, "members")
    members = table.get("members")
    if not isinstance(members, dict) or not members:
        raise RvtoolInputError(f"members file {name!r}: [members] must hold the design-file tables that switch the "
                               "members on")
    switches = {k: v for k, v in members.items() if k != "derived"}
    derived = members.get("derived", {})
    return switches, derived, load_assumed(name), table.get("assumptions_commit")


def _merge(base, over):
    out = copy.deepcopy(base)
    for k, v in over.items():
        out[k] = _merge(out.get(k, {}), v) if isinstance(v, dict) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def members_table(table, switches, derived, values, numerics=None):
    """The design table with the members on: ``switches`` merged, ``values`` {key: value} set (the members'
    inputs; ``members.*`` keys feed the derivation), the pillar holes derived (module docstring), ``numerics``
    (mesh sizes) merged last."""
    t = _merge(table, switches)
    gap = None
    for k, v in values.items():
        if k == "members.pillar_running_gap":
            gap = float(v)
        elif k.startswith("members."):
            raise RvtoolInputError(f"assumed key {k!r}: unknown members input (valid: {list(DERIVED_KEYS)} or a "
                                   "design-file key)")
        else:
            node = {}
            for part in reversed(k.split(".")):
                node = {part: node} if node != {} else {part: v}
            t = _merge(t, node)
    if derived.get("pillar_hole_count"):
        if gap is None:
            raise RvtoolInputError("members.derived.pillar_hole_count needs the assumed input "
                                   "members.pillar_running_gap")
        cs = t["carrier"]["structure"]
        holes = {"count": int(derived["pillar_hole_count"]), "circle_radius": cs["pillar_circle_radius"],
                 "radius": cs["pillar_radius"] + t["wheels"]["eccentricity"] + gap,
                 "angle_deg": float(derived.get("pillar_hole_angle_deg", 0.0))}
        t = _merge(t, {"wheels": {"structure": {"pillar_holes": holes}}})
    return _merge(t, numerics or {})


def _wheel_end(table):
    """Axial outer end [m] of the wheels (max |midplane| + width / 2) of a design table."""
    w = table["wheels"]
    return max(abs(float(z)) for z in w["midplanes"]) + 0.5 * float(w["width"])


def row_interval(table):
    """(low, high) [m] of a row spacing whose rows at +- spacing / 2 lie inside both carrier plates of the design
    ``table`` (:meth:`rvtool.structure.carrier.CarrierStructure.plates`)."""
    cs = table["carrier"]["structure"]
    h = float(cs["inner_face_position"])
    return 2.0 * h, 2.0 * (h + min(float(cs["flange_thickness"]), float(cs["end_plate_thickness"])))


_ROWS_CLASH = ("leaves no spacing whose rows lie inside the drawn carrier plates", "the cited ranges of the row "
               "spacing, carrier.structure.inner_face_position and the plate thicknesses cannot coexist")


def placed_value(a, u, interval, clash=_ROWS_CLASH, open_high=False):
    """The value of the assumed input ``a`` at its fraction ``u`` of the part of [low, high] inside ``interval``
    (module docstring): ``a.at(u)`` where the range lies inside; refused where nothing of it does (``clash``: what
    is missing, which ranges cannot coexist; ``open_high``: the interval's upper end is excluded)."""
    lo, hi = max(float(a.low), interval[0]), min(float(a.high), float(interval[1]))
    if lo == float(a.low) and hi == float(a.high):
        return a.at(u)
    if not (lo < hi if open_high else lo <= hi):
        raise RvtoolInputError(f"assumed range of {a.key} [{a.low}, {a.high}] {a.unit} {clash[0]} (feasible "
                               f"[{interval[0]:.6g}, {interval[1]:.6g}] m): {clash[1]}")
    return lo + float(u) * (hi - lo)


_PORT_CLASH = ("leaves no port depth clear of the drawn crank bores and holes", "the cited ranges of the port depth, "
               "the eccentric bearing (inner radius + roller diameter = crank bore), the pins, the eccentricity, the "
               "crank radius's gears and the pillar holes cannot coexist")


def port_depth_interval(t):
    """(0, limit) [m]: the port depths :func:`rvtool.assembly.wheel_body.wheel_geometry` accepts for the design
    table ``t`` (below half the ligament between root circle and crank bore, holes inside root less depth; the
    limit itself excluded: a fraction u < 1 of the Latin hypercube never reaches it)."""
    from ..assembly.topologies import design_from_table
    from ..assembly.wheel_body import port_depth_limit
    return 0.0, min(port_depth_limit(design_from_table(t)))


def sample_table(table, base, members_inputs, u, switches, derived, numerics=None):
    """The design table of one Latin-hypercube draw ``u`` (fractions: the design's ``base`` inputs, then the
    members' ``members_inputs``), valid by construction (module docstring): the plates' inner faces follow the
    drawn wheels and every drawn row spacing is placed inside the drawn plates."""
    from ..designs.catalogue import set_key
    t, deferred = table, []
    for a, uj in zip(base, u[:len(base)]):
        if a.key in LAYOUT_KEYS:
            deferred.append((a, uj))
        else:
            t = set_key(t, a.key, a.at(uj))
    vals = {a.key: a.at(uj) for a, uj in zip(members_inputs, u[len(base):])}
    t = members_table(t, switches, derived, vals, numerics)
    port = [(a, uj) for a, uj in zip(members_inputs, u[len(base):]) if a.key == PORT_DEPTH_KEY]
    ported = t.get("carrier", {}).get("body") == "ported"
    if ported:
        shift = _wheel_end(t) - _wheel_end(table)
        if shift != 0.0:
            h = float(t["carrier"]["structure"]["inner_face_position"]) + shift
            t = set_key(t, "carrier.structure.inner_face_position", h)
    for a, uj in deferred:
        t = set_key(t, a.key, placed_value(a, uj, row_interval(t)) if ported else a.at(uj))
    drawn = {a.key for a in base}
    if ported and SUPPORTS_KEY in drawn:
        # the crank's stations are its tapered rows: +- crank_bearing.row_spacing / 2 (the design files' relation)
        half = 0.5 * float(t["crank_bearing"]["row_spacing"])
        t = set_key(t, SUPPORTS_KEY, [-half, half])
    if t.get("wheels", {}).get("body") == "ported":
        # the wheel's port depth clear of the drawn crank bores (after every other input: the bores, pins, gears)
        for a, uj in port:
            t = set_key(t, a.key, placed_value(a, uj, port_depth_interval(t), _PORT_CLASH, open_high=True))
    return t


def check_frictionless(design):
    """Refuse a design whose loading branches depend on history (friction): the four-solve b/a needs none."""
    mu = design.pin_contact.mu
    bf = getattr(getattr(design, "bearing_friction", None), "model", "none")
    if mu > 0 or bf != "none":
        raise RvtoolInputError(f"the all-members-on row reads b/a at four static solves, valid for a frictionless "
                               f"model only; got pin_contact.mu = {mu}, bearing_friction.model = {bf!r} (valid: 0 "
                               "and 'none')")


def rigidity_ba(design, catalogue):
    """{"value": b/a [N m/arcmin] (mean of the loading branches), "per_branch", "angles_arcmin", "torques_Nm"}
    on the catalogue's points (module docstring)."""
    from ..assembly import build
    from ..assembly.rv.wheel_path import network_counters
    from ..protocols import catalogue as C
    from .validate import rigidity_points
    check_frictionless(design)
    pts, _ = rigidity_points(catalogue)
    T_R = catalogue.test.rated_torque
    t1, t2 = (p * T_R for p in pts)
    torques = np.array([t1, t2, -t1, -t2])
    model = build(design)
    path = C.ContinuationPath(model)
    angles = np.array([path.go_to(float(t)) for t in torques])
    labels = ["pos_loading", "pos_loading", "neg_loading", "neg_loading"]
    r = C.torsional_rigidity(torques, angles, labels, torque_points=(t1, t2))
    return {"value": r.value * RAD_PER_ARCMIN, "per_branch": {k: v * RAD_PER_ARCMIN for k, v in r.per_branch.items()},
            "torques_Nm": torques.tolist(), "angles_arcmin": (angles / RAD_PER_ARCMIN).tolist(),
            "networks": network_counters(model), "solver": path.stats()}


def _sample(args):
    table, catalogue = args
    from ..assembly.topologies import design_from_table
    c0 = time.process_time()
    try:
        r = rigidity_ba(design_from_table(table), catalogue)
        r["cpu_s"] = time.process_time() - c0          # build included (this process's CPU seconds)
        return r, None
    except Exception as exc:       # a failed variant is counted and reported
        return None, f"{type(exc).__name__}: {exc}"


def members_commit(name):
    """The commit recorded in the members file (``assumptions_commit``) and the last commit touching it."""
    from .. import designs
    from .validate import assumptions_commit
    _, _, _, recorded = load_members(name)
    last, date = assumptions_commit([designs.path(name)])
    return recorded, last, date


def band_fractions(d, n, seed=0):
    """The (n, d) Latin-hypercube fractions of the band (:mod:`scipy.stats.qmc`, ``seed``)."""
    from scipy.stats import qmc
    return qmc.LatinHypercube(d=d, seed=seed).random(n) if n > 0 else np.zeros((0, d))


def band_inputs(design, base_assumed=None):
    """(the design's assumed inputs, the members' inputs, switches, derived settings) of the band, in the order
    of its Latin-hypercube columns."""
    switches, derived, assumed, _ = load_members(members_name(design))
    base = list(base_assumed.inputs) if base_assumed is not None else []
    return base, list(assumed.inputs), switches, derived


def sampled_tornado(design, base_assumed, sample_values, *, keys=8, seed=0, planned=None):
    """The tornado of the all-members-on b/a ESTIMATED from the band's own samples (no extra solve): the inputs
    screened by |Spearman rho| of their Latin-hypercube fraction with b/a, then a least-squares fit
    b/a = c + sum_k beta_k (u_k - 1/2) over the ``keys`` largest (at most one per six finished samples); each
    input's ends are c -+ beta_k / 2 (its range's low and high end, the others at their middle fractions), with
    the fit's standard error of beta_k and R^2. A row spacing's fraction is of its feasible part
    (:func:`sample_table`); the crank supports (derived) are left out. None with fewer than 12 finished
    samples. ``planned``: the band's planned sample count where ``sample_values`` are its first draws only."""
    from scipy.stats import spearmanr
    base, members, _, _ = band_inputs(design, base_assumed)
    inputs = base + members
    U = band_fractions(len(inputs), planned or len(sample_values), seed)[:len(sample_values)]
    ok = [i for i, v in enumerate(sample_values) if v is not None]
    if len(ok) < 12:
        return None
    y = np.array([sample_values[i] for i in ok])
    screen = {}
    for j, a in enumerate(inputs):
        if a.key == SUPPORTS_KEY and any(b.key == "crank_bearing.row_spacing" for b in base):
            continue
        rho = spearmanr(U[ok, j], y).statistic if np.ptp(y) > 0 else 0.0
        screen[a.key] = float(np.nan_to_num(rho))
    k = min(keys, len(ok) // 6)
    chosen = sorted(screen, key=lambda q: -abs(screen[q]))[:k]
    col = {a.key: j for j, a in enumerate(inputs)}
    X = np.column_stack([np.ones(len(ok))] + [U[ok, col[q]] - 0.5 for q in chosen])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ coef
    dof = max(len(ok) - X.shape[1], 1)
    s2 = float(res @ res) / dof
    se = np.sqrt(np.diag(s2 * np.linalg.inv(X.T @ X)))
    r2 = 1.0 - float(res @ res) / float(((y - y.mean()) ** 2).sum())
    a_of = {a.key: a for a in inputs}
    tornado = {q: {"low": a_of[q].low, "high": a_of[q].high, "at_low": float(coef[0] - 0.5 * coef[i + 1]),
                   "at_high": float(coef[0] + 0.5 * coef[i + 1]), "swing": float(coef[i + 1]),
                   "swing_standard_error": float(se[i + 1]), "spearman_rho": screen[q]}
               for i, q in enumerate(chosen)}
    return {"baseline": float(coef[0]), "tornado": tornado, "r_squared": r2, "residual_std": float(np.sqrt(s2)),
            "samples_used": len(ok), "tornado_keys": k,
            "screening_spearman_rho": dict(sorted(screen.items(), key=lambda kv: -abs(kv[1]))),
            "method": (f"estimated from the {len(ok)} finished Latin-hypercube samples, no extra solve: least squares "
                       f"b/a = c + sum beta_k (u_k - 1/2) over the {k} inputs of largest |Spearman rho| (u_k the "
                       "input's fraction of its range; a row spacing's of its feasible part); ends c -+ beta_k / 2 "
                       "(at_low, at_high), swing beta_k with its standard error; R^2 of the fit")}


def members_tornado(design, table, catalogue, base_assumed, sample_values, *, keys=4, seed=0, quick=True,
                    log=print, planned=None, workers=1):
    """One-at-a-time tornado of the all-members-on b/a (as ``validate``'s): the band's samples (``sample_values``,
    None where failed, drawn by :func:`band_fractions` with ``seed``) screen the inputs by |Spearman rho| of
    each column's fraction against b/a; the ``keys`` largest are each set to the fraction 0 and 1 of its range,
    every other input at 1/2, through :func:`sample_table` (valid by construction: a row spacing's fraction is
    of its feasible part), beside that baseline (every fraction 1/2). The crank supports' column is not an
    input (derived from the row spacing) and is left out of the screening. ``workers``: processes over the
    2 keys + 1 independent b/a (validate.map_samples; one process: in order, as before)."""
    from scipy.stats import spearmanr
    from ..designs.catalogue import get_key
    t0 = time.perf_counter()
    base, members, switches, derived = band_inputs(design, base_assumed)
    inputs = base + members
    numerics = QUICK_NUMERICS if quick else None
    U = band_fractions(len(inputs), planned or len(sample_values), seed)[:len(sample_values)]
    ok = [i for i, v in enumerate(sample_values) if v is not None]
    y = np.array([sample_values[i] for i in ok])
    screen = {}
    for j, a in enumerate(inputs):
        if a.key == SUPPORTS_KEY and any(b.key == "crank_bearing.row_spacing" for b in base):
            continue
        rho = spearmanr(U[ok, j], y).statistic if len(ok) >= 3 and np.ptp(y) > 0 else 0.0
        screen[a.key] = float(np.nan_to_num(rho))
    chosen = sorted(screen, key=lambda k: -abs(screen[k]))[:keys]
    col = {a.key: j for j, a in enumerate(inputs)}

    from .validate import map_samples

    def table_at(k=None, f=0.5):
        x = np.full(len(inputs), 0.5)
        if k is not None:
            x[col[k]] = f
        return sample_table(table, base, members, x, switches, derived, numerics)
    log(f"validate {design}: all-members-on tornado over {len(chosen)} of {len(screen)} inputs "
        f"({2 * len(chosen) + 1} b/a, {workers} worker(s))")
    # the baseline, then each chosen input at the fraction 0 and 1: independent b/a (failures counted, as samples)
    tables = [table_at()] + [table_at(k, f) for k in chosen for f in (0.0, 1.0)]
    a_of = {a.key: a for a in inputs}
    res = map_samples(_sample, [(t, catalogue) for t in tables], workers, log)
    vals = [None if r is None else r["value"] for r, _ in res]
    errs = [e for _, e in res]
    baseline, base_err = vals[0], errs[0]
    tornado = {}
    for i, k in enumerate(chosen):
        ta, tb = tables[1 + 2 * i], tables[2 + 2 * i]
        va, vb = vals[1 + 2 * i], vals[2 + 2 * i]
        if k in DERIVED_KEYS:       # an input of the derivation (members.*), not a key of the design table
            lo, hi = a_of[k].at(0.0), a_of[k].at(1.0)
        else:                       # the table's value: a row spacing is placed in its feasible part
            lo, hi = get_key(ta, k), get_key(tb, k)
        tornado[k] = {"low": lo, "high": hi, "at_low": va, "at_high": vb,
                      "spearman_rho": screen[k], "errors": [e for e in errs[1 + 2 * i:3 + 2 * i] if e]}
        log(f"  {k}: {va} .. {vb}")
    return {"baseline": baseline, "baseline_error": base_err, "tornado": tornado, "tornado_keys": len(chosen),
            "screening_spearman_rho": dict(sorted(screen.items(), key=lambda kv: -abs(kv[1]))),
            "selection": (f"the {len(chosen)} inputs of largest |Spearman rank correlation| of their Latin-"
                          f"hypercube fraction with b/a over the {len(ok)} finished samples (screening; |rho| "
                          f"below about {2 / np.sqrt(max(len(ok) - 1, 1)):.2f} is within two standard errors of "
                          "0); each at the fraction 0 and 1 of its range, the others at 1/2 (baseline)"),
            "wall_s": time.perf_counter() - t0}


def table_digest(table):
    """SHA-256 (hex) of a design table (:func:`rvtool.analysis.workunits.json_sha256`): the identity of a draw
    in a band's checkpoint."""
    from .workunits import json_sha256
    return json_sha256(table)


def central_table(design, table, quick):
    """The all-members-on design table at the middles of every members range (the row's central design), on the
    quick meshes where ``quick``; None where the design has no members file."""
    name = members_name(design)
    if name is None:
        return None
    switches, derived, assumed, _ = load_members(name)
    return members_table(table, switches, derived, {a.key: a.middle for a in assumed.inputs},
                         QUICK_NUMERICS if quick else None)


def members_budget(table, rated_torque):
    """The compliance budget at T_R (input angle 0) of an all-members-on design table
    (:func:`rvtool.protocols.budget.stiffness_budget`: each path's strain-energy share of the output compliance,
    the rigid-switch shares, the tangent K_t [N m/arcmin]): every member's share, the column of issue 30's
    "validate shows every member's share" (cases/rv/compliance_budget.py checks these shares against switching
    each member on alone)."""
    from ..assembly import build
    from ..assembly.topologies import design_from_table
    from ..protocols.budget import stiffness_budget
    from ..solver.static import StaticSolver
    model = build(design_from_table(table))
    model.set_output_torque(-np.sign(model.ratio) * rated_torque)
    b = stiffness_budget(model, StaticSolver(model).solve(0.0))
    return {"K_t_Nm_per_arcmin": float(b["K_t_Nm_per_arcmin"]), "shares": b["shares"],
            "rigid_shares": b["rigid_shares"]}


def checkpoint_key(design, samples, seed, quick):
    """The key of a band's checkpoint (cases/rv/members_band.py): the design, the planned draws and the meshes, as
    readable text (the committed checkpoint_rv80e.json records ``"rv80e samples=64 seed=0 quick=True"``); not a
    digest: each draw in it is identified by its :func:`table_digest`."""
    return f"{design} samples={samples} seed={seed} quick={quick}"


def checkpoint_results(path, key):
    """{draw digest: finished result} of a band checkpoint (:func:`write_checkpoint`) under ``key`` (empty where
    the file is missing, has another key or no digests): the draws a later run takes instead of solving them,
    matched by the digest of their design table, never by position. ``path``: a path, None, or a list of them
    (the first file that has a draw gives it)."""
    import json
    if path is None:
        return {}
    if not isinstance(path, (str, os.PathLike)):
        out = {}
        for p in reversed(list(path)):
            out.update(checkpoint_results(p, key))
        return out
    if not os.path.exists(path):
        return {}
    with open(path) as fh:
        prev = json.load(fh)
    if prev.get("key") != key or prev.get("digests") is None:
        return {}
    return {d: tuple(r) for d, r in zip(prev["digests"], prev["results"]) if r is not None and r[0] is not None}


def write_checkpoint(path, key, digests, results):
    """A band checkpoint: JSON ``{"key", "of", "results", "digests"}``, ``results[k]`` the (result, error) of the
    draw of digest ``digests[k]`` or None where it did not finish (the format of the committed
    docs/case_results/rv/members_band/checkpoint_<design>.json, read by :func:`checkpoint_results`). Written to a
    temporary file and renamed, so a stop never leaves half a file."""
    import json
    tmp = f"{path}.tmp"
    with open(tmp, "w") as fh:
        json.dump({"key": key, "of": len(digests), "results": list(results), "digests": list(digests)}, fh,
                  default=lambda o: o.tolist() if hasattr(o, "tolist") else float(o))
    os.replace(tmp, path)


def members_rigidity(design, table, catalogue, base_assumed=None, *, quick=False, samples=None, seed=0, workers=1,
                     log=print, checkpoint=None, checkpoint_out=None, deadline=None, runner=None, short_band=None,
                     defer=False):
    """The all-members-on row (module docstring): a dict with ``rows`` (validate's table rows), ``central``
    (:func:`rigidity_ba` at the middles), ``band``, the samples and failures, the members file and its commit;
    None where the design has no members file.

    Every b/a (the central design's and each draw's) is a unit of ``runner`` (a
    :class:`rvtool.analysis.workunits.UnitRunner`; None: one of ``workers`` processes with ``deadline``, epoch
    seconds, storing nothing), keyed by the digest of its draw's design table and the catalogue file (``members.ba``
    units: ``rvtool validate``'s full run and cases/rv/members_band.py share them). ``checkpoint`` (a path or a
    list of paths) is READ: band checkpoints (:func:`write_checkpoint`; the committed one of members_band) whose
    draws are taken where their digest matches (:func:`checkpoint_results`; the same sampler,
    :func:`sample_table`, the same draws), the others are solved (``reused_from_checkpoint`` counts the draws
    taken). ``checkpoint_out``: the band's checkpoint written there once its units are gathered (every finished
    draw, taken or solved). A unit not started before the runner's deadline: with ``short_band`` (default: where
    this function owns its runner) the band ends at the draws before it (``samples_done`` of ``samples``: the
    first draws), else :class:`~rvtool.analysis.workunits.DeadlineReached` is raised (validate lists the design as
    incomplete). ``defer``: return a callable that waits for the units and returns the row (the units are
    submitted now), so the caller can submit its other units first."""
    from .workunits import DeadlineReached, UnitRunner, digest, file_digest
    name = members_name(design)
    if name is None:
        return (lambda: None) if defer else None
    t0 = time.perf_counter()
    switches, derived, assumed, _ = load_members(name)
    recorded, last, date = members_commit(name)
    numerics = QUICK_NUMERICS if quick else None
    mid = {a.key: a.middle for a in assumed.inputs}
    base = list(base_assumed.inputs) if base_assumed is not None else []
    inputs = base + list(assumed.inputs)
    n = samples if samples is not None else (QUICK_SAMPLES if quick else SAMPLES)
    U = band_fractions(len(inputs), n, seed)

    def table_of(u):
        return sample_table(table, base, assumed.inputs, u, switches, derived, numerics)
    own = runner is None
    if own:
        runner = UnitRunner(workers=workers, deadline=deadline, log=log)
    short = own if short_band is None else bool(short_band)
    # the central design (every input at its middle) first, then the samples
    log(f"validate {design}: all members on ({name}), central b/a and {n} Latin-hypercube samples over "
        f"{len(inputs)} ranges ({runner.workers} worker(s))")
    items = ([(members_table(table, switches, derived, mid, numerics), catalogue)]
             + [(table_of(u), catalogue) for u in U])
    key = checkpoint_key(design, n, seed, quick)
    prior = checkpoint_results(checkpoint, key)
    cat_id = file_digest(catalogue.path)
    digests = [table_digest(it[0]) for it in items]
    futures, done = [], [0]
    reused = sum(dg in prior for dg in digests)
    if checkpoint is not None:
        paths = [checkpoint] if isinstance(checkpoint, (str, os.PathLike)) else list(checkpoint)
        log(f"  {reused}/{len(items)} b/a taken from {', '.join(map(str, paths))} (the same draws by digest)")
    tw = time.perf_counter()

    def progress(f):          # a line as a b/a solved here finishes (not one taken from the store)
        if f.exception() is None and runner.counts["run"] > done[0]:
            done[0] = runner.counts["run"]
            err = f.result()[1]
            log(f"  {done[0]} b/a solved ({time.perf_counter() - tw:.0f} s)" + (f": {err}" if err else ""))
    try:
        for it, dg in zip(items, digests):
            if dg in prior:
                futures.append(prior[dg])
            else:
                f = runner.submit(_sample, it, key=digest("members.ba", {"table": dg, "catalogue": cat_id}),
                                  kind="members_ba")
                f.add_done_callback(progress)
                futures.append(f)
    except BaseException:
        if own:
            runner.close()
        raise

    def finish():
        try:
            got = []
            for f in futures:
                try:
                    got.append(f if isinstance(f, tuple) else f.result())
                except DeadlineReached:
                    got.append(None)
        finally:
            if own:
                runner.close()
        if checkpoint_out is not None:
            write_checkpoint(checkpoint_out, key, digests, got)
        if None in got:
            if not short:
                raise DeadlineReached(f"validate {design}: {got.count(None)} of {len(got)} all-members-on b/a not "
                                      "started before the deadline")
            log(f"  deadline reached: {len(got) - got.count(None)}/{len(got)} b/a done, the rest not started")
        res = got[:got.index(None)] if None in got else got
        return _members_row(design, name, catalogue, res, n, base, assumed, switches, derived, recorded, last, date,
                            numerics, mid, inputs, U, seed, quick, t0, reused)
    return finish if defer else finish()


def _members_row(design, name, catalogue, res, n, base, assumed, switches, derived, recorded, last, date, numerics,
                 mid, inputs, U, seed, quick, t0, reused):
    from .validate import catalogue_rows, rigidity_points
    if not res:
        raise RvtoolInputError(f"validate {design}: deadline reached before the all-members-on central design")
    central, err = res[0]
    if central is None:
        raise RvtoolInputError(f"validate {design}: the all-members-on central design failed: {err}")
    values = [None if r is None else r["value"] for r, _ in res[1:]]
    failures = [e for _, e in res[1:] if e]
    ok = [v for v in values if v is not None]
    band = [float(min(ok)), float(max(ok))] if ok else None
    pts, pts_source = rigidity_points(catalogue)
    note = (f"ALL MEMBERS ON ({name}.toml: {', '.join(sorted(switches))} switched on, new inputs at the middles of "
            f"their ranges, fixed at {recorded or last}); b/a on the loading branches at {pts} T_R: {pts_source}; "
            f"band: {n} Latin-hypercube samples over {len(inputs)} ranges ({len(base)} of the design, "
            f"{len(assumed.inputs)} of the members)" + ("; --quick meshes" if quick else ""))
    rows = catalogue_rows("torsional_rigidity", central["value"], "N m/arcmin", catalogue, band, note)
    for r in rows:
        r["figure"] = "torsional_rigidity_all_members_on"
    return {"rows": rows, "central": central, "band": band, "samples": n, "samples_done": len(values),
            "sample_values": values,
            "sample_networks": [None if r is None else r["networks"] for r, _ in res[1:]],
            "sample_cpu_s": [None if r is None else r["cpu_s"] for r, _ in res[1:]],
            "failures": failures, "keys": [a.key for a in inputs], "U": U.tolist(),
            "members_file": f"{name}.toml", "switches": switches, "derived": derived,
            "inputs_at_middle": mid, "assumptions_commit": recorded, "last_commit_touching_members": last,
            "last_commit_date": date, "quick_numerics": numerics, "seed": seed, "wall_s": time.perf_counter() - t0,
            "reused_from_checkpoint": reused}
