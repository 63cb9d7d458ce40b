"""RD-40 double-wheel cycloid drive: transmission error, rated loads and load sharing (quasi-static and dynamic).

Quasi-static TE over one output revolution at 40 points per mesh cycle
(--quick: one input revolution at 4 points), its error against a refined
reference (twice the profile samples and points over one mesh cycle), the
rated-state pin forces at zero input angle, peak loads per contact family
and a driven run at the rated speed (one output revolution; --quick: four
mesh cycles).
"""
import time

from rvtool import casekit
from rvtool.assembly.spec import load_design
from rvtool.analysis.precision_study import precision_study
from rvtool import designs

DESIGN = designs.path("rd40")


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    results, settings = precision_study(load_design(DESIGN), quick=args.quick, out_dir=args.out)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
