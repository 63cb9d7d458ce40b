"""Snapshots of variant models built without device objects (rvtool.solver.model_snapshot.build_snapshot)
against the snapshots of the full build: the same rows, tables and members, the same device figures."""
import pickle

import numpy as np
import pytest

from rvtool import build, designs, load_design
from rvtool.solver.model_snapshot import DEVICE_ATTRIBUTES, ModelSnapshot, build_snapshot

RD_KW = {"bearing_model": "lumped", "regularization": (1.0e4, 100.0)}   # cases/cycloid/monte_carlo_te.py's build


def _variant(name, k):
    if name == "rd40":
        from rvtool.variants.tolerances import load_tolerances, sample_variant
        d = load_design(designs.path("rd40"))
        return sample_variant(load_tolerances(designs.path("rd40_tolerances")), d, k, 2026).apply(d), RD_KW
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    d = load_design(designs.path(name))
    return sample_rv_design(load_rv_tolerances(designs.path(f"{name}_tolerances")), d, k, 20261124)[0], {}


def _differences(a, b, path, out, depth=0):
    """Paths where a and b differ: arrays bit for bit (shape, dtype, values), containers and
    objects with attributes member by member, the rest by ==."""
    if depth > 12:
        return
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape or a.dtype != b.dtype or not np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"):
            out.append(path)
        return
    if type(a) is not type(b):
        out.append(f"{path} (type {type(a).__name__} / {type(b).__name__})")
        return
    if isinstance(a, (list, tuple)):
        if len(a) != len(b):
            out.append(f"{path} (length)")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            _differences(x, y, f"{path}[{i}]", out, depth + 1)
        return
    if isinstance(a, dict):
        if a.keys() != b.keys():
            out.append(f"{path} (keys {sorted(map(str, set(a) ^ set(b)))})")
        for k in a.keys() & b.keys():
            _differences(a[k], b[k], f"{path}.{k}", out, depth + 1)
        return
    if hasattr(a, "__dict__") and not callable(a):
        _differences(vars(a), vars(b), path, out, depth + 1)
        return
    if type(a).__module__.startswith("exudyn"):
        same = int(a) == int(b)         # Exudyn item indices (ObjectIndex ...) compare by identity
    else:
        try:
            same = bool(a == b)
        except (TypeError, ValueError):
            same = repr(a) == repr(b)
    if not same:
        out.append(f"{path} ({a!r} / {b!r})")


@pytest.mark.parametrize("name", ["rd40", "rv40e", "rv80e"])
def test_a_snapshot_built_without_device_objects_equals_the_full_builds(name):
    """Every member of every contact set bit for bit (the NumPy-backend build only skips the Warp
    kernels, which a snapshot drops), the backend the full build's (nested sets too: rv80e's elastic
    crank closures and their row extension), the rest of the snapshot equal; pickled as the pool
    sends it. Fails if a set's rows or tables depended on the backend."""
    d, kw = _variant(name, 3)
    full = ModelSnapshot(build(d, **kw), d, kw)
    lean = pickle.loads(pickle.dumps(build_snapshot(d, kw)))
    diff = []
    for ea, eb in zip(full.contact_elements(), lean.contact_elements(), strict=True):
        assert ea.ids == eb.ids
        assert vars(eb.evaluator).get("backend", "warp") == "warp"
        _differences(vars(ea.evaluator), vars(eb.evaluator), ea.evaluator.name, diff)
        assert all(vars(eb.evaluator).get(k) is None for k in DEVICE_ATTRIBUTES)
    for k in ("body_names", "reference", "journal_locks", "reg_springs", "held_coordinates", "ratio", "build_kw",
              "row_extension", "row_extension_reasons"):
        _differences(getattr(full, k), getattr(lean, k), k, diff)
    np.testing.assert_array_equal(full.kinematics.poses(np.linspace(0.0, 1.0, 5)),
                                  lean.kinematics.poses(np.linspace(0.0, 1.0, 5)))
    assert diff == []


def test_a_lean_snapshot_gives_the_full_snapshots_device_figures_and_a_full_fallback_model():
    """TE and lost motion of the two snapshots of one RD-40 variant on the device row Newton
    (cpu, host sums: deterministic) bit for bit; the model an Exudyn fallback builds from the lean
    snapshot is the full one (Warp kernels, the given build options)."""
    from rvtool.batched.device_rows_variants import device_rows_variants
    d, kw = _variant("rd40", 5)
    full, lean = ModelSnapshot(build(d, **kw), d, kw), build_snapshot(d, kw)
    angles = 2 * np.pi * abs(d.ratio) * np.arange(3) / 23
    run = lambda m: device_rows_variants([m], torque=d.rated_torque, input_angles=angles,
                                         lost_motion_level=0.03 * d.rated_torque, device="cpu")
    a, b = run(full), run(lean)
    assert np.all(np.isfinite(a.te)) and np.isfinite(a.lost_motion_rad[0])
    np.testing.assert_array_equal(a.te, b.te)
    np.testing.assert_array_equal(a.lost_motion_rad, b.lost_motion_rad)
    m = lean.model()
    assert lean.build_kw == kw
    assert all(e.evaluator.backend == "warp" for e in m.contact_elements())
