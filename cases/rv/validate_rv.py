"""Shipped RV designs against their catalogues by the catalogue's own definitions (issue 28): `rvtool validate`.

For every shipped design with a <design>_catalogue.toml (rvtool.analysis.validate): a table predicted vs
catalogue (value, source with edition and page, test conditions) for torsional rigidity b/a, lost motion and
hysteresis loss (rvtool.protocols.catalogue, one repeating loop over +-T_R), the needle- and crank-bearing
ISO 281 L10 at T_R and the catalogue's rated output speed against its rated life, contact pressures where the
model declares Hertz peaks; the hysteresis curve (hysteresis.png), the compliance budget at the rated state,
the rigidity of another ratio variant of the same frame, an uncertainty band from 64 Latin-hypercube samples
over the `assumed` ranges with a one-at-a-time tornado (tornado.png), and the fraction of those variants within
the catalogue's lost-motion maximum; the assumptions_commit of each design.
--quick: 8 Latin-hypercube samples (not 64) and a coarse central loop (25 % level steps).
passed (stated criteria, NOT agreement with the catalogue, which is reported as it is): the machinery ran
(no failed sample), no NaN, the two loops repeat within 1e-4 arcmin, the band contains the central value.
"""
import time

import rvtool.analysis.validate as V
from rvtool import casekit


def main(argv=None):
    args = casekit.parse_args(argv, description=__doc__.splitlines()[0])
    t0 = time.perf_counter()
    per_design, passed = {}, True
    for name in V.validated_designs():
        out = V.validate(name, quick=args.quick, out_dir=f"{args.out}/{name}")
        crit = V.checks(out)
        passed = passed and all(crit.values())
        print(V.table_text(out))
        per_design[name] = {"table": out["table"], "central": out["central"], "checks": crit,
                            "assumptions_commit": out["assumptions_commit"],
                            "ratio_variant": out["ratio_variant"], "compliance_budget": out["compliance_budget"],
                            "bearing_lives": out["bearing_lives"],
                            "uncertainty": {k: v for k, v in (out["uncertainty"] or {}).items() if k != "X"},
                            "report": f"{name}/report.html"}
    casekit.write_results(args.out, {"designs": per_design, "passed": bool(passed and per_design),
                                     "criteria": "machinery ran (no failed sample), no NaN, loops repeat within "
                                                 f"{V.REPEAT_TOLERANCE_ARCMIN:g} arcmin, band contains central; "
                                                 "NOT agreement with the catalogue"},
                          settings={"quick": args.quick, "samples": V.QUICK_SAMPLES if args.quick else V.SAMPLES},
                          wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
