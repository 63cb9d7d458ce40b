"""The per-variant figures protocol on a batch of copies.

:func:`batched_variant_figures` is :func:`rvtool.variants.variant_figures` for all
variants at once: TE at ``protocol.n_te_points`` input angles under the rated torque,
the maximum pin force over those states and the lost motion, per variant on its own model
(default) or by the torque continuation +f -> -f at input angle 0 with the adaptive
increments of :class:`rvtool.protocols.stiffness.Continuation`, kept per copy (each copy has
its own output load, so copies continue at their own increments in the same solves).
"""
import time

import numpy as np

from ..protocols.precision import batch_te
from ..units import ARCMIN_PER_RAD
from .variant import VariantProtocol
from ..batched.assembly import build_batched
from ..solver.batched import BatchedStaticSolver


def _try_split(solver, q, t_now, target, mask, max_step):
    """Try the torque increments ``target`` for the copies in ``mask`` (the others parked at their
    accepted equilibrium q, torque t_now: Newton leaves them in place). Exudyn's Newton fails for
    the whole batch when one copy fails (and restores the start state), so a failed batch is split
    in halves until the failing copies are isolated (log2 B extra solves per failing copy).
    Accepted copies are written into q; returns the accepted mask."""
    solver.set_torques(np.where(mask, target, t_now))
    solver.park(~mask)
    try:
        ok, qn = solver.newton(q)
    finally:
        solver.park(None)
    if ok:
        acc = mask & np.all(np.isfinite(qn), axis=1) & (np.max(np.abs(qn - q), axis=1) <= max_step)
        q[acc] = qn[acc]
        return acc
    idx = np.flatnonzero(mask)
    if len(idx) == 1:
        return np.zeros_like(mask)
    lo, hi = np.zeros_like(mask), np.zeros_like(mask)
    lo[idx[:len(idx) // 2]] = True
    hi[idx[len(idx) // 2:]] = True
    return _try_split(solver, q, t_now, target, lo, max_step) | _try_split(solver, q, t_now, target, hi, max_step)


def _continuation(solver, torques, max_step=2e-3, min_increment=1e-4):
    """Per-copy torque continuation at the current angle through the levels ``torques``
    (B, L) [N m], as :class:`rvtool.protocols.stiffness.Continuation` (start: Newton from
    the kinematic state, else the solver's ladder; increments halved on failure or on a
    step above ``max_step``, doubled after success). Returns the flange rotations (B, L) [rad]."""
    m = solver.model
    B, L = torques.shape
    i_out = 3 * (m.nb - 1) + 2
    solver.set_torques(torques[:, 0])
    solver.set_angle(solver.angle)
    ok, qn = solver.newton(solver.kin)
    good = solver.converged(ok, qn) & solver.plausible(qn) & ~solver.dead
    q = np.where(good[:, None], qn, solver.kin)
    q, good = solver.complete(q, good, None)
    solver.qc = q
    out = np.full((B, L), np.nan)
    out[:, 0] = q[:, i_out]
    t_now = torques[:, 0].copy()
    for j in range(1, L):
        level = torques[:, j]
        inc = level - t_now
        while True:
            active = (t_now != level) & ~solver.dead
            if not np.any(active):
                break
            target = np.where(np.abs(level - t_now) <= np.abs(inc), level, t_now + inc)
            acc = _try_split(solver, q, t_now, target, active, max_step)
            rej = active & ~acc
            grow = np.abs(inc) < np.abs(level - target)
            t_now = np.where(acc, target, t_now)
            inc = np.where(acc & grow, 2 * inc, np.where(rej, 0.5 * inc, inc))
            stalled = rej & (np.abs(inc) < min_increment)
            if np.any(stalled):
                solver.dead |= stalled
                solver.stats.failed_copies += int(stalled.sum())
                solver._set_factors(np.where(solver.dead, 1e6, 1.0))
                solver.park(None)
                q[stalled] = solver.kin[stalled]
        out[:, j] = q[:, i_out]
    solver.qc = q
    out[solver.dead] = np.nan
    return out


def _lost_motion_fallback(design, variant, protocol, regularization):
    """(lost motion [arcmin], method, None) of one variant by :func:`variant_lost_motion` on its
    own model (load control, then spring control), or (NaN, None, error) if both fail."""
    from ..assembly import build
    from ..errors import SolverFailure
    from .variant import variant_lost_motion
    d = variant.apply(design)
    model = build(d, bearing_model="lumped", regularization=regularization)
    try:
        r = variant_lost_motion(model, d, protocol)
    except SolverFailure as exc:
        return np.nan, None, f"SolverFailure: {exc}"
    return r["lost_motion_arcmin"], r["method"], None


def batched_variant_figures(design, variants, protocol: VariantProtocol = VariantProtocol(), *, device="cpu",
                            backend="warp", return_model=False, inject_nan=None,
                            regularization=(100.0, 0.1), lost_motion="per_variant"):
    """:func:`rvtool.variants.variant_figures` for all ``variants`` in one Exudyn system.

    Returns one dict per variant with the keys of ``variant_figures`` (``te_pp_arcsec``,
    ``te_rms_arcsec``, ``max_pin_force_N``, ``lost_motion_arcmin``, ``newton_iterations``
    (of the shared batch solves), ``wall_s`` (batch wall time / B)) plus ``status``
    ("ok" or "failed": figures NaN), ``error`` and ``q_te`` ((n_te_points, 3 nb) equilibrium
    coordinates of the copy, body-major x, y, theta). With ``return_model=True`` returns
    (list, model, solver). inject_nan: {copy: evaluation counters} fault injection (tests).
    regularization: builder regularization springs (translational [N/m], rotational [N m/rad]),
    passed to the batched build and to the solver's per-variant fallback so both model the same
    reducer as ``variant_figures(..., regularization=...)``.
    lost_motion: "per_variant" (default): each copy's lost motion on its own model by
    :func:`rvtool.variants.variant_lost_motion` (load control, spring control where it fails);
    "batched": the per-copy torque continuation in the shared system (:func:`_continuation`),
    with the per-variant path for copies whose continuation stalls. The same figures either way
    (tested); per-variant is the faster on RD-40 (16 Monte Carlo variants, 53 TE points: 4.6 s
    against 14.2 s, because a batch continuation solve costs the whole system and a failed one is
    bisected to isolate its copy, while most per-variant continuations take a few Newton steps).
    """
    if lost_motion not in ("per_variant", "batched"):
        from ..errors import RvtoolInputError
        raise RvtoolInputError(f"lost_motion = {lost_motion!r}; valid choices are ['per_variant', 'batched']")
    t0 = time.perf_counter()
    variants = list(variants)
    if protocol.bearing_model != "lumped":
        from ..errors import RvtoolInputError
        raise RvtoolInputError(f"protocol.bearing_model = {protocol.bearing_model!r}; the batched path supports ['lumped']")
    model = build_batched(design, variants, device=device, backend=backend, regularization=regularization)
    if inject_nan:
        model.evaluator.inject_nan = {int(c): set(v) for c, v in inject_nan.items()}
    B = model.n_copies
    designs = [m.design for m in model.copies]
    solver = BatchedStaticSolver(model, build_kw={"regularization": regularization})
    ratio = np.array([d.ratio for d in designs])
    solver.set_torques(-np.sign(ratio) * protocol.te_torque_fraction * np.array([d.rated_torque for d in designs]))
    i_out = 3 * (model.nb - 1) + 2
    ref_out = np.array([m.reference[-1, 2] for m in model.copies])
    angles = protocol.input_angles(design)
    th_out, fmax, q_te = [], np.zeros(B), []
    prev = None
    for a in angles:
        q = solver.solve(a, prev)
        prev = a
        th_out.append(ref_out + q[:, i_out])
        fmax = np.maximum(fmax, np.where(solver.dead, np.nan, solver.pin_forces(q)))
        q_te.append(q)
    th_out = np.array(th_out)
    q_te = np.array(q_te)
    dead_te = solver.dead.copy()
    if lost_motion == "batched":
        tq = np.array([protocol.lost_motion_torques(d) for d in designs])
        solver.set_angle(0.0)
        lm_angles = _continuation(solver, tq)
        lm = (lm_angles[:, 0] - lm_angles[:, -1]) * ARCMIN_PER_RAD
        redo = solver.dead & ~dead_te
    else:
        lm = np.full(B, np.nan)
        redo = ~dead_te
    method = np.where(np.isfinite(lm), "load", None).astype(object)
    error = {int(c): "no plausible equilibrium (batch, homotopy and per-variant path failed)"
             for c in np.flatnonzero(dead_te)}
    for c in np.flatnonzero(redo):
        # every copy with a TE (per_variant), or one whose batched continuation stalled: the lost
        # motion of the per-variant path on the copy's own model, as in variant_figures
        lm[c], method[c], err = _lost_motion_fallback(design, variants[c], protocol, regularization)
        if err is not None:
            error[int(c)] = err
    wall = time.perf_counter() - t0
    out = []
    for c in range(B):
        if c in error:
            out.append({"te_pp_arcsec": np.nan, "te_rms_arcsec": np.nan, "max_pin_force_N": np.nan,
                        "lost_motion_arcmin": np.nan, "lost_motion_method": None,
                        "newton_iterations": solver.stats.newton_iterations, "wall_s": wall / B,
                        "status": "failed", "error": error[c], "q_te": q_te[:, c]})
            continue
        te = batch_te(angles, th_out[:, c], ratio[c])
        out.append({"te_pp_arcsec": float(te["pp_arcsec"][0]), "te_rms_arcsec": float(te["rms_arcsec"][0]),
                    "max_pin_force_N": float(fmax[c]),
                    "lost_motion_arcmin": float(lm[c]), "lost_motion_method": method[c],
                    "newton_iterations": solver.stats.newton_iterations, "wall_s": wall / B,
                    "status": "ok", "error": None, "q_te": q_te[:, c]})
    return (out, model, solver) if return_model else out
