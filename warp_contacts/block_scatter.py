"""Warp kernel: sum per-row generalized forces and tangents into per-copy blocks on the device.

The batched path evaluates B independent reducer copies in one launch per contact family
and needs, per copy, its force vector (3 nb) and tangent block (3 nb x 3 nb) (Eq.
(contact_mapping) summed over the copy's rows). On a GPU, copying the per-row tangents
to the host and scattering them there costs more than the contact kernels (RD-40 at
B = 256: 3.7 ms launch + transfer, 1.2 ms host scatter per evaluation); summing them on
the device moves B (3 nb)^2 numbers instead of N (3m)^2 (N ~ 100 B rows).

One thread per row adds its entries with atomics (the order of the additions, and so the
last bits of a sum, may differ between runs on a GPU). NumPy reference:
:class:`rvtool.batched.evaluator.CopyBlockAssembler` (a CSR product), compared in
``tests/test_batched_sequence.py``.
"""
import functools

import warp as wp


@functools.lru_cache(maxsize=None)
def _kernel(dtype):
    @wp.kernel(module="unique")
    def scatter_rows(q: wp.array2d(dtype=dtype), K: wp.array3d(dtype=dtype), local: wp.array2d(dtype=wp.int32),
                     row_copy: wp.array(dtype=wp.int32), q_out: wp.array2d(dtype=dtype),
                     K_out: wp.array3d(dtype=dtype)):
        i = wp.tid()
        c = row_copy[i]
        k = local.shape[1]
        for a in range(k):
            la = local[i, a]
            if la >= 0:
                wp.atomic_add(q_out, c, la, q[i, a])
                for b in range(k):
                    lb = local[i, b]
                    if lb >= 0:
                        wp.atomic_add(K_out, c, la, lb, K[i, a, b])
    return scatter_rows


class BlockScatter:
    """Device-side sum of the rows of several families into per-copy blocks.

    families: list of (local (N, k) int local coordinate index of each row entry or -1,
    row_copy (N,) int); n_copies, n: copy count and coordinates per copy; dtype: Warp
    scalar type; device: Warp device.
    """

    def __init__(self, families, n_copies, n, dtype, device):
        import numpy as np
        self.device = device
        self.kernel = _kernel(dtype)
        self.maps = [(wp.array(np.ascontiguousarray(loc, np.int32), dtype=wp.int32, device=device),
                      wp.array(np.ascontiguousarray(rc, np.int32), dtype=wp.int32, device=device), len(rc))
                     for loc, rc in families]
        self.Q = wp.zeros((n_copies, n), dtype=dtype, device=device)
        self.K = wp.zeros((n_copies, n, n), dtype=dtype, device=device)
        self._cmds = {}           # recorded launches per (family, row arrays): replayed without argument packing

    def sum(self, rows):
        """rows: per family (q (N, k) device array, K (N, k, k) device array), in the order of
        ``families``. Returns the device arrays Q (B, n), K (B, n, n) (overwritten by the next sum)."""
        self.Q.zero_()
        self.K.zero_()
        for i, ((loc, rc, n_rows), (q, K)) in enumerate(zip(self.maps, rows)):
            key = (i, q.ptr, K.ptr, q.shape, K.shape)
            hit = self._cmds.get(key)
            if hit is None:
                # the arrays are kept with the launch: their addresses stay theirs while it is cached
                hit = self._cmds[key] = (wp.launch(self.kernel, dim=n_rows, inputs=[q, K, loc, rc],
                                                   outputs=[self.Q, self.K], device=self.device, record_cmd=True),
                                         (q, K))
            hit[0].launch()
        return self.Q, self.K

    def __call__(self, rows):
        """As :meth:`sum`; returns host arrays Q (B, n), K (B, n, n)."""
        Q, K = self.sum(rows)
        return Q.numpy(), K.numpy()
