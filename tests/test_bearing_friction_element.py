"""Bearing friction torque wired into the reducer (rvtool.bearings.friction_element): off by
default (no element), Palmgren's moment at the committed bearing load on each bearing's relative
rotation with its analytic dQ/dv, the load as accepted-step history, the loss in the energy
account of a driven run, named errors."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design, replace
from rvtool.bearings.friction_torque import palmgren_torque
from rvtool.errors import RvtoolInputError
from rvtool.solver.continuation import Continuation
from warp_contacts import circle_pairs_ref as cref

OMEGA_IN = 1500 * 2 * np.pi / 60


@pytest.fixture(scope="module")
def loaded():
    model = build(replace(load_design(designs.path("rd40")), bearing_friction={"model": "palmgren"}))
    q = Continuation(model).go_to(70.0)
    return model, q


def test_switched_off_by_default():
    model = build(load_design(designs.path("rd40")))
    assert "bearing_friction" not in model.elements


def test_moment_at_the_committed_load_and_velocity_tangent(loaded):
    model, q = loaded
    el = model.elements["bearing_friction"]
    ev = el.evaluator
    # the continuation committed its last level: the load history is that state's bearing load
    bearings = model.elements["bearings"].evaluation_at(q).obs[:, cref.O_FN]
    np.testing.assert_array_equal(ev.history.load, bearings)
    assert ev.history.load[0] > 100.0                             # the eccentric bearings carry the load
    before = ev.history.load.copy()
    v = model.body_vector(model.kinematic_state(0.0, OMEGA_IN).velocities)
    q_other = q.copy()
    q_other[model.output_index] += 1e-4
    el.evaluate(0.0, el.local(q_other), el.local(v))             # a trial reads the history only
    np.testing.assert_array_equal(ev.history.load, before)
    e = el.evaluate(0.0, el.local(q), el.local(v))
    # each row: |F_t| r = M(|omega|, P1) (tanh saturated at these speeds)
    for k, b in enumerate(ev.bearings):
        w = abs(e.obs[k, cref.O_VT]) / (0.5 * b.model.pitch_diameter)
        M = palmgren_torque(b.model, w, ev.history.load[k])[0]
        assert abs(e.obs[k, cref.O_FT]) * 0.5 * b.model.pitch_diameter == pytest.approx(M, rel=1e-9)
    # dQ/dv against central differences (smooth in omega; h = 1e-4 rad/s against omega ~ 1e2:
    # truncation ~ (h/omega)^2, round-off ~ 1e-16 |Q| / h)
    vl = el.local(v)
    K = np.zeros((len(vl), len(vl)))
    for j in range(len(vl)):
        vp, vm = vl.copy(), vl.copy()
        vp[j] += 1e-4
        vm[j] -= 1e-4
        K[:, j] = (el.evaluate(0.0, el.local(q), vp).Q - el.evaluate(0.0, el.local(q), vm).Q) / 2e-4
    np.testing.assert_allclose(e.dQdv, K, rtol=0, atol=1e-7 * np.abs(e.dQdv).max())
    assert not np.any(e.dQdq)


def test_loss_in_the_energy_account_of_a_driven_run():
    import exudyn as exu

    from rvtool.observe.energy import EnergyAccount
    from rvtool.protocols.hysteresis_cycles import energy_laws
    from rvtool.solver import RunSpec, simulate
    model = build(replace(load_design(designs.path("rd40")), bearing_friction={"model": "palmgren"}))
    q = Continuation(model).go_to(50.0)
    model.commit_contacts(q)
    model.set_input_speed(OMEGA_IN)
    mbs = model.mbs
    mbs.systemData.SetODE2Coordinates(q, configuration=exu.ConfigurationType.Initial)
    mbs.systemData.SetODE2Coordinates_t(model.body_vector(model.kinematic_state(0.0, OMEGA_IN).velocities),
                                        configuration=exu.ConfigurationType.Initial)
    acc = EnergyAccount(mbs, model.contact_elements(), laws=energy_laws(model))
    rec = simulate(mbs, RunSpec(end_time=4e-4, step=2e-5, abs_tol=1e-6, rel_tol=1e-8), model.contact_elements(),
                   None, energy=acc)
    e = rec.energy
    loss = e["friction_dissipation_J"]["bearing_friction"]
    # the loss is about M omega dt: of order 10 W x 0.4 ms here, positive and a few percent of the drive work
    assert 0.0 < loss < 0.1 * e["drive_work_J"]
    assert e["balance_rel_err"] < 1e-3


def test_bad_inputs_are_named():
    d = load_design(designs.path("rd40"))
    with pytest.raises(RvtoolInputError, match="bearing_friction.model"):
        replace(d, bearing_friction={"model": "skf"})
    with pytest.raises(RvtoolInputError, match="bearing_friction.kinematic_viscosity"):
        replace(d, bearing_friction={"kinematic_viscosity": -1.0})
    # (the rolling-element bearing models take the loss too: tests/test_bearing_friction_rolling.py)
    with pytest.raises(RvtoolInputError, match="bearing_friction.static_stiffness"):
        replace(d, bearing_friction={"model": "palmgren", "static_stiffness": -1.0})
