"""Dense per-copy linear solve for the one-thread-per-copy kernels (batched static Newton, fused
dynamic stepper): Gaussian elimination with partial pivoting and back substitution on copy p's
block of a (B, n, n) array, or of an (n, n, B) one (copy-fastest: coalesced across a GPU warp;
:func:`accessors`). Its reference is ``numpy.linalg.solve`` (tests/test_dense_lu.py).

One sequential thread per copy and a fixed operation order make the result deterministic (two
runs bit-identical); no LAPACK call exists inside a Warp kernel, and the blocks are small (tens
of coordinates); on a GPU with one thread per copy the copy-major layout is the slow one (every
thread of a warp reads its own cache line), hence the copy-fastest layout of the block Newton step.
"""
import functools

import warp as wp


LAYOUTS = ("copy_major", "copy_fastest")


@functools.lru_cache(maxsize=None)
def accessors(dtype, layout="copy_major"):
    """(mat, set_mat, vec, set_vec): element (i, j) of copy p's block and element i of copy p's
    vector. ``layout`` "copy_major": blocks (B, n, n) and vectors (B, n), element (i, j) of copy p
    at [p, i, j] (each copy's block contiguous); "copy_fastest": blocks (n, n, B) and vectors (n, B),
    at [i, j, p] (neighbouring copies at neighbouring addresses: the threads of a GPU warp, one per
    copy, read one contiguous segment per access). The same arithmetic in the same order in both."""
    if layout not in LAYOUTS:
        raise ValueError(f"layout {layout!r}: one of {LAYOUTS}")
    if layout == "copy_major":
        @wp.func(module="unique")
        def mat(A: wp.array3d(dtype=dtype), p: int, i: int, j: int):
            return A[p, i, j]

        @wp.func(module="unique")
        def set_mat(A: wp.array3d(dtype=dtype), p: int, i: int, j: int, v: dtype):
            A[p, i, j] = v

        @wp.func(module="unique")
        def vec(b: wp.array2d(dtype=dtype), p: int, i: int):
            return b[p, i]

        @wp.func(module="unique")
        def set_vec(b: wp.array2d(dtype=dtype), p: int, i: int, v: dtype):
            b[p, i] = v
    else:
        @wp.func(module="unique")
        def mat(A: wp.array3d(dtype=dtype), p: int, i: int, j: int):
            return A[i, j, p]

        @wp.func(module="unique")
        def set_mat(A: wp.array3d(dtype=dtype), p: int, i: int, j: int, v: dtype):
            A[i, j, p] = v

        @wp.func(module="unique")
        def vec(b: wp.array2d(dtype=dtype), p: int, i: int):
            return b[i, p]

        @wp.func(module="unique")
        def set_vec(b: wp.array2d(dtype=dtype), p: int, i: int, v: dtype):
            b[i, p] = v
    return mat, set_mat, vec, set_vec


@functools.lru_cache(maxsize=None)
def lu_funcs(dtype, layout="copy_major"):
    """``lu_solve`` for ``dtype`` on blocks and vectors in ``layout`` (:func:`accessors`)."""
    mat, set_mat, vec, set_vec = accessors(dtype, layout)

    @wp.func(module="unique")
    def lu_solve(A: wp.array3d(dtype=dtype), b: wp.array2d(dtype=dtype), x: wp.array2d(dtype=dtype), p: int, n: int):
        """Solve A[p] x[p] = b[p] (copy p's leading n x n block, in the layout). A[p] and b[p] are
        overwritten by the elimination; x may be b (each x[p, i] is written after b[p, i] was read).
        Returns 0 where a pivot column is zero or not finite (x then untouched), else 1."""
        ok = int(1)
        for c in range(n):
            piv = int(c)
            best = wp.abs(mat(A, p, c, c))
            for i in range(c + 1, n):
                v = wp.abs(mat(A, p, i, c))
                if v > best:
                    best = v
                    piv = i
            # "not >" also rejects a NaN column
            if not (best > dtype(0.0)):
                ok = int(0)
            if ok != 0:
                if piv != c:
                    for j in range(n):
                        t = mat(A, p, c, j)
                        set_mat(A, p, c, j, mat(A, p, piv, j))
                        set_mat(A, p, piv, j, t)
                    t = vec(b, p, c)
                    set_vec(b, p, c, vec(b, p, piv))
                    set_vec(b, p, piv, t)
                for i in range(c + 1, n):
                    m = mat(A, p, i, c) / mat(A, p, c, c)
                    if m != dtype(0.0):
                        for j in range(c + 1, n):
                            set_mat(A, p, i, j, mat(A, p, i, j) - m * mat(A, p, c, j))
                        set_vec(b, p, i, vec(b, p, i) - m * vec(b, p, c))
        if ok != 0:
            for ii in range(n):
                i = n - 1 - ii
                s = vec(b, p, i)
                for j in range(i + 1, n):
                    s = s - mat(A, p, i, j) * vec(x, p, j)
                set_vec(x, p, i, s / mat(A, p, i, i))
        return ok

    return lu_solve
