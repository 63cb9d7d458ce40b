"""Elastic cycloid wheels as a static condensation of their contact stations (issue 30).

The wheel--pin contacts and the needle bearings of a wheel's crank bores are one stacked contact
set (:class:`~rvtool.contact.stacked.StackedContactSet`) evaluated on *station bodies*, closed by
the wheel's port compliance in the machinery of :class:`~rvtool.contact.pin_closure.ElasticPinClosure`
(one "pin" of that closure per wheel, its stations the z_b pin contacts and the n_c bores, x and y):

* pin station k of wheel j: ring pin k translated by u = -delta_k, minus the wheel's elastic
  displacement at its contact point (only the relative position enters the gap, so the pin moves
  instead of a copy of the wheel); carrier: ground;
* bore station k of wheel j: the wheel translated by u = +delta_bore_k; carrier: the wheel.

With the wheel's free-body port compliance C (:attr:`rvtool.structure.wheel_body.WheelBody.static_compliance`)
and the interpolation W of the contact points on the profile ports
(:func:`~rvtool.structure.wheel_body.profile_interpolation`: the contact between two profile
samples loads both with its linear weights, so it moves continuously along the flank), the station
compliance of wheel j is

    C_j = S R W C W^T R^T S,   S = diag(-1 on pin stations, +1 on bores),

R turning the wheel-frame blocks to the global frame at the wheel's angle, plus a compliance along
the wheel's rigid motion at the stations (S G, G the rigid translations and rotation of the station
points), which leaves the response to every balanced load unchanged (G^T S Q = 0) and keeps C_j
definite for the unbalanced trial loads of a Newton iteration. The contact point of pin
k is the flank point nearest to the pin centre in the wheel frame at the current pose, so C_j
follows the wheel's pose: it is recomputed at every evaluation (at a fixed input angle the
contacts move by the elastic displacement only; the tangent omits the derivative of C_j along the
pose, a second-order term). The contact law already holds the local contact approach; the
ports measure below the flank (:mod:`rvtool.structure.wheel_body`), so the FE does not add it twice.
"""
import numpy as np

from ..errors import RvtoolInputError
from ..structure.wheel_body import profile_interpolation
from .pin_closure import GROUND, ElasticPinClosure

POSE_STEP = 1e-7
"""Step [m, rad] of the central differences of a wheel's station stiffness along its pose (a contact
point moves 1e-7 m on the flank: far below a profile sample's spacing, far above round-off)."""


class WheelBodyClosure(ElasticPinClosure):
    """Contact evaluator of elastic wheels (module docstring).

    inner: the stacked pins + needle set over n_bodies + n_wheels (z_b + n_c) bodies;
    wheels: real body index of each wheel (n_w,); bodies: (n_w,) :class:`WheelBody` models;
    pin_centres: (z_b, 2) ring pin centres [m] (ground); station: (n_w, z_b + n_c) station indices;
    pin_carrier: the body carrying the ring pins' stations, GROUND or one index per pin (z_b,) (the
    ported housing's port bodies; the contact point on the wheel is found from the nominal centres).
    """

    def __init__(self, inner, *, n_bodies, wheels, bodies, pin_centres, station, pin_carrier=GROUND, **kw):
        wheels = tuple(int(w) for w in wheels)
        station = np.asarray(station, int)
        self.pin_centres = np.asarray(pin_centres, float)
        zb = len(self.pin_centres)
        self.n_ring_pins = zb
        self.n_bores = station.shape[1] - zb
        if len(bodies) != len(wheels) or station.shape[0] != len(wheels):
            raise RvtoolInputError(f"{len(wheels)} wheels, {len(bodies)} wheel bodies and {station.shape[0]} station "
                                   "rows must agree")
        carrier = np.full(station.shape, GROUND)
        carrier[:, :zb] = np.broadcast_to(np.asarray(pin_carrier, int), (zb,))
        for j, w in enumerate(wheels):
            carrier[j, zb:] = w
        super().__init__(inner, n_bodies=n_bodies, carrier=carrier, station_compliance=np.eye(station.shape[1]),
                         station=station, dofs=(0, 1), **kw)
        self.wheels = wheels
        self.bodies = tuple(bodies)
        self._port_compliance = [b.static_compliance for b in bodies]
        self._bore_rows = [np.concatenate([b.rows(f"bore{k}") for k in range(self.n_bores)]) for b in bodies]
        self.compliance = None          # not one isotropic matrix: see station_compliances
        self.station_compliances = np.zeros((len(wheels), 2 * station.shape[1], 2 * station.shape[1]))
        self._pose_key = None
        self.update(np.zeros((n_bodies, 3)))

    def station_matrix(self, j, pose):
        """C_j (2 n_s, 2 n_s) [m/N] of wheel j at real-body poses ``pose`` (module docstring)."""
        x, y, th = np.asarray(pose, float)[self.wheels[j]]
        c, s = np.cos(th), np.sin(th)
        Rt = np.array([[c, -s], [s, c]])
        local = (self.pin_centres - np.array([x, y])) @ Rt          # R(-th) (p - x): rows times R
        b = self.bodies[j]
        Wp, _ = profile_interpolation(b, local)
        # W (2 n_s, port rows) has two profile ports per pin station and one row per bore station: only
        # the port rows it touches enter C_j (the product over the others adds exact zeros)
        used = np.flatnonzero(np.any(Wp != 0.0, axis=0))
        rows = np.concatenate([np.asarray(b.rows("profile"))[used], self._bore_rows[j]])
        W = np.zeros((2 * (self.n_ring_pins + self.n_bores), len(rows)))
        W[:2 * self.n_ring_pins, :len(used)] = -Wp[:, used]          # S = -1 on the pin stations
        W[2 * self.n_ring_pins + np.arange(2 * self.n_bores), len(used) + np.arange(2 * self.n_bores)] = 1.0
        A = np.einsum("ab,nbk->nak", Rt, W.reshape(-1, 2, len(rows))).reshape(W.shape)     # R (x) I_2 per station
        C = A @ self._port_compliance[j][np.ix_(rows, rows)] @ A.T
        # the wheel's rigid motion at the stations (global frame, about the wheel centre; the pins'
        # normal forces and the needles' radial forces pass through the pin and bore centres), signed
        # by S: a compliance along it does not change the response to a balanced load (G^T S Q = 0)
        # and is taken up by the wheel's rigid coordinates; it makes C_j definite for unbalanced
        # trial loads, which the free body's inertia-relief compliance answers with ~0
        bores = np.array([b.geometry.bores[k][:2] for k in range(self.n_bores)]) @ Rt.T
        r = np.vstack([self.pin_centres - np.array([x, y]), bores])
        G = np.zeros((2 * len(r), 3))
        G[0::2, 0] = G[1::2, 1] = 1.0
        G[0::2, 2], G[1::2, 2] = -r[:, 1], r[:, 0]
        G[:2 * self.n_ring_pins] *= -1.0
        G /= np.linalg.norm(G, axis=0)
        C = C + np.trace(C) / len(C) * (G @ G.T)
        return 0.5 * (C + C.T)

    def update(self, pose):
        """Recompute the station stiffness blocks at real-body poses ``pose`` (nb, 3)."""
        pose = np.asarray(pose, float)
        key = pose[list(self.wheels)].round(12).tobytes()
        if key == self._pose_key:
            return
        m = 2 * self.station.shape[1]
        Kb = np.zeros((self.n_pins * m, self.n_pins * m))
        dKb = np.zeros((self.n_pins, 3, m, m))
        for j in range(self.n_pins):
            C = self.station_matrix(j, pose)
            lam = np.linalg.eigvalsh(C)
            if lam.min() <= 0:
                raise RvtoolInputError(f"the station compliance of wheel {j} is not positive definite (eigenvalues "
                                       f"{lam[:3].tolist()}...); valid: wheels.structure.samples_per_tooth large "
                                       "enough that no two pins share a profile port")
            self.station_compliances[j] = C
            Kb[j * m:(j + 1) * m, j * m:(j + 1) * m] = np.linalg.inv(C)
            for c in range(3):
                # the station stiffness along wheel j's pose (the contact points move on the flank, the
                # blocks turn with the wheel), by central differences over POSE_STEP
                pp, pm = pose.copy(), pose.copy()
                pp[self.wheels[j], c] += POSE_STEP
                pm[self.wheels[j], c] -= POSE_STEP
                Kp, Km = (np.linalg.inv(self.station_matrix(j, x)) for x in (pp, pm))
                dKb[j, c] = ((Kp - Km) + (Kp - Km).T) / (4 * POSE_STEP)
        self._Kb = 0.5 * (Kb + Kb.T)
        self._dKb = dKb
        self._pose_key = key

    def _reduced(self, ev, u):
        """The closure's reduced system (:meth:`ElasticPinClosure._reduced`) with the station
        stiffness's dependence on the wheel poses in the tangent: d(K_j(q) u_j)/dq on the station
        rows of wheel j (the forces are those of K_j at the current pose; without the term the
        condensed tangent misses 1e-5 of itself, measured against central differences)."""
        Q, K, D = super()._reduced(ev, u)
        nr = 3 * self.n_bodies
        m = 2 * self.station.shape[1]
        for j, w in enumerate(self.wheels):
            uj = u[j * m:(j + 1) * m]
            K[nr + j * m:nr + (j + 1) * m, 3 * w:3 * w + 3] -= np.einsum("cab,b->ac", self._dKb[j], uj)
        return Q, K, D

    def station_forces(self, pose, u):
        """(K u, K, dK u/dq) of the wheels' station stiffness K at real-body poses ``pose`` (the pose
        derivative on each wheel's coordinates, as :meth:`_reduced` subtracts it)."""
        self.update(pose)
        u = np.asarray(u, float)
        m = 2 * self.station.shape[1]
        Gq = np.zeros((self.n_u, 3 * self.n_bodies))
        for j, w in enumerate(self.wheels):
            Gq[j * m:(j + 1) * m, 3 * w:3 * w + 3] = np.einsum("cab,b->ac", self._dKb[j], u[j * m:(j + 1) * m])
        return self._Kb @ u, self._Kb, Gq

    def solve(self, pose, vel, u0=None):
        self.update(pose)
        return super().solve(pose, vel, u0)

    def energy(self, du):
        """sum_j du_j^T K_j du_j for station deflection increments du (n_w, n_s, 2) [m]."""
        du = np.asarray(du, float).reshape(-1)
        return float(du @ self._Kb @ du)
