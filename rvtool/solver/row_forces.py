"""Forces f(q, v), K = df/dq and C = df/dv of ONE copy of a built model, from its contact
families' rows evaluated AND summed on the Warp device, with every buffer and launch prepared
once: the force evaluation of the row stepper (:mod:`rvtool.solver.row_dynamics`).

The families are the device row Newton's (:func:`rvtool.solver.replica.copy_families`, one
copy: the same kernels and rows as the model's Exudyn element). One evaluation:

1. the absolute poses (reference + q) and velocities are written into two staging arrays (on
   the CPU through NumPy views of their memory; on a GPU one upload each) and copied on the
   device into every family's input buffers;
2. one recorded launch per family (no argument packing): cycloid pins, involute pairs and
   rolling elements (their staged launch, velocity tangent on), tapered rollers (planar state,
   rollers, planar rows and their dQ/dv: :mod:`warp_contacts.tapered_planar`), plain output
   pins; a family without device rows is evaluated on the host and its rows uploaded;
3. the rows are summed into f (n,) on the device (:class:`warp_contacts.row_gather.RowGather`:
   one thread per output entry gathers its row entries, no atomics) and read (CPU: a view of the
   device memory; GPU: one download); K, C (n, n) are gathered from the same rows only when the
   caller asks (:meth:`RowForces.tangents`: a converged Newton iterate needs none).

The device part of steps 1 to 3 is captured once as a graph and replayed per evaluation.

Reference: :class:`rvtool.solver.row_dynamics.RowDrivenModel`'s ``forces`` (the rows brought to
the host and summed with ``np.bincount``); the same sums up to the order of the additions.
"""
import time

import numpy as np

from ..errors import RvtoolInputError


NO_DEVICE_ROWS = ("has no device rows (backend 'warp' with staged or device rows, e.g. tapered rows with slices "
                  "'laminae'); the row stepper's device sums take none other")
"""The named reason of a contact element without device rows (:func:`device_row_reasons`, :class:`RowForces`)."""


def has_device_rows(s):
    """Whether the contact set ``s`` (a model's evaluator, or its copy) evaluates its rows on the
    device for :class:`RowForces`: a staged launch of backend "warp" (pair families, rolling
    elements, circle pairs, plain output pins), tapered rows with planar device rows (laminae),
    plain output-pin copies of backend "warp"."""
    from ..bearings.tapered_set import TaperedBearingSet
    from ..contact.evaluator import StagedLaunch
    from .replica import PlainPinCopies
    if isinstance(s, TaperedBearingSet):
        return bool(s.planar_on_device)
    if isinstance(s, PlainPinCopies):
        return bool(s.rows_on_device)
    return isinstance(s, StagedLaunch) and getattr(s, "backend", None) == "warp"


def device_row_reasons(model):
    """A named reason for every contact element of ``model`` whose rows :class:`RowForces` cannot
    sum on the device (:func:`has_device_rows`; checked on the model's own sets, no copy made)."""
    return [f"contact element '{el.evaluator.name}' ({type(el.evaluator).__name__}) {NO_DEVICE_ROWS}"
            for el in model.contact_elements() if not has_device_rows(el.evaluator)]


def history_families(families):
    """The families of ``families`` whose kernels read a committed history (stick--slip anchors)."""
    return [f for f in families if getattr(f.set, "anchor", False)
            and callable(getattr(f.set, "stages_history", None)) and f.set.stages_history()]


def commit_families(families, pose, vel, poses=None):
    """Commit every family's trial history at the state (pose, vel) (``poses``: a function of the
    family giving its own (pose, vel); default the state as it is) and stage it into its kernel."""
    for f in families:
        pf, vf = (pose, vel) if poses is None else poses(f)
        f.set.commit(pf, vf)                 # a fresh launch at the accepted state from the committed history
        f.set.stage(pf, vf)                  # the new history into the kernel's inputs


def warm_and_capture(device, launch_evaluation, gather, capture):
    """Run the evaluation launches and the gather once (it loads every module before a capture), then,
    with ``capture``, record the evaluation and the tangent gather as two CUDA graphs: (graph,
    tangent_graph), (None, None) without capture. Shared by the row stepper's plain and extended forces."""
    import warp as wp
    launch_evaluation()
    gather.launch()
    if not capture:
        return None, None
    with wp.ScopedCapture(device=device) as cap:
        launch_evaluation()
    graph = cap.graph
    with wp.ScopedCapture(device=device) as cap:
        gather.launch_tangents()
    return graph, cap.graph


class RowForces:
    """f, K, C of one copy of ``model`` (module docstring) on the Warp ``device``.
    :meth:`evaluate` takes body poses and velocities (nb, 3) (absolute; the ground is added) and
    returns the host array f (n,); :meth:`tangents` then gives K, C (n, n) of the same rows (on
    the CPU the results are views of the device sums, valid until the next call). capture: the
    evaluation's copies and launches as one captured graph
    (``wp.ScopedCapture``: a CUDA graph on a GPU, an APIC replay on the CPU), replayed by
    ``wp.capture_launch``; False: launched one by one. ``timing``: wall seconds in evaluations
    (inputs, launches, f read) and in tangents (gather, read)."""

    def __init__(self, model, *, device="cpu", capture=True):
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
        self.launches, inputs, buffers, lists = [], [], [], []
        for f in self.families:
            s = f.set
            if callable(getattr(s, "set_velocity_tangent", None)):
                s.set_velocity_tangent(True)              # driven runs: dQ/dv of every pair family
            if isinstance(s, StagedLaunch) and getattr(s, "backend", None) == "warp":
                pose, vel = s.pose_buffers()
                _, q, dq, dv = s.row_buffers()
                self.launches.append(s.launch_staged)
            elif isinstance(s, TaperedBearingSet) and s.planar_on_device:
                pose, vel = s.device_pose_buffers()
                q, dq, dv = s.launch_device_velocity_rows()   # allocates the dQ/dv rows once
                self.launches.append(s.launch_device_velocity_rows)
            elif isinstance(s, PlainPinCopies) and s.rows_on_device:
                pose, vel = s.device_pose_buffers()
                q, dq = s.launch_device_rows()
                dv = None
                self.launches.append(s.launch_device_rows)
            else:
                raise RvtoolInputError(f"contact element '{f.name}' ({type(s).__name__}) {NO_DEVICE_ROWS}: run it "
                                       "with sums='host' (the rows summed on the host)")
            inputs.append((pose, vel))
            buffers.append((q, dq, dv))
            loc = np.asarray(f.scatter.local)
            lists.append(gather_lists(loc, n))
        self.gather = RowGather(lists, buffers, n, wp.float64, device)
        # every input buffer of every family (pose, or velocity)
        bufs = []
        for pose, vel in inputs:
            bufs.append((pose, False))
            if vel is not None:
                bufs.append((vel, True))
        # poses and velocities (nb + 1, 3) (the ground's row last, zero) in two staging arrays, copied
        # on the device into every family's input buffers by each evaluation (inside its graph); on
        # the CPU written through views of their memory, on a GPU from host twins (one upload each)
        self.pose_stage = wp.zeros((nb + 1, 3), dtype=wp.float64, device=device)
        self.vel_stage = wp.zeros((nb + 1, 3), dtype=wp.float64, device=device)
        if self.on_cpu:
            self._stage_views = (self.pose_stage.numpy()[:nb], self.vel_stage.numpy()[:nb])
        else:
            self._stage_views = (np.zeros((nb + 1, 3)), np.zeros((nb + 1, 3)))
        self._bufs = bufs
        self._f_dev, self._kc_dev = self.gather.out[:n], self.gather.out[n:]
        o = self.gather.out.numpy() if self.on_cpu else None   # CPU: a view of the device sums (no copy)
        self._out = None if o is None else (o[:n], o[n:n + n * n].reshape(n, n), o[n + n * n:].reshape(n, n))
        self.graph, self.tangent_graph = warm_and_capture(self.device, self.launch_evaluation, self.gather, capture)
        self.timing = {"launches": 0.0, "tangents": 0.0}
        self.evaluations = 0
        #: the families with stick--slip anchors (their kernels read the committed history: :meth:`commit`)
        self.history_families = history_families(self.families)

    def commit(self, pose, vel):
        """Commit the contact history of every anchored family at the accepted state (absolute body
        poses and velocities (nb, 3)), as Exudyn's driver commits each contact element after an
        accepted step, and write it into the family's kernel inputs (read by the next evaluations'
        graph replays)."""
        commit_families(self.history_families, pose, vel)

    def launch_evaluation(self):
        """One evaluation from the staging arrays (:attr:`pose_stage`, :attr:`vel_stage`) as they
        are: the copies into the families' buffers, the families' launches and the f gather (no
        host transfer; capturable)."""
        import warp as wp
        for b, is_vel in self._bufs:
            wp.copy(b, self.vel_stage if is_vel else self.pose_stage)
        for launch in self.launches:
            launch()
        self.gather.launch_forces()

    def stage(self, pose, vel):
        """Write body poses and velocities (nb, 3) into the staging arrays (no launch)."""
        hp, hv = self._stage_views
        if self.on_cpu:
            hp[...] = pose
            hv[...] = vel
        else:
            hp[:self.nb] = pose
            hv[:self.nb] = vel
            self.pose_stage.assign(hp)
            self.vel_stage.assign(hv)

    def forces_view(self):
        """f (n,) of the last evaluation (CPU: a view of the device sums; GPU: downloaded)."""
        return self._out[0] if self.on_cpu else self._f_dev.numpy()

    def evaluate(self, pose, vel):
        """f (n,) at absolute body poses and velocities (nb, 3); the families' rows stay on the
        device for :meth:`tangents`. On the CPU f is a view of the device sums (valid until the
        next evaluation)."""
        import warp as wp
        t0 = time.perf_counter()
        self.stage(pose, vel)
        if self.graph is not None:
            wp.capture_launch(self.graph)
        else:
            self.launch_evaluation()
        f = self.forces_view()
        self.timing["launches"] += time.perf_counter() - t0
        self.evaluations += 1
        return f

    def tangents(self):
        """(K, C) (n, n) of the last :meth:`evaluate` (one gather launch over its rows)."""
        import warp as wp
        t0 = time.perf_counter()
        if self.tangent_graph is not None:
            wp.capture_launch(self.tangent_graph)
        else:
            self.gather.launch_tangents()
        if self.on_cpu:
            K, C = self._out[1:]
        else:
            n = self.n
            o = self._kc_dev.numpy()
            K, C = o[:n * n].reshape(n, n), o[n * n:].reshape(n, n)
        self.timing["tangents"] += time.perf_counter() - t0
        return K, C

    def evaluate_all(self, pose, vel):
        """(f, K, C) at absolute body poses and velocities (nb, 3)."""
        f = self.evaluate(pose, vel)
        return (f,) + self.tangents()


__all__ = ["NO_DEVICE_ROWS", "RowForces", "commit_families", "device_row_reasons", "has_device_rows",
           "history_families"]
