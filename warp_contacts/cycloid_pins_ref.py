"""NumPy reference of the cycloid--pin contact family with its analytic tangent
(readable version of :mod:`warp_contacts.cycloid_pins`).

Each contact is one face-width slice of one ring pin against a wheel (body A,
planar x, y, theta). The pin belongs to body B (usually the ground/housing).
Contact location (Section "Tooth geometry, deviations, and contact location"):
the pin centre is expressed in wheel coordinates, the arc-length resampled
profile table is searched in a window around the pin's polar angle, and the
nearest sample is refined by projection onto its osculating arc, clamped to one
sample spacing either side. Inside the interval the projected distance is used; a clamped
projection is tested conservatively with the sampled point (so activation and
indentation may differ there).

Gap, Eq. (gap): g = n . (p - c) - r_p + e, where c is the contact point,
n the outward profile normal, r_p the pin radius and e the slice's deviation
sum (pin-centre error along n, wheel normal deviation, clearance, skew and
crowning) plus the relative-tilt term of Eq. (skew),
z (Delta theta_y n_x - Delta theta_x n_y), for the slice at axial station z
with the declared relative tilt (Delta theta_x, Delta theta_y) of wheel and pin. Normal force Eq. (normal_force) with the power law k_s delta^p
(k_s the per-slice coefficient); regularized friction Eq. (friction) with the
material relative velocity of wheel and pin at the contact.

Tangent. The search station is frozen, and the profile is represented at it
by its osculating circle (curvature kappa), which reproduces the first
derivatives of gap, normal and contact point exactly on a smooth branch:

    Delta = dp - dc_mat,    d n = tau (kappa tau.Delta + d theta_A) / (1 + kappa n.w),
    d c   = dc_mat + tau (tau.Delta - d theta_A n.w) / (1 + kappa n.w),

with w = p - c and tau = perp(n). These forms stay finite at inflection
points (kappa = 0), where an osculating centre would be at infinity.
"""
import numpy as np

from . import anchor_ref, laws_ref
from .circle_pairs_ref import FRICTION_ANCHOR, FRICTION_REGULARIZED, N_OBS, O_FN, O_FT, O_GAP, O_NX, O_NY, O_PX, O_PY, O_VT
from .planar_ref import N_COORD_SEEDS, N_SEEDS, cross2, dot, perp, pair_seeds, rot

# ---- packed float parameters (one row per pin slice; named here once, used by the Warp kernel,
# this reference and the packer rvtool.contact.cycloid_set; SI units) ----
C_XI_B = 0          # (2) pin centre in body-B (pin carrier) coordinates [m]
C_RP = 2            # pin radius r_p [m]
C_E = 3             # deviation sum e of the slice (clearance, errors, crowning, skew) [m]
C_K = 4             # per-slice normal-law coefficient k_s [N m^-p]
C_P = 5             # normal-law exponent p [-]
C_C = 6             # per-slice damping coefficient [N s/m]
C_DR = 7            # damping ramp depth delta_r [m]
C_MUK = 8           # kinetic friction coefficient mu_k [-]
C_MUS = 9           # static (Stribeck peak) friction coefficient mu_s [-]
C_VS = 10           # Stribeck velocity v_s [m/s]
C_VREG = 11         # regularization velocity v_reg [m/s]
C_Z = 12            # axial station z of the slice [m]
C_TX = 13           # relative tilt Delta theta_x of wheel and pin [rad]
C_TY = 14           # relative tilt Delta theta_y [rad]
N_FLOAT = 15
# ---- packed integer parameters ----
J_BODY_A = 0        # pose row of the wheel (body A)
J_BODY_B = 1        # pose row of the pin carrier (body B)
J_FRICTION = 2      # friction mode (circle_pairs_ref.FRICTION_NONE or FRICTION_REGULARIZED)
J_TABLE = 3         # index of the profile table
N_INT = 4
# columns of a profile table's analytic row (Warp kernel): a flag (1.0: analytic search), the
# profile parameters of :func:`analytic_point` in their order, and the number n_l of lobe rotations
# (0: none) whose angles [rad] follow in columns N_ANALYTIC .. N_ANALYTIC + n_l - 1 (:func:`lobe_turn`)
(A_ANALYTIC, A_R, A_K1, A_ZB, A_RC, A_ROT, A_NLOBE) = range(7)
N_ANALYTIC = 7
LOBE_BLEND = 0.05
"""Half width of the blend of two neighbouring pitch units' rotations about the tooth tip between them, as a
fraction of the pitch 2 pi / z_g (:func:`lobe_turn`)."""


ANALYTIC_ITERATIONS = 4


def _epitrochoid(R, K1, zb, phi):
    """The unmodified curve's point E, its unit tangent, speed |E'| and signed curvature at generating angle phi
    (Eq. (cycloid_geometry)), shared by :func:`analytic_point` and :func:`analytic_point_turned`."""
    s, c, S, C = np.sin(phi), np.cos(phi), np.sin(zb * phi), np.cos(zb * phi)
    E = R * np.stack([s - K1 / zb * S, c - K1 / zb * C], axis=-1)
    dE = R * np.stack([c - K1 * C, -s + K1 * S], axis=-1)
    ddE = R * np.stack([-s + K1 * zb * S, -c + K1 * zb * C], axis=-1)
    speed = np.linalg.norm(dE, axis=-1)
    tau = dE / speed[..., None]
    kE = -(dE[..., 0] * ddE[..., 1] - dE[..., 1] * ddE[..., 0]) / speed ** 3
    return E, tau, speed, kE


def analytic_point(params, phi):
    """Analytic profile point, outward normal and curvature at generating angle phi
    (Eq. (cycloid_geometry) with equidistant, offset and rotation modifications)."""
    R, K1, zb, rc, rot_angle = params
    E, tau, speed, kE = _epitrochoid(R, K1, zb, phi)
    n = perp(tau)
    pt = E - rc * n
    kap = kE / (1.0 - rc * kE)
    dsdphi = speed * (1.0 - rc * kE)     # arc length of the offset curve per unit phi
    return rot(rot_angle, pt), rot(rot_angle, n), kap, dsdphi


def lobe_turn(lobes, phi):
    """Rotation d(phi) [rad] of the profile point of generating angle phi and its derivative d'(phi) from the
    rotations d_j of the z_g pitch units (``lobes``). Unit j is the tooth space about the root at
    phi = 2 pi j / z_g with its two flanks, from tip to tip (u = phi z_g / 2 pi + 1/2, j = floor(u) mod z_g,
    t = u - floor(u) in [0, 1), the root at t = 1/2): the unit turns rigidly (d = d_j, d' = 0), and within
    :data:`LOBE_BLEND` of a tip its rotation joins the neighbour's linearly (at the tip both units meet at
    (d_j + d_j+1) / 2), so that the profile has no step where two units meet (a step would be a jump of the
    contact geometry; at the tips the lever arm of a pin's force about the wheel centre is smallest). The rule
    of :meth:`rvtool.geometry.cycloid.CycloidProfile.lobe_turn` and of the Warp kernel."""
    d_l = np.asarray(lobes, float)
    n = len(d_l)
    u = np.asarray(phi, float) * n / (2 * np.pi) + 0.5
    fl = np.floor(u)
    t = u - fl
    j = np.mod(fl.astype(np.int64), n)
    dj, prev, nxt = d_l[j], d_l[(j - 1) % n], d_l[(j + 1) % n]
    b = LOBE_BLEND
    lo, hi = t < b, t > 1.0 - b
    d = np.where(lo, dj + (prev - dj) * ((b - t) / (2 * b)), np.where(hi, dj + (nxt - dj) * ((t - 1.0 + b) / (2 * b)), dj))
    dd = np.where(lo, (dj - prev) * (n / (4 * np.pi * b)), np.where(hi, (nxt - dj) * (n / (4 * np.pi * b)), 0.0))
    return d, dd


def analytic_point_turned(params, d, dd, phi):
    """:func:`analytic_point` of a profile whose point of generating angle phi is turned about the wheel centre
    by the profile rotation plus d(phi) (:func:`lobe_turn`): the point turned, the tangent of the turned curve
    c' = R(d) (c_0' + d' J c_0) (J: the quarter turn), its normal, the unturned curvature (d'' = 0) and the arc
    length per unit phi |c_0' + d' J c_0|."""
    R, K1, zb, rc, rot_angle = params
    E, tau, speed, kE = _epitrochoid(R, K1, zb, phi)
    pt = E - rc * perp(tau)
    kap = kE / (1.0 - rc * kE)
    v = (speed * (1.0 - rc * kE))[..., None] * tau + np.asarray(dd)[..., None] * perp(pt)
    ds = np.linalg.norm(v, axis=-1)
    n = perp(v / ds[..., None])
    a = rot_angle + d
    return rot(a, pt), rot(a, n), kap, ds


def search(table, pin_local, window, analytic=None):
    """Contact location for pins given in wheel coordinates.

    Discrete path: window search of the nearest sample and projection on its
    osculating arc. Analytic path (``analytic`` = profile parameters, see
    :func:`analytic_point`): starting from the nearest sample, Newton iterations
    on (c - p) . c' = 0 with the osculating-circle step, so the contact point is
    the exact closest point of the analytic profile (never clamped). With lobe
    rotations (a sixth entry of ``analytic``) each Newton iterate's point is turned
    by :func:`lobe_turn` of its generating angle (:func:`analytic_point_turned`).
    table: (points (n,2), normals (n,2), kappa (n,), polar (n,), spacing, phi (n,)).
    Returns (c (N,2), n (N,2), kappa (N,), clamped (N,) bool, sampled distance (N,)).
    """
    P, Nn, K, polar, h = table[:5]
    n = len(P)
    beta = np.mod(np.arctan2(pin_local[:, 1], pin_local[:, 0]), 2 * np.pi)
    i0 = np.searchsorted(polar, beta)
    idx = (i0[:, None] + np.arange(-window, window + 1)[None, :]) % n
    d2 = np.sum((P[idx] - pin_local[:, None, :]) ** 2, axis=2)
    best = idx[np.arange(len(beta)), np.argmin(d2, axis=1)]
    ci, ni, ki = P[best], Nn[best], K[best]
    if analytic is not None:
        phi = table[5][best]
        if len(analytic) > 5:
            lobes, base = analytic[5], analytic[:5]
            point = lambda ph: analytic_point_turned(base, *lobe_turn(lobes, ph), ph)
        else:
            point = lambda ph: analytic_point(analytic, ph)
        for _ in range(ANALYTIC_ITERATIONS):
            c, nn, kk, ds = point(phi)
            w = pin_local - c
            # the curve runs clockwise for increasing phi: the arc direction is -perp(n)
            dsn = dot(w, -perp(nn)) / (1.0 + kk * dot(w, nn))
            phi = phi + dsn / ds
        c, nn, kk, _ = point(phi)
        return c, nn, kk, np.zeros(len(phi), bool), np.linalg.norm(pin_local - ci, axis=1)
    ti = perp(ni)
    wi = pin_local - ci
    # projection onto the sample's osculating arc (second order in the arc parameter t),
    # the same local geometry the tangent differentiates
    t = dot(wi, ti) / (1.0 + ki * dot(wi, ni))
    # permitted local interval: up to the neighbouring samples
    clamped = np.abs(t) > h
    t = np.clip(t, -h, h)
    c = ci + t[:, None] * ti - (0.5 * ki * t * t)[:, None] * ni
    nn = ni + (ki * t)[:, None] * ti
    nn /= np.linalg.norm(nn, axis=1)[:, None]
    return c, nn, ki, clamped, np.linalg.norm(pin_local - ci, axis=1)


def evaluate(pose, vel, fparams, iparams, tables, window, analytic=None, anchor=None):
    """Evaluate all pin-slice contacts.

    pose, vel: (nb+1, 3) absolute poses and velocities, last row the ground.
    fparams (N, 12), iparams (N, 4): packed parameters (columns C_*, J_*).
    tables: list of profile tables (see :func:`search`), indexed by J_TABLE.
    analytic: None (discrete path) or a list of analytic profile parameters per table.
    anchor: None (no anchors), or (anchor_params (N, anchor_ref.N_ANCHOR), committed flags (N,),
    anchors in wheel coordinates (N, 2), anchors in pin-body coordinates (N, 2)) for the rows
    with J_FRICTION = FRICTION_ANCHOR (Eq. (friction), anchor model of :mod:`anchor_ref`: the
    anchors form at the contact point, as material points of the wheel and of the pin; the
    tangential force acts at the anchors).
    Returns Q (N,6), dQdq (N,6,6), dQdv (N,6,6), obs (N, 8), and with ``anchor`` the trial
    history (flags, anchor_A, anchor_B) as a fifth result.
    """
    fp = np.asarray(fparams, float)
    ip = np.asarray(iparams)
    N = len(fp)
    ia, ib = ip[:, J_BODY_A], ip[:, J_BODY_B]
    qa, qb, va, vb = pose[ia], pose[ib], vel[ia], vel[ib]
    b = rot(qb[:, 2], fp[:, C_XI_B:C_XI_B + 2])
    p = qb[:, :2] + b
    pin_local = rot(-qa[:, 2], p - qa[:, :2])
    c_loc = np.zeros((N, 2))
    n_loc = np.zeros((N, 2))
    kap = np.zeros(N)
    clamped = np.zeros(N, bool)
    dist = np.zeros(N)
    for tb in np.unique(ip[:, J_TABLE]):
        m = ip[:, J_TABLE] == tb
        c_loc[m], n_loc[m], kap[m], clamped[m], dist[m] = search(tables[tb], pin_local[m], window,
                                                                 None if analytic is None else analytic[tb])
    a = rot(qa[:, 2], c_loc)
    n = rot(qa[:, 2], n_loc)
    t = perp(n)
    c = qa[:, :2] + a
    w = p - c
    hw = dot(n, w)
    r = fp[:, C_RP]
    z, tx, ty = fp[:, C_Z], fp[:, C_TX], fp[:, C_TY]
    g = np.where(clamped, dist, hw) - r + fp[:, C_E] + z * (ty * n[:, 0] - tx * n[:, 1])
    delta = -g
    vc = va[:, :2] + va[:, 2:3] * perp(a)
    vp = vb[:, :2] + vb[:, 2:3] * perp(b)
    u = vp - vc
    delta_dot = -dot(n, u)
    F, Fd, Fdd = laws_ref.normal_force(fp[:, C_K], fp[:, C_P], fp[:, C_C], fp[:, C_DR], delta, delta_dot)
    fA = -F[:, None] * n
    bpc = b - r[:, None] * n
    vpc = vb[:, :2] + vb[:, 2:3] * perp(bpc)
    vt = dot(t, vc - vpc)
    mu, dmu = laws_ref.friction_coefficient(fp[:, C_MUK], fp[:, C_MUS], fp[:, C_VS], fp[:, C_VREG], vt)
    reg = (ip[:, J_FRICTION] == FRICTION_REGULARIZED) & (F > 0)
    ft = np.where(reg, -F * mu, 0.0)
    armA, armB = a, bpc
    if anchor is not None:
        ap, h_act, h_a, h_b = anchor
        ap = np.asarray(ap, float)
        is_anchor = ip[:, J_FRICTION] == FRICTION_ANCHOR
        ha, hb, e_anc = anchor_ref.anchor_separation(qa[:, :2], qa[:, 2], qb[:, :2], qb[:, 2], h_a, h_b)
        anchored, stick, slip, s_anc, sg, ft_anc = anchor_ref.state(F, is_anchor & (delta > 0), h_act, e_anc, t, ap)
        ft = np.where(anchored, ft_anc, ft)
        armA = np.where(anchored[:, None], ha, a)
        armB = np.where(anchored[:, None], hb, bpc)
    ftA = ft[:, None] * t

    Q = np.zeros((N, 6))
    Q[:, 0:2] = fA + ftA
    Q[:, 2] = cross2(a, fA) + cross2(armA, ftA)
    Q[:, 3:5] = -(fA + ftA)
    Q[:, 5] = -(cross2(b, fA) + cross2(armB, ftA))

    den = 1.0 + kap * hw
    wt = dot(w, t)
    dQ = np.zeros((N, 6, N_SEEDS))
    for j, dqa, dqb, dva, dvb in pair_seeds():
        dca = dqa[:2] + dqa[2] * perp(a)
        db = dqb[2] * perp(b)
        dp = dqb[:2] + db
        D = dp - dca
        dn = t * ((kap * dot(t, D) + dqa[2]) / den)[:, None]
        dt = perp(dn)
        dg = dot(n, D) + wt * dot(t, dn) + z * (ty * dn[:, 0] - tx * dn[:, 1])
        da = dqa[2] * perp(a) + t * ((dot(t, D) - dqa[2] * hw) / den)[:, None]
        dvc = dva[:2] + dva[2] * perp(a) + va[:, 2:3] * perp(da)
        dvp = dvb[:2] + dvb[2] * perp(b) + vb[:, 2:3] * perp(db)
        ddelta_dot = -(dot(dn, u) + dot(n, dvp - dvc))
        dF = Fd * (-dg) + Fdd * ddelta_dot
        dfA = -(dF[:, None] * n + F[:, None] * dn)
        dbpc = db - r[:, None] * dn
        dvpc = dvb[:2] + dvb[2] * perp(bpc) + vb[:, 2:3] * perp(dbpc)
        dvt = dot(dt, vc - vpc) + dot(t, dvc - dvpc)
        dft = np.where(reg, -(dF * mu + F * dmu * dvt), 0.0)
        darmA, darmB = da, dbpc
        if anchor is not None:
            # anchors are material points: they turn with their bodies and do not migrate
            dha, dhb = dqa[2] * perp(ha), dqb[2] * perp(hb)
            de = (dqa[:2] + dha) - (dqb[:2] + dhb)
            dft = np.where(anchored, anchor_ref.force_tangent(stick, slip, sg, e_anc, t, dF, dt, de, ap), dft)
            darmA = np.where(anchored[:, None], dha, da)
            darmB = np.where(anchored[:, None], dhb, dbpc)
        dftA = dft[:, None] * t + ft[:, None] * dt
        dQ[:, 0:2, j] = dfA + dftA
        dQ[:, 2, j] = cross2(da, fA) + cross2(a, dfA) + cross2(darmA, ftA) + cross2(armA, dftA)
        dQ[:, 3:5, j] = -(dfA + dftA)
        dQ[:, 5, j] = -(cross2(db, fA) + cross2(b, dfA) + cross2(darmB, ftA) + cross2(armB, dftA))

    obs = np.zeros((N, N_OBS))
    obs[:, O_FN] = F
    obs[:, O_VT] = vt
    obs[:, O_GAP] = g
    obs[:, O_PX:O_PY + 1] = c + 0.5 * (hw - r)[:, None] * n
    obs[:, O_NX:O_NY + 1] = n
    obs[:, O_FT] = ft
    if anchor is None:
        return Q, dQ[:, :, :N_COORD_SEEDS], dQ[:, :, N_COORD_SEEDS:], obs
    # a new anchor forms at the contact point c, as the profile's material point (wheel
    # coordinates) and the pin's material point there (pin-body coordinates): zero separation,
    # so the new anchor starts without force whatever the search's tangential residual
    trial = anchor_ref.trial_history(F, is_anchor & (delta > 0), anchored, slip, s_anc, sg, t, qa[:, 2], qb[:, 2], ha,
                                     hb, h_a, h_b, c_loc, rot(-qb[:, 2], c - qb[:, :2]), ap)
    return Q, dQ[:, :, :N_COORD_SEEDS], dQ[:, :, N_COORD_SEEDS:], obs, trial
