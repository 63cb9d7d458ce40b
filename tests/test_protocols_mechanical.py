"""Mechanical protocols: stiffness (torque sequence, branch fits, lost motion, condensed tangent)."""
import numpy as np
import pytest

from rvtool.bearings.frequencies import bearing_frequencies
from rvtool.errors import RvtoolInputError
from rvtool.protocols import stiffness as S
from rvtool import designs


def test_sequence_has_74_levels_and_paper_branch_counts():
    seq = S.rd40_sequence(140.0)
    torque, labels = seq.levels()
    assert len(torque) == 74
    assert torque[0] == 0 and torque[-1] == 0 and torque.max() == 140 and torque.min() == -140
    # Table tab:branch_stiffness: 11, 9, 9, 9 points with 70 <= |T| <= 140 N m
    counts = {b: len(i) for b, i in S.branch_points(torque, labels, 140.0).items()}
    assert counts == {"pos_loading": 11, "pos_unloading": 9, "neg_loading": 9, "neg_unloading": 9}


def test_sequence_validation_names_parameter():
    with pytest.raises(RvtoolInputError, match="rated_torque"):
        S.TorqueSequence(rated_torque=-1.0)
    with pytest.raises(RvtoolInputError, match="tail_fraction"):
        S.TorqueSequence(rated_torque=1.0, tail_fraction=1.5)


def test_linear_fit_recovers_exact_line_and_r2():
    # Eq. (stiffness_fit) on T = 120 theta - 3 is exact: K = 120, b = -3, R^2 = 1
    th = np.linspace(0.5, 1.0, 11)
    k, b, r2 = S.linear_fit(th, 120 * th - 3)
    assert k == pytest.approx(120, rel=1e-12) and b == pytest.approx(-3, abs=1e-10) and r2 == pytest.approx(1.0)
    # with noise of known variance, R^2 = 1 - SS_res / SS_tot computed independently
    rng = np.random.default_rng(0)
    y = 120 * th + rng.normal(0, 1.0, th.size)
    k, b, r2 = S.linear_fit(th, y)
    kp, bp = np.polyfit(th, y, 1)
    assert k == pytest.approx(kp, rel=1e-10) and b == pytest.approx(bp, rel=1e-10)
    assert r2 == pytest.approx(1 - np.sum((y - (kp * th + bp)) ** 2) / np.sum((y - y.mean()) ** 2), rel=1e-12)
    with pytest.raises(RvtoolInputError, match="at least 2"):
        S.linear_fit([1.0], [1.0])


def test_lost_motion_and_zero_return_on_synthetic_backlash():
    # bilinear curve with dead band +-b: theta = sign(T) b + T / K; lost motion at +-3 % = 2 (b + 0.03 T_r / K)
    seq = S.rd40_sequence(100.0)
    torque, labels = seq.levels()
    K, b = 50.0, 0.8
    angle = np.sign(torque) * b + torque / K
    angle[-1] += 0.1   # final zero-load state shifted
    assert S.lost_motion_from_levels(torque, angle, 100.0) == pytest.approx(2 * (b + 3.0 / K))
    assert S.zero_load_return(torque, angle) == pytest.approx(0.1)
    fits = S.branch_fits(torque, angle, labels, 100.0)
    for f in fits.values():
        assert f["K_Nm_per_arcmin"] == pytest.approx(K, rel=1e-10) and f["R2"] == pytest.approx(1.0)


@pytest.fixture(scope="module")
def rd40():
    from rvtool.assembly.spec import load_design
    from pathlib import Path
    return load_design(designs.path("rd40"))


def test_quasi_static_sequence_on_rd40(rd40):
    from rvtool.assembly.cycloid import build
    seq = S.TorqueSequence(rated_torque=rd40.rated_torque, loading_step=0.25, other_step=0.25)
    model = build(rd40)
    r = S.quasi_static_stiffness(model, seq)
    t, a = r["torque_Nm"], r["angle_arcmin"]
    # output deflection follows the sign of the torque and is odd-symmetric (frictionless model)
    assert np.all(np.sign(a[np.abs(t) > 0]) == np.sign(t[np.abs(t) > 0]))
    ip, im = np.argmax(t), np.argmin(t)
    assert a[ip] == pytest.approx(-a[im], rel=1e-6)
    # per wheel pin-force sums rise with load; regularization carries a negligible force
    assert r["sum_Fn_N"][ip].min() > 10 * r["sum_Fn_N"][0].max()
    assert r["regularization_max"] < 1e-2


def test_condensed_tangent_matches_finite_increment(rd40):
    from rvtool.assembly.cycloid import build
    tc = S.tangent_check(build(rd40), 0.75 * rd40.rated_torque)
    # K_t = dT/dtheta on a differentiable branch: a central increment of 0.1 % torque has a
    # truncation error ~ (dT)^2 curvature ~ 1e-7 relative here (measured 1.6e-7); 1e-5 leaves margin
    # for the Newton tolerance on the two angles
    assert tc["rel_diff"] < 1e-5


# -- vibration: spectra of synthetic signals --------------------------------------------------

from rvtool.protocols import vibration as V  # noqa: E402


def test_amplitude_spectrum_recovers_sine_amplitudes_after_adaptive_resampling():
    # x = 0.3 sin(2 pi 50 t) + 0.1 cos(2 pi 120 t) on adaptive (non-uniform) steps; on a 1 s
    # record both are bin frequencies, so the one-sided amplitude equals A up to the
    # linear-interpolation error ~ (omega dt)^2 / 8 relative (dt = 1e-4: 2e-4 at 120 Hz)
    rng = np.random.default_rng(1)
    dt = rng.uniform(0.5e-4, 1.5e-4, 20000)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    t = t[t <= 1.0 + 1e-12]
    t = np.append(t, 1.0) if t[-1] < 1.0 else t
    x = 0.3 * np.sin(2 * np.pi * 50 * t) + 0.1 * np.cos(2 * np.pi * 120 * t)
    t_u, x_u = V.uniform_resample(t, x, 1e-4)
    f, a = V.amplitude_spectrum(x_u[:-1], 1e-4)
    assert a[np.argmin(abs(f - 50))] == pytest.approx(0.3, rel=1e-3)
    assert a[np.argmin(abs(f - 120))] == pytest.approx(0.1, rel=1e-3)
    pos, _ = V.dominant(f, a, 2)
    assert sorted(np.round(pos)) == [50, 120]


def test_order_spectrum_follows_unwrapped_phase_under_varying_speed():
    # order-40 response on a run-up: constant in shaft angle, smeared in time
    t = np.linspace(0, 1, 200001)
    phase = np.mod(2 * np.pi * (5 * t + 10 * t ** 2), 2 * np.pi)       # wrapped: must be unwrapped
    true_phase = 2 * np.pi * (5 * t + 10 * t ** 2)
    x = 0.2 * np.sin(40 * true_phase) + 0.05 * np.sin(3 * true_phase)
    o, a = V.order_spectrum(phase, x, samples_per_rev=400)
    assert a[np.argmin(abs(o - 40))] == pytest.approx(0.2, rel=1e-2)
    assert a[np.argmin(abs(o - 3))] == pytest.approx(0.05, rel=1e-2)
    assert o[1] == pytest.approx(1 / 15)   # 15 whole revolutions


def test_bearing_markers_closed_form():
    # FTF = f/2 (1 - d/D), BPFO = Z FTF for a radial bearing
    m = bearing_frequencies(10.0, 8, 0.01, 0.05)
    assert m["ftf"] == pytest.approx(5 * 0.8) and m["bpfo"] == pytest.approx(8 * 4.0) and m["bpfi"] == pytest.approx(48.0)


def test_vibration_protocol_validation_and_short_run(rd40):
    from rvtool.assembly.cycloid import build
    from rvtool.solver import RunSpec
    with pytest.raises(RvtoolInputError, match="speed_rpm"):
        V.VibrationProtocol(speed_rpm=0.0, torque=1.0, duration=1.0)
    p = V.VibrationProtocol(speed_rpm=1500.0, torque=rd40.rated_torque, duration=0.001)
    run = V.driven_response(build(rd40), p, RunSpec(end_time=0.001, step=2e-5, abs_tol=1e-6, rel_tol=1e-8),
                            coordinates={"wheel1_x": (1, 0)})
    assert run["record"].accepted_steps == 50 and np.all(np.isfinite(run["responses"]["torsion"]))
    # the input follows the drive: phase = omega t
    assert run["phase_in"][-1] == pytest.approx(1500 * np.pi / 30 * 0.001, rel=1e-9)
    assert V.marker_frequencies(build(rd40), 1500.0)["mesh_hz"] == pytest.approx(40 * 25.0)


# -- hard cases ---------------------------------------------------------------------------------

from rvtool.analysis import hard_cases as H  # noqa: E402


def test_single_nan_is_retried_and_persistent_nan_fails_loudly_with_state_saved(rd40, tmp_path):
    import dataclasses
    case = H.case_by_name("nan")
    ok, _ = H.run_hard_case(case, rd40, quick=True)
    assert ok["passed"] and ok["rejected_steps"] >= 1
    assert ok["reject_reasons"]["non-finite contact force in a trial evaluation"] >= 1
    bad, _ = H.run_hard_case(dataclasses.replace(case, nan_at_evaluation=tuple(range(30, 20000))), rd40,
                             quick=True, out_dir=str(tmp_path))
    assert not bad["passed"] and "non-finite contact force" in bad["message"]
    assert bad["saved_state"] == str(tmp_path / "failed_state.npz")
    saved = np.load(bad["saved_state"])
    assert np.all(np.isfinite(saved["q"])) and 0 < float(saved["t"]) < case.quick_duration
    # nothing written half-way: only the saved state, no results and no temporary files
    assert sorted(p.name for p in tmp_path.iterdir()) == ["failed_state.npz"]


def test_hard_case_torque_history_and_validation():
    c = H.case_by_name("reversal")
    assert c.torque(0.0, 100.0) == 100.0 and c.torque(c.reverse_at_s + c.reverse_over_s, 100.0) == -100.0
    assert c.torque(c.reverse_at_s + 0.5 * c.reverse_over_s, 100.0) == pytest.approx(0.0, abs=1e-12)
    r = H.case_by_name("runup")
    # linear speed ramp: theta = w t^2 / (2 t_r) until t_r
    w = 3000 * np.pi / 30
    assert r.input_angle(r.run_up_s) == pytest.approx(0.5 * w * r.run_up_s)
    assert r.input_speed(2 * r.run_up_s) == pytest.approx(w)
    with pytest.raises(RvtoolInputError, match="hard case"):
        H.case_by_name("nope")


def test_dynamic_settling_path_agrees_with_quasi_static_at_high_load(rd40):
    from rvtool.assembly.cycloid import build
    seq = S.TorqueSequence(rated_torque=rd40.rated_torque, loading_step=0.5, other_step=0.5, fine_levels=(0.03,),
                           ramp_steps=10, dwell_steps=50, reset_interval=25)
    dyn = S.dynamic_stiffness(build(rd40), seq, step=2e-5)
    qs = S.quasi_static_stiffness(build(rd40), seq)
    hi = np.abs(qs["torque_Nm"]) >= 0.5 * rd40.rated_torque
    # with contact damping and kinetic resets the loaded levels settle to the equilibria: the residual
    # motion is below the tail span (~1e-3 arcmin at these loads), far below the 0.5 arcmin threshold
    assert np.max(np.abs(dyn["angle_arcmin"] - qs["angle_arcmin"])[hi]) < 0.05
    st = dyn["stats"]
    assert st["kinetic_resets"] >= 2 * len(qs["torque_Nm"]) and st["forced_commits"] == 0
    assert np.all(dyn["tail_span_arcmin"] <= seq.settle_span_arcmin)


def test_driven_start_from_continuation_is_the_physical_equilibrium(rd40):
    # a full-load Newton solve from the kinematic state may land in a far spurious state
    # (observed with the analytic search: wheels displaced by 1.3 mm, 1.5e6 N pin forces);
    # the continuation start must give the rated-load wind-up of the stiffness sequence (2.80 arcmin)
    from rvtool.assembly.cycloid import build
    from rvtool.assembly.spec import replace
    from rvtool.solver import RunSpec
    d = replace(rd40, wheels={"search": "analytic"})
    p = V.VibrationProtocol(speed_rpm=1500.0, torque=d.rated_torque, duration=2e-4)
    run = V.driven_response(build(d), p, RunSpec(end_time=2e-4, step=2e-5, abs_tol=1e-6, rel_tol=1e-8),
                            coordinates={"wheel1_y": (1, 1)})
    # wheel centre stays on its journal: displacement within bearing and mesh compliance (< 20 um)
    assert np.max(np.abs(run["responses"]["wheel1_y"])) < 20e-6
