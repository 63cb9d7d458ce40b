"""Forces f(q, v), K = df/dq and C = df/dv of ONE copy of a built model, from its contact
families' rows evaluated AND summed on the Warp device, with every buffer and launch prepared
once: the force evaluation of the row stepper (:mod:`rvtool.solver.row_dynamics`).

The families are the device row Newton's (:func:`rvtool.solver.replica.copy_families`, one
copy: the same kernels and rows as the model's Exudyn element). One evaluation:

1. the absolute poses (reference + q) and velocities are written into every family's input
   buffers (on the CPU the buffers' own memory through NumPy views, no copy; on a GPU one
   upload per buffer);
2. one recorded launch per family (no argument packing): cycloid pins, involute pairs and
   rolling elements (their staged launch, velocity tangent on), tapered rollers (planar state,
   rollers, planar rows and their dQ/dv: :mod:`warp_contacts.tapered_planar`), plain output
   pins; a family without device rows is evaluated on the host and its rows uploaded;
3. the rows are summed into f (n,), K, C (n, n) on the device in one launch
   (:class:`warp_contacts.row_gather.RowGather`: one thread per output entry gathers its row
   entries, no atomics) and read (CPU: views of the device memory; GPU: one download).

Reference: :class:`rvtool.solver.row_dynamics.RowDrivenModel`'s ``forces`` (the rows brought to
the host and summed with ``np.bincount``); the same sums up to the order of the additions.
"""
import time

import numpy as np

from ..errors import RvtoolInputError


class RowForces:
    """f, K, C of one copy of ``model`` (module docstring) on the Warp ``device``.
    :meth:`evaluate` takes body poses and velocities (nb, 3) (absolute; the ground is added) and
    returns host arrays f (n,), K (n, n), C (n, n), valid until the next call (on the CPU they are
    views of the device sums). ``timing``: seconds in writing inputs, launches, sums and reads."""

    def __init__(self, model, *, device="cpu"):
        import warp as wp

        from warp_contacts.row_gather import RowGather, gather_lists

        from ..bearings.tapered_set import TaperedBearingSet
        from ..contact.evaluator import StagedLaunch
        from .replica import PlainPinCopies, copy_families
        self.device = wp.get_device(device)
        self.on_cpu = self.device.is_cpu
        self.nb = nb = len(model.body_names)
        self.n = n = 3 * nb
        self.families = copy_families(model, 1, device=device)
        self._launch, inputs, buffers, lists = [], [], [], []
        for f in self.families:
            s = f.set
            if callable(getattr(s, "set_velocity_tangent", None)):
                s.set_velocity_tangent(True)              # driven runs: dQ/dv of every pair family
            if isinstance(s, StagedLaunch) and getattr(s, "backend", None) == "warp":
                pose, vel = s.pose_buffers()
                _, q, dq, dv = s.row_buffers()
                self._launch.append(s.launch_staged)
            elif isinstance(s, TaperedBearingSet) and s.planar_on_device:
                pose, vel = s.device_pose_buffers()
                q, dq, dv = s.launch_device_velocity_rows()   # allocates the dQ/dv rows once
                self._launch.append(s.launch_device_velocity_rows)
            elif isinstance(s, PlainPinCopies) and s.rows_on_device:
                pose, vel = s.device_pose_buffers()
                q, dq = s.launch_device_rows()
                dv = None
                self._launch.append(s.launch_device_rows)
            else:
                raise RvtoolInputError(f"contact element '{f.name}' ({type(s).__name__}) has no device rows "
                                       "(backend 'warp' with staged or device rows); the row stepper's device "
                                       "sums take none other")
            inputs.append((pose, vel))
            buffers.append((q, dq, dv))
            loc = np.asarray(f.scatter.local)
            lists.append(gather_lists(loc, n, loc.shape[0], loc.shape[1], dv is not None))
        self.gather = RowGather(lists, buffers, n, wp.float64, device)
        # every input buffer once (families may share none; a buffer listed twice would be written twice)
        bufs = []
        for pose, vel in inputs:
            bufs.append((pose, False))
            if vel is not None:
                bufs.append((vel, True))
        self._inputs = bufs
        if self.on_cpu:
            self._views = [(b.numpy()[:nb], is_vel) for b, is_vel in bufs]
        else:
            self._host = {id(b): np.zeros(tuple(b.shape)) for b, _ in bufs}
        self._out = None
        self.timing = {"inputs": 0.0, "launches": 0.0, "sums": 0.0, "read": 0.0}
        self.evaluations = 0

    def evaluate(self, pose, vel):
        """(f (n,), K (n, n), C (n, n)) at absolute body poses and velocities (nb, 3)."""
        t0 = time.perf_counter()
        if self.on_cpu:
            for view, is_vel in self._views:
                view[...] = vel if is_vel else pose
        else:
            for b, is_vel in self._inputs:
                h = self._host[id(b)]
                h[:self.nb] = vel if is_vel else pose
                b.assign(h)
        t1 = time.perf_counter()
        for launch in self._launch:
            launch()
        t2 = time.perf_counter()
        out = self.gather.launch()
        t3 = time.perf_counter()
        if self._out is None or not self.on_cpu:
            o = out.numpy()                      # CPU: a view of the device sums (no copy)
            n = self.n
            self._out = (o[:n], o[n:n + n * n].reshape(n, n), o[n + n * n:].reshape(n, n))
        out = self._out
        t4 = time.perf_counter()
        tm = self.timing
        tm["inputs"] += t1 - t0
        tm["launches"] += t2 - t1
        tm["sums"] += t3 - t2
        tm["read"] += t4 - t3
        self.evaluations += 1
        return out


__all__ = ["RowForces"]
