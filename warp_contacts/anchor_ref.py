"""NumPy reference of the anchor (elastic stick--slip) friction law shared by the
reducer contact families (readable version of :mod:`warp_contacts.anchor`).

Paper, Eq. (friction) and the anchor model: the tangential elastic
displacement is stored as two material points, one per body, in body-fixed
coordinates (the committed history z_n). Their separation
e = (x_A + R_A h_A) - (x_B + R_B h_B) along the contact tangent t gives the
trial force on body A

    stick:  F_t = -k_t s,               s = t . e,   |k_t s| <= mu F_n
    slip:   F_t = -mu F_n sign(s),      the A anchor projected so that
                                        k_t |s_new| = mu F_n,

and its analytic tangent per seed direction
dF_t = -k_t (dt . e + t . de) in stick, -mu dF_n sign(s) in slip (the
friction bound moves with the normal force).

History (Section "History ownership, retries, and acceptance"): every trial
reads the committed anchors only and returns a trial history
(flag, anchor_A, anchor_B) that the family's evaluator commits once per
accepted step. The flag is HISTORY_OPEN (no anchor: the contact is open),
HISTORY_KEPT (the committed anchor, kept in stick or projected in slip) or
HISTORY_FORMED (a new anchor at the current material contact points: the
first closed evaluation, or a release). A committed anchor is released when
its separation |e| exceeds the release distance d_rel: the contact point has
migrated (a pin passing to the next lobe region, a slice leaving and
re-entering contact within one step) and the old material points no longer
face each other. A released or newly formed anchor carries no force in that
evaluation (no phantom force from material points that do not touch) and
starts at zero separation; only kept anchors add to the slip distance.
"""
import numpy as np

from .planar_ref import dot, rot

# ---- packed anchor parameters (one row per contact row; named here once, used by the Warp
# functions of warp_contacts.anchor, this reference and the packers; SI units) ----
ANCHOR_KT = 0        # tangential (anchor) stiffness k_t [N/m]
ANCHOR_MU = 1        # friction coefficient mu of the bound mu F_n [-]
ANCHOR_RELEASE = 2   # release distance d_rel of the anchor separation [m]
N_ANCHOR = 3

# ---- trial/committed history flags ----
HISTORY_OPEN, HISTORY_KEPT, HISTORY_FORMED = 0, 1, 2


def anchor_separation(xa, tha, xb, thb, hist_a, hist_b):
    """World anchor arms (R_A h_A, R_B h_B) and their separation e (N, 2) [m]."""
    ha = rot(tha, np.asarray(hist_a, np.float64))
    hb = rot(thb, np.asarray(hist_b, np.float64))
    return ha, hb, (xa + ha) - (xb + hb)


def state(F, contact, hist_active, e, t, ap):
    """Branch of every row: (anchored, stick, slip, s = t.e, sign(s), F_t).

    F: normal force [N]; contact: geometric contact (indentation > 0); hist_active:
    committed flags; e: anchor separation [m]; t: unit tangent; ap: (N, N_ANCHOR).
    """
    kt, mu, drel = ap[:, ANCHOR_KT], ap[:, ANCHOR_MU], ap[:, ANCHOR_RELEASE]
    s = dot(t, e)
    lim = mu * F
    anchored = contact & (np.asarray(hist_active) != HISTORY_OPEN) & (np.linalg.norm(e, axis=-1) <= drel)
    stick = anchored & (np.abs(kt * s) <= lim)
    slip = anchored & ~stick
    sg = np.sign(s)
    ft = np.where(stick, -kt * s, np.where(slip, -lim * sg, 0.0))
    return anchored, stick, slip, s, sg, ft


def force_tangent(stick, slip, sg, e, t, dF, dt, de, ap):
    """dF_t along one seed: dt, de are (N, 2) seed derivatives of t and e, dF of F_n."""
    dst = dot(dt, e) + dot(t, de)
    return np.where(stick, -ap[:, ANCHOR_KT] * dst, np.where(slip, -ap[:, ANCHOR_MU] * dF * sg, 0.0))


def trial_history(F, contact, anchored, slip, s, sg, t, tha, thb, ha, hb, hist_a, hist_b, form_a, form_b, ap):
    """Trial history (flags, anchor_A, anchor_B in body coordinates) of every row.

    form_a, form_b: the current material contact points in body coordinates, where a new
    anchor forms. On slip the A anchor moves along t by s - s_lim with k_t s_lim = mu F_n sign(s).
    """
    kt = ap[:, ANCHOR_KT]
    s_lim = np.where(kt > 0, sg * ap[:, ANCHOR_MU] * F / np.where(kt > 0, kt, 1.0), 0.0)
    projected = rot(-tha, ha - (s - s_lim)[:, None] * t)
    a = np.where(slip[:, None], projected, np.asarray(hist_a, np.float64))
    a = np.where(anchored[:, None], a, form_a)
    b = np.where(anchored[:, None], np.asarray(hist_b, np.float64), form_b)
    flag = np.where(contact, np.where(anchored, HISTORY_KEPT, HISTORY_FORMED), HISTORY_OPEN).astype(np.int32)
    a = np.where(contact[:, None], a, 0.0)
    b = np.where(contact[:, None], b, 0.0)
    return flag, a, b


def slip_increment(hist_active, trial_flag, hist_a, trial_a):
    """Sliding distance [m] of an accepted step per row: the A anchor's projection shift of a
    kept anchor (zero for formed, released or open anchors)."""
    kept = (np.asarray(hist_active) != HISTORY_OPEN) & (np.asarray(trial_flag) == HISTORY_KEPT)
    return np.where(kept, np.linalg.norm(np.asarray(trial_a) - np.asarray(hist_a), axis=-1), 0.0)
