"""Manufacturing variants of a cycloid design and the per-variant figures protocol.

A :class:`Variant` is a set of deviations from a nominal
:class:`~rvtool.assembly.spec.CycloidDesign` (all SI units):

* ``eccentricity_error`` [m]: assembly eccentricity e = e_g + error (the nominal
  generating eccentricity e_g of the profile is unchanged),
* ``pin_centre_errors`` (z_b, 2) [m]: ring-pin centre errors in the housing frame,
* ``pin_radius_error`` [m]: actual pin radius r_p + error (profile generated with r_p),
* ``equidistant_mod`` / ``offset_mod`` [m]: profile modifications added to the design's,
* ``pin_clearance`` [m]: uniform added gap at every pin contact (added to the design's),
* ``bearing_clearance`` [m]: eccentric-bearing radial clearance (replaces the design's).

:meth:`Variant.apply` turns it into a design for
:func:`rvtool.assembly.cycloid.build`; the batched path applies the same deviations to
each copy, so both paths model exactly the same reducer.

:func:`variant_figures` is the per-variant reference protocol of the tolerance Monte
Carlo (issue 8): quasi-static TE over one output revolution at ``n_te_points``
input angles (a prime count, so that the samples fall at spread mesh phases instead
of aliasing onto one) under ``te_torque_fraction`` of the rated torque, the maximum
pin force over those states, and the lost motion at +-3 % of the rated torque from a
short torque continuation (+3 % -> -3 %) at input angle 0.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..units import ARCMIN_PER_RAD, ARCSEC_PER_RAD
from ..assembly.variant import Variant
from ..validation import check_range

__all__ = ["Variant", "VariantProtocol", "variant_figures", "variant_lost_motion"]



@dataclass(frozen=True, kw_only=True)
class VariantProtocol:
    """Per-variant figures: TE over one output revolution at ``n_te_points`` equally spaced
    input angles (prime: spread mesh phases) under ``te_torque_fraction`` x T_rated, maximum
    pin force over those states [N], and lost motion [arcmin] at +-``lost_motion_fraction``
    x T_rated from a continuation +f -> -f at input angle 0 (levels in steps of
    ``lost_motion_step`` x T_rated, so that Newton starts near each level).
    bearing_model: "lumped" or "rolling" (as :func:`rvtool.assembly.cycloid.build`)."""
    n_te_points: int = 401
    te_torque_fraction: float = 1.0
    lost_motion_fraction: float = 0.03
    lost_motion_step: float = 0.01
    bearing_model: str = "lumped"

    def __post_init__(self):
        if not isinstance(self.n_te_points, (int, np.integer)) or self.n_te_points < 3:
            raise RvtoolInputError(f"n_te_points = {self.n_te_points!r} is outside the valid range [3, inf) (integer)")
        check_range("te_torque_fraction", self.te_torque_fraction, 0.0, 2.0)
        check_range("lost_motion_fraction", self.lost_motion_fraction, 0.0, 1.0, low_open=True)
        check_range("lost_motion_step", self.lost_motion_step, 0.0, self.lost_motion_fraction, low_open=True)
        if self.bearing_model not in ("lumped", "rolling"):
            raise RvtoolInputError(f"bearing_model = {self.bearing_model!r}; valid choices are ['lumped', 'rolling']")

    def input_angles(self, design):
        """Input angles [rad] covering one output revolution (endpoint excluded)."""
        n_rev = abs(design.ratio)
        return 2 * np.pi * n_rev * np.arange(self.n_te_points) / self.n_te_points

    def lost_motion_torques(self, design):
        """Torque levels [N m] from +f (reached by a load ramp: loaded states are regular) down
        to -f; lost motion = output angle at +f minus output angle at -f."""
        f, s = self.lost_motion_fraction, self.lost_motion_step
        n = int(np.ceil(f / s - 1e-9))
        return np.linspace(f, -f, 2 * n + 1) * design.rated_torque


def variant_figures(design, variant: Variant, protocol: VariantProtocol = VariantProtocol(), **build_kw):
    """Reference per-variant run (one Exudyn system per variant). Returns a dict with
    ``te_pp_arcsec``, ``te_rms_arcsec``, ``max_pin_force_N``, ``lost_motion_arcmin``,
    ``lost_motion_method`` (see :func:`variant_lost_motion`), ``newton_iterations`` and ``wall_s``."""
    import time

    from ..assembly import build
    from ..solver.static import StaticSolver
    from ..protocols.precision import mesh_forces, quasi_static_te, te_metrics

    t0 = time.perf_counter()
    d = variant.apply(design)
    model = build(d, bearing_model=protocol.bearing_model, **build_kw)
    fmax = [0.0]

    def rec(k, a, q):
        fmax[0] = max(fmax[0], float(np.max(mesh_forces(model, q))))

    solver = StaticSolver(model)
    r = quasi_static_te(model, torque=protocol.te_torque_fraction * d.rated_torque,
                        input_angles=protocol.input_angles(d), solver=solver, record=rec)
    met = te_metrics(r["te"])
    lm = variant_lost_motion(model, d, protocol)
    return {"te_pp_arcsec": met["pp"] * ARCSEC_PER_RAD, "te_rms_arcsec": met["rms"] * ARCSEC_PER_RAD, "max_pin_force_N": fmax[0],
            "lost_motion_arcmin": lm["lost_motion_arcmin"], "lost_motion_method": lm["method"],
            "newton_iterations": int(r["stats"]["newton_iterations"] + lm["newton_iterations"]),
            "wall_s": time.perf_counter() - t0}


def variant_lost_motion(model, design, protocol: VariantProtocol = VariantProtocol(), *, abs_tol=1e-6,
                        rel_tol=1e-9, torque_tol=None):
    """Lost motion of a built variant at input angle 0: theta_out(+f) - theta_out(-f) [arcmin],
    f = ``protocol.lost_motion_fraction`` x T_rated.

    First by the torque continuation +f -> -f (load control, :class:`Continuation`, levels
    ``protocol.lost_motion_torques``); where that fails (a loaded start not found at +f, or a
    stall in the free play, 5 of the first 100 Monte Carlo variants of RD-40) by spring control
    (:func:`rvtool.protocols.lost_motion.lost_motion`), which marches the flange through the
    free play and starts at a larger torque if needed. Both give the same figure where both
    succeed (to 4e-7 arcmin on those 100 variants). Returns ``lost_motion_arcmin``, ``method``
    ("load" or "spring") and ``newton_iterations``; raises :class:`SolverFailure` naming both
    errors if both fail. abs_tol [N], rel_tol [-]: the Newton tolerances of both methods (default
    the static solver's); torque_tol [N m]: the spring control's accepted |T - level| (None: its
    default, 1e-7 x the level)."""
    from ..errors import SolverFailure
    from ..protocols.lost_motion import lost_motion
    from ..solver.continuation import Continuation

    torques = protocol.lost_motion_torques(design)
    i_out = model.output_index
    try:
        cont = Continuation(model, input_angle=0.0, initial_torque=float(torques[0]), abs_tol=abs_tol,
                            rel_tol=rel_tol)
        angles = [cont.q[i_out]] + [cont.go_to(float(t))[i_out] for t in torques[1:]]
        return {"lost_motion_arcmin": float((angles[0] - angles[-1]) * ARCMIN_PER_RAD), "method": "load",
                "newton_iterations": int(cont.static.stats.newton_iterations)}
    except SolverFailure as exc:
        load_error = str(exc)
    model.set_output_torque(0.0)
    try:
        r = lost_motion(model, torque_level=protocol.lost_motion_fraction * design.rated_torque, abs_tol=abs_tol,
                        rel_tol=rel_tol, torque_tol=torque_tol)
    except (SolverFailure, RvtoolInputError) as exc:
        raise SolverFailure(f"lost motion failed under load control ({load_error}) and under spring control "
                            f"({exc})") from None
    return {"lost_motion_arcmin": float(r["lost_motion_rad"] * ARCMIN_PER_RAD), "method": "spring",
            "newton_iterations": int(r["stats"]["newton_iterations"])}
