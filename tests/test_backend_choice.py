"""``rvtool analyze --backend`` / ``rvtool.analyze(..., backend=)``: results.json records which
backend ran each protocol and, for every other backend, the named reason it was not taken; a
named backend that cannot run a protocol skips it with the reasons (no silent fallback)."""
import json

import pytest

import rvtool
from rvtool.errors import RvtoolInputError
from rvtool.solver.backends import REPLICA_MIN_STATES, auto_order


def test_auto_records_the_choice_and_every_reason(tmp_path):
    res = rvtool.analyze("rd40", "te,lost_motion", quick=True, out_dir=str(tmp_path), backend="auto")
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["backend_requested"] == "auto"
    te = data["backends"]["te"]
    n = res["te"].settings["points"]
    assert te["ran"] == auto_order("equilibria", n_states=n)[0]       # RD-40 runs on every equilibria backend
    assert set(te["not_taken"]) == {"exudyn", "replica", "device"} - {te["ran"]}
    assert all(f"after {te['ran']!r} in auto's measured order for {n} states" in r for r in te["not_taken"].values())
    lm = data["backends"]["lost_motion"]
    assert lm["ran"] == "exudyn" and set(lm["not_taken"]) == {"replica", "device", "fused"}
    assert res["te"].settings["backend"] == te


def test_named_backends_run_or_skip_with_reasons(tmp_path):
    res = rvtool.analyze("rd40", "te,stiffness", quick=True, out_dir=None, backend="device")
    assert res["te"].status == "ok" and res["te"].settings["backend"]["ran"] == "device"
    # the torque sequence on the device torque path (tests/test_torque_path.py)
    assert res["stiffness"].status == "ok" and res["stiffness"].settings["backend"]["ran"] == "device"
    res = rvtool.analyze("rd40", "stiffness", quick=True, out_dir=None, backend="replica")
    assert res["stiffness"].status == "skipped" and "does not run torque_path" in res["stiffness"].reason
    # the device family on RV-40E: equilibria on the device row Newton (tests/test_device_rows.py)
    rv = rvtool.analyze("rv40e", "te", quick=True, out_dir=None, backend="fused")
    assert rv["te"].status == "ok" and rv["te"].settings["backend"]["ran"] == "device"
    with pytest.raises(RvtoolInputError, match="backend"):
        rvtool.analyze("rd40", "te", quick=True, backend="gpu")


def test_auto_order_is_the_measured_one():
    assert auto_order("equilibria", n_states=REPLICA_MIN_STATES - 1)[0] == "exudyn"
    assert auto_order("equilibria", n_states=REPLICA_MIN_STATES)[0] == "replica"
    assert auto_order("equilibria", n_states=10, device="cuda:0")[0] == "device"
    assert auto_order("dynamic") == ["fused", "exudyn"]


def test_monte_carlo_mode_follows_the_backend():
    """The Monte Carlo's mode per backend; auto keeps the batched Exudyn system on a CPU (today's mode,
    measured no slower) and names why not for the others, for a design the device copies cannot take
    (the RV) the reason."""
    from rvtool.analysis.protocols import _mc_backend
    from rvtool.analysis.registry import Context, Unsupported
    rd40, rv = rvtool.load_design("rd40"), rvtool.load_design("rv40e")
    for backend, mode in (("auto", "batched"), ("device", "device"), ("replica", "batched"), ("exudyn", "pool")):
        got, choice = _mc_backend(Context(rd40, quick=True, out_dir=None, backend=backend))
        assert got == mode and choice["requested"] == backend
        assert set(choice["not_taken"]) == {"device", "fused", "replica", "exudyn"} - {choice["ran"]}
    mode, choice = _mc_backend(Context(rv, quick=True, out_dir=None, backend="auto"))
    assert mode == "batched" and "cannot be built" in choice["not_taken"]["device"]
    with pytest.raises(Unsupported, match="cannot run the Monte Carlo"):
        _mc_backend(Context(rv, quick=True, out_dir=None, backend="device"))
