"""RV-40E class: one crank's eccentric phase off by 0, 2, 5, 10 arcmin -- crank load shares and TE.

Crank 0's two journals are turned by the error about its axis (``cranks.phase_errors_deg``,
a design variant; positive = counter-clockwise, i.e. lagging in the cranks' driving sense, since
the cranks turn clockwise when the input turns counter-clockwise). Per error: the crank load
shares at rated load (fraction of the summed crank torque about the carrier axis) at input angle 0
and their mean, minimum and maximum over one crank revolution, and the quasi-static TE
peak-to-peak over that revolution at 40 points per cycloid mesh cycle (--quick: 12 points and the
errors 0 and 10 arcmin).
"""
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build, load_design
from rvtool.protocols.precision import quasi_static_te, te_metrics
from rvtool.units import ARCSEC_PER_RAD

DESIGN = designs.path("rv40e")
ERRORS_ARCMIN = (0.0, 2.0, 5.0, 10.0)


def judge(r):
    """The case's checks on its results (see casekit.verdict): the direction of the effect, per error step."""
    sh = r["crank_load_share"]
    share0 = [s["fraction_mean_over_crank_revolution"][0] for s in sh]
    return {
        # a lagging crank (positive error) engages later and unloads: its mean share falls as the error grows
        "lagging_crank_unloads": casekit.check(max(b - a for a, b in zip(share0, share0[1:])), 0.0, "<",
                                               why="crank 0 lags: smaller share of the summed crank torque"),
        # no crank is unloaded completely at these errors (measured smallest share 0.28 at 10 arcmin): a share
        # of zero would mean a lost contact, which the statically indeterminate three-crank carrier should not show
        "all_cranks_loaded": casekit.check(min(min(s["fraction_min_over_crank_revolution"]) for s in sh), 0.0, ">",
                                           why="every crank keeps a positive share of the torque"),
        # a phase error adds a once-per-crank-revolution wind-up: the TE p-p grows with it
        "te_grows_with_error": casekit.check(min(b - a for a, b in zip(r["te_pp_arcsec"], r["te_pp_arcsec"][1:])), 0.0,
                                             ">", why="the error adds to the nominal TE"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    base = load_design(DESIGN)
    T = base.rated_torque
    errors = (0.0, 10.0) if args.quick else ERRORS_ARCMIN
    shares_out, te_pp, curves, walls = [], [], [], []
    for err in errors:
        t0 = time.perf_counter()
        d = base.replace(cranks={"phase_errors_deg": (err / 60,) + (0.0,) * (base.cranks.count - 1)})
        model = build(d)
        crank_rev = 2 * np.pi / abs(model.graph.crank_rate)
        n_pts = 12 if args.quick else int(round(crank_rev / model.mesh_period)) * 40
        angles = np.arange(n_pts) * crank_rev / n_pts
        sh = []
        qs = quasi_static_te(model, torque=T, input_angles=angles,
                             record=lambda k, a, q: sh.append(model.crank_load_share(q)))
        sh = np.array(sh)
        met = te_metrics(qs["te"], n_revolutions=1.0 / (abs(model.graph.crank_rate) * abs(model.ratio)))
        shares_out.append({"phase_error_arcmin": err, "fraction_at_rated": sh[0], "fraction_mean_over_crank_revolution":
                           sh.mean(axis=0), "fraction_min_over_crank_revolution": sh.min(axis=0),
                           "fraction_max_over_crank_revolution": sh.max(axis=0)})
        te_pp.append(met["pp"] * ARCSEC_PER_RAD)
        curves.append((angles * abs(model.graph.crank_rate), sh, qs["te"]))
        walls.append(time.perf_counter() - t0)
    results = {"crank_load_share": shares_out, "te_pp_arcsec": te_pp}
    settings = {"design": base.name, "quick": args.quick, "phase_errors_arcmin": errors, "crank_with_error": 0,
                "te_interval": "one crank revolution (1/z_g output revolution)", "points": len(curves[0][0]),
                "wall_s_per_error": walls}
    _plots(errors, curves, args.out)
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=time.perf_counter() - t_all)


def _plots(errors, curves, out):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.8))
    for err, (a, sh, te) in zip(errors, curves):
        ax[0].plot(np.rad2deg(a), sh[:, 0], lw=0.9, label=f"{err:g} arcmin")
        ax[1].plot(np.rad2deg(a), (te - te.mean()) * ARCSEC_PER_RAD, lw=0.8, label=f"{err:g} arcmin")
    ax[0].set(xlabel="crank angle [deg]", ylabel="share of crank 0", title="load share of the crank with the error")
    ax[1].set(xlabel="crank angle [deg]", ylabel="TE - mean [arcsec]", title="quasi-static TE at rated load")
    ax[0].legend(fontsize=8)
    casekit.save_figure(fig, out, "crank_phase_error")


if __name__ == "__main__":
    main()
