"""RD-40 as a single-wheel cycloid drive (one 16 mm wheel): transmission error, rated loads and load sharing.

The same protocol as cycloid_double_wheel on the single-wheel variant of
RD-40 (one wheel of 16 mm width at the flange midplane, journal phase 0).
"""
import time

import rvtool
from rvtool import casekit
from rvtool.analysis.precision_study import precision_study

DESIGN = "rd40"
judge = casekit.import_case("cycloid/cycloid_double_wheel").judge
"""The precision study's checks (cycloid_double_wheel)."""


def single_wheel(design):
    return rvtool.replace_design(design, n_wheels=1, wheels={"width": 0.016, "midplanes": (0.0,), "phases_deg": (0.0,)},
                   eccentric_bearing={"roller_length": 0.016}, name="RD-40 single wheel")


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    results, settings = precision_study(single_wheel(rvtool.load_design(DESIGN)), quick=args.quick, out_dir=args.out)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
