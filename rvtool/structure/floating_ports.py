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
    """
    model: str = "rigid"
    n_modes: int = 8
    damping_ratio: float = 0.02
    frozen: bool = False

    def __post_init__(self):
        if self.model not in MODELS:
            raise RvtoolInputError(f"model = {self.model!r}; valid choices are {list(MODELS)}")
        if isinstance(self.n_modes, bool) or not isinstance(self.n_modes, int) or not 1 <= self.n_modes <= 60:
            raise RvtoolInputError(f"n_modes = {self.n_modes!r} is outside the valid range [1, 60] (integer)")
        check_range("damping_ratio", self.damping_ratio, 0.0, 1.0, high_open=True)
        if not isinstance(self.frozen, bool):
            raise RvtoolInputError(f"frozen = {self.frozen!r} must be true or false")

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
    [kg m^2] of the FE model about the frame origin.
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

    @property
    def n_modes(self):
        return len(self.omega2)

    @property
    def frequencies_hz(self):
        return np.sqrt(np.maximum(self.omega2, 0.0)) / (2 * np.pi)

    def profile_weights(self, psi):
        """(i0, i1, w0, w1) of the linear interpolation at polar angle(s) psi [rad] between the two
        neighbouring profile stations (periodic)."""
        a = self.profile_angles
        n = len(a)
        psi = np.mod(np.asarray(psi, float), 2 * np.pi)
        i1 = np.searchsorted(a, psi, side="right") % n
        i0 = (i1 - 1) % n
        span = np.mod(a[i1] - a[i0], 2 * np.pi)
        span = np.where(span == 0.0, 2 * np.pi, span)
        w1 = np.mod(psi - a[i0], 2 * np.pi) / span
        return i0, i1, 1.0 - w1, w1

    def profile_map(self, psi):
        """(k, 2, m) displacement per unit zeta in the body frame at polar angles psi (k,) [rad]."""
        i0, i1, w0, w1 = self.profile_weights(np.atleast_1d(psi))
        return w0[:, None, None] * self.profile_maps[i0] + w1[:, None, None] * self.profile_maps[i1]

    def neglected_coupling(self, frame_speed):
        """(Omega_frame / omega_1)^2: the relative size of the quadratic-velocity coupling left out
        at frame angular speed ``frame_speed`` [rad/s]."""
        return float(frame_speed ** 2 / self.omega2[0])


def _station_xy(model, basis, group):
    """(2, m) mean x, y displacement of the vertices of ports ``group`` per unit modal coordinate."""
    rows = [model.vertex_dofs(model.ports[int(i)].vertex)[:2] for i in np.atleast_1d(group)]
    return np.mean([basis[r] for r in rows], axis=0)


def _station_point(model, group):
    return np.mean([model.vertices[model.ports[int(i)].vertex][:2] for i in np.atleast_1d(group)], axis=0)


def in_plane_fractions(model, vectors):
    """Fraction of each column's kinetic energy v^T M v in its x, y components (M is assembled per
    component: a scalar mass matrix times I_3, so the z part is v_z^T M v_z)."""
    z = model.dof_component == 2
    vz = np.where(z[:, None], vectors, 0.0)
    total = np.einsum("ij,ij->j", vectors, model.mass @ vectors)
    return 1.0 - np.einsum("ij,ij->j", vz, model.mass @ vz) / total


def planar_modal_body(model, *, n_modes, profile, bore=(), holes=(), damping_ratio=0.0, centre=(0.0, 0.0),
                      candidates=None):
    """:class:`PlanarModalBody` of an unsupported FE model.

    profile: port-index groups, one per profile station (the ports of a group are averaged,
    e.g. the vertices of one sample through the width); bore: port indices of the bore; holes:
    port-index groups, one per hole; centre: the frame origin in the mesh frame [m];
    candidates: free-free modes computed to pick ``n_modes`` in-plane ones from (default
    3 n_modes + 6)."""
    from .floating import floating_basis
    if len(profile) < 3:
        raise RvtoolInputError(f"profile has {len(profile)} stations; valid: at least 3 (interpolation around the body)")
    n_cand = 3 * n_modes + 6 if candidates is None else int(candidates)
    b = floating_basis(model, n_modes=n_cand)
    frac = in_plane_fractions(model, b["matrix"])
    keep = np.flatnonzero(frac >= IN_PLANE_FRACTION)[:n_modes]
    if len(keep) < n_modes:
        raise RvtoolInputError(f"n_modes = {n_modes}: only {len(keep)} in-plane modes among the first {n_cand} "
                               "free-free modes; valid: fewer modes (or pass more candidates)")
    Phi = b["matrix"][:, keep]
    lam = b["eigenvalues"][keep]
    c = np.asarray(centre, float)
    pts = np.array([_station_point(model, g) for g in profile]) - c
    ang = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2 * np.pi)
    order = np.argsort(ang, kind="stable")
    if np.any(np.diff(ang[order]) <= 0.0):
        raise RvtoolInputError("two profile stations share a polar angle; valid: distinct angles")
    maps = np.array([_station_xy(model, Phi, profile[i]) for i in order])
    bore_map = None
    if len(bore):
        xy = np.array([_station_xy(model, Phi, [i]) for i in bore])          # (k, 2, m)
        p = np.array([_station_point(model, [i]) for i in bore]) - c
        r2 = np.einsum("ij,ij->i", p, p)
        rot = np.mean((-p[:, 1, None] * xy[:, 0] + p[:, 0, None] * xy[:, 1]) / r2[:, None], axis=0)
        bore_map = np.vstack([xy[:, 0].mean(axis=0), xy[:, 1].mean(axis=0), rot])
    hole_maps = np.array([_station_xy(model, Phi, g) for g in holes]).reshape(len(holes), 2, len(keep))
    rv = model.vertices[model.dof_vertex][:, :2] - c
    ones = np.ones(model.n_dofs)
    m_total = float(ones[model.dof_component == 0] @ (model.mass[model.dof_component == 0][:, model.dof_component == 0]
                                                      @ ones[model.dof_component == 0]))
    rot_field = np.zeros(model.n_dofs)
    rot_field[model.dof_component == 0] = -rv[model.dof_component == 0, 1]
    rot_field[model.dof_component == 1] = rv[model.dof_component == 1, 0]
    J = float(rot_field @ (model.mass @ rot_field))
    omega = np.sqrt(np.maximum(lam, 0.0))
    return PlanarModalBody(omega2=lam, damping=np.diag(2.0 * damping_ratio * omega), profile_angles=ang[order],
                           profile_maps=maps, bore_map=bore_map, hole_maps=hole_maps, modes=keep, in_plane=frac[keep],
                           mesh_mass=m_total, mesh_inertia=J)
