"""A crankshaft as a floating flexible body in planar dynamic runs (``[cranks.dynamics] model =
"flexible"``, issue 33): the free-free beam, its elastic basis and its station maps.

The crank is the prismatic solid circular shaft of :mod:`rvtool.structure.crank_beam` (radius r,
the design's ``[cranks.shaft]`` geometry and material), now *free*: no supports, the tapered rows
being contacts. It extends over every station it carries (the two tapered rows, the eccentric
journals at the wheel midplanes with the needle length, the spur gear with its face width). Each
node carries five coordinates: the deflections u_x, u_y with their slopes (two bending planes,
the exact two-node Timoshenko stiffness :func:`rvtool.structure.pin_beam.timoshenko_element`,
the consistent Euler--Bernoulli mass with rotary inertia) and the twist phi (linear elements,
G J_p, consistent mass rho J_p).

The beam has five rigid modes: the x and y translations, the tilts about x and y, the twist. The
planar crank body (x, y, theta) is the floating frame, its mean axis: the elastic basis is
M-orthogonal to all five (the frame's tilts are held, as the rigid planar crank holds them,
declared in :mod:`rvtool.assembly.rv.builder`). The basis is the ``n_modes`` lowest free-free
elastic modes plus, with ``static_orders >= 0``, the inertia-relief static responses to unit x, y
forces and a unit torque at every station (Ritz vectors, diagonalized among themselves;
``static_orders`` has no further meaning for a crank).

A station's map (3, m) reads its x, y deflection and its twist at the station's centre per unit
modal coordinate, in the crank's body frame; the planar families on the crank (gear mesh, needle
rows, tapered pair) move their crank side by it (:class:`exudyn_user_elements.floating_ports.FloatingPorts`).
Quadratic-velocity terms (gyroscopic coupling of the spinning shaft's bending planes, centrifugal
stiffening) are left out: relative size (Omega_crank / omega_1)^2.
"""
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..errors import RvtoolInputError
from .pin_beam import cowper_circle, timoshenko_element

DOFS_PER_NODE = 5
"""u_x, slope_x, u_y, slope_y, phi per node."""


@dataclass(frozen=True)
class CrankStation:
    """One station of the crank: ``name``, axial centre ``z`` [m], ``width`` [m] (the contact's length)."""
    name: str
    z: float
    width: float


@dataclass(frozen=True)
class CrankBeamModel:
    """The free crank beam: nodes z (n,) [m], stiffness K and mass M (5 n, 5 n) (module docstring),
    stations, rigid modes R (5 n, 5) (x, tilt in the x plane, y, tilt in the y plane, twist) and
    its mass [kg]."""
    nodes: np.ndarray
    stiffness: np.ndarray
    mass: np.ndarray
    stations: tuple
    rigid: np.ndarray

    @property
    def n_dofs(self):
        return self.stiffness.shape[0]

    @property
    def total_mass(self):
        return float(self.rigid[:, 0] @ self.mass @ self.rigid[:, 0])

    def node_of(self, z):
        return int(np.argmin(np.abs(self.nodes - z)))

    def station_operator(self, name):
        """(3, 5 n): u_x, u_y and phi at the station's node."""
        st = {s.name: s for s in self.stations}[name]
        i = self.node_of(st.z)
        S = np.zeros((3, self.n_dofs))
        S[0, DOFS_PER_NODE * i] = S[1, DOFS_PER_NODE * i + 2] = S[2, DOFS_PER_NODE * i + 4] = 1.0
        return S


def crank_beam_model(radius, stations, youngs_modulus, poisson_ratio, density, *, element_length=None):
    """:class:`CrankBeamModel` of a prismatic solid circular crank of ``radius`` [m] over the
    ``stations`` (:class:`CrankStation`), a node at every station centre and at the ends of every
    station, elements no longer than ``element_length`` [m] (default: the length / 40)."""
    if radius <= 0 or density <= 0:
        raise RvtoolInputError(f"radius = {radius} m and density = {density} kg/m^3 must be positive")
    zs = sorted({float(v) for s in stations for v in (s.z - s.width / 2, s.z, s.z + s.width / 2)})
    length = zs[-1] - zs[0]
    if length <= 0:
        raise RvtoolInputError("the crank's stations span no length; valid: stations at distinct axial positions")
    h_max = length / 40 if element_length is None else float(element_length)
    nodes = [zs[0]]
    for a, b in zip(zs[:-1], zs[1:]):
        k = max(1, math.ceil((b - a) / h_max - 1e-9))
        nodes += list(a + (b - a) * np.arange(1, k + 1) / k)
    nodes = np.asarray(nodes)
    n = len(nodes)
    E, nu, rho = youngs_modulus, poisson_ratio, density
    A, I = math.pi * radius ** 2, math.pi * radius ** 4 / 4
    G = E / (2 * (1 + nu))
    kGA = cowper_circle(nu) * G * A
    Jp = 2 * I
    K = np.zeros((DOFS_PER_NODE * n, DOFS_PER_NODE * n))
    M = np.zeros_like(K)
    for e in range(n - 1):
        h = nodes[e + 1] - nodes[e]
        kb = timoshenko_element(E * I, kGA, h)
        mt = rho * A * h / 420.0 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                             [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
        mr = rho * I / (30.0 * h) * np.array([[36, 3 * h, -36, 3 * h], [3 * h, 4 * h * h, -3 * h, -h * h],
                                              [-36, -3 * h, 36, -3 * h], [3 * h, -h * h, -3 * h, 4 * h * h]])
        for off in (0, 2):                          # the x and the y bending plane
            idx = [DOFS_PER_NODE * e + off, DOFS_PER_NODE * e + off + 1,
                   DOFS_PER_NODE * (e + 1) + off, DOFS_PER_NODE * (e + 1) + off + 1]
            K[np.ix_(idx, idx)] += kb
            M[np.ix_(idx, idx)] += mt + mr
        idx = [DOFS_PER_NODE * e + 4, DOFS_PER_NODE * (e + 1) + 4]
        K[np.ix_(idx, idx)] += G * Jp / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
        M[np.ix_(idx, idx)] += rho * Jp * h / 6.0 * np.array([[2.0, 1.0], [1.0, 2.0]])
    R = np.zeros((DOFS_PER_NODE * n, 5))
    zc = nodes - nodes.mean()
    R[0::DOFS_PER_NODE, 0] = 1.0
    R[0::DOFS_PER_NODE, 1], R[1::DOFS_PER_NODE, 1] = zc, 1.0
    R[2::DOFS_PER_NODE, 2] = 1.0
    R[2::DOFS_PER_NODE, 3], R[3::DOFS_PER_NODE, 3] = zc, 1.0
    R[4::DOFS_PER_NODE, 4] = 1.0
    return CrankBeamModel(nodes=nodes, stiffness=K, mass=M, stations=tuple(stations), rigid=R)


def elastic_modes(beam):
    """(omega^2 (k,), Phi (5 n, k)): every elastic free-free mode of the beam, mass-normalized,
    ascending (the five rigid modes removed: the complement of R in the M inner product)."""
    K, M, R = beam.stiffness, beam.mass, beam.rigid
    # a basis of the M-orthogonal complement of the rigid modes, then the eigenproblem on it
    MR = M @ R
    Q = sla.null_space(MR.T)
    lam, Y = sla.eigh(Q.T @ K @ Q, Q.T @ M @ Q)
    return lam, Q @ Y


@dataclass(frozen=True)
class CrankModalBody:
    """The retained basis of a flexible crank: omega2 (m,) [rad^2/s^2], damping (m, m) [1/s],
    basis (5 n, m) (M-orthonormal, K-diagonal), station maps {name: (3, m)} (x, y [m], phi [rad]
    per unit modal coordinate), ``n_free_free`` of them free-free modes (the rest static Ritz
    vectors), the beam it came from."""
    omega2: np.ndarray
    damping: np.ndarray
    basis: np.ndarray
    station_maps: dict
    n_free_free: int
    beam: CrankBeamModel

    @property
    def n_modes(self):
        return len(self.omega2)

    @property
    def frequencies_hz(self):
        return np.sqrt(np.maximum(self.omega2, 0.0)) / (2 * np.pi)

    def neglected_coupling(self, spin):
        """(Omega / omega_1)^2 at crank speed ``spin`` [rad/s]."""
        return float(spin ** 2 / self.omega2[0])


def crank_modal_body(beam, *, n_modes, damping_ratio=0.0, static_orders=-1, full=False):
    """:class:`CrankModalBody` of ``beam`` (module docstring); ``full``: every elastic mode (the
    complete elastic space of the beam's FE model: the reference of the reduction)."""
    lam, Phi = elastic_modes(beam)
    if full:
        n_modes, static_orders = len(lam), -1
    if n_modes > len(lam):
        raise RvtoolInputError(f"n_modes = {n_modes}: the crank beam has only {len(lam)} elastic modes; valid: fewer")
    lam, Phi = lam[:n_modes], Phi[:, :n_modes]
    if static_orders >= 0:
        K, M, R = beam.stiffness, beam.mass, beam.rigid
        S = np.vstack([beam.station_operator(s.name) for s in beam.stations])
        F = S.T                                               # unit x, y forces and torques at the stations
        # inertia relief: the free beam under F less its rigid-body inertia loads, the response
        # M-orthogonal to the rigid modes (bordered system)
        MR = M @ R
        P = F - MR @ np.linalg.solve(R.T @ MR, R.T @ F)
        nr = R.shape[1]
        A = np.block([[K, MR], [MR.T, np.zeros((nr, nr))]])
        U = np.linalg.solve(A, np.vstack([P, np.zeros((nr, F.shape[1]))]))[:K.shape[0]]
        U = U - Phi @ (Phi.T @ (M @ U))
        Mu, Ku = U.T @ M @ U, U.T @ K @ U
        w, V = np.linalg.eigh(0.5 * (Mu + Mu.T))
        ok = w > 1e-10 * w.max()
        V = V[:, ok] / np.sqrt(w[ok])
        mu, Y = sla.eigh(V.T @ Ku @ V)
        Phi = np.hstack([Phi, U @ (V @ Y)])
        lam = np.concatenate([lam, mu])
    omega = np.sqrt(np.maximum(lam, 0.0))
    maps = {s.name: beam.station_operator(s.name) @ Phi for s in beam.stations}
    return CrankModalBody(omega2=lam, damping=np.diag(2.0 * damping_ratio * omega), basis=Phi, station_maps=maps,
                          n_free_free=n_modes, beam=beam)
