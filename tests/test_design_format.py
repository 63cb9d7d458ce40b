"""Design file format 2 (one unit convention): every angle key NAME_deg [deg], every spec SI inside;
format 1 files (no ``format_version``, angles in rad under the field name, crank phase errors in
arcmin) still load with one FutureWarning naming each old key and its new name."""
import dataclasses
import math
import tomllib
import warnings

import pytest

import rvtool
from rvtool import designs
from rvtool.assembly import topologies
from rvtool.errors import RvtoolInputError
from rvtool.units import is_angle


def _table(name):
    with open(designs.path(name), "rb") as fh:
        return tomllib.load(fh)


def _format_1(table):
    """``table`` written as format 1 did: no format_version, contact_angle / rotation_mod in rad."""
    t = {k: v for k, v in table.items() if k != "format_version"}
    out = {}
    for k, v in t.items():
        if isinstance(v, dict):
            v = _format_1(v)
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            v = [_format_1(x) for x in v]
        if k in ("contact_angle_deg", "rotation_mod_deg", "pressure_angle_deg"):
            out[k[:-4]] = math.radians(v)
        else:
            out[k] = v
    return out


@pytest.mark.parametrize("name", designs.design_names())
def test_shipped_designs_are_format_2_and_load_without_warning(name):
    table = _table(name)
    assert table.get("format_version") == topologies.FORMAT_VERSION
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no deprecation warning for a current file
        rvtool.load_design(name)


def test_format_1_file_loads_with_one_warning_naming_old_and_new_keys(tmp_path):
    """rv40e as format 1 wrote it: contact_angle = 0.6981317 rad in both main-bearing rows."""
    import tomlkit
    old = _format_1(_table("rv40e"))
    assert old["main_bearing"]["rows"][0]["contact_angle"] == pytest.approx(0.6981317, rel=1e-15)
    p = tmp_path / "old.toml"
    p.write_text(tomlkit.dumps(old))
    with pytest.warns(FutureWarning) as rec:
        d = rvtool.load_design(str(p))
    msgs = [str(w.message) for w in rec if issubclass(w.category, FutureWarning)]
    assert len(msgs) == 1, msgs                 # one warning for the whole file
    for k in (0, 1):
        assert f"main_bearing.rows[{k}].contact_angle -> main_bearing.rows[{k}].contact_angle_deg" in msgs[0]
    assert "format_version = 2" in msgs[0]
    # the same bearing as the format 2 file (the rad -> deg -> rad round trip to round-off)
    assert d.main_bearing.rows[0].contact_angle == pytest.approx(rvtool.load_design("rv40e").main_bearing.rows[0]
                                                                 .contact_angle, rel=1e-15)


def test_format_1_crank_phase_errors_in_arcmin_become_degrees():
    table = _format_1(_table("rv40e"))
    table["cranks"]["phase_errors_arcmin"] = [6.0, 0.0, -3.0]
    with pytest.warns(FutureWarning, match=r"cranks\.phase_errors_arcmin -> cranks\.phase_errors_deg"):
        d = topologies.design_from_table(table)
    # 6 arcmin = 0.1 deg
    assert d.cranks.phase_errors == pytest.approx((math.radians(0.1), 0.0, math.radians(-0.05)), rel=1e-14)


def test_format_1_cycloid_rotation_mod_and_rack_pressure_angle():
    table = _format_1(_table("rd40"))
    table["profile"]["rotation_mod"] = 2e-4
    with pytest.warns(FutureWarning) as rec:
        d = topologies.design_from_table(table)
    assert len(rec) == 1 and "profile.rotation_mod -> profile.rotation_mod_deg" in str(rec[0].message)
    assert d.profile.rotation_mod == pytest.approx(2e-4, rel=1e-14)
    std = _format_1(_table("std_involute"))
    std["wheel"]["rack"] = {"pressure_angle": math.radians(20.5)}
    std["ring"]["rack"] = {"pressure_angle": math.radians(20.5)}       # meshing gears: one rack
    with pytest.warns(FutureWarning, match=r"wheel\.rack\.pressure_angle -> wheel\.rack\.pressure_angle_deg"):
        d = topologies.design_from_table(std)
    assert d.wheel.rack.pressure_angle == pytest.approx(math.radians(20.5), rel=1e-14)


def test_format_2_refuses_old_keys_and_unknown_versions():
    table = _table("rv40e")
    rows = table["main_bearing"]["rows"]
    rows[0] = {**{k: v for k, v in rows[0].items() if k != "contact_angle_deg"}, "contact_angle": 0.7}
    with pytest.raises(RvtoolInputError, match=r"main_bearing\.rows\[0\]\.contact_angle is a format 1 key; "
                                               r"format_version = 2 gives it as main_bearing\.rows\[0\]\.contact_angle_deg"):
        topologies.design_from_table(table)
    with pytest.raises(RvtoolInputError, match=r"format_version = 3; valid choices are \[1, 2\]"):
        topologies.design_from_table({**_table("rd40"), "format_version": 3})


def _reachable_specs(cls, seen=None):
    """Every spec dataclass a design class holds (fields typed as dataclasses, also in unions)."""
    import typing
    seen = set() if seen is None else seen
    if cls in seen:
        return seen
    seen.add(cls)
    for f in dataclasses.fields(cls):
        try:
            tp = typing.get_type_hints(cls).get(f.name, f.type)
        except Exception:
            tp = f.type
        for t in (tp, *typing.get_args(tp)):
            if isinstance(t, type) and dataclasses.is_dataclass(t):
                _reachable_specs(t, seen)
    return seen


def test_every_angle_field_is_a_deg_file_key_and_every_spec_is_si():
    """No spec field is stored in degrees or arcmin (names ending in _deg / _arcmin), and the angle
    fields the format documents are exactly those marked as angles (rad inside, NAME_deg in files)."""
    from rvtool.bearings.tapered import TaperedPair, TaperedRollerBearing
    specs = set()
    for name in topologies.TOPOLOGIES:
        specs |= _reachable_specs(topologies.design_class(name))
    specs |= {TaperedPair, TaperedRollerBearing}
    angles = set()
    for cls in specs:
        for f in dataclasses.fields(cls):
            assert not f.name.endswith(("_deg", "_arcmin", "_arcsec")), f"{cls.__name__}.{f.name} is not SI"
            if is_angle(f):
                angles.add(f.name)
    assert {"contact_angle", "pressure_angle", "rotation_mod", "phases", "phase", "cup_angle", "cone_angle",
            "direction", "phase_errors"} <= angles
    # every format 1 key maps onto an angle field's file key
    for old, (new, _) in topologies.FORMAT_1_KEYS.items():
        assert new.endswith("_deg") and new[:-4] in angles


def test_designs_lists_each_shipped_design_under_its_own_topology(capsys):
    """rv_three_stage.toml says topology = "rv3"; `rvtool designs` listed it as rv2 (RVDesign is the
    class of both RV topologies and rv2 was found first)."""
    from rvtool import cli
    for name in designs.design_names():
        assert topologies.topology_of(rvtool.load_design(name)) == _table(name).get("topology", "cycloid"), name
    assert cli.main(["designs"]) in (0, None)
    lines = {ln.split()[0]: ln for ln in capsys.readouterr().out.splitlines() if ln.strip()}
    assert "rv3:" in lines["rv_three_stage"] and "rv2:" in lines["rv40e"]


def test_one_warning_per_file_when_it_is_loaded_twice(tmp_path):
    """`rvtool analyze FILE` loads a file to check it and again to run it: still one warning."""
    import tomlkit
    old = _format_1(_table("rv40e"))
    old["crank_gear"]["rack"] = {"pressure_angle": math.radians(20.0)}
    old["sun_gear"]["rack"] = {"pressure_angle": math.radians(20.0)}
    p = tmp_path / "old.toml"
    p.write_text(tomlkit.dumps(old))
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")         # Python's own "once" is not what makes it one
        rvtool.load_design(str(p))
        rvtool.load_design(str(p))
    msgs = [str(w.message) for w in rec if issubclass(w.category, FutureWarning)]
    assert len(msgs) == 1 and "crank_gear.rack.pressure_angle -> crank_gear.rack.pressure_angle_deg" in msgs[0]


def test_radial_mod_table_is_given_in_degrees_and_format_1_tables_convert():
    # the tabulated modification's angle column is in degrees in files (radial_mod_table_deg), radians
    # inside; the delta_r column stays SI. A format 1 file's radian table converts with the warning.
    table = _table("rd40")
    table["profile"]["radial_mod_table_deg"] = [[0.0, 0.0], [2.0, 1e-6], [4.0, 0.0]]
    d = topologies.design_from_table(table)
    import numpy as np
    np.testing.assert_allclose(d.profile.radial_mod_table, [[0.0, 0.0], [math.radians(2.0), 1e-6],
                                                           [math.radians(4.0), 0.0]], rtol=1e-14, atol=0)
    old = _format_1(_table("rd40"))
    old["profile"]["radial_mod_table"] = [[0.0, 0.0], [math.radians(2.0), 1e-6], [math.radians(4.0), 0.0]]
    with pytest.warns(FutureWarning, match=r"profile\.radial_mod_table -> profile\.radial_mod_table_deg"):
        d1 = topologies.design_from_table(old)
    np.testing.assert_allclose(d1.profile.radial_mod_table, d.profile.radial_mod_table, rtol=1e-14, atol=0)
    bad = _table("rd40")
    bad["profile"]["radial_mod_table_deg"] = [0.0, 1.0]
    with pytest.raises(RvtoolInputError, match="radial_mod_table_deg"):
        topologies.design_from_table(bad)
    radian_key = _table("rd40")
    radian_key["profile"]["radial_mod_table"] = [[0.0, 0.0], [0.03, 1e-6]]
    with pytest.raises(RvtoolInputError, match="radial_mod_table"):
        topologies.design_from_table(radian_key)


def test_an_angle_out_of_range_is_reported_in_the_file_key_and_degrees():
    # the spec validates radians; the user wrote degrees under NAME_deg: the error speaks the file's terms
    table = _table("rv40e")
    rows = table["main_bearing"]["rows"]
    rows[0]["contact_angle_deg"] = 120.0
    with pytest.raises(RvtoolInputError, match=r"main_bearing\.rows\[0\]\.contact_angle_deg = 120 is outside "
                                               r"the valid range \[0, 90\) deg"):
        topologies.design_from_table(table)
