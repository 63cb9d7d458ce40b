"""Dense per-copy linear solve for the one-thread-per-copy kernels (batched static Newton, fused
dynamic stepper): Gaussian elimination with partial pivoting and back substitution on copy p's
block of a (B, n, n) array. Its reference is ``numpy.linalg.solve`` (tests/test_dense_lu.py).

One sequential thread per copy and a fixed operation order make the result deterministic (two
runs bit-identical); no LAPACK call exists inside a Warp kernel, and the blocks are small (tens
of coordinates), so the O(n^3) loop is not the cost (the contact rows are).
"""
import functools

import warp as wp


@functools.lru_cache(maxsize=None)
def lu_funcs(dtype):
    """``lu_solve`` for ``dtype``."""

    @wp.func
    def lu_solve(A: wp.array3d(dtype=dtype), b: wp.array2d(dtype=dtype), x: wp.array2d(dtype=dtype), p: int, n: int):
        """Solve A[p] x[p] = b[p] (the leading n x n block). A[p] and b[p] are overwritten by the
        elimination; x may be b (each x[p, i] is written after b[p, i] was read). Returns 0 where a
        pivot column is zero or not finite (x then untouched), else 1."""
        ok = int(1)
        for c in range(n):
            piv = int(c)
            best = wp.abs(A[p, c, c])
            for i in range(c + 1, n):
                v = wp.abs(A[p, i, c])
                if v > best:
                    best = v
                    piv = i
            # "not >" also rejects a NaN column
            if not (best > dtype(0.0)):
                ok = int(0)
            if ok != 0:
                if piv != c:
                    for j in range(n):
                        t = A[p, c, j]
                        A[p, c, j] = A[p, piv, j]
                        A[p, piv, j] = t
                    t = b[p, c]
                    b[p, c] = b[p, piv]
                    b[p, piv] = t
                for i in range(c + 1, n):
                    m = A[p, i, c] / A[p, c, c]
                    if m != dtype(0.0):
                        for j in range(c + 1, n):
                            A[p, i, j] = A[p, i, j] - m * A[p, c, j]
                        b[p, i] = b[p, i] - m * b[p, c]
        if ok != 0:
            for ii in range(n):
                i = n - 1 - ii
                s = b[p, i]
                for j in range(i + 1, n):
                    s = s - A[p, i, j] * x[p, j]
                x[p, i] = s / A[p, i, i]
        return ok

    return lu_solve
