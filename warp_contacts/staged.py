"""Named inputs and outputs of a recorded kernel launch, written and read without the wrapper's
``evaluate`` round trip, so that the launch itself can be replayed on its own or inside a
captured graph (``wp.ScopedCapture``: a CUDA graph on a GPU, an APIC replay on the CPU).

A kernel wrapper exposes its arrays through ``device_array(name)`` (:class:`warp_contacts.recorded.PairLaunch`,
:class:`warp_contacts.circle_pairs.CirclePairKernel`, :class:`warp_contacts.output_pins.OutputPinKernel`).
On the CPU those arrays alias NumPy buffers: :class:`Staged` writes and reads NumPy views of them
(no copies). On a GPU it keeps a host twin of each input, written and then uploaded, and reads
outputs by download.
"""
import warp as wp


class Staged:
    """Inputs/outputs of the recorded launch of ``kernel`` (a wrapper with ``device_array``)."""

    def __init__(self, kernel):
        self.kernel = kernel
        self.on_cpu = wp.get_device(kernel.device).is_cpu
        self._views = {}
        self._rows = {}

    def _view(self, name):
        v = self._views.get(name)
        if v is None:
            a = self.kernel.device_array(name)
            # CPU: the device array's own memory; GPU: a host twin (uploaded by write)
            v = a.numpy()
            self._views[name] = v
        return v

    def write(self, name, value):
        """Input ``name`` = value (same shape)."""
        v = self._view(name)
        v[...] = value
        if not self.on_cpu:
            self.kernel.device_array(name).assign(v)

    def write_rows(self, name, value):
        """The leading rows of input ``name`` = value (a pose array whose last row, the ground, stays)."""
        rows = self._rows.get(name)
        if rows is None:
            rows = self._rows[name] = self._view(name)[:len(value)]
        rows[...] = value
        if not self.on_cpu:
            self.kernel.device_array(name).assign(self._view(name))

    def read(self, name):
        """Output ``name`` of the last launch: a view on the CPU (valid until the next launch), a
        downloaded copy on a GPU."""
        return self._view(name) if self.on_cpu else self.kernel.device_array(name).numpy()
