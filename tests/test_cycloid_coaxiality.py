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


def test_the_field_is_drawn_last_and_a_file_without_it_draws_todays_variants(rd40, tmp_path):
    """The key is the last of the draw order; the committed rd40 file with the key's lines removed loads to the spec
    of the earlier fields, whose variants are those of the full file less the offset: every other field equal bit
    for bit, and the pin-centre errors differing by one (x, y) offset common to every pin."""
    assert FIELDS[-1] == KEY and tuple(CYCLOID_TOLERANCE_KEYS)[-1] == KEY
    full = load_tolerances(designs.path("rd40_tolerances"))
    assert getattr(full, KEY) is not None and all(getattr(full, f) is not None for f in FIELDS)
    text = open(designs.path("rd40_tolerances")).read()
    p = tmp_path / "t.toml"
    p.write_text("\n".join(ln for ln in text.splitlines() if not ln.startswith(KEY)))
    stripped = load_tolerances(p)
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


def test_grade_is_it5_of_the_pin_circle_in_the_file_and_the_template(rd40):
    """rd40_tolerances.toml and `rvtool new`'s template: t = IT5 of the pin circle diameter (100 mm: 15 um, ISO
    286-1:2010 Table 1, over 80 up to 120 mm), each coordinate normal with std t / 6."""
    with open(designs.path("rd40_tolerances"), "rb") as fh:
        t = tomllib.load(fh)["tolerances"][KEY]
    assert 80.0 < 2e3 * rd40.pins.pin_circle_radius <= 120.0
    assert math.isclose(iso286_it5(2 * rd40.pins.pin_circle_radius, "pins.pin_circle_radius"), 15e-6, rel_tol=1e-12)
    assert t == {"dist": "normal", "mean": 0.0, "std": 15e-6 / 6}
    tmpl = tomllib.loads(tolerance_template(rd40))["tolerances"]
    assert tmpl[KEY] == t
    big = rd40.replace(pins={"pin_circle_radius": 0.080})          # 160 mm: over 120 up to 180 mm, IT5 = 18 um
    assert tomllib.loads(tolerance_template(big))["tolerances"][KEY]["std"] == 3e-6
