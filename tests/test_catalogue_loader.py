"""Catalogue data and assumed ranges (rvtool/designs/catalogue.py): the shipped files load, units
convert to SI, bad input names its key and valid range, the middle-of-range rule, dotted keys."""
import math

import pytest

from rvtool import designs
from rvtool.designs import catalogue as CAT
from rvtool.errors import RvtoolInputError
from rvtool.units import RAD_PER_ARCMIN

GOOD = """format_version = 2
design = "toy"
assumptions_commit = "e56e011e5ef659085820a1bae7f888cbf3149fbe"
[source]
title = "Toy catalogue"
edition = "ed. 1 (2020)"
[test]
rated_torque = 400.0
rated_output_speed_rpm = 15.0
rated_life_h = 6000.0
lost_motion_torque_fraction = 0.03
rigidity_torque_points = [0.5, 1.0]
[[figure]]
key = "torsional_rigidity"
value = 100.0
unit = "N m/arcmin"
page = "p. 3"
conditions = "input fixed"
kind = "typical"
[[figure]]
key = "lost_motion"
value = 1.0
unit = "arcmin"
page = "p. 3"
kind = "max"
[[figure]]
key = "lost_motion"
value = 0.45
low = 0.3
high = 0.6
unit = "arcmin"
page = "p. 4"
kind = "typical"
status = "read"
"""

ASSUMED = """format_version = 2
design = "toy"
[[assumed]]
key = "a.x"
low = 1.0
high = 3.0
unit = "m"
source = "Someone (2020) p. 1: 1-3 m"
[[assumed]]
key = "a.n"
low = 10
high = 20
unit = "-"
source = "counted"
[[assumed]]
key = "b.pair"
low = [-2.0, 1.0]
high = [-1.0, 2.0]
unit = "m"
source = "element-wise"
"""

TABLE = {"a": {"x": 2.0, "n": 15}, "b": {"pair": [-1.5, 1.5]}}


def _write(tmp_path, text, name="toy_catalogue.toml"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_good_catalogue_loads_in_si(tmp_path):
    c = CAT.load_catalogue(_write(tmp_path, GOOD))
    assert c.design == "toy" and c.source.edition == "ed. 1 (2020)" and c.assumptions_commit.startswith("e56e011")
    assert c.test.rated_output_speed == pytest.approx(15.0 * math.pi / 30.0, rel=1e-15)
    assert c.test.rigidity_torque_points == (0.5, 1.0)
    k = c.figure("torsional_rigidity")
    assert k.value_si == pytest.approx(100.0 / RAD_PER_ARCMIN, rel=1e-15)     # N m/rad
    assert [f.kind for f in c.figures_of("lost_motion")] == ["max", "typical"]
    typ = c.figure("lost_motion", "typical")
    assert typ.low == 0.3 and typ.high == 0.6 and typ.status == "read"
    assert c.figure("hysteresis_loss") is None
    assert "p. 3" in c.citation(k)


@pytest.mark.parametrize("old, new, match", [
    ("rated_torque = 400.0", "rated_torque = -1.0", r"test.rated_torque = -1.0 is outside the valid range \(0.0"),
    ("lost_motion_torque_fraction = 0.03", "lost_motion_torque_fraction = 1.5", "test.lost_motion_torque_fraction"),
    ("rigidity_torque_points = [0.5, 1.0]", "rigidity_torque_points = [0.5, 0.2]", r"rigidity_torque_points\[1\]"),
    ('unit = "N m/arcmin"', 'unit = "furlong"', r"figure\[0\].unit = 'furlong' is not a known unit"),
    ('kind = "typical"\n[[figure]]\nkey = "lost_motion"', 'kind = "best"\n[[figure]]\nkey = "lost_motion"',
     r"figure\[0\].kind = 'best' is not valid \(valid: \['max'"),
    ('status = "read"', 'status = "guessed"', r"figure\[2\].status"),
    ('kind = "typical"\nstatus', 'kind = "max"\nstatus', "appears twice"),
    ("format_version = 2", "format_version = 1", "format_version = 1 is outside the valid range"),
    ('assumptions_commit = "e56e011e5ef659085820a1bae7f888cbf3149fbe"', 'assumptions_commit = "HEAD"',
     "assumptions_commit"),
])
def test_bad_catalogue_names_key_and_range(tmp_path, old, new, match):
    assert old in GOOD
    with pytest.raises(RvtoolInputError, match=match):
        CAT.load_catalogue(_write(tmp_path, GOOD.replace(old, new, 1)))


def test_assumed_ranges_middle_and_values(tmp_path):
    a = CAT.load_assumed(_write(tmp_path, ASSUMED, "toy_assumed.toml"))
    x, n, pair = a.inputs
    assert x.middle == 2.0 and x.at(0.25) == 1.5
    assert n.integer and n.at(0.26) == 13 and isinstance(n.at(1.0), int)
    assert pair.middle == [-1.5, 1.5] and pair.at(1.0) == [-1.0, 2.0]
    CAT.check_assumed_middle(a, TABLE)
    off = {"a": {"x": 2.1, "n": 15}, "b": {"pair": [-1.5, 1.5]}}
    with pytest.raises(RvtoolInputError, match=r"a.x = 2.1 in the design is not the middle 2.0"):
        CAT.check_assumed_middle(a, off)
    with pytest.raises(RvtoolInputError, match="the design has no 'y'"):
        CAT.get_key(TABLE, "a.y")
    t2 = CAT.set_key(TABLE, "a.x", 5.0)
    assert t2["a"]["x"] == 5.0 and TABLE["a"]["x"] == 2.0           # a copy


@pytest.mark.parametrize("old, new, match", [
    ("high = 3.0", "high = 0.5", r"assumed\[0\].high"),
    ("high = 3.0", "high = 1.0", r"assumed\[0\].high"),               # a value, not a range
    ('key = "a.n"', 'key = "a.x"', "appears twice"),
    ("low = [-2.0, 1.0]", "low = [-2.0]", "one shape"),
    ('source = "counted"', 'source = ""', r"assumed\[1\].source"),
])
def test_bad_assumed_names_key(tmp_path, old, new, match):
    with pytest.raises(RvtoolInputError, match=match):
        CAT.load_assumed(_write(tmp_path, ASSUMED.replace(old, new, 1), "toy_assumed.toml"))


def test_shipped_catalogue_files_load_and_pair_with_designs():
    from rvtool.assembly.topologies import read_table
    names = [n for n in designs.design_names() if designs.catalogue_of(n)]
    assert "rv80e" in names
    for n in names:
        c = CAT.load_catalogue(designs.catalogue_of(n))
        assert c.design == n and c.figure("torsional_rigidity") is not None
        if designs.assumed_of(n):
            CAT.check_assumed_middle(CAT.load_assumed(designs.assumed_of(n)), read_table(designs.path(n)))
    assert designs.kind("rv80e_catalogue") == "catalogue" and "rv80e_catalogue" not in designs.design_names()
