"""The row stepper's coordinates for models with elastic closures and ported structures (issue 31,
Deliver 1: elastic pin and crank closures and the ported housing's modal coordinates in driven
runs off Exudyn).

The device row Newton (:mod:`rvtool.solver.row_extension`) takes these members as extra unknowns
with constant stiffness blocks: the *row coordinates* x (n) are the bodies' 3 nb coordinates, the
closures' station coordinates and the structures' port displacements w, and every contact set's
body poses are selections of x. A driven run integrates what Exudyn's model integrates:

* **closures** (:class:`rvtool.contact.pin_closure.ElasticPinClosure`: elastic ring or output pins,
  the RV crank's bending beam and its torsion): Exudyn condenses the stations statically in every
  evaluation (massless stations, the deflection rate not in the contact velocities: a station
  moves with its carrier's velocity). Here the stations are unknowns of the step with **zero
  mass**: their rows are algebraic (R_s = Q_s(q, s, v) - K_b (s - c) = 0, the closure's equation),
  solved in the same Newton iterations as the bodies; the station *velocity* handed to the contact
  kernels is the carrier's (the source of the station coordinate, followed through nested closures),
  so dQ/dv of a station column is the carrier's. At a converged step the body forces are the
  condensed forces of Exudyn's closure, to the Newton tolerance.
* **reduced structures on port bodies** (the ported housing,
  :class:`exudyn_user_elements.reduced_structure.ReducedStructure`): Exudyn integrates the modal
  coordinates eta with M = I, K = diag(omega^2) and the projected damping D, the port poses P eta
  and velocities P eta_dot. Here eta are unknowns of the step (mass 1) and the port displacements
  are x_w = P_w eta (P_w the nonzero rows of the element's port map; the row Newton's static block
  C^-1 over w is NOT used: it is the statics of these coordinates).

So the step's unknowns are y = [q (3 nb); stations; eta], x = x_ref + T y and the velocities of
the contact sets' bodies v_x = T_v v_y (T, T_v constant). The families are the row Newton's copies
(:func:`rvtool.solver.row_extension.copy_rows`, one copy: the same kernels and rows), their poses
gathered on the device from x (:func:`warp_contacts.block_newton.gather_pose_kernel`), the
closures' constant beam blocks one linear family (:class:`rvtool.solver.row_extension.StructureRows`,
:mod:`warp_contacts.linear_rows`), f_x, K_x, C_x summed on the device
(:class:`warp_contacts.row_gather.RowGather`), and

    f_y = T^T f_x - [0; 0; omega^2 eta + D eta_dot],  K_y = T^T K_x T - diag(0, 0, omega^2),
    C_y = T^T C_x T_v - diag(0, 0, D)

on the host (dense; rv80e: x 119, y 131).
"""
from dataclasses import dataclass
import time

import numpy as np

from ..errors import RvtoolInputError


@dataclass(frozen=True)
class StepCoordinates:
    """The row stepper's unknowns y of a model with extra row coordinates (module docstring).
    ``n_real`` body coordinates, then ``stations`` (the station extras' row coordinates, in y at
    n_real ..), then the structures' eta (``modal``: (name, y slice, omega2, damping D, ODE2
    indices of eta in the model)); ``T``, ``T_v`` (n_x, n) the pose and velocity maps
    (``velocity_source`` (n_x,): the row coordinate whose velocity each one takes, -1: zero),
    ``reference`` (n_x,) the row coordinates' reference. The diagonal mass of y (bodies [kg, kg
    m^2], stations 0, eta 1) is :class:`rvtool.solver.row_dynamics.RowDrivenModel`'s ``mass``."""
    n_real: int
    n: int
    n_x: int
    stations: np.ndarray
    modal: tuple
    T: np.ndarray
    T_v: np.ndarray
    velocity_source: np.ndarray
    reference: np.ndarray
    station_slice: slice

    def from_model(self, q):
        """y (n,) of a model state q (ODE2 vector: body coordinates first, then each structure's eta
        at its indices), every station at its carrier's displacement (no deflection)."""
        q = np.asarray(q, float)
        y = np.zeros(self.n)
        y[:self.n_real] = q[:self.n_real]
        for _, sl, _, _, idx in self.modal:
            y[sl] = q[idx]
        y[self.station_slice] = (self.T_v @ y)[self.stations]
        return y

    def to_model(self, y, size):
        """The model's ODE2 vector (``size``) of y (the stations have no model coordinates: Exudyn
        condenses them)."""
        q = np.zeros(size)
        q[:self.n_real] = y[:self.n_real]
        for _, sl, _, _, idx in self.modal:
            q[idx] = y[sl]
        return q


def _port_maps(model, ext):
    """{row coordinate of a port unknown: its row of the element's port map P (n_eta,)} from every
    leaf on port bodies (the contact element's ``ports.P``, the rows the extension selected)."""
    nb = len(model.body_names)
    elements = {el.evaluator.name: el for el in model.contact_elements()}
    port_coords = {int(c) for p in ext.ports for c in p.coords}
    rows = {}
    for lf in ext.leaves:
        ports = getattr(elements.get(lf.element), "ports", None)
        if ports is None:
            continue
        P = np.asarray(ports.P, float)
        for b in range(nb, min(len(lf.body_map), nb + P.shape[0] // 3)):
            for k in range(3):
                c = int(lf.body_map[b, k])
                if c in port_coords:
                    row = P[3 * (b - nb) + k]
                    if c in rows and not np.array_equal(rows[c], row):
                        raise RvtoolInputError(f"port coordinate {c} of element {lf.element!r} maps two different "
                                               "rows of its structure's port map")
                    rows[c] = row
    missing = port_coords - set(rows)
    if missing:
        raise RvtoolInputError(f"port coordinates {sorted(missing)} have no row of a port map in the model's contact "
                               "elements")
    return rows


def step_coordinates(model, ext):
    """The :class:`StepCoordinates` of a built ``model`` with its row extension ``ext``
    (:func:`rvtool.solver.row_extension.row_extension`)."""
    nr, nx = ext.n_real, ext.n
    port_of = {}
    for p in ext.ports:
        for c in p.coords:
            port_of[int(c)] = p.name
    stations = np.array([c for c in range(nr, nx) if c not in port_of], int)
    pw = _port_maps(model, ext) if ext.ports else {}
    modal, col = [], nr + len(stations)
    eta_at = {}
    for p in ext.ports:
        red = p.structure.reduced
        n_eta = int(red.n_coordinates)
        omega2 = np.asarray(red.omega2, float)
        D = np.asarray(red.damping, float)
        if D.shape != (n_eta, n_eta):
            raise RvtoolInputError(f"structure {p.name!r}: damping {D.shape} is not ({n_eta}, {n_eta})")
        sl = slice(col, col + n_eta)
        modal.append((p.name, sl, omega2, D, np.asarray(model.structures[p.name].coordinate_indices(), int)))
        eta_at[p.name] = sl
        col += n_eta
    n = col
    T = np.zeros((nx, n))
    T[np.arange(nr), np.arange(nr)] = 1.0
    T[stations, nr + np.arange(len(stations))] = 1.0
    for c, name in port_of.items():
        T[c, eta_at[name]] = pw[c]

    def velocity_source(c):
        # a station moves with its carrier's velocity (Exudyn's closure: the deflection rate is not in
        # the contact velocities), through nested closures; bodies and ports with their own
        while c >= nr and c not in port_of:
            c = int(ext.source[c - nr])
            if c < 0:
                return -1
        return c

    vs = np.array([velocity_source(c) for c in range(nx)], int)
    T_v = np.where(vs[:, None] >= 0, T[np.maximum(vs, 0)], 0.0)
    # a station's reference is its carrier's (through nested closures; ports and the ground: 0)
    ref = np.concatenate([np.asarray(model.reference, float).reshape(-1), np.zeros(nx - nr)])
    reference = np.where((vs >= 0) & (vs < nr), ref[np.maximum(vs, 0)], 0.0)
    return StepCoordinates(n_real=nr, n=n, n_x=nx, stations=stations, modal=tuple(modal), T=T, T_v=T_v,
                           velocity_source=vs, reference=reference, station_slice=slice(nr, nr + len(stations)))


def extended_row_reasons(model):
    """Named reasons why :class:`ExtendedRowForces` cannot sum a model's extended rows on the
    device (empty: it can; the row extension's own reasons are
    :func:`rvtool.solver.row_extension.extension_reasons`'): every contact set of the extension
    needs device rows (:func:`rvtool.solver.row_forces.has_device_rows`), every structure Exudyn's
    modal coordinates (a :class:`~exudyn_user_elements.reduced_structure.ReducedStructure`)."""
    from .row_extension import extension_reasons, row_extension
    from .row_forces import NO_DEVICE_ROWS, has_device_rows
    if extension_reasons(model):
        return []
    ext = row_extension(model)
    reasons = [f"contact set '{lf.set.name}' of element '{lf.element}' ({type(lf.set).__name__}) {NO_DEVICE_ROWS}"
               for lf in ext.leaves if not has_device_rows(lf.set)]
    for p in ext.ports:
        if not callable(getattr(p.structure, "coordinate_indices", None)) or p.name not in getattr(model, "structures",
                                                                                                  {}):
            reasons.append(f"structure {p.name!r} ({type(p.structure).__name__}) has no modal coordinates of the "
                           "model (a ReducedStructure): the row stepper integrates eta as Exudyn does")
    return reasons


class ExtendedRowForces:
    """f, K, C of one copy of ``model`` in the step's unknowns y (module docstring) on the Warp
    ``device``: :meth:`evaluate` (displacements q_y, velocities v_y (n,)) returns f_y (a new
    array); :meth:`tangents` then K_y, C_y of the same evaluation. The device part of an
    evaluation (the pose and velocity gathers, the families' launches, the f gather) is one
    captured graph, the tangent gather another (``capture=False``: launched one by one)."""

    def __init__(self, model, *, device="cpu", capture=True):
        import warp as wp

        from warp_contacts.block_newton import gather_pose_kernel
        from warp_contacts.row_gather import RowGather, gather_lists

        from ..bearings.tapered_set import TaperedBearingSet
        from ..contact.evaluator import StagedLaunch
        from .replica import FamilyCopies, PlainPinCopies
        from .row_extension import MappedAssembler, StructureRows, copy_rows
        from .row_forces import NO_DEVICE_ROWS, history_families
        self.device = wp.get_device(device)
        self.on_cpu = self.device.is_cpu
        families, ext = copy_rows(model, 1, device=device, host_structure=True)
        self.extension = ext
        self.coords = co = step_coordinates(model, ext)
        nx = ext.n
        # the closures' beam blocks as one device family; the ports' static block is replaced by the
        # modal coordinates (module docstring)
        port_names = {p.name for p in ext.ports}
        families = [f for f in families if not isinstance(f.set, StructureRows)]
        beams = [b for b in ext.blocks if b.name not in port_names]
        if beams:
            sr = StructureRows([beams], nx, device=device)
            families.append(FamilyCopies(name="structure", set=sr, scatter=MappedAssembler(sr.local, sr.row_copy, nx, 1),
                                         obs_rows=sr.n_blocks, pose_map=sr.index))
        self.families = families
        gather = gather_pose_kernel(wp.float64)
        self.x_stage = wp.zeros((1, nx), dtype=wp.float64, device=device)
        self.v_stage = wp.zeros((1, nx), dtype=wp.float64, device=device)
        self._zeros = wp.zeros((1, nx), dtype=wp.float64, device=device)
        self.launches, buffers, lists, self._gathers = [], [], [], []
        keep = []

        def velocity_map(pm):
            # the x coordinate whose velocity each body coordinate takes (-1: zero)
            return np.where(pm >= 0, co.velocity_source[np.maximum(pm, 0)], -1).astype(np.int64)

        for f in families:
            s = f.set
            if callable(getattr(s, "set_velocity_tangent", None)):
                s.set_velocity_tangent(True)
            if isinstance(s, StagedLaunch) and getattr(s, "backend", None) == "warp":
                pose, vel = s.pose_buffers()
                _, q, dq, dv = s.row_buffers()
                self.launches.append(s.launch_staged)
            elif isinstance(s, TaperedBearingSet) and s.planar_on_device:
                pose, vel = s.device_pose_buffers()
                q, dq, dv = s.launch_device_velocity_rows()
                self.launches.append(s.launch_device_velocity_rows)
            elif (isinstance(s, PlainPinCopies) or isinstance(s, StructureRows)) and s.rows_on_device:
                pose, vel = s.device_pose_buffers()
                q, dq = s.launch_device_rows()
                dv = None
                self.launches.append(s.launch_device_rows)
            else:
                raise RvtoolInputError(f"contact element '{f.name}' ({type(s).__name__}) {NO_DEVICE_ROWS}")
            pm = np.asarray(f.pose_map, np.int64)
            idx = wp.array(pm.reshape(-1), dtype=wp.int64, device=device)
            keep.append(idx)
            self._gathers.append((gather, self.x_stage, idx, pose))
            if vel is not None:
                vidx = wp.array(velocity_map(pm).reshape(-1), dtype=wp.int64, device=device)
                keep.append(vidx)
                self._gathers.append((gather, self.v_stage, vidx, vel))
            buffers.append((q, dq, dv))
            lists.append(gather_lists(np.asarray(f.scatter.local), nx))
        self._keep = keep
        self.gather = RowGather(lists, buffers, nx, wp.float64, device)
        self._x_host = self.x_stage.numpy()[0] if self.on_cpu else np.zeros(nx)
        self._v_host = self.v_stage.numpy()[0] if self.on_cpu else np.zeros(nx)
        o = self.gather.out.numpy() if self.on_cpu else None
        self._out = None if o is None else (o[:nx], o[nx:nx + nx * nx].reshape(nx, nx),
                                            o[nx + nx * nx:].reshape(nx, nx))
        from .row_forces import warm_and_capture
        self.graph, self.tangent_graph = warm_and_capture(self.device, self.launch_evaluation, self.gather, capture)
        # T's structure: the x coordinates that are selections of y (bodies, stations: y = [them; eta]) and the
        # ports (x_w = P_w eta); the stations' velocity columns folded into their sources' (C_x F, F the
        # velocity-source selection: T_v = F T)
        T = co.T
        ns = co.n_real + len(co.stations)
        self._sel = np.array([int(np.flatnonzero(T[:, j])[0]) for j in range(ns)], np.int64)
        self._ports = np.setdiff1d(np.arange(nx), self._sel)
        self._Pw = np.ascontiguousarray(T[self._ports, ns:])
        self._ns = ns
        self._identity = not len(self._ports) and np.array_equal(self._sel, np.arange(nx))
        folded = np.array([c for c in range(nx) if co.velocity_source[c] != c], np.int64)
        self._fold_from = folded[co.velocity_source[folded] >= 0]
        self._fold_to = co.velocity_source[self._fold_from]
        self._fold_zero = folded
        self._T = np.ascontiguousarray(T)
        self._Tv = np.ascontiguousarray(co.T_v)
        self._y = np.zeros(co.n)
        self._vy = np.zeros(co.n)
        self.timing = {"launches": 0.0, "tangents": 0.0}
        self.evaluations = 0
        self.history_families = history_families(self.families)
        self._maps = {id(f): (np.asarray(f.pose_map, np.int64), velocity_map(np.asarray(f.pose_map, np.int64)))
                      for f in self.history_families}

    def commit(self, q, v):
        """Commit the contact history of every anchored family at the accepted state (q, v) of the
        step's unknowns (:meth:`rvtool.solver.row_forces.RowForces.commit`)."""
        from .row_forces import commit_families
        if not self.history_families:
            return
        co = self.coords
        x, vx = co.reference + co.T @ q, co.T_v @ v

        def poses(f):
            pm, vm = self._maps[id(f)]
            return (np.where(pm >= 0, x[np.maximum(pm, 0)], 0.0), np.where(vm >= 0, vx[np.maximum(vm, 0)], 0.0))
        commit_families(self.history_families, None, None, poses)

    def _vector(self, fx):
        """T^T f_x."""
        if self._identity:
            return np.array(fx)
        return np.concatenate([fx[self._sel], self._Pw.T @ fx[self._ports]])

    def _fold(self, Cx):
        """C_x F: the stations' velocity columns added into their velocity sources' (T_v = F T)."""
        if not len(self._fold_zero):
            return Cx
        C = np.array(Cx)
        np.add.at(C.T, self._fold_to, Cx.T[self._fold_from])
        C[:, self._fold_zero] = 0.0
        return C

    def _matrix(self, A):
        """T^T A T (dense A (n_x, n_x))."""
        if self._identity:
            return np.array(A)
        ns, s, w, P = self._ns, self._sel, self._ports, self._Pw
        Y = np.empty((self.coords.n, self.coords.n))
        Y[:ns, :ns] = A[np.ix_(s, s)]
        Y[:ns, ns:] = A[np.ix_(s, w)] @ P
        Y[ns:, :ns] = P.T @ A[np.ix_(w, s)]
        Y[ns:, ns:] = P.T @ A[np.ix_(w, w)] @ P
        return Y

    def launch_evaluation(self):
        """The gathers of every family's body poses and velocities from the staged row coordinates,
        the families' launches and the f gather (no transfer; capturable)."""
        import warp as wp
        for kern, src, idx, out in self._gathers:
            wp.launch(kern, dim=idx.shape[0], device=self.device, inputs=[src, self._zeros, idx], outputs=[out])
        for launch in self.launches:
            launch()
        self.gather.launch_forces()

    def evaluate(self, q, v):
        """f_y (n,) at displacements q and velocities v (n,) of the step's unknowns."""
        import warp as wp
        t0 = time.perf_counter()
        co = self.coords
        self._y[...] = q
        self._vy[...] = v
        self._x_host[...] = co.reference + self._T @ q
        self._v_host[...] = self._Tv @ v
        if not self.on_cpu:
            self.x_stage.assign(self._x_host[None])
            self.v_stage.assign(self._v_host[None])
        if self.graph is not None:
            wp.capture_launch(self.graph)
        else:
            self.launch_evaluation()
        fx = self._out[0] if self.on_cpu else self.gather.out[:co.n_x].numpy()
        f = self._vector(fx)
        for _, sl, omega2, D, _ in co.modal:
            f[sl] -= omega2 * q[sl] + D @ v[sl]
        self.timing["launches"] += time.perf_counter() - t0
        self.evaluations += 1
        return f

    def tangents(self):
        """(K_y, C_y) (n, n) of the last :meth:`evaluate`."""
        import warp as wp
        t0 = time.perf_counter()
        co = self.coords
        if self.tangent_graph is not None:
            wp.capture_launch(self.tangent_graph)
        else:
            self.gather.launch_tangents()
        if self.on_cpu:
            Kx, Cx = self._out[1:]
        else:
            nx = co.n_x
            o = self.gather.out[nx:].numpy()
            Kx, Cx = o[:nx * nx].reshape(nx, nx), o[nx * nx:].reshape(nx, nx)
        K = self._matrix(Kx)
        C = self._matrix(self._fold(Cx))
        for _, sl, omega2, D, _ in co.modal:
            K[sl, sl] -= np.diag(omega2)
            C[sl, sl] -= D
        self.timing["tangents"] += time.perf_counter() - t0
        return K, C


__all__ = ["ExtendedRowForces", "StepCoordinates", "extended_row_reasons", "step_coordinates"]
