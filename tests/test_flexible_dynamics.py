"""Flexible cycloid wheels as floating bodies (issue 33, Deliver 2): the switch, the port maps, the
frozen-body check against the rigid model, the backends' refusals and a short driven run.
Coarse wheel mesh (the builder's default size), short runs."""
import numpy as np
import pytest

import rvtool
from _flex_helpers import (COARSE, assert_backends_refuse, assert_frozen_is_rigid, assert_tangent_is_the_linear_model,
                           rated_state, short_driven_run)
from _flex_helpers import flexible_wheels as flexible
from rvtool import designs
from rvtool.assembly.spec import replace
from rvtool.errors import RvtoolInputError

QUARTER_MESH = np.arange(4) * 2 * np.pi / (40 * 4)     # 4 points over one RD-40 mesh cycle


@pytest.fixture(scope="module")
def rd40():
    return rvtool.load_design(designs.path("rd40"))


@pytest.fixture(scope="module")
def flex_model(rd40):
    return rvtool.build(flexible(rd40))


def test_switch_defaults_to_rigid_and_refuses_bad_input(rd40):
    assert rd40.wheels.dynamics.model == "rigid"
    assert rvtool.build(rd40).flexible is None
    with pytest.raises(RvtoolInputError, match=r"n_modes = 0 is outside the valid range \[1, 60\]"):
        replace(rd40, wheels={"dynamics": {"model": "flexible", "n_modes": 0}})
    with pytest.raises(RvtoolInputError, match="valid choices are \\['rigid', 'flexible'\\]"):
        replace(rd40, wheels={"dynamics": {"model": "elastic"}})


def test_frozen_flexible_wheels_reproduce_the_rigid_te(rd40):
    # the bounds (those of the golden backend tests): TE 1e-6 arcsec, equilibria 1e-9 relative; the held
    # coordinates are reported as fixed
    assert_frozen_is_rigid(rd40, flexible(rd40, frozen=True), QUARTER_MESH, structure="wheels")


def test_elastic_wheels_add_compliance(rd40, flex_model):
    # the wheel body's elasticity can only soften the torque path: the TE under the rated torque grows
    from rvtool.protocols.precision import quasi_static_te
    rigid = quasi_static_te(rvtool.build(rd40), torque=rd40.rated_torque, input_angles=QUARTER_MESH[:2])
    flex = quasi_static_te(flex_model, torque=rd40.rated_torque, input_angles=QUARTER_MESH[:2])
    z = flex_model.structures["wheels"].coordinates()
    assert np.abs(z).max() > 0
    assert np.all(np.isfinite(flex["te"]))
    summary = flex_model.flexible.summary()
    assert summary["n_modes"] == 4 and min(min(f[:4]) for f in summary["in_plane_fraction"]) > 0.5
    # 4 modes + static responses to radial/tangential profile loads of orders 0, 1 (6), the bore (2), 8 holes (16)
    assert summary["n_coordinates"] == [4 + 6 + 2 + 16] * 2
    assert rigid["te"] is not None


def test_port_map_jacobian_matches_central_differences():
    from exudyn_user_elements.floating_ports import FloatingPorts

    class Coords:
        n = 3
    rng = np.random.default_rng(3)
    A = rng.normal(size=(4, 3, 3)) * 1e-3
    ports = FloatingPorts(Coords(), 3, base=[-1, 2, 1, 0], frame=[1, 1, 2, 1], sign=[-1, -1, 1, 1], maps=A)
    pose = rng.normal(size=(3, 3))
    eta = rng.normal(size=3) * 1e-2
    x = np.concatenate([pose.ravel(), eta])

    def f(x):
        return ports.map(x[:9].reshape(3, 3), x[9:])[0].ravel()
    _, T, T_l = ports.map(pose, eta)
    assert T_l is T
    h = 1e-6
    fd = np.column_stack([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(len(x))])
    # central differences of a smooth map: error O(h^2 |f'''|) ~ 1e-12
    assert np.abs(T - fd).max() < 1e-8
    # zero modal coordinates: every virtual body sits exactly on its base
    pv, _, _ = ports.map(pose, np.zeros(3))
    assert np.array_equal(pv[0], np.zeros(3)) and np.array_equal(pv[1], pose[2]) and np.array_equal(pv[3], pose[0])


def test_modes_are_mean_axis_modes(rd40):
    # the frame is the wheel's mean axis: the kept modes are M-orthogonal to the rigid modes, so the
    # linear inertia coupling between frame and modes vanishes (module docstring)
    from rvtool.assembly.flexible_wheels import wheel_body_mesh
    from rvtool.structure import floating_basis
    wm = wheel_body_mesh(rd40, 0, mesh_size=COARSE["mesh_size"])
    b = floating_basis(wm.model, n_modes=4)
    MR = wm.model.mass @ wm.model.rigid_body_modes()
    assert np.abs(b["matrix"].T @ MR).max() < 1e-8 * np.abs(MR).max()


def test_device_backends_refuse_flexible_wheels_by_name(flex_model):
    assert_backends_refuse(flex_model, (("device", "equilibria"), ("fused", "dynamic"), ("replica", "equilibria")))


def test_flexible_wheels_refuse_the_ported_wheel_body(rd40):
    with pytest.raises(RvtoolInputError, match="counted twice"):
        rvtool.build(replace(flexible(rd40), wheels={"body": "ported"}))


def test_short_driven_run_moves_the_modes(rd40, flex_model):
    short_driven_run(flex_model, rd40, 20)
    assert np.abs(flex_model.structures["wheels"].coordinates()).max() > 0


def test_element_tangent_equals_the_mounted_linear_model(rd40, flex_model):
    # the contact elements' contracted tangent and the independent assembly of rvtool.protocols.flexible_modes
    # (operators times modes, the same contact tangents) are the same linear operator
    from rvtool.protocols.flexible_modes import linear_model
    q = rated_state(flex_model, rd40)
    assert_tangent_is_the_linear_model(flex_model, q, linear_model(flex_model, q, full=False))


def test_load_and_measure_maps_enter_force_and_gap_separately():
    from exudyn_user_elements.floating_ports import FloatingPorts, contract
    from rvtool.contact.evaluator import Evaluation

    class Coords:
        n = 2
    rng = np.random.default_rng(5)
    A, Al = rng.normal(size=(2, 3, 2)), rng.normal(size=(2, 3, 2))
    ports = FloatingPorts(Coords(), 2, base=[-1, 0], frame=[1, 1], sign=[-1, 1], maps=A, load_maps=Al)
    pose, eta = rng.normal(size=(2, 3)), rng.normal(size=2)
    _, T, Tl = ports.map(pose, eta)
    nb = 4                                     # 2 rigid + 2 virtual bodies
    J = rng.normal(size=(3 * nb, 3 * nb))
    Qb = rng.normal(size=3 * nb)
    ev = contract(Evaluation(Qb, J, 0 * J, None, None, True), T, 6, 8, Tl)
    Tf, Tlf = np.zeros((12, 8)), np.zeros((12, 8))
    Tf[:6, :6] = Tlf[:6, :6] = np.eye(6)
    Tf[6:], Tlf[6:] = T, Tl
    assert np.allclose(ev.Q, Tlf.T @ Qb, rtol=1e-13, atol=1e-13)
    assert np.allclose(ev.dQdq, Tlf.T @ J @ Tf, rtol=1e-12, atol=1e-12)
    assert not np.allclose(T, Tl)


def test_vibration_markers_list_the_wheel_modes(rd40, flex_model):
    # the spectra draw the retained wheel modes beside the mesh and bearing markers; a rigid model has none
    m = flex_model.marker_frequencies(rd40.input_speed_rpm)
    expected = sorted({float(f) for b in flex_model.flexible.bodies for f in b.frequencies_hz})
    assert m["wheel_modes_hz"] == expected and len(expected) >= 4
    assert "wheel_modes_hz" not in rvtool.build(rd40).marker_frequencies(rd40.input_speed_rpm)
