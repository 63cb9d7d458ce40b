"""Every case script runs headless in its --quick form and writes a results.json with provenance."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted(p.stem for p in (ROOT / "cases").glob("*.py") if not p.name.startswith("_"))
CASE_TIMEOUT_S = 300
"""A --quick run is meant to take seconds; five minutes means it is no longer quick."""


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
    # a case's own pass/fail figures: every "passed" it writes must be true
    failed = [path for path, ok in _passed_flags(data) if ok is not True]
    assert not failed, f"{name}: its own criteria failed at {failed}"


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
