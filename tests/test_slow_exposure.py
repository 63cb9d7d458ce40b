"""Exposure windows of Eq. (supp_slow_exposure): closed-form sums over
consumer-owned windows, settling exclusion, phase-sample combination, and
accepted steps only (forced rejections in the driver add nothing).

Tolerance REL: the window sums are compensated float64 sums of a few hundred
terms (see tests/test_observe.py), so 1e-13 relative is a margin of ~100 over
round-off.
"""
import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.observe import AcceptedStep, ContactSnapshot, ObserverRegistry, PhaseWindows, StepRecorder, TimeWindows
from rvtool.slow.exposure import ExposureObserver, WindowExposure

REL = 1e-13


def _snap(force, slip):
    n = len(force)
    return ContactSnapshot(ids=tuple(f"pins/{i}" for i in range(n)), normal_force=np.asarray(force, float),
                           slip_speed=np.asarray(slip, float), position=np.tile([[0.01, 0.02]], (n, 1)))


def _feed(observer, n_steps, dt, force, slip, t0=0.0):
    reg = ObserverRegistry()
    reg.register("slow", observer)
    for k in range(n_steps):
        reg.on_accepted(AcceptedStep(index=k, t_start=t0 + k * dt, dt=dt, q_start=np.zeros(1), q_end=np.zeros(1),
                                     snapshots={"pins": _snap(force, slip)}))


def test_constant_load_windows_are_closed_form():
    # I_s = F |v| tau_w, I_m = F^m tau_w per window (Eq. (supp_slow_exposure)); dt = 2^-7 s divides tau_w = 2^-4 s
    obs = ExposureObserver(TimeWindows(2.0 ** -4, m=3.0))
    F, v = np.array([100.0, 250.0]), np.array([0.3, -0.2])
    _feed(obs, 8 * 5 + 3, 2.0 ** -7, F, v)
    done = obs.completed()
    assert len(done) == 5                          # the sixth window is still open
    for x in done:
        assert x.tau_w == 2.0 ** -4
        np.testing.assert_allclose(x.I_s, F * np.abs(v) * 2.0 ** -4, rtol=REL)
        np.testing.assert_allclose(x.I_m, F ** 3 * 2.0 ** -4, rtol=REL)
        np.testing.assert_allclose(x.mean_force, F, rtol=REL)
        np.testing.assert_allclose(x.position[:, :2], [[0.01, 0.02]] * 2, rtol=REL)


def test_phase_window_of_the_consumer():
    # a cage-cycle window: phase phi = q_0 advancing at omega = 3 rad/s, period 2 pi / 4 rad -> tau_w = pi / 6 s;
    # the steps (dt = 0.01 s) do not divide the period, so boundary steps are apportioned in time
    omega, period, dt = 3.0, 2 * np.pi / 4, 0.01
    obs = ExposureObserver(PhaseWindows([1.0], period, m=3.0))
    reg = ObserverRegistry()
    reg.register("cage", obs)
    for k in range(200):
        reg.on_accepted(AcceptedStep(index=k, t_start=k * dt, dt=dt, q_start=[omega * k * dt],
                                     q_end=[omega * (k + 1) * dt], snapshots={"pins": _snap([50.0], [0.2])}))
    done = obs.completed()
    assert len(done) == 3
    for x in done:
        assert x.tau_w == pytest.approx(period / omega, rel=1e-12)
        assert x.I_s[0] == pytest.approx(50.0 * 0.2 * period / omega, rel=1e-12)


def test_settling_is_excluded_and_partial_windows_are_dropped():
    obs = ExposureObserver(TimeWindows(0.1))
    obs.exclude_until(0.15)
    _feed(obs, 41, 0.01, [10.0], [1.0])            # steps over [0, 0.41): the step at 0.4 s closes [0.3, 0.4)
    done = obs.completed()
    # steps starting before 0.15 s are settling (15 of them); the window [0.1, 0.2) is then partial
    assert obs.results()["excluded_steps"] == 15 and obs.excluded_time == pytest.approx(0.15, rel=REL)
    assert [round(x.tau_w, 12) for x in done] == [0.1, 0.1]
    np.testing.assert_allclose([x.I_s[0] for x in done], [1.0, 1.0], rtol=REL)


def test_phase_samples_combine_rates():
    a = WindowExposure(ids=("pins/0",), tau_w=0.1, m=3, I_s=[2.0], I_m=[1.0], I_F=[10.0], F_pk=[120.0],
                       position=[[1.0, 0, 0]])
    b = WindowExposure(ids=("pins/0", "pins/1"), tau_w=0.3, m=3, I_s=[3.0, 6.0], I_m=[3.0, 3.0], I_F=[30.0, 3.0],
                       F_pk=[100.0, 10.0], position=[[0, 1.0, 0], [0, 0, 1.0]])
    c = WindowExposure.combine([a, b], [1.0, 3.0])
    # rates: pins/0 I_s/tau = (1 * 20 + 3 * 10) / 4 = 12.5 per s, tau = (0.1 + 3 * 0.3) / 4 = 0.25 s
    assert c.tau_w == pytest.approx(0.25, rel=REL)
    np.testing.assert_allclose(c.I_s / c.tau_w, [12.5, 3 * 20.0 / 4], rtol=REL)
    np.testing.assert_allclose(c.F_pk, [120.0, 10.0])
    # position weighted by the I_F rates 1 * 100 and 3 * 100 of pins/0
    np.testing.assert_allclose(c.position[0], [0.25, 0.75, 0.0], rtol=REL)
    with pytest.raises(RvtoolInputError, match="exponents"):
        WindowExposure.combine([a, WindowExposure(ids=("x",), tau_w=1, m=2, I_s=[0], I_m=[0], I_F=[0], F_pk=[0],
                                                  position=[[0, 0, 0]])], [1, 1])


def test_bad_window_inputs_are_named():
    with pytest.raises(RvtoolInputError, match="I_s"):
        WindowExposure(ids=("a",), tau_w=1.0, m=3, I_s=[-1.0], I_m=[0], I_F=[0], F_pk=[0], position=[[0, 0, 0]])
    with pytest.raises(RvtoolInputError, match="tau_w"):
        WindowExposure(ids=("a",), tau_w=0.0, m=3, I_s=[1.0], I_m=[0], I_F=[0], F_pk=[0], position=[[0, 0, 0]])
    with pytest.raises(RvtoolInputError, match="TimeWindows or PhaseWindows"):
        ExposureObserver(object())


def _belt(reject_attempts=()):
    pytest.importorskip("exudyn")
    from exudyn_user_elements.scenes import block_on_belt
    from rvtool.solver import RunSpec, simulate
    _, mbs, el = block_on_belt()
    calls = {"trial": 0}
    inner = el.evaluator.evaluate

    def counted(*args, **kw):
        calls["trial"] += 1
        return inner(*args, **kw)
    el.evaluator.evaluate = counted
    reg = ObserverRegistry()
    obs = ExposureObserver(TimeWindows(0.02, m=3.0))
    rec_steps = StepRecorder()
    reg.register("slow", obs)
    reg.register("steps", rec_steps)
    rec = simulate(mbs, RunSpec(end_time=0.06, step=5e-4, abs_tol=1e-6, rel_tol=1e-8), [el], reg,
                   reject_attempts=reject_attempts)
    return rec, obs, rec_steps.as_arrays(), calls["trial"]


def test_forced_rejections_add_no_exposure():
    """Rejected attempts evaluate contacts (trial count above the accepted count) but reach no observer:
    the exposure is the sum over the accepted steps only, and its clock is the accepted clock."""
    rec, obs, steps, trials = _belt(reject_attempts=(5, 17, 18, 40, 77))
    assert rec.rejected_steps == 5 and trials > rec.accepted_steps
    assert obs.accepted_steps == rec.accepted_steps == steps["dt"].size
    windows = obs.windows.windows
    total_time = sum(w.duration for w in windows)
    assert total_time == pytest.approx(0.06, rel=1e-12)
    s = steps["sets"]["belt"]
    I_s = np.sum(s["normal_force"][:, 0] * np.abs(s["slip_speed"][:, 0]) * steps["dt"])
    I_m = np.sum(s["normal_force"][:, 0] ** 3 * steps["dt"])
    assert sum(w.accumulator.I_s[0] for w in windows) == pytest.approx(I_s, rel=1e-12)
    assert sum(w.accumulator.I_m[0] for w in windows) == pytest.approx(I_m, rel=1e-12)
    # against the run without rejections: the retried (halved) steps change only the time discretization
    rec0, obs0, _, trials0 = _belt()
    assert rec0.rejected_steps == 0
    for w, w0 in zip(obs.completed(), obs0.completed()):
        assert w.tau_w == pytest.approx(w0.tau_w, rel=1e-12)
        np.testing.assert_allclose(w.I_m, w0.I_m, rtol=1e-5)   # measured 5e-7
        np.testing.assert_allclose(w.I_s, w0.I_s, rtol=1e-2)   # stick-slip onset shifts: measured 6e-3
