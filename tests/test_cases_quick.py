"""Every case script runs headless in its --quick form, writes a results.json with provenance, and is
judged by its own criteria: a top-level ``passed`` that is true (every ``passed`` it writes true), no NaN
anywhere in the results and no protocol result with a status other than ok."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rvtool import casekit, cli

ROOT = Path(__file__).resolve().parents[1]
CASES = cli.discover_cases(ROOT / "cases")
CASE_TIMEOUT_S = 300
"""A --quick run is meant to take seconds; five minutes means it is no longer quick."""
OPEN_TARGETS = {}
"""Checks of a case that record an open target honestly (``passed`` false): the case's other checks must pass,
and a listed check that starts passing fails here so that its entry is removed."""


def test_cases_are_grouped():
    # every case sits in one of the folders by kind and topology (docs/guide/cases.md)
    groups = {"cycloid", "rv", "std", "verification", "benchmarks", "hard", "studies"}
    assert CASES
    stray = [n for n in CASES if n.partition("/")[0] not in groups or "/" not in n]
    assert not stray, f"cases outside the folders {sorted(groups)}: {stray}"
    for group in groups:
        index = (ROOT / "cases" / group / "README.md").read_text()
        missing = [n for n in CASES if n.startswith(group + "/") and f"`{n.partition('/')[2]}`" not in index]
        assert not missing, f"cases/{group}/README.md does not list {missing}"


@pytest.mark.parametrize("name", CASES)
def test_case_quick(name, tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    # The checkout under test comes first, whatever rvtool is installed.
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    proc = subprocess.run([sys.executable, f"cases/{name}.py", "--quick", "--out", str(tmp_path)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=CASE_TIMEOUT_S)
    assert proc.returncode == 0, f"{name} exited {proc.returncode}\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}"
    results = tmp_path / "results.json"
    assert results.is_file(), f"{name} wrote no results.json"
    data = json.loads(results.read_text())
    prov = data.get("provenance")
    assert isinstance(prov, dict), f"{name}: results.json has no provenance dict"
    for key in ("versions", "device", "precision", "settings"):
        assert key in prov, f"{name}: provenance lacks {key!r}"
    wall = prov.get("wall_s_total")
    assert isinstance(wall, (int, float)) and wall >= 0, f"{name}: wall time {wall!r} is not a duration"
    judge(name, data, OPEN_TARGETS.get(name, {}))


def judge(name, data, open_checks=()):
    """The verdict of one case's results dict (raises AssertionError naming what failed); ``open_checks``:
    names of its checks that record an open target (OPEN_TARGETS)."""
    assert "passed" in data, f"{name}: results.json has no top-level 'passed' (every case judges itself)"
    for check in open_checks:
        assert data.get("checks", {}).get(check, {}).get("passed") is False, \
            f"{name}: the open target {check!r} passes now; remove it from OPEN_TARGETS"
    skip = {f"/checks/{c}/passed" for c in open_checks} | ({"/passed"} if open_checks else set())
    failed = [path for path, ok in _passed_flags(data) if ok is not True and path not in skip]
    assert not failed, f"{name}: its own criteria failed at {failed}: " + json.dumps(
        {k: v for k, v in data.get("checks", {}).items() if not v.get("passed")})[:2000]
    nans = casekit.nan_paths(data)
    assert not nans, f"{name}: NaN in results.json at {nans[:20]}"
    bad = list(_protocol_statuses(data))
    assert not bad, f"{name}: protocol results not ok: {bad}"


@pytest.mark.parametrize("data, reason", [
    ({"x": 1.0}, "no top-level 'passed'"),
    ({"passed": True, "sub": {"passed": False}}, "criteria failed"),
    ({"passed": True, "x": [1.0, "nan"]}, "NaN"),
    ({"passed": True, "te": {"status": "failed", "figures": {}}}, "not ok"),
])
def test_judge_can_fail(data, reason):
    with pytest.raises(AssertionError, match=reason):
        judge("dummy", data)


def test_an_open_target_excuses_only_its_own_check():
    checks = {"open": {"passed": False}, "other": {"passed": True}}
    judge("dummy", {"passed": False, "checks": checks}, {"open"})
    with pytest.raises(AssertionError, match="criteria failed"):
        judge("dummy", {"passed": False, "checks": dict(checks, other={"passed": False})}, {"open"})
    with pytest.raises(AssertionError, match="passes now"):
        judge("dummy", {"passed": True, "checks": dict(checks, open={"passed": True})}, {"open"})


def _passed_flags(obj, path=""):
    """(key path, value) of every "passed" entry in a results dict (provenance excluded)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k == "provenance":
                continue
            if k == "passed":
                yield path + "/passed", v
            yield from _passed_flags(v, f"{path}/{k}")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _passed_flags(v, f"{path}[{i}]")


def _protocol_statuses(obj, path=""):
    """(key path, status) of every protocol result (a dict with "status" and "figures") whose status is not ok."""
    if isinstance(obj, dict):
        if "status" in obj and "figures" in obj and obj["status"] != "ok":
            yield path, obj["status"]
        for k, v in obj.items():
            if k != "provenance":
                yield from _protocol_statuses(v, f"{path}/{k}")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _protocol_statuses(v, f"{path}[{i}]")
