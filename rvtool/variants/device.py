"""The per-variant figures protocol with the quasi-static TE on the device Newton.

:func:`device_variant_figures` returns, for all variants at once, the figures of
:func:`rvtool.variants.variant_figures`: the TE at ``protocol.n_te_points`` input angles
under ``te_torque_fraction`` x the rated torque and the maximum pin force over those states
from :func:`rvtool.batched.device_te.device_te` (every (variant, angle) pair one copy of
the device Newton; failed copies on the per-variant Exudyn path), and the lost motion per
variant on its own model by :func:`rvtool.variants.variant_lost_motion` (a continuation
through the free play: a sequence of dependent solves, which the batch over independent
equilibria does not cover). Each record names the TE path that ran (``te_path``) and how
many of the variant's TE points fell back to Exudyn (``te_fallback_points``).
"""
import time

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from .variant import VariantProtocol, variant_lost_motion


def device_variant_figures(design, variants, protocol: VariantProtocol = VariantProtocol(), *, device="cpu",
                           regularization=(100.0, 0.1), settings=None):
    """Figures of ``variants`` (see the module docstring); one dict per variant with the keys of
    ``variant_figures`` plus ``status`` ("ok"/"failed"), ``error``, ``te_path`` and
    ``te_fallback_points``. ``newton_iterations`` counts the variant's device Newton iterations
    over its TE points plus those of its lost motion."""
    from ..assembly.cycloid import build
    from ..batched.device_te import device_te
    from ..solver.device_newton import DeviceNewtonSettings
    if protocol.bearing_model != "lumped":
        raise RvtoolInputError(f"protocol.bearing_model = {protocol.bearing_model!r}; the device Newton supports "
                               f"['lumped']")
    t0 = time.perf_counter()
    variants = list(variants)
    angles = protocol.input_angles(design)
    te = device_te(design, variants, angles, torque=protocol.te_torque_fraction * design.rated_torque,
                   regularization=regularization, device=device, settings=settings or DeviceNewtonSettings())
    path = f"device_newton:{te.stats['device']}:{te.stats['path']}"
    out = []
    for c, v in enumerate(variants):
        rec = {"te_pp_arcsec": te.te_pp_arcsec[c], "te_rms_arcsec": te.te_rms_arcsec[c],
               "max_pin_force_N": te.max_pin_force_N[c], "te_path": path,
               "te_fallback_points": int(te.fallback_points[c]), "status": te.status[c], "error": None,
               "newton_iterations": int(te.iterations[c])}
        if rec["status"] != "ok":
            rec.update(lost_motion_arcmin=np.nan, lost_motion_method=None,
                       error="no plausible TE equilibrium (device Newton, homotopy and per-variant path failed)")
            out.append(rec)
            continue
        d = v.apply(design)
        try:
            lm = variant_lost_motion(build(d, bearing_model="lumped", regularization=regularization), d, protocol)
        except SolverFailure as exc:
            rec.update(status="failed", error=f"SolverFailure: {exc}", lost_motion_arcmin=np.nan,
                       lost_motion_method=None)
            out.append(rec)
            continue
        rec.update(lost_motion_arcmin=lm["lost_motion_arcmin"], lost_motion_method=lm["method"],
                   newton_iterations=rec["newton_iterations"] + int(lm["newton_iterations"]))
        out.append(rec)
    wall = time.perf_counter() - t0
    for rec in out:
        rec["wall_s"] = wall / len(out)
    return out
