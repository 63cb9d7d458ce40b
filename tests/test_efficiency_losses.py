"""Friction losses with the cited friction set (rvtool.analysis.losses; issue 30, Deliver 2)."""
import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.errors import RvtoolInputError
from rvtool.analysis import losses as L
from rvtool.protocols.efficiency import kinematic_velocity


@pytest.fixture(scope="module")
def loaded():
    return L.load_friction_set()


@pytest.fixture(scope="module")
def rv40e():
    d = rvtool.load_design(designs.path("rv40e"))
    return d, rvtool.build(d)


def test_assumed_entries_sit_at_mid_range(loaded):
    # the rule of issue 28/30: an assumed value is the middle of its range, fixed before any comparison
    assert loaded.ranges, "the friction set declares its assumed entries"
    for field, (lo, hi) in loaded.ranges.items():
        assert getattr(loaded.central, field) == pytest.approx(0.5 * (lo + hi), rel=1e-12), field


def test_walther_passes_through_its_two_points_and_thins_with_temperature():
    nu40, nu100 = 2.1e-4, 1.8e-5
    assert L.walther_viscosity(nu40, nu100, L.T40) == pytest.approx(nu40, rel=1e-12)
    assert L.walther_viscosity(nu40, nu100, L.T100) == pytest.approx(nu100, rel=1e-12)
    # hand: B = (loglog(210.7) - loglog(18.7)) / log10(373.15/313.15); at 30 degC 396 mm^2/s
    y40, y100 = math.log10(math.log10(210.7)), math.log10(math.log10(18.7))
    B = (y40 - y100) / math.log10(373.15 / 313.15)
    hand = 10 ** 10 ** (y40 + B * math.log10(313.15 / 303.15)) - 0.7
    assert L.walther_viscosity(nu40, nu100, 303.15) == pytest.approx(hand * 1e-6, rel=1e-12)
    assert 390e-6 < hand * 1e-6 < 400e-6


def test_iso_tr_14179_closed_form():
    # mu = 0.048 (w/(v rho))^0.2 eta^-0.05 Ra^0.25 X_L in N/mm, m/s, mm, mPa s, um: w = 20 N/mm, v = 2 m/s,
    # rho = 5 mm, eta = 100 mPa s, Ra = 0.5 um -> 0.048 * 2^0.2 * 100^-0.05 * 0.5^0.25
    mu = L.iso_tr_14179_mu(20e3, 2.0, 5e-3, 0.1, 0.5e-6)
    assert mu == pytest.approx(0.048 * 2 ** 0.2 * 100 ** -0.05 * 0.5 ** 0.25, rel=1e-12)
    assert L.iso_tr_14179_mu(0.0, 2.0, 5e-3, 0.1, 0.5e-6) == 0.0


def test_main_bearing_loss_is_palmgrens_moment_in_closed_form(rv40e, loaded):
    # at no load the main pair (two angular-contact rows, outer ring on the housing) turns at the output speed
    # with no radial load: loss = (M0 + M1) omega_out, M0 = 1e-7 (2 f0) (nu n)^(2/3) d_m^3 [N mm] (nu n >= 2000
    # here), M1 = f1 P1 d_m with Palmgren's P1 of the two rows at their 500 N preload, 2 x 0.9 F_a cot(40 deg)
    d, m = rv40e
    fs = loaded.central
    m.set_output_torque(0.0)
    from rvtool.solver.static import StaticSolver
    q = StaticSolver(m).solve(0.0)
    w_in = 1500 * 2 * math.pi / 60
    v = kinematic_velocity(m, 0.0, w_in)
    parts = L.part_losses(m, d, fs, q, v)
    n_out = 1500 / abs(m.ratio)
    nu_mm2 = fs.viscosity * 1e6
    assert nu_mm2 * n_out >= 2000
    M0 = 1e-7 * (2 * fs.f0_ball) * (nu_mm2 * n_out) ** (2 / 3) * 150.0 ** 3 * 1e-3
    M1 = fs.f1_ball * 2 * 0.9 * 500.0 / math.tan(math.radians(40.0)) * 150.0 * 1e-3
    assert parts["main_bearings"] == pytest.approx((M0 + M1) * w_in / abs(m.ratio), rel=1e-9)
    radial = L.part_losses(m, d, replace(fs, palmgren_load="radial"), q, v)
    assert radial["main_bearings"] == pytest.approx(M0 * w_in / abs(m.ratio), rel=1e-9)
    # the seal: c d^2 n with d = 1.1 x 150 mm
    assert parts["seals"] == pytest.approx(fs.seal_coefficient * (1.1 * 150.0) ** 2 * n_out, rel=1e-12)
    # no load: the sliding contacts carry nothing (1e-6 W: the contact law's regularization leaves 3e-10 W),
    # churning is its fraction of the rolling M0
    assert parts["pins"] <= 1e-6 and parts["teeth"] <= 1e-6
    assert parts["churning"] == pytest.approx(fs.churning_fraction * parts["m0_W"], rel=1e-14)


def test_frictionless_power_balance_and_efficiency_shape(rv40e, loaded):
    d, m = rv40e
    angles = tuple(np.arange(8) * m.mesh_period / 8)
    r = L.efficiency_map(m, d, loaded.central, torque_ratios=(0.3, 1.0), output_speeds_rpm=(5.0, 60.0),
                         input_angles=angles)
    for p in r["points"]:
        # friction off: the drive's power equals P_out over one mesh period (4.4e-5 measured; O(1) if wrong)
        assert p["frictionless_power_balance_rel_err"] <= 1e-4
        assert 0.3 < p["efficiency"] < 1.0
        assert p["P_loss_W"] == pytest.approx(sum(p["loss_by_part_W"].values()), rel=1e-14)
    eta = {(p["torque_ratio"], p["output_speed_rpm"]): p["efficiency"] for p in r["points"]}
    # the load-independent M0 grows as n^(2/3) x n: efficiency falls with speed and at low load
    assert eta[(1.0, 60.0)] < eta[(1.0, 5.0)] and eta[(0.3, 5.0)] < eta[(1.0, 5.0)]


def test_sliding_losses_scale_with_pin_mu(rv40e, loaded):
    d, m = rv40e
    a = L.efficiency_map(m, d, loaded.central)["points"][0]["loss_by_part_W"]
    b = L.efficiency_map(m, d, replace(loaded.central, pins_mu=2 * loaded.central.pins_mu))["points"][0]["loss_by_part_W"]
    assert b["pins"] == pytest.approx(2 * a["pins"], rel=1e-12) and b["teeth"] == a["teeth"]


def test_no_load_torque_by_part(rv40e, loaded):
    d, m = rv40e
    r = L.no_load_torque(m, d, loaded.central, 1500.0)
    assert r["total_Nm"] == pytest.approx(sum(r["by_part_Nm"].values()), rel=1e-14)
    assert r["by_part_Nm"]["pins"] <= 1e-8 and all(v >= 0 for v in r["by_part_Nm"].values())
    assert r["by_part_Nm"]["eccentric_bearings"] > 0 and r["by_part_Nm"]["crank_bearings"] > 0


def test_refuses_elastic_cranks_and_other_topologies(loaded):
    d = rvtool.load_design(designs.path("rv80e"))            # shipped with elastic cranks
    with pytest.raises(RvtoolInputError, match="cranks.shaft"):
        L.efficiency_map(rvtool.build(d), d, loaded.central)
    d = rvtool.load_design(designs.path("rd40"))
    with pytest.raises(RvtoolInputError, match="rv2"):
        L.efficiency_map(rvtool.build(d), d, loaded.central)


def test_bad_inputs(tmp_path, loaded, rv40e):
    with pytest.raises(RvtoolInputError, match="lubricant.nu100"):
        replace(loaded.central, nu100=3e-4)
    with pytest.raises(RvtoolInputError, match="load_per_width"):
        L.iso_tr_14179_mu(-1.0, 1.0, 1e-3, 0.1, 4e-7)
    with pytest.raises(RvtoolInputError, match="torque_ratio"):
        L.efficiency_map(rv40e[1], rv40e[0], loaded.central, torque_ratios=(0.0,))
    # a file whose assumed value lies outside its own range names the key
    text = open(designs.path("friction_set")).read().replace("value = 0.055, low = 0.03", "value = 0.02, low = 0.03")
    p = tmp_path / "fs.toml"
    p.write_text(text)
    with pytest.raises(RvtoolInputError, match="sliding.pins_mu"):
        L.load_friction_set(str(p))
    with pytest.raises(RvtoolInputError, match="output_speed_rpm"):
        L.catalogue_efficiency(L.load_efficiency_catalogue().curves["rv40e"], 100.0)


def test_efficiency_catalogue_loads_and_records_its_status():
    cat = L.load_efficiency_catalogue()
    assert set(cat.curves) >= {"rv40e", "rv80e"} and cat.case_temperature == pytest.approx(303.15)
    with open(designs.path("rv_e_efficiency"), "rb") as fh:
        t = tomllib.load(fh)
    # every figure says whether it was read from the page; none was in this edition of the file
    assert all(c["status"] in ("read", "not_reread") for c in t["efficiency_curve"])
    assert len(t["efficiency_catalogue"]["assumptions_commit"]) == 40
    assert "friction_set" not in designs.design_names() and "rv_e_efficiency" not in designs.design_names()


def test_validate_rows_and_plot(tmp_path, rv40e):
    # the rows `rvtool validate` adds: one per speed of the catalogue's chart and the no-load torque, each with
    # its source and reading status; the plot is written from the results dict
    d, _ = rv40e
    eff = L.validate_efficiency("rv40e", d, quick=True)
    rows = eff.pop("rows")
    cat = L.load_efficiency_catalogue()
    assert [r["figure"] for r in rows] == [f"efficiency_{n:g}rpm" for n in cat.curves["rv40e"].output_speed_rpm] \
        + ["no_load_running_torque"]
    for r in rows:
        assert "Nabtesco" in r["source"] and r["status"] == "not_reread" and "not re-read" in r["verdict"]
        assert np.isfinite(r["predicted"]) and r["predicted"] > 0
    assert L.efficiency_plot({"design": "rv40e", "efficiency": eff}, str(tmp_path)) == ["efficiency.png"]
    assert (tmp_path / "efficiency.png").is_file()
    # a design without figures gives no rows and says so
    assert L.validate_efficiency("rd40", None)["rows"] == []


def test_teeth_loss_uses_the_mesh_load_of_iso_tr_14179(rv40e, loaded):
    # ISO/TR 14179-2 takes the mesh's transverse load over the face width (all its tooth pairs together): the
    # loss recomputed by hand from the rows, with one mu per mesh, at the rated state
    d, m = rv40e
    fs = loaded.central
    from rvtool.solver.static import StaticSolver
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    w_in = 1500 * 2 * math.pi / 60
    v = kinematic_velocity(m, 0.0, w_in)
    el = m.elements["gears"]
    pose, vel = el.pose_velocity(el.local(q), el.local(v))
    fn = np.maximum(el.evaluator.evaluate(pose, 0 * vel, check=False).obs[:, 0], 0.0)
    vt = np.abs(el.evaluator.evaluate(pose, vel, check=False).obs[:, 1])
    rw1, aw, rho, b = L.sun_mesh_geometry(d)
    v_sum = 2 * (w_in - w_in / abs(m.ratio) * np.sign(m.ratio)) * rw1 * math.sin(aw)
    hand = 0.0
    for k in set(el.evaluator.mesh_of.tolist()):
        rows = el.evaluator.mesh_of == k
        w = fn[rows].sum() / b
        mu = 0.048 * (w * 1e-3 / (abs(v_sum) * rho * 1e3)) ** 0.2 * (fs.viscosity * fs.density * 1e3) ** -0.05 \
            * (fs.roughness * 1e6) ** 0.25
        hand += mu * np.sum(fn[rows] * vt[rows])
    assert np.count_nonzero(fn) >= 4                 # two pairs in some mesh: per-row loads would differ
    assert L.part_losses(m, d, fs, q, v)["teeth"] == pytest.approx(hand, rel=1e-9)


def test_audit_relative_speeds_are_the_closed_form_and_skf_changes_only_the_bearings(rv40e, loaded):
    # issue 30 audit: every rolling set turns at the speed the RV kinematics give from the tooth numbers alone
    # (needles and crank rows Z_p n_out = 2400 r/min at 60 r/min output, the main pair n_out)
    d, m = rv40e
    fs = loaded.central
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    from rvtool.solver.static import StaticSolver
    q = StaticSolver(m).solve(0.0)
    cf = L.closed_form_relative_speeds(d, 60.0)
    assert cf["eccentric_bearings"] == pytest.approx(40 * 60.0) and cf["wheel_rpm"] == pytest.approx(60.0)
    v = kinematic_velocity(m, 0.0, cf["input_rpm"] * 2 * math.pi / 60)
    rows = L.rolling_audit(m, d, fs, q, v)
    assert {r["element"] for r in rows} == set(L.ROLLING_ELEMENTS)
    for r in rows:
        assert r["n_rel_rpm"] == pytest.approx(cf[r["element"]], rel=1e-9), r["mounting"]
        assert r["skf_loss_W"] > 0 and r["palmgren_loss_W"] > 0
    pal = L.part_losses(m, d, fs, q, v)
    assert pal == L.part_losses(m, d, fs, q, v, bearing_model="palmgren")
    skf = L.part_losses(m, d, fs, q, v, bearing_model="skf")
    for k in pal:
        if k in L.ROLLING_ELEMENTS:
            assert skf[k] == pytest.approx(sum(r["skf_loss_W"] for r in rows if r["element"] == k), rel=1e-12)
            assert pal[k] == pytest.approx(sum(r["palmgren_loss_W"] for r in rows if r["element"] == k), rel=1e-12)
        else:
            assert skf[k] == pal[k], k          # seals, churning (on Palmgren's M0), sliding: unchanged
    # a constants override reaches only its own kind: the tapered rows' mu_EHL lowers the crank rows' sliding part
    from rvtool.bearings.skf_friction import CONSTANTS
    alt = L.rolling_audit(m, d, fs, q, v, skf_constants={
        "tapered_roller_302": replace(CONSTANTS["tapered_roller_302"], mu_ehl=0.002)})
    for a, r in zip(alt, rows):
        if r["element"] == "crank_bearings":
            assert a["skf_loss_W"] < r["skf_loss_W"]
        else:
            assert a["skf_loss_W"] == r["skf_loss_W"]
    with pytest.raises(RvtoolInputError, match="bearing_model"):
        L.efficiency_map(m, d, fs, bearing_model="harris")
