"""Torque sequences on the device row Newton (:mod:`rvtool.solver.device_rows`) for many variant
models: lost motion and the hysteresis (catalogue) loops of RV-40E and every other topology the
row Newton runs, one copy per variant model, all copies advancing together, on
:class:`rvtool.solver.device_torque_path.DeviceTorquePath` (re-exported here; the one model's
form is the device backend's ``"torque_path"`` task, :meth:`rvtool.solver.backends.DeviceBackend.torque_path`).

:func:`device_row_lost_motion`: lost motion = theta_out(+f) - theta_out(-f) (the Exudyn protocol:
:func:`rvtool.protocols.lost_motion.lost_motion`), each level reached in one of two ways
(:data:`LEVEL_PATHS`):

* ``"direct"`` (default): each level by its own loaded start from the kinematic state
  (:class:`DeviceTorquePath` with ``initial_torque`` = the level: warm start, regularization
  homotopy, the start scales of :data:`~rvtool.solver.torque_path.START_SCALES`); no copy
  crosses the free play;
* ``"continuation"``: +f by a loaded start, then the load continuation +f -> -f through the
  free play (increments halved on every rejection).

Without stick--slip anchors the contacts are history-free, so the equilibrium at a level does
not depend on the path to it where it is unique; both give the same lost motion: on RD-40's first 250 Monte Carlo variants to
1.7e-12 arcmin (measured with this module on cpu), where the continuation needed 90 rounds of
the whole batch (each up to ``max_iterations`` sweeps: the copies in the free play stall and halve
their increments) and the direct levels one start each (tests/test_device_rows.py checks the
equality on RV-40E and RD-40 variants). A copy whose loaded start fails at a level continues on
Exudyn (``fallback``) and is counted in ``exudyn_copies``. A model with stick--slip anchors (its
contact history committed per level, :meth:`DeviceRowNewton.commit`) always takes the
continuation (``stats["levels_path"]`` says which ran).
"""
import time

import numpy as np

from ..errors import RvtoolInputError
from ..solver.device_torque_path import COMPACT_BELOW, ROW_LOST_MOTION_NEWTON, DeviceTorquePath
from ..solver.torque_path import ContinuationSettings

LEVEL_PATHS = ("direct", "continuation")
"""How :func:`device_row_lost_motion` reaches its levels (module docstring)."""


def device_row_lost_motion(newton, torque_level, *, input_angle=0.0, settings=ROW_LOST_MOTION_NEWTON,
                           continuation=ContinuationSettings(), fallback=True, levels="direct",
                           compact_below=COMPACT_BELOW):
    """Lost motion of every copy of ``newton`` at ``input_angle`` [rad] between +-``torque_level``
    [N m] (module docstring; ``levels``: one of :data:`LEVEL_PATHS`). Returns {"lost_motion_rad"
    (P,), "theta_plus", "theta_minus" [rad] (output angle from the kinematic position), "path"
    ("device" / "exudyn" / None: failed), "status" ("ok" / "failed"), "error", "stats"} with P =
    the number of copies (variants) or 1 (one model); the stats of the two levels' paths summed
    (``exudyn_copies``: copies that continued on Exudyn at either level; ``exudyn_s``: their
    Exudyn time, their models' builds included). compact_below: see :class:`DeviceTorquePath`."""
    if not (np.isfinite(torque_level) and torque_level > 0):
        raise RvtoolInputError(f"torque_level = {torque_level!r} N m is outside the valid range (0, inf)")
    if levels not in LEVEL_PATHS:
        raise RvtoolInputError(f"levels = {levels!r}; valid choices are {list(LEVEL_PATHS)}")
    if levels == "direct" and newton.history_families:
        levels = "continuation"     # stick--slip anchors: the level's equilibrium depends on the path (its history)
    t0 = time.perf_counter()
    f = float(torque_level)
    kw = dict(input_angle=input_angle, settings=settings, continuation=continuation, fallback=fallback,
              compact_below=compact_below)
    plus = DeviceTorquePath(newton, **kw)
    th_p = np.atleast_1d(plus.go_to(f)).astype(float)
    minus = plus if levels == "continuation" else DeviceTorquePath(newton, initial_torque=-f, **kw)
    th_m = np.atleast_1d(minus.go_to(-f)).astype(float)
    paths = [plus] if minus is plus else [plus, minus]
    sts = [p.status() for p in paths]
    st = ["failed" if any(s[c] == "failed" for s in sts) else "exudyn" if any(s[c] == "exudyn" for s in sts)
          else "device" for c in range(plus.P)]
    stats = _summed_stats(paths)
    stats.update(copies=plus.P, levels_path=levels, wall_s=time.perf_counter() - t0)
    why = ["; ".join(w for w in (p.why[c] for p in paths) if w) or None for c in range(plus.P)]
    return {"lost_motion_rad": th_p - th_m, "theta_plus": th_p, "theta_minus": th_m,
            "path": [None if s == "failed" else s for s in st], "status": ["failed" if s == "failed" else "ok"
                                                                          for s in st],
            "error": [why[c] if s != "device" else None for c, s in enumerate(st)], "stats": stats}


def _summed_stats(paths):
    """The stats of the torque paths summed (counts, times, start scales); ``exudyn_copies`` and
    ``failed_copies`` count copies, not paths."""
    out = {}
    for p in paths:
        for k, v in p.stats().items():
            if isinstance(v, dict):
                d = out.setdefault(k, {})
                for kk, vv in v.items():
                    d[kk] = d.get(kk, 0) + vv
            else:
                out[k] = out.get(k, 0) + v
    out["exudyn_copies"] = len(set().union(*(p.exudyn for p in paths)))
    out["failed_copies"] = sum(any(s == "failed" for s in col) for col in zip(*(p.status() for p in paths)))
    return out


__all__ = ["DeviceTorquePath", "LEVEL_PATHS", "ROW_LOST_MOTION_NEWTON", "device_row_lost_motion"]
