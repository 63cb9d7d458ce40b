"""Shared profile tables of Monte Carlo variants (rvtool.contact.cycloid_set.shared_profile_tables,
build_snapshot(shared_tables=True)): variants that keep their wheel profile (RV-40E: pin radii,
clearances, phases, eccentricities drawn) share one table per wheel on the device, with the device
figures of per-variant tables; RD-40's drawn profile modifications keep a table per variant."""
import pickle

import numpy as np
import pytest

from rvtool import build, designs, load_design
from rvtool.batched.device_rows_variants import device_rows_variants
from rvtool.contact.cycloid_set import CycloidPinSet, ProfileTable, shared_profile_tables
from rvtool.errors import RvtoolInputError
from rvtool.solver.device_rows import DeviceRowNewton
from rvtool.solver.model_snapshot import build_snapshot
from rvtool.units import ARCSEC_PER_RAD

RV_SEED = 20261124                                                      # cases/rv/monte_carlo_rv.py
RD_SEED = 2026                                                          # cases/cycloid/monte_carlo_te.py
RD_KW = {"bearing_model": "lumped", "regularization": (1.0e4, 100.0)}   # cases/cycloid/monte_carlo_te.py's build


def _cuda_absent(device):
    import warp as wp
    return device.startswith("cuda") and wp.get_cuda_device_count() == 0


@pytest.fixture(scope="module")
def rv40e():
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    d = load_design(designs.path("rv40e"))
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    return d, [sample_rv_design(tol, d, k, RV_SEED)[0] for k in (1, 2, 3)]


@pytest.fixture(scope="module")
def rd40():
    from rvtool.variants.tolerances import load_tolerances, sample_variant
    d = load_design(designs.path("rd40"))
    tol = load_tolerances(designs.path("rd40_tolerances"))
    # profiles no other test builds (a process that used a table for two sets pickles its key): the drawn
    # equidistant modification moved by a nanometre
    import dataclasses
    return d, [dataclasses.replace(v, equidistant_mod=v.equidistant_mod + 1.234e-9).apply(d)
               for v in (sample_variant(tol, d, k, RD_SEED) for k in (4, 6))]


def _pins(model):
    return next(e.evaluator for e in model.contact_elements() if isinstance(e.evaluator, CycloidPinSet))


def _run(models, d, angles, device):
    return device_rows_variants(models, torque=d.rated_torque, input_angles=angles,
                                lost_motion_level=0.03 * d.rated_torque, device=device)


@pytest.mark.parametrize("device", [pytest.param(d, id=d) for d in ("cpu", "cuda:0")])
def test_rv40e_variants_share_one_table_per_wheel_with_the_figures_of_their_own_tables(rv40e, device):
    """Three RV-40E variants (different pin radii): the device copies hold 2 tables (one per wheel)
    instead of 6, the pickled snapshot carries the tables' keys (smaller by more than the 2 x ~260 kB
    tables), and TE and lost motion equal the per-variant tables' (the same nearest samples): bit for
    bit on cpu; on cuda, whose atomic row sums vary in order between any two runs, to 1e-9 arcsec and
    1e-9 relative. Fails if a shared table moved a contact."""
    if _cuda_absent(device):
        pytest.skip("no CUDA device")
    d, ds = rv40e
    assert len({float(_pins(build_snapshot(x)).meshes[0].pin_radius) for x in ds}) == 3
    own = [build_snapshot(x) for x in ds]
    build_snapshot(d, shared_tables=True)                          # the nominal build first, as a warmed worker
    shared = [build_snapshot(x, shared_tables=True) for x in ds]
    assert len(pickle.dumps(shared[0])) < len(pickle.dumps(own[0])) - 400e3
    shared = [pickle.loads(pickle.dumps(s)) for s in shared]      # as the build pool sends them
    rows = [DeviceRowNewton(m, device=device) for m in (own, shared)]
    tables = [len(next(f.set for f in r.families if isinstance(f.set, CycloidPinSet)).tables) for r in rows]
    assert tables == [6, 2]
    angles = np.array([0.0, 0.7])
    a, b = _run(own, d, angles, device), _run(shared, d, angles, device)
    assert a.status == b.status == ["ok"] * 3
    if device == "cpu":             # host sums: deterministic, the same nearest samples give the same figures
        np.testing.assert_array_equal(b.te, a.te)
        np.testing.assert_array_equal(b.lost_motion_rad, a.lost_motion_rad)
    else:                           # atomic row sums vary in order: rounding of the angles (~1e-16 rad)
        assert np.max(np.abs(b.te - a.te)) * ARCSEC_PER_RAD <= 1e-9
        np.testing.assert_allclose(b.lost_motion_rad, a.lost_motion_rad, rtol=1e-9)


def test_rv40e_shared_tables_against_the_exudyn_oracle(rv40e):
    """Two variants' TE with shared tables (cpu) against Exudyn's quasi-static TE on the variants'
    own full builds: equal to 1e-6 arcsec (issue 31)."""
    from rvtool.protocols.precision import quasi_static_te
    d, ds = rv40e
    angles = np.array([0.0, 0.7])
    r = _run([build_snapshot(x, shared_tables=True) for x in ds[:2]], d, angles, "cpu")
    for c, x in enumerate(ds[:2]):
        ref = quasi_static_te(build(x), torque=d.rated_torque, input_angles=angles, backend="exudyn")["te"]
        assert np.max(np.abs(r.te[c] - ref)) * ARCSEC_PER_RAD <= 1e-6


def test_rd40_drawn_profiles_keep_their_tables_and_figures(rd40):
    """RD-40 variants draw profile modifications: a table per variant and wheel stays (pickled with
    its arrays, 4 on the device for 2 variants) and the figures equal the full snapshots' bit for bit (cpu)."""
    d, ds = rd40
    own = [build_snapshot(x, RD_KW) for x in ds]
    shared = [pickle.loads(pickle.dumps(build_snapshot(x, RD_KW, shared_tables=True))) for x in ds]
    assert all(isinstance(t, ProfileTable) and t._arrays is not None for s in shared for t in _pins(s).tables)
    angles = 2 * np.pi * abs(d.ratio) * np.arange(2) / 23
    a, b = _run(own, d, angles, "cpu"), _run(shared, d, angles, "cpu")
    assert len(next(f.set for f in DeviceRowNewton(shared).families if isinstance(f.set, CycloidPinSet)).tables) == 4
    np.testing.assert_array_equal(b.te, a.te)
    np.testing.assert_array_equal(b.lost_motion_rad, a.lost_motion_rad)


def test_a_pin_radius_beyond_the_slack_gets_its_own_table_and_the_shared_window_covers_the_slack(rv40e):
    """Inside the context a mesh within the slack takes the shared table, whose window is at least the
    own table's; a pin radius 2 % off the generating radius (slack 1 %) builds its own table; a slack
    outside [0, 0.1] is refused by name."""
    import dataclasses
    d, ds = rv40e
    m = _pins(build(d, backend="numpy")).meshes[0]
    own = CycloidPinSet([m], 16, backend="numpy", search=d.wheels.search)
    with shared_profile_tables():
        near = CycloidPinSet([m], 16, backend="numpy", search=d.wheels.search)
        far = CycloidPinSet([dataclasses.replace(m, pin_radius=1.02 * m.profile.pin_radius)], 16, backend="numpy",
                            search=d.wheels.search)
    assert isinstance(near.tables[0], ProfileTable) and not isinstance(far.tables[0], ProfileTable)
    assert near.table_windows[0] >= own.table_windows[0]
    np.testing.assert_array_equal(near.tables[0][0], own.tables[0][0])      # the same sampled points
    with pytest.raises(RvtoolInputError, match="slack"):
        with shared_profile_tables(0.5):
            pass


def test_copied_circle_pairs_equal_the_moved_contacts_packed(rd40):
    """The circle-pair copier (RD-40's lumped bearings) moves the built rows' body columns instead of
    packing the moved contacts again: the same rows, bodies and ids as packing the renamed, shifted
    contacts."""
    import dataclasses
    from rvtool.contact.circle_set import GROUND, CircleContactSet
    from rvtool.contact.evaluator import ContactSetEvaluator
    from rvtool.solver.replica import COPIERS
    d, ds = rd40
    sets = [next(e.evaluator for e in build_snapshot(x, RD_KW).contact_elements()
                 if isinstance(e.evaluator, ContactSetEvaluator)) for x in ds]
    nb = sets[0].n_bodies
    got = COPIERS[ContactSetEvaluator](sets, nb, "float64", "cpu")
    sh = lambda b, c: b if b == GROUND else b + c * nb
    ref = CircleContactSet(name=sets[0].name, n_bodies=2 * nb, contacts=tuple(
        dataclasses.replace(ct, name=f"copy{c}_{ct.name}", body_a=sh(ct.body_a, c), body_b=sh(ct.body_b, c))
        for c, s in enumerate(sets) for ct in s.set.contacts))
    fp, ip = ref.packed()
    np.testing.assert_array_equal(got.fparams, fp)
    np.testing.assert_array_equal(got.iparams, ip)
    assert got.iparams.dtype == ip.dtype and got.ids == ref.ids and got.set.contacts == ref.contacts


def test_the_wheels_of_a_variant_share_a_window_that_covers_each_wheels_own(rd40):
    """RD-40's two wheels differ in their rotation only: inside the context the second wheel takes the
    first one's search window (no second window search), which is at least the window its own turned
    table gives with the widened band (so its nearest samples are found as with its own window); the
    tables themselves stay each wheel's own (bit for bit)."""
    from rvtool.contact.cycloid_set import PIN_RADIUS_SLACK, auto_window, pin_curve_table
    d, ds = rd40
    for x in ds:
        s = _pins(build_snapshot(x, RD_KW, shared_tables=True))
        assert s.table_windows[0] == s.table_windows[1]
        for t, tab in enumerate(s.tables):
            prof = s.meshes[t].profile
            for a, b in zip(tab, pin_curve_table(prof.table(s.samples_per_tooth * prof.n_teeth), prof.pin_radius)):
                np.testing.assert_array_equal(a, b)
            band = s.search_band + PIN_RADIUS_SLACK * (1.0 + s.search_band)
            assert s.table_windows[t] >= auto_window(prof, tab, prof.pin_radius, band=band)


@pytest.mark.parametrize("device", ["cpu", "cuda:0"])
def test_deferred_tables_computed_on_the_device(device):
    """RD-40 variants (each draws its wheel profile: a table per wheel) built with deferred tables
    (variant_snapshots(defer_tables=True)): the snapshot carries the profiles, not the tables (< 64 kB
    instead of ~548 kB); the tables computed by warp_contacts.profile_tables on ``device`` equal the
    host's (on cpu the points, normals, generating angles and spacing bit for bit, curvature and key to
    1e-14 relative: Warp's own atan2 and a contracted product, measured ~1 ulp; cuda's sine and cosine
    differ from the host's, so there to 1e-11, the curvature 1e-10), with the host's search windows; TE and lost motion of the
    device row Newton on them equal those of the host tables within 1e-9 arcsec / arcmin (the Newton
    iterates of equal rows to rounding; measured 1.8e-10 arcsec and 3e-13 arcmin). A deferred table left
    unprovided is computed by the host where read: then bit for bit. Fails if a device table moved a
    sample or a contact."""
    if _cuda_absent(device):
        pytest.skip("no CUDA device")
    from rvtool.contact.cycloid_set import _shared_entry, compute_profile_tables
    from rvtool.solver.device_rows import provide_profile_tables
    from rvtool.variants import VariantProtocol
    from rvtool.variants.multi_device import variant_snapshots
    from rvtool.variants.tolerances import load_tolerances
    d = load_design(designs.path("rd40"))
    tol = load_tolerances(designs.path("rd40_tolerances"))
    # Variants of their own per device: a profile key pickled once in this process is sent without its
    # arrays the next time (ProfileTable.__reduce__), so the cuda case must not reuse the cpu case's keys
    # (measured on the GPU host: the full snapshot came out 37 kB after the cpu case had run).
    jobs = [(d, tol, RD_SEED, k, RD_KW) for k in ((11, 12) if device == "cpu" else (13, 14))]
    full = [m for _, m, _ in variant_snapshots(jobs)]
    full_kb = len(pickle.dumps(full[0]))                  # before the same keys are used again here
    blobs = [pickle.dumps(m) for _, m, _ in variant_snapshots(jobs, defer_tables=True)]
    assert max(len(b) for b in blobs) < 64e3 < 400e3 < full_kb
    deferred, lazy = [pickle.loads(b) for b in blobs], [pickle.loads(b) for b in blobs]
    tabs = [t for m in deferred for t in _pins(m).tables]
    assert len(tabs) == 4 and not any(t.computed for t in tabs)
    assert provide_profile_tables(deferred, device) == 4 and all(t.computed for t in tabs)
    tol_rel = 1e-14
    for t in tabs:
        host, _, window = _shared_entry(*t.key)
        dev = t.entry[0]
        for i, name in enumerate(("points", "normals", "curvature", "key", "spacing", "phi")):
            a, b = np.asarray(dev[i]), np.asarray(host[i])
            if device == "cpu" and name in ("points", "normals", "spacing", "phi"):
                assert np.array_equal(a, b), name
            else:
                # cuda's sine/cosine differ from the host's by ulps, amplified by the profile's Z-fold argument and
                # by the normalisation of r' (measured on the H200 at b67a607: normals 1.09e-12, curvature -- the
                # second derivative over |r'|^3 -- 4.6e-12 relative), so 1e-11 / 1e-10 there: still 1e5 below
                # a moved sample or contact.
                bound = tol_rel if device == "cpu" else (1e-10 if name == "curvature" else 1e-11)
                assert np.max(np.abs(a - b)) <= bound * np.max(np.abs(b)), name
        assert t.window == window
    assert compute_profile_tables(tabs, device) == 0                      # computed once
    protocol = VariantProtocol(n_te_points=5)
    angles, tq = protocol.input_angles(d), protocol.te_torque_fraction * d.rated_torque
    run = lambda ms, dev: device_rows_variants(ms, torque=tq, input_angles=angles, device=dev,
                                               lost_motion_level=0.03 * d.rated_torque)
    ref, dev_run = run(full, "cpu"), run(deferred, device)
    assert ref.status == dev_run.status == ["ok", "ok"]
    assert np.max(np.abs(ref.te - dev_run.te)) * ARCSEC_PER_RAD <= 1e-9
    assert np.max(np.abs(ref.lost_motion_rad - dev_run.lost_motion_rad)) * ARCSEC_PER_RAD / 60 <= 1e-9
    if device == "cpu":
        host = run(lazy, "cpu")                   # nothing provided: the host computes them where read
        assert np.array_equal(host.te, ref.te) and np.array_equal(host.lost_motion_rad, ref.lost_motion_rad)


@pytest.mark.parametrize("device", ["cpu", "cuda:0"])
def test_device_tables_are_read_in_place_with_the_figures_of_host_tables(device):
    """Deferred RD-40 tables computed on ``device`` in one batch (provide_profile_tables, launched without
    waiting: each table settles at its first read, the stages' times reported then) are read by the
    row Newton's cycloid kernel where they lie: the copies' kernel and a compacted subset's (subset())
    address the batch's rows in place ("device_batch_view": no copy on the device, no read-back to the
    host; a subset asked for again is the one kept), and TE, lost motion and a subset's equilibria are bit for
    bit those of the same numbers uploaded from the host (a second batch of the same profiles read back and
    provided as host arrays: the kernel's "host" path). Host sums on both (device_sum=False: the atomic order
    of device sums is not part of the tables' path). Fails if a table were copied, read back, or read at another row."""
    if _cuda_absent(device):
        pytest.skip("no CUDA device")
    from rvtool.solver.device_rows import provide_profile_tables
    from rvtool.variants import VariantProtocol
    from rvtool.variants.multi_device import variant_snapshots
    from rvtool.variants.tolerances import load_tolerances
    d = load_design(designs.path("rd40"))
    tol = load_tolerances(designs.path("rd40_tolerances"))
    jobs = [(d, tol, RD_SEED, k, RD_KW) for k in ((21, 22) if device == "cpu" else (23, 24))]
    blobs = [pickle.dumps(m) for _, m, _ in variant_snapshots(jobs, defer_tables=True)]
    on_dev, other, on_host = ([pickle.loads(b) for b in blobs] for _ in range(3))
    stages = {}
    # launched without waiting (as DeviceRowNewton does): the tables settle where first read
    assert provide_profile_tables(on_dev, device, timing=stages, wait=False) == 4
    assert provide_profile_tables(other, device) == 4
    for a, b in zip((t for m in other for t in _pins(m).tables), (t for m in on_host for t in _pins(m).tables)):
        b.provide(tuple(a), a.window)                   # the same numbers, as host arrays (a read back)
    protocol = VariantProtocol(n_te_points=3)
    angles, tq = protocol.input_angles(d), protocol.te_torque_fraction * d.rated_torque
    newton = {nm: DeviceRowNewton(ms, device=device, device_sum=False) for nm, ms in (("dev", on_dev),
                                                                                      ("host", on_host))}
    assert _pins_of(newton["dev"]).table_source == "device_batch_view"
    assert _pins_of(newton["host"]).table_source == "host"
    assert set(stages) == {"upload", "dense_lengths", "arc_lengths", "resampled", "keyed", "window_offsets", "read"}
    assert all(v >= 0.0 for v in stages.values())
    got = {nm: device_rows_variants(ms, torque=tq, input_angles=angles, device=device, device_sum=False,
                                    lost_motion_level=0.03 * d.rated_torque) for nm, ms in (("dev", on_dev),
                                                                                           ("host", on_host))}
    assert got["dev"].status == got["host"].status == ["ok", "ok"]
    assert np.array_equal(got["dev"].te, got["host"].te)
    assert np.array_equal(got["dev"].lost_motion_rad, got["host"].lost_motion_rad)
    sub = {nm: nw.subset([1]) for nm, nw in newton.items()}
    assert _pins_of(sub["dev"]).table_source == "device_batch_view"
    r = {nm: s.solve(angles[1:2], [tq]) for nm, s in sub.items()}
    assert np.array_equal(r["dev"].q, r["host"].q) and r["dev"].converged.all()
    assert not any(t.read_back for m in on_dev for t in _pins(m).tables)   # nothing came back to the host
    # a subset of the same copies is kept and given again (SUBSETS_KEPT), another is made anew
    assert newton["dev"].subset([1]) is sub["dev"] and newton["dev"].subset([0]) is not sub["dev"]


def _pins_of(newton):
    return next(f.set for f in newton.families if isinstance(f.set, CycloidPinSet))
