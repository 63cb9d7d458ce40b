"""NumPy reference of rolling-element bearing contacts with analytic tangent
(readable version of :mod:`warp_contacts.rolling_elements`).

Each row is one rolling element (a ball, or one lamina of a sliced roller)
between an inner-ring body A and an outer-ring body B (planar x, y, theta;
the rings' axial translation and tilts are held). Ring centres c_A = x_A +
R(theta_A) xi_A and c_B likewise.

Cage kinematics (epicyclic, no gross slip): element j sits at

    psi_j = psi_0j + [(1 - gamma) theta_A + (1 + gamma) theta_B] / 2,
    gamma = D cos(alpha_0) / d_m,

so it advances with the rings and rolling-element passage excites the
structure. With u_j = (cos psi_j, sin psi_j) the radial approach of the inner
raceway toward the element is r_j = (c_A - c_B) . u_j and its rate
rdot_j = (v_cA - v_cB) . u_j + (c_A - c_B) . perp(u_j) psidot_j.

Element laws (paper, Section "Distributed bearing support"):

* KIND_LAMINA, roller lamina (cylindrical, needle, crossed roller) with fixed
  contact angle alpha (0 for radial rollers):
  delta = r cos(alpha) - c - crown, F = max(0, k delta^p + c_d rho(delta) deltadot)
  (Eq. (normal_force), p = 10/9 or 1), radial part f_r = F cos(alpha).
* KIND_SLICE, an influence-coefficient slice (Eq. (bearing_ic), :mod:`warp_contacts.roller_slices_ref`):
  the approach delta as a lamina's; its elastic force and dF/d delta are those of the
  roller's slice solve at this state (plus the lamina's viscous term on a slice in contact), written into columns R_SLICE_F, R_SLICE_DF by the owner
  (:class:`rvtool.bearings.set.BearingSet`) between a first launch that reads the approaches and
  the launch that assembles. In the planar model every slice of a roller moves by the same
  cos(alpha) dr, so dF_i/d delta = sum_k (df/ds)_ik is the exact per-slice derivative.
* KIND_BALL, Eq. (ball_bearing): a_r = A cos(alpha_0) + r,
  a_z = A sin(alpha_0) + s_a (s_a the axial approach that carries the
  preload; held in the planar model), delta = sqrt(a_r^2 + a_z^2) - A - c,
  working angle alpha_w = atan2(a_z, a_r), F = max(0, K(alpha_w) delta^(3/2)
  + c_d rho(delta) deltadot), f_r = F cos(alpha_w). K(alpha_w) combines the
  inner and outer Hertz point contacts, K = (K_i^(-2/3) + K_o^(-2/3))^(-3/2),
  each from the Hamrock--Brewe closed form (:func:`hertz_point_stiffness`)
  with the race curvatures of the working angle (gamma_w = D cos(alpha_w)/d_m),
  times a per-row factor s_K (column R_KSCALE) that makes K exact at the free
  contact angle (the specification computes it from the elliptic integrals;
  the curve fits then only supply the weak angle dependence).

The force on A is f_u u with f_u = -f_r, acting through the ring centres
(a radial force has no moment about the ring centre; the moments in Q are
those of the offsets xi). The axial component f_z = -sigma F sin(alpha_w)
(sigma = +-1, the row's axial sense) and the working angle are returned as
auxiliary observations: the planar model does not feed them back (no axial
or tilt coordinates), they give the axial force and tilting moment of a row
or a paired support.

Tangent: forward mode over the 12 unit seeds (dq_A, dq_B, dv_A, dv_B); the
law supplies df_r/dr and df_r/drdot, the kinematics dr and drdot including
the rotation of u_j with the cage.
"""
import numpy as np

from . import laws_ref
from .circle_pairs_ref import N_OBS, O_FN, O_GAP, O_NX, O_NY, O_PX, O_PY
from .planar_ref import N_COORD_SEEDS, N_SEEDS, cross2, dot, perp, pair_seeds, rot

# ---- packed float parameters (one row per ball or roller lamina; named here once, used by the
# Warp kernel, this reference and the packer rvtool.bearings.set; SI units) ----
R_XI_A = 0          # (2) inner-ring centre xi_A in body-A coordinates [m]
R_XI_B = 2          # (2) outer-ring centre xi_B in body-B coordinates [m]
R_PSI0 = 4          # element phase psi_0j [rad]
R_GAMMA = 5         # cage ratio gamma = D cos(alpha_0) / d_m [-]
R_CLEAR = 6         # radial clearance c [m]
R_K = 7             # lamina coefficient k [N m^-p]
R_P = 8             # lamina exponent p [-]
R_ALPHA = 9         # contact angle alpha (lamina) or free contact angle alpha_0 (ball) [rad]
R_SIGMA = 10        # axial sense sigma of the row (+1 or -1) [-]
R_A = 11            # ball: groove-centre distance A [m]
R_SAX = 12          # ball: axial approach s_a that carries the preload [m]
R_CROWN = 13        # lamina crowning drop [m]
R_PITCH = 14        # pitch diameter d_m [m]
R_DAMP = 15         # damping coefficient c_d [N s/m]
R_RAMP = 16         # damping ramp depth [m]
R_DBALL = 17        # ball diameter D [m]
R_FI = 18           # inner race conformity f_i [-]
R_FO = 19           # outer race conformity f_o [-]
R_EMOD = 20         # effective modulus E' [Pa]
R_KSCALE = 21       # stiffness factor s_K at the free contact angle [-]
R_SLICE_F = 22      # influence slice: its force F [N] from the roller's slice solve
R_SLICE_DF = 23     # influence slice: dF/d delta [N/m] (the roller's slices move together in the plane)
N_FLOAT = 24
# ---- packed integer parameters ----
K_BODY_A = 0        # pose row of the inner-ring body A
K_BODY_B = 1        # pose row of the outer-ring body B
K_KIND = 2          # element kind KIND_*
N_INT = 3
KIND_LAMINA, KIND_BALL, KIND_SLICE = 0, 1, 2
# auxiliary per-element output: force on A along u [N], axial force on A [N], working contact angle [rad]
AUX_FU, AUX_FZ, AUX_ALPHA = range(3)
N_AUX = 3

# Brewe & Hamrock (1977) / Hamrock & Brewe (1983) curve fits of the ellipticity
# parameter k = a/b, the complete elliptic integrals E(e) and F = K(e) as functions
# of the radius ratio alpha_r = R_y / R_x (quoted within 3 % for 1 <= alpha_r <= 100)
HB_K_COEF, HB_K_EXP = 1.0339, 0.6360
HB_E0, HB_E1 = 1.0003, 0.5968
HB_F0, HB_F1 = 1.5277, 0.6023


def hertz_point_stiffness(rx, ry, e_eff):
    """Hertz point contact Q = K delta^(3/2): K [N m^-3/2] and d ln K / d r_x.

    rx, ry: effective radii of relative curvature [m] in the rolling and the
    transverse direction (1/R_x = 1/r_ax + 1/r_bx, concave radii negative),
    e_eff: effective modulus E' = 2 / [(1 - nu_a^2)/E_a + (1 - nu_b^2)/E_b] [Pa].
    Hamrock--Brewe: delta = F [9/(2 E R) (Q/(pi k E'))^2]^(1/3) with
    1/R = 1/R_x + 1/R_y, so K = pi k E' sqrt(2 E R / 9) F^(-3/2).
    """
    ar = ry / rx
    R = rx * ry / (rx + ry)
    k = HB_K_COEF * ar ** HB_K_EXP
    E = HB_E0 + HB_E1 / ar
    F = HB_F0 + HB_F1 * np.log(ar)
    K = np.pi * k * e_eff * np.sqrt(2.0 * E * R / 9.0) * F ** -1.5
    dlnk_dar = HB_K_EXP / ar
    dlnE_dar = -HB_E1 / (ar * ar * E)
    dlnF_dar = HB_F1 / (ar * F)
    dlnK_dar = dlnk_dar + 0.5 * dlnE_dar - 1.5 * dlnF_dar
    dlnK_drx = dlnK_dar * (-ar / rx) + 0.5 * ry / (rx * (rx + ry))
    return K, dlnK_drx


def ball_stiffness(cos_alpha, D, dm, fi, fo, e_eff):
    """K(alpha) [N m^-3/2] of one ball (inner and outer Hertz contacts in series) and dK/d cos(alpha).

    Race curvatures at contact angle alpha (Harris & Kotzalas, Rolling Bearing
    Analysis, 5th ed., ch. 2, gamma = D cos(alpha)/d_m): inner R_x = D (1 - gamma)/2,
    outer R_x = D (1 + gamma)/2, both R_y = f D / (2 f - 1).
    """
    g = D * cos_alpha / dm
    dg = D / dm
    Ki, dlki = hertz_point_stiffness(0.5 * D * (1 - g), fi * D / (2 * fi - 1), e_eff)
    Ko, dlko = hertz_point_stiffness(0.5 * D * (1 + g), fo * D / (2 * fo - 1), e_eff)
    dlki = dlki * (-0.5 * D * dg)
    dlko = dlko * (0.5 * D * dg)
    wi, wo = Ki ** (-2.0 / 3.0), Ko ** (-2.0 / 3.0)
    K = (wi + wo) ** -1.5
    return K, K * (wi * dlki + wo * dlko) / (wi + wo)


def lamina_law(r, rdot, fp):
    """Roller lamina with fixed contact angle: (delta, F, f_r, F sin(alpha), alpha, df_r/dr, df_r/drdot)."""
    alpha = fp[:, R_ALPHA]
    ca, sa = np.cos(alpha), np.sin(alpha)
    delta = r * ca - fp[:, R_CLEAR] - fp[:, R_CROWN]
    F, Fd, Fdd = laws_ref.normal_force(fp[:, R_K], fp[:, R_P], fp[:, R_DAMP], fp[:, R_RAMP], delta, rdot * ca)
    return delta, F, F * ca, F * sa, alpha, Fd * ca * ca, Fdd * ca * ca


def slice_law(r, rdot, fp):
    """Influence slice: (delta, F, f_r, F sin(alpha), alpha, df_r/dr, df_r/drdot) with the elastic force
    and dF/d delta of the roller's solve read from its row, plus the lamina's viscous term
    c_d rho(delta) delta_dot of Eq. (normal_force) on a slice in contact (elastic force > 0), no tension."""
    alpha = fp[:, R_ALPHA]
    ca, sa = np.cos(alpha), np.sin(alpha)
    delta = r * ca - fp[:, R_CLEAR] - fp[:, R_CROWN]
    fel, cd = fp[:, R_SLICE_F], fp[:, R_DAMP]
    rho, drho = laws_ref.damping_ramp(delta, fp[:, R_RAMP])
    ddot = rdot * ca
    F = fel + cd * rho * ddot
    on = (fel > 0) & (F > 0)
    F = np.where(on, F, 0.0)
    dF = np.where(on, fp[:, R_SLICE_DF] + cd * drho * ddot, 0.0)
    dFd = np.where(on, cd * rho, 0.0)
    return delta, F, F * ca, F * sa, alpha, dF * ca * ca, dFd * ca * ca


def ball_law(r, rdot, fp):
    """Ball of Eq. (ball_bearing), the working angle moving with the radial approach:
    (delta, F, f_r, F sin(alpha_w), alpha_w, df_r/dr, df_r/drdot)."""
    A, alpha0, cd = fp[:, R_A], fp[:, R_ALPHA], fp[:, R_DAMP]
    ar = A * np.cos(alpha0) + r
    az = A * np.sin(alpha0) + fp[:, R_SAX]
    L = np.sqrt(ar * ar + az * az)
    Ls = np.where(L > 0, L, 1.0)
    delta = L - A - fp[:, R_CLEAR]
    dp = np.where(delta > 0, delta, 0.0)
    cw = ar / Ls                                   # cos(alpha_w)
    dcw = az * az / Ls ** 3                        # d cos(alpha_w) / dr
    K, dKc = ball_stiffness(cw, fp[:, R_DBALL], fp[:, R_PITCH], fp[:, R_FI], fp[:, R_FO], fp[:, R_EMOD])
    K, dKc = fp[:, R_KSCALE] * K, fp[:, R_KSCALE] * dKc
    Fel = K * dp ** 1.5
    dFel = dKc * dcw * dp ** 1.5 + 1.5 * K * np.sqrt(dp) * cw
    rho, drho = laws_ref.damping_ramp(delta, fp[:, R_RAMP])
    ddot = cw * rdot
    F = Fel + cd * rho * ddot
    on = (delta > 0) & (F > 0)
    F = np.where(on, F, 0.0)
    dF = np.where(on, dFel + cd * (drho * cw * ddot + rho * dcw * rdot), 0.0)
    dFd = np.where(on, cd * rho * cw, 0.0)
    return delta, F, F * cw, F * az / Ls, np.arctan2(az, ar), dF * cw + F * dcw, dFd * cw


#: Gauss--Legendre nodes of the ball potential's quadrature (:func:`ball_potential`); the
#: integrand t^4 K(delta t^2) is a polynomial times the weakly varying K, so 12 nodes are exact
#: to rounding (tests/test_contact_energy.py compares with adaptive quadrature)
BALL_POTENTIAL_NODES = 12


def ball_elastic(delta, fp):
    """Elastic force K(alpha_w) <delta>_+^(3/2) [N] of Eq. (ball_bearing) as a function of the
    approach delta [m] alone: the working angle follows from delta through
    L = delta + A + c, a_r = sqrt(L^2 - a_z^2), cos(alpha_w) = a_r / L (a_z held)."""
    A, c = fp[:, R_A], fp[:, R_CLEAR]
    az = A * np.sin(fp[:, R_ALPHA]) + fp[:, R_SAX]
    dp = np.where(delta > 0, delta, 0.0)
    L = dp + A + c
    cw = np.sqrt(np.maximum(L * L - az * az, 0.0)) / L
    K = fp[:, R_KSCALE] * ball_stiffness(cw, fp[:, R_DBALL], fp[:, R_PITCH], fp[:, R_FI], fp[:, R_FO],
                                         fp[:, R_EMOD])[0]
    return np.where(delta > 0, K * dp ** 1.5, 0.0)


def ball_potential(delta, fp):
    """Elastic energy [J] of a ball at approach delta [m], V = int_0^delta F(d) dd with F of
    :func:`ball_elastic` (K moves with the working angle, so no closed form): with d = delta t^2,
    V = 2 delta^(5/2) int_0^1 t^4 K(delta t^2) dt by Gauss--Legendre. Its delta-derivative is the
    force along the line of action, and dV/dr = F cos(alpha_w) = f_r, the radial force of
    :func:`ball_law` (d delta/dr = cos(alpha_w))."""
    delta = np.asarray(delta, float)
    x, w = np.polynomial.legendre.leggauss(BALL_POTENTIAL_NODES)
    t, w = 0.5 * (x + 1.0), 0.5 * w
    dp = np.where(delta > 0, delta, 0.0)
    V = np.zeros_like(dp)
    for ti, wi in zip(t, w):
        # F(d) = K d^(3/2) = K delta^(3/2) t^3, dd = 2 delta t dt
        V = V + wi * ball_elastic(dp * ti * ti, fp) * 2.0 * dp * ti
    return np.where(delta > 0, V, 0.0)


def elastic_state(kind, delta, fp):
    """Per row: the elastic normal force [N] (Eq. (normal_force) without its damping part, or
    :func:`ball_elastic`) and the potential [J] (k delta^(p+1)/(p+1) of a lamina,
    :func:`ball_potential` of a ball) at approaches delta [m]."""
    fp = np.asarray(fp, float)
    delta = np.asarray(delta, float)
    ball = np.asarray(kind) == KIND_BALL
    F, _ = laws_ref.power_law(fp[:, R_K], fp[:, R_P], delta)
    V = np.where(delta > 0, F * np.where(delta > 0, delta, 0.0) / (fp[:, R_P] + 1.0), 0.0)
    if np.any(ball):
        F = np.where(ball, 0.0, F)
        V = np.where(ball, 0.0, V)
        F[ball] = ball_elastic(delta[ball], fp[ball])
        V[ball] = ball_potential(delta[ball], fp[ball])
    return F, V


def element_law(kind, r, rdot, fp):
    """Per row: approach delta [m], normal force F [N], radial force f_r [N], axial
    magnitude F sin(alpha_w) [N], working angle alpha_w [rad], df_r/dr, df_r/drdot."""
    out = tuple(np.zeros(len(r)) for _ in range(7))
    for sel, law in ((kind == KIND_BALL, ball_law), (kind == KIND_LAMINA, lamina_law), (kind == KIND_SLICE, slice_law)):
        if np.any(sel):
            for o, v in zip(out, law(r[sel], rdot[sel], fp[sel])):
                o[sel] = v
    return out


def evaluate(pose, vel, fparams, iparams):
    """Evaluate all elements at absolute poses and velocities (nb+1, 3) (last row ground).

    Returns Q (N,6), dQdq (N,6,6), dQdv (N,6,6), obs (N,8) (columns of
    :mod:`circle_pairs_ref`: F, 0, gap = -delta, element centre on the pitch
    circle, u, 0) and aux (N,3) (AUX_* columns).
    """
    fp = np.asarray(fparams, float)
    ip = np.asarray(iparams)
    N = len(fp)
    qa, qb = pose[ip[:, K_BODY_A]], pose[ip[:, K_BODY_B]]
    va, vb = vel[ip[:, K_BODY_A]], vel[ip[:, K_BODY_B]]
    a = rot(qa[:, 2], fp[:, R_XI_A:R_XI_A + 2])
    b = rot(qb[:, 2], fp[:, R_XI_B:R_XI_B + 2])
    g = fp[:, R_GAMMA]
    psi = fp[:, R_PSI0] + 0.5 * ((1 - g) * qa[:, 2] + (1 + g) * qb[:, 2])
    psid = 0.5 * ((1 - g) * va[:, 2] + (1 + g) * vb[:, 2])
    u = np.column_stack([np.cos(psi), np.sin(psi)])
    pu = perp(u)
    d = (qa[:, :2] + a) - (qb[:, :2] + b)
    w = (va[:, :2] + va[:, 2:3] * perp(a)) - (vb[:, :2] + vb[:, 2:3] * perp(b))
    r = dot(d, u)
    rdot = dot(w, u) + dot(d, pu) * psid
    delta, F, fr, fzm, alpha_w, fr_r, fr_rd = element_law(ip[:, K_KIND], r, rdot, fp)
    fA = -fr[:, None] * u
    Q = np.zeros((N, 6))
    Q[:, 0:2] = fA
    Q[:, 2] = cross2(a, fA)
    Q[:, 3:5] = -fA
    Q[:, 5] = -cross2(b, fA)
    dQ = np.zeros((N, 6, N_SEEDS))
    for j, dqa, dqb, dva, dvb in pair_seeds():
        da = dqa[2] * perp(a)
        db = dqb[2] * perp(b)
        dpsi = 0.5 * ((1 - g) * dqa[2] + (1 + g) * dqb[2])
        dpsid = 0.5 * ((1 - g) * dva[2] + (1 + g) * dvb[2])
        du = pu * dpsi[:, None]
        dd = (dqa[:2] + da) - (dqb[:2] + db)
        dw = ((dva[:2] + dva[2] * perp(a) + va[:, 2:3] * perp(da))
              - (dvb[:2] + dvb[2] * perp(b) + vb[:, 2:3] * perp(db)))
        dr = dot(dd, u) + dot(d, du)
        # perp(du) = -u dpsi
        drdot = (dot(dw, u) + dot(w, du) + (dot(dd, pu) - dot(d, u) * dpsi) * psid
                 + dot(d, pu) * dpsid)
        dfr = fr_r * dr + fr_rd * drdot
        dfA = -dfr[:, None] * u - fr[:, None] * du
        dQ[:, 0:2, j] = dfA
        dQ[:, 2, j] = cross2(da, fA) + cross2(a, dfA)
        dQ[:, 3:5, j] = -dfA
        dQ[:, 5, j] = -(cross2(db, fA) + cross2(b, dfA))
    obs = np.zeros((N, N_OBS))
    obs[:, O_FN] = F
    obs[:, O_GAP] = -delta
    obs[:, O_PX:O_PY + 1] = qb[:, :2] + b + 0.5 * fp[:, R_PITCH][:, None] * u
    obs[:, O_NX:O_NY + 1] = u
    aux = np.zeros((N, N_AUX))
    aux[:, AUX_FU] = -fr
    aux[:, AUX_FZ] = -fp[:, R_SIGMA] * fzm
    aux[:, AUX_ALPHA] = alpha_w
    return Q, dQ[:, :, :N_COORD_SEEDS], dQ[:, :, N_COORD_SEEDS:], obs, aux
