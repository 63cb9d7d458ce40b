"""Jenkins element (a spring in series with a Coulomb slider) under a cyclic drive, integrated by the production driver.

A drive coordinate follows x_d(t) = x_a sin(2 pi f t); a spring k ties it to a
block pressed with F_N onto a nearly flat ground circle through the anchor
friction model of the circle-contact family (mu, tangential stiffness k_t).
The anchor regularizes stick by the elastic spring k_t in series with k, so
the model's exact quasi-static response is the Jenkins element of stick
stiffness k_s = k k_t / (k + k_t) and slip force F_c = mu F_N: the branches
start at the reversal points (x_r, F_r) = (±x_a, ±F_c) as

    F(x_d) = clip(F_r + k_s (x_d - x_r), -F_c, F_c)            (Masing branches)

(virgin branch: x_r = F_r = 0), and the loop of one cycle encloses

    A = ∮ F dx_d = 4 F_c (x_a - F_c / k_s).

This closed form for the series springs k, k_t is the reference (not the
rigid-stick form 4 F_c (x_a - F_c/k), which differs by 4 F_c^2/k_t).

Reported:
* loop_area_rel_err: |∮ F dx_d - A| / A over the last full loop (+peak to
  +peak), F = k (x_d - x_b) the spring force the drive transmits;
* branch_max_abs_err_m: max over all accepted samples of |x_b - x_b,cf| with
  x_b the block (slider-side) displacement and x_b,cf = x_d - F(x_d)/k from the
  closed-form branch at the same drive displacement;
* energy_balance_rel_err: the balance residual of the run's energy account
  (drive work against friction dissipation, elastic storage, kinetic energy and
  damping, from accepted steps) relative to the drive work.
"""
import math
import time

import numpy as np

from rvtool import casekit
from exudyn_user_elements.scenes import jenkins_element
from rvtool.observe import ObserverRegistry
from rvtool.observe.energy import EnergyAccount
from rvtool.protocols.hysteresis import Cycle, jenkins_branch, loop_integral, zero_torque_width
from rvtool.solver import RunSpec, simulate
from warp_contacts import circle_pairs_ref as ref

PARAMS = dict(normal_load=100.0, mu=0.3, tangential_stiffness=1e6, spring=1e5, amplitude=1e-3, frequency=0.1,
              block_mass=0.05, drive_mass=0.01, surface_radius=100.0, normal_damping=200.0)


class _Samples:
    """Drive and block displacement and the friction force of every accepted step (case-local observer)."""

    def __init__(self, element, drive_index, block_index):
        self.el, self.i_d, self.i_b = element, drive_index, block_index
        self.t, self.x_d, self.x_b, self.f_t = [], [], [], []

    def on_accepted(self, step):
        self.t.append(step.t_end)
        self.x_d.append(step.q_end[self.i_d])
        self.x_b.append(step.q_end[self.i_b])
        self.f_t.append(float(self.el.last_obs[0, ref.O_FT]))

    def results(self):
        return {}


def closed_form_force(t, x_d, *, amplitude, frequency, dwell, k_s, f_c):
    """F_cf at each sample: the virgin branch before the first peak, then the branch from the last peak."""
    period = 1.0 / frequency
    f = np.empty_like(x_d)
    peaks = np.floor((t - dwell - period / 4) / (period / 2))  # reversals passed; -1 before the first peak
    for j in np.unique(peaks):
        sel = peaks == j
        if j < 0:
            f[sel] = jenkins_branch(x_d[sel], stiffness=k_s, slip_force=f_c)
        else:
            x_r = amplitude * (1.0 if j % 2 == 0 else -1.0)
            f[sel] = jenkins_branch(x_d[sel], stiffness=k_s, slip_force=f_c, x_reversal=x_r,
                                    f_reversal=np.sign(x_r) * f_c)
    return f


def run(quick=False, steps_per_cycle=None, loops=None, spectral_radius=0.8):
    p = PARAMS
    k, kt, x_a, freq = p["spring"], p["tangential_stiffness"], p["amplitude"], p["frequency"]
    k_s = k * kt / (k + kt)
    f_c = p["mu"] * p["normal_load"]
    assert x_a > f_c / k_s, "the drive must exceed the stick range for a loop"
    period = 1.0 / freq
    n = steps_per_cycle or (400 if quick else 2000)
    loops = loops or (1 if quick else 2)
    dwell = period / n  # one step at rest: the anchor forms at the first accepted commit
    SC, mbs, el, items = jenkins_element(dwell=dwell, **p)
    i_d = int(mbs.systemData.GetNodeLTGODE2(items["drive_node"])[0])
    i_b = int(mbs.systemData.GetNodeLTGODE2(items["block_node"])[0])
    spec = RunSpec(end_time=dwell + period / 4 + loops * period, step=period / n, spectral_radius=spectral_radius,
                   abs_tol=1e-6, rel_tol=1e-8)
    samples = _Samples(el, i_d, i_b)
    reg = ObserverRegistry()
    reg.register("samples", samples)
    account = EnergyAccount(mbs, [el])
    t0 = time.perf_counter()
    rec = simulate(mbs, spec, [el], reg, energy=account)
    wall = time.perf_counter() - t0
    t, x_d, x_b = (np.array(a) for a in (samples.t, samples.x_d, samples.x_b))
    force = k * (x_d - x_b)
    f_cf = closed_form_force(t, x_d, amplitude=x_a, frequency=freq, dwell=dwell, k_s=k_s, f_c=f_c)
    x_b_cf = x_d - f_cf / k
    # the last full loop, +peak to +peak (accepted times land on the peaks: n is a multiple of 4)
    t_start = dwell + period / 4 + (loops - 1) * period
    eps = 1e-6 * spec.step
    sel = (t >= t_start - eps) & (t <= t_start + period + eps)
    loop = Cycle(torque=force[sel], angle=x_d[sel])
    area = loop_integral(loop)
    area_cf = 4 * f_c * (x_a - f_c / k_s)
    energy = rec.energy
    return {
        "loop_area_rel_err": abs(area - area_cf) / area_cf,
        "branch_max_abs_err_m": float(np.abs(x_b - x_b_cf).max()),
        "energy_balance_rel_err": energy["balance_rel_err"],
        "wall_s": wall,
        # details for the plot, the notes and the tests (not written to results.json)
        "_detail": {"t": t, "x_d": x_d, "x_b": x_b, "force": force, "f_cf": f_cf, "f_t": np.array(samples.f_t),
                    "area_J": area, "area_cf_J": area_cf, "width_m": zero_torque_width(loop),
                    "width_cf_m": 2 * (x_a - f_c / k_s), "k_s": k_s, "f_c": f_c, "energy": energy,
                    "record": rec.to_dict(), "spec": spec, "loop_sel": sel, "loops": loops},
    }


def error_bounds(d):
    """Error bounds of the three figures from the run's own parameters (derivations as in
    tests/test_jenkins.py): relative loop area, absolute branch error [m], relative energy balance."""
    p = PARAMS
    k, kt, m_b = p["spring"], p["tangential_stiffness"], p["block_mass"]
    x_a, w, R, F_N, mu = p["amplitude"], 2 * math.pi * p["frequency"], p["surface_radius"], p["normal_load"], p["mu"]
    k_s, f_c, dt = d["k_s"], d["f_c"], d["spec"].step
    area = 4 * f_c * (x_a - f_c / k_s)
    # loop area: the trapezoidal loop cuts the two stick->slip corners (k_s dx^2/8 each, dx = w x_a dt),
    # the ground circle of radius R adds a conservative spring -F_N/R and changes F_c by mu F_c x_a / R
    area_tol = k_s * (w * x_a * dt) ** 2 / 4 + F_N / (R * k) * 4 * f_c * x_a + mu * f_c * x_a / R * 4 * x_a
    # branches: the block's inertia ringing after a stick->slip transition (undamped bound), the ground
    # curvature and the Newton tolerance
    branch_tol = (w * x_a * kt / (k + kt)) / math.sqrt(k / m_b) + F_N * x_a / (R * k) + d["spec"].abs_tol / k
    # energy: k_s dx^2/2 per stick->slip step plus the ringing energy per transition, one per half cycle
    dv = w * x_a * kt / (k + kt)
    transitions = 2 * d["loops"] + 1   # the virgin quarter cycle's, then one per half cycle
    balance_tol = transitions * (k_s * (w * x_a * dt) ** 2 / 2 + 0.5 * m_b * dv ** 2)
    return {"loop_area_rel": area_tol / area, "branch_m": branch_tol,
            "energy_balance_rel": balance_tol / d["energy"]["balance_scale_J"]}


def judge(r):
    """The case's checks on its results (see casekit.verdict): the closed form within the derived bounds."""
    b = r["error_bounds"]
    return {
        "loop_area": casekit.check(r["loop_area_rel_err"], b["loop_area_rel"], "<=",
                                   why="Jenkins loop area 4 F_c (x_a - F_c/k_s); corner cut + ground curvature"),
        "branches": casekit.check(r["branch_max_abs_err_m"], b["branch_m"], "<=",
                                  why="Masing branches; inertia ringing + curvature + Newton tolerance"),
        "energy_balance": casekit.check(r["energy_balance_rel_err"], b["energy_balance_rel"], "<=",
                                        why="friction dissipation vs drive work; corner steps + ringing"),
    }


def plot(res, out):
    import matplotlib.pyplot as plt
    d = res["_detail"]
    p = PARAMS
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    x = np.linspace(-p["amplitude"], p["amplitude"], 400)
    for x_r in (p["amplitude"], -p["amplitude"]):
        f = jenkins_branch(x, stiffness=d["k_s"], slip_force=d["f_c"], x_reversal=x_r,
                           f_reversal=np.sign(x_r) * d["f_c"])
        ax.plot(x * 1e3, f, "k-", lw=2.5, alpha=0.35, label="closed form" if x_r > 0 else None)
    xv = np.linspace(0, p["amplitude"], 100)
    ax.plot(xv * 1e3, jenkins_branch(xv, stiffness=d["k_s"], slip_force=d["f_c"]), "k--", lw=1, alpha=0.5,
            label="closed form, virgin branch")
    ax.plot(d["x_d"] * 1e3, d["force"], "C0-", lw=0.9, label="production driver (accepted steps)")
    ax.set_xlabel("drive displacement x_d [mm]")
    ax.set_ylabel("spring force F [N]")
    ax.set_title(f"Jenkins loop: area error {res['loop_area_rel_err']:.1e}")
    ax.legend(fontsize=8)
    bx.plot(d["t"], (d["x_b"] - (d["x_d"] - d["f_cf"] / p["spring"])) * 1e9, "C1-", lw=0.8)
    bx.set_xlabel("time [s]")
    bx.set_ylabel("x_b - x_b,closed form [nm]")
    bx.set_title(f"branch error, max {res['branch_max_abs_err_m']:.1e} m")
    fig.tight_layout()
    casekit.save_figure(fig, out, "jenkins_loop")


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t0 = time.perf_counter()
    res = run(quick=args.quick)
    plot(res, args.out)
    d = res.pop("_detail")
    res["error_bounds"] = error_bounds(d)
    print(f"loop area {d['area_J']:.6e} J (closed form {d['area_cf_J']:.6e} J), rel. err {res['loop_area_rel_err']:.2e}; "
          f"zero-force width {d['width_m']:.6e} m (closed form {d['width_cf_m']:.6e} m); branch error "
          f"{res['branch_max_abs_err_m']:.2e} m; energy balance rel. err {res['energy_balance_rel_err']:.2e} "
          f"(friction {d['energy']['friction_dissipation_total_J']:.6e} J of drive work {d['energy']['drive_work_J']:.6e} J); "
          f"{d['record']['accepted_steps']} accepted / {d['record']['rejected_steps']} rejected steps in {res['wall_s']:.2f} s")
    settings = {"params": PARAMS, "run_spec": d["spec"].to_dict(), "quick": args.quick,
                "reference": "series springs k, k_t with Coulomb slider: A = 4 F_c (x_a - F_c/k_s), k_s = k k_t/(k + k_t)"}
    casekit.verdict(res, judge)
    return casekit.write_results(args.out, res, settings=settings, wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
