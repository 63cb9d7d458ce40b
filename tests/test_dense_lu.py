"""warp_contacts.dense_lu.lu_solve against numpy.linalg.solve (its reference), per device."""
import numpy as np
import pytest
import warp as wp

from warp_contacts.dense_lu import lu_funcs

DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]


@pytest.fixture(scope="module")
def solve_kernel():
    lu_solve = lu_funcs(wp.float64)

    @wp.kernel(enable_backward=False, module="unique")
    def solve(A: wp.array3d(dtype=wp.float64), b: wp.array2d(dtype=wp.float64), x: wp.array2d(dtype=wp.float64),
              n: int, ok: wp.array(dtype=wp.int32)):
        p = wp.tid()
        ok[p] = lu_solve(A, b, x, p, n)

    return solve


@pytest.mark.parametrize("device", DEVICES)
def test_lu_solve_matches_numpy(solve_kernel, device):
    if device != "cpu" and wp.get_cuda_device_count() == 0:
        pytest.skip("no CUDA device")
    rng = np.random.default_rng(7)
    n, B = 17, 6
    A = rng.normal(size=(B, n, n))
    A[1] = A[1][rng.permutation(n)]                   # pivoting needed
    A[2, :, 3] = 0.0                                   # singular: a zero column -> ok 0
    A[3, 5, 5] = np.nan                                # a NaN entry -> ok 0 (the pivot test is "not > 0")
    A[4] *= 1e9                                        # scale (contact tangents are ~1e8 N/m)
    A[5] = A[5] + n * np.eye(n)                        # diagonally dominant: no row swap
    b = rng.normal(size=(B, n))
    wA, wb = wp.array(A, dtype=wp.float64, device=device), wp.array(b, dtype=wp.float64, device=device)
    wx = wp.zeros((B, n), dtype=wp.float64, device=device)
    ok = wp.zeros(B, dtype=wp.int32, device=device)
    wp.launch(solve_kernel, dim=B, inputs=[wA, wb, wx, n, ok], device=device)
    okh, x = ok.numpy(), wx.numpy()
    assert list(okh) == [1, 1, 0, 0, 1, 1]
    for p in (0, 1, 4, 5):
        ref = np.linalg.solve(A[p], b[p])
        # partial pivoting on well-conditioned random blocks: error ~ cond * eps; cond < 1e4 here
        assert np.allclose(x[p], ref, rtol=1e-10, atol=1e-10 * np.max(np.abs(ref)))
    # x aliasing b (as the fused stepper calls it)
    wA2, wb2 = wp.array(A, dtype=wp.float64, device=device), wp.array(b, dtype=wp.float64, device=device)
    wp.launch(solve_kernel, dim=B, inputs=[wA2, wb2, wb2, n, ok], device=device)
    assert np.array_equal(wb2.numpy()[[0, 1, 4, 5]], x[[0, 1, 4, 5]])
