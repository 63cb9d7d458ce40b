"""Influence-coefficient roller slices (paper Eq. (bearing_ic)) against the panel solve of the same
finite-length line contact, against Lundberg's logarithmic profile, and against the precomputed
edge weight.

Roller: length l = 10 mm, contact radius R' = 2.5 mm (a 5 mm roller on flat races, the same R' at
both races), steel E = 206 GPa, nu = 0.3 (E* = E / (2 (1 - nu^2))). By symmetry each of the two
contacts takes half of the roller's approach s(y), so the reference is one contact on the pressure
module's rectangular half-space panels (:func:`rvtool.bearings.influence.panel_slice_forces`: the
exact complementarity solution on the panel grid, its forces summed per slice) at s(y) / 2, and
the influence slices are the roller's both-race solve at s(y).

1. Slice forces, 16 slices, four approach shapes (straight: uniform approach, with its edge
   loading; parabolic crown 3 um; tilt 5e-4 rad; crown + tilt) and the three half-width modes;
   bound: max |f_ic - f_panel| / max f_panel <= 2 % for half_width = "slice_load" (the issue's
   target; the panel reference itself moves by < 0.7 % from its quick to its full grid, reported).
2. Lundberg (1939): the crown drop g(y) = (q / (pi E*)) ln[1 / (1 - (2y/l)^2)] of each contact
   carries a uniform line load q in the half-space model (G. Lundberg, Elastische Beruehrung
   zweier Halbraeume, Forschung auf dem Gebiete des Ingenieurwesens 10, 1939, 201-211; the profile
   as used by H. Fujiwara and T. Kawase, Logarithmic profiles of rollers in roller bearings and
   optimization of the profiles, Trans. JSME C 72, 2006, 3022-3029). At the approach that carries
   q l, every slice's line load within 2 % of q (slice-mean drops: Galerkin collocation).
3. The precomputed edge weight (laminae with per-slice stiffness factors from the uniform-approach
   solve): its error under tilt against the solve, with that of plain laminae (reported).
4. Tangent df/ds against central differences (step 1e-6 of the approach): <= 1e-6 relative.

--quick uses the coarse panel grid only (6 panels per slice along, 24 across).
"""
import time

import numpy as np
from scipy.optimize import brentq

from rvtool import casekit
from rvtool.bearings.influence import panel_slice_forces, two_body_modulus
from warp_contacts import roller_slices_ref as sref

LENGTH = 10e-3
RADIUS = 2.5e-3
E_STAR = two_body_modulus(206e9, 0.3)
N_SLICES = 16
SHAPES = {
    "straight": lambda y: 6e-6 + 0.0 * y,
    "crowned": lambda y: 8e-6 - 6e-6 * (2 * y / LENGTH) ** 2,
    "tilted": lambda y: 6e-6 + 1e-3 * y,
    "crowned_tilted": lambda y: 8e-6 + 4e-4 * y - 6e-6 * (2 * y / LENGTH) ** 2,
}
MODES = {"fixed": sref.HALF_WIDTH_FIXED, "roller_load": sref.HALF_WIDTH_ROLLER_LOAD,
         "slice_load": sref.HALF_WIDTH_SLICE_LOAD}
#: the reference load of the fixed half-width (per roller)
REFERENCE_LOAD = 1000.0
LUNDBERG_LINE_LOAD = 3e5
GRIDS = {"coarse": (6, 24), "fine": (8, 32)}


def slice_mean(fun, n):
    """Mean of fun(y) over each of n slices (8-point Gauss--Legendre; exact for the polynomial shapes)."""
    dy = LENGTH / n
    x, w = np.polynomial.legendre.leggauss(8)
    yc = (np.arange(n) + 0.5) * dy - 0.5 * LENGTH
    return np.array([0.5 * np.sum(w * fun(c + 0.5 * dy * x)) for c in yc])


def params(n, mode):
    fp = np.zeros(sref.N_SLICE_FLOAT)
    fp[sref.SL_DY], fp[sref.SL_ESTAR], fp[sref.SL_LEN] = LENGTH / n, E_STAR, LENGTH
    fp[sref.SL_RIN] = fp[sref.SL_ROUT] = RADIUS
    fp[sref.SL_BIN] = fp[sref.SL_BOUT] = sref.line_load_half_width(REFERENCE_LOAD, LENGTH, RADIUS, E_STAR)
    return fp, np.array([n, MODES[mode]])


def judge(r):
    sl = r["slices_vs_panels"]
    return {
        "slice_forces_vs_panels": casekit.check(max(sl[s]["slice_load"]["max_rel_err"] for s in SHAPES), 0.02, "<=",
                                                why="issue target; panel reference converged to < 0.7 %"),
        "lundberg_uniform_load": casekit.check(r["lundberg"]["max_rel_dev"], 0.02, "<=",
                                               why="Lundberg's profile carries a uniform line load (half-space)"),
        "tangent_vs_central_differences": casekit.check(max(r["tangent_rel_err"].values()), 1e-6, "<=",
                                                        why="central differences, step 1e-6 of the approach"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    grids = ["coarse"] if args.quick else ["coarse", "fine"]
    n = N_SLICES
    results = {"n_slices": n, "length_m": LENGTH, "radius_m": RADIUS, "e_star_Pa": E_STAR, "grids": grids,
               "slices_vs_panels": {}}
    curves = {}
    for name, shape in SHAPES.items():
        ref = {}
        for g in grids:
            pps, nx = GRIDS[g]
            ref[g] = panel_slice_forces(length=LENGTH, radius=RADIUS, e_star=E_STAR, approach=lambda y: 0.5 * shape(y),
                                        n_slices=n, panels_per_slice=pps, nx=nx)[0]
        fp_ref = ref[grids[-1]]
        entry = {"panel_forces_N": fp_ref}
        if len(grids) > 1:
            entry["panel_grid_change"] = float(np.max(np.abs(ref["fine"] - ref["coarse"])) / np.max(ref["fine"]))
        s = slice_mean(shape, n)
        for mode in MODES:
            fp, ip = params(n, mode)
            f = sref.solve_roller(s, fp, ip)[0]
            entry[mode] = {"forces_N": f, "max_rel_err": float(np.max(np.abs(f - fp_ref)) / np.max(fp_ref))}
        results["slices_vs_panels"][name] = entry
        curves[name] = (fp_ref, entry["slice_load"]["forces_N"], entry["fixed"]["forces_N"])

    # Lundberg's logarithmic crown: the approach that carries q l, then the spread of the line loads
    q = LUNDBERG_LINE_LOAD
    drop = slice_mean(lambda y: q / (np.pi * E_STAR) * np.log(1.0 / (1.0 - (2 * y / LENGTH) ** 2)), n)
    fp, ip = params(n, "slice_load")

    def load(d):
        return sref.solve_roller(2.0 * (d - drop), fp, ip)[0]

    d = brentq(lambda x: load(x).sum() - q * LENGTH, 1e-7, 5e-5, xtol=1e-16)
    line = load(d) / (LENGTH / n)
    results["lundberg"] = {"design_line_load_N_per_m": q, "approach_per_contact_m": d, "line_load_ratio": line / q,
                           "max_rel_dev": float(np.max(np.abs(line / q - 1.0)))}

    # the precomputed edge weight vs the solve under tilt (linear laminae, secant at the uniform load)
    fp, ip = params(n, "fixed")
    yc = (np.arange(n) + 0.5) * LENGTH / n - 0.5 * LENGTH
    s0 = 6e-6
    C = sref.compliance(fp, n, np.full((2, n), fp[sref.SL_BIN]))[0]
    f_uniform = np.linalg.solve(C, np.full(n, s0))
    weights = f_uniform / f_uniform.mean()
    k = f_uniform.mean() / s0
    edge = {"weights": weights}
    for tilt in (0.0, 5e-4, 1e-3):
        s = s0 + tilt * yc
        f = sref.solve_roller(s, fp, ip)[0]
        lam = k * np.maximum(s, 0.0)
        wl = k * weights * np.maximum(s, 0.0)
        edge[f"tilt_{tilt:g}"] = {"laminae_max_rel_err": float(np.max(np.abs(lam - f)) / np.max(f)),
                                  "edge_weighted_max_rel_err": float(np.max(np.abs(wl - f)) / np.max(f))}
    results["edge_weight"] = edge

    # consistent tangent vs central differences, every mode, at the crowned + tilted approach
    s = slice_mean(SHAPES["crowned_tilted"], n)
    results["tangent_rel_err"] = {}
    for mode in MODES:
        fp, ip = params(n, mode)
        J = sref.solve_roller(s, fp, ip)[1]
        h = 1e-6 * np.max(np.abs(s))
        Jfd = np.column_stack([(sref.solve_roller(s + h * e, fp, ip)[0] - sref.solve_roller(s - h * e, fp, ip)[0])
                               / (2 * h) for e in np.eye(n)])
        results["tangent_rel_err"][mode] = float(np.max(np.abs(J - Jfd)) / np.max(np.abs(J)))
    results["wall_s"] = time.perf_counter() - t0

    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(SHAPES) + 1, figsize=(16, 3.4))
    for ax, (name, (fref, fic, ffix)) in zip(axes, curves.items()):
        ax.plot(yc * 1e3, fref, "ks", ms=4, label="panels (reference)")
        ax.plot(yc * 1e3, fic, "o-", ms=3, label="influence, slice_load")
        ax.plot(yc * 1e3, ffix, "x:", ms=3, label="influence, fixed")
        ax.set(xlabel="y [mm]", ylabel="slice force [N]", title=name)
    axes[0].legend(fontsize=7)
    axes[-1].plot(yc * 1e3, results["lundberg"]["line_load_ratio"], "o-")
    axes[-1].set(xlabel="y [mm]", ylabel="q_slice / q", title="Lundberg profile", ylim=(0.9, 1.1))
    fig.tight_layout()
    casekit.save_figure(fig, args.out, "roller_slices")
    casekit.verdict(results, judge)
    settings = {"quick": args.quick, "grids": {g: GRIDS[g] for g in grids}, "n_slices": n}
    return casekit.write_results(args.out, results, settings=settings, wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
