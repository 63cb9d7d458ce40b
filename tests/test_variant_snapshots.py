"""Cycloid variants written into the nominal snapshot (rvtool.solver.variant_snapshots) against their
full builds: the same snapshot attribute for attribute, the same device figures."""
import pickle
import sys
from pathlib import Path

import numpy as np
import pytest

from rvtool import designs, load_design
from rvtool.batched.device_rows_variants import device_rows_variants
from rvtool.solver.model_snapshot import build_snapshot
from rvtool.solver.variant_snapshots import cycloid_variant_snapshots, patchable

sys.path.insert(0, str(Path(__file__).parent))
from test_model_snapshot import _differences  # noqa: E402

RD_KW = {"bearing_model": "lumped", "regularization": (1.0e4, 100.0)}   # cases/cycloid/monte_carlo_te.py's build
RD_SEED = 2026                                                          # cases/cycloid/monte_carlo_te.py


@pytest.fixture(scope="module")
def rd40():
    from rvtool.variants.tolerances import load_tolerances, sample_variant
    d = load_design(designs.path("rd40"))
    tol = load_tolerances(designs.path("rd40_tolerances"))
    return d, [sample_variant(tol, d, k, RD_SEED) for k in (0, 1, 7)]


def test_written_variants_equal_their_full_builds(rd40):
    """Every member of every contact set (rows, meshes, shared tables by key, ids), the reference
    poses, the kinematics, locks and springs of RD-40 variants 0, 1, 7 (drawn eccentricity, pin
    centres and radius, clearances, profile modifications) equal the full build's snapshot; pickled
    as a pool sends them. Fails if the builder read a variant's field somewhere not written."""
    d, vs = rd40
    assert patchable(d, RD_KW) == []
    got = [pickle.loads(pickle.dumps(s)) for s in cycloid_variant_snapshots(d, vs, RD_KW)]
    for v, lean in zip(vs, got):
        dv = v.apply(d)
        full = build_snapshot(dv, RD_KW, shared_tables=True)
        diff = []
        for ea, eb in zip(full.contact_elements(), lean.contact_elements(), strict=True):
            assert ea.ids == eb.ids
            _differences(vars(ea.evaluator), vars(eb.evaluator), ea.evaluator.name, diff)
        for k in ("body_names", "reference", "journal_locks", "reg_springs", "held_coordinates", "ratio", "build_kw",
                  "row_extension", "input", "output", "structures"):
            _differences(getattr(full, k), getattr(lean, k), k, diff)
        assert diff == []
        assert lean.design == dv and lean.design.source == dv.source      # a design to replace() further too
        np.testing.assert_array_equal(full.kinematics.poses(np.linspace(0.0, 1.0, 5)),
                                      lean.kinematics.poses(np.linspace(0.0, 1.0, 5)))


def test_written_variants_give_the_full_builds_device_figures(rd40):
    """TE and lost motion of two written variants on the device row Newton (cpu) bit for bit those of
    their full snapshots."""
    d, vs = rd40
    angles = 2 * np.pi * abs(d.ratio) * np.arange(2) / 23
    run = lambda ms: device_rows_variants(ms, torque=d.rated_torque, input_angles=angles,
                                          lost_motion_level=0.03 * d.rated_torque, device="cpu")
    a = run([build_snapshot(v.apply(d), RD_KW, shared_tables=True) for v in vs[1:]])
    b = run(cycloid_variant_snapshots(d, vs[1:], RD_KW))
    assert a.status == ["ok", "ok"]
    np.testing.assert_array_equal(a.te, b.te)
    np.testing.assert_array_equal(a.lost_motion_rad, b.lost_motion_rad)


def test_what_is_not_written_is_named_and_built_in_full(rd40):
    """Rolling-element bearings: named by patchable, the variants built in full (the same snapshots)."""
    d, vs = rd40
    kw = dict(RD_KW, bearing_model="rolling")
    assert any("bearing_model" in r for r in patchable(d, kw))
    assert not patchable(d, RD_KW)
    s = cycloid_variant_snapshots(d, vs[1:2], kw)[0]
    assert [e.evaluator.name for e in s.contact_elements()] == [
        e.evaluator.name for e in build_snapshot(vs[1].apply(d), kw, shared_tables=True).contact_elements()]


def test_stacked_cycloid_kinematics_equal_each_copys_bit_for_bit(rd40):
    """The row Newton primes the kinematic states of RD-40 variant copies (their eccentricities differ) in
    one stacked evaluation (CycloidKinematics.stacked_poses): equal to each copy's own poses at each
    angle bit for bit; kinematics with other phases are not stacked."""
    import dataclasses
    from rvtool.assembly.cycloid import CycloidKinematics
    from rvtool.solver.device_rows import DeviceRowNewton
    d, vs = rd40
    models = cycloid_variant_snapshots(d, vs, RD_KW)
    nw = DeviceRowNewton(models)
    a = np.array([0.3, 0.1, 0.7])
    got = nw.kinematic(a)
    want = np.array([(m.kinematics.poses(a[c:c + 1])[0] - m.reference).reshape(-1) for c, m in enumerate(models)])
    want[:, nw.held] = 0.0
    want[:, nw.input_local] = a
    np.testing.assert_array_equal(got, want)
    assert len({float(m.kinematics.eccentricity) for m in models}) == 3
    other = CycloidKinematics(dataclasses.replace(d, wheels=dataclasses.replace(d.wheels, phases=(0.0, 3.0))))
    assert CycloidKinematics.stacked_poses([models[0].kinematics, other], a) is None


def test_rv_variant_designs_written_in_equal_the_loaded():
    """RV-40E Monte Carlo variants made by rvtool.assembly.rv.spec.light_replace (the changed sections
    built by the loader's builders, the rest kept; multi_device.rv_variant_design after its once-per-design
    check) equal sample_rv_design's loaded designs, source included; a change outside what it writes (the
    profile, a linked pin key, a top-level key) is left to replace (None). Fails if a written-in section or
    the source differs from the loaded one."""
    from rvtool.assembly.rv.spec import light_replace
    from rvtool.variants.multi_device import rv_variant_design
    from rvtool.variants.rv_tolerances import load_rv_tolerances, rv_design_changes, sample_rv_design
    d = load_design(designs.path("rv40e"))
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    seed = 20261124                                                   # cases/rv/monte_carlo_rv.py
    for k in (0, 1, 2):
        loaded = sample_rv_design(tol, d, k, seed)[0]
        light = light_replace(d, **rv_design_changes(tol, d, k, seed)[0])
        assert light == loaded and light.source == loaded.source
        assert rv_variant_design(tol, d, k, seed) == loaded
    assert light_replace(d, profile={"offset_mod": 1e-6}) is None
    assert light_replace(d, pins={"pin_radius": 0.004}) is None
    assert light_replace(d, rated_torque=100.0) is None
