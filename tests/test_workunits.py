"""rvtool.analysis.workunits: units keyed by the digest of their inputs, stored as they finish, taken from a
resume folder instead of run again, and none started after the deadline (serial and in a spawn pool)."""
import operator
import time

import pytest

from rvtool.analysis.workunits import DeadlineReached, UnitRunner, deadline_from, digest, json_sha256
from rvtool.errors import RvtoolInputError


def test_digest_names_the_inputs_not_their_order():
    assert digest("k", {"a": 1.0, "b": [1, 2]}) == digest("k", {"b": [1, 2], "a": 1.0})
    assert digest("k", {"a": 1.0}) != digest("k", {"a": 1.0 + 1e-15})      # shortest repr: every bit counts
    assert digest("k", {"a": 1}) != digest("other", {"a": 1})


def test_one_digest_keeps_every_key_of_the_three_it_replaced():
    """json_sha256 is the one digest behind a unit's key (digest), a TE job's design (te_revolution.design_digest)
    and a band draw's table (validate_members.table_digest). The hex strings below were computed by the three
    separate functions before they were merged (main at 969cb7a) on a payload with every JSON-able kind a table
    or design holds (nested tables, ints, tiny floats, None, bools, tuples, arrays, NumPy scalars): any change of
    serialisation moves them, and a moved key makes every committed unit and draw unreachable."""
    import dataclasses

    import numpy as np

    from rvtool.analysis.te_revolution import design_digest
    from rvtool.analysis.validate_members import table_digest
    payload = {"table": {"pins": {"n_pins": 40, "radius": 0.0035}, "w": [0.1, 1e-15]}, "step": 0.3,
               "a": np.array([1.5, 2.0]), "t": (1, 2), "n": None, "b": True, "f32": np.float32(0.1),
               "i64": np.int64(7), "f64": np.float64(0.1)}
    assert digest("validate.loop", payload) == "2f83bf88f20ae06e13b9c8aeb51f1f10d83440c152084a5a066d7d02a5525883"
    assert table_digest(payload) == "21169eada979ff2bad553845e64b49a93c1cd53b6bf76a79e916a5356fb2984e"
    assert json_sha256(payload) == table_digest(payload)
    Design = dataclasses.make_dataclass("Design", list(payload))
    # the TE job digest rounds its floats to 12 significant digits (portable across machines: te_revolution's
    # PORTABLE_DIGITS); it was "609ba2dc..." before (the float32's 0.10000000149011612 is 0.100000001490 now)
    assert design_digest(Design(**payload), torque=78.4, step=0.3) == \
        "91167c5b1f8c88dee22cf39f94abd5171661c8e042ea66a4a8aa94b30ebe95a0"


def test_serial_units_are_stored_and_resumed_by_key(tmp_path):
    a = UnitRunner(store=str(tmp_path / "a" / "units"))
    assert a.submit(operator.add, 2, 3, key="k1").result() == 5
    assert a.submit(operator.add, 2, 4).result() == 6              # no key: run, not stored
    assert a.counts["run"] == 2 and len(list((tmp_path / "a" / "units").iterdir())) == 1
    b = UnitRunner(store=str(tmp_path / "b" / "units"), resume=[str(tmp_path / "a" / "units")])
    # the same key is taken, whatever the function: the key IS the identity of the inputs
    assert b.submit(operator.mul, 2, 3, key="k1").result() == 5
    assert b.counts == {"run": 0, "reused": 1, "not_started": 0, "failed": 0}
    assert (tmp_path / "b" / "units" / "k1.pkl").exists()        # copied forward: the latest folder holds all


def test_no_unit_starts_after_the_deadline(tmp_path):
    r = UnitRunner(deadline=time.time() - 1.0, store=str(tmp_path))
    with pytest.raises(DeadlineReached):
        r.submit(operator.add, 1, 1, key="x").result()
    assert r.counts["not_started"] == 1 and not list(tmp_path.iterdir())


def test_pool_runs_units_and_refuses_those_pending_at_the_deadline(tmp_path):
    """Two workers: two units handed out at once run to the end although the deadline passes while they run; a
    unit submitted after the deadline is refused; the finished ones are stored."""
    with UnitRunner(workers=2, deadline=time.time() + 0.5, store=str(tmp_path)) as r:
        f1 = r.submit(operator.pow, 2, 10, key="p1")
        f2 = r.submit(operator.pow, 3, 3, key="p2")
        time.sleep(0.7)
        f3 = r.submit(operator.pow, 5, 2, key="p3")
        assert f1.result(timeout=120) == 1024 and f2.result(timeout=120) == 27
        with pytest.raises(DeadlineReached):
            f3.result(timeout=120)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p1.pkl", "p2.pkl"]
    assert r.summary()["run"] == 2 and r.summary()["not_started"] == 1


def test_no_unit_starts_when_its_kind_would_overrun_the_deadline():
    """A unit is not started once the time left is shorter than the longest unit of its kind so far: the run
    ends near the deadline, not one long unit after it."""
    r = UnitRunner(deadline=time.time() + 0.5)
    assert r.submit(time.sleep, 0.3, kind="slow").result() is None
    with pytest.raises(DeadlineReached):
        r.submit(time.sleep, 0.3, kind="slow").result()
    assert r.counts == {"run": 1, "reused": 0, "not_started": 1, "failed": 0}


def test_file_digest_follows_values_not_comments(tmp_path):
    from rvtool.analysis.workunits import file_digest
    a, b, c = (tmp_path / f"{n}.toml" for n in "abc")
    a.write_text("[test]\nrated_torque = 412.0   # N m\n")
    b.write_text("# searched again: unchanged\n[test]\nrated_torque = 412.0\n")
    c.write_text("[test]\nrated_torque = 413.0\n")
    assert file_digest(a) == file_digest(b) != file_digest(c)


def test_deadline_from_budget_and_utc_time():
    now = 1_800_000_000.0                   # 2027-01-15 08:00 UTC
    assert deadline_from(None, None, now=now) is None
    assert deadline_from(None, 540, now=now) == now + 540
    assert deadline_from("09:30", None, now=now) == now + 5400
    assert deadline_from("09:30", 60, now=now) == now + 60           # the earlier of the two
    assert deadline_from("07:00", None, now=now) == now - 3600       # an hour ago: already past
    late = now + 15 * 3600                  # 23:00 UTC
    assert deadline_from("01:00", None, now=late) == late + 2 * 3600  # 22 h ago: tomorrow's
    for bad in ("9h30", "25:00", "12:61"):
        with pytest.raises(RvtoolInputError, match="--deadline"):
            deadline_from(bad, None, now=now)
    with pytest.raises(RvtoolInputError, match="--budget-s"):
        deadline_from(None, 0, now=now)
