"""Torque sequences on the device row Newton (:mod:`rvtool.solver.device_rows`) for many variant
models: lost motion and the hysteresis (catalogue) loops of RV-40E and every other topology the
row Newton runs, one copy per variant model, all copies advancing together, on
:class:`rvtool.solver.device_torque_path.DeviceTorquePath` (re-exported here; the one model's
form is the device backend's ``"torque_path"`` task, :meth:`rvtool.solver.backends.DeviceBackend.torque_path`).

:func:`device_row_lost_motion`: lost motion = theta_out(+f) - theta_out(-f) on a
:class:`DeviceTorquePath` (the Exudyn protocol: :func:`rvtool.protocols.lost_motion.lost_motion`).
"""
import time

import numpy as np

from ..errors import RvtoolInputError
from ..solver.device_torque_path import ROW_LOST_MOTION_NEWTON, DeviceTorquePath
from ..solver.torque_path import ContinuationSettings


def device_row_lost_motion(newton, torque_level, *, input_angle=0.0, settings=ROW_LOST_MOTION_NEWTON,
                           continuation=ContinuationSettings(), fallback=True):
    """Lost motion of every copy of ``newton`` at ``input_angle`` [rad] between +-``torque_level``
    [N m] on a :class:`DeviceTorquePath` (module docstring). Returns {"lost_motion_rad" (P,),
    "theta_plus", "theta_minus" [rad] (output angle from the kinematic position), "path"
    ("device" / "exudyn"), "status" ("ok" / "failed"), "error", "stats"} with P = the number of
    copies (variants) or 1 (one model)."""
    if not (np.isfinite(torque_level) and torque_level > 0):
        raise RvtoolInputError(f"torque_level = {torque_level!r} N m is outside the valid range (0, inf)")
    t0 = time.perf_counter()
    path = DeviceTorquePath(newton, input_angle=input_angle, settings=settings, continuation=continuation,
                            fallback=fallback)
    th_p = np.atleast_1d(path.go_to(float(torque_level))).astype(float)
    th_m = np.atleast_1d(path.go_to(-float(torque_level))).astype(float)
    st = path.status()
    stats = path.stats()
    stats.update(copies=path.P, wall_s=time.perf_counter() - t0)
    return {"lost_motion_rad": th_p - th_m, "theta_plus": th_p, "theta_minus": th_m,
            "path": [None if s == "failed" else s for s in st], "status": ["failed" if s == "failed" else "ok"
                                                                          for s in st],
            "error": [path.why[c] or None if s != "device" else None for c, s in enumerate(st)], "stats": stats}


__all__ = ["DeviceTorquePath", "ROW_LOST_MOTION_NEWTON", "device_row_lost_motion"]
