"""The device torque path: load continuation on the device row Newton
(:class:`rvtool.solver.device_rows.DeviceRowNewton`), the device form of
:class:`rvtool.solver.torque_path.ContinuationPath` (the backends' ``"torque_path"`` task of
:class:`rvtool.solver.backends.DeviceBackend`; the lost motion and hysteresis loops of many
variant models: :mod:`rvtool.batched.device_rows_lost_motion`).

``go_to(torque)`` moves every copy to the output torque and returns its output angle from the
kinematic position, so the catalogue's loop functions
(:func:`rvtool.protocols.catalogue.catalogue_loop` / ``catalogue_loops``) and the stiffness
sequence run on it unchanged for one copy, and level by level for many. The increment control is
the cycloid device path's (:mod:`rvtool.batched.device_lost_motion`, :class:`ContinuationSettings`):

1. start (the first ``go_to``, or ``initial_torque``): every copy at the first of
   :data:`~rvtool.solver.torque_path.START_SCALES` x torque that converges from its kinematic
   state (warm start, then the regularization homotopy), then down to the torque as in 2;
2. every further level: copy c solves at its level if the rest fits in its increment, else at
   ``t_now + inc``; accepted if converged (plausibility bounds included) and max |q - q_prev| <=
   ``max_step``, then ``inc`` doubles while smaller than the rest; rejected: ``inc`` halves, below
   ``min_increment`` the copy has failed. Warm starts only (a restart from the kinematic state
   would leave the branch);
3. a copy that fails continues on Exudyn (``fallback``): a :class:`ContinuationPath` of its
   model started at the level it failed on, counted in ``exudyn_copies`` (never hidden); without
   fallback its angles are NaN from there on.

The contacts are history-free (the row Newton takes no stick--slip anchors), so an equilibrium
at a torque does not depend on the path to it where it is unique: RV-40E's lost motion from the
Exudyn continuation and from the spring-controlled march agree to 3e-11 arcmin
(tests/golden/backends.json), and the device reproduces both.
"""
import time

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from .device_newton import DeviceNewtonSettings
from .model_snapshot import real_model
from .torque_path import START_SCALES, ContinuationPath, ContinuationSettings, TorquePath

ROW_LOST_MOTION_NEWTON = DeviceNewtonSettings(max_step_rotation=1e-3)
"""Newton settings of the levels: the TE's with a rotation step limit of 1e-3 rad (as
:data:`rvtool.batched.device_lost_motion.LOST_MOTION_NEWTON`: below the free play a level step can cross)."""


class DeviceTorquePath(TorquePath):
    """Load continuation of every copy of ``newton`` (a :class:`~rvtool.solver.device_rows.DeviceRowNewton`:
    one copy per variant model, or one copy of one model) at ``input_angle`` [rad] (module
    docstring). ``go_to(torque)`` [N m] (on the output coordinate, as ContinuationPath's) returns
    the output angles from the kinematic position [rad]: a float for one model, (P,) for P variant
    copies. ``stats()``: rounds, copy solves, Newton iterations, wall-time split, Exudyn copies.
    ``state(copy)``: a copy's last equilibrium in its model's coordinates. initial_torque [N m]:
    the torque of the loaded start (None: the first torque asked for; the path then continues
    from there to that torque, as :class:`~rvtool.solver.torque_path.ContinuationPath`)."""

    def __init__(self, newton, *, input_angle=0.0, settings=ROW_LOST_MOTION_NEWTON,
                 continuation=ContinuationSettings(), fallback=True, initial_torque=None):
        self.newton, self.settings, self.cs, self.fallback = newton, settings, continuation, fallback
        if initial_torque is not None and not np.isfinite(initial_torque):
            raise RvtoolInputError(f"initial_torque = {initial_torque!r} N m must be finite (None: the first level)")
        self.initial_torque = initial_torque
        self.P = P = newton.B if newton.models is not None else 1
        self.models = newton.models or [newton.model]
        self.ang = np.full(P, float(input_angle))
        self.kin = newton.kinematic(self.ang, self._cp(np.arange(P)))
        self.q = None
        self.t_now = np.full(P, np.nan)
        self.exudyn = {}                       # copy -> ContinuationPath on Exudyn (after a device failure)
        self.failed = np.zeros(P, bool)
        self.exudyn_failed = set()             # copies whose Exudyn continuation failed too
        self.why = [""] * P
        self._stats = {"levels": 0, "rounds": 0, "copy_solves": 0, "newton_iterations": 0, "kernels_s": 0.0,
                       "scatter_s": 0.0, "step_s": 0.0, "exudyn_s": 0.0,
                       "start_scales": {f"{sc:g}": 0 for sc in START_SCALES}}

    def _cp(self, idx):
        return idx if self.newton.models is not None else None

    def _solve(self, idx, torque, q_start, homotopy):
        r = self.newton.solve(self.ang[idx], torque, q_start, copies=self._cp(idx), homotopy=homotopy,
                              settings=self.settings)
        st = self._stats
        st["copy_solves"] += len(idx)
        st["newton_iterations"] += int(r.iterations.sum())
        st["kernels_s"] += r.kernels_s
        st["scatter_s"] += r.scatter_s
        st["step_s"] += r.solve_s
        return r

    def _start(self, torque):
        P = self.P
        self.q = self.kin.copy()
        scale = np.full(P, np.nan)
        for sc in START_SCALES:
            todo = np.flatnonzero(np.isnan(scale))
            if not len(todo):
                break
            r = self._solve(todo, np.full(len(todo), sc * torque), None, True)
            got = r.converged
            self.q[todo[got]] = r.q[got]
            scale[todo[got]] = sc
            self._stats["start_scales"][f"{sc:g}"] += int(got.sum())
        self.t_now = np.where(np.isnan(scale), np.nan, scale * torque)
        for c in np.flatnonzero(np.isnan(scale)):
            self._fail(c, torque, f"no loaded start on the device at {', '.join(f'{s:g}' for s in START_SCALES)} "
                              f"x {torque:.6g} N m")

    def _fail(self, c, torque, why):
        """Copy c leaves the device at level ``torque``: Exudyn from there on, or NaN."""
        self.failed[c] = True
        self.why[c] = why
        if self.newton.history_families:
            # Exudyn's continuation would start from its own model's history, not the levels the device
            # committed: no hand-over (the copy fails, named)
            self.why[c] += ("; no Exudyn hand-over: the model has stick--slip anchors, whose history the device "
                            "committed (a continuation on Exudyn would start without it)")
            return
        if self.fallback:
            self.exudyn[c] = ContinuationPath(real_model(self.models[c]), input_angle=float(self.ang[c]))

    def go_to(self, torque):
        torque = float(torque)
        if not np.isfinite(torque):
            raise RvtoolInputError(f"torque = {torque!r} N m must be finite")
        self._stats["levels"] += 1
        if self.q is None:
            self._start(torque if self.initial_torque is None else float(self.initial_torque))
        cs = self.cs
        running = ~self.failed & (self.t_now != torque)
        inc = torque - self.t_now
        rounds = 0                             # max_rounds bounds each level (a loop has ~100 levels)
        while np.any(running) and rounds < cs.max_rounds:
            rounds += 1
            idx = np.flatnonzero(running)
            rest = torque - self.t_now[idx]
            target = np.where(np.abs(rest) <= np.abs(inc[idx]), torque, self.t_now[idx] + inc[idx])
            r = self._solve(idx, target, self.q[idx], False)
            self._stats["rounds"] += 1
            acc = r.converged & (np.max(np.abs(r.q - self.q[idx]), axis=1) <= cs.max_step)
            a, b = idx[acc], idx[~acc]
            self.q[a] = r.q[acc]
            self.t_now[a] = target[acc]
            rest_a = torque - self.t_now[a]
            inc[a] = np.where(np.abs(inc[a]) < np.abs(rest_a), 2 * inc[a], inc[a])
            running[a[self.t_now[a] == torque]] = False
            inc[b] *= 0.5
            for c in b[np.abs(inc[b]) < cs.min_increment]:
                running[c] = False
                self._fail(c, torque, f"device torque continuation stalled between {self.t_now[c]:.6g} and "
                                      f"{torque:.6g} N m (increment below min_increment = {cs.min_increment:g})")
        for c in np.flatnonzero(running):
            self._fail(c, torque, f"device torque continuation not finished in max_rounds = {cs.max_rounds} rounds")
        done = np.flatnonzero(~self.failed)
        if len(done) and self.newton.history_families:
            # the level's contact history (stick--slip anchors), once per level as Exudyn's continuation
            self.newton.commit(self.q[done], copies=self._cp(done))
        i = self.newton.output_local
        out = self.q[:, i] - self.kin[:, i]
        out[self.failed] = np.nan
        t0 = time.perf_counter()
        for c, path in self.exudyn.items():
            try:
                out[c] = path.go_to(torque)
            except SolverFailure as exc:
                self.why[c] += f"; Exudyn continuation: {exc}"
                self.exudyn_failed.add(c)
        self._stats["exudyn_s"] += time.perf_counter() - t0
        for c in self.exudyn_failed:
            out[c] = np.nan
        return float(out[0]) if self.newton.models is None else out

    def status(self):
        """Per copy: "device", "exudyn" (continued on Exudyn after a device failure) or "failed"."""
        bad = self.exudyn_failed
        return ["failed" if (c in bad or (f and c not in self.exudyn)) else "exudyn" if f else "device"
                for c, f in enumerate(self.failed)]

    def state(self, copy=0):
        """Copy ``copy``'s last equilibrium in its model's coordinates (n,): the device copy's, or
        its Exudyn continuation's after a device failure."""
        if self.q is None:
            raise RvtoolInputError("the torque path has no state before its first go_to(torque)")
        if copy in self.exudyn and self.exudyn[copy].continuation is not None:
            return np.array(self.exudyn[copy].state())
        from .row_extension import model_states
        return model_states(real_model(self.models[copy]), self.q[copy], self.newton.extension)[0]

    def stats(self):
        return dict(self._stats, exudyn_copies=len(self.exudyn),
                    failed_copies=sum(s == "failed" for s in self.status()))


__all__ = ["DeviceTorquePath", "ROW_LOST_MOTION_NEWTON"]
