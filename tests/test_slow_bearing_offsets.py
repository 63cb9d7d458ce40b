"""Clearance offsets of rolling-element bearings (``bearing_model="rolling"``): the kernel upload
against the NumPy reference, zeros bit for bit, a uniform offset is the design's clearance."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design, replace
from rvtool.bearings.reducer import rolling_bearing_sets
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.slow.reducer_windows import loaded_start

DESIGN = load_design(designs.path("rd40"))
T = DESIGN.rated_torque


def _contacts(model, family):
    return model.observe(np.zeros(model.mbs.systemData.ODE2Size()), family).per_contact()[0]


def _states(model, n=3):
    solver = loaded_start(model, T, 0.0)
    out, prev = [solver.q.copy()], 0.0
    for k in range(1, n):
        out.append(solver.solve(k * model.mesh_period / n, prev).copy())
        prev = solver.last_angle
    return np.array(out)


@pytest.mark.parametrize("device", ["cpu", "cuda:0"])
def test_kernel_offsets_match_the_reference(device):
    if device.startswith("cuda"):
        import warp as wp
        if not wp.is_cuda_available():
            pytest.skip("no CUDA device")
    sets = {b: rolling_bearing_sets(DESIGN, 2, backend=b, device=device)["bearings"] for b in ("warp", "numpy")}
    n = len(sets["numpy"].ids)
    rng = np.random.default_rng(3)
    off = rng.uniform(-2e-6, 4e-6, n)
    pose = np.zeros((sets["numpy"].n_bodies, 3))
    pose[1:3, 0] = 3e-6          # the wheels pressed onto their needles
    out = {}
    for b, s in sets.items():
        before = np.array(s.raw(pose)[3])
        s.set_gap_offsets(off)
        out[b] = np.array(s.raw(pose)[3])
        s.set_gap_offsets(np.zeros(n))
        assert np.array_equal(np.array(s.raw(pose)[3]), before)        # zeros: the built rows, bit for bit
    assert np.allclose(out["warp"], out["numpy"], rtol=1e-12, atol=1e-9)
    assert not np.allclose(out["numpy"], before)


def test_uniform_needle_offset_is_the_design_clearance():
    c0 = DESIGN.eccentric_bearing.radial_clearance
    q_ref = _states(build(replace(DESIGN, eccentric_bearing={"radial_clearance": c0 + 2e-6}), bearing_model="rolling"))
    m = build(DESIGN, bearing_model="rolling")
    m.set_gap_offsets(Family.ECCENTRIC_BEARINGS, {c: 2e-6 for c in _contacts(m, Family.ECCENTRIC_BEARINGS)})
    assert np.allclose(_states(m), q_ref, rtol=0, atol=1e-12)
    m.set_gap_offsets(Family.ECCENTRIC_BEARINGS, {c: 0.0 for c in _contacts(m, Family.ECCENTRIC_BEARINGS)})
    assert np.array_equal(_states(m), _states(build(DESIGN, bearing_model="rolling")))
    with pytest.raises(RvtoolInputError, match="finite"):
        m.set_gap_offsets(Family.ECCENTRIC_BEARINGS, {_contacts(m, Family.ECCENTRIC_BEARINGS)[0]: np.inf})
