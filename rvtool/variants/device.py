"""The per-variant figures protocol on the device Newton: TE and lost motion of all variants at once.

:func:`device_variant_figures` returns, for all variants at once, the figures of
:func:`rvtool.variants.variant_figures`: the TE at ``protocol.n_te_points`` input angles
under ``te_torque_fraction`` x the rated torque and the maximum pin force over those states
from :func:`rvtool.batched.device_te.device_te` (every (variant, angle) pair one copy of
the device Newton; failed copies on the per-variant Exudyn path), and the lost motion from
:func:`rvtool.batched.device_lost_motion.device_lost_motion` (the load continuation +f -> -f
of all variants together, one device solve per round; copies that fail there run
:func:`rvtool.variants.variant_lost_motion` on their own Exudyn model). Both share one set
of per-copy parameters. ``lost_motion="exudyn"`` keeps the earlier path (lost motion per
variant on Exudyn). Each record names the TE path (``te_path``), how many of the variant's TE
points fell back to Exudyn (``te_fallback_points``), the path of its lost motion
(``lost_motion_path``: the device path, or "exudyn" for a fallback or the earlier path) and
whether it fell back (``lost_motion_fallback``).
"""
import time

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from .variant import VariantProtocol, variant_lost_motion

LOST_MOTION_PATHS = ("device", "exudyn")


def device_variant_figures(design, variants, protocol: VariantProtocol = VariantProtocol(), *, device="cpu",
                           regularization=(100.0, 0.1), settings=None, lost_motion="device",
                           lost_motion_settings=None, executor=None):
    """Figures of ``variants`` (see the module docstring); one dict per variant with the keys of
    ``variant_figures`` plus ``status`` ("ok"/"failed"), ``error``, ``te_path``,
    ``te_fallback_points``, ``lost_motion_path`` and ``lost_motion_fallback``.
    ``newton_iterations`` counts the variant's device Newton iterations over its TE points plus
    those of its lost motion. settings: :class:`DeviceNewtonSettings` of the TE;
    lost_motion_settings: those of the lost motion (default
    :data:`rvtool.batched.device_lost_motion.LOST_MOTION_NEWTON`). executor: a
    ``concurrent.futures.Executor`` for the host work beside the device (the per-copy parameters
    in shares, the lost-motion Exudyn fallbacks), e.g. a process pool on a GPU host; None: all
    in this process."""
    from ..assembly.cycloid import build
    from ..solver.device_copies import nominal_copy_parameters
    from ..batched.device_lost_motion import LOST_MOTION_NEWTON, device_lost_motion
    from ..batched.device_te import device_te
    from ..solver.device_newton import DeviceNewtonSettings
    if protocol.bearing_model != "lumped":
        raise RvtoolInputError(f"protocol.bearing_model = {protocol.bearing_model!r}; the device Newton supports "
                               f"['lumped']")
    if lost_motion not in LOST_MOTION_PATHS:
        raise RvtoolInputError(f"lost_motion = {lost_motion!r}; valid choices are {list(LOST_MOTION_PATHS)}")
    t0 = time.perf_counter()
    variants = list(variants)
    params = nominal_copy_parameters(design, variants, regularization=regularization, executor=executor)
    angles = protocol.input_angles(design)
    te = device_te(design, variants, angles, torque=protocol.te_torque_fraction * design.rated_torque,
                   regularization=regularization, device=device, settings=settings or DeviceNewtonSettings(),
                   params=params)
    path = f"device_newton:{te.stats['device']}:{te.stats['path']}"
    ok = [c for c in range(len(variants)) if te.status[c] == "ok"]
    lm = None
    if lost_motion == "device" and ok:
        lm = device_lost_motion(design, variants, protocol, regularization=regularization, device=device,
                                settings=lost_motion_settings or LOST_MOTION_NEWTON, params=params, copies=ok,
                                executor=executor)
        lm_path = f"device_newton:{lm.stats['device']}:{lm.stats['path']}"
    out = []
    for c, v in enumerate(variants):
        rec = {"te_pp_arcsec": te.te_pp_arcsec[c], "te_rms_arcsec": te.te_rms_arcsec[c],
               "max_pin_force_N": te.max_pin_force_N[c], "te_path": path,
               "te_fallback_points": int(te.fallback_points[c]), "status": te.status[c], "error": None,
               "newton_iterations": int(te.iterations[c]), "lost_motion_path": None, "lost_motion_fallback": None}
        if rec["status"] != "ok":
            rec.update(lost_motion_arcmin=np.nan, lost_motion_method=None,
                       error="no plausible TE equilibrium (device Newton, homotopy and per-variant path failed)")
            out.append(rec)
            continue
        if lm is not None:
            fell_back = lm.path[c] == "exudyn"
            rec.update(lost_motion_arcmin=lm.lost_motion_arcmin[c], lost_motion_method=lm.method[c],
                       lost_motion_path="exudyn" if fell_back else lm_path, lost_motion_fallback=fell_back,
                       newton_iterations=rec["newton_iterations"] + int(lm.iterations[c]))
            if lm.status[c] != "ok":
                rec.update(status="failed", error=f"SolverFailure: {lm.error[c]}", lost_motion_method=None)
            out.append(rec)
            continue
        d = v.apply(design)
        try:
            r = variant_lost_motion(build(d, bearing_model="lumped", regularization=regularization), d, protocol)
        except SolverFailure as exc:
            rec.update(status="failed", error=f"SolverFailure: {exc}", lost_motion_arcmin=np.nan,
                       lost_motion_method=None, lost_motion_path="exudyn", lost_motion_fallback=False)
            out.append(rec)
            continue
        rec.update(lost_motion_arcmin=r["lost_motion_arcmin"], lost_motion_method=r["method"],
                   lost_motion_path="exudyn", lost_motion_fallback=False,
                   newton_iterations=rec["newton_iterations"] + int(r["newton_iterations"]))
        out.append(rec)
    wall = time.perf_counter() - t0
    for rec in out:
        rec["wall_s"] = wall / len(out)
    return out
