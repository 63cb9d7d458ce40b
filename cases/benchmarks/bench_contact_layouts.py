"""Benchmark of the two contact-element layouts of the RV and STD builders (issue 19, "one
contact element per Exudyn system"; ``build(..., contact_element=...)``), in the same run.

"per_family": one Exudyn element per contact family (five on rv40e), each with its own force and
Jacobian callbacks, the drive a Python offset function. "merged": one element carrying every
family (:class:`~exudyn_user_elements.merged_element.MergedContactElement`), one callback pair per
Newton evaluation, the launchable families summed on the device, the drive set per attempt.
Per layout, after a warm-up in the same process (imports, kernel loads, first launches):

* rv40e (rigid ring): the sequential quasi-static TE path (one warm-started Exudyn static solve per
  point, 40 points per cycloid mesh cycle; 200 points in blocks of 50, --quick 40 in blocks of 20;
  each block starts from the solver's cold start) in ms per point, and a
  driven run at the rated speed and load (1,000 steps of 2e-5 s; --quick 100) in us per step,
  with the Python crossings per step (element callbacks from Exudyn);
* rv40e with the ring pins on the ported elastic housing (``housing.model = "ports"``: 40 pin ports,
  the pins' element spans the housing's modal coordinates; 40 points in blocks of 20, --quick 4
  in one block on a coarser housing mesh) in ms per point;
* std_involute: quasi-static TE (200 points, --quick 40) in ms per point.

The layouts alternate point block by point block (interleaved) so that both see the same load of a
shared machine; each figure is the median over the blocks. The per-family layout is the reference
of every error: the largest TE difference of the merged layout at the same points (round-off: the
families' forces are summed in another order) and the dynamic run's step and Newton counts.
"""
import time

import numpy as np

from rvtool import casekit, designs
from rvtool import build
from rvtool.assembly.contact_layout import CONTACT_ELEMENTS
from rvtool import load_design as load_rv
from rvtool import load_design as load_std
from rvtool.protocols.precision import dynamic_te, quasi_static_te
from rvtool.solver import RunSpec
from rvtool.solver.static import StaticSolver
from rvtool.units import ARCSEC_PER_RAD

QUICK_MESH_SIZE = 0.008
"""--quick: the ported housing meshed at 8 mm (as rv_housing_ports --quick): a reduction of seconds."""


def callback_calls(model):
    """Element force + Jacobian callback calls from Exudyn so far (the Python crossings of the
    contact elements)."""
    objs = [model.contact_host] if model.contact_host is not None else list(model.elements.values())
    return sum(o.n_force_calls + o.n_jacobian_calls for o in objs)


class Sequence:
    """Quasi-static TE of one design in one layout, block by block (the solver kept across blocks)."""

    def __init__(self, design, layout, angles):
        self.model = build(design, contact_element=layout)
        self.torque = design.rated_torque
        self.solver = StaticSolver(self.model)
        self.angles = angles
        # warm-up: one point (kernel loads, first launches, Exudyn's solver set-up)
        quasi_static_te(self.model, torque=self.torque, input_angles=angles[:1], solver=self.solver)
        self.te, self.block_ms = [], []

    def run_block(self, sl):
        qs = quasi_static_te(self.model, torque=self.torque, input_angles=self.angles[sl], solver=self.solver)
        self.te.append(qs["te"])
        self.block_ms.append(1e3 * qs["wall_s"] / len(self.angles[sl]))


def sequences(design, angles, block):
    """{layout: figures} of the interleaved sequential TE, and the largest TE difference [arcsec]."""
    runs = {lay: Sequence(design, lay, angles) for lay in CONTACT_ELEMENTS}
    for b0 in range(0, len(angles), block):
        for lay in CONTACT_ELEMENTS:
            runs[lay].run_block(slice(b0, b0 + block))
    te = {lay: np.concatenate(r.te) for lay, r in runs.items()}
    out = {lay: {"ms_per_point": float(np.median(r.block_ms)), "blocks_ms_per_point": r.block_ms,
                 "newton_per_point": r.solver.stats.newton_iterations / (len(angles) + 1),
                 "te_pp_arcsec": float(np.ptp(te[lay]) * ARCSEC_PER_RAD)} for lay, r in runs.items()}
    out["points"] = len(angles)
    out["te_max_abs_diff_arcsec"] = float(np.max(np.abs(te["merged"] - te["per_family"])) * ARCSEC_PER_RAD)
    out["merged_speedup"] = out["per_family"]["ms_per_point"] / out["merged"]["ms_per_point"]
    return out


def dynamic(design, steps, step, repeats):
    """{layout: figures} of driven runs of ``steps`` steps, the layouts alternating ``repeats`` times
    (each a fresh build, warmed by 10 steps), and the largest TE difference [arcsec]."""
    out = {lay: {"us_per_step": [], "crossings_per_step": None} for lay in CONTACT_ELEMENTS}
    te = {}
    for _ in range(repeats):
        for lay in CONTACT_ELEMENTS:
            spec = RunSpec(end_time=10 * step, step=step, abs_tol=1e-6, rel_tol=1e-8)
            dynamic_te(build(design, contact_element=lay), torque=design.rated_torque,
                       speed_rpm=design.input_speed_rpm, duration=10 * step, run_spec=spec)
            model = build(design, contact_element=lay)
            spec = RunSpec(end_time=steps * step, step=step, abs_tol=1e-6, rel_tol=1e-8)
            c0 = {}
            dyn = dynamic_te(model, torque=design.rated_torque, speed_rpm=design.input_speed_rpm,
                             duration=steps * step, run_spec=spec,
                             on_start=lambda m=model: c0.update(calls=callback_calls(m)))
            rec = dyn["record"]
            n = max(rec.accepted_steps, 1)
            o = out[lay]
            o["us_per_step"].append(1e6 * rec.wall_s / n)
            o.update(steps=rec.accepted_steps, rejected_steps=rec.rejected_steps,
                     newton_per_step=rec.newton_iterations / n,
                     crossings_per_step=(callback_calls(model) - c0["calls"]) / n)
            te[lay] = dyn["te"]
    for lay in CONTACT_ELEMENTS:
        out[lay]["us_per_step_median"] = float(np.median(out[lay]["us_per_step"]))
    out["te_max_abs_diff_arcsec"] = float(np.max(np.abs(te["merged"] - te["per_family"])) * ARCSEC_PER_RAD)
    out["same_step_and_newton_counts"] = bool(
        (out["merged"]["steps"], out["merged"]["newton_per_step"], out["merged"]["rejected_steps"])
        == (out["per_family"]["steps"], out["per_family"]["newton_per_step"], out["per_family"]["rejected_steps"]))
    out["merged_speedup"] = out["per_family"]["us_per_step_median"] / out["merged"]["us_per_step_median"]
    return out


def judge(r):
    """The benchmark's correctness checks (see casekit.verdict); its times are reported, not judged."""
    rp = r["reproduces_per_family"]
    dyn = r["rv40e_dynamic"]
    return {
        # the merged element reproduces the per-family reference: round-off of the summation order (~1e-10
        # arcsec); a missing or misplaced family would move the TE by arcseconds
        "merged_reproduces_te": casekit.check(rp["largest_te_diff_arcsec"], rp["tolerance_arcsec"], "<=",
                                              why="same equilibria, another summation order"),
        "same_steps_and_newton_counts": casekit.check(dyn["same_step_and_newton_counts"], True, "==",
                                                      why="the same dynamic run step by step"),
        "no_rejected_steps": casekit.check(sum(v.get("rejected_steps", 0) for v in dyn.values() if isinstance(v, dict)),
                                           0, "==", why="maximum 0 in the smooth rated run"),
    }


def main(argv=None):
    args = casekit.parse_args(argv, __doc__)
    t_all = time.perf_counter()
    rv = load_rv(designs.path("rv40e"))
    std = load_std(designs.path("std_involute"))
    q = args.quick
    # blocks: each starts from the static solver's cold start (a load ramp), as a quasi-static TE call does
    n_rv, n_ported, n_std, block = (40, 4, 40, 20) if q else (200, 40, 200, 50)
    steps, step, repeats = (100, 2e-5, 1) if q else (1000, 2e-5, 3)

    period = build(rv, contact_element="per_family").mesh_period
    results = {"rv40e_quasistatic": sequences(rv, np.arange(n_rv) * period / 40, block)}
    ported = rv.replace(housing={"model": "ports", **({"structure": {"mesh_size": QUICK_MESH_SIZE}} if q else {})})
    results["rv40e_ported_housing_quasistatic"] = sequences(ported, np.arange(n_ported) * period / 40,
                                                            n_ported if q else n_ported // 2)
    std_period = build(std, contact_element="per_family").mesh_period
    results["std_involute_quasistatic"] = sequences(std, np.arange(n_std) * std_period / 40, block)
    results["rv40e_dynamic"] = dynamic(rv, steps, step, repeats)
    # the merged layout reproduces the reference: TE to 1e-6 arcsec (round-off of the family
    # summation order is ~1e-10 arcsec; a missing or misplaced family moves TE by arcseconds)
    diffs = [results[k]["te_max_abs_diff_arcsec"] for k in results]
    results["reproduces_per_family"] = {"largest_te_diff_arcsec": max(diffs), "tolerance_arcsec": 1e-6,
                                        "passed": bool(max(diffs) < 1e-6
                                                       and results["rv40e_dynamic"]["same_step_and_newton_counts"])}
    results["wall_s"] = time.perf_counter() - t_all
    settings = {"quick": q, "points": {"rv40e": n_rv, "rv40e_ported": n_ported, "std_involute": n_std},
                "interleaved_block_points": block, "points_per_mesh_cycle": 40, "dynamic_steps": steps,
                "dynamic_step_s": step, "dynamic_repeats": repeats, "device": "cpu", "precision": "float64",
                "ported_housing_mesh_size": QUICK_MESH_SIZE if q else "design default"}
    casekit.verdict(results, judge)
    return casekit.write_results(args.out, results, settings=settings, wall_s=results["wall_s"])


if __name__ == "__main__":
    main()
