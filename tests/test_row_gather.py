"""warp_contacts.row_gather (one copy's f, K, C gathered from several families' row buffers, no
atomics) against its NumPy reference gather_ref (segment_sum_ref's family sums) and an
independent loop scatter, per device (cuda skipped without a GPU)."""
import numpy as np
import pytest
import warp as wp

from warp_contacts.row_gather import RowGather, gather_lists, gather_ref

DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]


def _families(rng, n):
    """Three families of random rows: 6 entries per row over random coordinates of one copy
    (-1: the ground), one without dQ/dv (the plain output pins have none)."""
    out = []
    for rows, velocity in ((7, True), (40, True), (5, False)):
        loc = rng.integers(-1, n, size=(rows, 6))
        q = rng.normal(size=(rows, 6))
        dq = rng.normal(size=(rows, 6, 6))
        dv = rng.normal(size=(rows, 6, 6)) if velocity else None
        out.append((loc, q, dq, dv))
    return out


def _scatter(fams, n):
    f, K, C = np.zeros(n), np.zeros((n, n)), np.zeros((n, n))
    for loc, q, dq, dv in fams:
        for r in range(loc.shape[0]):
            for a, la in enumerate(loc[r]):
                if la < 0:
                    continue
                f[la] += q[r, a]
                for b, lb in enumerate(loc[r]):
                    if lb >= 0:
                        K[la, lb] += dq[r, a, b]
                        if dv is not None:
                            C[la, lb] += dv[r, a, b]
    return f, K, C


@pytest.mark.parametrize("device", DEVICES)
def test_gather_equals_the_reference_and_a_plain_scatter(device):
    if device != "cpu" and wp.get_cuda_device_count() == 0:
        pytest.skip("no CUDA device")
    rng = np.random.default_rng(3)
    n = 12
    fams = _families(rng, n)
    lists = [gather_lists(loc, n) for loc, *_ in fams]
    bufs = [tuple(None if x is None else wp.array(x, dtype=wp.float64, device=device) for x in (q, dq, dv))
            for _, q, dq, dv in fams]
    g = RowGather(lists, bufs, n, wp.float64, device)
    out = g.launch().numpy()
    f, K, C = out[:n], out[n:n + n * n].reshape(n, n), out[n + n * n:].reshape(n, n)
    fr, Kr, Cr = gather_ref([loc for loc, *_ in fams], [(q, dq, dv) for _, q, dq, dv in fams], n)
    # the same additions in the same (row) order per family, families added in order: equal to the
    # last bit where a family's sum is added to zero, else up to the order of the family sums
    for a, b in ((f, fr), (K, Kr), (C, Cr)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)
    # an independent scatter (loops): equal up to the order of the additions (sums of ~10 O(1) terms)
    fs, Ks, Cs = _scatter(fams, n)
    for a, b in ((f, fs), (K, Ks), (C, Cs)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    assert np.count_nonzero(C) > 0 and np.count_nonzero(K) > np.count_nonzero(C) - 1
    # the rows are read in place: new row values, a new launch, new sums (forces first, tangents after)
    bufs[0][0].assign(2.0 * fams[0][1])
    g.launch_forces()
    f2 = g.out.numpy()[:n]
    loc0 = fams[0][0]
    fr2 = fs + _scatter([(loc0, fams[0][1], 0.0 * fams[0][2], None)], n)[0]
    np.testing.assert_allclose(f2, fr2, rtol=0, atol=1e-12)
