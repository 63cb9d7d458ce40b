"""Quasi-static TE of many variants with the device Newton: one batch over (variant x input angle).

The quasi-static TE of :func:`rvtool.protocols.precision.quasi_static_te` under a constant
torque is a set of independent equilibria, one per input angle; the sequential path
warm-starts each from the previous angle only to be near it. Here every (variant, angle)
pair is one copy of :class:`rvtool.solver.device_newton.DeviceNewton`, all solved in one
device loop (in chunks of ``chunk_pairs`` copies), each warm-started from the NOMINAL
design's equilibrium at the same angle (its elastic deviation from the kinematic state
added to the variant's kinematic state): micrometre tolerances move the equilibrium by
micrometres, far less than the 4.6 rad of input angle between two TE points.

1. Nominal equilibria at the angles: device Newton from the kinematic state (homotopy on
   failure); a nominal point that still fails starts its pairs from the kinematic state.
2. All pairs in chunks; a copy that fails its warm start runs the regularization homotopy
   on the device (per-copy factor).
3. Copies that still fail go to the per-variant Exudyn path (:class:`StaticSolver` with its
   whole ladder, on :func:`rvtool.assembly.cycloid.build` of that variant, warm-started
   from the same guess): counted in ``fallback_copies``; if that fails too the variant's
   figures are NaN and its status "failed".

The TE per variant is Eq. (obs_te) over its angles (the solved angle of a fallback point
shifted off an activation kink by StaticSolver is recorded, as in the sequential path).
The equilibria are the device backend's (:meth:`rvtool.solver.backends.DeviceBackend.solve_variants`),
the TE the protocol's (:func:`rvtool.protocols.precision.batch_te`).
"""
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import RvtoolInputError
from ..protocols.precision import batch_te
from ..solver.backends import DeviceBackend, EquilibriumBatch
from ..solver.backends.device import DEFAULT_CHUNK  # noqa: F401  (the chunk sizes, documented here before)
from ..solver.device_newton import DeviceNewtonSettings


@dataclass
class DeviceTE:
    """Per-variant results of :func:`device_te` (V variants, A angles): solved input angles and
    flange rotations (V, A) [rad], TE (V, A) [rad], TE peak-to-peak and RMS [arcsec] and max pin
    force over the TE states [N] (V,) (NaN: failed), status per variant ("ok"/"failed"), device
    Newton iterations and points that fell back to Exudyn per variant (V,), and
    ``stats`` (pairs, Newton iterations per point, device loop sweeps and wall time, us per
    copy iteration, fallback and failed copies, the loop path)."""
    theta_in: np.ndarray
    theta_out: np.ndarray
    te: np.ndarray
    te_pp_arcsec: np.ndarray
    te_rms_arcsec: np.ndarray
    max_pin_force_N: np.ndarray
    status: list
    iterations: np.ndarray
    fallback_points: np.ndarray
    stats: dict = field(default_factory=dict)


def device_te(design, variants, angles, *, torque=None, regularization=(1e4, 100.0), device="cpu",
              settings: DeviceNewtonSettings = DeviceNewtonSettings(), chunk_pairs=None, fallback=True,
              pin_forces=True, params=None):
    """Quasi-static TE of ``variants`` of ``design`` at ``angles`` [rad] under ``torque`` [N m]
    (default: the rated torque, resisting the output rotation as in ``quasi_static_te``) with
    the device Newton on ``device``; see the module docstring. params: the
    :class:`CopyParameters` of ``[Variant()] + variants`` with this ``regularization`` to reuse
    (shared with the lost motion of the same variants); built here if None. Returns a
    :class:`DeviceTE`."""
    t0 = time.perf_counter()
    variants = list(variants)
    angles = np.asarray(angles, float)
    V, A = len(variants), len(angles)
    if V < 1 or A < 1:
        raise RvtoolInputError(f"device_te needs at least one variant and one angle; got {V} and {A}")
    batch = EquilibriumBatch(input_angles=angles, torque=design.rated_torque if torque is None else torque)
    eq = DeviceBackend(device=device, settings=settings).solve_variants(
        design, variants, batch, regularization=regularization, chunk_pairs=chunk_pairs, fallback=fallback,
        pin_forces=pin_forces, params=params)
    bad = eq.failed.any(axis=1)
    te = batch_te(eq.theta_in, eq.theta_out, design.ratio, bad)
    fmax = np.where(bad, np.nan, eq.pin_force.max(axis=1)) if pin_forces else np.full(V, np.nan)
    stats = dict(eq.stats, failed_variants=int(bad.sum()), wall_s=time.perf_counter() - t0)
    return DeviceTE(theta_in=eq.theta_in, theta_out=eq.theta_out, te=te["te"], te_pp_arcsec=te["pp_arcsec"],
                    te_rms_arcsec=te["rms_arcsec"], max_pin_force_N=fmax, status=["failed" if b else "ok" for b in bad],
                    iterations=eq.iterations.sum(axis=1), fallback_points=eq.fallback_points, stats=stats)
