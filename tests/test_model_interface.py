"""The model interface is topology-neutral: a second, minimal topology built here from public
pieces (one eccentric wheel in a rigid pin ring, no output mechanism: the wheel's rotation is
the output) runs the quasi-static TE protocol and the stiffness protocol's condensed tangent
unchanged. Also: the cycloid builder's contract (families, per-contact sums, kinematics)."""
import numpy as np
import pytest
import exudyn as exu
from exudyn.itemInterface import (CoordinateConstraint, CoordinateSpringDamper, LoadCoordinate, MarkerNodeCoordinate,
                                  NodePointGround, NodeRigidBody2D, ObjectRigidBody2D)

from exudyn_user_elements.contact_element import ContactElement
from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design
from rvtool.contact.circle_set import GROUND, CircleContact, CircleContactSet, NormalLaw
from rvtool.contact.cycloid_set import CycloidPinSet, WheelPinMesh, secant_line_stiffness
from rvtool.errors import RvtoolInputError
from rvtool.geometry.cycloid import CycloidProfile
from rvtool.geometry.eccentric import journal_centre, journal_velocity
from rvtool.model import BodyCoordinate, Family, ReducerModel
from rvtool.protocols.precision import mesh_forces, quasi_static_te
from rvtool.protocols.stiffness import condensed_tangent
from rvtool.solver.continuation import Continuation

Z_PINS, R_PINS, R_PIN, E = 20, 0.04, 0.003, 0.001
WIDTH = 0.01


class WheelInRingKinematics:
    """Shaft at the input angle a; the wheel on the journal, turned by -a / z_g."""
    z_g = Z_PINS - 1

    def poses(self, angles):
        a = np.asarray(angles, float)
        q = np.zeros((len(a), 2, 3))
        q[:, 0, 2] = a
        q[:, 1, 0], q[:, 1, 1] = journal_centre(E, 0.0, a)
        q[:, 1, 2] = -a / self.z_g
        return q

    def velocities(self, angle, omega):
        vx, vy = journal_velocity(E, 0.0, angle, omega)
        return np.array([[0.0, 0.0, omega], [vx, vy, -omega / self.z_g]])


def wheel_in_ring():
    """The minimal topology: bodies shaft (x, y locked) and wheel; contacts: the pin mesh and
    one lumped eccentric bearing; regularization springs on the wheel."""
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0))
    ref = np.zeros((2, 3))
    ref[1, :2] = journal_centre(E, 0.0)
    nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=list(r))) for r in ref]
    for n, (m, J) in zip(nodes, ((0.2, 1e-5), (0.3, 2e-4))):
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, mass=m, inertia=J))

    def marker(b, c):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[b], coordinate=c))
    locks = [mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(0, c)])) for c in (0, 1)]
    drive = mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(0, 2)], offset=0.0))
    springs = [(1, c, k, mbs.AddObject(CoordinateSpringDamper(markerNumbers=[mg, marker(1, c)], stiffness=k)))
               for c, k in ((0, 100.0), (1, 100.0), (2, 0.1))]
    load = mbs.AddLoad(LoadCoordinate(markerNumber=marker(1, 2), load=0.0))
    profile = CycloidProfile(pin_circle_radius=R_PINS, pin_radius=R_PIN, n_pins=Z_PINS, generating_eccentricity=E)
    mesh = WheelPinMesh(profile=profile, wheel_body=1, pin_body=GROUND, face_width=WIDTH, name="wheel0",
                        normal=NormalLaw(law="line", stiffness=secant_line_stiffness(500.0, WIDTH), ramp_depth=1e-6))
    pins = CycloidPinSet([mesh], 2, name="pins")
    bearing = CircleContactSet(name="bearings", n_bodies=2, contacts=(CircleContact(
        body_a=0, body_b=1, centre_a=tuple(ref[1, :2]), centre_b=(0.0, 0.0), radius_a=0.01, radius_b=0.01 + 1e-12,
        internal=True, normal=NormalLaw(law="power", stiffness=1e10, exponent=10 / 9, ramp_depth=1e-6),
        name="eccentric_bearing0"),))
    elements = {"pins": ContactElement(mbs, nodes, pins), "bearings": ContactElement(mbs, nodes, bearing)}
    mbs.Assemble()
    families = {Family.PINS: ("pins", np.arange(len(pins.ids))), Family.ECCENTRIC_BEARINGS: ("bearings", np.arange(1))}
    return ReducerModel(design=None, SC=SC, mbs=mbs, body_names=("shaft", "wheel0"), nodes=nodes, elements=elements,
                        families=families, input=BodyCoordinate("shaft", "theta"), output=BodyCoordinate("wheel0", "theta"),
                        ratio=-(Z_PINS - 1), kinematics=WheelInRingKinematics(), drive=drive, load=load, reference=ref,
                        locks=locks, reg_springs=springs, mesh_period=2 * np.pi / Z_PINS)


def test_second_topology_runs_quasi_static_te_unchanged():
    m = wheel_in_ring()
    torque = 20.0
    angles = np.arange(6) * m.mesh_period / 3
    r = quasi_static_te(m, torque=torque, input_angles=angles)
    assert set(r["peak_loads"]) == {"pins", "eccentric_bearings"}
    # the resisting torque winds the output back: a negative mean TE of the order of T / K_t
    cont = Continuation(m, input_angle=0.0)
    q = cont.go_to(-np.sign(m.ratio) * torque)
    kt = condensed_tangent(m, q)
    te0 = q[m.output_index] - m.kinematic_output(0.0)
    # secant (T / te0) and tangent stiffness agree within the mesh's load-dependent stiffening
    # (Hertzian line contact: the secant lies below the tangent, by well under a factor 2)
    assert 0.5 * kt < abs(torque / te0) <= 1.0 + 1e-9 * kt + kt
    assert np.all(np.isfinite(r["te"])) and np.ptp(r["te"]) < abs(te0)
    # the wheel's load balances the torque through the pins: sum of moments of the pin forces
    F = mesh_forces(m, q)
    assert F.shape == (1, Z_PINS) and F.sum() > torque / R_PINS


def test_observation_per_contact_sums_the_slices():
    d = load_design(designs.path("rd40")).replace(wheels={"n_slices": 3})
    m = build(d, bearing_model="rolling")
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = Continuation(m).go_to(-np.sign(m.ratio) * d.rated_torque)
    ob = m.observe(q, Family.PINS)
    names, f = ob.per_contact()
    assert len(names) == d.n_wheels * d.pins.n_pins and names[0] == "wheel0/pin0"
    np.testing.assert_array_equal(f.reshape(d.n_wheels, -1), m.pin_forces(q))
    assert f.sum() == pytest.approx(ob.normal_force.sum(), rel=1e-12)
    rollers, fr = m.observe(q, Family.ECCENTRIC_BEARINGS).per_contact()
    assert rollers[0] == "eccentric_bearing0/roller0" and len(rollers) == d.n_wheels * d.eccentric_bearing.n_rollers
    assert set(m.family_peaks(q)) == {f.value for f in m.families}


def test_kinematic_state_poses_and_velocities():
    d = load_design(designs.path("rd40"))
    m = build(d)
    a, w, h = 0.3, 150.0, 1e-6
    ks = m.kinematic_state(a, w)
    # velocities are the angle derivative of the poses times the input speed (central difference)
    dp = (m.kinematic_state(a + h).poses - m.kinematic_state(a - h).poses) / (2 * h)
    np.testing.assert_allclose(ks.velocities, dp * w, rtol=1e-7, atol=1e-9)
    assert m.ratio == -(d.pins.n_pins - 1)
    assert ks.poses[m.body_index("flange"), 2] == pytest.approx(-a / (d.pins.n_pins - 1))


def test_interface_errors_name_the_parameter():
    m = build(load_design(designs.path("rd40")))
    with pytest.raises(RvtoolInputError, match="body = 'carrier'"):
        m.coordinate_index("carrier", "theta")
    with pytest.raises(RvtoolInputError, match="family = 'crank_bearings'"):
        m.observe(np.zeros(m.mbs.systemData.ODE2Size()), Family.CRANK_BEARINGS)
    with pytest.raises(RvtoolInputError, match="coordinate = 'z'"):
        BodyCoordinate("shaft", "z")
