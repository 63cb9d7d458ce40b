"""`rvtool new` templates of every topology (issue 27): each loads unchanged into its reference
design, analyzes with every protocol under --quick, and documents every key (a unit for every
dimensional key, the valid range, a whole-sentence meaning; no comment cut with "...")."""
import dataclasses
import json
import re
import tomllib

import pytest

import rvtool
from rvtool import cli
from rvtool.analysis.registry import PROTOCOLS
from rvtool.assembly import topologies
from rvtool.designs.format import key_table, template

TOPOLOGIES = [t for t in topologies.TOPOLOGIES if topologies.available(t) is None]


def _new(topology, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name = f"mine_{topology.replace('-', '_')}"
    assert cli.main(["new", "--topology", topology, "--name", name]) in (0, None)
    return tmp_path / f"{name}.toml"


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_template_loads_into_its_reference_design(topology, tmp_path, monkeypatch):
    """Before issue 27 the rv2/rv3 templates failed ("crank_bearing.rows must hold 2 row tables") and
    the std-involute one ("wheel.face_width is set by the design")."""
    path = _new(topology, tmp_path, monkeypatch)
    table = tomllib.loads(path.read_text())
    assert table["format_version"] == topologies.FORMAT_VERSION and table["topology"] == topology
    d = rvtool.load_design(str(path))
    ref = rvtool.load_design(topologies.get(topology).reference)
    differ = [f.name for f in dataclasses.fields(d) if f.compare and f.name != "name"
              and getattr(d, f.name) != getattr(ref, f.name)]
    assert not differ, f"{topology}: the template's {differ} differ from {topologies.get(topology).reference}"


def _numeric(value):
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return True
    return isinstance(value, list) and bool(value) and all(_numeric(v) for v in value)


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_every_key_has_unit_range_and_a_whole_sentence(topology):
    rows = key_table(topology)
    for sec, key, value, unit, rng, meaning, required in rows:
        where = f"{sec}.{key}" if sec else key
        if _numeric(value) or value is None and key not in ("name",):
            assert unit, f"{topology}: {where} has no unit"
        if key.endswith("_deg"):
            # an angle in degrees; a table of rows has its angle columns in degrees (e.g. "deg, m")
            assert unit.split(",")[0] == "deg", where
        assert meaning, f"{topology}: {where} has no meaning"
    text = template(topology)
    assert "..." not in text                          # no comment cut mid-sentence
    for line in text.splitlines():
        m = re.match(r"^(\w+) = .*? # (.*)$", line)
        if m and m.group(1) not in ("format_version", "topology"):
            comment = m.group(2)
            assert comment.endswith("."), f"{topology}: the comment of {m.group(1)} is not a whole sentence: {comment}"
            value = tomllib.loads(line.split(" #")[0])[m.group(1)]
            if _numeric(value):
                assert re.match(r"^\[[^\]]+\]", comment), f"{topology}: {m.group(1)} has no [unit]: {comment}"


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_template_analyzes_with_every_protocol(topology, tmp_path, monkeypatch):
    """`rvtool new` then `rvtool analyze FILE --quick` (all protocols) on the unchanged file: exit 0,
    every protocol ok or skipped with its reason, no failed protocol; the Monte Carlo runs on the
    tolerance file `rvtool new` writes beside the design (it was skipped before: no tolerance file). Measured on one idle core: cycloid 28 s, rv2 37 s, rv3 25 s, std-involute 7 s."""
    path = _new(topology, tmp_path, monkeypatch)
    out = tmp_path / "out"
    code = cli.main(["analyze", str(path), "--quick", "--quiet", "--out", str(out)])
    assert code in (0, None)
    data = json.loads((out / "results.json").read_text())
    status = {n: data[n]["status"] for n in PROTOCOLS if n in data}
    assert set(status) == set(PROTOCOLS), status
    assert all(s in ("ok", "skipped") for s in status.values()), status
    assert status["te"] == status["stiffness"] == status["lost_motion"] == status["monte_carlo"] == "ok", status
    for n, s in status.items():
        if s == "skipped":
            assert data[n]["reason"], n
