"""Pressure resolution at the RD-40 rated state (140 N m, zero input angle), one pin contact per wheel.

The contact per wheel is selected once (largest fixed-width pressure measure: the panel peak at the
coarsest grid) and its gap and load are frozen; N = 129 ... 4097 panels over a fixed window.
"""
import time

import numpy as np

from rvtool import casekit
from rvtool.pressure import PanelContact, solve_panels, subsurface_stress
from rvtool.pressure.state import pin_contact_gap


def main(argv=None):
    args = casekit.parse_args(argv, description=__doc__)
    t_all = time.perf_counter()
    from rvtool.assembly.cycloid import build
    from rvtool.assembly.spec import load_design
    from rvtool.protocols.equilibrium import StaticSolver
    m = build(load_design("cases/designs/rd40.toml"))
    s = StaticSolver(m)
    m.set_output_torque(140.0)
    q = s.solve(0.0)
    el = m.elements["pins"]
    ql = el.local(q)
    obs = el.evaluate(0.0, ql, 0 * ql).obs
    E, nu = 210e9, 0.3
    e_star = E / (2 * (1 - nu ** 2))
    ns = [129, 257, 513] if args.quick else [129, 257, 513, 1025, 2049, 4097]
    half = 0.1e-3
    results = {}
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(m.n_wheels, 2, figsize=(12, 4 * m.n_wheels), squeeze=False)
    for k in range(m.n_wheels):
        mesh = m.pin_set.meshes[k]
        cand = [j for j in range(len(m.pin_set.ids)) if m.pin_set.mesh_of[j] == k and obs[j, 0] > 0]
        b = mesh.face_width / mesh.n_slices
        x0 = np.linspace(-half, half, ns[0])
        # selection by the fixed-width (coarsest-grid panel) pressure, done once
        meas = []
        for j in cand:
            g, F = pin_contact_gap(m, q, j, x0)
            meas.append(solve_panels(PanelContact(face_width=b, e_star=e_star, force=F), x0, g).p_raw)
        j = cand[int(np.argmax(meas))]
        out = {"contact": m.pin_set.ids[j], "force_N": float(obs[j, 0]), "N": [], "p_raw": [], "span": [], "wall_s": []}
        fields = []
        for n in ns:
            x = np.linspace(-half, half, n)
            g, F = pin_contact_gap(m, q, j, x)
            t0 = time.perf_counter()
            r = solve_panels(PanelContact(face_width=b, e_star=e_star, force=F), x, g)
            out["wall_s"].append(time.perf_counter() - t0)
            out["N"].append(n); out["p_raw"].append(r.p_raw); out["span"].append(r.span)
            fields.append((x, r.pressure))
        xf, pf = fields[-1]
        out["e1_vs_4097_pct"] = [float(100 * np.sum(np.abs(p - np.interp(x, xf, pf))) / np.sum(np.interp(x, xf, pf)))
                                 for x, p in fields]
        out["p_raw_change_pct"] = [float(100 * abs(a - c) / c) for a, c in zip(out["p_raw"][:-1], out["p_raw"][1:])]
        out["span_change_pct"] = [float(100 * abs(a - c) / c) for a, c in zip(out["span"][:-1], out["span"][1:])]
        out["converged"] = bool(out["p_raw_change_pct"][-1] < 2.0 and out["span_change_pct"][-1] < 1.0)
        results[f"wheel{k}"] = out
        a = 0.5 * out["span"][-1]
        z = np.linspace(a / 100, 2.5 * a, 150)
        st = subsurface_stress(xf, pf, z, nu=nu)
        msk = np.abs(xf) < 2 * a
        axes[k, 0].plot(xf * 1e3, pf / 1e6); axes[k, 0].set_xlabel("x [mm]"); axes[k, 0].set_ylabel("p [MPa]")
        axes[k, 0].set_title(out["contact"])
        c = axes[k, 1].contourf(xf[msk] * 1e3, z * 1e3, st["tau_max"][:, msk] / 1e6, 20)
        fig.colorbar(c, ax=axes[k, 1]); axes[k, 1].invert_yaxis(); axes[k, 1].set_title("tau_max [MPa]")
        out["tau_max_Pa"] = float(st["tau_max"].max())
        out["von_mises_max_Pa"] = float(st["von_mises"].max())
    casekit.save_figure(fig, args.out, "pressure_resolution")
    wall_s = time.perf_counter() - t_all
    casekit.write_results(args.out, results, {"torque_Nm": 140.0, "input_angle": 0.0, "window_halfwidth_m": half,
                                              "E_Pa": E, "nu": nu, "quick": args.quick}, wall_s)
    return results


if __name__ == "__main__":
    main()
