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
passed (stated criteria, NOT agreement with the catalogue, which is reported as it is): the machinery ran
(no failed sample), no NaN, the two loops repeat within 1e-4 arcmin, the band contains the central value
(where a band ran).
"""
import os
import time

# one BLAS thread per process (before NumPy loads): the solves here are small dense systems (a few hundred
# unknowns), where a second OpenBLAS thread on a shared 2-core machine spins instead of computing (measured: a
# 340 x 340 solve with 380 right-hand sides took 22x the CPU time with the default threads under load,
# cases/benchmarks/bench_nested_wheels.py)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from concurrent.futures import ProcessPoolExecutor

import rvtool.analysis.validate as V
import rvtool.analysis.validate_members as VM
from rvtool import casekit, designs


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


def one_design(job):
    """Validate one design (a process of its own): (name, its results entry, its criteria, its table text)."""
    name, quick, out = job
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
    res = V.validate(name, quick=quick, out_dir=f"{out}/{name}", **kw)
    crit = V.checks(res)
    entry = {"table": res["table"], "central": res["central"], "checks": crit,
             "assumptions_commit": res["assumptions_commit"], "pressures": res["pressures"],
             "ratio_variant": res["ratio_variant"], "compliance_budget": res["compliance_budget"],
             "bearing_lives": res["bearing_lives"], "uncertainty_note": res["uncertainty_note"],
             "uncertainty": {k: v for k, v in (res["uncertainty"] or {}).items() if k != "U"},
             "settings": res["settings"], "report": f"{name}/report.html",
             "te_measured": res.get("te_measured"), "all_members_on": res.get("all_members_on")}
    return name, entry, crit, V.table_text(res)


def main(argv=None):
    args = casekit.parse_args(argv, description=__doc__.splitlines()[0])
    t0 = time.perf_counter()
    per_design, passed = {}, True
    names = V.validated_designs()
    os.makedirs(args.out, exist_ok=True)
    jobs = [(name, args.quick, args.out) for name in names]
    # one process per design: the designs are independent (results in the designs' order)
    with ProcessPoolExecutor(max_workers=len(jobs)) as pool:
        done = list(pool.map(one_design, jobs))
    for name, entry, crit, text in done:
        passed = passed and all(crit.values())
        print(text)
        per_design[name] = entry
    casekit.write_results(args.out, {"designs": per_design, "passed": bool(passed and per_design),
                                     "criteria": "machinery ran (no failed sample), no NaN, loops repeat within "
                                                 f"{V.REPEAT_TOLERANCE_ARCMIN:g} arcmin, band contains central "
                                                 "where a band ran; the all-members-on row computed with no failed "
                                                 "sample; NOT agreement with the catalogue"},
                          settings={"quick": args.quick, "samples": V.QUICK_SAMPLES if args.quick else V.SAMPLES,
                                    "members_samples": None if args.quick else VM.SAMPLES},
                          wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
