"""Floating flexible bodies in the planar Exudyn system (:mod:`rvtool.structure.floating_ports`).

:class:`ModalCoordinates` adds the modal coordinates zeta of every flexible body of a reducer as
one ``NodeGenericODE2`` with one ``ObjectGenericODE2`` (M = I, K = diag(omega^2), D =
diag(2 zeta_d omega), block-diagonal over the bodies); the body's planar rigid node is its
floating frame (mean axis: no linear inertia coupling, see the structure module). It has the
interface of :class:`~exudyn_user_elements.reduced_structure.ReducedStructure` that the contact
elements, the stiffness protocols and the budget read (``node``, ``n``, ``stiffness()``,
``coordinate_indices()``, ``coordinates()``).

:class:`FloatingPorts` is a state-dependent port map of one contact family: the family's
evaluator sees ``n_virtual`` extra planar bodies ("virtual bodies") whose poses are

    x_v = x_base + s_v [R(theta_w) A_v(x) zeta ; a_v zeta]

with x_base the pose of a rigid body of the element (or zero: ground), w the flexible body whose
frame rotates the map, A_v (2, m) the body-frame displacement of the port per unit zeta (a
profile port interpolated at the contact, a hole's or the bore's rigid fit), a_v its rotation
and s_v = -1 where the virtual body stands for the partner (a ring pin or an output pin shifted
by minus the wheel's displacement at the contact: the same gap to first order) or +1 where it is
the flexible body's own feature (the bore). The element contracts the family's forces and
tangent with the Jacobian T = d x_v / d q (``ContactElement._contract``): Q = T^T Q_b,
dQ/dq = T^T (dQ_b/dq_b) T. T holds the derivatives in the frame rotation and in zeta; the
dependence of A_v on the contact location (the port a pin meets moves along the flank) and the
geometric term (dT^T/dq) Q_b are left out of the tangent (both of relative size |u| / r).
With zeta = 0 every virtual pose equals its base pose exactly, so a frozen flexible body gives
the rigid body's forces bit for bit.
"""
import numpy as np
import exudyn as exu
from exudyn.itemInterface import (CoordinateConstraint, MarkerNodeCoordinate, NodeGenericODE2, ObjectGenericODE2,
                                  VObjectGenericODE2)

from rvtool.errors import RvtoolInputError


class ModalCoordinates:
    """Modal coordinates of the floating flexible bodies of one system.

    mbs; bodies: {name: :class:`~rvtool.structure.floating_ports.PlanarModalBody`} in order (any
    modal body with ``omega2``, ``damping``, ``n_modes``); frozen: hold every modal coordinate at
    zero (True), or those of the bodies named in a collection (constraints to ``ground_marker``,
    returned in ``locks``). ``offsets[name]`` is the first index of a body's coordinates in zeta.
    """

    def __init__(self, mbs, bodies, *, frozen=False, ground_marker=None, name="flexible_bodies"):
        if not bodies:
            raise RvtoolInputError("ModalCoordinates needs at least one flexible body")
        self.bodies = dict(bodies)
        self.offsets, n = {}, 0
        for nm, b in self.bodies.items():
            self.offsets[nm] = n
            n += b.n_modes
        self.n = n
        self.mbs = mbs
        self.omega2 = np.concatenate([b.omega2 for b in self.bodies.values()])
        D = np.zeros((n, n))
        for nm, b in self.bodies.items():
            o = self.offsets[nm]
            D[o:o + b.n_modes, o:o + b.n_modes] = b.damping
        self.damping = D
        self.node = mbs.AddNode(NodeGenericODE2(name=f"{name}:zeta", numberOfODE2Coordinates=n,
                                                referenceCoordinates=[0.0] * n, initialCoordinates=[0.0] * n,
                                                initialCoordinates_t=[0.0] * n))
        self.object_number = mbs.AddObject(ObjectGenericODE2(
            name=name, nodeNumbers=[self.node], massMatrix=np.eye(n), stiffnessMatrix=np.diag(self.omega2),
            dampingMatrix=D, visualization=VObjectGenericODE2(show=False)))
        self.locks = []
        held = range(n) if frozen is True else [c for nm in (frozen or ()) for c in range(n)[self.slice(nm)]]
        if len(held):
            if ground_marker is None:
                raise RvtoolInputError("frozen modal coordinates need a ground coordinate marker")
            for c in held:
                m = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=self.node, coordinate=c))
                self.locks.append(mbs.AddObject(CoordinateConstraint(markerNumbers=[ground_marker, m])))

    def slice(self, name):
        o = self.offsets[name]
        return slice(o, o + self.bodies[name].n_modes)

    def stiffness(self):
        """diag(omega^2) (n, n): the modal stiffness this element hands Exudyn."""
        return np.diag(self.omega2)

    def coordinate_indices(self):
        """Global ODE2 indices of zeta (after Assemble)."""
        return np.asarray(self.mbs.systemData.GetNodeLTGODE2(self.node), int)

    def coordinates(self, configuration=exu.ConfigurationType.Current):
        return np.asarray(self.mbs.GetNodeOutput(self.node, exu.OutputVariableType.Coordinates, configuration), float)


def rotation(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


class FloatingPorts:
    """State-dependent port map of one contact family (module docstring).

    structure: the :class:`ModalCoordinates`; n_rigid_bodies: rigid bodies of the element (their
    coordinates come first); base (n_v,): base body of each virtual body (-1: ground); frame
    (n_v,): the flexible body's rigid-body index (its theta rotates the map); sign (n_v,): s_v;
    maps: callable(pose (nb, 3)) -> A (n_v, 3, n_eta) in the body frames (rows x, y, theta;
    columns all of zeta), or a constant array of that shape: where a port *measures* its
    displacement; load_maps: the same for where the contact force is *applied* (a port whose
    load is spread on the surface and whose displacement is measured below it, the separation
    of local and global deformation; None: the same as ``maps``). The element then returns
    Q = T_l^T Q_b and dQ/dq = T_l^T (dQ_b/dq_b) T_m.
    """
    state_dependent = True

    def __init__(self, structure, n_rigid_bodies, base, frame, sign, maps, load_maps=None):
        self.structure = structure
        self.n_rigid_bodies = int(n_rigid_bodies)
        self.base = np.asarray(base, int)
        self.frame = np.asarray(frame, int)
        self.sign = np.asarray(sign, float)
        self.n_virtual = len(self.base)
        self.n_eta = structure.n
        if not (len(self.frame) == len(self.sign) == self.n_virtual) or self.n_virtual < 1:
            raise RvtoolInputError("base, frame and sign must have one entry per virtual body (at least one)")
        if self.base.max() >= n_rigid_bodies or self.frame.min() < 0 or self.frame.max() >= n_rigid_bodies:
            raise RvtoolInputError(f"base and frame must index the element's {n_rigid_bodies} rigid bodies")
        self._maps = maps if callable(maps) else (lambda pose, A=np.asarray(maps, float): A)
        self._load_maps = None if load_maps is None else (
            load_maps if callable(load_maps) else (lambda pose, A=np.asarray(load_maps, float): A))

    def map(self, pose, eta):
        """(virtual poses (n_v, 3), T_m (3 n_v, 3 nb + n_eta), T_l) at rigid poses ``pose`` (nb, 3)
        (absolute) and modal coordinates ``eta``: T_m = d x_v / d q (measurement maps), T_l the
        same with the load maps (T_l is T_m where they are the same)."""
        pv, T = self._map(pose, eta, self._maps(pose))
        if self._load_maps is None:
            return pv, T, T
        return pv, T, self._map(pose, eta, self._load_maps(pose))[1]

    def _map(self, pose, eta, A):
        nv, nb = self.n_virtual, self.n_rigid_bodies
        th = pose[self.frame, 2]
        c, s = np.cos(th), np.sin(th)
        local = A @ eta                                       # (n_v, 3): body-frame displacement and rotation
        sg = self.sign
        out = np.zeros((nv, 3))
        out[:, 0] = sg * (c * local[:, 0] - s * local[:, 1])
        out[:, 1] = sg * (s * local[:, 0] + c * local[:, 1])
        out[:, 2] = sg * local[:, 2]
        T = np.zeros((3 * nv, 3 * nb + self.n_eta))
        rows = np.arange(nv)
        has = self.base >= 0
        for k in range(3):
            T[3 * rows[has] + k, 3 * self.base[has] + k] = 1.0
        out[has] += pose[self.base[has]]
        # d/dtheta of R(theta) l = R'(theta) l
        T[3 * rows, 3 * self.frame + 2] += sg * (-s * local[:, 0] - c * local[:, 1])
        T[3 * rows + 1, 3 * self.frame + 2] += sg * (c * local[:, 0] - s * local[:, 1])
        e = 3 * nb
        T[3 * rows, e:] = sg[:, None] * (c[:, None] * A[:, 0] - s[:, None] * A[:, 1])
        T[3 * rows + 1, e:] = sg[:, None] * (s[:, None] * A[:, 0] + c[:, None] * A[:, 1])
        T[3 * rows + 2, e:] = sg[:, None] * A[:, 2]
        return out, T


def contract(ev, T, n_rigid, n, T_load=None):
    """The evaluation ``ev`` on [rigid bodies; virtual bodies] contracted to the element's
    coordinates [q_r; eta] with T_full = [[I, 0]; T] (Q = T_full^T Q_b, J = T_full^T J_b T_full;
    with ``T_load``: Q = T_l,full^T Q_b, J = T_l,full^T J_b T_full).
    Only the virtual rows with a non-zero tangent enter the product (the others are not in
    contact: an exact rewrite), the tangents are contracted when first read, and the products are
    split to stay single-threaded (:func:`~exudyn_user_elements.merged_element.small_matmul`)."""
    from .merged_element import ContractedEvaluation, small_matmul
    nr = n_rigid
    Tl = T if T_load is None else T_load
    Q = np.zeros(n)
    Q[:nr] = ev.Q[:nr]
    Q += Tl.T @ ev.Q[nr:]

    def mat(J):
        mask = np.any(J[nr:] != 0, axis=1) | np.any(J[:, nr:] != 0, axis=0)
        a = np.flatnonzero(mask)
        idx = np.concatenate([np.arange(nr), nr + a])
        Js = J[np.ix_(idx, idx)]
        E = np.zeros((nr + len(a), n))
        E[:nr, :nr] = np.eye(nr)
        E[nr:] = T[a]
        if Tl is T:
            El = E
        else:
            El = E.copy()
            El[nr:] = Tl[a]
        return small_matmul(El.T, small_matmul(Js, E))
    return ContractedEvaluation(Q, lambda: mat(ev.dQdq), lambda: mat(ev.dQdv), ev.obs, ev.trial_history, ev.finite)
