"""Warp kernel of the rows of constant linear blocks (NumPy reference:
:mod:`warp_contacts.linear_rows_ref`, see there): one thread per (row, entry), Q_r = -K_r x_r with
x_r read from the pose array of the row's pseudo-bodies (row r's coordinate i at pose row
r nbp + i // 3, column i % 3), the tangent -K_r written once at construction.
"""
import functools

import numpy as np
import warp as wp


@functools.lru_cache(maxsize=None)
def kernel(dtype):
    @wp.kernel(module="unique")
    def linear_rows(K: wp.array3d(dtype=dtype), pose: wp.array2d(dtype=dtype), nbp: int,
                    q: wp.array2d(dtype=dtype)):
        r, i = wp.tid()
        m = K.shape[1]
        s = dtype(0.0)
        for j in range(m):
            s = s + K[r, i, j] * pose[r * nbp + j // 3, j % 3]
        q[r, i] = -s
    return linear_rows


class LinearRows:
    """Device arrays of N rows of blocks K (N, m, m): ``pose`` ((N nbp + 1, 3), the ground row last,
    as the contact kernels' pose arrays), ``q`` (N, m), ``dqdq`` (N, m, m) = -K; :meth:`launch`
    evaluates q at the poses in ``pose`` (a recorded launch)."""

    def __init__(self, K, nbp, device, dtype=wp.float64):
        K = np.ascontiguousarray(K, np.float64)
        N, m, _ = K.shape
        self.K = wp.array(K, dtype=dtype, device=device)
        self.dqdq = wp.array(np.ascontiguousarray(-K), dtype=dtype, device=device)
        self.pose = wp.zeros((N * int(nbp) + 1, 3), dtype=dtype, device=device)
        self.q = wp.zeros((N, m), dtype=dtype, device=device)
        self._cmd = wp.launch(kernel(dtype), dim=(N, m), inputs=[self.K, self.pose, int(nbp)], outputs=[self.q],
                              device=device, record_cmd=True)

    def launch(self):
        self._cmd.launch()


__all__ = ["LinearRows", "kernel"]
