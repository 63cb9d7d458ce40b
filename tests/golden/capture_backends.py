"""Capture the backends' golden figures (tests/golden/backends.json) with the code of the day.

Run from the project root: ``PYTHONPATH=$PWD python tests/golden/capture_backends.py``.
Written ONCE before the backends refactor (issue 29) from commit 8d3787b (main of 2026-11-27),
so that tests/test_backends_golden.py can hold every backend after the refactor to the figures
of before: equilibria 1e-9 relative, TE 1e-6 arcsec, lost motion 1e-6 arcmin. Do not rerun it
to make a failing test pass; rerun it only for a deliberate change of a figure and say why in
tests/golden/README.md.
"""
import json
import pathlib
import sys

import numpy as np

import rvtool
from rvtool.units import ARCMIN_PER_RAD, ARCSEC_PER_RAD

HERE = pathlib.Path(__file__).parent
DESIGNS = ("rd40", "rv40e", "std_involute", "rv_three_stage")
ANGLES = [0.0, 1.3, 4.9]                  # equilibria [rad]: spread mesh phases, as tests/test_device_newton.py
REG = (1e4, 100.0)                        # the Monte Carlo's regularization


def te_angles(model):
    """The quick `rvtool analyze te` angles: one input revolution, 4 points per mesh cycle."""
    mesh = float(model.mesh_period)
    n = int(round(2 * np.pi / mesh * 4))
    return np.arange(n) * mesh / 4


def variants():
    from rvtool.variants import Variant
    rng = np.random.default_rng(7)
    return [Variant(index=i, eccentricity_error=rng.normal(0, 1e-6), pin_centre_errors=rng.normal(0, 2e-6, (40, 2)),
                    pin_radius_error=rng.normal(0, 1e-6), pin_clearance=abs(rng.normal(0, 2e-6)),
                    bearing_clearance=None if i % 2 else 6e-6) for i in range(2)]


def exudyn_figures(name):
    from rvtool.protocols.lost_motion import lost_motion
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.protocols.stiffness import TorqueSequence, lost_motion_from_levels, quasi_static_stiffness
    from rvtool.solver.static import StaticSolver
    d = rvtool.load_design(name)
    m = rvtool.build(d)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    s = StaticSolver(m)
    q = [s.solve(a).tolist() for a in ANGLES]
    angles = te_angles(m)
    te = quasi_static_te(rvtool.build(d), torque=d.rated_torque, input_angles=angles)
    seq = TorqueSequence(rated_torque=d.rated_torque, loading_step=0.25, other_step=0.25)
    st = quasi_static_stiffness(rvtool.build(d), seq)
    lm_cont = lost_motion_from_levels(st["torque_Nm"], st["angle_arcmin"], d.rated_torque, 0.03)
    lm = lost_motion(rvtool.build(d), torque_level=0.03 * d.rated_torque)
    return {"equilibria_angles_rad": ANGLES, "equilibria_q": q, "te_angles_rad": angles.tolist(),
            "te_theta_in_rad": te["theta_in"].tolist(), "te_arcsec": (te["te"] * ARCSEC_PER_RAD).tolist(),
            "te_peak_loads_N": te["peak_loads"],
            "stiffness_torque_Nm": st["torque_Nm"].tolist(), "stiffness_angle_arcmin": st["angle_arcmin"].tolist(),
            "lost_motion_continuation_arcmin": float(lm_cont),
            "lost_motion_march_arcmin": float(lm["lost_motion_rad"] * ARCMIN_PER_RAD)}


def replica_figures(name):
    from rvtool.batched.sequence import batched_quasi_static_te
    d = rvtool.load_design(name)
    angles = te_angles(rvtool.build(d))[:12]
    r = batched_quasi_static_te(d, torque=d.rated_torque, input_angles=angles, copies=4)
    return {"te_angles_rad": angles.tolist(), "te_arcsec": (r["te"] * ARCSEC_PER_RAD).tolist(),
            "theta_in_rad": r["theta_in"].tolist()}


def device_figures():
    from rvtool.batched.device_te import device_te
    from rvtool.protocols.precision import dynamic_te
    from rvtool.solver import RunSpec
    d = rvtool.load_design("rd40")
    vs = variants()
    te = device_te(d, vs, np.array(ANGLES), regularization=REG, device="cpu")
    step, n = 2e-5, 50
    spec = RunSpec(end_time=n * step, step=step, abs_tol=1e-6, rel_tol=1e-8)
    kw = dict(torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=n * step, run_spec=spec)
    fused = dynamic_te(rvtool.build(d), solver="fused", device="cpu", **kw)
    exu = dynamic_te(rvtool.build(d), solver="exudyn", **kw)
    return {"device_te_angles_rad": ANGLES, "device_te_arcsec": (te.te * ARCSEC_PER_RAD).tolist(),
            "device_te_theta_out_rad": te.theta_out.tolist(),
            "dynamic_steps": n, "dynamic_step_s": step,
            "fused_t_s": fused["t"].tolist(), "fused_te_arcsec": (fused["te"] * ARCSEC_PER_RAD).tolist(),
            "exudyn_t_s": exu["t"].tolist(), "exudyn_te_arcsec": (exu["te"] * ARCSEC_PER_RAD).tolist()}


def main():
    out = {"note": __doc__.strip().splitlines()[2], "exudyn": {}, "replica": {}}
    for name in DESIGNS:
        out["exudyn"][name] = exudyn_figures(name)
        print(name, "exudyn done", flush=True)
    for name in ("rd40", "rv40e"):
        out["replica"][name] = replica_figures(name)
        print(name, "replica done", flush=True)
    out["device"] = {"rd40": device_figures()}
    path = HERE / "backends.json"
    path.write_text(json.dumps(out, indent=1))
    print("wrote", path)


if __name__ == "__main__":
    sys.exit(main())
