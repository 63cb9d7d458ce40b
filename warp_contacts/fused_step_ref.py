"""NumPy reference of the fused dynamic stepper (:mod:`warp_contacts.fused_step`).

B independent copies of one planar reducer (n = 3 nb coordinates each: shaft, wheels, flange;
lumped bearings, rigid housing, frictionless or regularized-friction contacts) are integrated
in time side by side, each with its own time and step. One step of a copy is Exudyn's
generalized-alpha step (``MainSolverImplicitSecondOrder``, the Arnold--Brüls form that
:class:`rvtool.solver.run_spec.RunSpec` configures: spectral radius rho_inf, not Newmark,
index-3 coordinate constraints, full Newton, initial accelerations computed):

* parameters, Eq. (alpha_parameters): alpha_m = (2 rho - 1)/(rho + 1), alpha_f = rho/(rho + 1),
  gamma = 1/2 + alpha_f - alpha_m, beta = (gamma + 1/2)^2 / 4;
* predictor from (q0, v0, a0, abar0) (abar: the algorithmic acceleration):
  q = q0 + h v0 + h^2 (1/2 - beta) abar0, v = v0 + h (1 - gamma) abar0,
  abar = (alpha_f a0 - alpha_m abar0)/(1 - alpha_m), q += h^2 beta abar, v += h gamma abar, a = 0;
* Newton on the residual r = M a - f(q, v) (f: contact forces + output load; Exudyn's ODE2
  residual) with the unknown increment D of the coordinates: J = s (beta' M - K - gamma' C),
  s = beta h^2, beta' = (1 - alpha_m)/(h^2 beta (1 - alpha_f)), gamma' = gamma/(h beta),
  K = df/dq, C = df/dv; J D = s r; q -= D, v -= gamma' D, a -= beta' D;
* the fixed coordinates (coordinate locks, the drive) are Exudyn's CoordinateConstraints
  (Lagrange multipliers lambda): their coordinates take the prescribed values at the step end
  (locks 0; drive angle, speed and acceleration of the motion), their multipliers follow
  Exudyn's update lambda -= (s r_x - J_xf D_f)/s, and their rows r_x = M a_x - f_x + lambda_x
  enter the residual norm as in Exudyn (lambda = 0 at the predictor);
* convergence as Exudyn's Newton: initial residual |r| at the predictor (at least 2 abs_tol),
  raised to the first iterate's if that is larger (``adaptInitialResidual``); converged when
  |r|/initial <= rel_tol or |r| <= abs_tol; at most ``max_iterations`` iterations;
* accepted: abar += (1 - alpha_f)/(1 - alpha_m) a (Exudyn's FinalizeNewton);
* rejected (no convergence, non-finite values, a zero pivot): the copy's start-of-step state is
  restored and the step halved (not below h_min) and retried; a copy whose step is already
  h_min is FAILED and stops (the other copies go on). After ``recovery`` accepted steps since
  the last change, an accepted step with fewer than ``recovery_iterations`` - 1 Newton
  iterations doubles the step (at most the nominal step) and restarts the count (Exudyn's
  adaptiveStepRecoverySteps / adaptiveStepRecoveryIterations, the post-Newton pass counted as
  one iteration); a copy ends once t >= t_end - END_TOLERANCE (Exudyn's end test).

Arrays: q, v, a, abar (B, n) [m, rad and rates] are displacements from each copy's reference
configuration; t, h (B,) [s]; status (B,); counters (B, N_COUNT); the history (B, K, N_HISTORY)
of the accepted steps of one call (columns H_*). Parameter columns (S_*, M_*, H_*, C_*) are
named here once and shared with the kernel.
"""
import numpy as np

from . import circle_pairs_ref as cref
from . import cycloid_pins_ref as pref
from . import output_pins_ref as oref

# settings vector (N_SETTINGS,)
(S_ALPHA_M, S_ALPHA_F, S_BETA, S_GAMMA, S_ABS_TOL, S_REL_TOL, S_MAX_IT, S_H_NOM, S_H_MIN, S_T_END,
 S_RECOVERY, S_RECOVERY_ITERATIONS) = range(12)
N_SETTINGS = 12
END_TOLERANCE = 1e-10     # [s] Exudyn's: the run ends once t >= end_time - 1e-10
# prescribed input motion per copy (B, N_MOTION): angle(t) = angle + speed t + accel t^2 / 2
M_ANGLE, M_SPEED, M_ACCEL = range(3)
N_MOTION = 3
# history of accepted steps (B, K, N_HISTORY)
(H_TIME, H_INPUT, H_OUTPUT, H_TORQUE, H_PIN, H_OUTPUT_PIN, H_BEARING, H_STEP, H_NEWTON) = range(9)
N_HISTORY = 9
# counters per copy (B, N_COUNT)
C_ACCEPTED, C_REJECTED, C_NEWTON, C_RUN, C_RECORDED = range(5)
N_COUNT = 5
# status per copy
ACTIVE, DONE, FAILED = 0, 1, 2


def alpha_parameters(spectral_radius):
    """(alpha_m, alpha_f, beta, gamma) of Exudyn's generalized-alpha, Eq. (alpha_parameters)."""
    rho = float(spectral_radius)
    am = (2.0 * rho - 1.0) / (rho + 1.0)
    af = rho / (rho + 1.0)
    gamma = 0.5 + af - am
    return am, af, 0.25 * (gamma + 0.5) ** 2, gamma


def prescribed(motion, free, input_index, t):
    """(q, v, a) (n,) of the fixed coordinates at time t: the drive's angle, speed and
    acceleration on ``input_index``, zero on the locks (free coordinates: zero, unused)."""
    n = len(free)
    q, v, a = np.zeros(n), np.zeros(n), np.zeros(n)
    q[input_index] = motion[M_ANGLE] + motion[M_SPEED] * t + 0.5 * motion[M_ACCEL] * t * t
    v[input_index] = motion[M_SPEED] + motion[M_ACCEL] * t
    a[input_index] = motion[M_ACCEL]
    return q, v, a


class ReferenceModel:
    """The copies' model in NumPy (see :class:`warp_contacts.fused_step.FusedStepper` for the
    fields). Rows are global: copy p owns rows p R .. p R + R - 1 of every family, bodies
    p nb .. p nb + nb - 1, the ground is pose row B nb."""

    def __init__(self, *, pin_f, pin_i, tables, window, analytic, op_f, op_i, stations, brg_f, brg_i, loc_pin,
                 loc_op, loc_brg, reference, mass, free, input_index, output_index, motion, torque, settings):
        self.__dict__.update({k: v for k, v in locals().items() if k != "self"})
        self.B, self.n = reference.shape
        self.nb = self.n // 3

    def forces(self, p, q, v):
        """Contact forces + load f (n,), K = df/dq, C = df/dv (n, n) of copy p at (q, v), and the
        peak loads (pin, output pin, bearing) [N]."""
        B, n, nb = self.B, self.n, self.nb
        pose = np.zeros((B * nb + 1, 3))
        vel = np.zeros((B * nb + 1, 3))
        pose[p * nb:(p + 1) * nb] = (self.reference[p] + q).reshape(nb, 3)
        vel[p * nb:(p + 1) * nb] = v.reshape(nb, 3)
        f = np.zeros(n)
        K = np.zeros((n, n))
        C = np.zeros((n, n))

        def add(Q, dQ, dV, loc):
            for rr in range(loc.shape[0]):
                for i, li in enumerate(loc[rr]):
                    if li < 0:
                        continue
                    f[li] += Q[rr, i]
                    for j, lj in enumerate(loc[rr]):
                        if lj >= 0:
                            K[li, lj] += dQ[rr, i, j]
                            if dV is not None:
                                C[li, lj] += dV[rr, i, j]
        rp = len(self.loc_pin)
        sl = slice(p * rp, (p + 1) * rp)
        Qp, dQp, dVp, obs_p = pref.evaluate(pose, vel, self.pin_f[sl], self.pin_i[sl], self.tables, self.window,
                                            self.analytic)
        add(Qp, dQp, dVp, self.loc_pin)
        ro = len(self.loc_op)
        so = slice(p * ro, (p + 1) * ro)
        op = oref.evaluate_plain(pose, self.op_f[so], self.op_i[so], self.stations)
        add(op["Q"], op["dQdq"], None, self.loc_op)
        rb = len(self.loc_brg)
        sb = slice(p * rb, (p + 1) * rb)
        z = np.zeros((rb, 2))
        Qb, dQb, dVb, obs_b, _ = cref.evaluate(pose, vel, self.brg_f[sb], self.brg_i[sb], np.zeros(rb, np.int32), z, z)
        add(Qb, dQb, dVb, self.loc_brg)
        f[self.output_index] += self.torque[p]
        peaks = (float(np.max(obs_p[:, cref.O_FN])), float(np.max(np.hypot(op["Q"][:, 0], op["Q"][:, 1]))),
                 float(np.max(obs_b[:, cref.O_FN])))
        return f, K, C, peaks

    def initial_accelerations(self, p, q, v):
        """Exudyn's computeInitialAccelerations: M a = f on the free coordinates, the fixed
        coordinates' prescribed accelerations (the constraints at acceleration level)."""
        f, _, _, _ = self.forces(p, q, v)
        _, _, a = prescribed(self.motion[p], self.free, self.input_index, 0.0)
        return np.where(self.free, f / self.mass[p], a)

    def attempt(self, p, q0, v0, a0, g0, t0, h):
        """One generalized-alpha step attempt of copy p (module docstring). Returns
        (converged, q, v, a, abar, Newton iterations, drive torque [N m], peaks)."""
        s = self.settings
        am, af, beta, gamma = s[S_ALPHA_M], s[S_ALPHA_F], s[S_BETA], s[S_GAMMA]
        free = self.free
        fixed = ~free
        M = self.mass[p]
        q = q0 + h * v0 + h * h * (0.5 - beta) * g0
        v = v0 + h * (1.0 - gamma) * g0
        g = (af * a0 - am * g0) / (1.0 - am)
        q = q + h * h * beta * g
        v = v + h * gamma * g
        a = np.zeros_like(q)
        qx, vx, ax = prescribed(self.motion[p], free, self.input_index, t0 + h)
        q = np.where(free, q, qx)
        v = np.where(free, v, vx)
        a = np.where(free, a, ax)
        sc = beta * h * h
        bp = (1.0 - am) / (h * h * beta * (1.0 - af))
        gp = gamma / (h * beta)
        lam = np.zeros_like(q)
        f, K, C, peaks = self.forces(p, q, v)
        r = M * a - f + lam
        initial = float(np.sqrt(np.sum(r * r)))
        if not np.isfinite(initial):
            return False, q, v, a, g, 0, 0.0, peaks
        initial = max(initial, 2.0 * s[S_ABS_TOL])
        for it in range(1, int(s[S_MAX_IT]) + 1):
            J = sc * (bp * np.diag(M) - K - gp * C)
            try:
                d = np.linalg.solve(J[np.ix_(free, free)], sc * r[free])
            except np.linalg.LinAlgError:
                return False, q, v, a, g, it, 0.0, peaks
            D = np.zeros_like(q)
            D[free] = d
            lam = np.where(fixed, lam - (sc * r - J @ D) / sc, 0.0)
            q = q - D
            v = v - gp * D
            a = a - bp * D
            f, K, C, peaks = self.forces(p, q, v)
            r = M * a - f + lam
            res = float(np.sqrt(np.sum(r * r)))
            if not np.isfinite(res):
                return False, q, v, a, g, it, 0.0, peaks
            if it == 1 and res > initial:
                initial = res
            if res / initial <= s[S_REL_TOL] or res <= s[S_ABS_TOL]:
                torque = M[self.input_index] * a[self.input_index] - f[self.input_index]
                return True, q, v, a, g + (1.0 - af) / (1.0 - am) * a, it, torque, peaks
        return False, q, v, a, g, int(s[S_MAX_IT]), 0.0, peaks

    def advance(self, state, n_steps):
        """Up to ``n_steps`` accepted steps of every ACTIVE copy (module docstring). state: dict
        with q, v, a, abar (B, n), t, h (B,), status (B,), counters (B, N_COUNT); updated in
        place. Returns the history (B, n_steps, N_HISTORY) (rows beyond C_RECORDED: zero)."""
        s = self.settings
        hist = np.zeros((self.B, n_steps, N_HISTORY))
        for p in range(self.B):
            cnt = state["counters"][p]
            cnt[C_RECORDED] = 0
            while state["status"][p] == ACTIVE and cnt[C_RECORDED] < n_steps:
                t0, h = state["t"][p], state["h"][p]
                if t0 + h > s[S_T_END]:
                    h = s[S_T_END] - t0
                ok, q, v, a, g, its, torque, peaks = self.attempt(p, state["q"][p], state["v"][p], state["a"][p],
                                                                  state["abar"][p], t0, h)
                cnt[C_NEWTON] += its
                if ok:
                    t1 = t0 + h
                    state["q"][p], state["v"][p], state["a"][p], state["abar"][p] = q, v, a, g
                    state["t"][p] = t1
                    cnt[C_ACCEPTED] += 1
                    cnt[C_RUN] += 1
                    k = cnt[C_RECORDED]
                    hist[p, k, [H_TIME, H_INPUT, H_OUTPUT, H_TORQUE, H_PIN, H_OUTPUT_PIN, H_BEARING, H_STEP, H_NEWTON]] = (
                        t1, q[self.input_index], self.reference[p, self.output_index] + q[self.output_index], torque,
                        peaks[0], peaks[1], peaks[2], h, its)
                    cnt[C_RECORDED] += 1
                    if cnt[C_RUN] >= s[S_RECOVERY] and its + 1 < s[S_RECOVERY_ITERATIONS]:
                        state["h"][p] = min(s[S_H_NOM], 2.0 * state["h"][p])
                        cnt[C_RUN] = 0
                    if t1 >= s[S_T_END] - END_TOLERANCE:
                        state["status"][p] = DONE
                else:
                    cnt[C_REJECTED] += 1
                    cnt[C_RUN] = 0
                    if state["h"][p] > s[S_H_MIN]:
                        state["h"][p] = max(s[S_H_MIN], 0.5 * state["h"][p])
                    else:
                        state["status"][p] = FAILED
        return hist
