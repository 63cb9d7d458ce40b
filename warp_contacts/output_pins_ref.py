"""NumPy reference of the output-pin contact family with its analytic
tangent (readable version of :mod:`warp_contacts.output_pins`).

Geometry (paper, Eq. (output_gap)). A pin of outer radius r_p is fixed to
the flange, its hole of radius R_h to a wheel. In every axial slice s the
gap is

    g = R_h - r_p - |c_p - c_h| + u_off,

so the approach is d = |c_p - c_h| - (R_h - r_p) - u_off. The pin centre
c_p follows the flange and the hole centre c_h the wheel, each with its own
translation, rotation about z and small tilts (theta_x, theta_y): a point at
body coordinates (xi, z) sits at x + R(theta) xi + (theta_y z, -theta_x z),
the first-order small-tilt offset. The axial plane of a slice is
z_f = z_w + s relative to the flange and z = s relative to the wheel, where
z_w is the wheel midplane and s the slice station.

Law. Each of the n_s uniform slices carries k_s [d]_+^p with k_s = k / n_s
and p = 10/9 (Eq. (pin_open_state)). The force on the pin points toward the
hole centre; its opposite, F n with n = (c_p - c_h)/|c_p - c_h|, acts on
the wheel. Reactions are summed as (F_x, F_y, M_z) about each body origin,
plus the tilt moments (M_x, M_y) = (-z f_y, z f_x) of each slice force about
the body origin.

Two modes:

* plain (rigid pin, uncondensed): one contact pair per (pin, wheel);
  coordinates (flange, wheel), 6 seeds.
* shared pin (condensed, Eqs. (pin_compliance), (pin_open_state),
  (pin_local_closure), (supp_pin_closure), (supp_pin_fit)): one pin loaded
  by two wheels through a massless sleeve with a radial clearance disk of
  radius c. Starting from u_fit = 0 the sleeve centre receives a fixed number
  of projected updates; at the final position the local closure is repeated
  and every slice force is re-evaluated after subtracting the station
  deflection u_p,i. Coordinates (flange, wheel 0, wheel 1), 9 seeds, the
  order of Eq. (supp_pin_coordinates).

Tangent. Forward mode: every intermediate quantity carries its derivative
along all unit seed directions at once (a trailing axis of length 6 or 9),
differentiated by hand through the closure, the fixed sleeve updates with
projection, clipping and floors, and the re-evaluation. It is the exact
derivative of the implemented finite-iteration force map on each smooth
branch, including the force-arm term of Eq. (moment_chain_rule). Tilts are
prescribed inputs (e.g. from a tilt-constrained or separately integrated
model): the tangent covers the planar coordinates (x, y, theta) only.

Complex step. With ``tangent=False`` the functions accept complex poses and
keep every branch decision on the real part, so that Im(Q(q + i h e_j))/h is
an independent derivative of the same force map (used by the moment
diagnostic of Eq. (moment_comparison_error)).
"""
import numpy as np

from .planar_ref import cross2, perp, rot

# ---- shared-pin packed float parameters (one row per pin; SI units) ----
P_XI_PIN = 0        # (2) pin centre in flange coordinates [m]
P_XI_HOLE0 = 2      # (2) hole centre in wheel-0 coordinates [m]
P_XI_HOLE1 = 4      # (2) hole centre in wheel-1 coordinates [m]
P_R_PIN = 6         # outer pin (sleeve) radius r_p [m]
P_R_HOLE = 7        # wheel-hole radius R_h [m]
P_OFF0 = 8          # gap offset u_off at wheel 0 [m]
P_OFF1 = 9          # gap offset u_off at wheel 1 [m]
P_K = 10            # whole-contact coefficient k [N m^-p]
P_EXP = 11          # exponent p [-]
P_Z0 = 12           # wheel-0 midplane relative to the flange [m]
P_Z1 = 13           # wheel-1 midplane relative to the flange [m]
P_C00 = 14          # self-compliance at station 0 [m/N]
P_C11 = 15          # self-compliance at station 1 [m/N]
P_C01 = 16          # cross-compliance [m/N]
P_CIN = 17          # inner-contact compliance added to the diagonal [m/N]
P_CLEAR = 18        # sleeve radial clearance c [m]
P_RELAX = 19        # sleeve-update relaxation (0.7) [-]
P_KFLOOR = 20       # sleeve-update tangent floor [N/m]
P_DETFLOOR = 21     # determinant floor [-]
P_DISTFLOOR = 22    # distance floor [m]
P_DMIN = 23         # open-tangent indentation floor d_min [m]
N_SHARED_F = 24
I_FLANGE, I_WHEEL0, I_WHEEL1, I_UPDATES = 0, 1, 2, 3
N_SHARED_I = 4

# ---- plain-pair packed float parameters (one row per pin-wheel pair) ----
Q_XI_PIN = 0        # (2) pin centre in flange coordinates [m]
Q_XI_HOLE = 2       # (2) hole centre in wheel coordinates [m]
Q_R_PIN = 4         # r_p [m]
Q_R_HOLE = 5        # R_h [m]
Q_OFF = 6           # u_off [m]
Q_K = 7             # whole-contact coefficient k [N m^-p]
Q_EXP = 8           # exponent p [-]
Q_Z = 9             # wheel midplane relative to the flange [m]
Q_DISTFLOOR = 10    # distance floor [m]
N_PLAIN_F = 11
J_FLANGE, J_WHEEL = 0, 1
N_PLAIN_I = 2

# ---- generalized coordinates of a row: the (x, y, theta) triple of each body starts at ----
X_FLANGE, X_WHEEL0, X_WHEEL1 = 0, 3, 6     # Eq. (supp_pin_coordinates) order; plain rows: flange, wheel

# ---- per-slice output columns ----
S_FORCE, S_APPROACH, S_GEOM, S_NX, S_NY, S_PX, S_PY = range(7)
N_SLICE_COLS = 7
# S_APPROACH: effective approach d - u_p,i used by the re-evaluated law [m];
# S_GEOM: geometric (rigid-support) approach d at the final sleeve position [m];
# (S_NX, S_NY): unit direction of the force on the wheel; (S_PX, S_PY): contact point [m].

# ---- per-pin output columns of the shared mode ----
(U_X, U_Y, FC0, FC1, UP0, UP1, K0, K1, FOPEN0, FOPEN1, FW0, FW1, N0X, N0Y, N1X, N1Y) = range(16)
N_PIN_COLS = 16
# (U_X, U_Y): sleeve offset u_fit [m]; FC*: clipped closure resultants F^c [N]; UP*: station
# deflections u_p = C_p F^c [m]; K*: open tangents [N/m]; FOPEN*: open resultants F^0 [N];
# FW*: re-evaluated wheel resultants sum_s F_is [N]; N*: wheel normals n_i.


# ------------------------------------------------------------------ helpers
def _norm(v):
    # sqrt of the sum of squares (not np.abs), so that complex steps propagate
    return np.sqrt(v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1])


def _re(x):
    return np.real(x)


def _tilt_offset(tilt, z):
    """Planar offset (theta_y z, -theta_x z) of a point at axial plane z (small tilts)."""
    return np.stack([tilt[..., 1] * z, -tilt[..., 0] * z], axis=-1)


def _seed_block(nseed, col0, arm):
    """d(x + R(theta) xi)/dq for a body whose triple starts at seed column col0: (Np, 2, nseed)."""
    n = arm.shape[0]
    J = np.zeros((n, 2, nseed), dtype=arm.dtype)
    J[:, 0, col0] = 1.0
    J[:, 1, col0 + 1] = 1.0
    J[:, :, col0 + 2] = perp(arm)
    return J


def _unit(v, dv, floor):
    """L = max(|v|, floor), n = v / L and their tangents (dv may be None)."""
    Lr = _norm(v)
    big = _re(Lr) > floor
    L = np.where(big, Lr, floor)
    n = v / L[..., None]
    if dv is None:
        return L, n, None, None
    dL = np.where(big[..., None], np.einsum("...k,...kj->...j", v, dv) / np.where(big, Lr, 1.0)[..., None], 0.0)
    dn = (dv - n[..., :, None] * dL[..., None, :]) / L[..., None, None]
    return L, n, dL, dn


def _power(ks, p, d, dd=None):
    """ks [d]_+^p and its tangent (Eq. (pin_open_state)); complex-step safe."""
    pos = _re(d) > 0.0
    ds = np.where(pos, d, 1.0)
    F = np.where(pos, ks * ds ** p, 0.0)
    if dd is None:
        return F, None
    dF = np.where(pos[..., None], (p * ks * ds ** (p - 1.0))[..., None] * dd, 0.0)
    return F, dF


# ------------------------------------------------------------------ plain mode
def evaluate_plain(pose, fparams, iparams, stations, tilt=None, tangent=True):
    """Rigid-pin (uncondensed) pin--hole pairs; one row per (pin, wheel) pair.

    Parameters
    ----------
    pose : (nb, 3) absolute body poses (x [m], y [m], theta [rad]).
    fparams, iparams : (N, N_PLAIN_F), (N, N_PLAIN_I) packed parameters.
    stations : (ns,) slice stations s relative to the wheel midplane [m].
    tilt : (nb, 2) small tilts (theta_x, theta_y) [rad] or None (zero).

    Returns a dict with Q (N, 6) on (flange, wheel), dQdq (N, 6, 6) (or None),
    tilt_moments (N, 2, 2) ((M_x, M_y) on flange and wheel), slices
    (N, ns, N_SLICE_COLS) and, with the tangent, slice_force_tangent (N, ns, 2, 6)
    (d(force vector on the wheel)/dq per slice).
    """
    fp = np.asarray(fparams, np.float64)
    ip = np.asarray(iparams)
    stations = np.asarray(stations, np.float64)
    pose = np.asarray(pose)
    N, ns = fp.shape[0], stations.size
    if tilt is None:
        tilt = np.zeros((pose.shape[0], 2))
    f, w = ip[:, J_FLANGE], ip[:, J_WHEEL]
    qf, qw = pose[f], pose[w]
    tf, tw = tilt[f], tilt[w]
    pf = rot(qf[:, 2], fp[:, Q_XI_PIN:Q_XI_PIN + 2])
    ph = rot(qw[:, 2], fp[:, Q_XI_HOLE:Q_XI_HOLE + 2])
    zw = fp[:, Q_Z]
    a = (qf[:, :2] + pf + _tilt_offset(tf, zw)) - (qw[:, :2] + ph)
    b = _tilt_offset(tf, np.ones(N)) - _tilt_offset(tw, np.ones(N))
    clr = fp[:, Q_R_HOLE] - fp[:, Q_R_PIN] + fp[:, Q_OFF]
    ks = fp[:, Q_K] / ns
    p = fp[:, Q_EXP]
    dtype = np.result_type(pose.dtype, np.float64)
    Q = np.zeros((N, 6), dtype)
    dQ = np.zeros((N, 6, 6)) if tangent else None
    Mt = np.zeros((N, 2, 2), dtype)
    S = np.zeros((N, ns, N_SLICE_COLS), dtype)
    da = (_seed_block(6, 0, pf) - _seed_block(6, 3, ph)) if tangent else None
    dfs = np.zeros((N, ns, 2, 6)) if tangent else None
    for js in range(ns):
        s = stations[js]
        e = a + s * b
        L, n, dL, dn = _unit(e, da, fp[:, Q_DISTFLOOR])
        d = L - clr
        F, dF = _power(ks, p, d, dL)
        fv = F[:, None] * n                                   # force on the wheel
        arm_w = ph + _tilt_offset(tw, s * np.ones(N))         # hole centre from the wheel origin
        arm_f = pf + _tilt_offset(tf, zw + s)                 # pin centre from the flange origin
        Q[:, 0:2] -= fv
        Q[:, 2] -= cross2(arm_f, fv)
        Q[:, 3:5] += fv
        Q[:, 5] += cross2(arm_w, fv)
        Mt[:, 0] -= np.stack([-(zw + s) * fv[:, 1], (zw + s) * fv[:, 0]], axis=-1)
        Mt[:, 1] += np.stack([-s * fv[:, 1], s * fv[:, 0]], axis=-1)
        hc = qw[:, :2] + arm_w
        S[:, js, S_FORCE] = F
        S[:, js, S_APPROACH] = d
        S[:, js, S_GEOM] = d
        S[:, js, S_NX:S_NY + 1] = n
        S[:, js, S_PX:S_PY + 1] = hc + (0.5 * (L + fp[:, Q_R_PIN] + fp[:, Q_R_HOLE]))[:, None] * n
        if tangent:
            dfv = dF[:, None, :] * n[:, :, None] + F[:, None, None] * dn
            dfs[:, js] = dfv
            darm_f = np.zeros((N, 2, 6))
            darm_f[:, :, 2] = perp(pf)
            darm_w = np.zeros((N, 2, 6))
            darm_w[:, :, 5] = perp(ph)
            dQ[:, 0:2] -= dfv
            dQ[:, 2] -= _dcross(arm_f, darm_f, fv, dfv)
            dQ[:, 3:5] += dfv
            dQ[:, 5] += _dcross(arm_w, darm_w, fv, dfv)
    return {"Q": Q, "dQdq": dQ, "tilt_moments": Mt, "slices": S, "slice_force_tangent": dfs}


def evaluate_plain_anchor(pose, fparams, iparams, stations, anchor_params, hist_active, hist_a, hist_b, tilt=None):
    """:func:`evaluate_plain` with anchor friction per slice (Eq. (friction), anchor model of
    :mod:`anchor_ref`).

    Every slice row k = i ns + s (the order of the slice observations) carries one anchor:
    A is the wheel, B the flange; a new anchor forms at the slice's contact point as material
    points of both bodies (planar section: the tilts are prescribed inputs and do not slide).
    The slice's normal force F_s and normal n_s come from the normal law; its tangent from the
    slice force tangent df_s = dF_s n_s + F_s dn_s, so dF_s = n_s . df_s and
    dn_s = (df_s - n_s dF_s) / F_s. The tangential force F_t t (t = perp(n_s)) acts on the
    wheel at its anchor and its opposite on the flange at the flange anchor.

    anchor_params (N ns, anchor_ref.N_ANCHOR); committed flags (N ns,), anchors in wheel and
    flange coordinates (N ns, 2). Returns the dict of :func:`evaluate_plain` with Q and dQdq
    including friction, ``ft`` (N, ns) tangential force on the wheel along t [N] and ``trial``
    (flags, anchor_A, anchor_B) of the slice rows.
    """
    from . import anchor_ref
    res = evaluate_plain(pose, fparams, iparams, stations, tilt=tilt, tangent=True)
    ip = np.asarray(iparams)
    pose = np.asarray(pose, np.float64)
    ap = np.asarray(anchor_params, np.float64)
    N, ns = ip.shape[0], len(stations)
    rows = np.repeat(np.arange(N), ns)                    # slice row k -> pair row
    qf, qw = pose[ip[rows, J_FLANGE]], pose[ip[rows, J_WHEEL]]
    S = res["slices"].reshape(N * ns, N_SLICE_COLS)
    dfs = res["slice_force_tangent"].reshape(N * ns, 2, 6)
    F, n = S[:, S_FORCE], S[:, S_NX:S_NY + 1]
    pc = S[:, S_PX:S_PY + 1]
    contact = S[:, S_APPROACH] > 0.0
    t = perp(n)
    ha, hb, e = anchor_ref.anchor_separation(qw[:, :2], qw[:, 2], qf[:, :2], qf[:, 2], hist_a, hist_b)
    anchored, stick, slip, s_anc, sg, ft = anchor_ref.state(F, contact, hist_active, e, t, ap)
    ftv = ft[:, None] * t
    Q = res["Q"].copy()
    dQ = res["dQdq"].copy()
    np.add.at(Q, (rows, slice(X_WHEEL0, X_WHEEL0 + 2)), ftv)
    np.add.at(Q, (rows, X_WHEEL0 + 2), cross2(ha, ftv))
    np.add.at(Q, (rows, slice(X_FLANGE, X_FLANGE + 2)), -ftv)
    np.add.at(Q, (rows, X_FLANGE + 2), -cross2(hb, ftv))
    Fs = np.where(F > 0, F, 1.0)
    for j in range(6):
        df = dfs[:, :, j]
        dF = np.sum(n * df, axis=1)
        dn = np.where((F > 0)[:, None], (df - n * dF[:, None]) / Fs[:, None], 0.0)
        dt = perp(dn)
        # seed j moves the flange (0-2) or the wheel (3-5); anchors turn with their bodies
        dxw = np.zeros((N * ns, 2))
        dxf = np.zeros((N * ns, 2))
        dha = np.zeros((N * ns, 2))
        dhb = np.zeros((N * ns, 2))
        if j < 2:
            dxf[:, j] = 1.0
        elif j == 2:
            dhb = perp(hb)
        elif j < 5:
            dxw[:, j - 3] = 1.0
        else:
            dha = perp(ha)
        de = (dxw + dha) - (dxf + dhb)
        dft = anchor_ref.force_tangent(stick, slip, sg, e, t, dF, dt, de, ap)
        dftv = dft[:, None] * t + ft[:, None] * dt
        np.add.at(dQ, (rows, slice(X_WHEEL0, X_WHEEL0 + 2), j), dftv)
        np.add.at(dQ, (rows, X_WHEEL0 + 2, j), cross2(dha, ftv) + cross2(ha, dftv))
        np.add.at(dQ, (rows, slice(X_FLANGE, X_FLANGE + 2), j), -dftv)
        np.add.at(dQ, (rows, X_FLANGE + 2, j), -(cross2(dhb, ftv) + cross2(hb, dftv)))
    trial = anchor_ref.trial_history(F, contact, anchored, slip, s_anc, sg, t, qw[:, 2], qf[:, 2], ha, hb, hist_a,
                                     hist_b, rot(-qw[:, 2], pc - qw[:, :2]), rot(-qf[:, 2], pc - qf[:, :2]), ap)
    out = dict(res)
    out.update(Q=Q, dQdq=dQ, ft=ft.reshape(N, ns), trial=trial)
    return out


def _dcross(r, dr, f, df):
    """Tangent of r x f: r x df + dr x f, the force and force-arm terms of Eq. (moment_chain_rule)."""
    return (r[:, 0, None] * df[:, 1] - r[:, 1, None] * df[:, 0]
            + dr[:, 0] * f[:, 1, None] - dr[:, 1] * f[:, 0, None])


# ------------------------------------------------------------------ shared mode
def _closure(a, da, b, u, du, fp, stations):
    """One local closure at sleeve offset u (Eqs. (supp_pin_closure)).

    a[i], b[i]: slice separation e_is = a_i + s b_i (pin minus hole centre,
    without sleeve offset) of wheel i; da[i] its tangent. Returns a dict of
    the slice geometry, open resultants/tangents, normals, clipped closure
    forces F^c and station deflections u_p, each with its tangent.
    """
    ns = stations.size
    N = fp.shape[0]
    k = fp[:, P_K]
    p = fp[:, P_EXP]
    ks = k / ns
    dmin = fp[:, P_DMIN]
    dfloor = fp[:, P_DISTFLOOR]
    tan = du is not None
    out = {"L": [], "n": [], "d": [], "dL": [], "dn": [], "F0": [], "K": [], "dF0": [], "dK": [],
           "nw": [], "dnw": []}
    for i in range(2):
        clr = fp[:, P_R_HOLE] - fp[:, P_R_PIN] + fp[:, P_OFF0 + i]
        F0 = np.zeros(N, a[i].dtype)
        K = np.zeros(N, a[i].dtype)
        dF0 = np.zeros((N, 9)) if tan else None
        dK = np.zeros((N, 9)) if tan else None
        Ls, ns_, ds, dLs, dns = [], [], [], [], []
        for js in range(ns):
            v = a[i] + stations[js] * b[i] + u
            dv = (da[i] + du) if tan else None
            L, n, dL, dn = _unit(v, dv, dfloor)
            d = L - clr
            pos = _re(d) > 0.0
            ds_ = np.where(pos, d, 1.0)
            F0 = F0 + np.where(pos, ks * ds_ ** p, 0.0)
            # open tangent with indentation floor d_min (Eq. (pin_open_state))
            dcl = np.where(_re(d) > dmin, d, dmin)
            K = K + np.where(pos, p * ks * dcl ** (p - 1.0), 0.0)
            if tan:
                dF0 = dF0 + np.where(pos[:, None], (p * ks * ds_ ** (p - 1.0))[:, None] * dL, 0.0)
                dK = dK + np.where((pos & (_re(d) > dmin))[:, None],
                                   (p * (p - 1.0) * ks * dcl ** (p - 2.0))[:, None] * dL, 0.0)
            Ls.append(L), ns_.append(n), ds.append(d), dLs.append(dL), dns.append(dn)
        # wheel normal: direction of the slice-mean separation (the wheel midplane for symmetric stations)
        m = a[i] + np.mean(stations) * b[i] + u
        _, nw, _, dnw = _unit(m, (da[i] + du) if tan else None, dfloor)
        for key, val in (("L", Ls), ("n", ns_), ("d", ds), ("dL", dLs), ("dn", dns), ("F0", F0), ("K", K),
                         ("dF0", dF0), ("dK", dK), ("nw", nw), ("dnw", dnw)):
            out[key].append(val)
    n0, n1 = out["nw"]
    K0, K1 = out["K"]
    F00, F01 = out["F0"]
    c01 = fp[:, P_C01] * (n0[:, 0] * n1[:, 0] + n0[:, 1] * n1[:, 1])      # Eq. (pin_compliance)
    c00 = fp[:, P_C00] + fp[:, P_CIN]
    c11 = fp[:, P_C11] + fp[:, P_CIN]
    A00, A01, A10, A11 = 1.0 + K0 * c00, K0 * c01, K1 * c01, 1.0 + K1 * c11
    detr = A00 * A11 - A01 * A10
    detok = _re(detr) > fp[:, P_DETFLOOR]
    det = np.where(detok, detr, fp[:, P_DETFLOOR])
    Fc0r = (A11 * F00 - A01 * F01) / det
    Fc1r = (A00 * F01 - A10 * F00) / det
    pos0, pos1 = _re(Fc0r) > 0.0, _re(Fc1r) > 0.0       # tensile resultants are clipped
    Fc0 = np.where(pos0, Fc0r, 0.0)
    Fc1 = np.where(pos1, Fc1r, 0.0)
    up0 = c00 * Fc0 + c01 * Fc1
    up1 = c01 * Fc0 + c11 * Fc1
    out.update(c01=c01, Fc=[Fc0, Fc1], up=[up0, up1])
    if tan:
        dn0, dn1 = out["dnw"]
        dK0, dK1 = out["dK"]
        dF00, dF01 = out["dF0"]
        dc01 = fp[:, P_C01, None] * (np.einsum("nk,nkj->nj", n1, dn0) + np.einsum("nk,nkj->nj", n0, dn1))
        dA00, dA11 = dK0 * c00[:, None], dK1 * c11[:, None]
        dA01 = dK0 * c01[:, None] + K0[:, None] * dc01
        dA10 = dK1 * c01[:, None] + K1[:, None] * dc01
        ddet = np.where(detok[:, None], dA00 * A11[:, None] + A00[:, None] * dA11
                        - dA01 * A10[:, None] - A01[:, None] * dA10, 0.0)
        dFc0 = (dA11 * F00[:, None] + A11[:, None] * dF00 - dA01 * F01[:, None] - A01[:, None] * dF01
                - Fc0r[:, None] * ddet) / det[:, None]
        dFc1 = (dA00 * F01[:, None] + A00[:, None] * dF01 - dA10 * F00[:, None] - A10[:, None] * dF00
                - Fc1r[:, None] * ddet) / det[:, None]
        dFc0 = np.where(pos0[:, None], dFc0, 0.0)
        dFc1 = np.where(pos1[:, None], dFc1, 0.0)
        dup0 = c00[:, None] * dFc0 + dc01 * Fc1[:, None] + c01[:, None] * dFc1
        dup1 = dc01 * Fc0[:, None] + c01[:, None] * dFc0 + c11[:, None] * dFc1
        out.update(dFc=[dFc0, dFc1], dup=[dup0, dup1])
    return out


def evaluate_shared(pose, fparams, iparams, stations, tilt=None, tangent=True):
    """Shared-pin condensation: one row per pin loaded by two wheels.

    Parameters as :func:`evaluate_plain` with (N, N_SHARED_F), (N, N_SHARED_I)
    parameters. Returns a dict with

    * Q (N, 9): (F_x, F_y, M_z) on flange, wheel 0, wheel 1 (Eq. (supp_pin_coordinates) order)
    * dQdq (N, 9, 9): forward-mode tangent dQ/dq (None if ``tangent`` is False)
    * tilt_moments (N, 3, 2): (M_x, M_y) on flange, wheel 0, wheel 1
    * slices (N, 2, ns, N_SLICE_COLS), pin (N, N_PIN_COLS)
    * slice_force_tangent (N, 2, ns, 2, 9): d(force vector on the wheel)/dq
    * sleeve_tangent (N, 2, 9): d u_fit / dq
    """
    fp = np.asarray(fparams, np.float64)
    ip = np.asarray(iparams)
    stations = np.asarray(stations, np.float64)
    pose = np.asarray(pose)
    N, ns = fp.shape[0], stations.size
    if tilt is None:
        tilt = np.zeros((pose.shape[0], 2))
    if tangent and np.iscomplexobj(pose):
        raise ValueError("tangent=True needs real poses; complex poses are for the complex-step check")
    dtype = np.result_type(pose.dtype, np.float64)
    ones = np.ones(N)
    bf = ip[:, I_FLANGE]
    qf, tf = pose[bf], tilt[bf]
    pf = rot(qf[:, 2], fp[:, P_XI_PIN:P_XI_PIN + 2])
    a, da, b, ph, tw, qw, zw = [], [], [], [], [], [], []
    for i in range(2):
        bw = ip[:, I_WHEEL0 + i]
        qw.append(pose[bw])
        tw.append(tilt[bw])
        zw.append(fp[:, P_Z0 + i])
        ph.append(rot(qw[i][:, 2], fp[:, P_XI_HOLE0 + 2 * i:P_XI_HOLE0 + 2 * i + 2]))
        # e_is = a_i + s b_i: pin centre minus hole centre in slice plane s (no sleeve offset)
        a.append((qf[:, :2] + pf + _tilt_offset(tf, zw[i])) - (qw[i][:, :2] + ph[i]))
        b.append(_tilt_offset(tf, ones) - _tilt_offset(tw[i], ones))
        if tangent:
            da.append(_seed_block(9, 0, pf) - _seed_block(9, 3 + 3 * i, ph[i]))
    if not tangent:
        da = [None, None]

    u = np.zeros((N, 2), dtype)
    du = np.zeros((N, 2, 9)) if tangent else None
    clear = fp[:, P_CLEAR]
    for _ in range(int(ip[0, I_UPDATES]) if N else 0):
        c = _closure(a, da, b, u, du, fp, stations)
        n0, n1 = c["nw"]
        Fc0, Fc1 = c["Fc"]
        g = Fc0[:, None] * n0 + Fc1[:, None] * n1            # sum_i F_i^c n_i (force on the wheels)
        Ktr = c["K"][0] + c["K"][1]
        kok = _re(Ktr) > fp[:, P_KFLOOR]
        Kt = np.where(kok, Ktr, fp[:, P_KFLOOR])
        w = u - (fp[:, P_RELAX] / Kt)[:, None] * g           # Eq. (supp_pin_fit)
        wl = _norm(w)
        out = _re(wl) > clear
        scale = np.where(out, clear / np.where(out, wl, 1.0), 1.0)
        if tangent:
            dg = (c["dFc"][0][:, None, :] * n0[:, :, None] + Fc0[:, None, None] * c["dnw"][0]
                  + c["dFc"][1][:, None, :] * n1[:, :, None] + Fc1[:, None, None] * c["dnw"][1])
            dKt = np.where(kok[:, None], c["dK"][0] + c["dK"][1], 0.0)
            dw = du - fp[:, P_RELAX, None, None] * (dg / Kt[:, None, None]
                                                    - g[:, :, None] * (dKt / Kt[:, None] ** 2)[:, None, :])
            wh = w / np.where(out, wl, 1.0)[:, None]
            # projection onto the disk: d(c w/|w|) = c (I - w_hat w_hat^T) dw / |w|
            dproj = (clear / np.where(out, wl, 1.0))[:, None, None] * (
                dw - wh[:, :, None] * np.einsum("nk,nkj->nj", wh, dw)[:, None, :])
            du = np.where(out[:, None, None], dproj, dw)
        u = w * scale[:, None]

    c = _closure(a, da, b, u, du, fp, stations)
    ks = fp[:, P_K] / ns
    p = fp[:, P_EXP]
    Q = np.zeros((N, 9), dtype)
    dQ = np.zeros((N, 9, 9)) if tangent else None
    Mt = np.zeros((N, 3, 2), dtype)
    S = np.zeros((N, 2, ns, N_SLICE_COLS), dtype)
    dfs = np.zeros((N, 2, ns, 2, 9)) if tangent else None
    FW = [np.zeros(N, dtype), np.zeros(N, dtype)]
    for i in range(2):
        up = c["up"][i]
        for js in range(ns):
            s = stations[js]
            L, n, d = c["L"][i][js], c["n"][i][js], c["d"][i][js]
            de = d - up                                        # station deflection subtracted
            F, dF = _power(ks, p, de, (c["dL"][i][js] - c["dup"][i]) if tangent else None)
            FW[i] = FW[i] + F
            fv = F[:, None] * n                                # force on wheel i
            arm_w = ph[i] + _tilt_offset(tw[i], s * ones)
            zf = zw[i] + s
            arm_f = pf + _tilt_offset(tf, zf) + u              # force line passes the sleeve centre
            Q[:, 0:2] -= fv
            Q[:, 2] -= cross2(arm_f, fv)
            Q[:, 3 + 3 * i:5 + 3 * i] += fv
            Q[:, 5 + 3 * i] += cross2(arm_w, fv)
            Mt[:, 0] -= np.stack([-zf * fv[:, 1], zf * fv[:, 0]], axis=-1)
            Mt[:, 1 + i] += np.stack([-s * fv[:, 1], s * fv[:, 0]], axis=-1)
            hc = qw[i][:, :2] + arm_w
            S[:, i, js, S_FORCE] = F
            S[:, i, js, S_APPROACH] = de
            S[:, i, js, S_GEOM] = d
            S[:, i, js, S_NX:S_NY + 1] = n
            S[:, i, js, S_PX:S_PY + 1] = hc + (0.5 * (L + fp[:, P_R_PIN] + fp[:, P_R_HOLE]))[:, None] * n
            if tangent:
                dfv = dF[:, None, :] * n[:, :, None] + F[:, None, None] * c["dn"][i][js]
                dfs[:, i, js] = dfv
                darm_w = np.zeros((N, 2, 9))
                darm_w[:, :, 5 + 3 * i] = perp(ph[i])
                darm_f = du.copy()
                darm_f[:, :, 2] += perp(pf)
                dQ[:, 0:2] -= dfv
                dQ[:, 2] -= _dcross(arm_f, darm_f, fv, dfv)
                dQ[:, 3 + 3 * i:5 + 3 * i] += dfv
                dQ[:, 5 + 3 * i] += _dcross(arm_w, darm_w, fv, dfv)
    pin = np.zeros((N, N_PIN_COLS), dtype)
    pin[:, U_X:U_Y + 1] = u
    pin[:, FC0], pin[:, FC1] = c["Fc"]
    pin[:, UP0], pin[:, UP1] = c["up"]
    pin[:, K0], pin[:, K1] = c["K"]
    pin[:, FOPEN0], pin[:, FOPEN1] = c["F0"]
    pin[:, FW0], pin[:, FW1] = FW
    pin[:, N0X:N0Y + 1], pin[:, N1X:N1Y + 1] = c["nw"]
    return {"Q": Q, "dQdq": dQ, "tilt_moments": Mt, "slices": S, "pin": pin,
            "slice_force_tangent": dfs, "sleeve_tangent": du}
