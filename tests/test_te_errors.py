"""The position and profile error sources of the RV tolerance Monte Carlo (issue 30, Deliver 3, helper teerrors):
crank-bore position errors in the wheels and the carrier (design keys cranks.wheel_bore_errors /
cranks.carrier_bore_errors), the ring-pin seats' radial position, the ground profile's equidistant and offset
errors; each moves the variant's geometry by exactly the drawn amount, bad input names its key, and a design or a
tolerance file without them is unchanged bit for bit."""
import math

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.assembly.rv.builder import Layout, crank_mountings, needle_mountings
from rvtool.assembly.rv.gear_graph import GearGraph
from rvtool.designs.measured import load_measured
from rvtool.errors import RvtoolInputError
from rvtool.variants.rv_tolerances import RV_FIELDS, RvToleranceSpec, load_rv_tolerances, sample_rv_design
from rvtool.variants.tolerances import Normal

NEW = ("pin_radial_position_error", "wheel_bore_position_error", "carrier_bore_position_error",
       "profile_equidistant_error", "profile_offset_error")


@pytest.fixture(scope="module")
def d():
    return rvtool.load_design("rv80e")


def _mounts(design):
    g, L = GearGraph.of(design), Layout(design)
    return needle_mountings(design, g, L), crank_mountings(design, g, L)


def test_wheel_bore_error_moves_that_bore_centre_by_the_draw(d):
    dv, drawn = sample_rv_design(RvToleranceSpec(wheel_bore_position_error=Normal(std=2.5e-6)), d, 1, 2026)
    e = np.asarray(drawn["wheel_bore_position_error"])
    assert e.shape == (d.cranks.count, d.n_wheels, 2) and np.all(e != 0)
    (n0, c0), (n1, c1) = _mounts(d), _mounts(dv)
    for m0, m1 in zip(n0, n1):
        k, j = (int(x) for x in m0.name.removeprefix("eccentric_bearing_c").split("w"))
        np.testing.assert_allclose(np.subtract(m1.outer_centre, m0.outer_centre), e[k, j], rtol=1e-9, atol=1e-18)
        assert m1.inner_centre == m0.inner_centre                # the journal is the crank's, unchanged
    assert [m.outer_centre for m in c1] == [m.outer_centre for m in c0]    # the carrier seats stay


def test_carrier_bore_error_moves_that_seat_by_the_draw(d):
    dv, drawn = sample_rv_design(RvToleranceSpec(carrier_bore_position_error=Normal(std=2.5e-6)), d, 2, 2026)
    e = np.asarray(drawn["carrier_bore_position_error"])
    (n0, c0), (n1, c1) = _mounts(d), _mounts(dv)
    for k, (m0, m1) in enumerate(zip(c0, c1)):
        np.testing.assert_allclose(np.subtract(m1.outer_centre, m0.outer_centre), e[k], rtol=1e-9, atol=1e-18)
    assert [m.outer_centre for m in n1] == [m.outer_centre for m in n0]


def test_pin_radial_error_moves_each_pin_off_the_circle_only(d):
    dv, drawn = sample_rv_design(RvToleranceSpec(pin_radial_position_error=Normal(std=3e-6)), d, 0, 2026)
    r = np.asarray(drawn["pin_radial_position_error"])
    e = np.asarray(dv.pins.centre_errors)
    a = 2 * np.pi * np.arange(d.pins.n_pins) / d.pins.n_pins            # pin k at R (sin a, cos a)
    np.testing.assert_allclose(e[:, 0] * np.sin(a) + e[:, 1] * np.cos(a), r, rtol=1e-12, atol=1e-20)
    assert np.max(np.abs(e[:, 0] * np.cos(a) - e[:, 1] * np.sin(a))) < 1e-20        # no tangential part


def test_pin_radial_error_adds_to_the_pitch_errors(d):
    spec = load_rv_tolerances(designs.path("rv80e_tolerances"))
    both = RvToleranceSpec(pin_pitch_deviation=spec.pin_pitch_deviation,
                           pin_radial_position_error=spec.pin_radial_position_error)
    pitch = RvToleranceSpec(pin_pitch_deviation=spec.pin_pitch_deviation)
    dv, drawn = sample_rv_design(both, d, 4, 2026)
    dp, _ = sample_rv_design(pitch, d, 4, 2026)
    a = 2 * np.pi * np.arange(d.pins.n_pins) / d.pins.n_pins
    diff = np.asarray(dv.pins.centre_errors) - np.asarray(dp.pins.centre_errors)
    np.testing.assert_allclose(diff, np.asarray(drawn["pin_radial_position_error"])[:, None]
                               * np.column_stack([np.sin(a), np.cos(a)]), rtol=1e-9, atol=1e-20)


def test_profile_errors_add_to_the_design_modifications(d):
    spec = RvToleranceSpec(profile_equidistant_error=Normal(std=1.833e-6), profile_offset_error=Normal(std=1.833e-6))
    dv, drawn = sample_rv_design(spec, d, 5, 2026)
    assert dv.profile.equidistant_mod == d.profile.equidistant_mod + drawn["profile_equidistant_error"]
    assert dv.profile.offset_mod == d.profile.offset_mod + drawn["profile_offset_error"]
    assert drawn["profile_equidistant_error"] != drawn["profile_offset_error"]


def test_new_fields_are_drawn_after_the_old_ones(d):
    """Adding the position and profile fields left the earlier fields' draws of a seed (and their design) as they
    were: every prefix of RV_FIELDS draws the same values."""
    i = RV_FIELDS.index(NEW[0])        # then the lobe pitch (helper tepitch) and the fields of test_te_coaxiality.py
    assert RV_FIELDS[i:i + len(NEW)] == NEW and RV_FIELDS[i + len(NEW)] == "wheel_lobe_pitch_deviation"
    full = load_rv_tolerances(designs.path("rv80e_tolerances"))
    assert all(getattr(full, f) is not None for f in RV_FIELDS)
    old = RvToleranceSpec(**{f: getattr(full, f) for f in RV_FIELDS[:i]})
    dv, drawn = sample_rv_design(full, d, 3, 2026)
    do, drawn_o = sample_rv_design(old, d, 3, 2026)
    for f in RV_FIELDS[:i]:
        assert np.array_equal(np.asarray(drawn[f], float), np.asarray(drawn_o[f], float)), f
    assert do.cranks.wheel_bore_errors == () and do.cranks.carrier_bore_errors == ()
    assert do.profile == d.profile


def test_absent_keys_leave_the_mountings_bit_identical(d):
    """No position errors: every bore centre is the crank-circle point as before (same float expression)."""
    assert d.cranks.wheel_bore_errors == () and d.cranks.carrier_bore_errors == ()
    g = GearGraph.of(d)
    nm, cm = _mounts(d)
    nominal = [(g.crank_radius * math.cos(b), g.crank_radius * math.sin(b)) for b in g.crank_angles]
    assert [m.outer_centre for m in cm] == nominal
    assert [m.outer_centre for m in nm] == [c for c in nominal for _ in d.wheels.phases]
    zero = d.replace(cranks={"wheel_bore_errors": [[[0.0, 0.0]] * 2] * 3, "carrier_bore_errors": [[0.0, 0.0]] * 3})
    n0, c0 = _mounts(zero)
    assert [m.outer_centre for m in n0] == [m.outer_centre for m in nm]
    assert [m.outer_centre for m in c0] == [m.outer_centre for m in cm]


@pytest.mark.parametrize("change, match", [
    ({"wheel_bore_errors": [[[0.0, 0.0]] * 2] * 2}, r"cranks\.wheel_bore_errors must have shape \(3, n_wheels, 2\)"),
    ({"wheel_bore_errors": [[[0.0, 0.0]]] * 3}, r"cranks\.wheel_bore_errors has 1 entries per crank"),
    ({"wheel_bore_errors": [[[0.0, float("nan")]] * 2] * 3}, r"cranks\.wheel_bore_errors"),
    ({"carrier_bore_errors": [[0.0, 0.0, 0.0]] * 3}, r"cranks\.carrier_bore_errors must have shape \(3, 2\)"),
    ({"carrier_bore_errors": [[0.0, float("inf")]] * 3}, r"cranks\.carrier_bore_errors"),
])
def test_bad_bore_errors_name_the_key(d, change, match):
    with pytest.raises(RvtoolInputError, match=match):
        d.replace(cranks=change)


def test_wheel_bore_errors_refused_on_ported_wheels(d):
    with pytest.raises(RvtoolInputError, match=r"cranks\.wheel_bore_errors with wheels\.body = 'ported'"):
        d.replace(cranks={"wheel_bore_errors": [[[1e-6, 0.0]] * 2] * 3}, wheels={"body": "ported"})


def test_bad_tolerance_entries_name_the_key(tmp_path):
    p = tmp_path / "t.toml"
    p.write_text('[tolerances]\nwheel_bore_position_error = { dist = "normal", std = -1.0e-6 }\n')
    with pytest.raises(RvtoolInputError, match=r"tolerances\.wheel_bore_position_error\.std"):
        load_rv_tolerances(p)
    p.write_text('[tolerances]\ncarrier_bore_position_eror = { dist = "normal", std = 1.0e-6 }\n')
    with pytest.raises(RvtoolInputError, match="carrier_bore_position_eror"):
        load_rv_tolerances(p)


def test_tolerances_commit_recorded_and_checked(tmp_path):
    m = load_measured("rv80e_measured")
    assert len(m.tolerances_commit) == 40
    text = designs.path("rv80e_measured").read_text() if hasattr(designs.path("rv80e_measured"), "read_text") \
        else open(designs.path("rv80e_measured")).read()
    p = tmp_path / "m.toml"
    p.write_text(text.replace(m.tolerances_commit, "HEAD"))
    with pytest.raises(RvtoolInputError, match="tolerances_commit"):
        load_measured(p)


def test_position_grades_follow_the_cited_it5_values(d):
    """rv80e_tolerances.toml: position tolerance t = IT5 of the locating diameter (ISO 286-1 Table 1: 15 um over
    80-120 mm, 18 um over 120-180 mm), std = t / 6 per coordinate; profile errors +-5.5 um (ISO 1328-1 class 5
    f_HaT of the wheel as a gear of module 2 R / z_b, 39 teeth), std = tol / 3."""
    import tomllib
    with open(designs.path("rv80e_tolerances"), "rb") as fh:
        t = tomllib.load(fh)["tolerances"]
    g = GearGraph.of(d)
    assert 80.0 < 2e3 * g.crank_radius <= 120.0 and 120.0 < 2e3 * d.pins.pin_circle_radius <= 180.0
    assert t["wheel_bore_position_error"]["std"] == t["carrier_bore_position_error"]["std"] == pytest.approx(15e-6 / 6)
    assert t["pin_radial_position_error"]["std"] == pytest.approx(18e-6 / 6)
    m = 2e3 * d.pins.pin_circle_radius / d.pins.n_pins
    f_h = 0.4 * m + 0.001 * m * (d.pins.n_pins - 1) + 4.0
    for k in ("profile_equidistant_error", "profile_offset_error"):
        assert 3 * t[k]["std"] * 1e6 == pytest.approx(round(f_h * 2) / 2, abs=2e-3), k
