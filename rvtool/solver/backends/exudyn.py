"""The Exudyn backend, the oracle: Exudyn's static solver with its fallback ladder
(:class:`rvtool.solver.static.StaticSolver`) for equilibria, the generalized-alpha driver
(:func:`rvtool.solver.driver.simulate`) with the contact elements for driven runs. It runs every
model a builder returns."""
import dataclasses
import time

import numpy as np

from ... import progress
from ..static import StaticSolver
from .base import Backend, DrivenHistory, Equilibria, Support


class ExudynBackend(Backend):
    """Exudyn static and dynamic (see the module docstring). solver: a :class:`StaticSolver` of
    the model to use for the equilibria (None: a new one per batch)."""
    name = "exudyn"
    tasks = ("equilibria", "dynamic", "torque_path")

    def __init__(self, *, solver=None):
        self.solver = solver

    def supports(self, model, task, run=None):
        if not self._task(task):
            return Support.of([f"exudyn does not implement {task!r}"])
        return Support(True)

    def solve_equilibria(self, model, batch, *, record=None):
        """Warm-started sequence (each point from the previous equilibrium where ``batch.warm_start``),
        the static solver's ladder on failure. record(k, angle, q): called at every solved point."""
        solver = self.solver or StaticSolver(model)
        model.set_output_torque(-np.sign(model.ratio) * batch.torque)
        i_out = model.output_index
        ref_out = model.reference_value(model.output)
        th_in, th_out, qs = [], [], []
        peaks, contact_peaks = {}, {}
        prev = None
        t0 = time.perf_counter()
        for k, a in enumerate(progress.track(batch.input_angles, desc="quasi-static TE", unit="point")):
            q = solver.solve(a, prev if batch.warm_start else None)
            a = solver.last_angle      # the solved angle (a kink shift of <= 1e-5 rad is recorded, not hidden)
            prev = a
            th_in.append(a)
            th_out.append(ref_out + q[i_out])
            qs.append(np.array(q))
            for fam, f in model.family_peaks(q).items():
                peaks[fam] = max(peaks.get(fam, 0.0), f)
            for fam, f in model.family_contact_peaks(q).items():
                contact_peaks[fam] = max(contact_peaks.get(fam, 0.0), f)
            if record is not None:
                record(k, a, q)
        return Equilibria(theta_in=np.array(th_in), theta_out=np.array(th_out), peak_loads=peaks,
                          peak_contact_loads=contact_peaks, regularization_max=model.regularization_force(solver.q),
                          stats=solver.stats.to_dict(), wall_s=time.perf_counter() - t0, q=np.array(qs))

    def torque_path(self, model, *, input_angle=0.0, initial_torque=None):
        """Exudyn's load continuation (:class:`rvtool.solver.torque_path.ContinuationPath`)."""
        from ..torque_path import ContinuationPath
        return ContinuationPath(model, input_angle=input_angle, initial_torque=initial_torque)

    def step_dynamic(self, model, run):
        """Driven run with the Exudyn driver from the StaticSolver's loaded state at angle 0."""
        import exudyn as exu

        from ..driver import simulate
        omega = run.speed_rpm * 2 * np.pi / 60.0
        solver = StaticSolver(model)
        model.set_output_torque(-np.sign(model.ratio) * run.torque)
        q0 = solver.solve(0.0)
        v0 = model.body_vector(model.kinematic_state(0.0, omega).velocities)
        mbs = model.mbs
        mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
        mbs.systemData.SetODE2Coordinates_t(v0, configuration=exu.ConfigurationType.Initial)
        model.set_input_speed(omega)
        mbs.Assemble()
        mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
        mbs.systemData.SetODE2Coordinates_t(v0, configuration=exu.ConfigurationType.Initial)
        i_out, i_in = model.output_index, model.input_index
        ref_out = model.reference_value(model.output)
        t_rec, th_in, th_out = [0.0], [q0[i_in]], [ref_out + q0[i_out]]
        spec = dataclasses.replace(run.run_spec, end_time=run.duration)
        if run.on_start is not None:
            run.on_start()
        with progress.task(run.duration, desc="dynamic TE run", unit="s") as advance:
            def accept(t, q, v):
                t_rec.append(t)
                th_in.append(q[i_in])
                th_out.append(ref_out + q[i_out])
                advance(t)

            rec = simulate(mbs, spec, model.contact_elements(), run.observers, before_accept=accept,
                           out_dir=run.out_dir)
        return DrivenHistory(t=np.array(t_rec), theta_in=np.array(th_in), theta_out=np.array(th_out), record=rec,
                             omega_in=omega)
