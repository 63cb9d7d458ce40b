"""NumPy reference of the involute tooth-pair contact family with its analytic tangent
(readable version of :mod:`warp_contacts.involute_pairs`).

Each row is one face-width slice of one tooth of gear A (body A, external) on one line
of action against the facing tooth of gear B (body B, external or internal), in a window
of teeth around the pitch point. Geometry (Section "Tooth geometry, deviations, and
contact location"; see :mod:`rvtool.geometry.involute` for the flank of Eq.
(involute_geometry)): for the current centres the line of action is the common tangent
of the base circles, cos(alpha_w) = (r_bB + eps r_bA) / a; every flank normal of A and of
B is a base-circle tangent, so the candidate flank normal of tooth k of A that is also a
flank normal of B is this line, and the two flank points on it are

    c_A = T_A + r_bA u_A d,   c_B = T_B - eps r_bB u_B d,
    g_geom = (c_B - c_A) . d = eps a sin(alpha_w) - r_bA u_A - eps r_bB u_B,

with d A's outward normal (eps = +1 external, -1 internal pair). The facing tooth j of B
is the one whose flank point is nearest along the line. The contact is on the line while
u_A and u_B lie in their admissible profile intervals (root form circle to the tip edge:
SAP..EAP). When the line point lies beyond a tip, the contact is off the line of action:
the rounded tip edge (radius rho_e, centre P) of that tooth against the other flank, whose
distance along that flank's own normal through P is exact for an involute,

    g_geom = lambda - r_b u - rho_e,   lambda = sqrt(|P - O|^2 - r_b^2),

(sign eps on B's flank). Gap, Eq. (gap) with Eq. (skew):
g = g_geom + e_A(u_A, z) + e_B(u_B, z) + e_0 + z (Delta theta_y n_x - Delta theta_x n_y) + z tan psi,
with the flank modifications e(u, z) of both teeth and the clearance e_0; pitch deviations
turn each tooth's flanks rigidly (table of tooth angles).

Normal law, Eq. (series_contact) per slice of width b_s:

    delta = F (c'_A(u_A) + c'_B(u_B)) / b_s + delta_H(F),
    delta_H(F) = sum_i F C_i [ln(2 h_i / a_H) - nu_i / (2 (1 - nu_i))],   C_i = 2 (1 - nu_i^2) / (pi E_i b_s),
    a_H = sqrt(4 F / (pi b_s E* K)),  1/E* = sum (1 - nu_i^2)/E_i,  K = 1/R_A + s_B / R_B,

tooth compliances c' of :mod:`rvtool.contact.tooth_stiffness` (potential-energy method,
foundation once per body), Weber's (1949) line-contact approach delta_H to the depth h_i
along the load line, and the Hertz half-width a_H. The scalar equation is solved by a
safeguarded Newton iteration (bracket [0, delta c_t^-1], bisection when a step leaves it);
the force derivatives follow by implicit differentiation. Damping ramp Eq. (normal_force);
regularized friction Eq. (friction) with the material sliding velocity of the two flanks.

Generalized forces Q = G^T f (Eq. (contact_mapping)), f acting on A and -f on B at the contact
point c = (c_A + c_B) / 2 (material points of both bodies there); the tangent in forward mode over the 12 seeds (q_A, q_B, v_A, v_B)
with the mode, the teeth and the wrapped roll angles frozen: both terms of Eq.
(assembled_contact_tangent) (moving arms c - O and normal, and the force response,
including the migration of the contact along both flanks through c'(u), h(u), R(u), e(u)).
"""
import numpy as np

from . import anchor_ref, laws_ref
from .planar_ref import rot as _rot

# -- float parameter columns: one block per gear (A at GEAR_A, B at GEAR_B), then the row --
(G_RB, G_PSI, G_EPS, G_ULO, G_UHI, G_UREF, G_RHO_C, G_CHI, G_RHO_E, G_UEDGE,
 G_UTIP, G_UCA, G_CA, G_QA, G_UROOT, G_UCF, G_CF, G_QF, G_CAL, G_UMID, G_UHALF, G_CB, G_FHB, G_B,
 G_PMID, G_PHALF, G_E, G_NU) = range(28)
POLY_TERMS = 9
G_PC = 28                      # compliance polynomial c'(u) [m^2/N], POLY_TERMS coefficients
G_PH = G_PC + POLY_TERMS       # depth polynomial h(u) [m]
N_GEAR = G_PH + POLY_TERMS
GEAR_A, GEAR_B = 0, N_GEAR
(C_Z, C_BS, C_E, C_TX, C_TY, C_TANPSI, C_C, C_DR, C_MUK, C_MUS, C_VS, C_VREG) = range(2 * N_GEAR, 2 * N_GEAR + 12)
N_FLOAT = 2 * N_GEAR + 12
# -- integer parameter columns --
(J_BODY_A, J_BODY_B, J_FRICTION, J_LINE, J_WINDOW, J_TOOTH_A, J_NA, J_TOOTH_B, J_NB) = range(9)
N_INT = 9
# -- observation columns: the first 8 as in circle_pairs_ref (read by the contact element) --
(O_FN, O_VT, O_GAP, O_PX, O_PY, O_NX, O_NY, O_FT, O_VROLL, O_UA, O_UB, O_MODE, O_TOOTH_A, O_TOOTH_B,
 O_KT) = range(15)
N_OBS = 15
MODE_OPEN, MODE_LINE, MODE_CORNER_A, MODE_CORNER_B = 0, 1, 2, 3
#: gap [m] reported for a row whose teeth are out of mesh (no candidate)
OPEN_GAP = 1.0e30
#: relative step of the series-law iteration: float64 and float32
SERIES_RTOL = {np.float64: 1e-14, np.float32: 1e-6}
SERIES_MAX_ITERATIONS = 80

TWO_PI = 2.0 * np.pi


def _perp(a):
    return np.stack([-a[..., 1], a[..., 0]], axis=-1)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _e(phi):
    return np.stack([np.cos(phi), np.sin(phi)], axis=-1)


def _nearest(x):
    """Nearest integer, halves upward (the kernel's floor(x + 1/2))."""
    return np.floor(x + 0.5)


def _wrap(x):
    """x reduced to [-pi, pi)."""
    return x + np.pi - TWO_PI * np.floor((x + np.pi) / TWO_PI) - np.pi


def _col(x):
    return np.asarray(x)[..., None]


def poly(fp, base, u):
    """Value and derivative in u of a gear polynomial (compliance at base=G_PC, depth at G_PH)."""
    half = fp[:, G_PHALF]
    t = (u - fp[:, G_PMID]) / half
    v = np.zeros_like(u)
    dv = np.zeros_like(u)
    for i in range(POLY_TERMS - 1, -1, -1):
        dv = dv * t + v
        v = v * t + fp[:, base + i]
    return v, dv / half


def modification(fp, g, u, z):
    """e(u, z) and de/du of gear block g (see rvtool.geometry.involute.modification_value)."""
    e = np.zeros_like(u)
    de = np.zeros_like(u)
    for amount, start, end, q in ((G_CA, G_UCA, G_UTIP, G_QA), (G_CF, G_UCF, G_UROOT, G_QF)):
        amt, st, en, qq = fp[:, g + amount], fp[:, g + start], fp[:, g + end], fp[:, g + q]
        span = np.where(amt > 0, en - st, 1.0)
        t = (u - st) / span
        on = (amt > 0) & (t > 0)
        tp = np.where(on, t, 1.0)
        e = e + np.where(on, amt * tp ** qq, 0.0)
        de = de + np.where(on, amt * qq * tp ** (qq - 1) / span, 0.0)
    w = (u - fp[:, g + G_UMID]) / fp[:, g + G_UHALF]
    b = fp[:, g + G_B]
    e = e + fp[:, g + G_CAL] * w * w + fp[:, g + G_CB] * (2 * z / b) ** 2 + fp[:, g + G_FHB] * z / b
    de = de + 2 * fp[:, g + G_CAL] * w / fp[:, g + G_UHALF]
    return e, de


def weber_approach(F, hA, hB, K, EA, nuA, EB, nuB, bs):
    """delta_H(F) of Eq. (series_contact) (Weber's line-contact approach) and d delta_H / dF."""
    CA = 2 * (1 - nuA ** 2) / (np.pi * EA * bs)
    CB = 2 * (1 - nuB ** 2) / (np.pi * EB * bs)
    estar = 1.0 / ((1 - nuA ** 2) / EA + (1 - nuB ** 2) / EB)
    aH = np.sqrt(4 * F / (np.pi * bs * estar * K))
    dH = F * (CA * (np.log(2 * hA / aH) - nuA / (2 * (1 - nuA))) + CB * (np.log(2 * hB / aH) - nuB / (2 * (1 - nuB))))
    return dH, dH / F - 0.5 * (CA + CB)


def series_force(delta, C, hA, hB, K, EA, nuA, EB, nuB, bs, rtol=SERIES_RTOL[np.float64]):
    """Force of Eq. (series_contact) for approach delta > 0 and its partials.

    Solves G(F) = C F + delta_H(F) - delta = 0 (G increasing and concave in F where the law
    holds) by Newton steps kept inside the bracket [lo, hi] (bisection otherwise), from
    hi = delta / C. Returns F, dF/d delta, dF/dC, dF/dh_A, dF/dh_B, dF/dK. NaN where the law
    does not hold (Hertz half-width beyond Weber's depth: G(hi) < 0 or G' <= 0).
    """
    lo = np.zeros_like(delta)
    hi = delta / C
    G_hi = C * hi + weber_approach(hi, hA, hB, K, EA, nuA, EB, nuB, bs)[0] - delta
    bad = ~(G_hi >= 0)
    F = 0.5 * hi
    for _ in range(SERIES_MAX_ITERATIONS):
        dH, dHd = weber_approach(F, hA, hB, K, EA, nuA, EB, nuB, bs)
        G = C * F + dH - delta
        Gp = C + dHd
        lo = np.where(G < 0, F, lo)
        hi = np.where(G >= 0, F, hi)
        Fn = F - G / Gp
        Fn = np.where((Fn > lo) & (Fn < hi) & (Gp > 0), Fn, 0.5 * (lo + hi))
        done = np.abs(Fn - F) <= rtol * Fn
        F = Fn
        if np.all(done | bad):
            break
    dH, dHd = weber_approach(F, hA, hB, K, EA, nuA, EB, nuB, bs)
    Gp = C + dHd
    bad = bad | ~(Gp > 0)
    CA = 2 * (1 - nuA ** 2) / (np.pi * EA * bs)
    CB = 2 * (1 - nuB ** 2) / (np.pi * EB * bs)
    out = (F, 1.0 / Gp, -F / Gp, -F * CA / hA / Gp, -F * CB / hB / Gp, -F * 0.5 * (CA + CB) / K / Gp)
    return tuple(np.where(bad, np.nan, x) for x in out)


def series_potential(F, delta, EA, nuA, EB, nuB, bs):
    """Elastic energy V [J] stored by Eq. (series_contact) at approach delta [m] carrying the
    elastic force F [N] (F = series_force(delta, ...)), the coefficients C, h_i, K frozen:

        V(delta) = int_0^delta F d(delta') = F delta - int_0^F delta(F') dF'   (by parts).

    With delta(F) = C F + F (A - (C_A + C_B)/2 ln F) (Weber: a_H ~ sqrt(F), so ln(2 h / a_H)
    = const - 1/2 ln F, A collecting the constants), the inner integral is
    C F^2/2 + F delta_H(F)/2 + (C_A + C_B) F^2/8 = F delta/2 + (C_A + C_B) F^2/8, hence

        V = F delta / 2 - (C_A + C_B) F^2 / 8,   C_i = 2 (1 - nu_i^2) / (pi E_i b_s),

    exact (no quadrature); dV/d delta = F because d delta/dF = delta/F - (C_A + C_B)/2.
    The tooth compliance C and the depths h_i drop out: they enter only through F."""
    CA = 2 * (1 - nuA ** 2) / (np.pi * EA * bs)
    CB = 2 * (1 - nuB ** 2) / (np.pi * EB * bs)
    return 0.5 * F * delta - 0.125 * (CA + CB) * F * F


def elastic_state(fp, obs):
    """Per row from observation rows (N, N_OBS) of :func:`evaluate`: the approach delta [m], the
    elastic force F of Eq. (series_contact) [N] (without the damping part of O_FN) and its
    potential V [J] (:func:`series_potential`). The series coefficients are rebuilt from the
    contact mode and the roll angles the row reports (as :func:`_gap_terms` forms them: on the
    line of action R_A = r_bA u_A, R_B = r_bB u_B; a tip edge has its edge radius and, on B, a
    convex sense); open rows and rows without approach carry zero force and energy."""
    fp = np.asarray(fp, float)
    obs = np.asarray(obs, float)
    A, B = GEAR_A, GEAR_B
    mode = obs[:, O_MODE]
    delta = -obs[:, O_GAP]
    on = (mode != MODE_OPEN) & (delta > 0)
    ua = np.where(on, obs[:, O_UA], fp[:, A + G_UREF])
    ub = np.where(on, obs[:, O_UB], fp[:, B + G_UREF])
    RA = np.where(mode == MODE_CORNER_A, fp[:, A + G_RHO_E], fp[:, A + G_RB] * ua)
    RB = np.where(mode == MODE_CORNER_B, fp[:, B + G_RHO_E], fp[:, B + G_RB] * ub)
    sB = np.where(mode == MODE_CORNER_B, 1.0, fp[:, B + G_EPS])
    bs = fp[:, C_BS]
    C = (poly(fp[:, :N_GEAR], G_PC, ua)[0] + poly(fp[:, B:B + N_GEAR], G_PC, ub)[0]) / bs
    hA = poly(fp[:, :N_GEAR], G_PH, ua)[0]
    hB = poly(fp[:, B:B + N_GEAR], G_PH, ub)[0]
    K = 1.0 / RA + sB / RB
    ds = np.where(on, delta, 1.0)
    E = (fp[:, A + G_E], fp[:, A + G_NU], fp[:, B + G_E], fp[:, B + G_NU])
    F = series_force(ds, C, hA, hB, K, *E, bs)[0]
    F = np.where(on, F, 0.0)
    V = np.where(on, series_potential(F, ds, *E, bs), 0.0)
    return delta, F, V


def select(pose, fp, ip, dev):
    """Contact mode, teeth and frozen roll-angle offsets of every row at the primal state.

    Returns a dict of per-row arrays: mode, k (tooth of A), j (tooth of B), and for each
    mode the integer multiples of 2 pi removed from the roll angles (off_a, off_b)."""
    N = len(fp)
    ia, ib = ip[:, J_BODY_A], ip[:, J_BODY_B]
    OA, OB = pose[ia, :2], pose[ib, :2]
    tha, thb = pose[ia, 2], pose[ib, 2]
    A, B = GEAR_A, GEAR_B
    eps = fp[:, B + G_EPS]
    rba, rbb = fp[:, A + G_RB], fp[:, B + G_RB]
    s = np.where(ip[:, J_LINE] == 0, 1.0, -1.0)
    omega = s * eps
    sig_a, sig_b = -omega, -omega * eps
    za, zb = ip[:, J_NA], ip[:, J_NB]
    D = OB - OA
    a = np.linalg.norm(D, axis=1)
    beta = np.arctan2(D[:, 1], D[:, 0])
    cw = (rbb + eps * rba) / a
    has_line = cw < 1.0
    aw = np.arccos(np.clip(cw, -1.0, 1.0))
    phia = np.where(eps > 0, beta + s * aw, beta + s * (np.pi - aw))
    L = eps * a * np.sin(aw)
    # tooth of A: the window offset from the tooth nearest the reference roll angle
    U0a = omega * (phia - tha - sig_a * fp[:, A + G_PSI])
    kstar = omega * _nearest((U0a - fp[:, A + G_UREF]) * za / TWO_PI)
    k = np.mod(kstar + ip[:, J_WINDOW], za).astype(np.int64)
    Xa = U0a - omega * (TWO_PI * k / za + dev[ip[:, J_TOOTH_A] + k])
    ua = fp[:, A + G_UREF] + _wrap(Xa - fp[:, A + G_UREF])
    # facing tooth of B: its flank point nearest A's along the line
    ubt = eps * (L - rba * ua) / rbb
    phib = phia + np.where(eps > 0, np.pi, 0.0)
    U0b = omega * (phib - thb - sig_b * fp[:, B + G_PSI])
    j = np.mod(omega * _nearest((U0b - ubt) * zb / TWO_PI), zb).astype(np.int64)
    Xb = U0b - omega * (TWO_PI * j / zb + dev[ip[:, J_TOOTH_B] + j])
    ub = ubt + _wrap(Xb - ubt)
    in_a = (ua >= fp[:, A + G_ULO]) & (ua <= fp[:, A + G_UHI])
    in_b = (ub >= fp[:, B + G_ULO]) & (ub <= fp[:, B + G_UHI])
    past_a = ua > fp[:, A + G_UHI]
    past_b = np.where(eps > 0, ub > fp[:, B + G_UHI], ub < fp[:, B + G_ULO])
    mode = np.where(in_a & in_b, MODE_LINE, np.where(past_a, MODE_CORNER_A, np.where(past_b, MODE_CORNER_B, MODE_OPEN)))
    mode = np.where(has_line, mode, MODE_OPEN)
    off_a = _nearest((Xa - ua) / TWO_PI)
    off_b = _nearest((Xb - ub) / TWO_PI)
    sel = dict(mode=mode, k=k, j=j, off_a=off_a, off_b=off_b)
    # corner modes: the foot on the other flank, and its admissible interval
    zeros = np.zeros((N, 2))
    for m, fn in ((MODE_CORNER_A, _corner_a), (MODE_CORNER_B, _corner_b)):
        rows = np.flatnonzero(mode == m)
        if len(rows) == 0:
            continue
        geo, ok, off = fn(pose, fp, ip, dev, rows, sel, (zeros[rows], np.zeros(len(rows)), zeros[rows],
                                                          np.zeros(len(rows))), select_foot=True)
        mode[rows[~ok]] = MODE_OPEN
        (off_b if m == MODE_CORNER_A else off_a)[rows] = off[0]
        if m == MODE_CORNER_A:
            j[rows] = off[1]
    sel["mode"] = mode
    return sel


def _common(pose, fp, ip, rows):
    ia, ib = ip[rows, J_BODY_A], ip[rows, J_BODY_B]
    f = fp[rows]
    eps = f[:, GEAR_B + G_EPS]
    s = np.where(ip[rows, J_LINE] == 0, 1.0, -1.0)
    return f, eps, s, s * eps, pose[ia, :2], pose[ia, 2], pose[ib, :2], pose[ib, 2]


def _line(pose, fp, ip, dev, rows, sel, seed):
    """Line-of-action contact: values and directional derivatives along ``seed``
    (dO_A, dtheta_A, dO_B, dtheta_B) of the geometry (see module docstring)."""
    f, eps, s, omega, OA, tha, OB, thb = _common(pose, fp, ip, rows)
    dOA, dtha, dOB, dthb = seed
    rba, rbb = f[:, GEAR_A + G_RB], f[:, GEAR_B + G_RB]
    D, dD = OB - OA, dOB - dOA
    a = np.linalg.norm(D, axis=1)
    da = _dot(D, dD) / a
    beta = np.arctan2(D[:, 1], D[:, 0])
    dbeta = _cross(D, dD) / a ** 2
    Rs = rbb + eps * rba
    aw = np.arccos(Rs / a)
    sw = np.sin(aw)
    daw = Rs * da / (a ** 2 * sw)
    phia = np.where(eps > 0, beta + s * aw, beta + s * (np.pi - aw))
    dphia = dbeta + s * eps * daw
    ea = _e(phia)
    d = -_col(omega) * _perp(ea)
    dd = _col(omega * dphia) * ea
    TA = OA + _col(rba) * ea
    dTA = dOA + _col(rba * dphia) * _perp(ea)
    TB = OB - _col(eps * rbb) * ea
    dTB = dOB - _col(eps * rbb * dphia) * _perp(ea)
    L = eps * a * sw
    dL = eps * da / sw
    k, j = sel["k"][rows], sel["j"][rows]
    ua = (omega * (phia - tha - (-omega) * f[:, GEAR_A + G_PSI]) - omega * (TWO_PI * k / ip[rows, J_NA]
          + dev[ip[rows, J_TOOTH_A] + k]) - TWO_PI * sel["off_a"][rows])
    phib = phia + np.where(eps > 0, np.pi, 0.0)
    ub = (omega * (phib - thb - (-omega * eps) * f[:, GEAR_B + G_PSI]) - omega * (TWO_PI * j / ip[rows, J_NB]
          + dev[ip[rows, J_TOOTH_B] + j]) - TWO_PI * sel["off_b"][rows])
    dua = omega * (dphia - dtha)
    dub = omega * (dphia - dthb)
    cA = TA + _col(rba * ua) * d
    dcA = dTA + _col(rba * dua) * d + _col(rba * ua) * dd
    cB = TB - _col(eps * rbb * ub) * d
    dcB = dTB - _col(eps * rbb * dub) * d - _col(eps * rbb * ub) * dd
    g = L - rba * ua - eps * rbb * ub
    dg = dL - rba * dua - eps * rbb * dub
    return dict(g=(g, dg), n=(d, dd), cA=(cA, dcA), cB=(cB, dcB), ua=(ua, dua), ub=(ub, dub),
                RA=(rba * ua, rba * dua), RB=(rbb * ub, rbb * dub), sB=eps)


def _foot(Pc, dPc, O, dO, rb, omega):
    """Foot of the involute normal through point Pc on a base circle (rb, centre O): tangent
    angle phi_t, lambda = |Pc - T| and their derivatives."""
    w, dw = Pc - O, dPc - dO
    rho = np.linalg.norm(w, axis=1)
    drho = _dot(w, dw) / rho
    lam = np.sqrt(np.maximum(rho ** 2 - rb ** 2, 0.0))
    lam_s = np.where(lam > 0, lam, 1.0)
    phit = np.arctan2(w[:, 1], w[:, 0]) + omega * np.arccos(np.clip(rb / rho, -1.0, 1.0))
    dphit = _cross(w, dw) / rho ** 2 + omega * rb * drho / (rho * lam_s)
    return phit, dphit, lam, rho * drho / lam_s, rho > rb


def _corner_a(pose, fp, ip, dev, rows, sel, seed, select_foot=False):
    """Tip edge of A's tooth k against B's flank (off the line of action)."""
    f, eps, s, omega, OA, tha, OB, thb = _common(pose, fp, ip, rows)
    dOA, dtha, dOB, dthb = seed
    A, B = GEAR_A, GEAR_B
    rbb = f[:, B + G_RB]
    k = sel["k"][rows]
    phi0 = tha + TWO_PI * k / ip[rows, J_NA] + dev[ip[rows, J_TOOTH_A] + k] - omega * f[:, A + G_PSI]
    ang = phi0 + omega * f[:, A + G_CHI]
    Pc = OA + _col(f[:, A + G_RHO_C]) * _e(ang)
    dPc = dOA + _col(f[:, A + G_RHO_C] * dtha) * _perp(_e(ang))
    phit, dphit, lam, dlam, ok = _foot(Pc, dPc, OB, dOB, rbb, omega)
    zb = ip[rows, J_NB]
    Xb0 = omega * (phit - thb - (-omega * eps) * f[:, B + G_PSI])
    if select_foot:
        ubt = lam / rbb
        j = np.mod(omega * _nearest((Xb0 - ubt) * zb / TWO_PI), zb).astype(np.int64)
        Xb = Xb0 - omega * (TWO_PI * j / zb + dev[ip[rows, J_TOOTH_B] + j])
        ub = ubt + _wrap(Xb - ubt)
        ok = ok & (ub >= f[:, B + G_ULO]) & (ub <= f[:, B + G_UHI])
        return None, ok, (_nearest((Xb - ub) / TWO_PI), j)
    j = sel["j"][rows]
    ub = Xb0 - omega * (TWO_PI * j / zb + dev[ip[rows, J_TOOTH_B] + j]) - TWO_PI * sel["off_b"][rows]
    dub = omega * (dphit - dthb)
    et = _e(phit)
    dT = -_col(omega) * _perp(et)
    ddT = _col(omega * dphit) * et
    n, dn = -_col(eps) * dT, -_col(eps) * ddT
    cB = OB + _col(rbb) * et + _col(rbb * ub) * dT
    dcB = dOB + _col(rbb * dphit) * _perp(et) + _col(rbb * dub) * dT + _col(rbb * ub) * ddT
    rho_e = f[:, A + G_RHO_E]
    cA = Pc + _col(rho_e) * n
    dcA = dPc + _col(rho_e) * dn
    ue = f[:, A + G_UEDGE]
    zero = np.zeros(len(rows))
    return dict(g=(eps * (lam - rbb * ub) - rho_e, eps * (dlam - rbb * dub)), n=(n, dn), cA=(cA, dcA), cB=(cB, dcB),
                ua=(ue, zero), ub=(ub, dub), RA=(rho_e, zero), RB=(rbb * ub, rbb * dub), sB=eps)


def _corner_b(pose, fp, ip, dev, rows, sel, seed, select_foot=False):
    """Tip edge of B's tooth j against A's flank of tooth k (off the line of action)."""
    f, eps, s, omega, OA, tha, OB, thb = _common(pose, fp, ip, rows)
    dOA, dtha, dOB, dthb = seed
    A, B = GEAR_A, GEAR_B
    rba = f[:, A + G_RB]
    j = sel["j"][rows]
    phi0 = thb + TWO_PI * j / ip[rows, J_NB] + dev[ip[rows, J_TOOTH_B] + j] - omega * eps * f[:, B + G_PSI]
    ang = phi0 + omega * f[:, B + G_CHI]
    Pc = OB + _col(f[:, B + G_RHO_C]) * _e(ang)
    dPc = dOB + _col(f[:, B + G_RHO_C] * dthb) * _perp(_e(ang))
    phit, dphit, lam, dlam, ok = _foot(Pc, dPc, OA, dOA, rba, omega)
    k = sel["k"][rows]
    Xa = (omega * (phit - tha - (-omega) * f[:, A + G_PSI])
          - omega * (TWO_PI * k / ip[rows, J_NA] + dev[ip[rows, J_TOOTH_A] + k]))
    if select_foot:
        uat = lam / rba
        ua = uat + _wrap(Xa - uat)
        ok = ok & (ua >= f[:, A + G_ULO]) & (ua <= f[:, A + G_UHI])
        return None, ok, (_nearest((Xa - ua) / TWO_PI), None)
    ua = Xa - TWO_PI * sel["off_a"][rows]
    dua = omega * (dphit - dtha)
    et = _e(phit)
    n = -_col(omega) * _perp(et)
    dn = _col(omega * dphit) * et
    cA = OA + _col(rba) * et + _col(rba * ua) * n
    dcA = dOA + _col(rba * dphit) * _perp(et) + _col(rba * dua) * n + _col(rba * ua) * dn
    rho_e = f[:, B + G_RHO_E]
    cB = Pc - _col(rho_e) * n
    dcB = dPc - _col(rho_e) * dn
    ue = f[:, B + G_UEDGE]
    zero = np.zeros(len(rows))
    return dict(g=(lam - rba * ua - rho_e, dlam - rba * dua), n=(n, dn), cA=(cA, dcA), cB=(cB, dcB),
                ua=(ua, dua), ub=(ue, zero), RA=(rba * ua, rba * dua), RB=(rho_e, zero), sB=np.ones(len(rows)))


GEOMETRY = {MODE_LINE: _line, MODE_CORNER_A: _corner_a, MODE_CORNER_B: _corner_b}


def _gap_terms(f, geo):
    """Total gap (Eq. (gap) with Eq. (skew) and the modifications), the compliance sum C, the
    depths and the curvature sum, each with its derivative."""
    z = f[:, C_Z]
    (ua, dua), (ub, dub) = geo["ua"], geo["ub"]
    eA, deA = modification(f, GEAR_A, ua, z)
    eB, deB = modification(f, GEAR_B, ub, z)
    n, dn = geo["n"]
    tx, ty = f[:, C_TX], f[:, C_TY]
    g0, dg0 = geo["g"]
    g = g0 + eA + eB + f[:, C_E] + z * (ty * n[:, 0] - tx * n[:, 1]) + z * f[:, C_TANPSI]
    dg = dg0 + deA * dua + deB * dub + z * (ty * dn[:, 0] - tx * dn[:, 1])
    fa = f[:, :N_GEAR]
    fb = f[:, GEAR_B:GEAR_B + N_GEAR]
    cA, dcA = poly(fa, G_PC, ua)
    cB, dcB = poly(fb, G_PC, ub)
    hA, dhA = poly(fa, G_PH, ua)
    hB, dhB = poly(fb, G_PH, ub)
    bs = f[:, C_BS]
    (RA, dRA), (RB, dRB) = geo["RA"], geo["RB"]
    sB = geo["sB"]
    K = 1.0 / RA + sB / RB
    dK = -dRA / RA ** 2 - sB * dRB / RB ** 2
    return dict(g=(g, dg), C=((cA + cB) / bs, (dcA * dua + dcB * dub) / bs), hA=(hA, dhA * dua),
                hB=(hB, dhB * dub), K=(K, dK))


def flank_offset(ip, n_teeth, tooth_offsets, k, j):
    """Slow-state gap offset [m] of the tooth pair of each row: the offset of the flank of tooth k
    of A on the row's line plus that of the facing flank of tooth j of B (positive opens the gap).
    tooth_offsets: (2 n_teeth,) per line of action (the flank side), then per tooth in the
    J_TOOTH_* layout of the deviations: index line * n_teeth + J_TOOTH_A + k. The offsets follow
    the teeth, not the rows (a row is a window slot whose teeth change as the gears turn)."""
    base = ip[:, J_LINE] * n_teeth
    return tooth_offsets[base + ip[:, J_TOOTH_A] + k] + tooth_offsets[base + ip[:, J_TOOTH_B] + j]


def evaluate(pose, vel, fparams, iparams, deviations, precision=np.float64, anchor=None, tooth_offsets=None):
    """Evaluate all rows. pose, vel: (nb+1, 3) with the ground last; fparams (N, N_FLOAT),
    iparams (N, N_INT); deviations: concatenated tooth-angle deviations [rad] (J_TOOTH_* offsets).
    tooth_offsets: None, or per-flank gap offsets (2 len(deviations),) [m] of :func:`flank_offset`
    added to the gap of Eq. (gap) (constant per tooth: no tangent term).
    anchor: None, or (anchor_params (N, anchor_ref.N_ANCHOR), committed flags (N,), anchors in
    A and in B coordinates (N, 2)) for the rows with J_FRICTION = FRICTION_ANCHOR (2): the anchor
    model of :mod:`anchor_ref`, anchors formed at the contact point c as material points of both
    teeth, the tangential force acting at the anchors. A row's teeth change as the gears turn (a
    window slot): the old pair's anchors are then a base pitch away and released (d_rel).
    Returns Q (N,6), dQdq (N,6,6), dQdv (N,6,6), obs (N, N_OBS), and with ``anchor`` the trial
    history (flags, anchor_A, anchor_B) as a fifth result."""
    fp = np.asarray(fparams, float)
    ip = np.asarray(iparams)
    dev = np.asarray(deviations, float)
    N = len(fp)
    sel = select(pose, fp, ip, dev)
    if anchor is not None:
        ap_all, h_act_all, h_a_all, h_b_all = (np.asarray(x) for x in anchor)
        ap_all = ap_all.astype(float)
        trial = (np.zeros(N, np.int32), np.zeros((N, 2)), np.zeros((N, 2)))   # open rows: no anchor
    Q = np.zeros((N, 6))
    dQ = np.zeros((N, 6, 12))
    obs = np.zeros((N, N_OBS))
    obs[:, O_MODE] = sel["mode"]
    obs[:, O_TOOTH_A] = sel["k"]
    obs[:, O_TOOTH_B] = sel["j"]
    obs[:, O_GAP] = OPEN_GAP
    for mode, geometry in GEOMETRY.items():
        rows = np.flatnonzero(sel["mode"] == mode)
        if len(rows) == 0:
            continue
        n_r = len(rows)
        f = fp[rows]
        ia, ib = ip[rows, J_BODY_A], ip[rows, J_BODY_B]
        OA, OB = pose[ia, :2], pose[ib, :2]
        vOA, wA, vOB, wB = vel[ia, :2], vel[ia, 2], vel[ib, :2], vel[ib, 2]
        z2, z1 = np.zeros((n_r, 2)), np.zeros(n_r)
        geo = geometry(pose, fp, ip, dev, rows, sel, (z2, z1, z2, z1))
        gt = _gap_terms(f, geo)
        g = gt["g"][0]
        if tooth_offsets is not None:
            g = g + flank_offset(ip[rows], len(dev), np.asarray(tooth_offsets, float), sel["k"][rows], sel["j"][rows])
        delta = -g
        on = delta > 0
        ds = np.where(on, delta, 1.0)
        Fel, Fd, FC, FhA, FhB, FK = series_force(ds, gt["C"][0], gt["hA"][0], gt["hB"][0], gt["K"][0], f[:, GEAR_A + G_E],
                                                 f[:, GEAR_A + G_NU], f[:, GEAR_B + G_E], f[:, GEAR_B + G_NU], f[:, C_BS],
                                                 SERIES_RTOL[precision])
        Fel, Fd, FC, FhA, FhB, FK = (np.where(on, x, 0.0) for x in (Fel, Fd, FC, FhA, FhB, FK))
        n = geo["n"][0]
        t = _perp(n)
        # the force acts at the contact point c = (c_A + c_B) / 2 on both bodies (on the line of both
        # flank points, so the normal moments equal those at c_A and c_B); friction and damping use the
        # material velocities there, so the sliding speed vanishes exactly at the pitch point and the
        # power identity of Eq. (contact_mapping) holds
        cA, cB = geo["cA"][0], geo["cB"][0]
        cm = 0.5 * (cA + cB)
        rA, rB = cm - OA, cm - OB
        vA = vOA + _col(wA) * _perp(rA)
        vB = vOB + _col(wB) * _perp(rB)
        ddot = -_dot(n, vB - vA)
        r, dr = laws_ref.damping_ramp(delta, f[:, C_DR])
        Fn = Fel + f[:, C_C] * r * ddot
        act = on & (Fn > 0)
        Fn = np.where(act, Fn, 0.0)
        vt = _dot(t, vA - vB)
        mu, dmu = laws_ref.friction_coefficient(f[:, C_MUK], f[:, C_MUS], f[:, C_VS], f[:, C_VREG], vt)
        fric = act & (ip[rows, J_FRICTION] == 1)
        Ft = np.where(fric, -Fn * mu, 0.0)
        if anchor is not None:
            ap = ap_all[rows]
            thA, thB = pose[ia, 2], pose[ib, 2]
            ha, hb, e_anc = anchor_ref.anchor_separation(OA, thA, OB, thB, h_a_all[rows], h_b_all[rows])
            contact = on & (ip[rows, J_FRICTION] == 2)
            anchored, stick, slip, s_anc, sg, ft_anc = anchor_ref.state(Fn, contact, h_act_all[rows], e_anc, t, ap)
            Ft = np.where(anchored, ft_anc, Ft)
            armA = np.where(anchored[:, None], ha, rA)
            armB = np.where(anchored[:, None], hb, rB)
            fnA, ftA = -_col(Fn) * n, _col(Ft) * t
            fA = fnA + ftA
            Q[rows, 0:2] = fA
            Q[rows, 2] = _cross(rA, fnA) + _cross(armA, ftA)
            Q[rows, 3:5] = -fA
            Q[rows, 5] = -(_cross(rB, fnA) + _cross(armB, ftA))
            tr = anchor_ref.trial_history(Fn, contact, anchored, slip, s_anc, sg, t, thA, thB, ha, hb, h_a_all[rows],
                                          h_b_all[rows], _rot(-thA, cm - OA), _rot(-thB, cm - OB), ap)
            for out, val in zip(trial, tr):
                out[rows] = val
        else:
            fA = -_col(Fn) * n + _col(Ft) * t
            Q[rows, 0:2] = fA
            Q[rows, 2] = _cross(rA, fA)
            Q[rows, 3:5] = -fA
            Q[rows, 5] = -_cross(rB, fA)
        for jseed in range(12):
            sd = np.zeros((n_r, 12))
            sd[:, jseed] = 1.0
            dOA, dtha, dOB, dthb = sd[:, 0:2], sd[:, 2], sd[:, 3:5], sd[:, 5]
            dvOA, dwA, dvOB, dwB = sd[:, 6:8], sd[:, 8], sd[:, 9:11], sd[:, 11]
            dgeo = geometry(pose, fp, ip, dev, rows, sel, (dOA, dtha, dOB, dthb))
            dgt = _gap_terms(f, dgeo)
            ddelta = -dgt["g"][1]
            dFel = Fd * ddelta + FC * dgt["C"][1] + FhA * dgt["hA"][1] + FhB * dgt["hB"][1] + FK * dgt["K"][1]
            dn = dgeo["n"][1]
            dt = _perp(dn)
            dcm = 0.5 * (dgeo["cA"][1] + dgeo["cB"][1])
            drA, drB = dcm - dOA, dcm - dOB
            dvA = dvOA + _col(dwA) * _perp(rA) + _col(wA) * _perp(drA)
            dvB = dvOB + _col(dwB) * _perp(rB) + _col(wB) * _perp(drB)
            dddot = -(_dot(dn, vB - vA) + _dot(n, dvB - dvA))
            dFn = np.where(act, dFel + f[:, C_C] * (dr * ddelta * ddot + r * dddot), 0.0)
            dvt = _dot(dt, vA - vB) + _dot(t, dvA - dvB)
            dFt = np.where(fric, -(dFn * mu + Fn * dmu * dvt), 0.0)
            if anchor is not None:
                # anchors are material points: they turn with their bodies and do not migrate
                dha, dhb = _col(dtha) * _perp(ha), _col(dthb) * _perp(hb)
                de = (dOA + dha) - (dOB + dhb)
                dFt = np.where(anchored, anchor_ref.force_tangent(stick, slip, sg, e_anc, t, dFn, dt, de, ap), dFt)
                darmA = np.where(anchored[:, None], dha, drA)
                darmB = np.where(anchored[:, None], dhb, drB)
                dfnA = -_col(dFn) * n - _col(Fn) * dn
                dftA = _col(dFt) * t + _col(Ft) * dt
                dQ[rows, 0:2, jseed] = dfnA + dftA
                dQ[rows, 2, jseed] = _cross(drA, fnA) + _cross(rA, dfnA) + _cross(darmA, ftA) + _cross(armA, dftA)
                dQ[rows, 3:5, jseed] = -(dfnA + dftA)
                dQ[rows, 5, jseed] = -(_cross(drB, fnA) + _cross(rB, dfnA) + _cross(darmB, ftA) + _cross(armB, dftA))
                continue
            dfA = -_col(dFn) * n - _col(Fn) * dn + _col(dFt) * t + _col(Ft) * dt
            dQ[rows, 0:2, jseed] = dfA
            dQ[rows, 2, jseed] = _cross(drA, fA) + _cross(rA, dfA)
            dQ[rows, 3:5, jseed] = -dfA
            dQ[rows, 5, jseed] = -(_cross(drB, fA) + _cross(rB, dfA))
        obs[rows, O_FN] = Fn
        obs[rows, O_VT] = vt
        obs[rows, O_GAP] = g
        obs[rows, O_PX:O_PY + 1] = cm
        obs[rows, O_NX:O_NY + 1] = n
        obs[rows, O_FT] = Ft
        obs[rows, O_VROLL] = 0.5 * _dot(t, vA + vB)
        obs[rows, O_UA] = geo["ua"][0]
        obs[rows, O_UB] = geo["ub"][0]
        obs[rows, O_KT] = Fd
    if anchor is not None:
        return Q, dQ[:, :, :6], dQ[:, :, 6:], obs, trial
    return Q, dQ[:, :, :6], dQ[:, :, 6:], obs
