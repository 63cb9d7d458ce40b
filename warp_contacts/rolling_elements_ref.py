"""NumPy reference of rolling-element bearing contacts with analytic tangent
(readable version of :mod:`warp_contacts.rolling_elements`).

Each row is one rolling element (or one lamina of a sliced roller) between an
inner-ring body A and an outer-ring body B (planar x, y, theta; axial
translation and tilts held). The element sits at the cage angle

    psi_j = psi_0j + [(1 - gamma) theta_A + (1 + gamma) theta_B] / 2,

(epicyclic cage kinematics, gamma = D cos(alpha) / d_m), so it advances with
the rings and rolling-element passage excites the structure. With the ring
centres c_A, c_B and u_j = (cos psi_j, sin psi_j), the radial approach is
r_j = (c_A - c_B) . u_j. Laws (Section "Distributed bearing support"):

* kind 0, roller lamina (cylindrical, needle, crossed roller):
  delta = r cos(alpha) - c - crown, F = k delta^p (per lamina), radial part F cos(alpha);
* kind 1, ball, Eq. (ball_bearing): a_r = A cos(alpha_0) + r, a_z = A sin(alpha_0) + s_a
  (s_a the axial preload offset), delta = sqrt(a_r^2 + a_z^2) - A - c, F = K delta^(3/2),
  working angle alpha = atan2(a_z, a_r), radial part F a_r / |a|.

The radial force acts on A as -f_r u_j through the ring centres. Tangent:
dr = u . (dc_A - dc_B) + d . perp(u) dpsi with dpsi from the cage kinematics.
Elements carry no damping (the rings' damping is declared elsewhere).
"""
import numpy as np

from .circle_pairs_ref import N_OBS, O_FN, O_GAP, O_NX, O_NY, O_PX, O_PY, _cross, _dot, _perp, _rot

(R_XI_A, R_XI_B, R_PSI0, R_GAMMA, R_CLEAR, R_K, R_P, R_ALPHA, R_A, R_SAX, R_CROWN, R_PITCH) = (
    0, 2, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13)
N_FLOAT = 14
(K_BODY_A, K_BODY_B, K_KIND) = range(3)
N_INT = 3
KIND_LAMINA, KIND_BALL = 0, 1


def radial_law(kind, r, fp):
    """(approach delta, normal force F, radial force f_r, d f_r / d r) per row."""
    k, p, alpha, A, sax, c, crown = (fp[:, R_K], fp[:, R_P], fp[:, R_ALPHA], fp[:, R_A], fp[:, R_SAX],
                                     fp[:, R_CLEAR], fp[:, R_CROWN])
    ca = np.cos(alpha)
    # roller lamina
    d_l = r * ca - c - crown
    dl = np.maximum(d_l, 0.0)
    Fl = k * np.where(dl > 0, dl, 0.0) ** p
    dFl = np.where(dl > 0, p * k * np.where(dl > 0, dl, 1.0) ** (p - 1), 0.0)
    # ball
    ar = A * ca + r
    az = A * np.sin(alpha) + sax
    L = np.sqrt(ar * ar + az * az)
    d_b = L - A - c
    db = np.maximum(d_b, 0.0)
    Fb = k * db ** 1.5
    dFb = 1.5 * k * np.sqrt(db)
    Ls = np.where(L > 0, L, 1.0)
    frb = Fb * ar / Ls
    dfrb = dFb * (ar / Ls) ** 2 + Fb * (1.0 / Ls - ar * ar / Ls ** 3)
    ball = kind == KIND_BALL
    delta = np.where(ball, d_b, d_l)
    F = np.where(ball, Fb, Fl)
    fr = np.where(ball, frb, Fl * ca)
    dfr = np.where(ball, dfrb, dFl * ca * ca)
    return delta, F, fr, dfr


def evaluate(pose, fparams, iparams):
    """Q (N,6), dQdq (N,6,6), obs (N,8) at absolute poses (nb+1, 3) (last row ground)."""
    fp = np.asarray(fparams, float)
    ip = np.asarray(iparams)
    N = len(fp)
    qa, qb = pose[ip[:, K_BODY_A]], pose[ip[:, K_BODY_B]]
    a = _rot(qa[:, 2], fp[:, R_XI_A:R_XI_A + 2])
    b = _rot(qb[:, 2], fp[:, R_XI_B:R_XI_B + 2])
    g = fp[:, R_GAMMA]
    psi = fp[:, R_PSI0] + 0.5 * ((1 - g) * qa[:, 2] + (1 + g) * qb[:, 2])
    u = np.column_stack([np.cos(psi), np.sin(psi)])
    d = (qa[:, :2] + a) - (qb[:, :2] + b)
    r = _dot(d, u)
    delta, F, fr, dfr = radial_law(ip[:, K_KIND], r, fp)
    fA = -fr[:, None] * u
    Q = np.zeros((N, 6))
    Q[:, 0:2] = fA
    Q[:, 2] = _cross(a, fA)
    Q[:, 3:5] = -fA
    Q[:, 5] = -_cross(b, fA)
    dQ = np.zeros((N, 6, 6))
    for j in range(6):
        s = np.zeros(6)
        s[j] = 1.0
        dqa, dqb = s[:3], s[3:]
        da = dqa[2] * _perp(a)
        db = dqb[2] * _perp(b)
        dpsi = 0.5 * ((1 - g) * dqa[2] + (1 + g) * dqb[2])
        du = _perp(u) * dpsi[:, None]
        dd = (dqa[:2] + da) - (dqb[:2] + db)
        dr = _dot(u, dd) + _dot(d, du)
        dfA = -(dfr * dr)[:, None] * u - fr[:, None] * du
        dQ[:, 0:2, j] = dfA
        dQ[:, 2, j] = _cross(da, fA) + _cross(a, dfA)
        dQ[:, 3:5, j] = -dfA
        dQ[:, 5, j] = -(_cross(db, fA) + _cross(b, dfA))
    obs = np.zeros((N, N_OBS))
    obs[:, O_FN] = F
    obs[:, O_GAP] = -delta
    pos = qb[:, :2] + b + 0.5 * fp[:, R_PITCH][:, None] * u
    obs[:, O_PX:O_PY + 1] = pos
    obs[:, O_NX:O_NY + 1] = u
    return Q, dQ, obs
