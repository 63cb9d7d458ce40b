"""Anchor (elastic stick--slip) friction law as Warp functions, shared by the
contact-family kernels that carry anchors (cycloid--pin slices, output-pin
slices). Mirrors :mod:`warp_contacts.anchor_ref` (equations, columns and
history flags are documented there).
"""
import functools
import types

import warp as wp

from .anchor_ref import ANCHOR_KT, ANCHOR_MU, ANCHOR_RELEASE, HISTORY_FORMED, HISTORY_KEPT, HISTORY_OPEN
from .planar import planar_funcs


@functools.lru_cache(maxsize=None)
def anchor_funcs(dtype):
    """Warp functions of the anchor law for scalar type ``dtype``."""
    G = planar_funcs(dtype)
    vec2, rot = G.vec2, G.rot

    @wp.func
    def anchor_state(F: dtype, contact: bool, active: int, e: vec2, t: vec2, ap: wp.array2d(dtype=dtype), i: int):
        """(anchored, stick, slip, s, sign(s), F_t) of row i (see anchor_ref.state)."""
        kt = ap[i, ANCHOR_KT]
        s = wp.dot(t, e)
        lim = ap[i, ANCHOR_MU] * F
        anchored = contact and active != HISTORY_OPEN and wp.length(e) <= ap[i, ANCHOR_RELEASE]
        stick = anchored and wp.abs(kt * s) <= lim
        slip = anchored and not stick
        sg = wp.sign(s)
        if s == dtype(0.0):
            sg = dtype(0.0)
        ft = dtype(0.0)
        if stick:
            ft = -kt * s
        if slip:
            ft = -lim * sg
        return anchored, stick, slip, s, sg, ft

    @wp.func
    def anchor_force_tangent(stick: bool, slip: bool, sg: dtype, e: vec2, t: vec2, dF: dtype, dt: vec2, de: vec2,
                             ap: wp.array2d(dtype=dtype), i: int):
        """dF_t along one seed (see anchor_ref.force_tangent)."""
        dft = dtype(0.0)
        if stick:
            dft = -ap[i, ANCHOR_KT] * (wp.dot(dt, e) + wp.dot(t, de))
        if slip:
            dft = -ap[i, ANCHOR_MU] * dF * sg
        return dft

    @wp.func
    def anchor_trial(F: dtype, contact: bool, anchored: bool, slip: bool, s: dtype, sg: dtype, t: vec2, tha: dtype,
                     ha: vec2, hla: vec2, hlb: vec2, form_a: vec2, form_b: vec2, ap: wp.array2d(dtype=dtype),
                     i: int):
        """(flag, anchor_A, anchor_B) of the trial history (see anchor_ref.trial_history)."""
        flag = HISTORY_OPEN
        na = vec2(dtype(0.0), dtype(0.0))
        nb = vec2(dtype(0.0), dtype(0.0))
        if contact:
            if anchored:
                flag = HISTORY_KEPT
                na = hla
                nb = hlb
                if slip:
                    kt = ap[i, ANCHOR_KT]
                    s_lim = dtype(0.0)
                    if kt > dtype(0.0):
                        s_lim = sg * ap[i, ANCHOR_MU] * F / kt
                    na = rot(-tha, ha - (s - s_lim) * t)
            else:
                flag = HISTORY_FORMED
                na = form_a
                nb = form_b
        return flag, na, nb

    return types.SimpleNamespace(anchor_state=anchor_state, anchor_force_tangent=anchor_force_tangent,
                                 anchor_trial=anchor_trial)
