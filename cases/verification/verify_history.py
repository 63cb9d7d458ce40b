"""Accepted-step history ownership: a block on an oscillating belt with anchor friction, with and without forced step rejections.

The belt moves as A sin(2 pi f t); the block is tied to the ground by a spring
and pressed on the belt with 100 N, so the anchor friction model (tangential
elastic displacement stored in body coordinates, bounded by mu F_n,
projected on slip) goes through stick and slip twice per cycle. The run is
repeated with every 25th attempt rejected by force (retried with a smaller
step). With correct ownership (trials read z_n, commits only at accepted
states) the slip exposure I_s of Eq. (obs_statistics) and the friction-force
history differ only by the time discretization of the retried steps. As a
control, the same pair of runs is made with a deliberately wrong policy that
commits the history of every trial evaluation: the difference it produces
shows what the ownership rules prevent. The committed history compared is
the anchor state and the accumulated slip distance (the sliding distance a
wear model consumes), which a trial-committing policy counts once per
evaluation instead of once per accepted step.
"""
import time

import numpy as np

from rvtool import casekit
from exudyn_user_elements.scenes import block_on_belt
from rvtool.observe import ObserverRegistry, WholeRun
from rvtool.solver import RunSpec, simulate
from warp_contacts import circle_pairs_ref as ref


class _ForceHistory:
    """Friction force and time of every accepted step (case-local observer)."""

    def __init__(self, element):
        self.el = element
        self.t, self.ft, self.fn = [], [], []

    def on_accepted(self, step):
        self.t.append(step.t_start + step.dt)
        self.ft.append(float(self.el.last_obs[0, ref.O_FT]))
        self.fn.append(float(self.el.last_obs[0, ref.O_FN]))

    def results(self):
        return {}


def _commit_every_trial(el):
    """The wrong policy (control only): every trial overwrites the committed history."""
    inner = el.evaluator.evaluate

    def leaky(pose, vel, history=None, **kw):
        ev = inner(pose, vel, history, **kw)
        el.evaluator.history.assign(ev.trial_history)
        return ev
    el.evaluator.evaluate = leaky


def run(spec, reject_every=0, leaky=False):
    SC, mbs, el = block_on_belt()
    if leaky:
        _commit_every_trial(el)
    reg = ObserverRegistry()
    whole = WholeRun()
    hist = _ForceHistory(el)
    reg.register("whole", whole)
    reg.register("force_history", hist)
    n_max = int(4 * spec.end_time / spec.step) + 10
    rejects = range(reject_every, n_max, reject_every) if reject_every else ()
    t0 = time.perf_counter()
    rec = simulate(mbs, spec, [el], reg, reject_attempts=rejects)
    wall = time.perf_counter() - t0
    acc = whole.accumulator
    i = acc.index("belt/block")
    return {"I_s": float(acc.I_s[i]), "I_F": float(acc.I_F[i]), "t": np.array(hist.t), "ft": np.array(hist.ft),
            "fn": np.array(hist.fn), "rec": rec, "wall_s": wall,
            "slip_distance": float(el.evaluator.history.slip_distance[0])}


def _compare(a, b):
    """Relative differences of slip exposure I_s, of the committed history
    (accumulated slip distance) and of the friction-force time history."""
    exposure = abs(b["I_s"] - a["I_s"]) / abs(a["I_s"])
    history = abs(b["slip_distance"] - a["slip_distance"]) / abs(a["slip_distance"])
    ft_b = np.interp(a["t"], b["t"], b["ft"])
    force = float(np.max(np.abs(ft_b - a["ft"])) / np.max(np.abs(a["ft"])))
    return float(exposure), float(history), force


def judge(r):
    """The case's checks on its results (see casekit.verdict)."""
    return {
        "rejections_happened": casekit.check(r["n_rejected"], 1, ">=", why="the forced rejections must occur"),
        # correct ownership: only the time discretization of the retried steps differs (measured 1.1e-6 in the
        # committed history, 3e-4 in I_s, 4.5e-3 in the friction force); bounds 10x / 6x / 2x above those
        "history_vs_no_rejection": casekit.check(r["history_rel_diff"], 1e-5, "<=",
                                                 why="time discretization of the retried steps only"),
        "exposure_vs_no_rejection": casekit.check(r["exposure_rel_diff"], 2e-3, "<=",
                                                  why="time discretization of the retried steps only"),
        "friction_force_vs_no_rejection": casekit.check(r["friction_force_rel_diff"], 1e-2, "<=",
                                                        why="time discretization of the retried steps only"),
        # the control (history committed at every trial) must be visibly worse, or the test could not fail
        "control_history_worse": casekit.check(
            r["control_wrong_policy_history_rel_diff"] / max(r["history_rel_diff"], 1e-300), 10.0, ">=",
            why="the wrong policy's history error is at least 10x the correct one's (measured 300x)"),
        "control_force_worse": casekit.check(
            r["control_wrong_policy_friction_force_rel_diff"] / max(r["friction_force_rel_diff"], 1e-300), 5.0, ">=",
            why="the wrong policy's friction-force error is at least 5x the correct one's (measured 10x)"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    spec = RunSpec(end_time=0.25 if args.quick else 1.0, step=5e-4 if args.quick else 2e-4, abs_tol=1e-6, rel_tol=1e-8)
    t0 = time.perf_counter()
    base = run(spec)
    rej = run(spec, reject_every=25)
    leak = run(spec, leaky=True)
    leak_rej = run(spec, reject_every=25, leaky=True)
    exposure, history, force = _compare(base, rej)
    leak_exposure, leak_history, leak_force = _compare(leak, leak_rej)
    _, leak_vs_correct, _ = _compare(base, leak)
    ft = base["ft"]
    mu_fn = 0.3 * base["fn"]
    slipping = np.abs(np.abs(ft) - mu_fn) < 1e-6 * mu_fn
    results = {
        "exposure_rel_diff": exposure,
        "history_rel_diff": history,
        "n_rejected": rej["rec"].rejected_steps,
        "friction_force_rel_diff": force,
        "slip_distance_m": base["slip_distance"],
        "reference": "the same run without rejections (difference = time discretization of retried steps)",
        "I_s_Ns_m": base["I_s"], "I_F_Ns": base["I_F"],
        "slip_fraction": float(np.mean(slipping)),
        "control_wrong_policy_exposure_rel_diff": leak_exposure,
        "control_wrong_policy_history_rel_diff": leak_history,
        "control_wrong_policy_friction_force_rel_diff": leak_force,
        "control_wrong_policy_slip_distance_vs_correct_rel": leak_vs_correct,
        "wall_s": [base["wall_s"], rej["wall_s"]],
        "steps": [base["rec"].accepted_steps, rej["rec"].accepted_steps],
        "run_record": base["rec"].to_dict(),
    }
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 3.8))
    ax.plot(base["t"], base["ft"], "-", label="friction force, no rejections")
    ax.plot(rej["t"], rej["ft"], "--", label=f"{rej['rec'].rejected_steps} forced rejections")
    ax.plot(base["t"], mu_fn, "k:", lw=0.8, label="mu F_n")
    ax.plot(base["t"], -mu_fn, "k:", lw=0.8)
    ax.set(xlabel="t [s]", ylabel="tangential force on block [N]")
    ax.legend(fontsize=8)
    casekit.save_figure(fig, args.out, "stick_slip_history")
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=spec.to_dict(), wall_s=time.perf_counter() - t0)


if __name__ == "__main__":
    main()
