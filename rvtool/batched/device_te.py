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
"""
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..protocols.precision import te_metrics, transmission_error
from ..solver.device_newton import CONVERGED, DeviceNewton, DeviceNewtonSettings
from ..units import ARCSEC_PER_RAD
from ..variants.variant import Variant
from ..solver.device_copies import copy_parameters

#: default copies per device loop: bounded by memory (RD-40: ~16 kB of contact rows and
#: tangents per copy; 65,536 copies ~ 1 GB on a GPU) and, on the CPU, by cache
DEFAULT_CHUNK = {"cpu": 2048, "cuda": 65536}


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


class _Fallback:
    """The per-variant Exudyn path for single failed (variant, angle) pairs (models cached)."""

    def __init__(self, design, variants, regularization, settings):
        self.design, self.variants, self.reg, self.settings = design, variants, regularization, settings
        self._models = {}

    def solve(self, v, angle, torque, q_guess):
        """(q (3 nb,), solved angle, max pin force) or None."""
        from ..assembly.cycloid import build
        from ..protocols.precision import mesh_forces
        from ..solver.static import StaticSolver
        if v not in self._models:
            m = build(self.variants[v].apply(self.design), bearing_model="lumped", regularization=self.reg)
            idx = np.concatenate([np.asarray(m.mbs.systemData.GetNodeLTGODE2(n), int) for n in m.nodes])
            s = self.settings
            # the per-variant path with its own iteration limit and ladder (not the device budget)
            self._models[v] = (m, StaticSolver(m, abs_tol=s.abs_tol, max_translation=s.max_translation,
                                               max_rotation=s.max_rotation), idx)
        m, solver, idx = self._models[v]
        m.set_output_torque(float(torque))
        solver.q = np.zeros(m.mbs.systemData.ODE2Size())
        solver.q[idx] = q_guess
        try:
            q = solver.solve(float(angle), float(angle))
        except SolverFailure:
            return None
        return q[idx], solver.last_angle, float(np.max(mesh_forces(m, q)))


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
    tq = -np.sign(design.ratio) * (design.rated_torque if torque is None else torque)
    # index 0: the nominal design (warm starts); variants at 1..V
    if params is None:
        params = copy_parameters(design, [Variant()] + variants, regularization=regularization)
    elif len(params.variants) != V + 1:
        raise RvtoolInputError(f"params must hold [Variant()] + variants ({V + 1} copies); got {len(params.variants)}")
    newton = DeviceNewton(params, device=device, settings=settings)
    kind = "cpu" if newton.device == "cpu" else "cuda"
    chunk = int(chunk_pairs or DEFAULT_CHUNK[kind])
    if chunk < 1:
        raise RvtoolInputError(f"chunk_pairs = {chunk_pairs!r} is outside the valid range [1, inf)")
    setup_s = time.perf_counter() - t0

    nom = newton.solve(np.zeros(A, int), angles, np.full(A, tq), params.kinematic(np.zeros(A, int), angles))
    nominal_dev = np.where((nom.status == CONVERGED)[:, None], nom.q - params.kinematic(np.zeros(A, int), angles), 0.0)
    vi = 1 + np.repeat(np.arange(V), A)
    ai = np.tile(np.arange(A), V)
    P = V * A
    q = np.empty((P, params.n))
    status = np.empty(P, int)
    iters = np.empty(P, int)
    forces = np.zeros(P)
    loop_s, sweeps, copy_sweeps = nom.loop_s, nom.sweeps, nom.copy_sweeps
    for s0 in range(0, P, chunk):
        sl = slice(s0, min(P, s0 + chunk))
        guess = params.kinematic(vi[sl], angles[ai[sl]]) + nominal_dev[ai[sl]]
        r = newton.solve(vi[sl], angles[ai[sl]], np.full(sl.stop - sl.start, tq), guess, pin_forces=pin_forces)
        q[sl], status[sl], iters[sl] = r.q, r.status, r.iterations
        loop_s += r.loop_s
        sweeps += r.sweeps
        copy_sweeps += r.copy_sweeps
        if pin_forces:
            nw, zb = params.nb - 2, design.pins.n_pins
            forces[sl] = r.pin_forces.reshape(len(r.q), nw, zb, -1).sum(axis=3).max(axis=(1, 2))
    device_s = time.perf_counter() - t0
    theta_in = angles[ai].copy()
    failed = status != CONVERGED
    n_fallback = int(failed.sum())
    fallback_points = failed.reshape(V, A).sum(axis=1)
    if np.any(failed) and fallback:
        fb = _Fallback(design, variants, regularization, settings)
        for p in np.flatnonzero(failed):
            guess = params.kinematic(vi[p:p + 1], angles[ai[p:p + 1]])[0] + nominal_dev[ai[p]]
            res = fb.solve(vi[p] - 1, angles[ai[p]], tq, guess)
            if res is not None:
                q[p], theta_in[p], forces[p] = res
                failed[p] = False
    q[failed] = np.nan
    forces[failed] = np.nan
    th_in = theta_in.reshape(V, A)
    th_out = q[:, params.output_index].reshape(V, A)
    bad = failed.reshape(V, A).any(axis=1)
    te = np.full((V, A), np.nan)
    pp, rms = np.full(V, np.nan), np.full(V, np.nan)
    for c in np.flatnonzero(~bad):
        te[c] = transmission_error(th_in[c], th_out[c], design.ratio, unwrap=False)
        met = te_metrics(te[c])
        pp[c], rms[c] = met["pp"] * ARCSEC_PER_RAD, met["rms"] * ARCSEC_PER_RAD
    fmax = np.where(bad, np.nan, forces.reshape(V, A).max(axis=1)) if pin_forces else np.full(V, np.nan)
    stats = {"pairs": P, "chunks": -(-P // chunk), "chunk_pairs": chunk,
             "newton_iterations_per_point": float(iters.mean()),
             "sweeps": int(sweeps), "copy_sweeps": int(copy_sweeps), "device_loop_s": loop_s,
             "us_per_copy_iteration": 1e6 * loop_s / max(copy_sweeps, 1),
             "fallback_copies": n_fallback, "failed_copies": int(failed.sum()), "failed_variants": int(bad.sum()),
             "nominal_failed_points": int(np.sum(nom.status != CONVERGED)),
             "path": newton.last_path, "device": newton.device, "setup_s": setup_s,
             "device_s": device_s, "wall_s": time.perf_counter() - t0}
    return DeviceTE(theta_in=th_in, theta_out=th_out, te=te, te_pp_arcsec=pp, te_rms_arcsec=rms, max_pin_force_N=fmax,
                    status=["failed" if b else "ok" for b in bad], iterations=iters.reshape(V, A).sum(axis=1),
                    fallback_points=fallback_points, stats=stats)
