"""Merged element row sums (warp_contacts.segment_sum) against the NumPy reference
(warp_contacts.segment_sum_ref) and the CSR assembler of the per-family path
(rvtool.contact.assembly), on every available device."""
import numpy as np
import pytest
import warp as wp

from rvtool.contact.assembly import BlockAssembler, coordinate_index
from warp_contacts import segment_sum_ref as ref
from warp_contacts.precision import resolve_device
from warp_contacts.segment_sum import ElementSums

resolve_device("cpu")  # initializes Warp
DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(
    wp.get_cuda_device_count() == 0, reason="no CUDA device"))]


def _family(rng, n_rows, m, n_bodies):
    """Rows coupling m bodies (some on the ground, index n_bodies), random forces and tangents."""
    bodies = rng.integers(0, n_bodies + 1, size=(n_rows, m))
    k = 3 * m
    q = rng.normal(size=(n_rows, k)) * 10.0 ** rng.uniform(-3, 4, size=(n_rows, 1))
    dq = rng.normal(size=(n_rows, k, k)) * 1e8
    dv = rng.normal(size=(n_rows, k, k)) * 1e2
    return bodies, q, dq, dv


def _device_rows(a, device):
    return wp.array(np.ascontiguousarray(a), dtype=wp.float64, device=device)


@pytest.mark.parametrize("device", DEVICES)
def test_element_sums_match_reference_and_csr_bit_for_bit(device):
    # the kernel sums every entry's sources in the order of the reference and of the CSR product
    # (ascending flat source position, from 0.0), so all three give the same bits: any index or
    # order error shows as a difference of at least one rounding of a 1e8-sized entry
    rng = np.random.default_rng(7)
    nb = 4
    n = 3 * nb
    fams = [_family(rng, 80, 2, nb), _family(rng, 12, 2, nb), _family(rng, 30, 3, nb)]
    withs = [True, True, False]
    index = [coordinate_index(b, nb) for b, *_ in fams]
    rows = [(_device_rows(q, device), _device_rows(dq, device), _device_rows(dv, device) if w else None)
            for (_, q, dq, dv), w in zip(fams, withs)]
    sums = ElementSums([(ix, *r) for ix, r in zip(index, rows)], n)
    for f in range(3):
        sums.add(f, f == 0, withs[f])
    Q, finite = sums.vector()
    assert finite
    Qr, Kq, Kv = np.zeros(n), [], []
    for (b, q, dq, dv), ix, w in zip(fams, index, withs):
        fq, fkq, fkv = ref.family_sums(q, dq, dv if w else None, ix, n)
        asm = BlockAssembler(b, nb)
        assert np.array_equal(fq, asm.vector(q)) and np.array_equal(fkq, asm.matrix(dq))
        if w:
            assert np.array_equal(fkv, asm.matrix(dv))
        Qr += fq
        Kq.append(fkq)
        Kv.append(fkv)
    assert np.array_equal(Q, Qr)
    for f_q, f_v in ((1.0, 0.0), (0.25, 3.0e3)):
        J = sums.jacobian(f_q, f_v)
        assert np.array_equal(J, ref.element_jacobian(np.array(Kq), np.array(Kv), f_q, f_v))
    # a family left to the host: its slot is not combined
    sums.set_used([True, False, True])
    J = sums.jacobian(1.0, 2.0)
    assert np.array_equal(J, ref.element_jacobian(np.array(Kq)[[0, 2]], np.array(Kv)[[0, 2]], 1.0, 2.0))


@pytest.mark.parametrize("device", DEVICES)
def test_element_sums_flag_a_nonfinite_tangent(device):
    rng = np.random.default_rng(3)
    b, q, dq, dv = _family(rng, 10, 2, 2)
    row = int(np.flatnonzero(np.all(b < 2, axis=1))[0])   # a row with both bodies free: none dropped
    dq[row, 1, 2] = np.nan
    rows = (_device_rows(q, device), _device_rows(dq, device), _device_rows(dv, device))
    sums = ElementSums([(coordinate_index(b, 2), *rows)], 6)
    sums.add(0, True, True)
    Q, finite = sums.vector()
    assert np.all(np.isfinite(Q)) and not finite and not sums.slot_finite(0)


def test_segments_list_every_kept_entry_once():
    rng = np.random.default_rng(1)
    b = rng.integers(0, 4, size=(20, 2))
    ix = coordinate_index(b, 3)
    vs, vsrc, ms, msrc = ref.segments(ix, 9)
    assert sorted(vsrc.tolist()) == np.flatnonzero(ix.reshape(-1) >= 0).tolist()
    kept = (ix[:, :, None] >= 0) & (ix[:, None, :] >= 0)
    assert sorted(msrc.tolist()) == np.flatnonzero(kept.reshape(-1)).tolist()
    assert vs[-1] == len(vsrc) and ms[-1] == len(msrc)


def test_element_sums_in_float32_hand_back_double():
    # the explicit float32 option: sums in single precision, results handed to Exudyn in double;
    # equal to the float64 sums of the float32-rounded rows to single-precision round-off
    # (N = 12 rows: ~12 eps32 relative at most)
    rng = np.random.default_rng(11)
    b, q, dq, dv = _family(rng, 12, 2, 2)
    rows32 = [wp.array(np.ascontiguousarray(a, np.float32), dtype=wp.float32, device="cpu") for a in (q, dq, dv)]
    sums = ElementSums([(coordinate_index(b, 2), *rows32)], 6)
    sums.add(0, True, True)
    Q, finite = sums.vector()
    J = sums.jacobian(1.0, 0.5)
    assert Q.dtype == np.float64 and J.dtype == np.float64 and finite
    q64, dq64, dv64 = (np.asarray(a, np.float32).astype(np.float64) for a in (q, dq, dv))
    Qr, Kq, Kv = ref.family_sums(q64, dq64, dv64, coordinate_index(b, 2), 6)
    assert np.allclose(Q, Qr, rtol=0, atol=24 * np.finfo(np.float32).eps * np.abs(q64).sum())
    Jr = ref.element_jacobian(Kq[None], Kv[None], 1.0, 0.5)
    assert np.allclose(J, Jr, rtol=0, atol=24 * np.finfo(np.float32).eps * (np.abs(dq64).sum() + np.abs(dv64).sum()))


@pytest.mark.parametrize("device", DEVICES)
def test_weighted_family_sums_match_the_dense_map(device):
    # a family reaching the element through linear maps, C of the forces and D of the displacements
    # (the width slices of tilting bodies: C = T^T W A, D = T^T A): Q = C vec(q), K = sum_i C_i K_i
    # D_i^T. The reference's and the kernel's weighted segmented sums against the dense products;
    # they sum in another order than the BLAS products, so the bound is some roundings of the largest
    # term (|C|, |D| <= 1, entries up to ~1e9: 50 roundings relative to the largest entry)
    from scipy import sparse
    rng = np.random.default_rng(11)
    nb, n_rows, n = 3, 20, 14
    bodies, q, dq, dv = _family(rng, n_rows, 2, nb)
    k = q.shape[1]
    ix = coordinate_index(bodies, nb)
    A = np.zeros((3 * nb, n_rows * k))          # the plain scatter of the rows into 3 nb coordinates
    keep = np.flatnonzero(ix.ravel() >= 0)
    A[ix.ravel()[keep], keep] = 1.0
    T = rng.uniform(-1, 1, size=(n, 3 * nb)) * (rng.uniform(size=(n, 3 * nb)) < 0.3)
    W = rng.uniform(0.1, 1, size=3 * nb)
    C, D = (T * W) @ A, T @ A
    Q_d = C @ q.ravel()
    K_d = sum(C[:, i * k:(i + 1) * k] @ dq[i] @ D[:, i * k:(i + 1) * k].T for i in range(n_rows))
    V_d = sum(C[:, i * k:(i + 1) * k] @ dv[i] @ D[:, i * k:(i + 1) * k].T for i in range(n_rows))
    Cs, Ds = sparse.csr_matrix(C), sparse.csr_matrix(D)
    Qr, Kqr, Kvr = ref.weighted_family_sums(q, dq, dv, Cs, Ds)
    for got, want in ((Qr, Q_d), (Kqr, K_d), (Kvr, V_d)):
        assert np.max(np.abs(got - want)) <= 50 * np.finfo(float).eps * np.max(np.abs(want))
    # C = D with unit weights reproduces the plain lists (one entry per column: a row scatter)
    plain = ref.segments(ix, 3 * nb)
    weighted = ref.weighted_segments(sparse.csr_matrix(A), k)
    for p, w in zip(plain, weighted[0:2] + weighted[3:5]):
        assert np.array_equal(p, w)
    assert np.all(weighted[2] == 1.0) and np.all(weighted[5] == 1.0)
    sums = ElementSums([((Cs, Ds), _device_rows(q, device), _device_rows(dq, device), _device_rows(dv, device))], n)
    sums.add(0, True, True)
    Q, finite = sums.vector()
    assert finite
    # the kernel sums in the reference's order: the same bits on cpu; nvcc contracts the weighted
    # multiply-adds into FMAs, so on cuda the sums differ in the last bits (seen on an H200)
    for got, want in ((Q, Qr), (-sums.jacobian(1.0, 0.0), Kqr), (sums.Kv[0].reshape(n, n), Kvr)):
        if str(device).startswith("cuda"):
            assert np.max(np.abs(got - want)) <= 8 * np.finfo(float).eps * np.max(np.abs(want))
        else:
            assert np.array_equal(got, want)
