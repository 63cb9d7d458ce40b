"""Flexible cycloid wheels as floating bodies (issue 33, Deliver 2): the switch, the port maps, the
frozen-body check against the rigid model, the backends' refusals and a short driven run.
Coarse wheel mesh (the builder's default size), short runs."""
import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.assembly.spec import replace
from rvtool.errors import RvtoolInputError
from rvtool.units import ARCSEC_PER_RAD

QUARTER_MESH = np.arange(4) * 2 * np.pi / (40 * 4)     # 4 points over one RD-40 mesh cycle


@pytest.fixture(scope="module")
def rd40():
    return rvtool.load_design(designs.path("rd40"))


COARSE = {"mesh_size": 0.006, "samples_per_tooth": 4}
"""A coarse wheel body (issue 30's mesh) for short tests."""


def flexible(design, **kw):
    return replace(design, wheels={"dynamics": {"model": "flexible", "n_modes": 4, "static_orders": 1, **kw},
                                   "structure": COARSE})


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
    from rvtool.protocols.precision import quasi_static_te
    def run(model):
        qs = []
        te = quasi_static_te(model, torque=rd40.rated_torque, input_angles=QUARTER_MESH, backend="exudyn",
                             record=lambda k, a, q: qs.append([model.body_pose(q, b) - model.reference[b]
                                                               for b in range(len(model.body_names))]))["te"]
        return np.asarray(te), np.asarray(qs)
    te_r, q_r = run(rvtool.build(rd40))
    frozen_model = rvtool.build(flexible(rd40, frozen=True))
    te_f, q_f = run(frozen_model)
    # the bounds (those of the golden backend tests): TE 1e-6 arcsec, equilibria 1e-9 relative (held
    # modal coordinates: the virtual bodies sit exactly on their base poses, so only the larger Newton
    # system's round-off and stopping point differ)
    assert np.abs(te_f - te_r).max() * ARCSEC_PER_RAD < 1e-6
    assert np.abs(q_f - q_r).max() <= 1e-9 * np.abs(q_r).max()
    # and the held coordinates are reported as fixed
    zeta = frozen_model.structures["wheels"].coordinate_indices()
    assert set(zeta) <= frozen_model.fixed_coordinates()


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
    from rvtool.solver.backends import get as get_backend
    from rvtool.solver.backends.base import FLEXIBLE_BODIES_REASON
    for name, task in (("device", "equilibria"), ("fused", "dynamic"), ("replica", "equilibria")):
        sup = get_backend(name).supports(flex_model, task)
        assert not sup.ok
        assert any(FLEXIBLE_BODIES_REASON in r for r in sup.reasons), (name, sup.reasons)


def test_flexible_wheels_refuse_the_ported_wheel_body(rd40):
    with pytest.raises(RvtoolInputError, match="counted twice"):
        rvtool.build(replace(flexible(rd40), wheels={"body": "ported"}))


def test_short_driven_run_moves_the_modes(rd40, flex_model):
    from rvtool.protocols import vibration as V
    from rvtool.solver import RunSpec
    speed = rd40.input_speed_rpm
    duration = 20 * 2e-5
    proto = V.VibrationProtocol(speed_rpm=speed, torque=rd40.rated_torque, duration=duration, sample_step=2e-5)
    run = V.driven_response(flex_model, proto, RunSpec(end_time=duration, step=2e-5, abs_tol=1e-6, rel_tol=1e-8))
    assert run["record"].accepted_steps >= 20
    assert np.all(np.isfinite(run["responses"]["torsion"]))
    assert np.abs(flex_model.structures["wheels"].coordinates()).max() > 0


def test_element_tangent_equals_the_mounted_linear_model(rd40, flex_model):
    # the contact elements' contracted tangent (what Newton and the stiffness protocols use) and the
    # independent assembly of rvtool.protocols.flexible_modes (operators times modes, the same contact
    # tangents) are the same linear operator: equal spectra of K over the free coordinates
    from rvtool.protocols.flexible_modes import linear_model
    from rvtool.protocols.stiffness import assembled_stiffness
    from rvtool.solver.continuation import Continuation
    m = flex_model
    q = Continuation(m, input_angle=0.0).go_to(-np.sign(m.ratio) * rd40.rated_torque)
    K = assembled_stiffness(m, q)
    free = sorted(set(range(len(q))) - set(m.fixed_coordinates()))
    Ke = K[np.ix_(free, free)]
    Kl, _, fl, _ = linear_model(m, q, full=False)
    Kl = Kl[fl][:, fl].toarray()
    ev_e = np.sort(np.linalg.eigvalsh(0.5 * (Ke + Ke.T)))
    ev_l = np.sort(np.linalg.eigvalsh(0.5 * (Kl + Kl.T)))
    # round-off of the two summation orders, relative to the largest eigenvalue (contact stiffness ~1e9)
    assert np.abs(ev_e - ev_l).max() < 1e-9 * np.abs(ev_e).max()


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
