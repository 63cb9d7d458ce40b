"""Driven runs of any replicable topology (RV, small-tooth-difference) on the device families'
rows: Exudyn's generalized-alpha step with the contact forces and tangents of the device row
Newton's copied families (issue 31, deliverable 1, first part: the RV driven run off Exudyn).

The step is :class:`warp_contacts.fused_step_ref.ReferenceModel`'s (Exudyn's
``MainSolverImplicitSecondOrder``: predictor, full Newton with the index-3 coordinate constraints
of the drive and the locks, Exudyn's convergence test, adaptive step halving and recovery), one
copy, on the host; only its forces differ: f(q, v), K = df/dq and C = df/dv come from every
contact element of the built model copied once on the Warp device
(:func:`rvtool.solver.replica.copy_families`, the families of
:class:`rvtool.solver.device_rows.DeviceRowNewton`: the same kernels and rows as the model's
Exudyn element), plus the output torque. Masses: the model's rigid bodies (mass, mass, polar
inertia; centre of mass at the node). The static start is Exudyn's (the same StaticSolver as the
Exudyn path), so both paths start from one state.

Where the forces are summed (``sums``): "device" (default) evaluates and sums every family on the
Warp device (:class:`rvtool.solver.row_forces.RowForces`: one captured graph per evaluation, f
read back, K and C gathered only where a Newton iteration needs them), and steps with
:meth:`RowDrivenModel.attempt` / :meth:`RowDrivenModel.advance` (the reference's arithmetic on
the free block, Python scalars for the step control); "host" brings every family's rows back and
sums them with ``np.bincount``, stepping with ReferenceModel's own loop (the reference).

Cost (rv40e, one CPU core, CPU time; docs/benchmarks/fused_rv.md): per accepted step about 3.2
evaluations (the predictor and Exudyn's ~2.2 Newton iterations) and 2.2 tangent gathers; the
families' kernels are most of an evaluation, and they run in Exudyn's path too, so the row
stepper's gain is Exudyn's own overhead per evaluation (``cases/benchmarks/bench_fused_rv.py``
measures it).

This is NOT the fused stepper (one Warp launch per K steps): every Newton iteration replays the
evaluation's graph and reads f back, and the step is on the host. What a fused RV kernel still
lacks is named by :func:`rvtool.solver.device_dynamics.unfused_element_reasons`.
"""
import math
import time

import numpy as np

from warp_contacts.fused_step_ref import (ACTIVE, C_ACCEPTED, C_NEWTON, C_RECORDED, C_REJECTED, C_RUN, DONE,
                                          END_TOLERANCE, FAILED, H_INPUT, H_NEWTON, H_OUTPUT, H_STEP, H_TIME,
                                          H_TORQUE, M_ACCEL, M_ANGLE, M_SPEED, N_COUNT, N_HISTORY, N_MOTION,
                                          S_ABS_TOL, S_ALPHA_F, S_ALPHA_M, S_BETA, S_GAMMA, S_H_MIN, S_H_NOM,
                                          S_MAX_IT, S_RECOVERY, S_RECOVERY_ITERATIONS, S_REL_TOL, S_T_END,
                                          ReferenceModel)

from ..errors import RvtoolInputError, SolverFailure


def _as_slice(idx):
    """``idx`` (sorted, unique) as a slice where it is contiguous, else as it is."""
    if len(idx) and idx[-1] - idx[0] + 1 == len(idx):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def rigid_body_masses(model):
    """(3 nb,) diagonal mass matrix [kg, kg, kg m^2] of the model's bodies from their Exudyn
    RigidBody2D objects (centre of mass at the node required)."""
    mbs = model.mbs
    by_node = {}
    for i in range(mbs.systemData.NumberOfObjects()):
        o = mbs.GetObject(i)
        if o["objectType"] == "RigidBody2D":
            if np.any(np.asarray(o["centerOfMass"]) != 0.0):
                raise RvtoolInputError(f"body object {i} has its centre of mass off its node; the row stepper "
                                       "takes bodies with the centre of mass at the node")
            by_node[int(o["nodeNumber"])] = (float(o["mass"]), float(o["mass"]), float(o["inertia"]))
    try:
        return np.concatenate([by_node[int(n)] for n in model.nodes])
    except KeyError as exc:
        raise RvtoolInputError(f"node {exc} carries no RigidBody2D: the row stepper takes planar rigid bodies") from None


class RowDrivenModel(ReferenceModel):
    """One copy of a built ``model`` for :class:`ReferenceModel`'s step, forces from the copied
    device families (module docstring). torque: output torque [N m] (signed, as applied);
    motion (N_MOTION,): the drive's angle, speed, acceleration; settings_vector: the stepper's
    settings (:meth:`rvtool.solver.device_dynamics.DeviceDynamicsSettings.vector`); sums: where
    the rows are summed (:data:`SUMS`); device_step: the Newton iterations on the device
    (:class:`DeviceIteration`; None: with the device sums)."""

    def __init__(self, model, *, torque, motion, settings_vector, device="cpu", sums="device", device_step=None):
        from .device_rows import needs_extension, row_reasons
        from .replica import copy_families
        if sums not in SUMS:
            raise RvtoolInputError(f"sums = {sums!r}; valid: {list(SUMS)}")
        reasons = row_reasons(model)
        if reasons:
            raise RvtoolInputError("; ".join(reasons))
        nb = len(model.body_names)
        #: elastic closures / ported structures: the step's unknowns are rvtool.solver.row_closures' y
        self.extended = needs_extension(model)
        idx = np.concatenate([np.asarray(model.mbs.systemData.GetNodeLTGODE2(n), int) for n in model.nodes])
        if self.extended:
            from .row_closures import ExtendedRowForces
            if sums != "device" or device_step:
                raise RvtoolInputError("a model with elastic closures or a ported structure steps with the device "
                                       "sums and the host step only (valid: sums='device', device_step=False)")
            device_step = False
            self.row_forces = ExtendedRowForces(model, device=device)
            co = self.row_forces.coords
            n = co.n
            eta = [int(i) for m in co.modal for i in m[4]]
            if not np.array_equal(idx, np.arange(len(idx))) or len(idx) + len(eta) != model.mbs.systemData.ODE2Size():
                raise RvtoolInputError("the model has coordinates beyond its rigid bodies' (x, y, theta) and its "
                                       "reduced structures' eta; the row stepper takes planar rigid bodies, elastic "
                                       "closures and grounded reduced structures")
        else:
            if not np.array_equal(idx, np.arange(len(idx))) or len(idx) != model.mbs.systemData.ODE2Size():
                raise RvtoolInputError("the model has coordinates beyond its rigid bodies' (x, y, theta); the row "
                                       "stepper takes planar rigid bodies only")
            n = 3 * nb
        self.model = model
        self.sums = sums
        if sums == "device" and not self.extended:
            from .row_forces import RowForces
            self.row_forces = RowForces(model, device=device)
        elif not self.extended:
            if any(getattr(el.evaluator, "anchor", False) for el in model.contact_elements()):
                raise RvtoolInputError("sums = 'host' (ReferenceModel's step) commits no anchor history; a model "
                                       "with stick--slip anchors steps with sums='device'")
            self.families = copy_families(model, 1, device=device)
            for f in self.families:                          # driven runs: dQ/dv of every family
                if callable(getattr(f.set, "set_velocity_tangent", None)):
                    f.set.set_velocity_tangent(True)
            # one copy: each family's row entries summed into f (n,) and K, C (n, n) by flat indices
            # (np.bincount; the rows' local coordinates of the copy's block scatter, -1: ground)
            self._scatter = []
            for f in self.families:
                loc = np.asarray(f.scatter.local, np.int64)
                vec = loc.reshape(-1)
                pair = (loc[:, :, None] * n + loc[:, None, :]).reshape(-1)
                pair_ok = ((loc[:, :, None] >= 0) & (loc[:, None, :] >= 0)).reshape(-1)
                self._scatter.append((vec >= 0, vec[vec >= 0], pair_ok, pair[pair_ok]))
        free = np.ones(n, bool)
        free[sorted(model.fixed_coordinates())] = False
        self.B, self.n, self.nb = 1, n, nb
        if self.extended:
            # the stations: massless, referenced at their carriers; the modal coordinates: M = I, reference 0
            co = self.row_forces.coords
            self.reference = np.zeros((1, n))
            self.reference[0, :co.n_real] = np.asarray(model.reference, float).reshape(-1)
            self.reference[0, co.station_slice] = co.reference[co.stations]
            self.mass = np.ones((1, n))
            self.mass[0, :co.n_real] = rigid_body_masses(model)
            self.mass[0, co.station_slice] = 0.0
        else:
            self.reference = np.asarray(model.reference, float).reshape(1, n)
            self.mass = rigid_body_masses(model).reshape(1, n)
        self.free = free
        self.input_index, self.output_index = model.input_index, model.output_index
        self.motion = np.asarray(motion, float).reshape(1, N_MOTION)
        self.torque = np.array([float(torque)])
        self.settings = np.asarray(settings_vector, float)
        self.forces_s = self.forces_cpu_s = self.evaluate_cpu_s = self.tangents_cpu_s = 0.0
        self.evaluations = self.tangent_gathers = 0
        # the lean step's constants (device sums): free/fixed index lists, the diagonal mass matrix
        # (contiguous index sets as slices: views instead of fancy-index copies; rv40e's locks and drive
        # are the first body's three coordinates)
        self._fi = _as_slice(np.flatnonzero(free))
        self._xi = _as_slice(np.flatnonzero(~free))
        both_slices = isinstance(self._fi, slice) and isinstance(self._xi, slice)
        self._ff = (self._fi, self._fi) if both_slices else np.ix_(np.flatnonzero(free), np.flatnonzero(free))
        self._xf = (self._xi, self._fi) if both_slices else np.ix_(np.flatnonzero(~free), np.flatnonzero(free))
        self._mass_diag = np.diag(self.mass[0])
        st = self.settings
        self._floats = tuple(float(st[c]) for c in (S_ALPHA_M, S_ALPHA_F, S_BETA, S_GAMMA, S_ABS_TOL, S_REL_TOL)) + (
            int(st[S_MAX_IT]),)
        self._motion = tuple(float(self.motion[0, c]) for c in (M_ANGLE, M_SPEED, M_ACCEL))
        if device_step is None:
            device_step = sums == "device"
        if device_step and sums != "device":
            raise RvtoolInputError("device_step = True needs sums = 'device' (the step reads the device sums)")
        self.device_iteration = DeviceIteration(self) if device_step else None

    def commit_history(self, q, v):
        """Commit the anchored families' contact history at the accepted state (q, v) (Exudyn's
        driver commits every contact element after each accepted step, at its state)."""
        t0, c0 = time.perf_counter(), time.process_time()
        if self.extended:
            self.row_forces.commit(q, v)
        else:
            self.row_forces.commit((self.reference[0] + q).reshape(self.nb, 3), v.reshape(self.nb, 3))
        self.forces_s += time.perf_counter() - t0
        self.forces_cpu_s += time.process_time() - c0

    def initial_accelerations(self, p, q, v):
        """:meth:`ReferenceModel.initial_accelerations` (Exudyn's M a = f on the free coordinates);
        the massless stations of elastic closures take a = 0 (their rows are algebraic:
        :meth:`settle_stations` first)."""
        if not self.extended:
            return super().initial_accelerations(p, q, v)
        f = np.array(self._device_forces(p, q, v))
        M = self.mass[p]
        a = np.where(M > 0.0, f / np.where(M > 0.0, M, 1.0), 0.0)
        (_, _, accel), ii = self._motion, self.input_index
        a[self._xi] = 0.0
        a[ii] = accel
        return a

    def settle_stations(self, q, v, max_iterations=40):
        """The closures' stations of state q (its bodies and modal coordinates held) at their
        equilibrium R_s = 0 with the velocities v (in place; Newton on the station rows to the
        closure's own tolerance: 1e-8 N, or 1e-13 of the largest force where that is larger,
        :data:`rvtool.contact.pin_closure.RELATIVE_TOLERANCE`), or until a step no longer moves the
        stations' absolute coordinates (16 machine epsilons of them: the beam rows are K_b times a
        difference of absolute coordinates, whose round-off floors the residual near 1e-8 N on
        rv80e): the start of a driven run, as Exudyn's condensed closure evaluates it. Returns the
        Newton iterations."""
        from ..contact.pin_closure import RELATIVE_TOLERANCE
        if not self.extended:
            return 0
        sl = self.row_forces.coords.station_slice
        if sl.stop == sl.start:
            return 0
        for it in range(max_iterations + 1):
            f = self._device_forces(0, q, v)
            r = f[sl]
            if np.max(np.abs(r)) <= max(1e-8, RELATIVE_TOLERANCE * np.max(np.abs(f))):
                return it
            K, _ = self._tangents()
            d = np.linalg.solve(K[sl, sl], r)
            q[sl] -= d
            if np.max(np.abs(d)) <= 16 * np.finfo(float).eps * np.max(np.abs(self.reference[0, sl] + q[sl])):
                return it + 1
        raise SolverFailure(f"row stepper: the closures' stations did not settle in {max_iterations} Newton "
                            f"iterations at the start (largest station residual {np.max(np.abs(r)):.3g} N)")

    def forces(self, p, q, v):
        if self.sums == "device":
            f = self._device_forces(p, q, v)
            K, C = self._tangents()
            return f, K, C, (0.0, 0.0, 0.0)
        from .replica import family_rows
        t0, c0 = time.perf_counter(), time.process_time()
        n = self.n
        pose = (self.reference[p] + q).reshape(self.nb, 3)
        vel = v.reshape(self.nb, 3)
        f, K, C = np.zeros(n), np.zeros(n * n), np.zeros(n * n)
        for fam, (vok, vidx, pok, pidx) in zip(self.families, self._scatter):
            Q, dQ, dV = family_rows(fam.set, pose, vel)[:3]
            f += np.bincount(vidx, np.asarray(Q, np.float64).reshape(-1)[vok], minlength=n)
            K += np.bincount(pidx, np.asarray(dQ, np.float64).reshape(-1)[pok], minlength=n * n)
            if dV is not None:
                C += np.bincount(pidx, np.asarray(dV, np.float64).reshape(-1)[pok], minlength=n * n)
        f[self.output_index] += self.torque[p]
        out = f, K.reshape(n, n), C.reshape(n, n), (0.0, 0.0, 0.0)   # peak loads: not recorded here
        self.forces_s += time.perf_counter() - t0
        self.forces_cpu_s += time.process_time() - c0
        self.evaluations += 1
        return out

    def _device_forces(self, p, q, v):
        """f (n,) of copy p at (q, v) from the device sums (its rows kept for :meth:`_tangents`)."""
        t0, c0 = time.perf_counter(), time.process_time()
        if self.extended:
            f = self.row_forces.evaluate(q, v)
        else:
            f = self.row_forces.evaluate((self.reference[p] + q).reshape(self.nb, 3), v.reshape(self.nb, 3))
        f[self.output_index] += self.torque[p]        # f is the device sums' buffer: rewritten by each launch
        dc = time.process_time() - c0
        self.forces_s += time.perf_counter() - t0
        self.forces_cpu_s += dc
        self.evaluate_cpu_s += dc
        self.evaluations += 1
        return f

    def _tangents(self):
        """K, C (n, n) of the last evaluation (the device gather of its rows)."""
        t0, c0 = time.perf_counter(), time.process_time()
        K, C = self.row_forces.tangents()
        dc = time.process_time() - c0
        self.forces_s += time.perf_counter() - t0
        self.forces_cpu_s += dc
        self.tangents_cpu_s += dc
        self.tangent_gathers += 1
        return K, C

    def attempt(self, p, q0, v0, a0, g0, t0, h):
        """:meth:`ReferenceModel.attempt` (the same arithmetic, Exudyn's step) with the dense work on
        the free block only and no per-iteration allocations beyond NumPy's temporaries; the
        reference's ``attempt`` with ``sums="host"``; the Newton iterations on the device with
        ``device_step`` (:class:`DeviceIteration`)."""
        if self.sums != "device":
            return super().attempt(p, q0, v0, a0, g0, t0, h)
        if self.device_iteration is not None:
            return self.device_iteration.attempt(q0, v0, a0, g0, t0, h)
        am, af, beta, gamma, abs_tol, rel_tol, max_it = self._floats
        fi, xi, ff = self._fi, self._xi, self._ff
        M = self.mass[p]
        q = q0 + h * v0 + h * h * (0.5 - beta) * g0
        v = v0 + h * (1.0 - gamma) * g0
        g = (af * a0 - am * g0) / (1.0 - am)
        q = q + h * h * beta * g
        v = v + h * gamma * g
        a = np.zeros_like(q)
        # the fixed coordinates: locks 0, the drive's angle, speed and acceleration at the step end
        (angle, speed, accel), tt, ii = self._motion, t0 + h, self.input_index
        q[xi], v[xi], a[xi] = 0.0, 0.0, 0.0
        q[ii] = angle + speed * tt + 0.5 * accel * tt * tt
        v[ii] = speed + accel * tt
        a[ii] = accel
        sc = beta * h * h
        bp = (1.0 - am) / (h * h * beta * (1.0 - af))
        gp = gamma / (h * beta)
        lam = np.zeros_like(q)
        peaks = (0.0, 0.0, 0.0)                          # peak loads: not recorded here
        f = self._device_forces(p, q, v)
        r = M * a - f
        initial = math.sqrt(float(np.dot(r, r)))
        if not math.isfinite(initial):
            return False, q, v, a, g, 0, 0.0, peaks
        initial = max(initial, 2.0 * abs_tol)
        for it in range(1, max_it + 1):
            K, C = self._tangents()                      # of the last evaluation (a converged one needs none)
            J = sc * (bp * self._mass_diag - K - gp * C)
            try:
                d = np.linalg.solve(J[ff], sc * r[fi])
            except np.linalg.LinAlgError:
                return False, q, v, a, g, it, 0.0, peaks
            # Exudyn's multiplier update on the fixed rows: lam -= (s r_x - J_xf D_f) / s
            lam[xi] -= (sc * r[xi] - J[self._xf] @ d) / sc
            q[fi] -= d
            v[fi] -= gp * d
            a[fi] -= bp * d
            f = self._device_forces(p, q, v)
            r = M * a - f + lam
            res = math.sqrt(float(np.dot(r, r)))
            if not math.isfinite(res):
                return False, q, v, a, g, it, 0.0, peaks
            if it == 1 and res > initial:
                initial = res
            if res / initial <= rel_tol or res <= abs_tol:
                torque = M[ii] * a[ii] - f[ii]
                return True, q, v, a, g + (1.0 - af) / (1.0 - am) * a, it, torque, peaks
        return False, q, v, a, g, max_it, 0.0, peaks

    def advance(self, state, n_steps):
        """:meth:`ReferenceModel.advance` for the one copy (the same step control: Exudyn's adaptive
        halving and recovery, the end test) with its scalars as Python numbers; the reference's
        ``advance`` with ``sums="host"``."""
        if self.sums != "device":
            return super().advance(state, n_steps)
        st = self.settings
        t_end, h_nom, h_min = float(st[S_T_END]), float(st[S_H_NOM]), float(st[S_H_MIN])
        recovery, recovery_its = float(st[S_RECOVERY]), float(st[S_RECOVERY_ITERATIONS])
        hist = np.zeros((1, n_steps, N_HISTORY))
        cnt = state["counters"][0]
        accepted, rejected, newton, run = (int(cnt[c]) for c in (C_ACCEPTED, C_REJECTED, C_NEWTON, C_RUN))
        status, t, h_state = int(state["status"][0]), float(state["t"][0]), float(state["h"][0])
        q, v, a, g = (np.array(state[k][0]) for k in ("q", "v", "a", "abar"))
        ii, oi = self.input_index, self.output_index
        ref_out = float(self.reference[0, oi])
        k = 0
        while status == ACTIVE and k < n_steps:
            h = h_state
            if t + h > t_end:
                h = t_end - t
            ok, q1, v1, a1, g1, its, torque, _ = self.attempt(0, q, v, a, g, t, h)
            newton += its
            if ok:
                t = t + h
                q, v, a, g = q1, v1, a1, g1
                if self.row_forces.history_families:      # stick--slip anchors: Exudyn commits per accepted step
                    self.commit_history(q, v)
                accepted += 1
                run += 1
                hist[0, k, :] = (t, q[ii], ref_out + q[oi], torque, 0.0, 0.0, 0.0, h, its)  # H_* order
                k += 1
                if run >= recovery and its + 1 < recovery_its:
                    h_state = min(h_nom, 2.0 * h_state)
                    run = 0
                if t >= t_end - END_TOLERANCE:
                    status = DONE
            else:
                rejected += 1
                run = 0
                if h_state > h_min:
                    h_state = max(h_min, 0.5 * h_state)
                else:
                    status = FAILED
        state["q"][0], state["v"][0], state["a"][0], state["abar"][0] = q, v, a, g
        state["t"][0], state["h"][0], state["status"][0] = t, h_state, status
        cnt[C_ACCEPTED], cnt[C_REJECTED], cnt[C_NEWTON], cnt[C_RUN], cnt[C_RECORDED] = (accepted, rejected, newton,
                                                                                      run, k)
        return hist


class DeviceIteration:
    """The Newton iterations of :meth:`RowDrivenModel.attempt` on the Warp device
    (``device_step=True``): the predictor on the host, then per iteration one captured graph
    (the tangent gather, :func:`warp_contacts.row_step.kernels`' ``newton_update`` with the dense
    solve, the evaluation from the poses it writes, the ``residual``) and one read of the
    residual norm; the state (q, v, a) comes back once per step. The same formulas as the host
    step (the solve and the norm summed in another order: last bits)."""

    def __init__(self, rm):
        import warp as wp

        from warp_contacts.row_step import kernels
        self.rm = rm
        rf = rm.row_forces
        dev, f64 = rf.device, wp.float64
        n = rm.n
        free = np.flatnonzero(rm.free).astype(np.int32)
        fixed = np.flatnonzero(~rm.free).astype(np.int32)
        nf = len(free)
        arr = lambda x, t=f64: wp.array(np.ascontiguousarray(x), dtype=t, device=dev)
        self.mass, self.free, self.fixed = arr(rm.mass[0]), arr(free, wp.int32), arr(fixed, wp.int32)
        self.reference = arr(rm.reference[0])
        self.torque = arr(np.asarray(rm.torque[:1], float))
        # q, v, a, lambda in one array (one transfer each way); the step constants; [|r|, pivot flag]
        self.state = wp.zeros((4, n), dtype=f64, device=dev)
        self.coef = wp.zeros(3, dtype=f64, device=dev)
        self.status = wp.zeros(2, dtype=f64, device=dev)
        self.r = wp.zeros(n, dtype=f64, device=dev)
        self.J = wp.zeros((1, nf, nf), dtype=f64, device=dev)
        self.rhs = wp.zeros((1, nf), dtype=f64, device=dev)
        self.d = wp.zeros((1, nf), dtype=f64, device=dev)
        q, v, a, lam = (self.state[i] for i in range(4))
        update, residual = kernels()
        on_cpu = rf.on_cpu
        self._host = {k: (getattr(self, k).numpy() if on_cpu else np.zeros(getattr(self, k).shape))
                      for k in ("state", "coef", "status")}

        def residual_launch():
            wp.launch(residual, dim=1, device=dev, inputs=[self.mass, int(rm.output_index), self.torque,
                                                           rf.gather.out, a, lam], outputs=[self.r, self.status])

        def iteration():
            rf.gather.launch_tangents()
            wp.launch(update, dim=1, device=dev,
                      inputs=[self.mass, self.free, self.fixed, self.reference, self.coef, rf.gather.out, self.r,
                              self.J, self.rhs, self.d, q, v, a, lam],
                      outputs=[rf.pose_stage, rf.vel_stage, self.status])
            rf.launch_evaluation()
            residual_launch()

        def first():
            rf.launch_evaluation()
            residual_launch()

        first()                       # loads the modules before the captures
        iteration()
        self.graphs = []
        for body in (first, iteration):
            with wp.ScopedCapture(device=dev) as cap:
                body()
            self.graphs.append(cap.graph)
        self.on_cpu = on_cpu

    def _put(self, name):
        if not self.on_cpu:
            getattr(self, name).assign(self._host[name])

    def _get(self, name):
        if not self.on_cpu:
            self._host[name][...] = getattr(self, name).numpy()
        return self._host[name]

    def _count(self, t0, c0):
        """Book the device work since (wall t0, CPU c0) as evaluation time of the row model."""
        rm, dc = self.rm, time.process_time() - c0
        rm.forces_s += time.perf_counter() - t0
        rm.forces_cpu_s += dc
        rm.evaluate_cpu_s += dc

    def attempt(self, q0, v0, a0, g0, t0, h):
        """:meth:`RowDrivenModel.attempt` with the iterations on the device (class docstring)."""
        import warp as wp
        rm = self.rm
        am, af, beta, gamma, abs_tol, rel_tol, max_it = rm._floats
        xi, ii = rm._xi, rm.input_index
        M = rm.mass[0]
        q = q0 + h * v0 + h * h * (0.5 - beta) * g0
        v = v0 + h * (1.0 - gamma) * g0
        g = (af * a0 - am * g0) / (1.0 - am)
        q = q + h * h * beta * g
        v = v + h * gamma * g
        a = np.zeros_like(q)
        (angle, speed, accel), tt = rm._motion, t0 + h
        q[xi], v[xi], a[xi] = 0.0, 0.0, 0.0
        q[ii] = angle + speed * tt + 0.5 * accel * tt * tt
        v[ii] = speed + accel * tt
        a[ii] = accel
        sc = beta * h * h
        st, co, ss = self._host["state"], self._host["coef"], self._host["status"]
        st[0], st[1], st[2], st[3] = q, v, a, 0.0
        co[0], co[1], co[2] = sc, (1.0 - am) / (h * h * beta * (1.0 - af)), gamma / (h * beta)
        ss[...] = 0.0
        for nm in ("state", "coef", "status"):
            self._put(nm)
        peaks = (0.0, 0.0, 0.0)
        t0, c0 = time.perf_counter(), time.process_time()
        rm.row_forces.stage((rm.reference[0] + q).reshape(rm.nb, 3), v.reshape(rm.nb, 3))
        wp.capture_launch(self.graphs[0])
        initial = float(self._get("status")[0])
        rm.evaluations += 1
        self._count(t0, c0)
        if not math.isfinite(initial):
            return False, q, v, a, g, 0, 0.0, peaks
        initial = max(initial, 2.0 * abs_tol)
        for it in range(1, max_it + 1):
            t0, c0 = time.perf_counter(), time.process_time()
            wp.capture_launch(self.graphs[1])
            stat = self._get("status")
            res, singular = float(stat[0]), stat[1] != 0.0
            rm.evaluations += 1
            rm.tangent_gathers += 1
            self._count(t0, c0)
            if singular or not math.isfinite(res):
                return False, q, v, a, g, it, 0.0, peaks
            if it == 1 and res > initial:
                initial = res
            if res / initial <= rel_tol or res <= abs_tol:
                s = self._get("state")
                q, v, a = np.array(s[0]), np.array(s[1]), np.array(s[2])
                f_in = float(rm.row_forces.forces_view()[ii])
                if ii == rm.output_index:
                    f_in += float(rm.torque[0])
                torque = M[ii] * a[ii] - f_in
                return True, q, v, a, g + (1.0 - af) / (1.0 - am) * a, it, torque, peaks
        return False, q, v, a, g, max_it, 0.0, peaks


SUMS = ("device", "host")
"""Where the row stepper sums its families' rows: on the Warp device in one gather launch
(:class:`rvtool.solver.row_forces.RowForces`, with the lean step) or on the host (the rows
brought back, ``np.bincount``; the reference, with :class:`ReferenceModel`'s step)."""


RUN_SPEC_REQUIRED = (("newton_mode", "'full'"), ("strict_abs_tol", "None"), ("reference_length", "None"),
                     ("adaptive", "True"), ("precision", "'float64'"))
"""RunSpec fields the row stepper runs with one value each (its step is Exudyn's with these)."""


def row_stepper_reasons(model, run_spec=None):
    """Every named reason why :func:`row_driven_run` cannot run ``model`` (and ``run_spec``, a
    :class:`~rvtool.solver.run_spec.RunSpec`, when given) as Exudyn's driven run would (empty: it
    can; checked on the built model, nothing copied): the device row Newton's families
    (:func:`rvtool.solver.device_rows.row_reasons`) on planar rigid bodies, summed on the device
    (:func:`rvtool.solver.row_forces.device_row_reasons`), and not

    * retained out-of-plane coordinates or floating flexible bodies (planar rigid copies only);
    * elastic closures or reduced structures on port bodies (the row Newton's extra unknowns,
      :mod:`rvtool.solver.row_extension`, are not in the stepper's coordinates);
    * stick--slip anchors where the device row Newton names them (inside closures, on families whose
      kernels do not stage the history); the others are committed per accepted step;
    * journal locks (``rigid_supports=True``: the stepper holds the drive and the coordinate locks);
    * contact sets in another precision than float64 (the copies are float64);
    * run settings other than :data:`RUN_SPEC_REQUIRED`."""
    from .backends.base import flexible_body_reasons, spatial_body_reasons
    from .device_rows import needs_extension, row_reasons
    from .row_forces import device_row_reasons
    reasons = spatial_body_reasons(model) + flexible_body_reasons(model)
    if run_spec is not None:
        reasons += [f"run_spec.{k} = {getattr(run_spec, k)!r} (the row stepper runs {ok})"
                    for k, ok in RUN_SPEC_REQUIRED if repr(getattr(run_spec, k)) != ok]
    if reasons:
        return reasons
    reasons = list(row_reasons(model))
    if needs_extension(model):
        # elastic closures and ported structures: the row extension's unknowns in the step
        # (rvtool.solver.row_closures); their contact sets need device rows
        from .row_closures import extended_row_reasons
        reasons += extended_row_reasons(model)
    for el in model.contact_elements():
        s = el.evaluator
        precision = getattr(s, "precision", "float64")
        if precision != "float64":
            reasons.append(f"contact element {s.name!r} has precision = {precision!r}: the row stepper's copies "
                           "are 'float64'")
    if getattr(model, "journal_locks", None):
        reasons.append("rigid_supports=True (journal locks): the row stepper holds the drive and the coordinate "
                       "locks only (valid: rigid_supports=False)")
    # an element the row Newton already names (no copier) is not named again for its rows; an extended
    # model's sets are checked leaf by leaf above (its closure elements have no rows of their own)
    if not needs_extension(model):
        reasons += [r for r in device_row_reasons(model) if not any(r.split(" (")[0] in k for k in reasons)]
    return [r for i, r in enumerate(reasons) if r not in reasons[:i]]


def row_driven_run(model, *, torque, speed_rpm, duration, settings, device="cpu", q0=None, sums="device",
                   device_step=None):
    """The dynamic TE protocol's driven run of ``model`` on the row stepper: from the loaded
    quasi-static state at input angle 0 (``q0``; None: Exudyn's StaticSolver, as the Exudyn path),
    kinematic velocities, constant input speed [rpm] and output torque [N m] (resisting the
    nominal rotation), for ``duration`` [s] with ``settings``
    (:class:`~rvtool.solver.device_dynamics.DeviceDynamicsSettings`). Returns a dict: t, theta_in,
    theta_out (accepted steps, t = 0 first), omega_in, accepted, rejected, newton, and the split:
    wall (``forces_s``, ``step_s``) and CPU seconds (``evaluate_cpu_s``: evaluations, with
    ``device_step`` whole Newton iterations on the device; ``tangents_cpu_s``: host-step tangent
    gathers; ``step_cpu_s``: the rest), ``evaluations``, ``tangent_gathers``. sums, device_step:
    :data:`SUMS` and :class:`DeviceIteration` (None: on with the device sums). A step that fails
    at the minimum step raises :class:`SolverFailure`."""
    import dataclasses

    from .static import StaticSolver
    # Exudyn's nominal step: the run divided into ceil(duration / step) equal steps (rvtool.solver.driver),
    # not steps of ``step`` with a short last one (a duration that is no multiple of the step, e.g. the
    # vibration protocol's quarter input revolution, would otherwise take other steps than Exudyn's)
    n_nominal = int(np.ceil(duration / settings.step - 1e-9))
    settings = dataclasses.replace(settings, step=duration / n_nominal, min_step=settings.minimum_step)
    omega = speed_rpm * 2 * np.pi / 60.0
    tq = -np.sign(model.ratio) * float(torque)
    model.set_output_torque(tq)
    if q0 is None:
        q0 = StaticSolver(model).solve(0.0)
    v0 = model.body_vector(model.kinematic_state(0.0, omega).velocities)
    motion = np.zeros(N_MOTION)
    motion[M_SPEED] = omega
    rm = RowDrivenModel(model, torque=tq, motion=motion, settings_vector=settings.vector(duration), device=device,
                        sums=sums, device_step=device_step)
    fixed = ~rm.free
    if rm.extended:                  # the step's unknowns (rvtool.solver.row_closures): stations settled below
        co = rm.row_forces.coords
        q, v = co.from_model(q0), co.from_model(v0)
    else:
        q = np.array(q0, float)
        v = np.array(v0, float)
    q[fixed], v[fixed] = 0.0, 0.0
    q[rm.input_index], v[rm.input_index] = 0.0, omega
    rm.settle_stations(q, v)
    a = rm.initial_accelerations(0, q, v)
    state = {"q": q[None].copy(), "v": v[None].copy(), "a": a[None].copy(), "abar": a[None].copy() * 0.0,
             "t": np.zeros(1), "h": np.full(1, settings.step), "status": np.full(1, ACTIVE),
             "counters": np.zeros((1, N_COUNT), np.int64)}
    # Exudyn's initial algorithmic acceleration is the initial acceleration
    state["abar"][0] = a
    ref_out = rm.reference[0, rm.output_index]
    t_h, th_in, th_out, tq_in, steps, newton = [0.0], [q[rm.input_index]], [ref_out + q[rm.output_index]], [np.nan], \
        [0.0], [0]
    t0, c0 = time.perf_counter(), time.process_time()
    while state["status"][0] == ACTIVE:
        hist = rm.advance(state, settings.steps_per_launch)
        k = int(state["counters"][0, 4])
        t_h.extend(hist[0, :k, H_TIME])
        th_in.extend(hist[0, :k, H_INPUT])
        th_out.extend(hist[0, :k, H_OUTPUT])
        tq_in.extend(hist[0, :k, H_TORQUE])
        steps.extend(hist[0, :k, H_STEP])
        newton.extend(hist[0, :k, H_NEWTON])
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if state["status"][0] != DONE:
        raise SolverFailure(f"row stepper: step below the minimum step {settings.minimum_step:.3g} s at "
                            f"t = {state['t'][0]:.9g} s")
    c = state["counters"][0]
    return {"t": np.array(t_h), "theta_in": np.array(th_in), "theta_out": np.array(th_out),
            "torque_in": np.array(tq_in), "step": np.array(steps), "omega_in": omega,
            "accepted": int(c[C_ACCEPTED]), "rejected": int(c[C_REJECTED]), "newton": int(c[C_NEWTON]),
            "wall_s": wall, "forces_s": rm.forces_s, "step_s": wall - rm.forces_s, "evaluations": rm.evaluations,
            "cpu_s": cpu, "forces_cpu_s": rm.forces_cpu_s, "step_cpu_s": cpu - rm.forces_cpu_s,
            "evaluate_cpu_s": rm.evaluate_cpu_s, "tangents_cpu_s": rm.tangents_cpu_s,
            "tangent_gathers": rm.tangent_gathers, "device_step": rm.device_iteration is not None}


__all__ = ["RUN_SPEC_REQUIRED", "RowDrivenModel", "rigid_body_masses", "row_driven_run", "row_stepper_reasons"]
