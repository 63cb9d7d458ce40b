"""Issue 21: per-contact figures (slices and laminae summed per physical contact)."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design
from rvtool.model import Family
from rvtool.observe import AcceptedStep, ContactPeaks, ContactSnapshot
from rvtool.solver.static import StaticSolver


@pytest.fixture(scope="module")
def rated():
    d = load_design(designs.path("rd40"))
    m = build(d, bearing_model="rolling")
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    return m, StaticSolver(m).solve(0.0)


def test_slice_sums_equal_contact_loads(rated):
    m, q = rated
    peaks = m.family_contact_peaks(q)
    for fam in m.families:
        ob = m.observe(q, fam)
        names, per_contact = ob.per_contact()
        for name, f in zip(names, per_contact):
            rows = [i for i, r in enumerate(ob.ids) if r.startswith(name + "/") or r == name]
            # a contact's load is exactly the sum of its rows (one summation order: 1e-12 relative)
            assert f == pytest.approx(ob.normal_force[rows].sum(), rel=1e-12, abs=1e-12)
        assert peaks[fam.value] == pytest.approx(per_contact.max(), rel=1e-15)
        assert peaks[fam.value] >= m.family_peaks(q)[fam.value]
    # the output pins are observed as 4 axial slices of an axially uniform contact (no tilt): the
    # per-contact peak is 4 slice loads up to the slices' small axial load variation (wheel tilt)
    n_sl = m.design.output_pins.n_slices
    ratio = peaks["output_pins"] / m.family_peaks(q)["output_pins"]
    assert 0.9 * n_sl < ratio <= n_sl + 1e-9
    # a needle roller is 4 laminae; the contact count is 16 rollers per eccentric bearing
    names, _ = m.observe(q, Family.ECCENTRIC_BEARINGS).per_contact()
    assert len(names) == m.design.n_wheels * m.design.eccentric_bearing.n_rollers


def _step(k, forces, ids):
    f = np.asarray(forces, float)
    snap = ContactSnapshot(ids=ids, normal_force=f, slip_speed=None, position=np.zeros((len(ids), 2)))
    return AcceptedStep(index=k, t_start=0.1 * k, dt=0.1, q_start=np.zeros(1), q_end=np.zeros(1),
                        snapshots={"s": snap})


def test_contact_peaks_observer_sums_rows_per_step():
    ids = ("pin0/slice0", "pin0/slice1", "pin1/slice0", "pin1/slice1")
    obs = ContactPeaks()
    obs.on_accepted(_step(0, [3.0, 1.0, 0.0, 0.0], ids))
    obs.on_accepted(_step(1, [1.0, 2.5, 2.0, 2.0], ids))
    # pin0: max(4.0, 3.5) = 4.0 although its slice peaks 3.0 and 2.5 sum to 5.5
    assert obs.peaks == {"pin0": 4.0, "pin1": 4.0}
    assert obs.peak("pin0") == 4.0 and obs.peak("gear") is None
