"""Verifies the Warp contact laws and circle contact against NumPy double-precision references (float64, float32).

Paper, Section "Contact laws, signed clearance, and force direction".
Laws F_n = k <-g>_+^p: point contact k_p = 1e10 N/m^1.5, p = 3/2; linearized
line contact k_l = 2e8 N/m, p = 1; output-pin law k = 1e9 N/m^(10/9),
p = 10/9. Circle contact: a 3 mm pin outside (g_ext = |c_B - c_A| - r_A - r_B)
and inside (g_int = R_B - r_A - |c_B - c_A|) a 50 mm circle whose centre is
off the origin, 64 centre directions, point law. The signed approach -g is
swept from -50 um (separated) to +50 um (compressed), 2001 samples.

The reference evaluates the precision-rounded inputs promoted to float64, so
the error is arithmetic and implementation error only. Force error of Eq.
(force_error): eps_F = max_j ||F_j - F_j^ref||_2 / max_j ||F_j^ref||_2.
In float32 the circle errors are dominated by the gap, a difference of
~5e-2 m lengths resolved to ~eps32 * 5e-2 m = 6e-9 m, against indentations
of at most 5e-5 m; the scalar laws see only the law's own arithmetic.
"""
import time

import numpy as np

from rvtool import casekit
from warp_contacts import circle_geometry_ref, laws_ref
from warp_contacts.primitives import eval_circle_contact, eval_power_law

LAWS = {  # name: (k in N m^-p, p)
    "point_law": (1e10, 1.5),
    "line_law": (2e8, 1.0),
    "pin_law": (1e9, 10.0 / 9.0),
}
PIN_RADIUS = 3e-3  # r_A, m
CIRCLE_RADIUS = 50e-3  # r_B (external) or R_B (internal), m
CIRCLE_CENTRE = (0.012, -0.007)  # c_B, m
CIRCLE_LAW = LAWS["point_law"]
APPROACH_MAX = 50e-6  # |-g| at the ends of the sweep, m


EPS32 = float(np.finfo(np.float32).eps)


def judge(r):
    """The case's checks on its results (see casekit.verdict): arithmetic error bounds per precision."""
    checks = {}
    for name in LAWS:
        # float64: the reference does the same arithmetic in float64: a few ulps (pow), 1e-14 = 45 ulps
        checks[f"float64_{name}"] = casekit.check(r[f"float64.{name}_norm_err"], 1e-14, "<=", why="few float64 ulps")
        # float32: a handful of roundings of a power law, 1e-6 = 8 eps32
        checks[f"float32_{name}"] = casekit.check(r[f"float32.{name}_norm_err"], 1e-6, "<=", why="8 float32 ulps")
    for tag in ("ext", "int"):
        checks[f"float64_{tag}_circle"] = casekit.check(r[f"float64.{tag}_circle_norm_err"], 1e-14, "<=",
                                                        why="few float64 ulps")
        checks[f"float64_{tag}_gap"] = casekit.check(r[f"float64.{tag}_gap_max_abs_err_m"], 1e-17, "<=",
                                                     why="same float64 arithmetic (ulp of 5e-2 m is 7e-18)")
        # float32 gap: centre distances of ~5e-2 m resolve to eps32 * 5e-2 = 6e-9 m; two such roundings
        gap_bound = 2 * EPS32 * CIRCLE_RADIUS
        checks[f"float32_{tag}_gap"] = casekit.check(r[f"float32.{tag}_gap_max_abs_err_m"], gap_bound, "<=",
                                                     why="two float32 roundings of the 5e-2 m centre distance")
        # force: p * gap error / largest approach (1.5 * 1.2e-8 / 5e-5 = 3.6e-4)
        checks[f"float32_{tag}_circle"] = casekit.check(r[f"float32.{tag}_circle_norm_err"],
                                                        CIRCLE_LAW[1] * gap_bound / APPROACH_MAX, "<=",
                                                        why="law exponent x float32 gap error / largest approach")
    return checks


def _rounded(x, precision):
    """Inputs as the kernel sees them, promoted to float64 for the reference."""
    return np.asarray(x, dtype=precision).astype(np.float64)


def norm_error(f, f_ref):
    """Eq. (force_error): max_j ||F_j - F_j^ref||_2 / max_j ||F_j^ref||_2 (scalars: absolute values)."""
    f, f_ref = np.atleast_2d(f.T).T, np.atleast_2d(f_ref.T).T
    return float(np.max(np.linalg.norm(f - f_ref, axis=1)) / np.max(np.linalg.norm(f_ref, axis=1)))


def circle_configurations(internal, n_angles, approach):
    """Centres c_A, c_B for every (direction, approach) pair; direction = unit vector A -> B."""
    theta = np.repeat(np.linspace(0.0, 2.0 * np.pi, n_angles, endpoint=False), approach.size)
    s = np.tile(approach, n_angles)
    dist = CIRCLE_RADIUS - PIN_RADIUS + s if internal else PIN_RADIUS + CIRCLE_RADIUS - s
    cb = np.broadcast_to(np.asarray(CIRCLE_CENTRE), (s.size, 2))
    ca = cb - dist[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
    return ca, np.ascontiguousarray(cb), s


def verify_laws(precision, device, approach):
    """Warp and reference forces of each scalar law over the approach sweep."""
    out = {}
    for name, (k, p) in LAWS.items():
        f, _ = eval_power_law(k, p, approach, precision=precision, device=device)
        f_ref, _ = laws_ref.power_law(_rounded(k, precision), _rounded(p, precision), _rounded(approach, precision))
        out[name] = (f.astype(np.float64), f_ref)
    return out


def verify_circle(internal, precision, device, n_angles, approach):
    """Warp and reference gaps and force vectors on the pin for all centre directions."""
    ca, cb, s = circle_configurations(internal, n_angles, approach)
    k, p = CIRCLE_LAW
    g, f = eval_circle_contact(ca, cb, PIN_RADIUS, CIRCLE_RADIUS, internal, k, p, precision=precision, device=device)
    car, cbr, rar, rbr, kr, pr = (_rounded(x, precision) for x in (ca, cb, PIN_RADIUS, CIRCLE_RADIUS, k, p))
    g_ref, n_ref, _ = circle_geometry_ref.circle_gap(car, cbr, rar, rbr, internal)
    fn_ref, _ = laws_ref.power_law(kr, pr, -g_ref)
    f_ref = circle_geometry_ref.circle_force_on_a(fn_ref, n_ref, internal)
    return {"s": s, "g": g.astype(np.float64), "g_ref": g_ref, "f": f.astype(np.float64), "f_ref": f_ref}


def plot(out_dir, approach, laws, circles):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(2, 4, figsize=(17, 7.5), sharex=True, layout="constrained")
    um = 1e6 * approach
    floor = 1e-20  # exact agreement (error 0) is drawn at this floor
    styles = {"float64": dict(marker="o", ms=3, ls="none"), "float32": dict(marker="x", ms=3, ls="none")}
    every = max(1, approach.size // 60)
    for j, name in enumerate(LAWS):
        k, p = LAWS[name]
        f_ref = laws["float64"][name][1]
        ax[0, j].plot(um, f_ref, "k-", lw=1, label="reference (float64)")
        for prec in laws:
            f, f_ref = laws[prec][name]
            ax[0, j].plot(um[::every], f[::every], label=f"Warp {prec}", **styles[prec])
            ax[1, j].semilogy(um, np.maximum(np.abs(f - f_ref) / np.max(np.abs(f_ref)), floor), lw=0.8,
                              label=prec)
        ax[0, j].set(title=f"{name.replace('_', ' ')}: k = {k:.0e} N/m^p, p = {p:.3g}", ylabel="F_n [N]")
        ax[1, j].set(xlabel="signed approach -g [um]", ylabel="|F - F_ref| / max|F_ref|")
    for internal, ls in ((False, "-"), (True, "--")):
        label = "internal" if internal else "external"
        c = circles["float64"][internal]
        n = approach.size
        ax[0, 3].plot(um, np.linalg.norm(c["f_ref"][:n], axis=1), "k" + ls, lw=1, label=f"{label} reference")
        for prec in circles:
            c = circles[prec][internal]
            err = np.linalg.norm(c["f"] - c["f_ref"], axis=1).reshape(-1, n).max(axis=0)
            ax[1, 3].semilogy(um, np.maximum(err / np.max(np.linalg.norm(c["f_ref"], axis=1)), floor), ls=ls,
                              lw=0.8, label=f"{label} {prec}")
            ax[0, 3].plot(um[::every], np.linalg.norm(c["f"][:n], axis=1)[::every], label=f"{label} Warp {prec}",
                          **styles[prec])
    ax[0, 3].set(title="circle contact, 3 mm pin / 50 mm circle\n|F| on the pin, first direction", ylabel="|F| [N]")
    ax[1, 3].set(xlabel="signed approach -g [um]", ylabel="max over directions, normalized")
    for a in ax.ravel():
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    fig.suptitle(f"Contact primitives vs double-precision reference (errors of 0 drawn at {floor:g})")
    return casekit.save_figure(fig, out_dir, "contact_primitives")


def main(argv=None):
    args = casekit.parse_args(argv, __doc__, extra=lambda p: p.add_argument(
        "--device", default="cpu", help="Warp device (cpu, cuda, cuda:N)"))
    n_approach, n_angles = (201, 8) if args.quick else (2001, 64)
    approach = np.linspace(-APPROACH_MAX, APPROACH_MAX, n_approach)
    results, laws, circles, walls = {}, {}, {}, {}
    for prec in ("float64", "float32"):
        t0 = time.perf_counter()
        laws[prec] = verify_laws(prec, args.device, approach)
        circles[prec] = {internal: verify_circle(internal, prec, args.device, n_angles, approach)
                         for internal in (False, True)}
        walls[prec] = time.perf_counter() - t0
        for name, (f, f_ref) in laws[prec].items():
            results[f"{prec}.{name}_norm_err"] = norm_error(f, f_ref)
        for internal, tag in ((False, "ext"), (True, "int")):
            c = circles[prec][internal]
            results[f"{prec}.{tag}_circle_norm_err"] = norm_error(c["f"], c["f_ref"])
        for internal, tag in ((False, "ext"), (True, "int")):
            c = circles[prec][internal]
            results[f"{prec}.{tag}_gap_max_abs_err_m"] = float(np.max(np.abs(c["g"] - c["g_ref"])))
        results[f"{prec}.wall_s"] = walls[prec]
        peak = {name: float(np.max(f_ref)) for name, (_, f_ref) in laws[prec].items()}
        print(f"{prec}: " + ", ".join(f"{k} = {v:.3g}" for k, v in results.items() if k.startswith(prec)),
              f"(peak law forces {peak} N)")
    plot(args.out, approach, laws, circles)
    settings = {
        "approach_range_m": [-APPROACH_MAX, APPROACH_MAX], "n_approach": n_approach, "n_angles": n_angles,
        "laws": {name: {"k": k, "p": p} for name, (k, p) in LAWS.items()},
        "circle": {"pin_radius_m": PIN_RADIUS, "circle_radius_m": CIRCLE_RADIUS, "circle_centre_m": CIRCLE_CENTRE,
                   "law": {"k": CIRCLE_LAW[0], "p": CIRCLE_LAW[1]}},
        "reference": "NumPy float64 (warp_contacts.laws_ref, circle_geometry_ref) on the precision-rounded inputs",
        "wall_s": "per precision: Warp evaluations and reference, including kernel loading",
        "quick": args.quick, "device": args.device,
    }
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=float(sum(walls.values())),
                                 precision="float64,float32", device=args.device)


if __name__ == "__main__":
    main()
