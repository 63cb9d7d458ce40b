"""Palmgren's load P1 by bearing type (rvtool.bearings.palmgren_load; issue 30, Deliver 2): each type against a
hand value, the radial form against the committed figures bit for bit, and the no-load running torque's
increase against the closed form of the crank and main rows' M1 at their preload."""
import math
from dataclasses import replace

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.analysis import losses as L
from rvtool.assembly.spec import BearingFriction
from rvtool.bearings.friction_element import ElementResultantLoads
from rvtool.bearings.palmgren_load import palmgren_load, row_loads
from rvtool.errors import RvtoolInputError

Y14 = 0.4 / math.tan(math.radians(14.0))      # ISO 281 Y of a 14 deg tapered row, 1.6043


@pytest.fixture(scope="module")
def rv40e():
    d = rvtool.load_design(designs.path("rv40e"))
    return d, rvtool.build(d)


def test_each_type_against_a_hand_value(rv40e):
    d, _ = rv40e
    main, crank, ecc = d.main_bearing, d.crank_bearing, d.eccentric_bearing
    # needle set: F_r
    assert palmgren_load(ecc, 1234.5) == 1234.5
    # angular-contact pair, 500 N per row at 40 deg, F_r = 400 N (200 per row): 2 (0.9 x 500 cot 40 - 0.1 x 200)
    # = 2 (536.29 - 20) = 1032.58 N; under a large F_r each row's P1 is its F_r (the pair's F_r)
    cot = 1.0 / math.tan(main.rows[0].contact_angle)     # the file's 39.99999995 deg
    assert palmgren_load(main, 400.0) == pytest.approx(2 * (0.9 * 500 * cot - 20.0), rel=1e-14)
    assert palmgren_load(main, 400.0) == pytest.approx(1032.58, abs=0.01)
    assert palmgren_load(main, 3000.0) == 3000.0
    # one ball row, 25 deg, 200 N preload, F_r = 100 N: 0.9 x 200 cot 25 - 10 = 376.0 N
    row = replace(main.rows[0], contact_angle=math.radians(25.0), axial_preload=200.0)
    assert palmgren_load(row, 100.0) == pytest.approx(0.9 * 200 / math.tan(math.radians(25.0)) - 10.0, rel=1e-14)
    assert palmgren_load(row, 100.0) == pytest.approx(376.0, abs=0.1)
    # tapered pair, 300 N preload, 14 deg cups: 2 rows x 2 Y F_a = 4 x 1.6043 x 300 = 1925.2 N at no radial load;
    # a radial load whose induced axial force per row exceeds the preload gives P1 = F_r (rows: 0.5 F_r each)
    assert palmgren_load(crank, 0.0) == pytest.approx(2 * 2 * Y14 * 300.0, rel=1e-14)
    assert palmgren_load(crank, 0.0) == pytest.approx(1925.2, abs=0.1)
    assert palmgren_load(crank, 1000.0) == pytest.approx(2 * 2 * Y14 * 300.0, rel=1e-14)   # 500 N/row < 962.6 N
    assert palmgren_load(crank, 10000.0) == 10000.0
    rows = row_loads(crank, 10000.0)
    assert [r[1] for r in rows] == [5000.0, 5000.0]
    assert rows[0][2] == pytest.approx(0.5 * 5000.0 / Y14, rel=1e-14)          # F_a: the induced force
    # a pair preloaded by interference: each row's F_a is its axial force at the approach interference / 2
    clamped = replace(main, rows=tuple(replace(r, axial_preload=0.0) for r in main.rows), interference=2e-6)
    (lab, fr, fa, p1), _ = row_loads(clamped, 100.0)
    assert fa == main.rows[0].axial_force_at(1e-6) > 0 and p1 == pytest.approx(0.9 * fa * cot - 5.0, rel=1e-14)
    # the radial form is the radial resultant itself
    for b in (main, crank, ecc):
        assert palmgren_load(b, 777.0, "radial") == 777.0


def test_bad_values_are_refused_by_name(tmp_path, rv40e):
    d, _ = rv40e
    with pytest.raises(RvtoolInputError, match="palmgren_load"):
        palmgren_load(d.main_bearing, 1.0, "axial")
    with pytest.raises(RvtoolInputError, match="bearing_friction.palmgren_load"):
        BearingFriction(palmgren_load="typed ")
    with pytest.raises(RvtoolInputError, match="rolling.palmgren_load"):
        replace(L.load_friction_set().central, palmgren_load="Radial")
    text = open(designs.path("friction_set")).read().replace('palmgren_load = "typed"', 'palmgren_load = 1')
    p = tmp_path / "fs.toml"
    p.write_text(text)
    with pytest.raises(RvtoolInputError, match="rolling.palmgren_load"):
        L.load_friction_set(str(p))
    # a preloaded ball row needs a contact angle for Palmgren's form
    with pytest.raises(RvtoolInputError, match="contact_angle"):
        palmgren_load(replace(d.main_bearing.rows[0], contact_angle=0.0), 10.0)
    with pytest.raises(RvtoolInputError, match="radial"):
        palmgren_load(d.main_bearing, -1.0)


def test_the_shipped_set_and_the_design_default_are_typed():
    assert L.load_friction_set().central.palmgren_load == "typed"
    assert BearingFriction().palmgren_load == "typed"


# committed results of cases/rv/efficiency_rv.py --quick (docs/case_results/rv/efficiency_rv, commit f6c1398),
# made with the radial P1: rv40e's no-load running torque at 1500 r/min by part [N m], 8 input angles
COMMITTED_RADIAL_NO_LOAD = {"eccentric_bearings": 0.1255442190507584, "crank_bearings": 0.15103622381748813,
                            "main_bearings": 0.0032201639223164743, "total_Nm": 0.43622358060491484}


def test_radial_form_reproduces_the_committed_figures_bit_for_bit(rv40e):
    d, m = rv40e
    fs = replace(L.load_friction_set().central, palmgren_load="radial")
    r = L.no_load_torque(m, d, fs, 1500.0, input_angles=L.mesh_angles(m, 8))
    for k in ("eccentric_bearings", "crank_bearings", "main_bearings"):
        assert r["by_part_Nm"][k] == COMMITTED_RADIAL_NO_LOAD[k], k
    assert r["total_Nm"] == COMMITTED_RADIAL_NO_LOAD["total_Nm"]


def test_no_load_torque_rises_by_the_preloaded_rows_m1(rv40e):
    """At zero output torque the rows carry (almost) no radial load: the typed P1 adds, at the input,
    sum f1 d_m P1(preload) n_rel / n_in over the crank pairs (2 rows x 2 Y F_p each, turning at Z_p n_out in
    the carrier) and the main pair (2 rows x 0.9 F_p cot(alpha), at n_out). Nothing else moves."""
    d, m = rv40e
    loaded = L.load_friction_set().central
    typed = L.no_load_torque(m, d, loaded, 1500.0)
    radial = L.no_load_torque(m, d, replace(loaded, palmgren_load="radial"), 1500.0)
    cf = L.closed_form_relative_speeds(d, 1.0)           # per r/min of output
    crank = d.crank_bearing
    dm_c = crank.rows[0].pitch_diameter
    Y = 0.4 / math.tan(crank.rows[0].cup_angle)
    m1_crank = d.cranks.count * loaded.f1_tapered * dm_c * 2 * 2 * Y * crank.axial_preload
    row = d.main_bearing.rows[0]
    m1_main = loaded.f1_ball * row.pitch_diameter * 2 * 0.9 * row.axial_preload / math.tan(row.contact_angle)
    want_crank = m1_crank * cf["crank_bearings"] / cf["input_rpm"]
    want_main = m1_main * cf["main_bearings"] / cf["input_rpm"]
    got = {k: typed["by_part_Nm"][k] - radial["by_part_Nm"][k] for k in typed["by_part_Nm"]}
    # rel 1e-6: the radial resultants at zero torque are not exactly zero (the static solve's residual; the
    # radial form's M1 at them is < 1e-6 of the crank rows' preload M1)
    assert got["crank_bearings"] == pytest.approx(want_crank, rel=1e-6)
    assert got["main_bearings"] == pytest.approx(want_main, rel=1e-6)
    assert typed["total_Nm"] - radial["total_Nm"] == pytest.approx(want_crank + want_main, rel=1e-6)
    for k in ("pins", "teeth", "eccentric_bearings", "seals", "churning"):
        assert got[k] == 0.0, k
    assert want_crank > 0.02 and want_main > 5e-4       # 0.026 and 0.0007 N m for rv40e: not a rounding


def test_dynamic_element_takes_the_same_function(rv40e):
    d, m = rv40e
    from rvtool.solver.static import StaticSolver
    m.set_output_torque(0.0)
    q = StaticSolver(m).solve(0.0)
    for name in ("crank_bearings", "main_bearings"):
        el = m.elements[name]
        bset = el.evaluator
        pose, vel = el.pose_velocity(el.local(q), el.local(0 * q))
        names = [mt.name for mt in bset.mountings]
        fr = ElementResultantLoads(bset, names)(pose, vel)
        typed = ElementResultantLoads(bset, names, [mt.bearing for mt in bset.mountings], mode="typed")(pose, vel)
        assert np.array_equal(typed, [palmgren_load(mt.bearing, f) for mt, f in zip(bset.mountings, fr)])
        assert np.all(typed > 10 * fr)
    with pytest.raises(RvtoolInputError, match="one bearing per mounting"):
        ElementResultantLoads(bset, names, mode="typed")
