"""Observation of accepted steps: closed-form exposure statistics of Eq.
(obs_statistics), window apportioning in time and phase, double-precision
accumulation, determinism of the accepted-sequence interface and input errors.

Tolerances: sums are compensated (Kahan) in float64, so a total over n
terms carries ~1 ulp per term product; 1e-14 relative covers the few hundred
terms used here with a margin of ~10.
"""
import math

import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.observe import (AcceptedStep, ContactSnapshot, ExposureAccumulator, ObserverRegistry, PhaseWindows,
                            StepRecorder, TimeWindows, WholeRun)

REL = 1e-14


def snap(force, slip=None, ids=None, position=None, normal=None):
    f = np.atleast_1d(np.asarray(force))
    n = f.size
    ids = tuple(f"pins/{i}" for i in range(n)) if ids is None else tuple(ids)
    position = np.zeros((n, 2)) if position is None else position
    return ContactSnapshot(ids=ids, normal_force=f, slip_speed=slip, position=position, normal=normal)


def step(index, t_start, dt, snapshots, q_start=(0.0,), q_end=(0.0,)):
    return AcceptedStep(index=index, t_start=t_start, dt=dt, q_start=np.asarray(q_start, float),
                        q_end=np.asarray(q_end, float), snapshots=snapshots)


def driver_times(dts, t0=0.0):
    """(t_start, dt) pairs as the driver forms them: t_n accumulated, dt = t_n - t_{n-1}."""
    t = t0 + np.concatenate(([0.0], np.cumsum(dts)))
    return [(float(t[i]), float(t[i + 1] - t[i])) for i in range(len(dts))]


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300)))


# --- Eq. (obs_statistics) in closed form ------------------------------------

def test_constant_force_dyadic_steps_are_exact():
    # F, v, dt dyadic: every product and sum is exact, so I_F = F T, I_s = F v T, I_m = F^3 T bitwise
    F, v = np.array([3.0, 0.5]), np.array([0.25, 2.0])
    reg, whole = ObserverRegistry(), WholeRun()
    reg.register("whole", whole)
    dts = [2.0 ** -4, 2.0 ** -3, 2.0 ** -5, 2.0 ** -5, 2.0 ** -2]
    for n, (t0, dt) in enumerate(driver_times(dts)):
        reg.on_accepted(step(n, t0, dt, {"pins": snap(F, v)}))
    T = sum(dts)
    acc = whole.accumulator
    assert acc.duration == T
    np.testing.assert_array_equal(acc.I_F, F * T)
    np.testing.assert_array_equal(acc.I_s, F * v * T)
    np.testing.assert_array_equal(acc.I_m, F ** 3 * T)
    np.testing.assert_array_equal(acc.F_pk, F)


@pytest.mark.parametrize("m", [3.0, 1.5, 10.0 / 3.0])
def test_constant_force_nonuniform_steps(m):
    # I_F = F T, I_s = F |v| T, I_m = F^m T for constant F, v over total duration T
    rng = np.random.default_rng(1)
    dts = rng.uniform(1e-5, 3e-4, 400)
    F, v = np.array([1234.5, 0.7, 0.0]), np.array([-0.03, 1.1, 5.0])
    whole = WholeRun(m=m)
    for n, (t0, dt) in enumerate(driver_times(dts)):
        whole.on_accepted(step(n, t0, dt, {"pins": snap(F, v)}))
    T = math.fsum(dts)
    acc = whole.accumulator
    assert rel(acc.duration, T) < REL
    assert rel(acc.I_F, F * T) < REL
    assert rel(acc.I_s, F * np.abs(v) * T) < REL
    assert rel(acc.I_m, F ** m * T) < REL
    np.testing.assert_array_equal(acc.observed_time, acc.slip_time)
    d = whole.results()
    assert d["ids"] == ["pins/0", "pins/1", "pins/2"] and d["m"] == m
    assert d["load_weighted_position"][2] is None  # zero load: None, not NaN


def test_slip_unavailable_accumulates_load_only():
    acc = ExposureAccumulator()
    acc.add(0.5, snap([2.0]))
    acc.add(0.25, snap([2.0], slip=[4.0]))
    assert acc.I_F[0] == 1.5 and acc.I_m[0] == 8.0 * 0.75
    assert acc.I_s[0] == 2.0 * 4.0 * 0.25      # only the step that carried a slip speed
    assert acc.slip_time[0] == 0.25 and acc.observed_time[0] == 0.75


def test_peak_is_a_maximum_and_never_integrated():
    acc = ExposureAccumulator()
    small, big = snap([1.0, 2.0]), snap([500.0, 0.5])
    acc.add(1.0, small)
    acc.peak(small)
    before = acc.to_dict()
    acc.peak(big)                      # a sampled maximum: no time weight
    np.testing.assert_array_equal(acc.F_pk, [500.0, 2.0])
    for key in ("I_F", "I_s", "I_m", "observed_time"):
        np.testing.assert_array_equal(acc.to_dict()[key], before[key])
    assert acc.duration == before["duration"]
    acc.add(1e-6, big)                 # a short integral does not change the maximum
    np.testing.assert_array_equal(acc.F_pk, [500.0, 2.0])
    assert acc.I_F[0] == 1.0 + 500.0 * 1e-6


def test_ids_grow_and_load_weighted_position_and_normal():
    acc = ExposureAccumulator()
    s1 = snap([2.0, 0.0], ids=("a", "b"), position=np.array([[1.0, 0.0], [5.0, 5.0]]),
              normal=np.array([[1.0, 0.0], [0.0, 1.0]]))
    s2 = snap([1.0, 4.0], ids=("c", "a"), position=np.array([[0.0, 2.0], [3.0, 0.0]]),
              normal=np.array([[0.0, 1.0], [0.0, 1.0]]))
    acc.add(1.0, s1)
    acc.add(0.5, s2)
    assert acc.ids == ("a", "b", "c")
    ia = acc.index("a")
    assert acc.I_F[ia] == 2.0 * 1.0 + 4.0 * 0.5
    assert acc.observed_time.tolist() == [1.5, 1.0, 0.5]
    pos = acc.load_weighted_position()
    # x_a = (2*1*[1,0] + 4*0.5*[3,0]) / (2*1 + 4*0.5) = [2, 0]
    np.testing.assert_allclose(pos["a"], [2.0, 0.0], rtol=0, atol=1e-15)
    assert pos["b"] is None                       # never loaded
    np.testing.assert_allclose(pos["c"], [0.0, 2.0], rtol=0, atol=1e-15)
    nrm = acc.load_weighted_normal()
    np.testing.assert_allclose(nrm["a"], [0.5, 0.5], rtol=0, atol=1e-15)  # the normal turned under load
    with pytest.raises(KeyError, match="zz"):
        acc.index("zz")


def test_float32_forces_accumulate_in_float64():
    rng = np.random.default_rng(7)
    n = 5000
    F32 = rng.uniform(10.0, 2000.0, (n, 3)).astype(np.float32)
    V32 = rng.uniform(0.0, 0.1, (n, 3)).astype(np.float32)
    dts = rng.uniform(1e-5, 2e-4, n)
    acc = ExposureAccumulator()
    for k in range(n):
        s = snap(F32[k], V32[k], position=np.zeros((3, 3), np.float32))
        acc.add(dts[k], s)
    ref_F = [math.fsum(F32[:, c].astype(np.float64) * dts) for c in range(3)]
    ref_s = [math.fsum(F32[:, c].astype(np.float64) * V32[:, c].astype(np.float64) * dts) for c in range(3)]
    assert acc.I_F.dtype == np.float64
    assert rel(acc.I_F, ref_F) < 1e-14
    assert rel(acc.I_s, ref_s) < 1e-14
    # the check has teeth: a float32 running sum misses the reference by orders of magnitude more
    f32_sum = np.cumsum((F32[:, 0] * dts.astype(np.float32)), dtype=np.float32)[-1]
    assert rel(f32_sum, ref_F[0]) > 1e-7


# --- time windows ------------------------------------------------------------

def test_time_window_apportions_straddling_steps_exactly():
    # dyadic times: every apportioned part is exact
    tw = TimeWindows(1.0)
    seq = [(0.0, 0.75, 10.0), (0.75, 0.5, 30.0), (1.25, 2.25, 20.0)]  # (t_start, dt, F)
    for n, (t0, dt, F) in enumerate(seq):
        tw.on_accepted(step(n, t0, dt, {"pins": snap([F])}))
    ws = tw.windows
    assert [w.index for w in ws] == [0, 1, 2, 3]
    assert [w.closed for w in ws] == [True, True, True, False]
    assert [w.duration for w in ws] == [1.0, 1.0, 1.0, 0.5]
    # window 0: 0.75 s at 10 N + 0.25 s at 30 N; window 1: 0.25 s at 30 N + 0.75 s at 20 N
    assert [w.accumulator.I_F[0] for w in ws] == [0.75 * 10 + 0.25 * 30, 0.25 * 30 + 0.75 * 20, 20.0, 10.0]
    # the peak enters every window the step touches
    assert [w.accumulator.F_pk[0] for w in ws] == [30.0, 30.0, 20.0, 20.0]
    assert [(w.t_start, w.t_end) for w in ws] == [(0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 3.5)]
    assert [w.complete for w in ws] == [True, True, True, False]
    res = tw.results()
    assert res["kind"] == "time" and len(res["closed"]) == 3 and res["open"]["index"] == 3
    assert res["open"]["exposure"]["I_F"][0] == 10.0


def test_time_windows_sum_to_whole_run():
    rng = np.random.default_rng(3)
    dts = rng.uniform(1e-4, 4e-3, 600)
    L = 0.0137
    reg = ObserverRegistry()
    tw, whole = TimeWindows(L, m=2.5), WholeRun(m=2.5)
    reg.register("windows", tw)
    reg.register("whole", whole)
    steps = driver_times(dts)
    for n, (t0, dt) in enumerate(steps):
        F = rng.uniform(0.0, 800.0, 5)
        s = snap(F, rng.normal(0, 0.2, 5), position=rng.normal(0, 0.05, (5, 3)))
        reg.on_accepted(step(n, t0, dt, {"pins": s}))
    acc, ws = whole.accumulator, tw.windows
    for key in ("I_F", "I_s", "I_m", "observed_time"):
        total = [math.fsum(getattr(w.accumulator, key)[c] for w in ws) for c in range(5)]
        assert rel(total, getattr(acc, key)) < REL, key
    assert rel(math.fsum(w.duration for w in ws), acc.duration) < REL
    np.testing.assert_array_equal(np.max([w.accumulator.F_pk for w in ws], axis=0), acc.F_pk)
    t_end = steps[-1][0] + steps[-1][1]
    assert len(tw.closed) == int(t_end // L)
    # every closed window after the first holds exactly L of accepted time (to round-off of t ~ 1 s)
    assert all(abs(w.duration - L) < 1e-14 for w in tw.closed) and all(w.complete for w in tw.closed)
    assert [w.index for w in ws] == list(range(len(ws)))


def test_time_windows_boundary_hit_by_driver_roundoff():
    # 0.1 accumulated ten times is 0.9999999999999999: the next step must not leave a 1e-16 s sliver behind
    tw = TimeWindows(1.0)
    t = 0.0
    for n in range(12):
        t_new = t + 0.1
        tw.on_accepted(step(n, t, t_new - t, {"pins": snap([1.0])}))
        t = t_new
    assert [w.index for w in tw.windows] == [0, 1]
    assert abs(tw.windows[0].duration - 1.0) < 1e-15 and abs(tw.windows[1].duration - 0.2) < 1e-15


# --- phase windows -------------------------------------------------------------

def _phase_run(pw, omega_in, ratio, dts, phase_forces=None):
    """Input angle omega_in t, output angle omega_in t / ratio; returns the step times."""
    times = driver_times(dts)
    for n, (t0, dt) in enumerate(times):
        q0 = np.array([omega_in * t0, omega_in * t0 / ratio, 7.0])
        q1 = np.array([omega_in * (t0 + dt), omega_in * (t0 + dt) / ratio, 7.0])
        pw.on_accepted(step(n, t0, dt, {"pins": snap([100.0 + n])}, q0, q1))
    return times


@pytest.mark.parametrize("omega_in", [31.0, -31.0])
def test_phase_windows_match_analytic_crossing_times(omega_in):
    # phi = q_in - q_out = omega_in (1 - 1/ratio) t is linear in t, so the boundary
    # phi_b = offset + k P is crossed at t_k = (phi_b - phi_0) / (omega_in (1 - 1/ratio))
    ratio, P, offset = 5.0, 0.37, 0.11
    rate = omega_in * (1.0 - 1.0 / ratio)
    pw = PhaseWindows([1.0, -1.0, 0.0], P, offset)
    dts = np.random.default_rng(5).uniform(1e-4, 6e-3, 500)
    times = _phase_run(pw, omega_in, ratio, dts)
    t_end = times[-1][0] + times[-1][1]
    ws = pw.windows
    step_dir = 1 if omega_in > 0 else -1
    assert [w.index for w in ws] == list(range(ws[0].index, ws[0].index + step_dir * len(ws), step_dir))
    assert ws[0].index == -1  # phi_0 = 0 lies in [offset - P, offset)
    for w in ws:
        entry = w.lower if omega_in > 0 else w.upper
        leave = w.upper if omega_in > 0 else w.lower
        t_in = max(0.0, entry / rate)
        t_out = min(t_end, leave / rate)
        assert abs(w.t_start - t_in) < 1e-13 and abs(w.t_end - t_out) < 1e-13
        assert abs(w.duration - (t_out - t_in)) < 1e-13
    assert all(w.complete for w in pw.closed[1:]) and not ws[0].complete and not ws[-1].complete
    assert rel(math.fsum(w.duration for w in ws), math.fsum(dts)) < REL
    res = pw.results()
    assert res["kind"] == "phase" and "phase_start" in res["open"]


def test_phase_window_peak_is_max_of_touching_steps():
    # one long step crossing three windows carries its accepted-state peak into each
    pw = PhaseWindows([1.0], 1.0)
    pw.on_accepted(step(0, 0.0, 1.0, {"pins": snap([5.0])}, [0.5], [0.75]))
    pw.on_accepted(step(1, 1.0, 1.0, {"pins": snap([9.0])}, [0.75], [3.25]))
    ws = pw.windows
    assert [w.index for w in ws] == [0, 1, 2, 3]
    assert [w.accumulator.F_pk[0] for w in ws] == [9.0, 9.0, 9.0, 9.0]
    # phase 0.75 -> 3.25 in 1 s: 0.25 s, 0.4 s, 0.4 s, 0.1 s of the second step
    np.testing.assert_allclose([w.duration for w in ws], [1.1, 0.4, 0.4, 0.1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(ws[0].accumulator.I_F, [5.0 * 1.0 + 9.0 * 0.1], rtol=1e-15)


def test_phase_window_zero_phase_change_and_reversal():
    pw = PhaseWindows([1.0], 1.0)
    seq = [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.6), (0.6, 1.5), (1.5, 0.5)]  # (phi_start, phi_end)
    for n, (p0, p1) in enumerate(seq):
        pw.on_accepted(step(n, float(n), 1.0, {"pins": snap([1.0])}, [p0], [p1]))
    ws = pw.windows
    # at rest in window 0, up to the boundary, at rest on it, back down (still in window 0: never left),
    # up into window 1 and back into window 0 (a new visit)
    assert [w.index for w in ws] == [0, 1, 0]
    np.testing.assert_allclose([w.duration for w in ws], [4.0 + 0.4 / 0.9, 0.5 / 0.9 + 0.5, 0.5], atol=1e-15)
    assert rel(math.fsum(w.duration for w in ws), 6.0) < REL
    assert ws[0].complete and not ws[1].complete and not ws[2].complete


# --- registry: accepted steps only, deterministic ---------------------------------

def _sequence(seed=11, n=120):
    rng = np.random.default_rng(seed)
    out, q = [], np.zeros(2)
    for k, (t0, dt) in enumerate(driver_times(rng.uniform(1e-3, 1e-2, n))):
        q_new = q + rng.uniform(0.0, 0.3, 2) * np.array([1.0, 0.1])
        out.append(step(k, t0, dt, {"pins": snap(rng.uniform(0, 50, 4), rng.uniform(0, 1, 4)),
                                    "ring": snap(rng.uniform(0, 9, 2), None, ids=("ring/0", "ring/1"))}, q, q_new))
        q = q_new
    return out


def _registry():
    reg = ObserverRegistry()
    reg.register("whole", WholeRun())
    reg.register("time", TimeWindows(0.05, contact_sets=["pins"]))
    reg.register("phase", PhaseWindows([1.0, -1.0], 0.7, m=2.0))
    reg.register("steps", StepRecorder())
    return reg


def _flatten(obj, prefix=""):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _flatten(v, f"{prefix}/{k}")
    elif isinstance(obj, list) and obj and isinstance(obj[0], dict):
        for i, v in enumerate(obj):
            yield from _flatten(v, f"{prefix}[{i}]")
    else:
        yield prefix, obj


def test_results_depend_only_on_the_accepted_sequence():
    # no trial, rejection or Newton interface exists to call: the registry's public surface is the accepted step
    public = {n for n in dir(ObserverRegistry) if not n.startswith("_")}
    assert public == {"register", "on_accepted", "results"}
    assert not any(w in n.lower() for n in dir(ObserverRegistry) for w in ("trial", "reject", "newton", "attempt"))
    a, b = _registry(), _registry()
    for s in _sequence():
        a.on_accepted(s)
    for s in _sequence():
        b.on_accepted(s)
    fa, fb = dict(_flatten(a.results())), dict(_flatten(b.results()))
    assert fa.keys() == fb.keys()
    for key, va in fa.items():
        if isinstance(va, np.ndarray):
            np.testing.assert_array_equal(va, fb[key], key)
        else:
            assert va == fb[key], key
    assert list(a) == ["whole", "time", "phase", "steps"] and "time" in a and len(a) == 4
    assert a["time"].windows[0].accumulator.ids == ("pins/0", "pins/1", "pins/2", "pins/3")
    assert a["whole"].accumulator.ids[-2:] == ("ring/0", "ring/1")


def test_registry_calls_in_order_once_and_refuses_repeats():
    calls = []

    class Probe:
        def __init__(self, tag):
            self.tag = tag

        def on_accepted(self, step):
            calls.append((self.tag, step.index))

        def results(self):
            return {}

    reg = ObserverRegistry()
    reg.register("b", Probe("b"))
    reg.register("a", Probe("a"))
    seq = _sequence(n=3)
    for s in seq:
        reg.on_accepted(s)
    assert calls == [("b", 0), ("a", 0), ("b", 1), ("a", 1), ("b", 2), ("a", 2)]
    with pytest.raises(RvtoolInputError, match="step.index"):
        reg.on_accepted(seq[-1])  # the same accepted step again would double its exposure
    with pytest.raises(RvtoolInputError, match="name"):
        reg.register("a", Probe("c"))
    with pytest.raises(RvtoolInputError, match="on_accepted"):
        reg.register("x", object())
    with pytest.raises(KeyError, match="nope"):
        reg["nope"]


def test_step_recorder_arrays():
    rec = StepRecorder(contact_sets=["pins"])
    rec.on_accepted(step(0, 0.0, 0.5, {"pins": snap([1.0, 2.0], [0.1, 0.2], ids=("p/0", "p/1"))}))
    rec.on_accepted(step(1, 0.5, 0.25, {"pins": snap([3.0], None, ids=("p/2",)), "ring": snap([9.0])}))
    arr = rec.as_arrays()
    np.testing.assert_array_equal(arr["t_end"], [0.5, 0.75])
    np.testing.assert_array_equal(arr["dt"], [0.5, 0.25])
    p = arr["sets"]["pins"]
    assert p["ids"] == ["p/0", "p/1", "p/2"] and list(arr["sets"]) == ["pins"]
    np.testing.assert_array_equal(p["normal_force"], [[1.0, 2.0, np.nan], [np.nan, np.nan, 3.0]])
    np.testing.assert_array_equal(p["slip_speed"], [[0.1, 0.2, np.nan], [np.nan, np.nan, np.nan]])


# --- input errors name the parameter -----------------------------------------------

@pytest.mark.parametrize("make, name", [
    (lambda: step(0, 0.0, -1e-3, {}), "dt"),
    (lambda: step(0, float("nan"), 1e-3, {}), "t_start"),
    (lambda: step(0, 0.0, 1e-3, {}, [0.0, 1.0], [0.0]), "q_end"),
    (lambda: step(0, 0.0, 1e-3, {"pins": 3.0}), "snapshots"),
    (lambda: snap([1.0, float("nan")]), "normal_force"),
    (lambda: snap([1.0, -2.0]), "normal_force"),
    (lambda: snap([1.0, 2.0], ids=("a", "b", "c")), "normal_force"),
    (lambda: snap([1.0, 2.0], [0.1]), "slip_speed"),
    (lambda: snap([1.0, 2.0], [0.1, float("inf")]), "slip_speed"),
    (lambda: snap([1.0, 2.0], position=np.zeros((2, 4))), "position"),
    (lambda: snap([1.0, 2.0], normal=np.zeros((2, 3))), "normal"),
    (lambda: snap([1.0, 2.0], ids=("a", "a")), "ids"),
    (lambda: ExposureAccumulator(m=0.0), "m"),
    (lambda: ExposureAccumulator().add(-1.0, snap([1.0])), "dt_weight"),
    (lambda: ExposureAccumulator().add(1.0, snap([1.0]), snap([2.0])), "ids"),
    (lambda: TimeWindows(0.0), "length_s"),
    (lambda: TimeWindows(1.0, m=-3.0), "m"),
    (lambda: PhaseWindows([1.0], 0.0), "period_rad"),
    (lambda: PhaseWindows([1.0], -1.0), "period_rad"),
    (lambda: PhaseWindows([0.0, 0.0], 1.0), "coefficients"),
    (lambda: PhaseWindows([1.0], 1.0, float("nan")), "offset_rad"),
    (lambda: PhaseWindows([1.0, 1.0], 1.0).on_accepted(step(0, 0.0, 1.0, {})), "coefficients"),
    (lambda: WholeRun(contact_sets=["gear"]).on_accepted(step(0, 0.0, 1.0, {"pins": snap([1.0])})),
     "contact_sets"),
])
def test_bad_inputs_name_the_parameter(make, name):
    with pytest.raises(RvtoolInputError, match=name):
        make()
