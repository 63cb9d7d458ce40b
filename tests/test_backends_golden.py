"""Every solver backend against the figures of before the backends refactor (issue 29), on every
shipped design: tests/golden/backends.json, written once by tests/golden/capture_backends.py at
commit 8d3787b (see tests/golden/README.md).

Tolerances (the issue's targets): equilibria 1e-9 relative (each coordinate kind against the
largest elastic deviation of that kind, as tests/test_device_newton.py: the Newton tolerance of
1e-6 N over contact stiffnesses of ~1e8 N/m moves a state by ~1e-14 m), TE 1e-6 arcsec (the
replica backend's 1e-4 N residual tolerance moved the RD-40 TE by 2.6e-7 arcsec), lost motion
1e-6 arcmin. A backend that reproduced a different reducer (another regularization, a lost
contact family) misses these by orders of magnitude.
"""
import json
import pathlib

import numpy as np
import pytest
from states import assert_equal_states

import rvtool
from rvtool.protocols.precision import dynamic_te, quasi_static_te
from rvtool.solver.backends import DeviceBackend, EquilibriumBatch, ExudynBackend, ReplicaBackend, choose
from rvtool.units import ARCSEC_PER_RAD

GOLDEN = json.loads((pathlib.Path(__file__).parent / "golden" / "backends.json").read_text())
DESIGNS = tuple(GOLDEN["exudyn"])
TE_TOL = 1e-6           # arcsec
EQ_TOL = 1e-9           # relative
LM_TOL = 1e-6           # arcmin


def _equal_states(q, q_ref, model):
    assert_equal_states(q, q_ref, model, EQ_TOL)


@pytest.mark.parametrize("name", DESIGNS)
def test_exudyn_backend_equals_the_golden_figures(name):
    """Equilibria, the quick TE sequence and the lost motion (continuation and march) of every
    shipped design through the Exudyn backend and the protocols."""
    from rvtool.protocols.lost_motion import lost_motion
    from rvtool.protocols.stiffness import TorqueSequence, lost_motion_from_levels, quasi_static_stiffness
    g = GOLDEN["exudyn"][name]
    d = rvtool.load_design(name)
    model = rvtool.build(d)
    eq = ExudynBackend().solve_equilibria(model, EquilibriumBatch(input_angles=g["equilibria_angles_rad"],
                                                                  torque=d.rated_torque, warm_start=False))
    _equal_states(eq.q, g["equilibria_q"], model)
    te = quasi_static_te(model, torque=d.rated_torque, input_angles=g["te_angles_rad"], backend="exudyn")
    assert te["backend"]["ran"] == "exudyn"
    assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - g["te_arcsec"])) <= TE_TOL
    for fam, f in g["te_peak_loads_N"].items():
        assert te["peak_loads"][fam] == pytest.approx(f, rel=1e-9)
    seq = TorqueSequence(rated_torque=d.rated_torque, loading_step=0.25, other_step=0.25)
    st = quasi_static_stiffness(model, seq)
    lm = lost_motion_from_levels(st["torque_Nm"], st["angle_arcmin"], d.rated_torque, 0.03)
    assert abs(lm - g["lost_motion_continuation_arcmin"]) <= LM_TOL
    march = lost_motion(rvtool.build(d), torque_level=0.03 * d.rated_torque)["lost_motion_rad"]
    assert abs(march * 60 * 180 / np.pi - g["lost_motion_march_arcmin"]) <= LM_TOL


@pytest.mark.parametrize("name", tuple(GOLDEN["replica"]))
def test_replica_backend_equals_the_golden_te(name):
    g = GOLDEN["replica"][name]
    d = rvtool.load_design(name)
    te = quasi_static_te(rvtool.build(d), torque=d.rated_torque, input_angles=g["te_angles_rad"],
                         backend=ReplicaBackend(copies=4))
    assert te["backend"]["ran"] == "replica"
    np.testing.assert_allclose(te["theta_in"], g["theta_in_rad"], rtol=0, atol=1e-12)
    assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - g["te_arcsec"])) <= TE_TOL
    # and against the Exudyn backend's golden TE at the same angles (the oracle)
    ref = np.array(GOLDEN["exudyn"][name]["te_arcsec"])[:len(g["te_arcsec"])]
    assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - ref)) <= TE_TOL


def test_device_backend_equals_the_exudyn_golden_figures():
    """The device Newton on RD-40 (its supported set): equilibria and the quick TE sequence
    against the Exudyn figures of before (the oracle), every point converged on the device."""
    g = GOLDEN["exudyn"]["rd40"]
    d = rvtool.load_design("rd40")
    model = rvtool.build(d)
    eq = DeviceBackend().solve_equilibria(model, EquilibriumBatch(input_angles=g["equilibria_angles_rad"],
                                                                  torque=d.rated_torque))
    assert eq.stats["exudyn_points"] == 0
    _equal_states(eq.q, g["equilibria_q"], model)
    te = quasi_static_te(model, torque=d.rated_torque, input_angles=g["te_angles_rad"], backend="device")
    assert te["backend"]["ran"] == "device" and te["stats"]["exudyn_points"] == 0
    assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - g["te_arcsec"])) <= TE_TOL
    for fam, f in g["te_peak_loads_N"].items():
        assert te["peak_loads"][fam] == pytest.approx(f, rel=1e-6)


def test_device_te_of_variants_equals_the_golden_figures():
    """The variants' device TE (rvtool.batched.device_te, the Monte Carlo's device path) unchanged."""
    from rvtool.batched.device_te import device_te
    from rvtool.variants import Variant
    g = GOLDEN["device"]["rd40"]
    rng = np.random.default_rng(7)       # the variants of tests/golden/capture_backends.py
    vs = [Variant(index=i, eccentricity_error=rng.normal(0, 1e-6), pin_centre_errors=rng.normal(0, 2e-6, (40, 2)),
                  pin_radius_error=rng.normal(0, 1e-6), pin_clearance=abs(rng.normal(0, 2e-6)),
                  bearing_clearance=None if i % 2 else 6e-6) for i in range(2)]
    te = device_te(rvtool.load_design("rd40"), vs, np.array(g["device_te_angles_rad"]), regularization=(1e4, 100.0),
                   device="cpu")
    assert np.max(np.abs(te.te * ARCSEC_PER_RAD - g["device_te_arcsec"])) <= TE_TOL


def test_fused_and_exudyn_dynamic_equal_the_golden_runs():
    g = GOLDEN["device"]["rd40"]
    d = rvtool.load_design("rd40")
    from rvtool.solver import RunSpec
    n, step = g["dynamic_steps"], g["dynamic_step_s"]
    spec = RunSpec(end_time=n * step, step=step, abs_tol=1e-6, rel_tol=1e-8)
    kw = dict(torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=n * step, run_spec=spec)
    for solver, key in (("fused", "fused"), ("exudyn", "exudyn")):
        r = dynamic_te(rvtool.build(d), solver=solver, device="cpu", **kw)
        assert r["solver"] == solver
        np.testing.assert_allclose(r["t"], g[f"{key}_t_s"], rtol=0, atol=1e-15)
        assert np.max(np.abs(r["te"] * ARCSEC_PER_RAD - g[f"{key}_te_arcsec"])) <= TE_TOL


@pytest.mark.parametrize("name", DESIGNS)
def test_auto_names_why_each_other_backend_was_not_taken(name):
    """auto picks a backend that supports the model, and names a reason for each other one; its
    TE equals the golden TE."""
    g = GOLDEN["exudyn"][name]
    d = rvtool.load_design(name)
    model = rvtool.build(d)
    b, choice = choose("auto", model, "equilibria", n_states=len(g["te_angles_rad"]))
    assert choice["ran"] == b.name and b.supports(model, "equilibria").ok
    assert set(choice["not_taken"]) == {"exudyn", "replica", "device"} - {b.name}
    assert all(isinstance(r, str) and r for r in choice["not_taken"].values())
    te = quasi_static_te(model, torque=d.rated_torque, input_angles=g["te_angles_rad"], backend="auto")
    assert te["backend"] == choice
    assert np.max(np.abs(te["te"] * ARCSEC_PER_RAD - g["te_arcsec"])) <= TE_TOL


def test_a_named_backend_that_cannot_run_the_model_is_an_error():
    """No silent fallback: --backend device on an RV model with conformal pin grooves (a closure with a
    nonlinear station law) names the reasons (RV-40E, with or without stick--slip anchors, runs on the
    device row Newton: tests/test_device_rows.py, tests/test_device_families.py)."""
    from rvtool.errors import RvtoolInputError
    d = rvtool.load_design("rv40e")
    model = rvtool.build(d.replace(pins={"groove": "conformal", "groove_clearance": 5e-6}))
    with pytest.raises(RvtoolInputError, match=r"backend = 'device'.*cannot run equilibria.*Valid choices"):
        choose("device", model, "equilibria")
    with pytest.raises(RvtoolInputError, match=r"valid choices are"):
        choose("gpu", model, "equilibria")
