"""TE against a published measurement (issue 30, Deliver 3): the measurement file and its loader, the pin-seat
pitch deviations of the RV tolerance sampler, the cited tolerance grades of rv80e_tolerances.toml, and the TE row
of ``rvtool validate`` (rvtool.analysis.validate_te)."""
import math
import tomllib

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.analysis import validate_te as VT
from rvtool.designs.measured import load_measured
from rvtool.errors import RvtoolInputError
from rvtool.units import ARCSEC_PER_RAD
from rvtool.variants.rv_tolerances import RV_FIELDS, RvToleranceSpec, load_rv_tolerances, pin_pitch_centre_errors, \
    sample_rv_design

MEASURED = """format_version = 2
design = "rv80e"
[source]
title = "t"
authors = "a"
reference = "r"
status = "{status}"
{read_through}
[[transmission_error]]
specimen = "p1"
low = {low}
high = 30.0
unit = "arcsec"
conditions = "c"
"""


def _write(tmp_path, **kw):
    args = {"status": "read", "read_through": "", "low": -30.0}
    args.update(kw)
    p = tmp_path / "m.toml"
    p.write_text(MEASURED.format(**args))
    return p


def test_shipped_measurement_file_loads_in_si():
    m = load_measured("rv80e_measured")
    assert m.design == "rv80e" and m.source.status == "transcribed" and "104384" in m.source.reference
    pp = [t.peak_to_peak * ARCSEC_PER_RAD for t in m.transmission_error]
    # the transcribed ranges [-29.68, 30.39] and [-31.51, 33.13] arcsec
    assert pp == pytest.approx([60.07, 64.64], rel=1e-12)
    assert m.transmission_error[0].model_low * ARCSEC_PER_RAD == pytest.approx(-28.83, rel=1e-12)


def test_measurement_file_kind_and_companion():
    assert designs.kind("rv80e_measured") == "measured"
    assert "rv80e_measured" not in designs.design_names()
    assert designs.measured_of("rv80e") == "rv80e_measured" and designs.measured_of("rv40e") is None


@pytest.mark.parametrize("kw, match", [
    ({"status": "guessed"}, "source.status"),
    ({"status": "transcribed"}, "source.read_through"),
    ({"low": 31.0}, r"transmission_error\[0\].high"),
])
def test_bad_measurement_file_names_the_key(tmp_path, kw, match):
    with pytest.raises(RvtoolInputError, match=match):
        load_measured(_write(tmp_path, **kw))


def test_good_synthetic_measurement_file(tmp_path):
    m = load_measured(_write(tmp_path, status="transcribed", read_through='read_through = "somewhere"'))
    assert m.transmission_error[0].peak_to_peak == pytest.approx(60.0 / ARCSEC_PER_RAD, rel=1e-12)


def test_te_window_pairs_every_sun_and_crank_gear_tooth():
    d = rvtool.load_design("rv80e")
    assert VT.te_window(d) == 19       # lcm(10, 38) / 10


def test_pin_pitch_centre_errors_are_tangential_accumulated_pitch():
    d = rvtool.load_design("rv80e")
    z = d.pins.n_pins
    f = np.zeros(z)
    f[5], f[6] = 1e-6, -1e-6                  # pin 5's seat 1 um late, the next pitch 1 um short: pin 5 alone moves
    e = np.asarray(pin_pitch_centre_errors(d.pins, f))
    s = np.cumsum(f) - np.mean(np.cumsum(f))
    a = 2 * np.pi * np.arange(z) / z
    assert e.shape == (z, 2)
    np.testing.assert_allclose(e, s[:, None] * np.column_stack([np.cos(a), -np.sin(a)]), rtol=0, atol=1e-18)
    # tangential: no radial component (pin k at R (sin a, cos a))
    radial = e[:, 0] * np.sin(a) + e[:, 1] * np.cos(a)
    assert np.max(np.abs(radial)) < 1e-20
    assert np.argmax(np.hypot(*e.T)) == 5
    with pytest.raises(RvtoolInputError, match="shape"):
        pin_pitch_centre_errors(d.pins, f[:-1])


def test_pin_pitch_field_is_drawn_after_the_earlier_fields_and_leaves_their_draws():
    d = rvtool.load_design("rv80e")
    full = load_rv_tolerances(designs.path("rv80e_tolerances"))
    i = RV_FIELDS.index("pin_pitch_deviation")
    assert i == 6 and full.pin_pitch_deviation is not None      # the fields after it: tests/test_te_errors.py
    full = RvToleranceSpec(**{f: getattr(full, f) for f in RV_FIELDS[:i + 1]})
    without = RvToleranceSpec(**{f: getattr(full, f) for f in RV_FIELDS[:i]})
    dv, drawn = sample_rv_design(full, d, 3, 2026)
    dw, drawn_w = sample_rv_design(without, d, 3, 2026)
    for f in RV_FIELDS[:i]:
        assert np.array_equal(np.asarray(drawn[f], float), np.asarray(drawn_w[f], float)), f
    assert dw.pins.centre_errors is None and np.asarray(dv.pins.centre_errors).shape == (d.pins.n_pins, 2)
    assert abs(sum(drawn["pin_pitch_deviation"])) < 1e-18             # the deviations close the circle


def _iso1328_fpt(d_mm, m_mm):
    """ISO 1328-1:2013 single pitch tolerance of class 5 [um], rounded as the standard (0.5 um between 5 and 10)."""
    v = 0.001 * d_mm + 0.4 * m_mm + 5.0
    return round(v * 2) / 2


def test_rv80e_tolerance_grades_follow_the_cited_formulas():
    """The pitch tolerances of rv80e_tolerances.toml are the ISO 1328-1:2013 class-5 values of each gear's size
    (3 sigma), the pin radius range the h4 (IT4 = 4 um at 6-10 mm, ISO 286-1) half on the radius."""
    d = rvtool.load_design("rv80e")
    with open(designs.path("rv80e_tolerances"), "rb") as fh:
        t = tomllib.load(fh)["tolerances"]
    m = d.sun_gear.module * 1e3
    cases = {"sun_pitch_deviation": (m * d.sun_gear.n_teeth, m),
             "crank_gear_pitch_deviation": (m * d.crank_gear.n_teeth, m),
             "pin_pitch_deviation": (2e3 * d.pins.pin_circle_radius, 2e3 * d.pins.pin_circle_radius / d.pins.n_pins)}
    for key, (dia, mod) in cases.items():
        assert 3 * t[key]["std"] * 1e6 == pytest.approx(_iso1328_fpt(dia, mod), abs=2e-3), key   # std written to 4 digits
    assert t["pin_radius_error"]["low"] == -0.5 * 4e-6 and t["pin_radius_error"]["high"] == 0.0
    assert 2e3 * d.pins.pin_radius == pytest.approx(8.0) and 6.0 < 2e3 * d.pins.pin_radius <= 10.0


class _Measured:
    def __init__(self, status="read"):
        from rvtool.designs.measured import MeasuredSource, MeasuredTE
        self.source = MeasuredSource(title="t", authors="a", reference="r", status=status, read_through="x")
        self.transmission_error = (MeasuredTE(specimen="p", low=-30 / ARCSEC_PER_RAD, high=30 / ARCSEC_PER_RAD,
                                              unit="arcsec", low_printed=-30.0, high_printed=30.0, conditions="c"),)


@pytest.mark.parametrize("band, where", [((50.0, 70.0), "inside"), ((5.0, 12.0), "above"), ((61.0, 90.0), "below")])
def test_te_row_verdict(band, where):
    dist = {"n": 3, "min": band[0], "p5": band[0], "median": sum(band) / 2, "p95": band[1], "max": band[1]}
    (r,) = VT.te_rows(_Measured(), dist, "note")
    assert r["catalogue"] == pytest.approx(60.0) and r["kind"] == "measured" and r["band"] == list(band)
    assert f"measured {where} the predicted band" in r["verdict"]
    assert r["ratio"] == pytest.approx(sum(band) / 2 / 60.0)
    (t,) = VT.te_rows(_Measured("transcribed"), dist, "note")
    assert "transcription" in t["verdict"]
    (w,) = VT.te_rows(_Measured(), dist, "note", over=VT.WINDOW_TEXT.format(n=19))      # the row names its window
    assert w["conditions"].startswith(r["conditions"]) and w["conditions"].endswith("revolution's peak-to-peak)")
    assert "19-input-revolution" in w["conditions"] and "19-input" not in r["conditions"]
    (n,) = VT.te_rows(_Measured(), None, "note")
    assert n["predicted"] is None and "not computed" in n["verdict"]


def test_te_distribution_skips_failed_variants():
    recs = [{"te_pp_rad": v / ARCSEC_PER_RAD} for v in (3.0, 1.0, 2.0)] + [{"te_pp_rad": None}]
    dist = VT.te_distribution(recs)
    assert dist["n"] == 3 and dist["min"] == pytest.approx(1.0) and dist["median"] == pytest.approx(2.0)
    assert VT.te_distribution([{"te_pp_rad": None}]) is None


def test_te_variants_run_and_the_pin_seats_move_the_te():
    """One variant of rv80e over the window at 1 point per mesh (machinery; 195 equilibria): finite, and the
    variant's TE exceeds the nominal design's (deviations of micrometres against a conjugate profile)."""
    d = rvtool.load_design("rv80e")
    res = VT.te_variants(d, designs.path("rv80e_tolerances"), n=1, points_per_mesh=1,
                         torque=VT.TE_TORQUE_FRACTION * d.rated_torque)
    (rec,) = res["records"]
    assert rec["status"] == "ok", rec["error"]
    assert math.isfinite(rec["te_pp_rad"]) and rec["te_pp_rad"] > res["nominal_pp"] > 0
    assert set(rec["deviations"]) == set(RV_FIELDS)


def test_te_comparison_needs_a_measurement_file():
    d = rvtool.load_design("rv40e")      # a tolerance file, no measurement file
    assert designs.tolerances_of("rv40e") and VT.te_comparison("rv40e", d, d.rated_torque, quick=True) is None


def test_validate_checks_count_failed_te_variants():
    from rvtool.analysis import validate as V
    out = {"central": {"torsional_rigidity": 1.0, "lost_motion": 1.0, "hysteresis_loss": 1.0, "repeat_passed": True},
           "uncertainty": None, "te_measured": {"n_failed": 1}}
    assert V.checks(out)["te_no_failed_variant"] is False
    out["te_measured"]["n_failed"] = 0
    assert V.checks(out)["te_no_failed_variant"] is True
    out["te_measured"] = None
    assert "te_no_failed_variant" not in V.checks(out)
