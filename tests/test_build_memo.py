"""The per-process memos of the set constructors (cycloid profile samples, tooth compliances,
tapered axial approaches): variant builds share them, and what they return equals a fresh
computation bit for bit."""
import numpy as np
import pytest

import rvtool
from rvtool.bearings.tapered import TaperedPair
from rvtool.contact.cycloid_set import sampled_profile
from rvtool.contact.involute_set import tooth_compliance
from rvtool.contact.tooth_stiffness import ToothCompliance
from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design


@pytest.fixture(scope="module")
def variants():
    d = rvtool.load_design("rv40e")
    tol = load_rv_tolerances(rvtool.designs.path("rv40e_tolerances"))
    return [rvtool.build(sample_rv_design(tol, d, k, 3)[0]) for k in range(2)]


def _set(model, cls):
    return next(e.evaluator for e in model.contact_elements() if type(e.evaluator).__name__ == cls)


def test_variants_share_the_sampled_profile_and_it_equals_a_fresh_sampling(variants):
    a, b = (_set(m, "CycloidPinSet") for m in variants)
    prof = a.meshes[0].profile
    n = a.samples_per_tooth * prof.n_teeth
    assert prof == b.meshes[0].profile
    shared = sampled_profile(prof, n)
    assert sampled_profile(b.meshes[0].profile, n) is shared
    for x, y in zip(shared, prof.table(n)):
        np.testing.assert_array_equal(x, y)
    arr = next(x for x in shared if isinstance(x, np.ndarray))
    with pytest.raises(ValueError):
        arr[0] = 0.0                                  # shared: read-only


def test_tooth_compliance_memo_equals_a_fresh_fit(variants):
    """Gears that differ in their single pitch deviations only share one fit, equal to each one's own."""
    g, h = (_set(m, "InvoluteContactSet").meshes[0].pair.gear_a for m in variants)
    assert g.single_pitch_deviations is not None and g.single_pitch_deviations != h.single_pitch_deviations
    assert tooth_compliance(g) is tooth_compliance(h)
    assert tooth_compliance(g) == ToothCompliance.of(g) == ToothCompliance.of(h)


def test_tapered_predisplacements_equal_the_root_search(variants):
    pair = next(m.bearing for m in _set(variants[0], "TaperedBearingSet").mountings
                if isinstance(m.bearing, TaperedPair))
    assert pair.axial_preload > 0                    # the memo is taken (preloaded pair)
    fresh = tuple(-sg * r.axial_approach_for(pair.axial_preload) for r, sg in zip(pair.rows, pair.senses))
    assert pair.axial_predisplacements == fresh
