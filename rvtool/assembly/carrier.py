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
"""
import functools
import math

import numpy as np

from ..contact.pin_closure import ElasticPinClosure
from ..errors import RvtoolInputError
from ..structure.carrier import carrier_fe, reduce_carrier
from ..structure.static import SupportedCompliance


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
    fe = parent.fe
    sc = SupportedCompliance(fe.stiffness, parent.port_matrix)
    # the main-bearing seats' rigid fit (both rows' seats, about the wheels' mid-plane): the carrier's own
    # compliance between the output face and the main bearings, translations and tilts (issue 32's moment path)
    C_main = sc.compliance(parent.rigid_fit(("main_flange", "main_end_plate"), (0.0, 0.0, 0.0)))
    info = {"vertices": int(len(fe.vertices)), "tetrahedra": int(len(fe.tetrahedra)), "dofs": int(fe.n_dofs),
            "seat_vertices": {k: int(len(v)) for k, v in parent.seat_vertices.items()},
            "ports": list(parent.port_names), "n_eta": int(red.n_coordinates),
            "first_clamped_hz": float(np.sqrt(red.omega2.min()) / (2 * np.pi)),
            "main_seats_compliance": C_main.tolist(),
            "main_seats_tilt_stiffness_Nm_per_rad": float(2.0 / (C_main[3, 3] + C_main[4, 4]))}
    return red, sc.compliance(), info


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
