"""warp_contacts.tapered_planar (the tapered family's planar mapping on the device) against its
NumPy reference TaperedBearingSet.raw, per device (cuda skipped without a GPU)."""
import dataclasses

import numpy as np
import pytest
import warp as wp

import rvtool

DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]


@pytest.fixture(scope="module")
def tapered():
    m = rvtool.build(rvtool.load_design("rv40e"))
    s = next(e.evaluator for e in m.contact_elements() if type(e.evaluator).__name__ == "TaperedBearingSet")
    return m, s


@pytest.mark.parametrize("device", DEVICES)
def test_device_rows_equal_the_planar_reference(tapered, device):
    if device != "cpu" and wp.get_cuda_device_count() == 0:
        pytest.skip("no CUDA device")
    from rvtool.bearings.tapered_set import TaperedBearingSet
    m, s0 = tapered
    s = TaperedBearingSet(s0.mountings, s0.n_bodies, name=s0.name, device=device)
    ref = TaperedBearingSet(s0.mountings, s0.n_bodies, name=s0.name, backend="numpy")
    rng = np.random.default_rng(5)
    nb = s0.n_bodies
    base = np.asarray(m.reference, float).reshape(nb, 3)
    loaded = 0
    for trial in range(4):
        pose = base + rng.normal(size=(nb, 3)) * np.array([2e-5, 2e-5, 1e-3]) + np.array([0.0, 0.0, trial])
        vel = rng.normal(size=(nb, 3)) * np.array([1e-3, 1e-3, 0.5]) if trial % 2 else None
        Qr, Kr = ref.raw(pose, vel)[:2]
        Qd, Kd = (x.numpy() for x in s.device_rows(pose, vel))
        loaded += int(np.count_nonzero(np.abs(Qr) > 1.0))
        # the same sums in the same roller order; the arm products in another order (last bits)
        np.testing.assert_allclose(Qd, Qr, rtol=1e-11, atol=1e-9 * max(1.0, np.max(np.abs(Qr))))
        np.testing.assert_allclose(Kd, Kr, rtol=1e-11, atol=1e-9 * max(1.0, np.max(np.abs(Kr))))
    assert loaded > 0                                     # the rows carried load (not a comparison of zeros)



@pytest.mark.parametrize("device", DEVICES)
def test_device_velocity_rows_equal_the_planar_reference(tapered, device):
    """dQ/dv of the device rows (driven runs) against TaperedBearingSet.raw's, at moving bodies."""
    if device != "cpu" and wp.get_cuda_device_count() == 0:
        pytest.skip("no CUDA device")
    from rvtool.bearings.tapered_set import TaperedBearingSet
    m, s0 = tapered
    # rv40e's rollers carry no damping: give them some (c_d 400 N s/m, assumed) so dQ/dv is not zero
    mounts = [dataclasses.replace(mt, bearing=dataclasses.replace(
        mt.bearing, rows=tuple(dataclasses.replace(r, damping=400.0) for r in mt.bearing.rows)))
        for mt in s0.mountings]
    s = TaperedBearingSet(mounts, s0.n_bodies, name=s0.name, device=device)
    ref = TaperedBearingSet(mounts, s0.n_bodies, name=s0.name, backend="numpy")
    rng = np.random.default_rng(7)
    nb = s0.n_bodies
    base = np.asarray(m.reference, float).reshape(nb, 3)
    pose_d, vel_d = s.device_pose_buffers()
    for trial in range(3):
        pose = base + rng.normal(size=(nb, 3)) * np.array([2e-5, 2e-5, 1e-3]) + np.array([0.0, 0.0, trial])
        vel = rng.normal(size=(nb, 3)) * np.array([1e-3, 1e-3, 0.5])
        Qr, Kr, Cr = ref.raw(pose, vel)[:3]
        pose_d.assign(np.vstack([pose, np.zeros((1, 3))]))
        vel_d.assign(np.vstack([vel, np.zeros((1, 3))]))
        Qd, Kd, Cd = (x.numpy() for x in s.launch_device_velocity_rows())
        assert np.max(np.abs(Cr)) > 0.0                   # damping rows present (not zeros against zeros)
        # the same sums in the same roller order; the arm products in another order (last bits)
        np.testing.assert_allclose(Qd, Qr, rtol=1e-11, atol=1e-9 * max(1.0, np.max(np.abs(Qr))))
        np.testing.assert_allclose(Kd, Kr, rtol=1e-11, atol=1e-9 * max(1.0, np.max(np.abs(Kr))))
        np.testing.assert_allclose(Cd, Cr, rtol=1e-11, atol=1e-9 * max(1.0, np.max(np.abs(Cr))))
