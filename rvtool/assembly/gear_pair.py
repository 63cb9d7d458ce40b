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
from ..errors import RvtoolInputError
from ..geometry.involute import InvolutePair

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
