"""The all-members-on rigidity of the validation designs with its Latin-hypercube band (issue 30; the row
``torsional_rigidity_all_members_on`` of ``rvtool validate``, rvtool.analysis.validate_members).

For rv40e and rv80e: every member of the torque path on (elastic cranks bending + torsion, ported housing, ported
carrier, pin grooves, elastic wheel bodies nested with them) as ``<design>_members.toml`` lists them, the catalogue's
b/a on the catalogue's torque points (four static solves) at the middles of every range (the central value) and at
Latin-hypercube samples over the design's own assumed ranges together with the members' (validate_members.members_
rigidity, seed 0). The band is [min, max] over the samples; the verdict row says whether the catalogue lies in it.

Meshes: the quick meshes of ``rvtool validate --quick`` (validate_members.QUICK_NUMERICS: wheels at 6 mm with 4
profile ports per tooth, housing and carrier at 8 mm) in both modes: the band is over the assumed inputs, and these
meshes keep one sample near 40 CPU seconds (cases/benchmarks/bench_nested_wheels.py).

Modes: full, 64 samples per design (issue 28's number); --quick, the central value of rv40e only (one b/a, about
25 CPU-s with its build: a sample costs as much again, which the quick budget leaves out). Since the joint network
is robust (rvtool.contact.pin_closure.JointNetwork: scaled Newton with a line search, unloaded groove stations at
their exact zero, a continuation from the last converged state) a sample no longer falls back to the nested solve:
the trial states it still cannot solve (Exudyn's Newton steps of radians and decimetres) are answered as
non-finite and rejected by the static solver; each design reports how often (``network_failures``) and the CPU
seconds per sample (``cpu_s_per_sample``); ``--samples N`` sets the number
explicitly (a SHORT band where N < 64, stated in the results as ``band_is_short``); ``--resume DIRS`` keeps the
designs that stopped or separate runs finished with at least this run's N samples and computes the others (with
this run's N: ``samples_per_design`` per design; a design whose kept band is shorter is recomputed), taking every
b/a those folders hold (their ``units`` and ``checkpoint_<design>.json``, by draw digest).

Units (rvtool.analysis.workunits, as ``rvtool validate``'s full run): every b/a is a unit keyed by the digest of
its draw's design table and the catalogue (the ``members.ba`` units of validate: a folder of either case serves
the other's ``--resume``), run on ``--workers N`` spawn processes (one BLAS thread each) and stored in
``OUT/units`` as it finishes; ``--deadline HH:MM`` (UTC) starts no unit once the time left is shorter than the
longest b/a seen so far: the band is then its first draws done (``samples_done`` of ``samples``;
``band_is_short``), and the same command again (the same --out) takes the stored units and solves the rest.

Draws: valid by construction (rvtool.analysis.validate_members.sample_table: the carrier plates follow the drawn
wheels, the row spacings are placed inside the drawn plates, the wheels' port depth clear of the drawn crank
bores); rv40e's draws are bit-identical to the independent sampler's (tests/test_validate_members.py), so its band
computed before that change is kept by --resume. ``--redo LIST`` runs those designs again although a --resume
folder has them: every b/a whose drawn design table is unchanged (draw digests) is taken from the --out and
--resume folders' units and checkpoints, only the changed draws are solved (``--resume
docs/case_results/rv/members_band --redo rv80e`` takes all 65 of the committed band).

The run folder's ``checkpoint_<design>.json`` (validate_members.write_checkpoint, written when the design's units
are gathered, every finished b/a with its draw digest; the format of the checkpoints before the band ran on
units, which are read the same way) is what gets committed beside results.json
(docs/case_results/rv/members_band/checkpoint_<design>.json): ``rvtool validate``'s full run
(cases/rv/validate_rv.py) takes the all-members-on b/a from it, draw by draw where the digests match
(validate_members.checkpoint_results); the pickled units are not committed.

Tornado (issue 28: a tornado chart with the band), after the bands, per design: ``tornado_sampled``
(validate_members.sampled_tornado), ESTIMATED from the band's own samples at no extra solve (a least-squares fit
over the 8 inputs of largest |Spearman rho|, each swing with its standard error and the fit's R^2); and, with
``--tornado-keys K`` (default 0: 2 K + 1 b/a, about 10 CPU-minutes for rv80e at K = 4), ``tornado``: the solved
one-at-a-time tornado of validate_members.members_tornado (the K inputs of largest |rho| each at both ends of its
range, the others at their middle fractions, beside that baseline). ``tornado_<sampled|solved>_<design>.png`` in
the run folder. A design kept by --resume keeps the tornados it has and gets those it lacks (so a band run and
its tornado may be separate runs, recorded under ``resumed_from``).

Criteria (``passed``): the central value and every sample finite, no failed sample (a failed sample is counted and
reported, never dropped), every tornado b/a solved. NOT agreement with the catalogue (reported as it is).
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")     # small dense solves: one BLAS thread (bench_nested_wheels)

import time  # noqa: E402

import numpy as np  # noqa: E402

from rvtool import casekit, designs  # noqa: E402
from rvtool.analysis.workunits import deadline_from, folder_runner  # noqa: E402
from rvtool.analysis.validate_members import (SAMPLES, members_rigidity, members_tornado,  # noqa: E402
                                              sampled_tornado)
from rvtool.assembly.topologies import read_table  # noqa: E402
from rvtool.designs.catalogue import load_assumed, load_catalogue  # noqa: E402

DESIGNS = ("rv40e", "rv80e")
QUICK = {"designs": ("rv40e",), "samples": 0}
TORNADO_KEYS = 0        # solved tornado: 2 K + 1 b/a per design (K = 4: about 10 CPU-minutes for rv80e loaded)
SAMPLED_KEYS = 8        # the tornado estimated from the band's samples (no extra solve)


def extra(parser):
    parser.add_argument("--samples", type=int, default=None, metavar="N",
                        help=f"Latin-hypercube samples per design (default {SAMPLES}; --quick: {QUICK['samples']})")
    parser.add_argument("--designs", default=None, metavar="LIST", help="comma-separated designs (default: both)")
    parser.add_argument("--resume", default=None, metavar="DIRS",
                        help="comma-separated run folders: keep the designs the runs there finished (their "
                             "results.json) and compute only the others, each design with its own sample count "
                             "(samples_per_design), taking the b/a those folders hold (units/, checkpoint_<design>"
                             ".json) by draw digest; the kept runs' command and date are recorded under resumed_from")
    parser.add_argument("--redo", default=None, metavar="LIST",
                        help="comma-separated designs NOT kept from the --resume folders but run again: the b/a "
                             "of unchanged draws are taken from the out and --resume folders (units, checkpoints; "
                             "draw digests), only the draws whose design table changed are solved")
    parser.add_argument("--deadline", default=None, metavar="HH:MM",
                        help="UTC time of day after which no b/a is started (nor once the time left is below the "
                             "longest b/a so far): the band is then the first draws done (samples_done of "
                             "samples; band_is_short), the rest resumable from the run folder's units by the same "
                             "command")
    parser.add_argument("--tornado-keys", type=int, default=None, metavar="K",
                        help=f"one-at-a-time tornado over the K inputs of largest |Spearman rho| (default "
                             f"{TORNADO_KEYS}; --quick: 0); a design that has one (kept by --resume) keeps it")
    parser.add_argument("--workers", type=int, default=1, metavar="N",
                        help="processes for the band's b/a (spawn pool, one BLAS thread each) and the solved "
                             "tornado's 2 K + 1 independent b/a (default 1)")


def one_design(name, samples, out_dir, runner, resume=()):
    t0, c0 = time.perf_counter(), time.process_time()
    catalogue = load_catalogue(designs.catalogue_of(name))
    ck = f"checkpoint_{name}.json"
    r = members_rigidity(name, read_table(designs.path(name)), catalogue, assumed_of(name), quick=True,
                         samples=samples, checkpoint=[os.path.join(d, ck) for d in (out_dir, *resume)],
                         checkpoint_out=os.path.join(out_dir, ck), runner=runner, short_band=True)
    r.pop("U", None)
    r["band_is_short"] = r["samples_done"] < SAMPLES
    # CPU and wall of THIS process (b/a solved in pool workers, or taken from units or checkpoints, carry their own
    # sample_cpu_s)
    r["cpu_s"] = time.process_time() - c0
    r["wall_s"] = time.perf_counter() - t0
    cpu = [c for c in r["sample_cpu_s"] if c is not None]
    r["cpu_s_per_sample"] = {"mean": float(np.mean(cpu)), "max": float(np.max(cpu))} if cpu else None
    nets = [r["central"]["networks"]] + [n for n in r["sample_networks"] if n is not None]
    # trial states of Exudyn's Newton where the joint network did not converge (answered as non-finite trials,
    # which the static solver rejects; before: the cascading nested solve) and those its continuation reached
    r["network_failures"] = int(sum(n["failures"] for n in nets))
    r["network_continued"] = int(sum(n["continued"] for n in nets))
    r["network_solves"] = int(sum(n["solves"] for n in nets))
    return r


def assumed_of(name):
    """The design's own assumed ranges (None: a class design without them)."""
    assumed_name = designs.assumed_of(name)
    return load_assumed(assumed_name) if assumed_name else None


def design_tornado(name, r, keys, workers=1):
    """validate_members.members_tornado on the design's finished band (its seed and samples)."""
    catalogue = load_catalogue(designs.catalogue_of(name))
    base = assumed_of(name)
    t0, c0 = time.perf_counter(), time.process_time()
    out = members_tornado(name, read_table(designs.path(name)), catalogue, base, r["sample_values"], keys=keys,
                          seed=r["seed"], quick=True, planned=r["samples"],
                          workers=workers)
    out["tornado_cpu_s"] = time.process_time() - c0
    out["tornado_wall_s"] = time.perf_counter() - t0
    return out


def tornado_png(out_dir, name, r, band, kind):
    """tornado_<kind>_<design>.png: each input's b/a at the low and high end of its range about the baseline."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    tor, c = r["tornado"], r["baseline"]
    if c is None or not tor:
        return
    keys = list(tor)[::-1]
    fig, ax = plt.subplots(figsize=(7.0, 0.5 * len(keys) + 1.4))
    for j, k in enumerate(keys):
        for end, colour in (("at_low", "tab:blue"), ("at_high", "tab:red")):
            v = tor[k][end]
            if v is not None:
                ax.barh(j, v - c, left=c, color=colour, alpha=0.7, label=end if j == 0 else None)
    ax.axvline(c, color="k", lw=0.8)
    if band:
        ax.axvspan(band[0], band[1], color="0.85", zorder=0, label="band (LHS samples)")
    ax.set_yticks(range(len(keys)), keys, fontsize=7)
    ax.set_xlabel("all-members-on b/a [N m/arcmin]")
    ax.set_title(f"{name}: tornado, {kind} (baseline: every input at its middle fraction)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, f"tornado_{kind}_{name}.png"), dpi=110)
    plt.close(fig)


def judge(r):
    out = {}
    for name, d in r["designs"].items():
        vals = [d["central"]["value"]] + [v for v in d["sample_values"] if v is not None]
        out[f"{name}_finite"] = casekit.check(float(all(np.isfinite(vals))), 1.0, "==", "every b/a finite")
        out[f"{name}_failed_samples"] = casekit.check(len(d["failures"]), 0, "==",
                                                      "a failed sample is counted, never dropped")
        if "tornado" in d:
            errs = sum(len(v["errors"]) for v in d["tornado"].values()) + (d["baseline_error"] is not None)
            out[f"{name}_tornado_failed"] = casekit.check(errs, 0, "==", "every tornado b/a solved")
    return out


def main(argv=None):
    args = casekit.parse_args(argv, __doc__.splitlines()[0], extra=extra)
    t0 = time.perf_counter()
    names = tuple(args.designs.split(",")) if args.designs else (QUICK["designs"] if args.quick else DESIGNS)
    samples = args.samples if args.samples is not None else (QUICK["samples"] if args.quick else SAMPLES)
    per, counts, resumed = {}, {}, []
    resume_dirs = args.resume.split(",") if args.resume else []
    for run_dir in resume_dirs:
        import json
        with open(os.path.join(run_dir, "results.json")) as fh:
            prev = json.load(fh)
        prev_counts = prev["samples_per_design"]

        def count(n):
            return prev_counts[n] if isinstance(prev_counts, dict) else prev_counts
        # a design is kept only where it has at least this run's samples (a short band is recomputed, not kept)
        redo = args.redo.split(",") if args.redo else []
        kept = [n for n in prev["designs_done"] if n in names and n not in per and n not in redo
                and count(n) >= samples]
        for n in kept:
            per[n] = prev["designs"][n]
            per[n].setdefault("samples_done", len(per[n]["sample_values"]))   # runs before the key existed
            counts[n] = count(n)
        resumed.append({"designs": kept, "command": prev["provenance"]["command"], "date": prev["provenance"]["date"],
                        "wall_s_total": prev["provenance"]["wall_s_total"],
                        "resumed_from": prev.get("resumed_from", [])})      # the kept run's own kept runs
    runner = folder_runner(args.out, workers=args.workers, deadline=deadline_from(args.deadline), resume=resume_dirs)
    try:
        return run(args, names, samples, per, counts, resumed, runner, resume_dirs, t0)
    finally:
        runner.close()


def run(args, names, samples, per, counts, resumed, runner, resume_dirs, t0):
    """The bands (units of ``runner``), then the tornados; results.json written after each design."""
    out = None
    n_tor = args.tornado_keys if args.tornado_keys is not None else (0 if args.quick else TORNADO_KEYS)
    for name in list(names) + [f"tornado:{n}" for n in names]:
        if name.startswith("tornado:"):
            runner.close()          # the band's pool (idempotent); the solved tornado has its own processes
            name = name.split(":", 1)[1]
            d = per[name]
            if "tornado_sampled" not in d and d["sample_values"]:
                d["tornado_sampled"] = sampled_tornado(name, assumed_of(name), d["sample_values"], keys=SAMPLED_KEYS,
                                                       seed=d["seed"], planned=d["samples"])
                if d["tornado_sampled"]:
                    tornado_png(args.out, name, d["tornado_sampled"], d.get("band"), "sampled")
            if n_tor > 0 and "tornado" not in d and d["sample_values"]:
                d.update(design_tornado(name, d, n_tor, args.workers))
                tornado_png(args.out, name, d, d.get("band"), "solved")
        elif name not in per:
            per[name] = one_design(name, samples, args.out, runner, resume_dirs)
            counts[name] = per[name]["samples_done"]
        # written after every design (a long run that stops keeps the designs it finished; ``designs_done``)
        done = {n: per[n] for n in names if n in per}
        for d in done.values():
            d["failed_samples"] = len(d["failures"])
        results = {"designs": done, "samples_per_design": {n: counts[n] for n in done},
                   "samples_planned": {n: per[n]["samples"] for n in done},
                   "band_is_short": any(counts[n] < SAMPLES for n in done), "issue_samples": SAMPLES,
                   "designs_done": list(done), "designs_asked": list(names), "resumed_from": resumed,
                   "units": runner.summary()}
        casekit.verdict(results, judge)
        out = casekit.write_results(args.out, results, settings={"quick": args.quick, "samples": samples,
                                                                 "designs": list(names), "seed": 0},
                                    wall_s=time.perf_counter() - t0)
    return out


if __name__ == "__main__":
    main()
