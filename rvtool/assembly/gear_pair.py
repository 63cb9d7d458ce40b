"""Builder: an involute gear pair on two rigid gear bodies rotating about fixed centres, as
an Exudyn system, with quasi-static equilibria at prescribed input angles.

Bodies (planar rigid, x, y, theta): 0 gear A (the driving pinion, centre at the origin),
1 gear B (centre at (a, 0); internal gears included). Both centres are held by coordinate
constraints; gear A's rotation is prescribed (an angle), gear B carries a load torque about
its axis. The mesh is one :class:`~rvtool.contact.involute_set.InvoluteContactSet` in one
:class:`~exudyn_user_elements.contact_element.ContactElement`.
Kinematic state: theta_B = theta_B0 + ratio theta_A (rigid conjugate action,
:meth:`InvolutePair.mesh_phase`); transmission error TE = theta_B - theta_B,kin [rad].
"""
from dataclasses import dataclass
import math

import numpy as np
import exudyn as exu
from exudyn.itemInterface import (CoordinateConstraint, LoadCoordinate, MarkerNodeCoordinate, NodePointGround,
                                  NodeRigidBody2D, ObjectRigidBody2D)

from exudyn_user_elements.contact_element import ContactElement

from ..contact.involute_set import GearMesh, InvoluteContactSet
from ..errors import RvtoolInputError, SolverFailure
from ..geometry.involute import InvolutePair
from ..solver.static import static_settings

STEEL_DENSITY = 7850.0
"""kg/m^3 (gear body inertia as a solid disk on the reference circle; irrelevant to statics)."""


@dataclass
class GearPairModel:
    """An assembled gear-pair system (see module docstring)."""
    pair: InvolutePair
    SC: object
    mbs: object
    element: ContactElement
    contact_set: InvoluteContactSet
    nodes: tuple
    drive: int
    load: int
    phase: float

    def kinematic_angle_b(self, theta_a):
        return self.phase + self.pair.ratio * theta_a

    def set_input_angle(self, theta_a):
        self.mbs.SetObjectParameter(self.drive, "offset", float(theta_a))

    def set_output_torque(self, torque):
        """Load torque on gear B [N m] (see :meth:`line_load_torque` for the sign that loads line 0)."""
        self.mbs.SetLoadParameter(self.load, "load", float(torque))

    def line_load_torque(self, line_load):
        """Torque on gear B [N m] that loads the drive flanks (line 0) with ``line_load`` [N/m]
        along the line of action over the face width: T_B = -w b r_bB (the contact torque on B
        from line 0 is +F r_bB for an external pair, -F r_bB for an internal one)."""
        return -self.pair.eps * line_load * self.pair.gear_a.face_width * self.pair.gear_b.base_radius

    #: stiffness per face width [N/m^2] of the first guess of a loaded state (14 N/(mm um), a
    #: typical single-pair value); only a Newton starting point, never a result
    GUESS_STIFFNESS = 14e9

    def loaded_guess(self, theta_a, line_load):
        """First guess of gear B's angle under ``line_load`` [N/m]: the kinematic angle backed off
        by the approach w / GUESS_STIFFNESS along the line of action."""
        back = line_load / self.GUESS_STIFFNESS / self.pair.gear_b.base_radius
        return self.kinematic_angle_b(theta_a) - self.pair.eps * back

    def state_vector(self, theta_a, theta_b):
        q = np.zeros(self.mbs.systemData.ODE2Size())
        q[np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.nodes[0]))[2]] = theta_a
        q[np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.nodes[1]))[2]] = theta_b
        return q

    def angles(self, q):
        ia = np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.nodes[0]))[2]
        ib = np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.nodes[1]))[2]
        return float(q[ia]), float(q[ib])

    def pose(self, theta_a, theta_b):
        """Body poses (2, 3) of the contact set."""
        return np.array([[0.0, 0.0, theta_a], [self.pair.a, 0.0, theta_b]])


def build_gear_pair(pair: InvolutePair, *, n_slices=1, modification_a=None, modification_b=None, backend="warp",
                    precision="float64", device="cpu", mesh_kwargs=None):
    """Exudyn system of ``pair`` on fixed centres (see module docstring); returns :class:`GearPairModel`.

    mesh_kwargs: further :class:`GearMesh` fields (friction, damping, tilt, window, lines, clearance).
    """
    if not isinstance(pair, InvolutePair):
        raise RvtoolInputError(f"pair must be an InvolutePair; got {type(pair).__name__}")
    mesh = GearMesh(pair=pair, body_a=0, body_b=1, n_slices=n_slices, **(mesh_kwargs or {}))
    cset = InvoluteContactSet([mesh], 2, backend=backend, precision=precision, device=device, name="mesh")
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    phase = pair.mesh_phase(0)
    nodes = []
    for g, x0, th0 in ((pair.gear_a, 0.0, 0.0), (pair.gear_b, pair.a, phase)):
        r = g.reference_radius
        mass = STEEL_DENSITY * math.pi * r * r * g.face_width
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[x0, 0.0, th0]))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=n, physicsMass=mass, physicsInertia=0.5 * mass * r * r))
        nodes.append(n)
    ng = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))

    def marker(b, c):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[b], coordinate=c))

    for b in range(2):
        for c in range(2):
            mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(b, c)]))
    drive = mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, marker(0, 2)], offset=0.0))
    load = mbs.AddLoad(LoadCoordinate(markerNumber=marker(1, 2), load=0.0))
    el = ContactElement(mbs, nodes, cset)
    mbs.Assemble()
    return GearPairModel(pair, SC, mbs, el, cset, tuple(nodes), drive, load, phase)


class GearPairStatics:
    """Warm-started static equilibria of a :class:`GearPairModel` (Exudyn's static solver with the
    contact element's analytic tangent). abs_tol [N], rel_tol [-]: Newton tolerances."""

    def __init__(self, model: GearPairModel, *, abs_tol=1e-8, rel_tol=1e-12, max_iterations=40):
        self.model = model
        self.settings = static_settings(abs_tol=abs_tol, rel_tol=rel_tol, max_iterations=max_iterations,
                                        solver_type=exu.LinearSolverType.EXUdense)
        self.newton_iterations = 0
        model.contact_set.set_velocity_tangent(False)

    def solve(self, theta_a, theta_b_guess):
        """Equilibrium at input angle theta_a from the guess of gear B's angle; returns theta_B.
        A failed Newton solve is retried from :meth:`GearPairModel.loaded_guess` at the current
        load, then with Exudyn's load ramp. Raises :class:`SolverFailure` naming the angle."""
        m = self.model
        m.set_input_angle(theta_a)
        torque = float(m.mbs.GetLoadParameter(m.load, "load"))
        line_load = -torque / (m.pair.eps * m.pair.gear_a.face_width * m.pair.gear_b.base_radius)
        for guess, ramp in ((theta_b_guess, False), (m.loaded_guess(theta_a, line_load), False),
                            (m.loaded_guess(theta_a, line_load), True)):
            q0 = m.state_vector(theta_a, guess) - m.state_vector(0.0, m.phase)
            st = self.settings.staticSolver
            st.useLoadFactor = ramp
            st.numberOfLoadSteps = 20 if ramp else 1
            st.adaptiveStep = ramp
            m.mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
            solver = exu.MainSolverStatic()
            try:
                ok = solver.SolveSystem(m.mbs, self.settings)
            except Exception:  # Exudyn raises on a singular tangent: the next start is tried
                ok = False
            self.newton_iterations += int(solver.it.newtonStepsCount)
            q = np.array(m.mbs.systemData.GetODE2Coordinates())
            if ok and np.all(np.isfinite(q)):
                return m.angles(q)[1] + m.phase
        raise SolverFailure(f"no static equilibrium of the gear pair at theta_A = {theta_a:.9g} rad")

    def observations(self, theta_a, theta_b):
        """The contact set's per-row observations at the given angles (bodies at rest)."""
        m = self.model
        return m.contact_set.evaluate(m.pose(theta_a, theta_b), np.zeros((2, 3))).obs
