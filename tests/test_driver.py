"""Accepted-step driver: time-integration order, history ownership under
rejections and extra evaluations, NaN handling and loud failure."""
import importlib.util
import os

import numpy as np
import pytest

pytest.importorskip("exudyn")

from exudyn_user_elements.scenes import block_on_belt  # noqa: E402
from rvtool.errors import RvtoolInputError, SolverFailure  # noqa: E402
from rvtool.observe.registry import ObserverRegistry  # noqa: E402
from rvtool.solver import RunSpec, simulate  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _case(name):
    spec = importlib.util.spec_from_file_location(name, os.path.join(ROOT, "cases", "verification", name + ".py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class _Record:
    """Minimal observer: keeps every accepted step's duration and belt snapshot."""

    def __init__(self):
        self.dt, self.fn, self.vs = [], [], []

    def on_accepted(self, step):
        s = step.snapshots["belt"]
        self.dt.append(step.dt)
        self.fn.append(float(s.normal_force[0]))
        self.vs.append(float(s.slip_speed[0]))

    def results(self):
        return {}

    def exposure(self):
        dt, fn, vs = map(np.array, (self.dt, self.fn, self.vs))
        return np.sum(fn * dt), np.sum(fn * vs * dt)


def test_oscillator_second_order():
    """Generalized-alpha is second order on the smooth oscillator (Eq. (time_error))."""
    osc = _case("verify_oscillator")
    w = np.sqrt(osc.K / osc.M)
    eps = []
    for n in (40, 80, 160):
        ts, qs, rec, _ = osc.run_oscillator(n)
        assert rec.rejected_steps == 0 and len(ts) == n
        eps.append(np.max(np.abs(qs - osc.Q0 * np.cos(w * ts))) / osc.Q0)
    orders = np.log2(np.array(eps[:-1]) / np.array(eps[1:]))
    assert np.all(orders > 1.95), orders


def _belt_run(end_time=0.06, step=5e-4, reject_attempts=(), wrap=None):
    SC, mbs, el = block_on_belt()
    if wrap is not None:
        wrap(el)
    reg = ObserverRegistry()
    obs = _Record()
    reg.register("rec", obs)
    rec = simulate(mbs, RunSpec(end_time=end_time, step=step, abs_tol=1e-6, rel_tol=1e-8), [el], reg,
                   reject_attempts=reject_attempts)
    return rec, obs, el


def test_extra_trial_evaluations_do_not_change_observations():
    """Trials read only committed history: additional evaluations at perturbed
    states (as extra Newton iterations or line searches would make) leave every
    accepted observation and the committed history bitwise unchanged."""
    rec0, obs0, el0 = _belt_run()

    def wrap(el):
        inner = el.evaluator.evaluate
        rng = np.random.default_rng(0)

        def noisy(pose, vel, history=None, **kw):
            inner(pose + rng.normal(0, 1e-6, pose.shape), vel + rng.normal(0, 1e-3, vel.shape), history, **kw)
            return inner(pose, vel, history, **kw)
        el.evaluator.evaluate = noisy

    rec1, obs1, el1 = _belt_run(wrap=wrap)
    assert obs1.fn == obs0.fn and obs1.vs == obs0.vs and obs1.dt == obs0.dt
    np.testing.assert_array_equal(el0.evaluator.history.anchor_a, el1.evaluator.history.anchor_a)
    np.testing.assert_array_equal(el0.evaluator.history.slip_distance, el1.evaluator.history.slip_distance)
    assert el0.evaluator.history.slip_distance[0] > 0


def test_rejected_trials_see_only_committed_history():
    """Every trial evaluation -- including those of forcibly rejected attempts --
    receives exactly the history committed at the last accepted step, and the
    clock advances only by accepted steps."""
    log = []

    def wrap(el):
        inner = el.evaluator.evaluate
        commit = el.evaluator.commit

        def trial(pose, vel, history=None, **kw):
            h = el.evaluator.history
            log.append(("trial", h.active.copy(), h.anchor_a.copy(), h.anchor_b.copy()))
            return inner(pose, vel, history, **kw)

        def committed(pose, vel, **kw):
            out = commit(pose, vel, **kw)
            h = el.evaluator.history
            log.append(("commit", h.active.copy(), h.anchor_a.copy(), h.anchor_b.copy()))
            return out
        el.evaluator.evaluate = trial
        el.evaluator.commit = committed

    rec, obs, el = _belt_run(reject_attempts=(5, 17, 18, 40, 77), wrap=wrap)
    assert rec.rejected_steps == 5 and rec.reject_reasons == {"forced rejection (test)": 5}
    assert np.isclose(sum(obs.dt), 0.06, rtol=1e-12)
    last = None
    for kind, act, a, b in log:
        if kind == "commit":
            last = (act, a, b)
        elif last is not None:
            np.testing.assert_array_equal(act, last[0])
            np.testing.assert_array_equal(a, last[1])
            np.testing.assert_array_equal(b, last[2])
    assert sum(1 for k, *_ in log if k == "commit") == rec.accepted_steps
    # exposure with retried (smaller) steps differs only by time discretization
    i0 = _belt_run()[1].exposure()
    i1 = obs.exposure()
    assert abs(i1[0] - i0[0]) / i0[0] < 1e-3


def test_single_nan_evaluation_is_rejected_and_retried():
    def wrap(el):
        el.inject_nan_at = {40}
    rec, obs, el = _belt_run(wrap=wrap)
    assert rec.rejected_steps >= 1
    assert rec.reject_reasons.get("non-finite contact force in a trial evaluation", 0) >= 1
    assert np.all(np.isfinite(obs.fn)) and np.isclose(sum(obs.dt), 0.06, rtol=1e-12)


def test_persistent_nan_fails_loudly_with_saved_state(tmp_path):
    SC, mbs, el = block_on_belt()
    el.inject_nan_at = set(range(30, 100000))
    with pytest.raises(SolverFailure, match="non-finite") as info:
        simulate(mbs, RunSpec(end_time=0.05, step=5e-4, min_step=1e-6), [el], out_dir=str(tmp_path))
    assert info.value.state_file is not None
    saved = np.load(info.value.state_file)
    assert 0.0 < float(saved["t"]) < 0.05 and np.all(np.isfinite(saved["q"]))
    assert "belt.anchor_a" in saved.files


def test_run_spec_errors_name_the_parameter():
    with pytest.raises(RvtoolInputError, match="spectral_radius"):
        RunSpec(end_time=1.0, step=0.1, spectral_radius=1.5)
    with pytest.raises(RvtoolInputError, match="step"):
        RunSpec(end_time=1.0, step=-0.1)
    with pytest.raises(RvtoolInputError, match="newton_mode"):
        RunSpec(end_time=1.0, step=0.1, newton_mode="quasi")
    with pytest.raises(RvtoolInputError, match="rel_tol"):
        RunSpec(end_time=1.0, step=0.1, precision="float32", rel_tol=1e-12)


def test_commit_from_cached_last_trial_equals_fresh_commit():
    """The element commits its cached last Newton evaluation (same state, same
    committed history); a fresh evaluation at the accepted state gives the same bits."""
    rec0, obs0, el0 = _belt_run()

    def wrap(el):
        commit = el.evaluator.commit

        def fresh(pose, vel, evaluation=None):
            return commit(pose, vel)
        el.evaluator.commit = fresh

    rec1, obs1, el1 = _belt_run(wrap=wrap)
    assert obs0.fn == obs1.fn and obs0.vs == obs1.vs
    np.testing.assert_array_equal(el0.evaluator.history.slip_distance, el1.evaluator.history.slip_distance)
