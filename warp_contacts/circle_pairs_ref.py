"""NumPy reference of the circle--circle contact-pair evaluation with its
analytic tangent (readable version of :mod:`warp_contacts.circle_pairs`).

Each contact couples two planar rigid bodies A and B (coordinates
q = (x, y, theta), velocities v = (vx, vy, omega)). A circle of radius r_A is
fixed to A at local centre xi_A, a circle of radius r_B (the enclosing radius
R_B for internal contact) to B at xi_B. Per contact the function returns

* Q (6,): generalized forces on (q_A, q_B), Q = G^T f  (Eq. (contact_mapping))
* dQ/dq (6, 6) and dQ/dv (6, 6): the analytic tangent of Eq.
  (assembled_contact_tangent), i.e. both the changing-arm term
  (dG^T/dq) f and the force term G^T df/dq, including the dependence of the
  contact points and of the tangent direction on q.

The tangent is computed in forward mode: every intermediate quantity is
differentiated along each of the 12 unit seed directions (dq_A, dq_B, dv_A,
dv_B) with hand-written chain rules. This is an analytic derivative of the
implemented force (a verification test compares it with central differences).

Normal force: Eq. (normal_force) with power law k delta^p, damping c and
ramp delta_r. Friction (``friction_mode``):
0 none; 1 regularized velocity law of Eq. (friction) using the relative
velocity of the material points at the contact; 2 anchor (elastic
stick--slip) model: anchors are material points stored in body coordinates
(history), the tangential force is -k_t (t . e) t with e the anchor
separation, bounded by mu_k F_n; on slip the A-anchor is projected so that
the bound holds (committed only for accepted steps).
"""
import numpy as np

from . import laws_ref
from .planar_ref import N_COORD_SEEDS, N_SEEDS, cross2, dot, perp, pair_seeds, rot

# ---- packed float parameters (one row per contact; named here once, used by the Warp kernel,
# this reference and the packer rvtool.contact.circle_set; SI units) ----
P_XI_A = 0          # (2) centre xi_A of circle A in body-A coordinates [m]
P_XI_B = 2          # (2) centre xi_B of circle B in body-B coordinates [m]
P_RA = 4            # radius r_A [m]
P_RB = 5            # radius r_B, or the enclosing radius R_B of an internal contact [m]
P_K = 6             # normal-law coefficient k [N m^-p]
P_P = 7             # normal-law exponent p [-]
P_C = 8             # damping coefficient c [N s/m]
P_DR = 9            # damping ramp depth delta_r [m]
P_MUK = 10          # kinetic friction coefficient mu_k [-]
P_MUS = 11          # static (Stribeck peak) friction coefficient mu_s [-]
P_VS = 12           # Stribeck velocity v_s [m/s]
P_VREG = 13         # regularization velocity v_reg [m/s]
P_KT = 14           # anchor tangential stiffness k_t [N/m]
N_FLOAT_PARAMS = 15
# ---- packed integer parameters ----
I_BODY_A = 0        # pose row of body A (the ground is the last row)
I_BODY_B = 1        # pose row of body B
I_INTERNAL = 2      # 1: A inside the enclosing circle B, 0: external contact
I_FRICTION = 3      # friction mode FRICTION_*
N_INT_PARAMS = 4
# ---- observation columns (shared by every pair family) ----
# normal force [N], tangential slip velocity [m/s], gap [m], contact point (2) [m], unit normal (2),
# tangential force on A along t = perp(n) [N]
O_FN, O_VT, O_GAP, O_PX, O_PY, O_NX, O_NY, O_FT = range(8)
N_OBS = 8

FRICTION_NONE, FRICTION_REGULARIZED, FRICTION_ANCHOR = 0, 1, 2


def evaluate(pose, vel, fparams, iparams, hist_active, hist_a, hist_b):
    """Evaluate all contacts; see module docstring.

    Parameters
    ----------
    pose, vel : (nb+1, 3) absolute poses [m, m, rad] and velocities [m/s, m/s, rad/s];
        the last row is the ground (all zero).
    fparams : (N, 15) packed float parameters (column constants P_*), SI units.
    iparams : (N, 4) body indices of A and B, internal flag, friction mode.
    hist_active, hist_a, hist_b : committed anchor history (N,), (N, 2), (N, 2),
        anchors in body-A and body-B coordinates [m].

    Returns
    -------
    Q (N, 6), dQdq (N, 6, 6), dQdv (N, 6, 6), obs (N, 8),
    trial history (active (N,), anchor_a (N, 2), anchor_b (N, 2)).
    """
    fp = np.asarray(fparams, np.float64)
    ip = np.asarray(iparams)
    N = fp.shape[0]
    ia, ib = ip[:, I_BODY_A], ip[:, I_BODY_B]
    s = np.where(ip[:, I_INTERNAL] != 0, -1.0, 1.0)
    mode = ip[:, I_FRICTION]
    qa, qb = pose[ia], pose[ib]
    va, vb = vel[ia], vel[ib]
    xi_a, xi_b = fp[:, P_XI_A:P_XI_A + 2], fp[:, P_XI_B:P_XI_B + 2]
    ra, rb = fp[:, P_RA], fp[:, P_RB]

    pa, pb = rot(qa[:, 2], xi_a), rot(qb[:, 2], xi_b)
    ca, cb = qa[:, :2] + pa, qb[:, :2] + pb
    d = cb - ca
    L = np.linalg.norm(d, axis=1)
    Ls = np.where(L > 0, L, 1.0)
    n = np.where((L > 0)[:, None], d / Ls[:, None], np.array([1.0, 0.0]))
    t = perp(n)
    g = np.where(s > 0, L - ra - rb, rb - ra - L)
    delta = -g
    vca = va[:, :2] + va[:, 2:3] * perp(pa)
    vcb = vb[:, :2] + vb[:, 2:3] * perp(pb)
    w = vcb - vca
    Ldot = dot(n, w)
    delta_dot = -s * Ldot
    F, Fd, Fdd = laws_ref.normal_force(fp[:, P_K], fp[:, P_P], fp[:, P_C], fp[:, P_DR], delta, delta_dot)
    fnA = (-s * F)[:, None] * n

    # material contact points and their relative tangential velocity
    aa = pa + (s * ra)[:, None] * n
    bb = pb - rb[:, None] * n
    ua = va[:, :2] + va[:, 2:3] * perp(aa)
    ub = vb[:, :2] + vb[:, 2:3] * perp(bb)
    vrel = ua - ub
    vt = dot(t, vrel)

    # friction
    mu, dmu = laws_ref.friction_coefficient(fp[:, P_MUK], fp[:, P_MUS], fp[:, P_VS], fp[:, P_VREG], vt)
    ha = rot(qa[:, 2], np.asarray(hist_a, float))
    hb = rot(qb[:, 2], np.asarray(hist_b, float))
    e = (qa[:, :2] + ha) - (qb[:, :2] + hb)
    st = dot(t, e)
    kt = fp[:, P_KT]
    lim = fp[:, P_MUK] * F
    contact = delta > 0
    anchored = (mode == FRICTION_ANCHOR) & contact & (np.asarray(hist_active) != 0)
    stick = anchored & (np.abs(kt * st) <= lim)
    slip = anchored & ~stick
    sg = np.sign(st)
    reg = (mode == FRICTION_REGULARIZED) & (F > 0)
    ft_mag = np.where(reg, -F * mu, 0.0)
    ft_mag = np.where(stick, -kt * st, ft_mag)
    ft_mag = np.where(slip, -lim * sg, ft_mag)
    ftA = ft_mag[:, None] * t
    armA = np.where(anchored[:, None], ha, aa)
    armB = np.where(anchored[:, None], hb, bb)

    Q = np.zeros((N, 6))
    Q[:, 0:2] = fnA + ftA
    Q[:, 2] = cross2(pa, fnA) + cross2(armA, ftA)
    Q[:, 3:5] = -(fnA + ftA)
    Q[:, 5] = -(cross2(pb, fnA) + cross2(armB, ftA))

    dQ = np.zeros((N, 6, N_SEEDS))
    for j, dqa, dqb, dva, dvb in pair_seeds():
        dpa = dqa[2] * perp(pa)
        dpb = dqb[2] * perp(pb)
        dd = (dqb[:2] + dpb) - (dqa[:2] + dpa)
        dL = dot(n, dd)
        dn = (dd - n * dL[:, None]) / Ls[:, None]
        dt = perp(dn)
        ddelta = -s * dL
        dvca = dva[:2] + dva[2] * perp(pa) + va[:, 2:3] * perp(dpa)
        dvcb = dvb[:2] + dvb[2] * perp(pb) + vb[:, 2:3] * perp(dpb)
        dw = dvcb - dvca
        dLdot = dot(dn, w) + dot(n, dw)
        ddelta_dot = -s * dLdot
        dF = Fd * ddelta + Fdd * ddelta_dot
        dfnA = (-s)[:, None] * (dF[:, None] * n + F[:, None] * dn)
        daa = dpa + (s * ra)[:, None] * dn
        dbb = dpb - rb[:, None] * dn
        dua = dva[:2] + dva[2] * perp(aa) + va[:, 2:3] * perp(daa)
        dub = dvb[:2] + dvb[2] * perp(bb) + vb[:, 2:3] * perp(dbb)
        dvt = dot(dt, vrel) + dot(t, dua - dub)
        dha = dqa[2] * perp(ha)
        dhb = dqb[2] * perp(hb)
        de = (dqa[:2] + dha) - (dqb[:2] + dhb)
        dst = dot(dt, e) + dot(t, de)
        dft_mag = np.where(reg, -(dF * mu + F * dmu * dvt), 0.0)
        dft_mag = np.where(stick, -kt * dst, dft_mag)
        dft_mag = np.where(slip, -fp[:, P_MUK] * dF * sg, dft_mag)
        dftA = dft_mag[:, None] * t + ft_mag[:, None] * dt
        darmA = np.where(anchored[:, None], dha, daa)
        darmB = np.where(anchored[:, None], dhb, dbb)
        dQ[:, 0:2, j] = dfnA + dftA
        dQ[:, 2, j] = cross2(dpa, fnA) + cross2(pa, dfnA) + cross2(darmA, ftA) + cross2(armA, dftA)
        dQ[:, 3:5, j] = -(dfnA + dftA)
        dQ[:, 5, j] = -(cross2(dpb, fnA) + cross2(pb, dfnA) + cross2(darmB, ftA) + cross2(armB, dftA))

    # trial history: keep anchors while sticking, project on slip, open on separation
    new_a = np.zeros((N, 2))
    new_b = np.zeros((N, 2))
    ca_loc = rot(-qa[:, 2], aa)
    cb_loc = rot(-qb[:, 2], bb)
    st_lim = np.where(kt > 0, sg * lim / np.where(kt > 0, kt, 1.0), 0.0)
    ha_new = rot(-qa[:, 2], ha - (st - st_lim)[:, None] * t)
    new_a = np.where(anchored[:, None], np.where(slip[:, None], ha_new, np.asarray(hist_a, float)), ca_loc)
    new_b = np.where(anchored[:, None], np.asarray(hist_b, float), cb_loc)
    act = (contact & (mode == FRICTION_ANCHOR)).astype(np.int32)
    new_a = np.where(act[:, None] != 0, new_a, 0.0)
    new_b = np.where(act[:, None] != 0, new_b, 0.0)

    obs = np.zeros((N, N_OBS))
    obs[:, O_FN] = F
    obs[:, O_VT] = vt
    obs[:, O_GAP] = g
    obs[:, O_PX:O_PY + 1] = 0.5 * ((qa[:, :2] + aa) + (qb[:, :2] + bb))
    obs[:, O_NX:O_NY + 1] = n
    obs[:, O_FT] = ft_mag
    return Q, dQ[:, :, :N_COORD_SEEDS], dQ[:, :, N_COORD_SEEDS:], obs, (act, new_a, new_b)
