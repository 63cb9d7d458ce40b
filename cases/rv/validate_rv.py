"""Shipped RV designs against their catalogues by the catalogue's own definitions (issue 28): `rvtool validate`.

For every shipped design with a <design>_catalogue.toml (rvtool.analysis.validate): a table predicted vs
catalogue (value, source with edition and page, test conditions, reading status) for torsional rigidity b/a,
lost motion and hysteresis loss (rvtool.protocols.catalogue, one repeating loop over +-T_R), the needle- and
crank-bearing ISO 281 L10 at T_R and the catalogue's rated output speed against its rated life, Hertz peaks
against declared allowables; the hysteresis curve (hysteresis.png), the compliance budget at the rated state,
the rigidity of another ratio variant of the same frame, an uncertainty band from 64 Latin-hypercube samples
over the `assumed` ranges with a one-at-a-time tornado (tornado.png), the fraction of those variants within the
catalogue's lost-motion maximum; the assumptions_commit of each design; and (issue 30) the rigidity b/a with every
member of the torque path on (rvtool.analysis.validate_members: wheel bodies, pin grooves, ported carrier, crank
torsion, from <design>_members.toml at the middles of its ranges) with its Latin-hypercube band (64 samples, the
full run; --quick: the central value on the quick meshes, no band).

--quick (a loop of rv80e costs 31 s, of rv40e 4 s): the central loops at 50 % level steps (the catalogue's
levels are in every spacing); rv40e with its ratio variant and a band over the needle clearance range its
shipped tolerance file declares (rv40e_tolerances.toml needle_clearance [0, 3] um; the class design has no
assumed file): 4 Latin-hypercube samples and a 1-key tornado; designs with a shipped assumed file (rv80e):
central loop, lives, pressures and budget only (their 64-sample band and full tornado are the full run's).
Full run (issue 28 Deliver 3, issue 30 Deliver 4): every member on, for both designs: the central loop at 1/16
T_R level steps, the rated state (lives over 8 states of a crank revolution, pressures, the budget of every
switch the file has and the ported carrier's share), the moment rigidity with its 16-sample band, the ratio
variant, the base band (64 Latin-hypercube samples over the assumed ranges: rv80e's 41 cited ranges, rv40e's
needle clearance from its tolerance file) with a one-at-a-time tornado over every assumed key, the all-members-on
row with its 64-sample band on members_band's meshes (its b/a taken from cases/rv/members_band.py's checkpoint
where the draw digests match: ``--members-from``), the TE comparison over one output revolution, the measured
definition (taken from a te_measured_rv80e results.json whose inputs digest matches: ``--te-from``, else the
nominal design and its 16 variants run as rvtool.analysis.te_revolution's units, the same keys as that case's
full mode, so a --resume folder of either case serves both), the
efficiency curve against the catalogue's.

Work is split into independent units (rvtool.analysis.workunits) run on ``--workers N`` spawn processes (one
BLAS thread each), every finished unit stored in ``OUT/units`` under the digest of its inputs; ``--deadline
HH:MM`` (UTC) or ``--budget-s S`` starts no unit once the time left is shorter than the longest unit of its kind
seen so far (so the run ends near the deadline; the running ones finish), ``--resume DIR[,DIR]``
takes the units finished in earlier run folders (by digest, never by position). results.json is written at
every stop with ``complete`` true|false; a design whose units are not all done is listed with what is missing
(rerun the same command with ``--resume`` the previous --out).

passed (stated criteria, NOT agreement with the catalogue, which is reported as it is): the machinery ran
(no failed sample), no NaN, the two loops repeat within 1e-4 arcmin, the band contains the central value
(where a band ran).
"""
import json
import os
import time

# one BLAS thread per process (before NumPy loads): the solves here are small dense systems (a few hundred
# unknowns), where a second OpenBLAS thread on a shared 2-core machine spins instead of computing (measured: a
# 340 x 340 solve with 380 right-hand sides took 22x the CPU time with the default threads under load,
# cases/benchmarks/bench_nested_wheels.py)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from concurrent.futures import ThreadPoolExecutor

import rvtool.analysis.validate as V
import rvtool.analysis.validate_members as VM
from rvtool import casekit, designs
from rvtool.designs.catalogue import load_catalogue


def rv40e_clearance_ranges(out_dir):
    """A ranges file for rv40e from its shipped tolerance file: the needle clearance's uniform range."""
    import tomllib
    with open(designs.path("rv40e_tolerances"), "rb") as fh:
        nc = tomllib.load(fh)["tolerances"]["needle_clearance"]
    path = os.path.join(out_dir, "rv40e_clearance_ranges.toml")
    with open(path, "w") as fh:
        fh.write('format_version = 2\ndesign = "rv40e"\n[[assumed]]\nkey = "eccentric_bearing.radial_clearance"\n'
                 f'low = {nc["low"]!r}\nhigh = {nc["high"]!r}\nunit = "m"\n'
                 'source = "rv40e_tolerances.toml needle_clearance (uniform; chosen there, no third-party source)"\n')
    return path


MEMBERS_FROM = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "case_results", "rv", "members_band")
"""Where the full run looks for members_band's checkpoint_<design>.json (the committed band's own checkpoint)."""

TE_FROM = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "case_results", "rv", "te_measured_rv80e",
                       "results.json")
"""The committed te_measured_rv80e results: the full run takes its TE comparison where the inputs digest matches."""


def design_kwargs(name, quick, out, members_from, te_from):
    """validate's keyword arguments of one design in this case's mode (module docstring)."""
    kw = {}
    if quick:
        if designs.assumed_of(name):
            # the TE row against a measurement runs as its own case under --quick (te_measured_rv80e)
            kw = {"band": False, "variant": False, "te": False}
        elif name == "rv40e":
            kw = {"assumed": rv40e_clearance_ranges(out)}
        # the all-members-on row: its central b/a on the quick meshes (validate_members.QUICK_NUMERICS; about a
        # CPU-minute per design with the nested closures solved as one network, bench_nested_wheels), no band:
        # the band's samples are the full run's
        kw["members_samples"] = 0
        return kw
    if not designs.assumed_of(name):
        kw["assumed"] = rv40e_clearance_ranges(out)
    # the members' band on members_band's meshes and draws: its checkpoint's b/a are taken by draw digest
    kw["members_quick_numerics"] = True
    kw["members_samples"] = VM.SAMPLES
    kw["members_checkpoint"] = os.path.join(members_from, f"checkpoint_{name}.json") if members_from else None
    kw["te_reuse"] = [te_from] if te_from else None
    return kw


QUICK_FROM = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "case_results", "rv", "validate_rv",
                          "results.json")
"""The committed --quick results the full run's rows are set against (``moved_against_quick``)."""


def moved_against_quick(entry, quick_entry):
    """{row label: {"quick", "full", "rel_change", "band_full"}} for every table row with a predicted value in both
    (label: figure, and the catalogue figure's kind where a figure has several rows), plus the all-members-on
    band, which the quick run does not compute: what the full run moved against the committed quick rows."""
    def rows(e):
        out = {}
        for r in e.get("table", []):
            if r.get("predicted") is None:
                continue
            label = r["figure"] if r.get("kind") in (None, "typical") else f"{r['figure']} ({r['kind']})"
            if r["figure"] == "rated_life":          # one row per bearing family: the note names it
                label += f" ({(r.get('note') or '').split(':')[0]})"
            out.setdefault(label, r)
        return out
    q, f = rows(quick_entry), rows(entry)
    moved = {}
    for label, r in f.items():
        if label not in q:
            continue
        a, b = q[label]["predicted"], r["predicted"]
        moved[label] = {"quick": a, "full": b, "rel_change": None if not a else b / a - 1.0,
                        "band_quick": q[label].get("band"), "band_full": r.get("band"), "unit": r.get("unit")}
    return moved


def entry_of(name, res):
    return {"complete": True, "table": res["table"], "central": res["central"], "checks": V.checks(res),
            "assumptions_commit": res["assumptions_commit"], "pressures": res["pressures"],
            "ratio_variant": res["ratio_variant"], "compliance_budget": res["compliance_budget"],
            "bearing_lives": res["bearing_lives"], "uncertainty_note": res["uncertainty_note"],
            "uncertainty": {k: v for k, v in (res["uncertainty"] or {}).items() if k != "U"},
            "settings": res["settings"], "report": f"{name}/report.html",
            "te_measured": res.get("te_measured"), "all_members_on": res.get("all_members_on"),
            "efficiency": res.get("efficiency"), "moment_rigidity": res.get("moment_rigidity")}


def one_design(name, quick, out, runner, members_from, te_from, log):
    """Validate one design through ``runner``: (name, results, None) or (name, None, the unit not started)."""
    from rvtool.analysis.workunits import DeadlineReached
    kw = design_kwargs(name, quick, out, members_from, te_from)
    try:
        # written by the main thread afterwards (matplotlib is not thread-safe): out_dir None here
        res = V.validate(name, quick=quick, out_dir=None, runner=runner, log=lambda m: log(f"[{name}] {m}"), **kw)
    except DeadlineReached as exc:
        return name, None, str(exc)
    except Exception as exc:       # a design that fails is reported (complete: false), the other still written
        import traceback
        traceback.print_exc()
        return name, None, f"failed: {type(exc).__name__}: {exc}"
    return name, res, None


def extra(parser):
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="processes for the units (default: one per design, as the quick run always had)")
    parser.add_argument("--designs", default=None, metavar="LIST", help="comma-separated designs (default: all "
                        "shipped designs with a catalogue file)")
    parser.add_argument("--deadline", default=None, metavar="HH:MM",
                        help="UTC time of day after which no unit is started (results.json says complete: false)")
    parser.add_argument("--budget-s", type=float, default=None, metavar="S",
                        help="seconds from the start after which no unit is started (as --deadline)")
    parser.add_argument("--resume", default=None, metavar="DIRS",
                        help="comma-separated earlier run folders whose finished units (DIR/units) are taken")
    parser.add_argument("--members-from", default=None, metavar="DIR",
                        help="folder of members_band's checkpoint_<design>.json (full run; default "
                             "docs/case_results/rv/members_band; 'none': solve every b/a)")
    parser.add_argument("--te-from", default=None, metavar="FILE",
                        help="a te_measured_rv80e results.json taken where its inputs digest matches (full run; "
                             "default the committed one; 'none': run the variants)")


def deadline_of(args, t_start):
    """Epoch seconds of --deadline (UTC, workunits.deadline_from) or --budget-s from ``t_start``; one of them."""
    from rvtool.analysis.workunits import deadline_from
    if args.deadline and args.budget_s is not None:
        raise SystemExit("--deadline and --budget-s: give one")
    return deadline_from(args.deadline, args.budget_s, now=t_start)


def main(argv=None):
    from rvtool.analysis.workunits import folder_runner
    args = casekit.parse_args(argv, description=__doc__.splitlines()[0], extra=extra)
    t0, t_start = time.perf_counter(), time.time()
    deadline = deadline_of(args, t_start)
    names = args.designs.split(",") if args.designs else V.validated_designs()
    workers = args.workers if args.workers is not None else len(names)
    if workers < 1:
        raise SystemExit(f"--workers = {workers} is outside the valid range [1, inf)")
    os.makedirs(args.out, exist_ok=True)
    members_from = None if (args.members_from or "").lower() == "none" else (args.members_from or MEMBERS_FROM)
    te_from = None if (args.te_from or "").lower() == "none" else (args.te_from or TE_FROM)
    runner = folder_runner(args.out, workers=workers, deadline=deadline,
                           resume=args.resume.split(",") if args.resume else ())
    jobs = [(n, args.quick, args.out, runner, members_from, te_from, print) for n in names]
    try:
        if workers > 1:
            # the designs' units go to one pool together (a thread per design submits and waits; the parent
            # only draws tables and assembles)
            with ThreadPoolExecutor(max_workers=len(jobs)) as threads:
                done = list(threads.map(lambda j: one_design(*j), jobs))
        else:
            done = [one_design(*j) for j in jobs]
    finally:
        runner.close()
    per_design, passed, missing = {}, True, {}
    for name, res, why in done:
        if res is None:
            per_design[name] = {"complete": False, "stopped": why}
            missing[name] = why
            continue
        V.write(res, os.path.join(args.out, name), load_catalogue(designs.catalogue_of(name)))
        entry = entry_of(name, res)
        if not args.quick and os.path.exists(QUICK_FROM):
            with open(QUICK_FROM) as fh:
                quick_entry = json.load(fh)["designs"].get(name)
            if quick_entry:
                entry["moved_against_quick"] = moved_against_quick(entry, quick_entry)
        passed = passed and all(entry["checks"].values())
        print(V.table_text(res))
        per_design[name] = entry
    complete = not missing
    units = runner.summary()
    print(f"units: {units['run']} run, {units['reused']} reused, {units['not_started']} not started "
          f"({workers} worker(s)); complete: {complete}")
    casekit.write_results(args.out, {"designs": per_design, "complete": complete,
                                     "passed": bool(passed and per_design and complete), "units": units,
                                     "deadline_utc": None if deadline is None else time.strftime(
                                         "%H:%M:%S", time.gmtime(deadline)),
                                     "resumed_from": args.resume.split(",") if args.resume else [],
                                     "criteria": "machinery ran (no failed sample), no NaN, loops repeat within "
                                                 f"{V.REPEAT_TOLERANCE_ARCMIN:g} arcmin, band contains central "
                                                 "where a band ran; the all-members-on row computed with no failed "
                                                 "sample; every design complete; NOT agreement with the catalogue"},
                          settings={"quick": args.quick, "samples": V.QUICK_SAMPLES if args.quick else V.SAMPLES,
                                    "members_samples": None if args.quick else VM.SAMPLES, "workers": workers,
                                    "designs": names, "members_from": members_from, "te_from": te_from},
                          wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
