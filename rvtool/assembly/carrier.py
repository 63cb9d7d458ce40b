"""The RV carrier as a reduced structure in the reducer model (``[carrier] body = "ported"``, issue 30).

The carrier of :mod:`rvtool.structure.carrier` (output face clamped: the carrier body of the model is its output
face) is reduced once per (structure, material, crank layout) and cached within a process, as the ported housing
(:mod:`rvtool.assembly.housing`). In the planar model each crank's tapered pair acts on a *seat body* (one station
body per crank after the real bodies) that rides on the carrier body translated by the seat's elastic
displacement u_k (2,) [m]; the seats are closed together by the carrier's coupled, anisotropic seat compliance
C_s (2 N_c, 2 N_c) -- the crank rows of the reduced structure's static port compliance -- through
:class:`~rvtool.contact.pin_closure.ElasticPinClosure` with a linear station law (:class:`CarrierSeatSupport`):

    Q_u(q, u) = K_s(theta_c) u,   K_s(theta_c) = R(theta_c) C_s^-1 R(theta_c)^T,

R the block rotation by the carrier angle theta_c (the compliance is stated in the carrier's frame and turns with
it). The closure's tangent holds K_s at the current angle and the turn of the seat forces with the carrier,
d(K_s u)/d theta_c = (J K_s - K_s J) u with J the block rotation generator (R' = J R), so that the condensed
tangent is the exact derivative (checked against central differences in tests/test_carrier_body.py).

Modelling choices, stated: the main-bearing seats are ports of the reduced structure (their compliance is
computed and reported), but in the planar model the main bearing acts on the carrier body: under torque the
cranks' forces on the carrier have no resultant (equal cranks on a circle), so the main bearing carries no load
and its seat's coupling to the crank seats does no work; under an external radial load it would. The carrier's
mass stays the rigid body's (quasi-static seats: the carrier's lowest clamped mode is reported, far above the
torque path's).

Spatial carrier (``bodies.carrier_coordinates = "spatial"``, issue 32): the carrier retains the axial and tilt
coordinates of its output face (the external moment's body, the clamped face of the parent) and, as a second
out-of-plane row, those of its main-bearing seats (the main bearing's rows act on them). The two rows are closed
by the carrier's out-of-plane seat compliance C_o (3, 3) -- the (z, gamma_x, gamma_y) block of the main seats'
rigid-fit compliance from the same NGSolve parent (:func:`carrier_ports`, ``main_seats_compliance``) -- as a
linear spring turning with the carrier (:class:`CarrierTiltSeats`): with d = (seat row - face row),

    Q_seat = -K_o(theta_c) d,   Q_face = +K_o(theta_c) d,   K_o(theta_c) = R(theta_c) C_o^-1 R(theta_c)^T,

R rotating (gamma_x, gamma_y) by the carrier angle, and the turn of the moment with the carrier in the tangent's
carrier-angle column. Stated: C_o^-1 is the seats' out-of-plane stiffness with no in-plane force on them (the
main bearing's in-plane forces act on the carrier body, as in the planar ported model), so the seats' in-plane
translation that a tilt causes about the clamped face (the lever in ``main_seats_compliance``'s x--gamma_y
block) does not reach the main bearing; the crank seats stay planar ports, and the coupling between crank-seat
forces and the main seats' out-of-plane motion is not carried (under pure torque the crank forces are
self-equilibrated).
"""
import functools
import math

import numpy as np

from warp_contacts.circle_pairs_ref import N_OBS, O_FN

from ..contact.evaluator import Evaluation
from ..contact.pin_closure import ElasticPinClosure
from ..errors import RvtoolInputError
from ..structure.carrier import carrier_fe, reduce_carrier
from ..validation import check_body_state, SPATIAL_LAYOUT

#: the out-of-plane components (z, gamma_x, gamma_y) among the rigid fit's (x, y, z, gamma_x, gamma_y, gamma_z)
OUT_OF_PLANE = (2, 3, 4)


def carrier_layout(design, graph=None):
    """(crank circle radius [m], crank angles [rad], tapered-row positions z [m], main-bearing row positions z
    [m]) of an RV design: the rows symmetric about the wheels' mid-plane at +- row_spacing / 2."""
    from .rv.gear_graph import GearGraph
    g = GearGraph.of(design) if graph is None else graph
    s, m = design.crank_bearing.row_spacing / 2, design.main_bearing.row_spacing / 2
    return float(g.crank_radius), tuple(float(b) for b in g.crank_angles), (-s, s), (-m, m)


def check_carrier(design, graph=None):
    """A ported carrier fits the design (:meth:`~rvtool.structure.carrier.CarrierStructure.check_layout`)."""
    if not design.carrier.ported:
        return
    r, angles, rows, main = carrier_layout(design, graph)
    design.carrier.structure.check_layout(r, angles, rows, main)


@functools.lru_cache(maxsize=8)
def _reduced(structure, material, crank_radius, crank_angles):
    parent = carrier_fe(structure, material, crank_radius, crank_angles)
    red = reduce_carrier(parent, structure.n_modes)
    # the main-bearing seats' rigid fit (both rows' seats, about the wheels' mid-plane): the carrier's own
    # compliance between the output face and the main bearings, translations and tilts (issue 32's moment path)
    C_main = parent.compliance(parent.rigid_fit(("main_flange", "main_end_plate"), (0.0, 0.0, 0.0)))
    info = {**parent.counts, "seat_areas_m2": dict(parent.seat_areas),
            "ports": list(parent.port_names), "n_eta": int(red.n_coordinates),
            "first_clamped_hz": float(np.sqrt(red.omega2.min()) / (2 * np.pi)),
            "main_seats_compliance": C_main.tolist(),
            "main_seats_tilt_stiffness_Nm_per_rad": float(2.0 / (C_main[3, 3] + C_main[4, 4]))}
    return red, parent.compliance(), info


def carrier_ports(design, graph=None):
    """(PortReducedModel, parent static port compliance C_ref [m/N], info dict) of ``design.carrier``
    (``body = "ported"``); port k (rows 2k, 2k + 1) is crank k's seat pair, the last port the main bearings.
    ``info["main_seats_compliance"]`` (6, 6) [m/N, rad/(N m)] is the compliance of the main-bearing seats'
    rigid fit (:meth:`~rvtool.structure.carrier.CarrierFE.rigid_fit`: x, y, z, tilts about x and y, turn
    about z, through the wheels' mid-plane) relative to the output face, and
    ``main_seats_tilt_stiffness_Nm_per_rad`` the carrier's tilt stiffness between them (the mean of both
    axes): the carrier's member in the moment path, reported (the spatial model does not take it yet)."""
    c = design.carrier
    if not c.ported:
        raise RvtoolInputError(f"carrier.body = {c.body!r}: the carrier has no ports; valid: 'ported'")
    r, angles, _, _ = carrier_layout(design, graph)
    material = design.material if c.structure.material is None else c.structure.material
    return _reduced(c.structure, material, r, angles)


def seat_compliance(design, graph=None):
    """C_s (2 N_c, 2 N_c) [m/N]: the crank-seat rows of the reduced carrier's static port compliance, in the
    carrier's frame (rows 2k, 2k + 1: x, y of crank k's seat)."""
    red, _, _ = carrier_ports(design, graph)
    n = 2 * design.cranks.count
    C = red.static_compliance()[:n, :n]
    return 0.5 * (C + C.T)


class CarrierSeatSupport:
    """Linear station law of the crank seats (module docstring) for
    :class:`~rvtool.contact.pin_closure.ElasticPinClosure` (``support=``; one "pin", the carrier, whose
    stations are the crank seats): s(u) = K_s(theta_c) u with the tangent K_s(theta_c)."""

    def __init__(self, compliance):
        C = np.asarray(compliance, float)
        self.compliance = C
        self.stiffness = np.linalg.inv(C)
        self.stiffness = 0.5 * (self.stiffness + self.stiffness.T)
        self.zero_load_stiffness = float(np.mean(np.diag(self.stiffness)))
        self.angle = 0.0
        self._K = self.stiffness

    def turn_to(self, angle):
        """State the carrier's angle theta_c [rad] (the frame of the seat compliance)."""
        angle = float(angle)
        if angle == self.angle:
            return
        self.angle = angle
        c, s = math.cos(angle), math.sin(angle)
        R = np.kron(np.eye(len(self.stiffness) // 2), np.array([[c, -s], [s, c]]))
        self._K = R @ self.stiffness @ R.T

    def angle_derivative(self, u):
        """d s / d theta_c (2 n_s,) [N/rad] at seat displacements u (1, n_s, 2) [m]: (J K_s - K_s J) u."""
        u = np.asarray(u, float).reshape(-1)
        Ju = np.empty_like(u)
        Ju[0::2], Ju[1::2] = -u[1::2], u[0::2]
        Ku = self._K @ u
        JKu = np.empty_like(Ku)
        JKu[0::2], JKu[1::2] = -Ku[1::2], Ku[0::2]
        return JKu - self._K @ Ju

    def forces(self, u):
        """(s (1, n_s, 2) [N], ds/du (1, 2 n_s, 2 n_s) [N/m]) at seat displacements u (1, n_s, 2) [m]."""
        u = np.asarray(u, float)
        return (self._K @ u.reshape(-1)).reshape(u.shape), self._K[None]


def tilt_seat_compliance(design, graph=None):
    """C_o (3, 3) [m/N, rad/(N m)]: the (z, gamma_x, gamma_y) block of the main seats' rigid-fit compliance relative
    to the output face (the carrier's frame; module docstring), symmetric."""
    _, _, info = carrier_ports(design, graph)
    C = np.asarray(info["main_seats_compliance"], float)[np.ix_(OUT_OF_PLANE, OUT_OF_PLANE)]
    return 0.5 * (C + C.T)


class _NoHistory:
    """The seat spring carries no contact memory."""


class CarrierTiltSeats:
    """The carrier's output face and its main-bearing seats, out of plane, closed by the carrier's out-of-plane
    seat compliance (module docstring): an evaluator over ``n_bodies`` pose rows (the planar bodies and the
    out-of-plane rows) with the carrier's planar body ``carrier`` (its angle turns the compliance), the face's
    out-of-plane pose row ``face`` and the seats' ``seat``; compliance C_o (3, 3) in the carrier's frame."""

    def __init__(self, compliance, *, n_bodies, carrier, face, seat, name="carrier_seats"):
        C = np.asarray(compliance, float)
        if C.shape != (3, 3) or not np.all(np.isfinite(C)) or np.linalg.eigvalsh(0.5 * (C + C.T)).min() <= 0:
            raise RvtoolInputError("the carrier's out-of-plane seat compliance must be a finite, symmetric positive "
                                   f"definite (3, 3) matrix; got shape {C.shape}")
        for nm, b in (("carrier", carrier), ("face", face), ("seat", seat)):
            if not 0 <= b < n_bodies:
                raise RvtoolInputError(f"{nm} = {b} is outside the valid range [0, {n_bodies - 1}]")
        self.name, self.n_bodies = name, int(n_bodies)
        self.carrier, self.face, self.seat = int(carrier), int(face), int(seat)
        self.compliance = C
        K = np.linalg.inv(C)
        self.stiffness = 0.5 * (K + K.T)
        self.ids = (f"{name}/main",)
        self.history = _NoHistory()
        self.backend = "numpy"

    def stiffness_at(self, angle):
        """K_o(theta_c) (3, 3) and dK_o/d theta_c at the carrier angle [rad]."""
        c, s = math.cos(angle), math.sin(angle)
        R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
        J = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
        K = R @ self.stiffness @ R.T
        return K, J @ K - K @ J

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"carrier seats '{self.name}'", pose, vel, (self.n_bodies, 3), SPATIAL_LAYOUT)

    def evaluate(self, pose, vel=None, history=None, check=True):
        """:class:`~rvtool.contact.evaluator.Evaluation` at poses (n_bodies, 3) (linear spring: no damping)."""
        if check:
            self.check_state(pose, vel)
        pose = np.asarray(pose, float)
        n = 3 * self.n_bodies
        K, dK = self.stiffness_at(pose[self.carrier, 2])
        d = pose[self.seat] - pose[self.face]
        f = K @ d
        fs, ff = slice(3 * self.seat, 3 * self.seat + 3), slice(3 * self.face, 3 * self.face + 3)
        Q = np.zeros(n)
        Q[fs], Q[ff] = -f, f
        T = np.zeros((n, n))
        T[fs, fs], T[fs, ff], T[ff, fs], T[ff, ff] = -K, K, K, -K
        t = 3 * self.carrier + 2
        T[fs, t], T[ff, t] = -(dK @ d), dK @ d
        obs = np.zeros((1, N_OBS))
        obs[0, O_FN] = float(np.hypot(f[1], f[2]))      # the seats' tilting moment [N m]
        return Evaluation(Q, T, np.zeros((n, n)), obs, (), bool(np.all(np.isfinite(Q)) and np.all(np.isfinite(T))))

    def commit(self, pose, vel=None, evaluation=None):
        """Observation row (1, 8) at the accepted state (nothing to commit)."""
        return np.array((evaluation if evaluation is not None else self.evaluate(pose, vel, check=False)).obs, float)


class CarrierSeatClosure(ElasticPinClosure):
    """The crank seats closed by the carrier's seat compliance: an
    :class:`~rvtool.contact.pin_closure.ElasticPinClosure` with one pin (the carrier body ``carrier``) whose
    stations are the N_c seats, and a :class:`CarrierSeatSupport` turned to the carrier's angle at every
    solve."""

    def __init__(self, inner, *, n_bodies, carrier, compliance):
        n = len(compliance) // 2
        self.seat_support = CarrierSeatSupport(compliance)
        super().__init__(inner, n_bodies=n_bodies, carrier=carrier, station_compliance=None,
                         station=np.arange(n)[None, :], support=self.seat_support)
        self.carrier_body = int(carrier)

    def solve(self, pose, vel, u0=None):
        """As :meth:`ElasticPinClosure.solve`, with the support turned to the carrier's angle and the seat
        forces' turn with it in the reduced tangent's carrier-angle column (module docstring)."""
        self.seat_support.turn_to(np.asarray(pose, float).reshape(-1, 3)[self.carrier_body, 2])
        u, ev, (Q, K, D), ok = super().solve(pose, vel, u0)
        nr = 3 * self.n_bodies
        K = K.copy()
        K[nr:, 3 * self.carrier_body + 2] -= self.seat_support.angle_derivative(u)
        return u, ev, (Q, K, D), ok
