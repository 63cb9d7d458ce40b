"""Retained out-of-plane coordinates of a planar rigid body (issue 32): its axial translation z
and two small tilts gamma_x, gamma_y about its mounting centre, as one Exudyn ``NodeGenericODE2``
with three coordinates beside the body's ``NodeRigidBody2D`` (the planar body plus retained
axial and tilt coordinates; the in-plane rotation stays on the planar node).

The object carries the body's mass and transverse inertias diag(m, J_t, J_t) on these coordinates
(small tilts: the gyroscopic coupling with the in-plane rotation is not represented) and an optional
diagonal regularization stiffness (k_z, k_gamma, k_gamma) to ground, the weak springs every free
coordinate of a builder has (zero-load free play). A contact family reaches the coordinates as one
extra pose row (z, gamma_x, gamma_y) of its evaluator: this object is the ``structure`` of a
contact element and its own ``ports`` (P = I, one virtual body), the port mechanism of
:mod:`exudyn_user_elements.contact_element` with the identity map.
"""
import numpy as np
from exudyn.itemInterface import LoadCoordinate, MarkerNodeCoordinate, NodeGenericODE2, ObjectGenericODE2

#: the retained coordinates, in node order
OUT_OF_PLANE = ("z", "gamma_x", "gamma_y")


class RetainedTilt:
    """The out-of-plane coordinates of one body. mbs: the MainSystem; mass [kg], tilt_inertia
    [kg m^2]; stiffness: (k_z [N/m], k_gamma [N m/rad]) regularization to ground; name: node name."""

    n = 3
    n_virtual = 1
    n_eta = 3
    P = np.eye(3)

    def __init__(self, mbs, mass, tilt_inertia, stiffness=(0.0, 0.0), *, name="carrier_tilt"):
        self.mbs = mbs
        self.node = mbs.AddNode(NodeGenericODE2(name=f"{name}:z_gx_gy", numberOfODE2Coordinates=3,
                                                referenceCoordinates=[0.0] * 3, initialCoordinates=[0.0] * 3,
                                                initialCoordinates_t=[0.0] * 3))
        k_z, k_g = stiffness
        self.object = mbs.AddObject(ObjectGenericODE2(name=name, nodeNumbers=[self.node],
                                                      massMatrix=np.diag([mass, tilt_inertia, tilt_inertia]),
                                                      stiffnessMatrix=np.diag([k_z, k_g, k_g])))
        self.loads = tuple(mbs.AddLoad(LoadCoordinate(markerNumber=mbs.AddMarker(MarkerNodeCoordinate(
            nodeNumber=self.node, coordinate=c)), load=0.0)) for c in range(3))
        self.structure = self               # the port interface: the coordinates are their own structure

    def set_load(self, axial_force=0.0, moment=(0.0, 0.0)):
        """External axial force [N] and moment (M_x, M_y) [N m] on the body at its mounting centre."""
        for load, v in zip(self.loads, (axial_force, *moment)):
            self.mbs.SetLoadParameter(load, "load", float(v))

    @property
    def coordinate_indices(self):
        """Global ODE2 indices of (z, gamma_x, gamma_y) (after Assemble)."""
        return np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.node), int)

    def coordinates(self, q):
        """(z [m], gamma_x, gamma_y [rad]) from a global ODE2 vector."""
        return np.asarray(q, float)[self.coordinate_indices]
