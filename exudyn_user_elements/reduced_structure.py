"""Structural coordinates in an Exudyn system (Section "Assembly and allocation of elasticity").

Two paths:

* **Stationary (grounded) structure with port maps** -- :class:`ReducedStructure` adds
  the retained coordinates eta of a :class:`rvtool.structure.PortReducedModel` as one
  ``NodeGenericODE2`` and one ``ObjectGenericODE2`` with M = I, K = diag(Omega^2) and
  the full projected damping D. :class:`PortCouplingElement` couples rigid-body nodes
  and that structure through the constant map T_e of Eq. (port_runtime_transform):
  its force callback expands q_s = [q_r; eta] to q_e = T_e q_s (port displacements
  u = H eta), evaluates a contact law on q_e and returns Q_s = T_e^T Q_e; its Jacobian
  callback contracts the complete tangent, J_s = T_e^T J_e T_e, in Exudyn's
  convention for ``ObjectGenericODE2``: J_user = -(f_ODE2 dQ/dq + f_ODE2_t dQ/dq_t).
* **Floating flexible body (wheels, cranks)** -- :func:`add_floating_flexible_body`
  hands a parent :class:`rvtool.structure.FEModel` and a mode basis from
  :func:`rvtool.structure.floating_basis` to ``exudyn.FEM``'s
  ``ObjectFFRFreducedOrderInterface`` (``ObjectFFRFreducedOrder``: floating frame of
  reference with modal coordinates); ports become ``MarkerSuperElementPosition``
  markers through :func:`add_port_marker`.

Callbacks keep Exudyn's exact signatures; the maps live in :mod:`rvtool.structure.port_map`.
"""
import numpy as np
import exudyn as exu
from exudyn.itemInterface import MarkerSuperElementPosition, NodeGenericODE2, ObjectGenericODE2, VObjectGenericODE2

from rvtool.errors import RvtoolInputError
from rvtool.structure.port_map import expanded_map, reduce_force, reduce_tangent


class ReducedStructure:
    """Retained structural coordinates eta of a port-reduced model in ``mbs``.

    Attributes: node (NodeGenericODE2 number), object_number, reduced (the model), n.
    """

    def __init__(self, mbs, reduced, *, name="structure"):
        n = reduced.n_coordinates
        self.reduced = reduced
        self.n = n
        self.mbs = mbs
        self.node = mbs.AddNode(NodeGenericODE2(name=f"{name}:eta", numberOfODE2Coordinates=n,
                                                referenceCoordinates=[0.0] * n, initialCoordinates=[0.0] * n,
                                                initialCoordinates_t=[0.0] * n))
        self.object_number = mbs.AddObject(ObjectGenericODE2(
            name=name, nodeNumbers=[self.node], massMatrix=np.eye(n), stiffnessMatrix=np.diag(reduced.omega2),
            dampingMatrix=np.asarray(reduced.damping), visualization=VObjectGenericODE2(show=False)))

    def stiffness(self):
        """Stiffness (n, n) of eta [N/m per unit eta]: diag(omega^2) of the mass-normalized reduction,
        the matrix this element hands Exudyn."""
        return np.diag(np.asarray(self.reduced.omega2, float))

    def coordinate_indices(self):
        """Global ODE2 indices of eta (after Assemble)."""
        return np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.node), int)

    def coordinates(self, configuration=exu.ConfigurationType.Current):
        """eta of the node."""
        return np.asarray(self.mbs.GetNodeOutput(self.node, exu.OutputVariableType.Coordinates, configuration), float)

    def port_displacements(self, configuration=exu.ConfigurationType.Current):
        """Stacked port displacements u = H eta [m]."""
        return self.reduced.maps @ self.coordinates(configuration)


class PortCouplingElement:
    """Contact law on the expanded workspace, coupled through T_e (Eq. port_runtime_transform).

    mbs; rigid_nodes: node numbers whose ODE2 coordinates form q_r (in order; may be empty);
    structure: :class:`ReducedStructure`; law: callable (t, q_e, v_e) -> (Q_e, dQ_e/dq_e,
    dQ_e/dv_e) on q_e = [q_r; eta; u] with q_r the nodes' ODE2 coordinates (displacements from
    their reference) and u = H eta the stacked port displacements; sampled_ports: the ports
    the law sees (default all; any contact resolution over the same basis).
    """

    def __init__(self, mbs, rigid_nodes, structure: ReducedStructure, law, *, sampled_ports=None, name="ports"):
        rigid_nodes = [int(n) for n in rigid_nodes]
        n_r = sum(len(mbs.GetNodeParameter(n, "referenceCoordinates")) for n in rigid_nodes)
        H = structure.reduced.maps if sampled_ports is None else structure.reduced.sampled_maps(sampled_ports)
        if not callable(law):
            raise RvtoolInputError(f"law must be callable (t, q_e, v_e) -> (Q_e, J_q, J_v); got {type(law).__name__}")
        self.T_e = expanded_map(n_r, H)
        self.n_rigid = n_r
        self.n = self.T_e.shape[1]
        self.law = law
        self.name = name
        self._key, self._ev = None, None
        self.n_evaluations = 0
        self.object_number = mbs.AddObject(ObjectGenericODE2(
            name=name, nodeNumbers=rigid_nodes + [structure.node], massMatrix=np.zeros((self.n, self.n)),
            forceUserFunction=self.force_callback, jacobianUserFunction=self.jacobian_callback,
            visualization=VObjectGenericODE2(show=False)))

    def evaluate(self, t, q, q_t):
        """(Q_s, J_s, D_s) at integrated coordinates, cached per state."""
        q, q_t = np.asarray(q, float), np.asarray(q_t, float)
        key = (float(t), q.tobytes(), q_t.tobytes())
        if key != self._key:
            Q_e, J_e, D_e = self.law(t, self.T_e @ q, self.T_e @ q_t)
            self._ev = (reduce_force(self.T_e, Q_e), reduce_tangent(self.T_e, J_e), reduce_tangent(self.T_e, D_e))
            self._key = key
            self.n_evaluations += 1
        return self._ev

    # -- Exudyn callbacks (exact signatures) ------------------------------
    def force_callback(self, mbs, t, itemNumber, q, q_t):
        return self.evaluate(t, q, q_t)[0]

    def jacobian_callback(self, mbs, t, itemNumber, q, q_t, fODE2, fODE2_t):
        _, J, D = self.evaluate(t, q, q_t)
        return -(fODE2 * J + fODE2_t * D)


def fem_interface(model, basis):
    """``exudyn.FEM.FEMinterface`` holding the parent's mesh, M, K_e and the mode basis.

    model: unsupported :class:`FEModel` (no clamps: the frame carries the rigid motion);
    basis: dict(matrix=(3 nv, m), type=..., eigenvalues=...) from ``floating_basis``.
    Both use the node-interleaved ordering of FEMinterface.
    """
    from exudyn.FEM import FEMinterface
    if len(model.clamped_vertices):
        raise RvtoolInputError(f"the model has {len(model.clamped_vertices)} clamped vertices; a floating body "
                               "must be unsupported (valid: 0)")
    fem = FEMinterface()
    fem.nodes = {"Position": np.asarray(model.vertices, float)}
    fem.elements = [{"Name": "tet4", "Tet4": np.asarray(model.tetrahedra, int)}]
    fem.surface = [{"Name": "surface", "Trigs": np.asarray(model.surface_triangles, int)}]
    fem.massMatrix = model.mass.tocsr()
    fem.stiffnessMatrix = model.elastic_stiffness.tocsr()
    fem.modeBasis = {"matrix": np.asarray(basis["matrix"], float), "type": basis["type"]}
    fem.eigenValues = np.asarray(basis.get("eigenvalues", []), float)
    return fem


def add_floating_flexible_body(mbs, model, basis, *, position=(0.0, 0.0, 0.0), rotation_matrix=None,
                               velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0),
                               rayleigh=(0.0, 0.0), rigid_body_node_type="NodeType.RotationRxyz", name="flexible"):
    """Add a floating flexible body (ObjectFFRFreducedOrder) and return its
    ``ObjectFFRFreducedOrderInterface`` (attributes nRigidBody, nGenericODE2, oFFRFreducedOrder).

    position [m], rotation_matrix (3, 3), velocity [m/s], angular_velocity [rad/s] of the frame;
    rayleigh: (alpha [1/s], beta [s]) on the modal coordinates; rigid_body_node_type: Exudyn
    rotation parameters of the frame (default Tait-Bryan Rxyz: six coordinates, no algebraic
    constraint, regular for any rotation about z).
    """
    from exudyn.FEM import ObjectFFRFreducedOrderInterface
    fem = fem_interface(model, basis)
    cms = ObjectFFRFreducedOrderInterface(fem, rigidBodyNodeType=rigid_body_node_type)
    R = np.eye(3) if rotation_matrix is None else np.asarray(rotation_matrix, float)
    cms.AddObjectFFRFreducedOrder(mbs, positionRef=list(position), initialVelocity=list(velocity),
                                  rotationMatrixRef=R, initialAngularVelocity=list(angular_velocity),
                                  massProportionalDamping=rayleigh[0], stiffnessProportionalDamping=rayleigh[1],
                                  name=name)
    return cms


def add_port_marker(mbs, body, vertices, weights=None):
    """``MarkerSuperElementPosition`` at the weighted mean of mesh ``vertices`` of an FFRF body
    (object number ``body``); weights default to equal (summing to one)."""
    vertices = [int(v) for v in np.atleast_1d(vertices)]
    w = np.full(len(vertices), 1.0 / len(vertices)) if weights is None else np.asarray(weights, float)
    if w.shape != (len(vertices),) or abs(w.sum() - 1.0) > 1e-12:
        raise RvtoolInputError(f"weights must be {len(vertices)} values summing to 1; got sum {w.sum()}")
    return mbs.AddMarker(MarkerSuperElementPosition(bodyNumber=body, meshNodeNumbers=vertices,
                                                    weightingFactors=list(w)))
