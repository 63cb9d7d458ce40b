"""Helpers shared by the kernel wrappers' recorded launches (one definition instead of one per
family): replaying a recorded launch over the first rows only, and overwriting the packed row
parameters in place so that the recorded launch keeps pointing at them."""
import numpy as np
import warp as wp


def launch_rows(cmd, n, n_rows=None):
    """Replay the recorded launch ``cmd`` (``n`` rows) over its first ``n_rows`` rows (a batch
    compacted to the front of the arrays, e.g. by the device Newton; None: all)."""
    if n_rows is None or int(n_rows) == n:
        cmd.launch()
        return
    cmd.set_dim(int(n_rows))
    try:
        cmd.launch()
    finally:
        cmd.set_dim(n)


def assign_parameters(array, fparams, dtype):
    """Overwrite the device array of packed float parameters in place with ``fparams`` (same
    shape; slow-state gap offsets and friction between mechanical windows)."""
    fp = np.ascontiguousarray(fparams, dtype=dtype)
    if fp.shape != tuple(array.shape):
        raise ValueError(f"parameter rows of shape {fp.shape} for a launch recorded with {tuple(array.shape)}")
    array.assign(fp)


class RecordedRows:
    """Device access of a kernel wrapper's recorded launch (``_cmd`` over ``n`` rows, float
    parameters of numpy dtype ``ndtype``): the wrapper says where its packed row parameters
    (:meth:`parameter_arrays`) and its data buffers (:meth:`data_array`) live."""

    def parameter_arrays(self):
        """(fparams, iparams): the device arrays of the packed row parameters the launch reads."""
        return self.fparams, self.iparams

    def data_array(self, name):
        """The device data buffer ``name`` of the recorded launch."""
        return self._dev[name]

    def device_array(self, name):
        """A device array of the recorded launch: a data buffer (pose, vel, q, dqdq, dqdv, obs) or
        the row parameters ("fparams", "iparams"), which a device-side refill may overwrite
        between launches (the recorded launch reads them in place)."""
        if name in ("fparams", "iparams"):
            return self.parameter_arrays()[0 if name == "fparams" else 1]
        return self.data_array(name)

    def launch_recorded(self, n_rows=None):
        """Replay the recorded launch on the device-resident arrays as they are (no host
        transfers; benchmarks and CUDA-graph capture fill the inputs with ``device_array``).
        n_rows: evaluate only the first n_rows rows (a batch compacted to the front of the
        arrays, e.g. by the device Newton); default all."""
        launch_rows(self._cmd, self.n, n_rows)

    def set_parameters(self, fparams):
        """Overwrite the packed float parameters (same shape) in place on the device; the recorded
        launch keeps pointing at them (slow-state gap offsets between mechanical windows)."""
        assign_parameters(self.parameter_arrays()[0], fparams, self.ndtype)


class PairLaunch(RecordedRows):
    """The recorded launch of a two-body pair kernel (cycloid--pin slices, involute tooth pairs):
    launch buffers, the optional anchor history of Eq. (friction)'s anchor model, the velocity
    tangent switch and the host round trip, written once for every such family.

    A wrapper sets ``wdtype``, ``ndtype``, ``device`` and ``n`` and calls :meth:`_setup_launch`
    with its kernel factory ``(wdtype, velocity_tangent, anchor) -> kernel`` and its model
    arrays (the packed float parameters first, the int parameters second); the anchor
    parameters are appended as the model's last argument."""

    # outputs left on the device (returned as None; read them with device_array), e.g. the
    # per-row tangents that a device-side block scatter sums (warp_contacts.block_scatter)
    keep_on_device = frozenset()

    def _setup_launch(self, kernel_factory, model, anchor_params, n_bodies, n_obs):
        from .anchor_ref import N_ANCHOR
        from .planar import LaunchBuffers
        n = self.n
        self._kernel_factory = kernel_factory
        self.anchor = anchor_params is not None
        # without anchors the history arguments are one-row placeholders the kernel never reads
        nh = n if self.anchor else 1
        ap = np.zeros((1, N_ANCHOR)) if anchor_params is None else np.asarray(anchor_params, float)
        assert ap.shape == (nh, N_ANCHOR)
        self._model = list(model) + [wp.array(ap.astype(self.ndtype), dtype=self.wdtype, device=self.device)]
        self._buf = LaunchBuffers({"pose": ((n_bodies + 1, 3), "f"), "vel": ((n_bodies + 1, 3), "f"),
                                   "h_act_in": (nh, "int"), "h_a_in": ((nh, 2), "f"), "h_b_in": ((nh, 2), "f"),
                                   "q": ((n, 6), "f"), "dqdq": ((n, 6, 6), "f"), "dqdv": ((n, 6, 6), "f"),
                                   "obs": ((n, n_obs), "f"), "h_act_out": (nh, "int"), "h_a_out": ((nh, 2), "f"),
                                   "h_b_out": ((nh, 2), "f")}, self.wdtype, self.ndtype, self.device)
        self.velocity_tangent = True
        self._record()

    def _record(self):
        dev = self._buf.dev
        self._cmd = wp.launch(self._kernel_factory(self.wdtype, self.velocity_tangent, self.anchor), dim=self.n,
                              device=self.device,
                              inputs=self._model + [dev[k] for k in ("pose", "vel", "h_act_in", "h_a_in", "h_b_in")],
                              outputs=[dev[k] for k in ("q", "dqdq", "dqdv", "obs", "h_act_out", "h_a_out", "h_b_out")],
                              record_cmd=True)

    def set_velocity_tangent(self, on):
        """Switch the velocity tangent dQ/dv on (default) or off. Off, the kernel skips the six
        velocity seeds of the tangent loop (about a third of its work) and dQ/dv is returned as
        None: for static solves, whose residual does not depend on velocities."""
        self.velocity_tangent = bool(on)
        self._record()

    def evaluate(self, pose, vel):
        """Returns (Q (N,6), dQdq, dQdv or None, obs (N, n_obs)); arrays are reused by the next call."""
        h = self._buf.host
        h["pose"][...] = pose
        h["vel"][...] = vel
        self._buf.upload(("pose", "vel"))
        self._cmd.launch()
        names = [k for k in ("q", "dqdq", "dqdv", "obs") if k not in self.keep_on_device
                 and (k != "dqdv" or self.velocity_tangent)]
        self._buf.download(names)
        return tuple(h[k] if k in names else None for k in ("q", "dqdq", "dqdv", "obs"))

    def evaluate_anchor(self, pose, vel, hist_active, hist_a, hist_b):
        """:meth:`evaluate` with the committed anchor history in and the trial history
        (flags (N,), anchor_A (N, 2), anchor_B (N, 2)) out as a fifth result."""
        if not self.anchor:
            raise RuntimeError("evaluate_anchor needs a kernel built with anchor_params")
        h = self._buf.host
        h["h_act_in"][...] = hist_active
        h["h_a_in"][...] = hist_a
        h["h_b_in"][...] = hist_b
        self._buf.upload(("h_act_in", "h_a_in", "h_b_in"))
        out = self.evaluate(pose, vel)
        self._buf.download(("h_act_out", "h_a_out", "h_b_out"))
        return out + ((h["h_act_out"], h["h_a_out"], h["h_b_out"]),)

    def parameter_arrays(self):
        return self._model[0], self._model[1]

    def data_array(self, name):
        return self._buf.dev[name]
