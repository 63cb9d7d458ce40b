"""NumPy reference of tapered-roller bearing contacts with analytic tangent
(readable version of :mod:`warp_contacts.tapered_rollers`).

Frame and coordinates. The bearing axis is e_z. Per roller the state is the
relative displacement of the inner ring (cone) with respect to the outer ring
(cup) at the bearing's reference point O on the axis, in the cup's frame,

    q = (delta_x, delta_y, delta_z, gamma_x, gamma_y)   [m, m, m, rad, rad],

(rotation about the axis is free: it only advances the cage), its rate q_dot,
the roller's azimuth psi [rad] and the cage rate psi_dot [rad/s]. A point of
the cone at radius rho and axial position z on azimuth psi moves by
d = t + gamma x p (small rotations), so its displacement along a meridional
direction n = (n_r, n_z) is g . q with

    g = (n_r cos psi, n_r sin psi, n_z, (n_z rho - n_r z) sin psi, (n_r z - n_z rho) cos psi),

linear in q, and h = dg/dpsi.

Laminae (one row per lamina, grouped by roller). Each roller is sliced along
its generator; a lamina has a contact point (rho, z), a normal (n_r, n_z), a
coefficient k_s and exponent p of Eq. (normal_force) (Palmgren's line-contact
law p = 10/9, inner and outer contacts in series, or its secant p = 1), a
fixed offset o_s = clearance + crowning drop, damping c_d and ramp delta_r.
Its approach is

    delta_s = g_s . (q + z_pre e_3) - kappa a - o_s,

with z_pre the row's axial pre-displacement (preload, or minus half the end
play) and a the roller's axial position along its own axis (below);
F_s = max(0, k_s delta_s^p + c_d rho(delta_s) delta_s_dot) of Eq. (normal_force),
delta_s_dot = g_s . q_dot + (h_s . q) psi_dot.

Rib contact (integer column RI_RIB):

* 0, cone and rib lumped (rigid rib, the classical model): the laminae use
  the cup contact points and the cup normal n_o = (cos alpha_o, -sigma sin alpha_o)
  and a = 0 in the approach. A rigid rib holds the roller's axial position to the
  cone; the raceway normal forces Q n_i on the cone and the rib reaction
  2 sin(phi) Q e_a add up to Q n_o (phi the roller half-angle), so each
  lamina transmits its load along the cup normal (Harris & Kotzalas,
  Rolling Bearing Analysis, 5th ed., vol. 1, ch. 7). The rib reaction
  kappa sum_s F_s (kappa = 2 sin(phi)) and the roller's axial position
  (that of the cone's rib point) are returned as observations.
* 1, elastic rib: the laminae use the cone contact points and the cone
  normal n_i; the roller slides along its axis e_a by a (relative to the
  cup) against the rib, a Hertz point contact of its spherical large end,
  F_f = K_f <delta_f>_+^(3/2), delta_f = a - g_f . q - c_f (g_f of the rib
  point and normal e_a, c_f the rib play). The lamina approach loses
  kappa a with kappa = 2 sin(phi) because n_o - n_i = -kappa e_a. a solves
  the roller's axial balance

      H(a) = F_f(delta_f) - kappa sum_s F_s(delta_s) = 0,

  which is increasing in a, so its root is unique (found by Newton's method
  safeguarded by bisection on a bracket). This path is elastic only
  (damping must be zero; the specification enforces it).

Outputs per roller: the wrench on the cone f = -sum_s F_s g_s + F_f g_f
(F_x, F_y, F_z, M_x, M_y about O; the cup carries -f), df/dq, df/dq_dot,
df/dpsi, df/dpsi_dot and the rib values (F_f, a); per lamina (F_s, delta_s).
With the elastic rib the elimination of a enters the tangent through
da/dq = (F_f' g_f + kappa sum_s F_s' g_s) / H'(a), H' = F_f' + kappa^2 sum_s F_s'.
"""
import numpy as np

from . import laws_ref

# roller columns (float): rib stiffness K_f [N m^-3/2], rib play c_f [m], rib point rho, z [m],
# rib normal (the roller axis e_a) n_r, n_z, kappa = 2 sin(phi) [-], the row's axial pre-displacement [m]
(RL_KF, RL_CF, RL_FRHO, RL_FZ, RL_FNR, RL_FNZ, RL_KAPPA, RL_ZPRE) = range(8)
N_ROLLER_FLOAT = 8
# roller columns (int): first lamina row, number of laminae, rib mode (0 lumped, 1 elastic)
(RI_FIRST, RI_COUNT, RI_RIB) = range(3)
N_ROLLER_INT = 3
# lamina columns (float): contact point rho, z [m], normal n_r, n_z, coefficient k [N m^-p], exponent p,
# offset (clearance + crowning) [m], damping [N s/m], ramp depth [m]
(LA_RHO, LA_Z, LA_NR, LA_NZ, LA_K, LA_P, LA_OFF, LA_DAMP, LA_RAMP) = range(9)
N_LAMINA_FLOAT = 9
# per-roller rib output: rib force F_f [N], roller axial position a [m]
RIB_F, RIB_A = range(2)
# per-lamina output: normal force F_s [N], approach delta_s [m]
LAM_F, LAM_DELTA = range(2)
#: exponent of the rib's Hertz point contact
RIB_EXPONENT = 1.5
#: Newton--bisection iterations of the roller's axial balance (float64 converges in < 12 from
#: the bracket; the bound only guards the kernel's loop)
RIB_MAX_ITERATIONS = 60
#: relative step at which the balance iteration stops (a few float64 ulp of the bracket; the
#: kernel uses 8 ulp of its precision)
RIB_RTOL = 1e-14
N_Q = 5


def meridional_gradient(rho, z, nr, nz, psi):
    """g (.., 5) and h = dg/dpsi of the displacement along (n_r, n_z) of the point (rho, z) at psi."""
    rho, z, nr, nz, psi = np.broadcast_arrays(*(np.asarray(x, float) for x in (rho, z, nr, nz, psi)))
    c, s = np.cos(psi), np.sin(psi)
    m = nz * rho - nr * z
    g = np.stack([nr * c, nr * s, nz, m * s, -m * c], axis=-1)
    h = np.stack([-nr * s, nr * c, np.zeros_like(c), m * c, m * s], axis=-1)
    return g, h


def rib_position(b, bf, k, p, kf, kappa, cf, rtol):
    """Root a of H(a) = K_f <a - b_f - c_f>^(3/2) - kappa sum_s k_s <b_s - kappa a>^p for one roller
    (b_s the lamina approaches at a = 0, b_f the rib point's axial displacement); the roller is
    unloaded (a = b_f + c_f) when every lamina is open there."""
    lo = bf + cf
    if np.max(b - kappa * lo) <= 0.0:
        return lo
    hi = np.max(b) / kappa
    a = 0.5 * (lo + hi)
    tol = rtol * (abs(lo) + abs(hi))
    for _ in range(RIB_MAX_ITERATIONS):
        fs, dfs = laws_ref.power_law(k, p, b - kappa * a)
        ff, dff = laws_ref.power_law(kf, RIB_EXPONENT, a - lo)
        H = ff - kappa * np.sum(fs)
        dH = dff + kappa * kappa * np.sum(dfs)
        if H > 0:
            hi = a
        else:
            lo = a
        # Newton inside the bracket, else bisection; bounds inclusive so that a vanishing Newton
        # step at the root ends the iteration instead of falling back to a bisection
        step = H / dH if dH > 0 else np.inf
        a_new = a - step
        if not lo <= a_new <= hi:
            a_new = 0.5 * (lo + hi)
        if abs(a_new - a) <= tol:
            return a_new
        a = a_new
    return a


def evaluate(q, qdot, psi, psidot, roller_fp, roller_ip, lamina_fp, rtol=RIB_RTOL):
    """Evaluate every roller (see the module docstring).

    q, qdot (R, 5); psi, psidot (R,); roller_fp (R, N_ROLLER_FLOAT); roller_ip (R, N_ROLLER_INT);
    lamina_fp (L, N_LAMINA_FLOAT). Returns f (R,5), df/dq (R,5,5), df/dq_dot (R,5,5),
    df/dpsi (R,5), df/dpsi_dot (R,5), rib (R,2) (RIB_* columns), lam (L,2) (LAM_* columns).
    """
    q, qdot = np.asarray(q, float), np.asarray(qdot, float)
    rf, ri, lf = np.asarray(roller_fp, float), np.asarray(roller_ip), np.asarray(lamina_fp, float)
    R = len(rf)
    f, K, C = np.zeros((R, N_Q)), np.zeros((R, N_Q, N_Q)), np.zeros((R, N_Q, N_Q))
    fpsi, fpsid, rib, lam = np.zeros((R, N_Q)), np.zeros((R, N_Q)), np.zeros((R, 2)), np.zeros((len(lf), 2))
    for j in range(R):
        sl = slice(ri[j, RI_FIRST], ri[j, RI_FIRST] + ri[j, RI_COUNT])
        L = lf[sl]
        qe = q[j].copy()
        qe[2] += rf[j, RL_ZPRE]
        g, h = meridional_gradient(L[:, LA_RHO], L[:, LA_Z], L[:, LA_NR], L[:, LA_NZ], psi[j])
        b = g @ qe - L[:, LA_OFF]
        bpsi = h @ qe                                   # d b / d psi
        kappa = rf[j, RL_KAPPA]
        gf, hf = meridional_gradient(rf[j, RL_FRHO], rf[j, RL_FZ], rf[j, RL_FNR], rf[j, RL_FNZ], psi[j])
        bf = gf @ qe                                    # axial displacement of the rib point along e_a
        if ri[j, RI_RIB]:
            kf, cf = rf[j, RL_KF], rf[j, RL_CF]
            a = rib_position(b, bf, L[:, LA_K], L[:, LA_P], kf, kappa, cf, rtol)
            delta = b - kappa * a
            F, dF = laws_ref.power_law(L[:, LA_K], L[:, LA_P], delta)
            Ff, dFf = laws_ref.power_law(kf, RIB_EXPONENT, a - bf - cf)
            Ha = dFf + kappa * kappa * np.sum(dF)
            sum_dFg = dF @ g
            a_q = (dFf * gf + kappa * sum_dFg) / Ha if Ha > 0 else np.zeros(N_Q)
            a_psi = (dFf * (hf @ qe) + kappa * (dF @ bpsi)) / Ha if Ha > 0 else 0.0
            f[j] = -F @ g + Ff * gf
            K[j] = -g.T @ (dF[:, None] * (g - kappa * a_q)) + dFf * np.outer(gf, a_q - gf)
            fpsi[j] = (-g.T @ (dF * (bpsi - kappa * a_psi)) - F @ h
                       + dFf * (a_psi - hf @ qe) * gf + Ff * hf)
            rib[j] = Ff, a
        else:
            delta = b
            dd = g @ qdot[j] + bpsi * psidot[j]          # delta_s_dot
            F, dF, dFd = laws_ref.normal_force(L[:, LA_K], L[:, LA_P], L[:, LA_DAMP], L[:, LA_RAMP], delta, dd)
            # d delta_dot / d psi = h . q_dot + (dh/dpsi . q) psi_dot, dh/dpsi = -(g - n_z e_3)
            dd_psi = h @ qdot[j] - (g @ qe - L[:, LA_NZ] * qe[2]) * psidot[j]
            f[j] = -F @ g
            K[j] = -g.T @ (dF[:, None] * g + (dFd * psidot[j])[:, None] * h)
            C[j] = -g.T @ (dFd[:, None] * g)
            fpsi[j] = -g.T @ (dF * bpsi + dFd * dd_psi) - F @ h
            fpsid[j] = -g.T @ (dFd * bpsi)
            # the rigid rib's reaction; the roller follows the cone's rib point
            rib[j] = kappa * np.sum(F), bf
        lam[sl, LAM_F], lam[sl, LAM_DELTA] = F, delta
    return f, K, C, fpsi, fpsid, rib, lam


def influence_approaches(q, psi, roller_fp, lamina_fp, rows):
    """Slice approaches of influence-coefficient rollers (rigid rib, Eq. (bearing_ic)): per roller r of
    ``rows`` (Ri, n_max) lamina indices (-1 padding), s = g . (q + z_pre e_3) - o_s (Ri, n_max) [m],
    with g, h (Ri, n_max, 5) and the rib point's axial displacement b_f (Ri,)."""
    q, psi = np.asarray(q, float), np.asarray(psi, float)
    rf, lf = np.asarray(roller_fp, float), np.asarray(lamina_fp, float)
    qe = q.copy()
    qe[:, 2] += rf[:, RL_ZPRE]
    L = lf[np.where(rows < 0, 0, rows)]
    g, h = meridional_gradient(L[..., LA_RHO], L[..., LA_Z], L[..., LA_NR], L[..., LA_NZ], psi[:, None])
    pad = rows < 0
    g[pad], h[pad] = 0.0, 0.0
    s = np.where(pad, 0.0, np.einsum("rsk,rk->rs", g, qe) - L[..., LA_OFF])
    gf, _ = meridional_gradient(rf[:, RL_FRHO], rf[:, RL_FZ], rf[:, RL_FNR], rf[:, RL_FNZ], psi)
    return s, g, h, qe, np.einsum("rk,rk->r", gf, qe)


def influence_wrench(F, J, g, h, qe, kappa, bf, damping=None):
    """Per-roller results of influence-coefficient rollers from their slice forces F (Ri, n) [N] and
    tangent J = dF/ds (Ri, n, n) [N/m]: the lumped-rib branch of :func:`evaluate` with the slice solve
    in place of the laminae's power law. Returns f, df/dq, df/dq_dot, df/dpsi, df/dpsi_dot and the
    rigid rib's values (kappa sum F, b_f); ds/dpsi = h . q.

    ``damping`` = (s (Ri, n) slice approaches, qdot (Ri, 5), psidot (Ri,), c_d (Ri, n), ramp depth
    (Ri, n)) adds the lamina's viscous term c_d rho(s) s_dot of Eq. (normal_force) on every slice in
    contact (elastic force > 0), no tension, s_dot = g . q_dot + (h . q) psi_dot, with the velocity
    terms of the lamina path of :func:`evaluate`. Returns the slice forces too (damping included)."""
    bpsi = np.einsum("rsk,rk->rs", h, qe)
    R = len(F)
    Jon, Ft = J, F
    Fd = np.zeros_like(F)          # dF/d s_dot
    dFv = np.zeros_like(F)         # d(viscous force)/ds at fixed s_dot
    dd_psi = np.zeros_like(F)      # d s_dot / d psi
    psid = np.zeros(R)
    if damping is not None:
        s, qdot, psid, cd, ramp = damping
        sd = np.einsum("rsk,rk->rs", g, qdot) + bpsi * psid[:, None]
        rho, drho = laws_ref.damping_ramp(s, ramp)
        Ft = F + cd * rho * sd
        on = (F > 0) & (Ft > 0)
        Ft = np.where(on, Ft, 0.0)
        Jon = np.where(on[:, :, None], J, 0.0)
        Fd = np.where(on, cd * rho, 0.0)
        dFv = np.where(on, cd * drho * sd, 0.0)
        # d s_dot / d psi = h . q_dot + (dh/dpsi . q) psi_dot, dh/dpsi = -(g - n_z e_3) (lamina path)
        gq = np.einsum("rsk,rk->rs", g, qe) - g[..., 2] * qe[:, None, 2]
        dd_psi = np.einsum("rsk,rk->rs", h, qdot) - gq * psid[:, None]
    f = -np.einsum("rs,rsk->rk", Ft, g)
    K = (-np.einsum("rsi,rst,rtj->rij", g, Jon, g) - np.einsum("rsi,rs,rsj->rij", g, dFv, g)
         - np.einsum("rsi,rs,rsj->rij", g, Fd * psid[:, None], h))
    C = -np.einsum("rsi,rs,rsj->rij", g, Fd, g)
    fpsi = (-np.einsum("rsi,rst,rt->ri", g, Jon, bpsi) - np.einsum("rsi,rs->ri", g, dFv * bpsi + Fd * dd_psi)
            - np.einsum("rs,rsk->rk", Ft, h))
    fpsid = -np.einsum("rsi,rs->ri", g, Fd * bpsi)
    rib = np.column_stack([kappa * Ft.sum(axis=1), bf])
    return f, K, C, fpsi, fpsid, rib, Ft
