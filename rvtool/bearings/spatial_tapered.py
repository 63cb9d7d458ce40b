"""Tapered-roller rows between bodies that retain axial and tilt coordinates: the crankshafts of an
RV reducer on their tapered pairs in the carrier with ``bodies.crank_coordinates = "spatial"``
(issue 32).

The planar set (:class:`~rvtool.bearings.tapered_set.TaperedBearingSet`) holds the cone's axial
and tilt displacement at zero and reports the pair's axial force and tilting moment as
observations. Here they are fed back: each mounting's relative displacement of the cone (body A)
against the cup (body B) at the mounting's axial centre,

    q5 = (r_x, r_y, delta_z, gamma_x, gamma_y),
    r        = (p_A + a) - (p_B + b)                          (the planar ring-centre offset),
    delta_z  = z_A - z_B + (gA_x a_y - gA_y a_x) - (gB_x b_y - gB_y b_x),
    gamma    = gamma_A - gamma_B,

with a, b the ring centres' in-plane arms from the body centres (a body's tilt lifts a point at arm
a by gamma x a), goes through the 5-DOF roller law of the set
(:meth:`~rvtool.bearings.tapered_set.TaperedBearingSet.relative`: laminae along each roller, the
working contact of cone, cup and rib, Eq. (width_resultant) over laminae and rollers) at the cage
angle of the planar use, and the wrench w on the cone gives the generalized forces Q = J^T w
(J = dq5/dx over the twelve coordinates of A and B: planar and out-of-plane). The tangent is
J^T (dw/dq5) J + J^T (dw/dpsi) dpsi/dx + sum_i w_i d^2 q5_i / dx^2 (the arms turn with theta):
the Hessian of the rollers' potential at fixed cage, analytic (tests: central differences).

Assumption (stated): the tilt centre of each body lies in the mounting's axial plane (the crank's
at the centre of its pair, the carrier's at the main bearing's axial centre, taken as the same
plane): a tilt moves the ring centres axially, not in the plane. At zero axial and tilt
displacement the in-plane forces and their tangent are the planar set's (tests).
"""
import numpy as np

from warp_contacts import tapered_rollers_ref as ref
from warp_contacts.circle_pairs_ref import N_OBS, O_FN, O_GAP, O_NX, O_NY, O_PX, O_PY
from warp_contacts.planar_ref import perp as _perp, rot as _rot

from ..contact.circle_set import GROUND
from ..contact.evaluator import Evaluation, all_finite
from ..errors import RvtoolInputError
from .tapered_set import TaperedLoads
from ..validation import check_body_state, SPATIAL_LAYOUT

N_Q = 5


class SpatialTaperedSet:
    """The tapered mountings of ``planar`` (a :class:`~rvtool.bearings.tapered_set.TaperedBearingSet`
    over n planar bodies) with the out-of-plane coordinates of the bodies in ``tilt_rows`` ({planar
    body: its row among the ``n_virtual`` out-of-plane pose rows appended after the planar bodies});
    a body not in it holds its axial and tilt coordinates. The evaluator protocol of
    :class:`exudyn_user_elements.contact_element.ContactElement` (NumPy host assembly)."""

    def __init__(self, planar, n_virtual, tilt_rows):
        self.planar = planar
        self.name, self.ids, self.history = planar.name, planar.ids, planar.history
        self.mountings = planar.mountings
        n = planar.n_bodies
        self.n_planar, self.n_virtual = n, int(n_virtual)
        self.n_bodies = n + self.n_virtual
        rows = {int(b): int(r) for b, r in tilt_rows.items() if 0 <= b < n}
        g = self.n_bodies                                  # the ground slot
        cols, cage = [], []
        for k, m in enumerate(self.mountings):
            gam = planar.roller_gamma[planar.roller_owner == k]
            if np.ptp(gam) > 0:
                raise RvtoolInputError(f"{m.name}: its rows have different cage ratios {sorted(set(gam.tolist()))}; the "
                                       "spatial tapered set turns one cage per mounting (valid: equal rows)")
            cage.append(gam[0])
            slots = []
            for body in (m.inner, m.outer):
                planar_slot = g if body == GROUND else body
                tilt_slot = n + rows[body] if body in rows else g
                slots += [planar_slot, tilt_slot]
            cols.append(np.concatenate([3 * s + np.arange(3) for s in slots]))
        self.columns = np.array(cols)                      # (M, 12): A (x, y, th), A (z, gx, gy), B ..., B ...
        self.cage_ratio = np.array(cage)
        self.centres = np.array([[m.inner_centre, m.outer_centre] for m in self.mountings], float)
        self._n = 3 * (self.n_bodies + 1)

    def state(self, pose, vel=None):
        """(q5 (M, 5), qdot5 (M, 5), J (M, 5, 12), cage angle (M,), cage rate (M,), a, b (M, 2), x (M, 12))."""
        p = np.vstack([np.asarray(pose, float), np.zeros((1, 3))]).ravel()
        v = np.zeros_like(p) if vel is None else np.vstack([np.asarray(vel, float), np.zeros((1, 3))]).ravel()
        x, xd = p[self.columns], v[self.columns]
        a, b = _rot(x[:, 2], self.centres[:, 0]), _rot(x[:, 8], self.centres[:, 1])
        pa, pb = _perp(a), _perp(b)
        M = len(x)
        gA, gB = x[:, 4:6], x[:, 10:12]
        q = np.zeros((M, N_Q))
        q[:, :2] = x[:, 0:2] + a - x[:, 6:8] - b
        q[:, 2] = x[:, 3] - x[:, 9] + (gA[:, 0] * a[:, 1] - gA[:, 1] * a[:, 0]) - (gB[:, 0] * b[:, 1] - gB[:, 1] * b[:, 0])
        q[:, 3:5] = gA - gB
        J = np.zeros((M, N_Q, 12))
        J[:, 0:2, 0:2] = np.eye(2)
        J[:, 0:2, 2] = pa
        J[:, 0:2, 6:8] = -np.eye(2)
        J[:, 0:2, 8] = -pb
        J[:, 2, 3], J[:, 2, 9] = 1.0, -1.0
        J[:, 2, 4], J[:, 2, 5] = a[:, 1], -a[:, 0]
        J[:, 2, 10], J[:, 2, 11] = -b[:, 1], b[:, 0]
        J[:, 2, 2] = gA[:, 0] * a[:, 0] + gA[:, 1] * a[:, 1]
        J[:, 2, 8] = -(gB[:, 0] * b[:, 0] + gB[:, 1] * b[:, 1])
        J[:, 3, 4], J[:, 3, 10] = 1.0, -1.0
        J[:, 4, 5], J[:, 4, 11] = 1.0, -1.0
        g = self.cage_ratio
        cage = 0.5 * ((1 - g) * x[:, 2] + (1 + g) * x[:, 8])
        cage_rate = 0.5 * ((1 - g) * xd[:, 2] + (1 + g) * xd[:, 8])
        qd = np.einsum("mij,mj->mi", J, xd)
        return q, qd, J, cage, cage_rate, a, b, x, xd

    def raw(self, pose, vel=None):
        """Per-mounting (Q (M, 12), dQ/dx (M, 12, 12), dQ/dv (M, 12, 12), the RelativeEvaluation, state)."""
        q, qd, J, cage, cage_rate, a, b, x, xd = st = self.state(pose, vel)
        rel = self.planar.relative(q, qd, cage, cage_rate)
        w, K, C = rel.wrench, rel.stiffness, rel.damping
        g = self.cage_ratio
        dpsi = np.zeros((len(q), 12))
        dpsi[:, 2], dpsi[:, 8] = 0.5 * (1 - g), 0.5 * (1 + g)
        Q = np.einsum("mij,mi->mj", J, w)
        Jt = np.transpose(J, (0, 2, 1))
        dQ = Jt @ K @ J + Jt @ (rel.cage_sensitivity[:, :, None] * dpsi[:, None, :])
        # the arms turn with theta: the second derivatives of q5 weighted by the wrench
        F, Fz = w[:, 0:2], w[:, 2]
        gA, gB = x[:, 4:6], x[:, 10:12]
        dQ[:, 2, 2] += -np.sum(a * F, axis=1) + Fz * (-gA[:, 0] * a[:, 1] + gA[:, 1] * a[:, 0])
        dQ[:, 8, 8] += np.sum(b * F, axis=1) - Fz * (-gB[:, 0] * b[:, 1] + gB[:, 1] * b[:, 0])
        for i, j, v in ((2, 4, Fz * a[:, 0]), (2, 5, Fz * a[:, 1]), (8, 10, -Fz * b[:, 0]), (8, 11, -Fz * b[:, 1])):
            dQ[:, i, j] += v
            dQ[:, j, i] += v
        # the rate of r through the turning arms (the planar set's velocity terms)
        dqd = np.zeros_like(J)
        dqd[:, 0:2, 2], dqd[:, 0:2, 8] = -xd[:, 2:3] * a, xd[:, 8:9] * b
        dQ += Jt @ C @ dqd
        dQv = Jt @ C @ J + Jt @ (rel.cage_rate_sensitivity[:, :, None] * dpsi[:, None, :])
        return Q, dQ, dQv, rel, st

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state(f"bearing set '{self.name}'", pose, vel, (self.n_bodies, 3), SPATIAL_LAYOUT)

    def observations(self, pose, rel, st):
        """(L, 8) observation rows per lamina: normal force, gap = -approach, the lamina's point
        projected on the plane, the radial direction (as the planar set's)."""
        P = self.planar
        x, b = st[7], st[6]
        lr = P.lamina_roller
        psi = P.roller_phase + st[3][P.roller_owner]
        u = np.column_stack([np.cos(psi[lr]), np.sin(psi[lr])])
        centre = (x[:, 6:8] + b)[P.roller_owner[lr]]
        obs = np.zeros((len(lr), N_OBS))
        obs[:, O_FN], obs[:, O_GAP] = rel.lamina_force, -rel.lamina_approach
        obs[:, O_PX:O_PY + 1] = centre + P.lamina_fp[:, ref.LA_RHO][:, None] * u
        obs[:, O_NX:O_NY + 1] = u
        return obs

    def evaluate(self, pose, vel=None, history=None, check=True):
        if check:
            self.check_state(pose, vel)
        Q, dQ, dQv, rel, st = self.raw(pose, vel)
        n, cols = self._n, self.columns
        Qa = np.bincount(cols.ravel(), weights=Q.ravel(), minlength=n)
        flat = (cols[:, :, None] * n + cols[:, None, :]).ravel()
        Ka = np.bincount(flat, weights=dQ.ravel(), minlength=n * n).reshape(n, n)
        Ca = np.bincount(flat, weights=dQv.ravel(), minlength=n * n).reshape(n, n)
        m = 3 * self.n_bodies
        Qa, Ka, Ca = Qa[:m], Ka[:m, :m], Ca[:m, :m]
        return Evaluation(Qa, Ka, Ca, self.observations(pose, rel, st), (), all_finite(Qa, Ka, Ca))

    def commit(self, pose, vel=None, evaluation=None):
        if evaluation is not None:
            return np.array(evaluation.obs, float)
        return self.evaluate(pose, vel, check=False).obs

    def resultants(self, pose, vel=None):
        """{mounting name: :class:`~rvtool.bearings.tapered_set.TaperedLoads`} on the cones (fed back):
        force, axial force, tilting moment, the wrench and rib force of each row."""
        st = self.state(pose, vel)
        rel = self.planar.relative(st[0], st[1], st[3], st[4])
        P = self.planar
        ribs = np.zeros((len(self.mountings), 2))
        np.add.at(ribs, (P.roller_owner, P.roller_row), rel.rib_force)
        out = {}
        for k, m in enumerate(self.mountings):
            nr = len(m.rows())
            w = rel.wrench[k]
            out[m.name] = TaperedLoads(force=w[:2], axial_force=float(w[2]), tilting_moment=w[3:5],
                                       row_wrenches=rel.row_wrench[k, :nr], rib_forces=ribs[k, :nr])
        return out

    def element_loads(self, obs):
        return self.planar.element_loads(obs)
