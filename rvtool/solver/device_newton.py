"""Device-resident batched static Newton: B independent equilibria of one topology on cpu or cuda.

Each copy p is one variant of a design (:class:`rvtool.solver.device_copies.CopyParameters`)
at its own input angle and output torque. One iteration, for all copies at once and without
leaving the device:

1. ``scatter_poses``: absolute poses reference + q of every copy into the contact kernels'
   pose arrays;
2. the existing contact kernels in static mode (cycloid pins without the velocity tangent,
   plain output pins, lumped bearings as circle pairs), each one launch over the rows of all
   copies, results left on the device (``launch_recorded``);
3. ``newton_step`` (:mod:`warp_contacts.batched_newton`): per copy, the residual and dense
   tangent block by a deterministic sum over its own rows, regularization springs (times the
   copy's homotopy factor), the output torque and the fixed coordinates (drive, locks), a
   dense solve with partial pivoting, step limiting, plausibility bounds and the per-copy
   stage/status bookkeeping (warm start -> regularization homotopy -> failed).

The loop runs until no copy is active: on a CUDA device as one CUDA graph with
``wp.capture_while`` on the active-copy counter (no host round trip per iteration); on the
CPU (or where conditional graphs are not available) as a host loop reading the counter.
Every copy's iteration count is bounded (``max_iterations`` per stage), so the loop ends.

Exudyn's :class:`rvtool.solver.static.StaticSolver` solves the same residual (contact
forces + springs + torque over the free coordinates, Eq. (contact_mapping)) and is the
oracle of the tests; copies that fail here are handed to it by the protocol
(:mod:`rvtool.batched.device_te`).
"""
import time
from dataclasses import dataclass

import numpy as np
import warp as wp

from warp_contacts.batched_newton import kernels
from warp_contacts.batched_newton_ref import ACTIVE, CONVERGED, FAILED
from warp_contacts.precision import resolve_device

from ..errors import RvtoolInputError
from ..validation import check_integer
from .static import StaticSolver


@dataclass(frozen=True, kw_only=True)
class DeviceNewtonSettings:
    """Tolerances and bounds of the device Newton (SI units).

    abs_tol [N, N m]: residual norm over the free coordinates (StaticSolver's default).
    max_iterations: Newton iterations per stage (warm start, each homotopy stage).
    max_translation [m], max_rotation [rad]: plausibility bounds of every coordinate from its
    kinematic value (StaticSolver's).
    max_step_translation [m], max_step_rotation [rad]: step limits (1/5 of the bounds: a
    converging Newton on micrometre contact deformations takes far smaller steps).
    homotopy: on a failed warm start, run the regularization-stiffness homotopy
    (``stiffening`` factors, StaticSolver.STIFFENING) from the kinematic state.
    graph: on CUDA, run the loop as a conditional CUDA graph (False: host loop).
    compact_after: sweeps after which the copies still active continue in a smaller launch
    (0: never; see :meth:`DeviceNewton.solve`). RD-40 from nominal warm starts (32 variants x
    53 angles, 14,935 copy iterations): the contact kernels evaluated 31,005 copies without
    compaction, 20,769 with 6, 20,429 with 10 (the slowest copies take 17 iterations).
    """
    abs_tol: float = 1e-6
    max_iterations: int = 30
    max_translation: float = 5e-4
    max_rotation: float = 2e-2
    max_step_translation: float = 1e-4
    max_step_rotation: float = 4e-3
    homotopy: bool = True
    stiffening: tuple = StaticSolver.STIFFENING
    graph: bool = True
    compact_after: int = 6

    def __post_init__(self):
        for nm in ("abs_tol", "max_translation", "max_rotation", "max_step_translation", "max_step_rotation"):
            v = getattr(self, nm)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise RvtoolInputError(f"device_newton.{nm} = {v!r} is outside the valid range (0, inf)")
        check_integer("device_newton.compact_after", self.compact_after, 0)
        check_integer("device_newton.max_iterations", self.max_iterations, 1)
        if len(self.stiffening) < 1 or self.stiffening[-1] != 1.0:
            raise RvtoolInputError(f"device_newton.stiffening = {self.stiffening!r}; the last factor must be 1.0 "
                                   f"(the unmodified problem)")


@dataclass
class DeviceSolve:
    """Result of :meth:`DeviceNewton.solve` for P copies: states q (P, 3 nb) [m, rad]
    (displacements from each copy's reference), status (P,) (CONVERGED / FAILED), the
    stage that converged (-1: warm start, s: homotopy stage), Newton iterations per copy,
    residual norms [N], loop iterations (device sweeps, and the sum over launches of copies x
    sweeps: the work the contact kernels did), the wall times [s] of the loop and of
    the set-up (rows, kernels, uploads), and optionally the pin slice forces (P, R_p) [N]."""
    q: np.ndarray
    status: np.ndarray
    stage: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    sweeps: int
    copy_sweeps: int
    loop_s: float
    setup_s: float
    pin_forces: np.ndarray = None

    @property
    def converged(self):
        return self.status == CONVERGED


class DeviceNewton:
    """Batched static Newton of the copies of one :class:`CopyParameters` on one Warp device.

    device: "cpu", "cuda" or "cuda:N". The variants' rows go to the device once; the contact
    kernel objects are built once per capacity (the chunk size) and their rows refilled on the
    device for every launch, compacted launches included.
    """

    def __init__(self, params, *, device="cpu", settings: DeviceNewtonSettings = DeviceNewtonSettings()):
        from warp_contacts.batched_newton_ref import ROW_ENTRIES
        for nm in ("loc_pin", "loc_op", "loc_brg"):
            if getattr(params, nm).shape[1] != ROW_ENTRIES:
                raise RvtoolInputError(f"params.{nm} has {getattr(params, nm).shape[1]} entries per row; the Newton "
                                       f"step sums rows of two planar bodies ({ROW_ENTRIES} entries)")
        self.params = params
        self.settings = settings
        self.device = resolve_device(device)
        self._scatter, self._step, self._gate, self._gather_rows, self._gather_bodies = kernels(wp.float64)
        self._var = None
        self._kernel_cache = {}
        self.last_path = None

    # -- per-copy rows -------------------------------------------------------------------
    def _variant_arrays(self):
        """The variants' rows on the device, uploaded once: (rows (V or 1, R, C), body columns or
        None for float rows) per parameter array, in the order pins f/i, output pins f/i,
        bearings f/i."""
        if self._var is None:
            from warp_contacts import circle_pairs_ref as cref
            from warp_contacts import cycloid_pins_ref as pref
            from warp_contacts import output_pins_ref as oref
            pr, d = self.params, self.device
            f = lambda x: wp.array(np.ascontiguousarray(x, np.float64), dtype=wp.float64, device=d)
            i = lambda x: wp.array(np.ascontiguousarray(x, np.int32), dtype=wp.int32, device=d)
            cols = lambda c: i(np.array(c, np.int32))
            self._var = [(f(pr.pin_f), None), (i(pr.pin_i), cols([pref.J_BODY_A, pref.J_BODY_B])),
                         (f(pr.op_f[None]), None), (i(pr.op_i[None]), cols([oref.J_FLANGE, oref.J_WHEEL])),
                         (f(pr.brg_f), None), (i(pr.brg_i[None]), cols([cref.I_BODY_A, cref.I_BODY_B]))]
        return self._var

    def _contact_kernels(self, vi):
        """The contact kernels for P = len(vi) copies: kernel objects of some capacity >= P (built
        once per capacity: the chunk size; a compacted or last, smaller batch reuses them and
        evaluates only its first P copies' rows, ``launch_recorded(n_rows)``), their parameter
        rows of copies 0..P-1 filled on the device from the variants' rows (``gather_rows`` /
        ``gather_bodies``; reference :func:`warp_contacts.batched_newton_ref.gather_rows`).
        Returns (pins, output pins, bearings, capacity)."""
        from warp_contacts.circle_pairs import CirclePairKernel
        from warp_contacts.cycloid_pins import CycloidPinKernel
        from warp_contacts.output_pins import OutputPinKernel
        from ..output_pins.spec import PinMode
        pr, d = self.params, self.device
        P = len(vi)
        fits = [c for c in self._kernel_cache if c >= P]
        if fits:
            cap = min(fits)
        else:
            cap = P
            if len(self._kernel_cache) >= 2:              # bound the device memory held
                self._kernel_cache.pop(min(self._kernel_cache))
            nt = cap * pr.nb
            z = lambda a, dt=np.float64: np.zeros((cap * a.shape[-2], a.shape[-1]), dt)
            pin_i0 = np.tile(pr.pin_i[0], (cap, 1))      # valid table indices until the refill
            pins = CycloidPinKernel(z(pr.pin_f), pin_i0, pr.tables, pr.window, nt, "float64", d,
                                    analytic=pr.analytic)
            pins.set_velocity_tangent(False)          # static residual: no velocity seeds
            op = OutputPinKernel(z(pr.op_f), z(pr.op_i, np.int32), pr.stations, nt + 1, PinMode.PLAIN.value,
                                 "float64", d)
            brg = CirclePairKernel(z(pr.brg_f), z(pr.brg_i, np.int32), nt, "float64", d)
            self._kernel_cache[cap] = (pins, op, brg)
        pins, op, brg = self._kernel_cache[cap]
        v = wp.array(np.asarray(vi, np.int32), dtype=wp.int32, device=d)
        v0 = wp.zeros(P, dtype=wp.int32, device=d)     # the output-pin rows and bearing bodies: one set for all
        targets = [(pins, "fparams", v), (pins, "iparams", v), (op, "fparams", v0), (op, "iparams", v0),
                   (brg, "fparams", v), (brg, "iparams", v0)]
        ground = cap * pr.nb                            # the pose arrays' last row: never written
        for (rows, cols), (kern, name, var) in zip(self._variant_arrays(), targets):
            out = kern.device_array(name)
            if cols is None:
                wp.launch(self._gather_rows, dim=(P, rows.shape[1]), inputs=[rows, var], outputs=[out], device=d)
            else:
                wp.launch(self._gather_bodies, dim=(P, rows.shape[1]), inputs=[rows, cols, pr.nb, ground, var],
                          outputs=[out], device=d)
        return pins, op, brg, cap

    # -- solve -----------------------------------------------------------------------------
    def solve(self, variant_index, angles, torques, q_start, *, pin_forces=False):
        """Equilibria of P copies: variant indices (P,), input angles (P,) [rad], output
        torques (P,) [N m] (on the flange rotation), starting states (P, 3 nb) (a warm start;
        fixed coordinates are set from the angle). pin_forces: also return the cycloid-pin
        slice normal forces (P, R_p) [N] at the final states (one more pin launch). Returns a
        :class:`DeviceSolve`.

        Compaction: the contact kernels evaluate every copy of a launch, converged or not, and
        a batch iterates until its slowest copy is done (RD-40 variants from the nominal warm
        start: median 8, up to 17 iterations). After ``settings.compact_after`` sweeps the
        copies still active continue in a new, smaller launch from their state (stage and
        iteration counts carried over), so the tail costs only its own copies. A copy's
        arithmetic does not depend on the others, so the results are the same bit for bit."""
        t0 = time.perf_counter()
        pr = self.params
        vi = np.asarray(variant_index, np.int64)
        a = np.asarray(angles, float)
        P = len(vi)
        if a.shape != (P,) or np.shape(torques) != (P,) or np.shape(q_start) != (P, pr.n):
            raise RvtoolInputError(f"device Newton inputs: variant_index (P,), angles (P,), torques (P,), q_start "
                                   f"(P, {pr.n}) with P = {P}; got {a.shape}, {np.shape(torques)}, {np.shape(q_start)}")
        if np.any((vi < 0) | (vi >= len(pr.variants))):
            raise RvtoolInputError(f"variant_index must lie in [0, {len(pr.variants) - 1}]")
        kin = pr.kinematic(vi, a)
        q0 = np.array(q_start, float)
        fixed = ~pr.free
        q0[:, fixed] = kin[:, fixed]
        if not np.all(np.isfinite(q0)):
            raise RvtoolInputError("q_start must be finite (valid: a finite warm start per copy)")
        state = {"q": q0, "status": np.zeros(P, np.int32), "stage": np.full(P, -1, np.int32),
                 "iters": np.zeros(P, np.int32), "total": np.zeros(P, np.int32), "residual": np.zeros(P)}
        forces = np.zeros((P, pr.pin_f.shape[1])) if pin_forces else None
        todo = np.arange(P)
        sweeps = copy_sweeps = 0
        loop_s = 0.0
        setup_s = time.perf_counter() - t0
        while len(todo):
            out, n_sweeps, t_loop, t_setup, f = self._launch(vi[todo], a[todo], np.asarray(torques, float)[todo],
                                                             kin[todo], {k: v[todo] for k, v in state.items()},
                                                             pin_forces)
            for k, v in out.items():
                state[k][todo] = v
            if pin_forces:
                forces[todo] = f
            sweeps += n_sweeps
            copy_sweeps += n_sweeps * len(todo)
            loop_s += t_loop
            setup_s += t_setup
            todo = todo[out["status"] == ACTIVE]
        return DeviceSolve(q=state["q"], status=state["status"], stage=state["stage"], iterations=state["total"],
                           residual=state["residual"], sweeps=sweeps, copy_sweeps=copy_sweeps, loop_s=loop_s,
                           setup_s=setup_s, pin_forces=forces)

    def _launch(self, vi, a, torques, kin, state, pin_forces):
        """One device loop over the copies ``vi`` from ``state`` for at most
        ``settings.compact_after`` sweeps (0: until all are done). Returns (state, sweeps, loop
        wall [s], set-up wall [s], pin forces or None)."""
        t0 = time.perf_counter()
        pr, st = self.params, self.settings
        P, n, d = len(vi), pr.n, self.device
        pins, op, brg, _ = self._contact_kernels(vi)
        n_pin, n_op, n_brg = (P * pr.pin_f.shape[1], P * pr.op_f.shape[0], P * pr.brg_f.shape[1])
        arr = lambda x, dt=wp.float64: wp.array(np.ascontiguousarray(x), dtype=dt, device=d)
        ref = arr(pr.reference[vi].reshape(P, n))
        q = arr(state["q"])
        model = [arr(pr.loc_pin, wp.int32), arr(pr.loc_op, wp.int32), arr(pr.loc_brg, wp.int32), arr(kin),
                 arr(np.broadcast_to(pr.spring_k, (P, n))), arr(pr.free.astype(np.int32), wp.int32),
                 arr(torques), int(pr.output_index), arr(np.asarray(st.stiffening, float)),
                 float(st.abs_tol), int(st.max_iterations), float(st.max_step_translation),
                 float(st.max_step_rotation), float(st.max_translation), float(st.max_rotation), int(st.homotopy)]
        rows_in = [pins.device_array("q"), pins.device_array("dqdq"), op.device_array("q"), op.device_array("dqdq"),
                   brg.device_array("q"), brg.device_array("dqdq")]
        status, stage = arr(state["status"], wp.int32), arr(state["stage"], wp.int32)
        iters, total = arr(state["iters"], wp.int32), arr(state["total"], wp.int32)
        resid = arr(state["residual"])
        scratch = [wp.zeros((P, n), dtype=wp.float64, device=d), wp.zeros((P, n, n), dtype=wp.float64, device=d),
                   wp.zeros((P, n), dtype=wp.float64, device=d)]
        active = arr(np.array([P], np.int32), wp.int32)
        counter = wp.zeros(1, dtype=wp.int32, device=d)
        cap = int(st.compact_after) if st.compact_after > 0 else 2 ** 30
        poses = [pins.device_array("pose"), op.device_array("pose"), brg.device_array("pose")]
        outputs = [q, status, stage, iters, total, resid] + scratch + [active]

        def body():
            active.zero_()
            wp.launch(self._scatter, dim=(P, n), inputs=[ref, q], outputs=poses, device=d)
            pins.launch_recorded(n_pin)
            op.launch_recorded(n_op)
            brg.launch_recorded(n_brg)
            wp.launch(self._step, dim=P, inputs=model + rows_in, outputs=outputs, device=d)
            wp.launch(self._gate, dim=1, inputs=[cap], outputs=[counter, active], device=d)

        graph = None
        if not wp.get_device(d).is_cpu and st.graph:
            try:
                with wp.ScopedCapture(device=d) as capture:
                    wp.capture_while(active, body)
                graph = capture.graph
            except Exception:          # conditional graph nodes need CUDA >= 12.4 drivers: host loop then
                graph = None
        wp.synchronize_device(d)
        t1 = time.perf_counter()
        if graph is not None:
            wp.capture_launch(graph)
            wp.synchronize_device(d)
            self.last_path = "cuda_graph"
        else:
            self.last_path = "host_loop"
            while True:
                body()
                if int(active.numpy()[0]) == 0:
                    break
        t2 = time.perf_counter()
        forces = None
        if pin_forces:
            from warp_contacts.circle_pairs_ref import O_FN
            wp.launch(self._scatter, dim=(P, n), inputs=[ref, q], outputs=poses, device=d)
            pins.launch_recorded(n_pin)
            forces = pins.device_array("obs").numpy()[:n_pin, O_FN].reshape(P, -1)
        out = {"q": q.numpy(), "status": status.numpy(), "stage": stage.numpy(), "iters": iters.numpy(),
               "total": total.numpy(), "residual": resid.numpy()}
        return out, int(counter.numpy()[0]), t2 - t1, t1 - t0, forces


__all__ = ["DeviceNewton", "DeviceNewtonSettings", "DeviceSolve", "ACTIVE", "CONVERGED", "FAILED"]
