"""Property-based fuzzing of the design files (hypothesis).

Every shipped design is perturbed (values out of range, wrong types, NaN/inf, missing and
unknown keys and sections, swapped tooth counts). Property: loading gives either a validated
design or an RvtoolInputError with a one-line message that names a key path of the file --
never another exception (a traceback) and never a hang (hypothesis deadline per example).

Cost control: the validation-only property runs 300 perturbations per shipped design (about 10 s for RD-40 on one core). A
full ``rvtool analyze --quick --protocols te,stiffness`` (subprocess, with a timeout; no
traceback; no NaN in results.json) runs on a small subset: FULL_EXAMPLES
perturbations per design (marked slow: about 1-2 min); exit 0, or 2 with one line and nothing
written -- a design that validates but cannot carry its load (e.g. 1e6 x the rated torque) is an
input error naming ``rated_torque`` and its admissible range (:mod:`rvtool.analysis.admissible`),
not a failed analysis. Each shipped design's rated torque x 1e6 is checked explicitly (the few
hypothesis examples need not draw that scale).
"""
import copy
import functools
import json
import math
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rvtool import designs
from rvtool.assembly import topologies
from rvtool.errors import RvtoolInputError

ROOT = Path(__file__).resolve().parents[1]
N_VALIDATION = 300
"""Perturbations per shipped design in the validation-only property (issue 20: at least 300)."""
FULL_EXAMPLES = 3
"""Perturbations per shipped design run through a whole quick analysis (subprocess)."""
FULL_TIMEOUT_S = 240
"""A quick te+stiffness analysis takes ~10 s; four minutes means a hang."""

DESIGNS = designs.design_names()


def _table(name):
    with open(designs.path(name), "rb") as fh:
        return tomllib.load(fh)


def _leaves(table, prefix=()):
    """Key paths of every value that is not a table."""
    out = []
    for k, v in table.items():
        if isinstance(v, dict):
            out += _leaves(v, prefix + (k,))
        else:
            out.append(prefix + (k,))
    return out


def _set(table, path, value):
    t = table
    for k in path[:-1]:
        t = t[k]
    t[path[-1]] = value


def _get(table, path):
    t = table
    for k in path:
        t = t[k]
    return t


def _delete(table, path):
    t = table
    for k in path[:-1]:
        t = t[k]
    del t[path[-1]]


BAD_VALUES = st.one_of(
    st.sampled_from([float("nan"), float("inf"), -float("inf"), 0, 0.0, -1, -1.0, 1e30, -1e30, 1e-300, 2**63 - 1,
                     True, False, "", "x", [], [1.0], [[1.0, 2.0]], {"a": 1}]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10**6, max_value=10**6),
    st.text(max_size=8),
)


@st.composite
def perturbation(draw, name):
    """(description, perturbed table) of shipped design ``name``."""
    table = _table(name)
    leaves = _leaves(table)
    sections = [k for k, v in table.items() if isinstance(v, dict)]
    kind = draw(st.sampled_from(["value", "value", "scale", "missing_key", "missing_section", "unknown_key",
                                 "unknown_section", "swap_counts", "section_not_table"]))
    t = copy.deepcopy(table)
    if kind == "value":
        path = draw(st.sampled_from(leaves))
        v = draw(BAD_VALUES)
        _set(t, path, v)
        return f"{'.'.join(path)} = {v!r}", t
    if kind == "scale":
        nums = [p for p in leaves if isinstance(_get(t, p), (int, float)) and not isinstance(_get(t, p), bool)]
        path = draw(st.sampled_from(nums))
        f = draw(st.sampled_from([-1.0, 0.0, 1e-6, 0.1, 0.5, 2.0, 10.0, 1e6]))
        old = _get(t, path)
        _set(t, path, type(old)(old * f) if isinstance(old, float) else int(old * f))
        return f"{'.'.join(path)} x {f}", t
    if kind == "missing_key":
        path = draw(st.sampled_from(leaves))
        _delete(t, path)
        return f"missing {'.'.join(path)}", t
    if kind == "missing_section":
        sec = draw(st.sampled_from(sections))
        del t[sec]
        return f"missing [{sec}]", t
    if kind == "unknown_key":
        sec = draw(st.sampled_from(sections + [None]))
        (t if sec is None else t[sec])["no_such_key"] = 1.0
        return f"unknown key in [{sec}]", t
    if kind == "unknown_section":
        t["no_such_section"] = {"a": 1.0}
        return "unknown section", t
    if kind == "section_not_table":
        sec = draw(st.sampled_from(sections))
        t[sec] = draw(st.sampled_from([1.0, "x", [1, 2]]))
        return f"[{sec}] not a table", t
    # swap two integer counts (tooth counts, pin counts, roller counts)
    ints = [p for p in leaves if isinstance(_get(t, p), int) and not isinstance(_get(t, p), bool)]
    a, b = draw(st.sampled_from(ints)), draw(st.sampled_from(ints))
    va, vb = _get(t, a), _get(t, b)
    _set(t, a, vb)
    _set(t, b, va)
    return f"swap {'.'.join(a)} <-> {'.'.join(b)}", t


def _key_names(table):
    names = set()
    for path in _leaves(table):
        names.update(path)
    names.update(k for k, v in table.items() if isinstance(v, dict))
    return names | {"topology", "design"}


def _check_load(name, desc, table):
    try:
        topologies.design_from_table(table)
    except RvtoolInputError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg.strip(), f"{desc}: multi-line error {msg!r}"
        # names a key path of the file (a key or a section of the design)
        assert any(k in msg for k in _key_names(_table(name))), f"{desc}: error names no key: {msg!r}"
    # any other exception propagates: the property fails with the perturbation in the report


@pytest.mark.parametrize("name", DESIGNS)
def test_validation_fuzz(name):
    @settings(max_examples=N_VALIDATION, deadline=5000, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(perturbation(name))
    def check(case):
        desc, table = case
        _check_load(name, desc, table)

    check()


def _has_nan(obj):
    if isinstance(obj, dict):
        return any(_has_nan(v) for v in obj.values())
    if isinstance(obj, list):
        return any(_has_nan(v) for v in obj)
    if isinstance(obj, float):
        return not math.isfinite(obj)
    return isinstance(obj, str) and obj in ("nan", "inf", "-inf")


@pytest.mark.slow
@pytest.mark.parametrize("name", DESIGNS)
def test_full_quick_analysis_on_a_subset(name, tmp_path):
    @settings(max_examples=FULL_EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    @given(perturbation(name))
    def check(case):
        desc, table = case
        try:
            topologies.design_from_table(copy.deepcopy(table))
        except RvtoolInputError:
            pass
        d = tmp_path / f"case{len(list(tmp_path.iterdir()))}"
        proc = _run_cli(table, d)
        assert "Traceback" not in proc.stderr, f"{desc}: {proc.stderr[-3000:]}"
        _check_clean_outcome(desc, proc, d / "out")

    check()


def _error_lines(stderr):
    """stderr without Warp's start-up notice (printed by the library on a machine without CUDA)."""
    return [ln for ln in stderr.strip().splitlines() if ln.strip() and not ln.startswith("Warp ")]


def _check_clean_outcome(desc, proc, out):
    """Issue 20's contract: a successful quick analysis (exit 0, results.json without NaN, every
    protocol ok or skipped), or an input error (exit 2, one line, nothing written)."""
    assert proc.returncode in (0, 2), f"{desc}: exit {proc.returncode}\n{proc.stdout}\n{proc.stderr[-2000:]}"
    if proc.returncode == 2:
        assert not out.exists(), f"{desc}: an input error wrote output"
        lines = _error_lines(proc.stderr)
        assert len(lines) == 1 and lines[0].startswith("rvtool: error: "), f"{desc}: {proc.stderr}"
        return
    data = json.loads((out / "results.json").read_text())
    assert not _has_nan({k: v for k, v in data.items() if k != "provenance"}), desc
    failed = {n: data[n]["reason"] for n in data["protocols"] if data[n]["status"] == "failed"}
    assert not failed, f"{desc}: {failed}"


def _run_cli(table, d, protocols="te,stiffness"):
    import tomlkit
    d.mkdir()
    f = d / "fuzz.toml"
    f.write_text(tomlkit.dumps(table))
    env = dict(os.environ, MPLBACKEND="Agg",
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-m", "rvtool.cli", "analyze", str(f), "--quick", "--quiet",
                           "--protocols", protocols, "--out", str(d / "out")],
                          cwd=d, env=env, capture_output=True, text=True, timeout=FULL_TIMEOUT_S)


@pytest.mark.parametrize("name", DESIGNS)
def test_unsolvable_rated_torque_is_an_input_error(name, tmp_path):
    """rated_torque x 1e6 passes every key's own check but no reducer carries it: exit 2, one line
    naming rated_torque and its admissible range, nothing written (this failed before the
    admissibility check: exit 1 with failed protocols and a results.json)."""
    table = _table(name)
    if "rated_torque" not in table:
        pytest.skip(f"{name} is not a reducer design")
    table["rated_torque"] *= 1e6
    proc = _run_cli(table, tmp_path / "big", protocols="stiffness")
    _check_clean_outcome(f"{name}: rated_torque x 1e6", proc, tmp_path / "big" / "out")
    assert proc.returncode == 2, proc.stdout
    msg = _error_lines(proc.stderr)[0]
    assert "rated_torque" in msg and "valid range: 0 < rated_torque <= " in msg, msg
    limit = float(msg.split("rated_torque <= ")[1].split()[0])
    assert 0 < limit < table["rated_torque"], msg


# -- in-range fuzz from every template (issue 27) ---------------------------------------------------
# Every topology's `rvtool new` template is the starting point; one to three keys with a stated
# valid range (the format documentation's, i.e. the range the spec enforces) are moved inside that
# range. Property: the file loads, or fails with a one-line RvtoolInputError naming a key (ranges
# that depend on other keys, e.g. a hole larger than its pin, can still reject a combination) --
# never another exception. Budget: N_TEMPLATE examples per template (about 5 s each on one core).

N_TEMPLATE = 150
"""In-range perturbations per template (validation only)."""
TEMPLATE_TOPOLOGIES = [t for t in topologies.TOPOLOGIES if topologies.available(t) is None]
_INTERVAL = re.compile(r"([\[\(])\s*([-+0-9.einf]+),\s*([-+0-9.einf]+)\s*([\]\)])")


@functools.lru_cache(maxsize=None)
def _template_text(topology):
    from rvtool.designs.format import template
    return template(topology)


def _template_table(topology):
    return tomllib.loads(_template_text(topology))


def _ranged_keys(topology):
    """[(key path, example value, low, high, low_open, high_open, integer)] of every numeric key of
    the template with a stated finite bound (the intersection of the intervals quoted)."""
    from rvtool.designs.format import key_table
    table = _template_table(topology)
    out = []
    for sec, key, value, unit, rng, meaning, required in key_table(topology):
        path = tuple(sec.split(".")) + (key,) if sec else (key,)
        try:
            example = _get(table, path)
        except (KeyError, TypeError):
            continue                    # not written in the template (an optional key without value)
        if isinstance(example, bool) or not isinstance(example, (int, float)):
            continue
        lo, hi, lo_open, hi_open = -math.inf, math.inf, False, False
        found = False
        for a, x, y, b in _INTERVAL.findall(rng or ""):
            found = True
            x, y = float(x), float(y)
            if x > lo or (x == lo and a == "("):
                lo, lo_open = x, a == "("
            if y < hi or (y == hi and b == ")"):
                hi, hi_open = y, b == ")"
        if found and (math.isfinite(lo) or math.isfinite(hi)) and lo < hi:
            out.append((path, example, lo, hi, lo_open, hi_open, isinstance(example, int)))
    return out


@st.composite
def in_range_change(draw, topology, keys):
    t = copy.deepcopy(_template_table(topology))
    changes = []
    for _ in range(draw(st.integers(1, 3))):
        path, example, lo, hi, lo_open, hi_open, integer = draw(st.sampled_from(keys))
        if integer:
            a = int(math.floor(lo)) + (1 if lo_open and float(lo).is_integer() else 0)
            top = hi if math.isfinite(hi) else max(a, 2 * abs(example)) + 2
            b = int(math.ceil(top)) - (1 if hi_open and float(top).is_integer() else 0)
            v = draw(st.integers(a, max(a, min(b, a + 200))))
        else:
            low = lo if math.isfinite(lo) else min(example, hi) - max(1.0, abs(example))
            high = hi if math.isfinite(hi) else max(example, low) * 4 + abs(low) + 1e-9
            v = draw(st.floats(low, high, exclude_min=lo_open or not math.isfinite(lo),
                               exclude_max=hi_open or not math.isfinite(hi), allow_nan=False, allow_infinity=False))
        _set(t, path, v)
        changes.append(f"{'.'.join(path)} = {v!r}")
    return "; ".join(changes), t


@pytest.mark.parametrize("topology", TEMPLATE_TOPOLOGIES)
def test_template_in_range_fuzz(topology):
    keys = _ranged_keys(topology)
    assert len(keys) >= 30, f"{topology}: only {len(keys)} ranged keys found"   # the parse found the ranges
    names = set()
    for path, *_ in keys:
        names.update(path)
    names |= set(_template_table(topology))

    @settings(max_examples=N_TEMPLATE, deadline=5000, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(in_range_change(topology, keys))
    def check(case):
        desc, table = case
        try:
            topologies.design_from_table(table)
        except RvtoolInputError as exc:
            msg = str(exc)
            assert msg and "\n" not in msg.strip(), f"{desc}: multi-line error {msg!r}"
            assert any(k in msg for k in names | {"design"}), f"{desc}: error names no key: {msg!r}"

    check()


@pytest.mark.slow
@pytest.mark.parametrize("topology", TEMPLATE_TOPOLOGIES)
def test_template_in_range_full_quick_analysis(topology, tmp_path):
    """FULL_EXAMPLES in-range changes of each template through a whole quick te+stiffness analysis."""
    keys = _ranged_keys(topology)

    @settings(max_examples=FULL_EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    @given(in_range_change(topology, keys))
    def check(case):
        desc, table = case
        d = tmp_path / f"case{len(list(tmp_path.iterdir()))}"
        proc = _run_cli(table, d)
        assert "Traceback" not in proc.stderr, f"{desc}: {proc.stderr[-3000:]}"
        _check_clean_outcome(desc, proc, d / "out")

    check()
