"""Explicit-sleeve alternative to the shared-pin condensation (paper,
subsection "Output-pin transfer and a reproducible two-wheel coupling",
last paragraph).

Each pin's sleeve is a planar body with its own coordinates (x_s, y_s,
theta_s), so its motion, and later its inertia, can be studied separately
from the shaft's load redistribution. Two contact groups act through the
sleeve coordinates:

* outer contacts, sleeve in wheel hole i, per slice s: approach
  d_is = |x_s - c_h,i| - (R_h - r_p) - u_off,i and force k_s [d_is]_+^p on the
  wheel along n_is = (x_s - c_h,i)/|x_s - c_h,i|, the opposite on the sleeve;
* inner contacts, shaft in the sleeve bore, at the same 2 n_s slice stations:
  the flexible shaft-to-sleeve interface solves, slice by slice,

      delta_j = delta_j^rigid - sum_k C_jk F_k,   F_k = k_in,s [delta_k]_+^p_in,

  with delta_j^rigid = |x_s - c_p| - c (clearance c), C_jk = C_{w(j) w(k)}
  (m_j . m_k) the station compliance of the slices' wheels projected on the
  inner normals m_j = (x_s - c_p)/|x_s - c_p| (Eq. (pin_compliance) slice by
  slice), solved by Newton's method. The shaft pushes the sleeve toward its
  centre (-F m on the sleeve, +F m on the flange at the pin arm).

Both groups pass through the sleeve centre, so the sleeve carries no moment.
The tangent is forward mode over the 12 coordinates (flange, wheel 0, wheel
1, sleeve), with the interface derivative from the implicit-function theorem
d delta = J^-1 (d delta^rigid - dC F), J = I + C diag(F'). Planar only (no tilts).

:func:`sleeve_equilibrium` places a massless sleeve where its net force
vanishes, the static counterpart of the condensed model's sleeve updates.
"""
import numpy as np

from warp_contacts import output_pins_ref as ref

from ..errors import RvtoolInputError, SolverFailure
from .spec import ExplicitSleeveInterface, OutputPinMechanism, PinMode
from ..validation import check_body_state


def _perp(a):
    return np.array([-a[1], a[0]])


def _rot(th, xi):
    c, s = np.cos(th), np.sin(th)
    return np.array([c * xi[0] - s * xi[1], s * xi[0] + c * xi[1]])


def _unit(v, dv, floor):
    Lr = float(np.hypot(v[0], v[1]))
    if Lr > floor:
        dL = v @ dv / Lr
        L = Lr
    else:
        L, dL = floor, np.zeros(dv.shape[1])
    n = v / L
    return L, n, dL, (dv - np.outer(n, dL)) / L


class ExplicitSleeveModel:
    """Explicit-sleeve forces and tangent for one pin of a shared-mode mechanism (NumPy).

    Coordinates q (12,): flange, wheel 0, wheel 1, sleeve, each (x, y, theta)
    [m, rad], absolute. Uses the geometry, outer law and station compliance of
    ``mechanism`` (its first pin) and the inner interface of ``interface``.
    """

    def __init__(self, mechanism: OutputPinMechanism, interface: ExplicitSleeveInterface):
        if not isinstance(mechanism, OutputPinMechanism) or mechanism.mode != PinMode.SHARED:
            raise RvtoolInputError("mechanism must be an OutputPinMechanism with mode 'shared' "
                                   "(the explicit sleeve uses its station compliance)")
        if not isinstance(interface, ExplicitSleeveInterface):
            raise RvtoolInputError(f"interface must be an ExplicitSleeveInterface; got {type(interface).__name__}")
        self.mechanism = mechanism
        self.interface = interface
        fp, _ = mechanism.packed(0, (1, 2))
        self.fp = fp[0]
        self.stations = mechanism.stations
        self.radius = mechanism.pin_circle_radius

    def _interface(self, drig, ddrig, m, dm, wheel_of):
        """Solve delta = delta^rigid - C F(delta) (Newton) and its tangent."""
        fp, it = self.fp, self.interface
        ns2 = drig.size
        Cs = np.array([[fp[ref.P_C00], fp[ref.P_C01]], [fp[ref.P_C01], fp[ref.P_C11]]])
        Cw = Cs[np.ix_(wheel_of, wheel_of)]
        C = Cw * (m @ m.T)
        ks = it.inner_coefficient / self.stations.size
        p = it.inner_exponent

        def law(d):
            pos = d > 0.0
            ds = np.where(pos, d, 1.0)
            return np.where(pos, ks * ds ** p, 0.0), np.where(pos, p * ks * ds ** (p - 1.0), 0.0)

        d = drig.copy()
        for _ in range(it.max_iterations):
            F, dF = law(d)
            r = d + C @ F - drig
            J = np.eye(ns2) + C * dF[None, :]
            step = np.linalg.solve(J, r)
            d = d - step
            if np.max(np.abs(step)) <= it.tolerance:
                break
        F, dF = law(d)
        # dC_jk = C_w (dm_j . m_k + m_j . dm_k)
        dC = Cw[:, :, None] * (np.einsum("jan,ka->jkn", dm, m) + np.einsum("ja,kan->jkn", m, dm))
        J = np.eye(ns2) + C * dF[None, :]
        dd = np.linalg.solve(J, ddrig - np.einsum("jkn,k->jn", dC, F))
        return d, F, dF[:, None] * dd

    def evaluate(self, q):
        """Q (12,) [N, N m], dQ/dq (12, 12) and a dict of slice quantities at coordinates ``q``."""
        q = np.asarray(q, float)
        if q.shape != (12,):
            raise RvtoolInputError(f"q must have 12 coordinates (flange, wheel 0, wheel 1, sleeve); got shape {q.shape}")
        fp, st = self.fp, self.stations
        ns = st.size
        P = q.reshape(4, 3)
        xs = P[3, :2]
        dxs = np.zeros((2, 12))
        dxs[0, 9], dxs[1, 10] = 1.0, 1.0
        Q = np.zeros(12)
        dQ = np.zeros((12, 12))
        ks = fp[ref.P_K] / ns
        p = fp[ref.P_EXP]
        floor = fp[ref.P_DISTFLOOR]
        outer = np.zeros((2, ns))
        outer_d = np.zeros((2, ns))
        outer_n = np.zeros((2, ns, 2))
        outer_p = np.zeros((2, ns, 2))
        for i in range(2):
            ph = _rot(P[1 + i, 2], fp[ref.P_XI_HOLE0 + 2 * i:ref.P_XI_HOLE0 + 2 * i + 2])
            dh = np.zeros((2, 12))
            dh[0, 3 + 3 * i], dh[1, 4 + 3 * i] = 1.0, 1.0
            dh[:, 5 + 3 * i] = _perp(ph)
            clr = fp[ref.P_R_HOLE] - fp[ref.P_R_PIN] + fp[ref.P_OFF0 + i]
            for s in range(ns):
                L, n, dL, dn = _unit(xs - (P[1 + i, :2] + ph), dxs - dh, floor)
                d = L - clr
                F = ks * d ** p if d > 0 else 0.0
                dF = p * ks * d ** (p - 1.0) * dL if d > 0 else np.zeros(12)
                outer[i, s] = F
                outer_d[i, s] = d
                outer_n[i, s] = n
                outer_p[i, s] = P[1 + i, :2] + ph + 0.5 * (L + fp[ref.P_R_PIN] + fp[ref.P_R_HOLE]) * n
                f = F * n
                df = np.outer(n, dF) + F * dn
                darm = np.zeros((2, 12))
                darm[:, 5 + 3 * i] = _perp(ph)
                Q[3 + 3 * i:5 + 3 * i] += f
                Q[5 + 3 * i] += ph[0] * f[1] - ph[1] * f[0]
                Q[9:11] -= f
                dQ[3 + 3 * i:5 + 3 * i] += df
                dQ[5 + 3 * i] += ph[0] * df[1] - ph[1] * df[0] + darm[0] * f[1] - darm[1] * f[0]
                dQ[9:11] -= df
        # inner interface: 2 ns slices at the wheel stations (planar: one shaft centre)
        pf = _rot(P[0, 2], fp[ref.P_XI_PIN:ref.P_XI_PIN + 2])
        dcp = np.zeros((2, 12))
        dcp[0, 0], dcp[1, 1] = 1.0, 1.0
        dcp[:, 2] = _perp(pf)
        L, m1, dL, dm1 = _unit(xs - (P[0, :2] + pf), dxs - dcp, floor)
        wheel_of = np.repeat([0, 1], ns)
        m = np.tile(m1, (2 * ns, 1))
        dm = np.tile(dm1, (2 * ns, 1, 1))
        drig = np.full(2 * ns, L - self.interface.clearance)
        ddrig = np.tile(dL, (2 * ns, 1))
        delta, Fin, dFin = self._interface(drig, ddrig, m, dm, wheel_of)
        darm_f = np.zeros((2, 12))
        darm_f[:, 2] = _perp(pf)
        for j in range(2 * ns):
            f = Fin[j] * m[j]                                   # on the flange; -f on the sleeve
            df = np.outer(m[j], dFin[j]) + Fin[j] * dm[j]
            Q[0:2] += f
            Q[2] += pf[0] * f[1] - pf[1] * f[0]
            Q[9:11] -= f
            dQ[0:2] += df
            dQ[2] += pf[0] * df[1] - pf[1] * df[0] + darm_f[0] * f[1] - darm_f[1] * f[0]
            dQ[9:11] -= df
        info = {"outer_force": outer, "outer_approach": outer_d, "outer_normal": outer_n, "outer_point": outer_p,
                "inner_force": Fin.reshape(2, ns), "inner_approach": delta.reshape(2, ns), "inner_normal": m1,
                "shaft_centre": P[0, :2] + pf, "sleeve_offset": xs - (P[0, :2] + pf)}
        return Q, dQ, info

    def sleeve_equilibrium(self, q9, start_offset=(0.0, 0.0), tol=1e-6, max_iterations=100):
        """Massless sleeve: Newton on (x_s, y_s) until the net sleeve force is below ``tol`` [N].

        Returns (q12, Q, K_q = -dQ/dq, info). Backtracking halves a step that
        does not reduce the force residual (the clearance makes the sleeve
        stiffness jump from the outer contacts alone to the inner law).
        """
        q9 = np.asarray(q9, float)
        pf = _rot(q9[2], self.fp[ref.P_XI_PIN:ref.P_XI_PIN + 2])
        q = np.concatenate([q9, q9[0:2] + pf + np.asarray(start_offset, float), [0.0]])
        Q, dQ, info = self.evaluate(q)
        for _ in range(max_iterations):
            res = Q[9:11]
            if np.linalg.norm(res) <= tol:
                break
            step = np.linalg.solve(dQ[9:11, 9:11], -res)
            lam = 1.0
            while lam > 1e-6:
                qt = q.copy()
                qt[9:11] += lam * step
                Qt, dQt, it = self.evaluate(qt)
                if np.linalg.norm(Qt[9:11]) < np.linalg.norm(res):
                    break
                lam *= 0.5
            q, Q, dQ, info = qt, Qt, dQt, it
        else:
            raise SolverFailure(f"sleeve equilibrium did not reach tol = {tol} N in {max_iterations} iterations "
                                   f"(residual {np.linalg.norm(Q[9:11]):.3e} N)")
        return q, Q, -dQ, info


class ExplicitSleeveEvaluator:
    """The explicit-sleeve model behind the contact-element evaluator protocol.

    Bodies (in this order): flange, wheel 0, wheel 1, sleeve, each a planar
    rigid body (x, y, theta); give the sleeve node its own mass and inertia to
    study the inertia assumption, or a small one for a nearly massless sleeve.
    Observed contacts: the 2 n_s outer slices (sleeve in wheel holes), then the
    2 n_s inner slices (shaft in sleeve bore, normal = direction of the force on
    the flange, point = shaft centre). No history; dQ/dv = 0.
    """

    def __init__(self, mechanism: OutputPinMechanism, interface: ExplicitSleeveInterface, *, name="explicit_sleeve"):
        from .evaluator import NoHistory
        self.model = ExplicitSleeveModel(mechanism, interface)
        self.name = name
        self.n_bodies = 4
        ns = mechanism.n_slices
        self.ids = tuple(f"{name}/outer/wheel{w}/slice{s}" for w in range(2) for s in range(ns)) + \
            tuple(f"{name}/inner/station{w}/slice{s}" for w in range(2) for s in range(ns))
        self.history = NoHistory()

    def check_state(self, pose, vel):
        """Raise :class:`RvtoolInputError` for a state of the wrong shape or with NaN/inf."""
        check_body_state("the explicit sleeve", pose, vel, (4, 3), "flange, wheel 0, wheel 1, sleeve")

    @staticmethod
    def _observations(info):
        from warp_contacts import circle_pairs_ref as cref
        ns = info["outer_force"].shape[1]
        obs = np.zeros((4 * ns, cref.N_OBS))
        obs[:2 * ns, cref.O_FN] = info["outer_force"].ravel()
        obs[:2 * ns, cref.O_GAP] = -info["outer_approach"].ravel()
        obs[:2 * ns, cref.O_PX:cref.O_PY + 1] = info["outer_point"].reshape(-1, 2)
        obs[:2 * ns, cref.O_NX:cref.O_NY + 1] = info["outer_normal"].reshape(-1, 2)
        obs[2 * ns:, cref.O_FN] = info["inner_force"].ravel()
        obs[2 * ns:, cref.O_GAP] = -info["inner_approach"].ravel()
        obs[2 * ns:, cref.O_PX:cref.O_PY + 1] = info["shaft_centre"]
        obs[2 * ns:, cref.O_NX:cref.O_NY + 1] = info["inner_normal"]
        return obs

    def evaluate(self, pose, vel, history=None, check=True):
        from rvtool.contact.evaluator import Evaluation
        if check:
            self.check_state(pose, vel)
        Q, dQ, info = self.model.evaluate(np.asarray(pose, float).ravel())
        finite = bool(np.all(np.isfinite(Q)) and np.all(np.isfinite(dQ)))
        return Evaluation(Q, dQ, np.zeros_like(dQ), self._observations(info), (), finite)

    def commit(self, pose, vel, evaluation=None):
        if evaluation is not None:
            return np.array(evaluation.obs, np.float64)
        return self._observations(self.model.evaluate(np.asarray(pose, float).ravel())[2])
