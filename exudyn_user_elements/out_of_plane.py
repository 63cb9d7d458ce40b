"""Retained out-of-plane coordinates of planar rigid bodies (issue 32): for each body its axial
translation z and two small tilts gamma_x, gamma_y about its own centre (the mounting centre of a
flange, the mid-plane of a wheel, the bearing centre of a crank), as one Exudyn ``NodeGenericODE2``
with three coordinates per body beside the bodies' ``NodeRigidBody2D`` (the planar bodies plus their
retained axial and tilt coordinates; the in-plane rotation stays on the planar node).

The object carries each body's mass and transverse inertias diag(m, J_t, J_t) on its coordinates
(small tilts: the gyroscopic coupling with the in-plane rotation is not represented) and an optional
diagonal regularization stiffness (k_z, k_gamma, k_gamma) to ground, the weak springs every free
coordinate of a builder has (zero-load free play). A contact family reaches the coordinates as one
extra pose row (z, gamma_x, gamma_y) per body of its evaluator, appended after the planar bodies in
the order of ``names``: this object is the ``structure`` of a contact element and its own ``ports``
(P = I, one virtual body per retained body), the port mechanism of
:mod:`exudyn_user_elements.contact_element` with the identity map.
"""
import numpy as np
from exudyn.itemInterface import LoadCoordinate, MarkerNodeCoordinate, NodeGenericODE2, ObjectGenericODE2

from rvtool.errors import RvtoolInputError

#: the retained coordinates of one body, in node order
OUT_OF_PLANE = ("z", "gamma_x", "gamma_y")


class RetainedTilt:
    """The out-of-plane coordinates of one or more bodies. mbs: the MainSystem; mass [kg] and
    tilt_inertia [kg m^2]: one value (one body) or one per body; stiffness: (k_z [N/m], k_gamma
    [N m/rad]) regularization to ground; name: node name; names: the bodies' names (pose-row order;
    default ``(name,)`` for one body)."""

    n_virtual = 1

    def __init__(self, mbs, mass, tilt_inertia, stiffness=(0.0, 0.0), *, name="carrier_tilt", names=None):
        mass, inertia = np.atleast_1d(np.asarray(mass, float)), np.atleast_1d(np.asarray(tilt_inertia, float))
        names = (name,) if names is None else tuple(names)
        if not (len(mass) == len(inertia) == len(names) >= 1):
            raise RvtoolInputError(f"RetainedTilt: mass ({len(mass)}), tilt_inertia ({len(inertia)}) and names "
                                   f"({len(names)}) must have one entry per body")
        self.mbs, self.names = mbs, names
        self.n_virtual = nb = len(names)
        self.n = self.n_eta = 3 * nb
        self.P = np.eye(3 * nb)
        self.node = mbs.AddNode(NodeGenericODE2(name=f"{name}:z_gx_gy", numberOfODE2Coordinates=3 * nb,
                                                referenceCoordinates=[0.0] * (3 * nb),
                                                initialCoordinates=[0.0] * (3 * nb),
                                                initialCoordinates_t=[0.0] * (3 * nb)))
        k_z, k_g = stiffness
        M = np.column_stack([mass, inertia, inertia]).ravel()
        #: the regularization stiffness of every coordinate [N/m, N m/rad] (the object's diagonal)
        self.stiffness_diagonal = np.array([k_z, k_g, k_g] * nb, float)
        self.object = mbs.AddObject(ObjectGenericODE2(name=name, nodeNumbers=[self.node], massMatrix=np.diag(M),
                                                      stiffnessMatrix=np.diag(self.stiffness_diagonal)))
        self.loads = tuple(mbs.AddLoad(LoadCoordinate(markerNumber=mbs.AddMarker(MarkerNodeCoordinate(
            nodeNumber=self.node, coordinate=c)), load=0.0)) for c in range(3 * nb))
        self.structure = self               # the port interface: the coordinates are their own structure

    def row(self, body):
        """Pose row (among the virtual bodies) of the body named ``body`` (or its index)."""
        if isinstance(body, (int, np.integer)) and 0 <= body < self.n_virtual:
            return int(body)
        if body in self.names:
            return self.names.index(body)
        raise RvtoolInputError(f"body = {body!r} retains no out-of-plane coordinates; valid: {list(self.names)}")

    def set_load(self, axial_force=0.0, moment=(0.0, 0.0), body=0):
        """External axial force [N] and moment (M_x, M_y) [N m] on ``body`` (name or row; default the
        first) at its centre."""
        r = self.row(body)
        for load, v in zip(self.loads[3 * r:3 * r + 3], (axial_force, *moment)):
            self.mbs.SetLoadParameter(load, "load", float(v))

    @property
    def coordinate_indices(self):
        """Global ODE2 indices of (z, gamma_x, gamma_y) of every body, body after body (after Assemble)."""
        return np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.node), int)

    def coordinates(self, q, body=0):
        """(z [m], gamma_x, gamma_y [rad]) of ``body`` (name or row; default the first) from a global ODE2 vector."""
        r = self.row(body)
        return np.asarray(q, float)[self.coordinate_indices[3 * r:3 * r + 3]]
