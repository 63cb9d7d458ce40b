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

Bore patches (``wheels.structure.bore_ports = N > 0``): the bore station is no longer tied to the
bore's mean motion. It carries the needle row's outer envelope as a rigid race that presses on the
bore's N radial patch ports through compression-only contacts (:mod:`rvtool.contact.bore_patches`):
only the loaded arc carries load and the bore ovalises. The wheel's rows are then its pin stations'
profile ports (as above) and the patches (scalar, turned by nothing), their compliance
C_r = A C A^T plus the rigid-motion term (the patches' readings of the wheel's rigid motion), and the
station law is the patches' piecewise-linear law with its exact tangent, a nonlinear station law
(``support``) of the closure. Its dependence on the pose (the contact points on the flank, the
turning frame) enters the tangent by central differences of the law at the current set of open
patches.
"""
import numpy as np

from ..errors import RvtoolInputError
from ..structure.wheel_body import profile_interpolation
from .bore_patches import patch_law, patch_matrix, station_tangent
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
        n_ports = {b.spec.bore_ports for b in bodies}
        if len(n_ports) > 1:
            raise RvtoolInputError(f"the wheels' bore_ports differ ({sorted(n_ports)}); valid: one "
                                   "wheels.structure.bore_ports for every wheel")
        self.bore_ports = n_ports.pop() if n_ports else 0
        support = _PatchSupport(self) if self.bore_ports else None
        super().__init__(inner, n_bodies=n_bodies, carrier=carrier, station_compliance=np.eye(station.shape[1]),
                         station=station, dofs=(0, 1), support=support, **kw)
        self.wheels = wheels
        self.bodies = tuple(bodies)
        self._port_compliance = [b.static_compliance for b in bodies]
        self._bore_rows = [np.concatenate([b.rows(f"bore{k}") for k in range(self.n_bores)]) for b in bodies]
        self.compliance = None          # not one isotropic matrix: see station_compliances
        self.station_compliances = np.zeros((len(wheels), 2 * station.shape[1], 2 * station.shape[1]))
        if self.bore_ports:
            self._patch_rows = [np.concatenate([b.rows(f"bore{k}_patches") for k in range(self.n_bores)])
                                for b in bodies]
            self._patch_readings = [b.rigid_readings(r) for b, r in zip(bodies, self._patch_rows)]
            n_r = 2 * zb + len(self._patch_rows[0])
            # with patches: the compliance of each wheel's rows (pin stations, patches), not of its stations
            self.station_compliances = np.zeros((len(wheels), n_r, n_r))
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

    def port_matrix(self, j, pose):
        """(C_r, P) of wheel j at real-body poses ``pose`` with bore patches (module docstring): C_r
        (n_r, n_r) [m/N] the compliance of its rows (2 z_b pin-station rows in the global frame, signed
        -1, then the patches' radial rows) with the rigid-motion term, P the patches' map from the
        station displacements (:func:`rvtool.contact.bore_patches.patch_matrix`, normals turned to
        the global frame)."""
        x, y, th = np.asarray(pose, float)[self.wheels[j]]
        c, s = np.cos(th), np.sin(th)
        Rt = np.array([[c, -s], [s, c]])
        local = (self.pin_centres - np.array([x, y])) @ Rt
        b = self.bodies[j]
        Wp, _ = profile_interpolation(b, local)
        Cp = self._port_compliance[j]
        prof = b.rows("profile")
        pr = self._patch_rows[j]
        zb2 = 2 * self.n_ring_pins
        A = np.zeros((zb2 + len(pr), Cp.shape[0]))
        A[:zb2, prof] = -np.kron(np.eye(self.n_ring_pins), Rt) @ Wp
        A[zb2 + np.arange(len(pr)), pr] = 1.0
        C = A @ Cp @ A.T
        r = self.pin_centres - np.array([x, y])
        G = np.zeros((len(A), 3))
        G[0:zb2:2, 0] = G[1:zb2:2, 1] = -1.0
        G[0:zb2:2, 2], G[1:zb2:2, 2] = r[:, 1], -r[:, 0]
        rd = self._patch_readings[j]
        G[zb2:, :2] = rd[:, :2] @ Rt.T
        G[zb2:, 2] = rd[:, 2]
        G /= np.linalg.norm(G, axis=0)
        C = C + np.trace(C) / len(C) * (G @ G.T)
        N = self.bore_ports
        normals = [(rd[k * N:(k + 1) * N, :2] @ Rt.T) for k in range(self.n_bores)]
        return 0.5 * (C + C.T), patch_matrix(zb2, normals)

    def _update_patches(self, pose):
        """The rows' stiffness K_r and map P of every wheel at ``pose`` and at the pose steps of its
        three coordinates (for the pose term of the tangent)."""
        data = []
        for j in range(self.n_pins):
            C, P = self.port_matrix(j, pose)
            lam = np.linalg.eigvalsh(C)
            if lam.min() <= 0:
                raise RvtoolInputError(f"the port compliance of wheel {j} is not positive definite (eigenvalues "
                                       f"{lam[:3].tolist()}...); valid: wheels.structure.samples_per_tooth large "
                                       "enough that no two pins share a profile port, and bore_ports small enough "
                                       "for the bores' mesh")
            self.station_compliances[j] = C
            steps = []
            for c in range(3):
                pp, pm = pose.copy(), pose.copy()
                pp[self.wheels[j], c] += POSE_STEP
                pm[self.wheels[j], c] -= POSE_STEP
                steps.append([(np.linalg.inv(Cx), Px) for Cx, Px in (self.port_matrix(j, pp), self.port_matrix(j, pm))])
            data.append((np.linalg.inv(C), P, steps))
        self._patch_data = data

    def update(self, pose):
        """Recompute the station stiffness blocks at real-body poses ``pose`` (nb, 3)."""
        pose = np.asarray(pose, float)
        key = pose[list(self.wheels)].round(12).tobytes()
        if key == self._pose_key:
            return
        if self.bore_ports:
            self._update_patches(pose)
            self._pose_key = key
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
            if self.bore_ports:
                dK = self.support.pose_derivative(j, uj)
                K[nr + j * m:nr + (j + 1) * m, 3 * w:3 * w + 3] -= dK
            else:
                K[nr + j * m:nr + (j + 1) * m, 3 * w:3 * w + 3] -= np.einsum("cab,b->ac", self._dKb[j], uj)
        return Q, K, D

    def station_forces(self, pose, u):
        """(K u, K, dK u/dq) of the wheels' station stiffness K at real-body poses ``pose`` (the pose
        derivative on each wheel's coordinates, as :meth:`_reduced` subtracts it)."""
        self.update(pose)
        u = np.asarray(u, float)
        m = 2 * self.station.shape[1]
        Gq = np.zeros((self.n_u, 3 * self.n_bodies))
        if self.bore_ports:                     # the patches' law (its tangent and pose term at the open set)
            F, G = self.support.forces(u.reshape(self.n_pins, self.n_stations, len(self.dofs)))
            for j, w in enumerate(self.wheels):
                Gq[j * m:(j + 1) * m, 3 * w:3 * w + 3] = self.support.pose_derivative(j, u[j * m:(j + 1) * m])
            return F.ravel(), self._block_diagonal(G), Gq
        for j, w in enumerate(self.wheels):
            Gq[j * m:(j + 1) * m, 3 * w:3 * w + 3] = np.einsum("cab,b->ac", self._dKb[j], u[j * m:(j + 1) * m])
        return self._Kb @ u, self._Kb, Gq

    def solve(self, pose, vel, u0=None):
        self.update(pose)
        return super().solve(pose, vel, u0)

    @property
    def open_patches(self):
        """Per wheel the open patches (n_c N,) bool (bore k's at k N ... (k + 1) N - 1) of the last
        evaluation of the station law; None without bore patches or before an evaluation."""
        if not self.bore_ports or self.support.open_sets is None:
            return None
        return [None if o is None else o.copy() for o in self.support.open_sets]

    def energy(self, du):
        """sum_j du_j^T K_j du_j for station deflection increments du (n_w, n_s, 2) [m] (the mean bore tie;
        with bore patches :meth:`station_energy` at the solved deflections)."""
        if self.bore_ports:
            raise RvtoolInputError("energy(du) is the mean bore tie's; with wheels.structure.bore_ports > 0 use "
                                   "station_energy(du, u) (the patches' tangent depends on u)")
        du = np.asarray(du, float).reshape(-1)
        return float(du @ self._Kb @ du)


class _PatchSupport:
    """The station law of wheels with bore patches for :class:`ElasticPinClosure` (``support``):
    per wheel the patches' law (:func:`rvtool.contact.bore_patches.patch_law`) on the rows' stiffness
    of the closure's current pose (:meth:`WheelBodyClosure.update`)."""

    def __init__(self, closure):
        self.closure = closure
        self.zero_load_stiffness = None         # the closure passes its own (identity) station compliance
        #: per wheel, the open patches (n_c N,) bool of the last evaluation of the law (None before one)
        self.open_sets = None

    def forces(self, u):
        """(s (n_w, n_s, 2) [N], ds/du (n_w, 2 n_s, 2 n_s) [N/m]) at station deflections u (n_w, n_s, 2)."""
        cl = self.closure
        u = np.asarray(u, float)
        n_w, n_s, _ = u.shape
        zb2 = 2 * cl.n_ring_pins
        if self.open_sets is None:
            self.open_sets = [None] * n_w
        s = np.zeros((n_w, 2 * n_s))
        G = np.zeros((n_w, 2 * n_s, 2 * n_s))
        for j in range(n_w):
            K, P, _ = cl._patch_data[j]
            s[j], G[j], self.open_sets[j], _, _ = patch_law(K, P, zb2, u[j].ravel(), self.open_sets[j])
        return s.reshape(u.shape), G

    def pose_derivative(self, j, uj):
        """d s_j / d(wheel j's pose) (2 n_s, 3) at station deflections uj, the open patches held (central
        differences over the closure's POSE_STEP)."""
        cl = self.closure
        zb2 = 2 * cl.n_ring_pins
        _, _, steps = cl._patch_data[j]
        open_ = self.open_sets[j] if self.open_sets is not None and self.open_sets[j] is not None else None
        if open_ is None:
            K, P, _ = cl._patch_data[j]
            open_ = patch_law(K, P, zb2, uj)[2]
        out = np.zeros((len(uj), 3))
        for c, ((Kp, Pp), (Km, Pm)) in enumerate(steps):
            out[:, c] = (station_tangent(Kp, Pp, zb2, open_) - station_tangent(Km, Pm, zb2, open_)) @ uj / (2 * POSE_STEP)
        return out
