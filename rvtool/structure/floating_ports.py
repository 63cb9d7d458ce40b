"""Floating flexible bodies in planar dynamic runs: the switch, the in-plane modal body and its ports.

A wheel (or crank) switched to ``dynamics.model = "flexible"`` keeps its planar rigid node
(x, y, theta): that node is the floating frame. Its elastic motion relative to the frame is a
combination of ``n_modes`` free-free elastic modes of the body's 3-D FE model (NGSolve
tetrahedra, :func:`rvtool.structure.floating_basis`), mass-normalized and M-orthogonal to the six
rigid-body modes, i.e. the frame is the body's mean axis (Eq. ffrf of the paper: the floating
frame of reference with modal coordinates zeta, ``ObjectFFRFreducedOrder`` of Exudyn restricted
to the plane):

    u(X) = R(theta) Phi(X) zeta,   M = blockdiag(M_frame, I),   K = blockdiag(0, diag(omega^2)).

Because the modes are M-orthogonal to the rigid modes about the frame origin (the body's centre
of mass), the linear inertia coupling between frame and modes vanishes (int rho Phi dV = 0,
int rho X x Phi dV = 0); what is left out is the quadratic-velocity coupling (centrifugal and
Coriolis terms) of relative size (Omega_frame / omega_1)^2, reported by
:meth:`PlanarModalBody.neglected_coupling` (1e-8 for RD-40's wheels at rated speed). Only modes
whose kinetic energy lies mostly in the plane are kept (``IN_PLANE_FRACTION``): the planar contacts
do no work on the out-of-plane (plate) modes of a symmetric wheel.

Ports (every contact family on the body couples through them):

* **profile**: one port station per profile sample (mean of its vertices through the face width);
  the elastic displacement at a contact point is interpolated linearly in the polar angle
  between the two neighbouring stations (:meth:`PlanarModalBody.profile_map`);
* **bore**: the least-squares rigid motion (x, y, theta) of the bore's ports (the eccentric
  bearing sees the bore move as a rigid ring; ovalization is not passed to the lumped bearing);
* **holes**: per output-pin hole, the mean translation of its ports.

The contact force f acting at a port maps to the modal coordinates as Phi_port^T R^T f and to the
frame as the rigid body's force and moment (virtual work of the force at the material point;
the geometric-stiffness terms dT^T/dq f of relative size |u| / r are left out of the tangent,
not of the residual). :mod:`exudyn_user_elements.floating_ports` mounts it in Exudyn.
"""
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import RvtoolInputError
from ..validation import check_range

MODELS = ("rigid", "flexible")

IN_PLANE_FRACTION = 0.5
"""A free-free mode is kept when at least this fraction of its kinetic energy (mass-normalized:
phi^T M phi = 1) lies in its x, y components; in-plane modes of a wheel symmetric about its
midplane carry ~0.9-1, plate modes ~0.1 or less."""


@dataclass(frozen=True, kw_only=True)
class FloatingDynamics:
    """How a body moves in driven and quasi-static runs (design sub-tables ``[wheels.dynamics]``,
    ``[cranks.dynamics]``).

    model: "rigid" (the default and the "nothing" variant: the planar rigid body, no mesh, no
        cost) or "flexible" (a floating flexible body: the rigid node is the frame, ``n_modes``
        in-plane free-free modes of the body's FE model are added as coordinates, and every
        contact family on the body couples through its ports).
    n_modes: retained in-plane elastic modes per body [-].
    damping_ratio: modal damping ratio zeta of every retained mode [-] (assumed; steel
        structures 0.005-0.05).
    frozen: true holds the modal coordinates at zero (a verification switch: the flexible
        model must then reproduce the rigid one).
    static_orders: static correction of the basis [-]: -1 none (free-free modes only); J >= 0
        adds the inertia-relief static responses to radial and tangential profile loads of
        Fourier orders 0..J and to unit loads at the bore and at each hole, orthogonalized
        against the modes (Ritz vectors: a free-free basis alone misses the quasi-static
        compliance under the contacts). For a crank (``[cranks.dynamics]``, a beam:
        :mod:`rvtool.structure.crank_modes`) the modes are its free-free bending and torsion
        modes, and any J >= 0 adds the responses to unit x, y forces and a unit torque at every
        station (gear, journals, tapered rows).
    """
    model: str = "rigid"
    n_modes: int = 8
    damping_ratio: float = 0.02
    frozen: bool = False
    static_orders: int = 8

    def __post_init__(self):
        if self.model not in MODELS:
            raise RvtoolInputError(f"model = {self.model!r}; valid choices are {list(MODELS)}")
        if isinstance(self.n_modes, bool) or not isinstance(self.n_modes, int) or not 1 <= self.n_modes <= 60:
            raise RvtoolInputError(f"n_modes = {self.n_modes!r} is outside the valid range [1, 60] (integer)")
        check_range("damping_ratio", self.damping_ratio, 0.0, 1.0, high_open=True)
        if not isinstance(self.frozen, bool):
            raise RvtoolInputError(f"frozen = {self.frozen!r} must be true or false")
        if isinstance(self.static_orders, bool) or not isinstance(self.static_orders, int) or \
                not -1 <= self.static_orders <= 32:
            raise RvtoolInputError(f"static_orders = {self.static_orders!r} is outside the valid range [-1, 32] (integer)")

    @property
    def flexible(self):
        return self.model == "flexible"


@dataclass(frozen=True)
class PlanarModalBody:
    """In-plane port maps of a floating flexible body (module docstring).

    omega2 (m,) [rad^2/s^2]; damping (m, m) [1/s] (2 zeta omega on the diagonal);
    profile_angles (n_p,) [rad] increasing in [0, 2 pi), profile_maps (n_p, 2, m) [m per unit
    zeta] in the body frame; bore_map (3, m) (x, y [m], theta [rad] per unit zeta) or None;
    hole_maps (n_h, 2, m); modes: indices of the kept modes among the free-free ones;
    in_plane (m,) their in-plane kinetic-energy fractions; mesh_mass [kg], mesh_inertia
    [kg m^2] of the FE model about the frame origin; basis (n_dofs, m) the kept modes on the FE
    coordinates; ``*_load_map(s)``: the maps where a contact force is applied, where they differ
    from where the port measures (None: the same).
    """
    omega2: np.ndarray
    damping: np.ndarray
    profile_angles: np.ndarray
    profile_maps: np.ndarray
    bore_map: np.ndarray | None
    hole_maps: np.ndarray
    modes: np.ndarray
    in_plane: np.ndarray
    mesh_mass: float
    mesh_inertia: float
    basis: np.ndarray | None = None
    profile_load_maps: np.ndarray | None = None
    bore_load_map: np.ndarray | None = None
    hole_load_maps: np.ndarray | None = None

    @property
    def n_modes(self):
        return len(self.omega2)

    @property
    def frequencies_hz(self):
        return np.sqrt(np.maximum(self.omega2, 0.0)) / (2 * np.pi)

    def profile_map(self, psi, load=False):
        """(k, 2, m) displacement per unit zeta in the body frame at polar angles psi (k,) [rad]
        (linear between the neighbouring profile stations, :func:`interpolate`); ``load``: the
        load map."""
        maps = self.profile_load_maps if (load and self.profile_load_maps is not None) else self.profile_maps
        return interpolate(maps, self.profile_angles, psi)

    def map_of(self, name, load=False):
        """The bore map (3, m) or the hole maps (n_h, 2, m) (``name`` "bore" or "holes"), measured or
        ``load``."""
        meas, ld = (self.bore_map, self.bore_load_map) if name == "bore" else (self.hole_maps, self.hole_load_maps)
        return ld if (load and ld is not None) else meas

    @property
    def split(self):
        return any(v is not None for v in (self.profile_load_maps, self.bore_load_map, self.hole_load_maps))

    def neglected_coupling(self, frame_speed):
        """(Omega_frame / omega_1)^2: the relative size of the quadratic-velocity coupling left out
        at frame angular speed ``frame_speed`` [rad/s]."""
        return float(frame_speed ** 2 / self.omega2[0])


@dataclass(frozen=True)
class PortOperators:
    """The port stations of a body as operators on its FE coordinates (n = model.n_dofs):
    ``angles`` (n_p,) [rad] increasing, ``profile`` (2 n_p, n) sparse: mean x, y of each profile
    station, ``bore`` (3, n) sparse: the bore's rigid fit (x, y [m], theta [rad]) or None, ``holes``
    (2 n_h, n) sparse: mean x, y of each hole's ports (where the ports *measure*);
    ``profile_load``, ``bore_load``, ``holes_load``: the same where a contact force is *applied*
    (None: the measurement operators); ``rigid`` (n, 3) the planar rigid fields (x, y, theta about the
    frame origin) and ``rigid_projection`` (3, n) the mass-weighted projection onto them
    ((R^T M R)^-1 R^T M: the mean-axis frame motion of a displacement field)."""
    angles: np.ndarray
    profile: object
    bore: object
    holes: object
    rigid: np.ndarray
    rigid_projection: np.ndarray
    profile_load: object = None
    bore_load: object = None
    holes_load: object = None

    @property
    def n(self):
        return self.rigid.shape[0]

    def load(self, name):
        """The load operator of ``name`` ("profile", "bore", "holes")."""
        v = getattr(self, name + "_load")
        return getattr(self, name) if v is None else v

    @property
    def split(self):
        """True where load and measurement operators differ."""
        return any(getattr(self, nm + "_load") is not None for nm in ("profile", "bore", "holes"))

    def profile_at(self, psi, load=False):
        """(k, 2, n) the profile (measurement, or ``load``) operator interpolated at polar angles psi
        (k,) [rad] (as :meth:`PlanarModalBody.profile_map`, on the FE coordinates)."""
        P = self.load("profile") if load else self.profile
        i0, i1, w1 = interpolation_weights(self.angles, psi)
        out = np.zeros((len(i0), 2, self.n))
        for k in range(len(i0)):
            for c in range(2):
                out[k, c] = ((1.0 - w1[k]) * P[2 * i0[k] + c] + w1[k] * P[2 * i1[k] + c]).toarray()[0]
        return out


def interpolation_weights(angles, psi):
    """(i0, i1, w1): the neighbouring stations of polar angles psi (k,) [rad] among increasing
    ``angles`` (periodic) and the weight of i1 (that of i0 is 1 - w1)."""
    n = len(angles)
    psi = np.mod(np.atleast_1d(np.asarray(psi, float)), 2 * np.pi)
    i1 = np.searchsorted(angles, psi, side="right") % n
    i0 = (i1 - 1) % n
    span = np.mod(angles[i1] - angles[i0], 2 * np.pi)
    span = np.where(span == 0.0, 2 * np.pi, span)
    return i0, i1, np.mod(psi - angles[i0], 2 * np.pi) / span


def interpolate(stack, angles, psi):
    """Linear interpolation of ``stack`` (n_p, ...) given at increasing polar ``angles`` (n_p,)
    [rad] to the polar angles psi (k,) [rad] (periodic): (k, ...)."""
    i0, i1, w1 = interpolation_weights(angles, psi)
    shape = (-1,) + (1,) * (np.ndim(stack) - 1)
    return (1.0 - w1).reshape(shape) * stack[i0] + w1.reshape(shape) * stack[i1]


def port_operators(model, *, profile, bore=(), holes=(), centre=(0.0, 0.0)):
    """:class:`PortOperators` of an unsupported FE model (arguments as :func:`planar_modal_body`)."""
    if len(profile) < 3:
        raise RvtoolInputError(f"profile has {len(profile)} stations; valid: at least 3 (interpolation around the body)")
    n = model.n_dofs
    c = np.asarray(centre, float)

    def mean_xy(group):
        g = np.atleast_1d(group)
        cols = np.array([model.vertex_dofs(model.ports[int(i)].vertex)[:2] for i in g]).T    # (2, len(g))
        return sp.csr_matrix((np.full(cols.size, 1.0 / len(g)), (np.repeat([0, 1], len(g)), cols.ravel())),
                             shape=(2, n))
    pts = np.array([_station_point(model, g) for g in profile]) - c
    ang = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2 * np.pi)
    order = np.argsort(ang, kind="stable")
    if np.any(np.diff(ang[order]) <= 0.0):
        raise RvtoolInputError("two profile stations share a polar angle; valid: distinct angles")
    prof = sp.vstack([mean_xy(profile[i]) for i in order]).tocsr()
    bore_op = None
    if len(bore):
        xy = [mean_xy([i]).toarray() for i in bore]                          # (2, n) each
        p = np.array([_station_point(model, [i]) for i in bore]) - c
        r2 = np.einsum("ij,ij->i", p, p)
        rot = np.mean([(-pk[1] * a[0] + pk[0] * a[1]) / rk for pk, a, rk in zip(p, xy, r2)], axis=0)
        bore_op = sp.csr_matrix(np.vstack([np.mean([a[0] for a in xy], axis=0), np.mean([a[1] for a in xy], axis=0), rot]))
    hole_ops = sp.vstack([mean_xy(g) for g in holes]).tocsr() if len(holes) else sp.csr_matrix((0, n))
    R, proj = planar_rigid(model, c)
    return PortOperators(angles=ang[order], profile=prof, bore=bore_op, holes=hole_ops, rigid=R, rigid_projection=proj)


def planar_rigid(model, centre):
    """(R (n, 3), P (3, n)): the planar rigid fields x, y, theta about ``centre`` [m] on the model's
    coordinates and the mass-weighted projection (R^T M R)^-1 R^T M onto them."""
    n = model.n_dofs
    rv = model.vertices[model.dof_vertex][:, :2] - np.asarray(centre, float)
    comp = model.dof_component
    R = np.zeros((n, 3))
    R[comp == 0, 0] = 1.0
    R[comp == 1, 1] = 1.0
    R[comp == 0, 2] = -rv[comp == 0, 1]
    R[comp == 1, 2] = rv[comp == 1, 0]
    MR = model.mass @ R
    return R, np.linalg.solve(R.T @ MR, MR.T)


def _station_point(model, group):
    return np.mean([model.vertices[model.ports[int(i)].vertex][:2] for i in np.atleast_1d(group)], axis=0)


def in_plane_fractions(model, vectors):
    """Fraction of each column's kinetic energy v^T M v in its x, y components (M is assembled per
    component: a scalar mass matrix times I_3, so the z part is v_z^T M v_z)."""
    z = model.dof_component == 2
    vz = np.where(z[:, None], vectors, 0.0)
    total = np.einsum("ij,ij->j", vectors, model.mass @ vectors)
    return 1.0 - np.einsum("ij,ij->j", vz, model.mass @ vz) / total


def static_correction(model, ops, Phi, orders, responses=None):
    """(n, k) inertia-relief static responses of the free body (``FloatingDynamics.static_orders``)
    to radial and tangential profile loads cos(j psi), sin(j psi), j = 0..orders (on the load
    operators), and to unit x, y loads at the bore and at each hole, with the part in the span of
    the modes ``Phi`` removed (M-orthogonal complement); orthogonal to the rigid modes by
    construction (inertia relief). responses: :func:`static_responses` of these arguments if
    already computed."""
    U = static_responses(model, ops, orders) if responses is None else responses
    return U - Phi @ (Phi.T @ (model.mass @ U))


def static_responses(model, ops, orders):
    """(n, k) inertia-relief static responses of :func:`static_correction` before the modes are
    removed (one factorization of the bordered system; the loads of module :func:`static_correction`)."""
    from .static import InertiaReliefCompliance
    Pl = ops.load("profile")
    psi = ops.angles
    c, s = np.cos(psi), np.sin(psi)
    loads = []
    for j in range(orders + 1):
        for w in ((np.cos(j * psi),) if j == 0 else (np.cos(j * psi), np.sin(j * psi))):
            for dx, dy in ((c, s), (-s, c)):                  # radial, tangential
                g = np.zeros(2 * len(psi))
                g[0::2], g[1::2] = w * dx, w * dy
                loads.append(Pl.T @ g)
    for name in ("bore", "holes"):
        P = ops.load(name)
        if P is None:
            continue
        rows = P.shape[0] if name == "holes" else 2
        for r in range(rows):
            loads.append(np.asarray(P[r].toarray()).ravel())
    F = np.column_stack(loads)
    irc = InertiaReliefCompliance(model.elastic_stiffness, model.mass, model.rigid_body_modes())
    return irc.solve(F)[0]


def planar_modal_body(model, *, n_modes, profile=(), bore=(), holes=(), damping_ratio=0.0, centre=(0.0, 0.0),
                      candidates=None, operators=None, static_orders=-1, free_free=None, static=None):
    """:class:`PlanarModalBody` of an unsupported FE model.

    profile: port-index groups, one per profile station (the ports of a group are averaged,
    e.g. the vertices of one sample through the width); bore: port indices of the bore; holes:
    port-index groups, one per hole; centre: the frame origin in the mesh frame [m];
    candidates: free-free modes computed to pick ``n_modes`` in-plane ones from (default
    3 n_modes + 6); operators: the :class:`PortOperators` of these ports if already built;
    static_orders: :attr:`FloatingDynamics.static_orders` (:func:`static_correction`); free_free:
    a :func:`~rvtool.structure.floating_basis` result of this model with at least ``candidates``
    modes to pick from (its lowest ones are used; None: computed here); static: the
    :func:`static_responses` of ``static_orders`` if already computed."""
    from .floating import floating_basis
    ops = operators or port_operators(model, profile=profile, bore=bore, holes=holes, centre=centre)
    n_cand = 3 * n_modes + 6 if candidates is None else int(candidates)
    if free_free is not None and free_free["matrix"].shape[1] >= n_cand:
        b = {"matrix": free_free["matrix"][:, :n_cand], "eigenvalues": free_free["eigenvalues"][:n_cand]}
    else:
        b = floating_basis(model, n_modes=n_cand)
    frac = in_plane_fractions(model, b["matrix"])
    keep = np.flatnonzero(frac >= IN_PLANE_FRACTION)[:n_modes]
    if len(keep) < n_modes:
        raise RvtoolInputError(f"n_modes = {n_modes}: only {len(keep)} in-plane modes among the first {n_cand} "
                               "free-free modes; valid: fewer modes (or pass more candidates)")
    Phi = b["matrix"][:, keep]
    lam = b["eigenvalues"][keep]
    if static_orders >= 0:
        # Ritz vectors of [Phi, U]: the modes stay (U is M-orthogonal to them), the static responses
        # are diagonalized among themselves; each is then an in-plane shape of the free body
        U = static_correction(model, ops, Phi, static_orders, static)
        Ku, Mu = U.T @ (model.elastic_stiffness @ U), U.T @ (model.mass @ U)
        import scipy.linalg as sla
        # drop directions the loads repeat (a load set with dependent columns)
        w, V = np.linalg.eigh(0.5 * (Mu + Mu.T))
        V = V[:, w > 1e-10 * w.max()] / np.sqrt(w[w > 1e-10 * w.max()])
        mu, Y = sla.eigh(V.T @ Ku @ V)
        Phi = np.hstack([Phi, U @ (V @ Y)])
        lam = np.concatenate([lam, mu])
        keep = np.concatenate([keep, -1 - np.arange(len(mu))])
    R = ops.rigid
    MR = model.mass @ R
    omega = np.sqrt(np.maximum(lam, 0.0))
    m = len(keep)
    loads = {}
    if ops.profile_load is not None:
        loads["profile_load_maps"] = (ops.profile_load @ Phi).reshape(-1, 2, m)
    if ops.bore_load is not None:
        loads["bore_load_map"] = ops.bore_load @ Phi
    if ops.holes_load is not None:
        loads["hole_load_maps"] = (ops.holes_load @ Phi).reshape(-1, 2, m)
    return PlanarModalBody(omega2=lam, damping=np.diag(2.0 * damping_ratio * omega), profile_angles=ops.angles,
                           profile_maps=(ops.profile @ Phi).reshape(-1, 2, len(keep)),
                           bore_map=None if ops.bore is None else ops.bore @ Phi,
                           hole_maps=(ops.holes @ Phi).reshape(-1, 2, len(keep)), modes=keep,
                           in_plane=in_plane_fractions(model, Phi), mesh_mass=float(MR[:, 0] @ R[:, 0]), mesh_inertia=float(MR[:, 2] @ R[:, 2]),
                           basis=Phi, **loads)


def port_operators_from_rows(model, *, measure, load, profile_rows, profile_points, bore_rows=(), hole_rows=(),
                             centre=(0.0, 0.0)):
    """:class:`PortOperators` from port matrices (n_rows, n_dofs) that already spread each port
    over its patch: ``measure`` (where a port's displacement is read) and ``load`` (where its force
    acts; may be the same matrix); ``profile_rows`` (2 N,) the x, y rows of the N profile
    samples in order, ``profile_points`` (N, 2) [m] their positions in the mesh frame,
    ``bore_rows`` the x, y rows of the bore (its rotation row is zero: a lumped bearing at the
    bore centre does not turn its contact), ``hole_rows`` the x, y rows of each hole in pin
    order. E.g. the wheel body of issue 30 (``rvtool.structure.wheel_body.WheelBody``:
    ``measure_matrix``, ``load_matrix``, ``groups``)."""
    n = model.n_dofs
    c = np.asarray(centre, float)
    pts = np.asarray(profile_points, float) - c
    ang = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2 * np.pi)
    order = np.argsort(ang, kind="stable")
    if np.any(np.diff(ang[order]) <= 0.0):
        raise RvtoolInputError("two profile samples share a polar angle; valid: a profile star-shaped about its centre")
    pr = np.asarray(profile_rows, int).reshape(-1, 2)[order].ravel()
    same = load is measure

    def ops(P):
        P = sp.csr_matrix(P)
        bore = None
        if len(bore_rows):
            bore = sp.vstack([P[np.asarray(bore_rows, int)], sp.csr_matrix((1, n))]).tocsr()
        holes = sp.vstack([P[np.asarray(r, int)] for r in hole_rows]).tocsr() if len(hole_rows) else sp.csr_matrix((0, n))
        return P[pr], bore, holes
    prof, bore, holes = ops(measure)
    loads = {} if same else dict(zip(("profile_load", "bore_load", "holes_load"), ops(load)))
    R, proj = planar_rigid(model, c)
    return PortOperators(angles=ang[order], profile=prof, bore=bore, holes=holes, rigid=R, rigid_projection=proj,
                         **loads)
