"""The pin circle off the output (main-bearing) axis in the cycloid tolerance Monte Carlo
(``pin_circle_coaxiality_error``, rvtool/variants/tolerances.py): one (x, y) translation of every ring-pin centre,
fixed in the housing frame, added to the per-pin ``pin_centre_errors`` and drawn after every earlier field (a
tolerance file without it draws today's variants bit for bit); its grade in rd40_tolerances.toml and in the
``rvtool new`` template (IT5 of the pin circle diameter, ISO 286-1:2010 Table 1); the TE of a one-wheel cycloid
drive with only this error against the closed form of tests/test_te_coaxiality.py (a)."""
import math
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from rvtool import designs, load_design
from rvtool.designs.tolerance_keys import CYCLOID_TOLERANCE_KEYS
from rvtool.designs.tolerance_template import iso286_it5, tolerance_template
from rvtool.variants.tolerances import FIELDS, Normal, ToleranceSpec, load_tolerances, sample_variant

KEY = "pin_circle_coaxiality_error"
SEED = 2026                                           # cases/cycloid/monte_carlo_te.py's seed


@pytest.fixture(scope="module")
def rd40():
    return load_design(designs.path("rd40"))


def _without(spec):
    return ToleranceSpec(**{f: getattr(spec, f) for f in FIELDS if f != KEY})


def _same_variant(a, b):
    for f in ("eccentricity_error", "pin_radius_error", "equidistant_mod", "offset_mod", "pin_clearance",
              "bearing_clearance"):
        assert getattr(a, f) == getattr(b, f), f
    assert np.array_equal(np.asarray(a.pin_centre_errors), np.asarray(b.pin_centre_errors))


def _activated(tmp_path):
    """rd40_tolerances.toml with its commented-out coaxiality line active (the grade it states)."""
    text = open(designs.path("rd40_tolerances")).read()
    assert text.count(f"# {KEY} = ") == 1
    p = tmp_path / "rd40_tolerances_coaxiality.toml"
    p.write_text(text.replace(f"# {KEY} = ", f"{KEY} = "))
    return p


def test_the_field_is_drawn_last_and_a_file_without_it_draws_todays_variants(rd40, tmp_path):
    """The key is the last of the draw order; the committed rd40 file with the key's lines removed loads to the spec
    of the earlier fields, whose variants are those of the full file less the offset: every other field equal bit
    for bit, and the pin-centre errors differing by one (x, y) offset common to every pin."""
    assert FIELDS[-1] == KEY and tuple(CYCLOID_TOLERANCE_KEYS)[-1] == KEY
    stripped = load_tolerances(designs.path("rd40_tolerances"))      # shipped: the key's line commented out
    full = load_tolerances(_activated(tmp_path))
    assert getattr(full, KEY) is not None and all(getattr(full, f) is not None for f in FIELDS)
    assert getattr(stripped, KEY) is None and stripped == _without(full)
    offsets = []
    for k in (0, 7, 123):
        old, new = sample_variant(stripped, rd40, k, SEED), sample_variant(full, rd40, k, SEED)
        _same_variant(old, sample_variant(_without(full), rd40, k, SEED))
        diff = np.asarray(new.pin_centre_errors) - np.asarray(old.pin_centre_errors)
        np.testing.assert_allclose(diff, np.broadcast_to(diff[0], diff.shape), rtol=0, atol=1e-20)  # rounding only
        assert np.all(np.abs(diff[0]) > 1e-12)
        _same_variant(old, new.__class__(**{**new.__dict__, "pin_centre_errors": old.pin_centre_errors}))
        offsets.append(diff[0])
    assert len({tuple(o) for o in offsets}) == 3                      # one draw per variant


def test_alone_it_translates_every_pin_by_its_two_draws(rd40):
    """A spec with only the coaxiality: pin_centre_errors = the offset on every row, the offset a seeded normal of
    the spec's std (its coordinates over 400 variants: mean within 4 standard errors of 0, std within 10 %)."""
    spec = ToleranceSpec(**{KEY: Normal(std=2.5e-6)})
    vs = [sample_variant(spec, rd40, k, SEED) for k in range(400)]
    e = np.asarray(vs[3].pin_centre_errors)
    assert e.shape == (rd40.pins.n_pins, 2) and np.array_equal(e, np.tile(e[0], (rd40.pins.n_pins, 1)))
    assert vs[3].eccentricity_error == 0.0 and vs[3].bearing_clearance is None
    o = np.array([np.asarray(v.pin_centre_errors)[0] for v in vs])
    assert np.all(np.abs(o.mean(axis=0)) < 4 * 2.5e-6 / math.sqrt(400))
    assert np.all(np.abs(o.std(axis=0) / 2.5e-6 - 1.0) < 0.10)
    assert np.array_equal(np.asarray(sample_variant(spec, rd40, 3, SEED).pin_centre_errors), e)


def test_grade_is_it5_of_the_pin_circle_in_the_file_and_the_template(rd40, tmp_path):
    """rd40_tolerances.toml and `rvtool new`'s template: t = IT5 of the pin circle diameter (100 mm: 15 um, ISO
    286-1:2010 Table 1, over 80 up to 120 mm), each coordinate normal with std t / 6."""
    with open(designs.path("rd40_tolerances"), "rb") as fh:
        assert KEY not in tomllib.load(fh)["tolerances"]             # shipped inactive (the file says why)
    with open(_activated(tmp_path), "rb") as fh:
        t = tomllib.load(fh)["tolerances"][KEY]
    assert 80.0 < 2e3 * rd40.pins.pin_circle_radius <= 120.0
    assert math.isclose(iso286_it5(2 * rd40.pins.pin_circle_radius, "pins.pin_circle_radius"), 15e-6, rel_tol=1e-12)
    assert t == {"dist": "normal", "mean": 0.0, "std": 15e-6 / 6}
    tmpl = tomllib.loads(tolerance_template(rd40))["tolerances"]
    assert tmpl[KEY] == t
    big = rd40.replace(pins={"pin_circle_radius": 0.080})          # 160 mm: over 120 up to 180 mm, IT5 = 18 um
    assert tomllib.loads(tolerance_template(big))["tolerances"][KEY]["std"] == 3e-6


# -- closed form (tests/test_te_coaxiality.py (a)) on a one-wheel cycloid drive -----------------------------------

RD_KW = {"bearing_model": "lumped", "regularization": (1.0e4, 100.0)}   # cases/cycloid/monte_carlo_te.py's build


def _te_of_offset(one, pin_centre_errors, angles, **kw):
    """TE [rad] of the one-wheel design with the variant's pin centres (and with their negatives: the difference
    over two keeps the first order in the offset and drops the nominal ripple and the even orders)."""
    from rvtool import build
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.variants import Variant
    out = []
    for sign in (1.0, -1.0):
        dv = Variant(pin_centre_errors=sign * np.asarray(pin_centre_errors)).apply(one)
        r = quasi_static_te(build(dv, **kw), torque=0.5 * one.rated_torque, input_angles=angles)
        out.append(np.asarray(r["te"]))
    return (out[0] - out[1]) / 2


def _fit(chis, y, eps):
    """(c_t, c_r, residual / signal): y ~ c_t (eps . u_t) + c_r (eps . u) + c_0, u = (-sin chi, cos chi) the
    eccentric's direction at input angle chi (rvtool.geometry.eccentric.journal_centre), u_t = (cos chi, sin chi)."""
    u = np.column_stack([-np.sin(chis), np.cos(chis)])
    ut = np.column_stack([np.cos(chis), np.sin(chis)])
    A = np.column_stack([ut @ eps, u @ eps, np.ones_like(chis)])
    c = np.linalg.lstsq(A, y, rcond=None)[0]
    return c[0], c[1], float(np.std(y - A @ c) / np.std(y))


def test_one_wheel_te_of_a_coaxiality_variant_is_the_closed_form(rd40):
    """Variant 3 drawn with only ``pin_circle_coaxiality_error`` (std 2.5 um, rd40's grade; this draw |eps| =
    0.35 um) on RD-40 with one wheel, TE at half the rated torque at 16 input angles over one input revolution.
    With the wheel held on its journal and the shaft and flange on the axis (``rigid_supports``: the rigid-body
    idealisation of the closed form) the TE's first harmonic is tests/test_te_coaxiality.py's closed form (a): the
    tangential part eps . u_t turns the wheel by (eps . u_t) / (e z_w), exact at first order (bound 1 %; measured
    1.0009), the radial part by C_r (eps . u) / (e z_w), C_r the continuum's lever-arm-weighted radial coefficient
    with every pin of positive lever arm loaded (bound 10 %: 40 discrete pins against the continuum; measured 0.280
    against 0.299 at rd40's K1 = 0.64), so the amplitude is |eps| / (e z_w) sqrt(1 + C_r^2) (bound 2 %; 2.33 arcsec
    x 1.044, measured 2.43 arcsec). The radial part's C_r is a small-offset figure: at variant 11's |eps| = 3.3 um
    the shift changes the set of loaded pins and the measured coefficient is 0.10 (the tangential one still 1.0004).

    On the Monte Carlo's build (compliant eccentric, shaft and flange bearings) the pins centre the wheel instead:
    it follows the radial part (measured 0.97 of it at two crank angles), and the output-pin mechanism, whose
    hole-pin offset grows by that much along the pins' common contact normal, turns the flange by (eps . u) / R_w
    times sum(s) / sum(s^2) over the loaded output pins' lever-arm sines s (1 for one pin at full lever arm,
    1.21 .. 1.31 for 8 pins with half of them loaded; R_w = 32 mm against e z_w = 31.2 mm): a radial coefficient
    of about 1 instead of C_r. Measured: tangential 1.05 (the loaded wheel sits 28 um off its journal, so that the
    fit's u_t is not quite the loaded crank direction), radial / tangential 0.91, amplitude 1.42 times
    |eps| / (e z_w) (3.31 arcsec here; 1.42 at variant 11 too). Asserted: 1.3 .. 1.7 times |eps| / (e z_w), a
    radial coefficient of 0.83 .. 1.37 (0.975 x [0.97 .. 1.31] less the wheel's own turn, measured 0.035): fails
    if the radial part stopped reaching the flange or the tangential part were lost."""
    sys.path.insert(0, str(Path(__file__).parent))
    from test_te_coaxiality import radial_coefficient
    one = rd40.replace(n_wheels=1, wheels={"midplanes": (0.0,), "phases_deg": (0.0,)})
    v = sample_variant(ToleranceSpec(**{KEY: Normal(std=2.5e-6)}), one, 3, SEED)
    eps = np.asarray(v.pin_centre_errors)[0]
    e, zw = one.wheels.eccentricity, one.pins.n_pins - 1
    cr_closed = radial_coefficient(e * one.pins.n_pins / one.pins.pin_circle_radius)
    chis = 2 * np.pi * np.arange(16) / 16

    ct, cr, res = _fit(chis, _te_of_offset(one, v.pin_centre_errors, chis, rigid_supports=True, **RD_KW), eps)
    assert abs(abs(ct) * e * zw - 1.0) < 0.01, ct * e * zw
    assert abs(abs(cr / ct) / cr_closed - 1.0) < 0.10, (cr / ct, cr_closed)
    assert abs(math.hypot(ct, cr) * e * zw / math.hypot(1.0, cr_closed) - 1.0) < 0.02
    assert res < 0.02, res

    ct, cr, res = _fit(chis, _te_of_offset(one, v.pin_centre_errors, chis, **RD_KW), eps)
    assert 1.3 < math.hypot(ct, cr) * e * zw < 1.7, (ct * e * zw, cr * e * zw)
    assert res < 0.05, res


def test_device_rows_take_a_coaxiality_variant(rd40):
    """The device Monte Carlo's path (rvtool.variants.multi_device.variant_snapshots, the row Newton of
    rvtool.batched.device_rows_variants on cpu) takes a variant of the rd40 file (the offset inside its pin-centre
    errors) and a coaxiality-only variant: TE equal to the Exudyn run of the variant's full build within 1e-6
    arcsec at 5 points (both solve the same equilibria to the Newton tolerance; test_device_te_order's bound)."""
    from rvtool import build
    from rvtool.batched.device_rows_variants import device_rows_variants
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.units import ARCSEC_PER_RAD
    from rvtool.variants.multi_device import variant_snapshots
    full = load_tolerances(designs.path("rd40_tolerances"))
    alone = ToleranceSpec(**{KEY: getattr(full, KEY)})
    jobs = [(rd40, full, SEED, 2, RD_KW), (rd40, alone, SEED, 2, RD_KW)]
    models = [s for _, s, _ in variant_snapshots(jobs)]
    angles = 2 * np.pi * abs(rd40.ratio) * np.arange(5) / 23
    dev = device_rows_variants(models, torque=rd40.rated_torque, input_angles=angles, device="cpu")
    assert dev.status == ["ok", "ok"]
    for i, (d, spec, seed, k, kw) in enumerate(jobs):
        ref = quasi_static_te(build(sample_variant(spec, d, k, seed).apply(d), **kw), torque=d.rated_torque,
                              input_angles=angles)["te"]
        assert np.max(np.abs(dev.te[i] - ref)) * ARCSEC_PER_RAD <= 1e-6, i


def test_two_wheels_at_180_degrees_make_the_te_even_in_the_offset(rd40):
    """RD-40's two wheels (eccentric phases 0 and 180 degrees, 40 pins, 8 output pins, the Monte Carlo's compliant
    build): turning the whole reducer by 180 degrees about the axis maps the drive with offset eps onto the drive
    with -eps (the pin and output-pin patterns map onto themselves, the two wheels trade places), so the TE is
    even in eps: the one-wheel first order (closed form (a)) cancels between the wheels and what remains is of
    second order (the load share between the wheels acting through the contacts' nonlinear stiffness). Variant 11
    (|eps| = 3.3 um) at rated torque, 16 input angles over one input revolution: the odd part below 1e-6 arcsec
    (the solver's tolerance; measured 2e-11), the even part present but below a tenth of the one-wheel first-order
    amplitude |eps| / (e z_w) (22 arcsec; measured 0.29 arcsec at most)."""
    from rvtool import build
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.units import ARCSEC_PER_RAD
    from rvtool.variants import Variant
    v = sample_variant(ToleranceSpec(**{KEY: Normal(std=2.5e-6)}), rd40, 11, SEED)
    pe = np.asarray(v.pin_centre_errors)
    chis = 2 * np.pi * np.arange(16) / 16
    te = {s: np.asarray(quasi_static_te(build(Variant(pin_centre_errors=s * pe).apply(rd40) if s else rd40, **RD_KW),
                                        torque=rd40.rated_torque, input_angles=chis)["te"]) * ARCSEC_PER_RAD
          for s in (1.0, -1.0, 0.0)}
    odd, even = (te[1.0] - te[-1.0]) / 2, (te[1.0] + te[-1.0]) / 2 - te[0.0]
    first_order = np.linalg.norm(pe[0]) / (rd40.wheels.eccentricity * (rd40.pins.n_pins - 1)) * ARCSEC_PER_RAD
    assert np.max(np.abs(odd)) < 1e-6, np.max(np.abs(odd))
    assert 1e-3 < np.max(np.abs(even)) < 0.1 * first_order, (np.max(np.abs(even)), first_order)
