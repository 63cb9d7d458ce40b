"""Admissible load of a design, checked before ``rvtool analyze`` writes anything.

A design can pass every key's own range check and still be unsolvable: e.g. a ``rated_torque``
of 1e6 x the catalogue value on a 100 mm reducer. That is an input error of the load, not a
solver failure: :func:`check_rated_state` solves the rated state (input angle 0) once -- the
state the ``te`` protocol reports its contact forces at, so it is reused, not repeated -- and
raises :class:`~rvtool.errors.RvtoolInputError` naming ``rated_torque`` and its admissible
range when

* the static solver finds no plausible equilibrium there (:class:`~rvtool.errors.SolverFailure`;
  the solver's ladder ends with the guide-spring homotopy of :mod:`rvtool.solver.guide` here for
  every topology, reached only where every other start failed: free play such as a cycloid's
  ``wheels.clearance = 1e-4`` m let the load ramp jump to a periodic copy of the engagement
  at 10 and 140 N m, and a false ``rated_torque <= 44.27 N m`` was reported):
  the range is then bracketed by solving lower torques (decades down, then a few bisection steps
  in log scale) and reported as ``0 < rated_torque <= T_ok``, the largest torque shown to
  equilibrate; or
* the rated state's largest Hertz line-contact peak (``model.hertz_peaks``, where the topology
  provides the local contact geometry) exceeds the contact law's validity: Hertz's half-space
  solution needs the contact half-width b small against the relative radius of curvature R;
  for a line contact b / R = 2 p0 / E* (p0 = sqrt(F' E* / (pi R)), b = 2 sqrt(F' R / (pi E*))),
  and b / R <= :data:`HERTZ_HALF_WIDTH_RATIO` gives p0 <= 0.05 E*. The admissible torque is
  estimated with p0 ~ sqrt(T) (the contact force proportional to the torque at fixed load
  sharing).
"""
import numpy as np

from ..errors import RvtoolInputError, SolverFailure

HERTZ_HALF_WIDTH_RATIO = 0.1
"""Largest contact half-width over relative radius of curvature b / R for which the Hertz
line-contact law is taken as valid (the half-space assumption; b / R = 2 p0 / E*)."""

DECADES_DOWN = 9
"""Decades of torque searched below a failing rated torque for one that equilibrates (a design
with no equilibrium even at 1e-9 x its rated torque is not a load problem)."""

BISECTION_STEPS = 3
"""Log-scale bisection steps between the last equilibrated and the first failing torque (a
factor 10 bracket narrowed to 10^(1/8) = 1.33)."""


def hertz_limit_pressure(design):
    """Largest Hertz peak pressure [Pa] inside the law's validity, p0 <= (b/R)_max E* / 2, for
    contacts of the design's material (E* = E / (2 (1 - nu^2)), both bodies of that material);
    None where the design declares no material."""
    mat = getattr(design, "material", None)
    if mat is None:
        return None
    e_star = mat.youngs_modulus / (2.0 * (1.0 - mat.poisson_ratio ** 2))
    return 0.5 * HERTZ_HALF_WIDTH_RATIO * e_star


def _solve(build, torque):
    """(model, state) at ``torque`` and input angle 0 on a fresh model, or (model, None) where the
    static solver finds no plausible equilibrium."""
    from ..solver.static import StaticSolver
    model = build()
    model.set_output_torque(-np.sign(model.ratio) * torque)
    try:
        return model, StaticSolver(model, guided_fallback=True).solve(0.0)
    except SolverFailure:
        return model, None


def _fmt(x):
    return f"{x:.4g}"


def _hertz_bound(design, model, q, torque):
    """(admissible torque estimate, family, p0 [Pa]) of the family whose Hertz peak at state q (torque
    ``torque``) is the largest against the law's validity, or None where the topology gives no
    Hertz peaks or the design no material."""
    p_lim = hertz_limit_pressure(design)
    peaks = model.hertz_peaks(q) if p_lim is not None else {}
    if not peaks:
        return None
    fam, p0 = max(peaks.items(), key=lambda kv: kv[1])
    return torque * (p_lim / p0) ** 2, fam, p0


PRELOAD_PROBE = 1e-6
"""Fraction of the rated torque at which a design whose rated state is beyond the Hertz validity is
solved once more: a contact family already beyond it there is pressed by the geometry (an
interference), not by the load, and no rated torque is admissible."""


def _eccentricity_hint(design):
    """`` (wheels.eccentricity = e m against profile.generating_eccentricity = e_g m)`` where a
    design's wheels ride a larger eccentric than their profile was generated with, else ""."""
    e = getattr(getattr(design, "wheels", None), "eccentricity", None)
    e_g = getattr(getattr(design, "profile", None), "generating_eccentricity", None)
    if e is None or e_g is None or e <= e_g:
        return ""
    return (f"; e.g. wheels.eccentricity = {_fmt(e)} m exceeds profile.generating_eccentricity = {_fmt(e_g)} m, "
            "which presses the wheels into the pins")


def _check_preload(design, build, rated, family):
    """Raise :class:`RvtoolInputError` naming the geometry where ``family``'s Hertz peak is beyond the
    law's validity already at :data:`PRELOAD_PROBE` x ``rated`` (then p0 ~ sqrt(torque) does not
    hold and no rated torque would do)."""
    small = rated * PRELOAD_PROBE
    m, q = _solve(build, small)
    if q is None:
        return
    p0 = m.hertz_peaks(q).get(family)
    p_lim = hertz_limit_pressure(design)
    if p0 is not None and p_lim is not None and p0 > p_lim:
        raise RvtoolInputError(
            f"the {family} contacts reach a Hertz peak of {_fmt(p0 / 1e9)} GPa already at {_fmt(small)} N m "
            f"({PRELOAD_PROBE:g} x rated_torque), beyond the line-contact law's validity p0 <= {_fmt(p_lim / 1e9)} GPa: "
            f"the geometry, not the load, presses them together (an interference), so no rated_torque is "
            f"admissible; check the eccentricities, clearances and radii against 'rvtool designs --format-doc'"
            f"{_eccentricity_hint(design)}")


def _check_engagement(design, model, q, torque):
    """Raise :class:`RvtoolInputError` naming the geometry where the main mesh carries no load at the
    state q of the largest torque that equilibrates: that torque is held by the solver's
    regularization springs alone, not by the reducer, so it is no admissible rated torque (a
    ``wheels.clearance`` of 10 mm, larger than the mesh can close, said "valid range: 0 < rated_torque
    <= 0.005904 N m")."""
    fam = getattr(model, "main_mesh", None)
    if fam is None or np.any(model.observe(q, fam).normal_force > 0):
        return
    hint = ""
    for sec in ("wheels", "mesh"):      # the uniform mesh clearance of a cycloid / RV or std-involute design
        c = getattr(getattr(design, sec, None), "clearance", None)
        if isinstance(c, (int, float)) and c > 0:
            hint = f"; e.g. {sec}.clearance = {_fmt(c)} m"
    raise RvtoolInputError(
        f"rated_torque = {_fmt(design.rated_torque)} N m: no static equilibrium at the rated state (input angle 0), "
        f"and the main mesh ({getattr(fam, 'value', fam)}) carries no load at {_fmt(torque)} N m, the largest torque "
        "that equilibrates (only the solver's regularization holds it): the geometry does not engage, so no "
        f"rated_torque is admissible; check the clearances and radii against 'rvtool designs --format-doc'{hint}")


def check_rated_state(design, build):
    """Solve ``design``'s rated state with models from ``build()``; returns (model, q) for reuse, or
    raises :class:`RvtoolInputError` naming ``rated_torque`` and its admissible range (see the
    module docstring). Designs without a ``rated_torque`` return (None, None)."""
    rated = getattr(design, "rated_torque", None)
    if rated is None:
        return None, None
    model, q = _solve(build, rated)
    if q is None:
        ok, bad, at_ok = None, rated, None
        for k in range(1, DECADES_DOWN + 1):
            t = rated * 10.0 ** -k
            m, qk = _solve(build, t)
            if qk is not None:
                ok, at_ok = t, (m, qk)
                break
            bad = t
        if ok is None:
            raise RvtoolInputError(
                f"rated_torque = {_fmt(rated)} N m: the design has no static equilibrium at the rated state nor at "
                f"{_fmt(rated * 10.0 ** -DECADES_DOWN)} N m (input angle 0); the geometry, not the load, is "
                "inadmissible: check the clearances and radii against 'rvtool designs --format-doc'")
        for _ in range(BISECTION_STEPS):
            mid = float(np.sqrt(ok * bad))
            m, qm = _solve(build, mid)
            if qm is not None:
                ok, at_ok = mid, (m, qm)
            else:
                bad = mid
        _check_engagement(design, *at_ok, ok)
        limit, why = ok, "the largest torque shown to equilibrate"
        hz = _hertz_bound(design, *at_ok, ok)
        if hz is not None and hz[0] < ok:
            limit, why = hz[0], f"Hertz validity of the {hz[1]} contacts, p0 ~ sqrt(torque)"
        raise RvtoolInputError(
            f"rated_torque = {_fmt(rated)} N m: no static equilibrium at the rated state (input angle 0); the design "
            f"equilibrates at {_fmt(ok)} N m but not at {_fmt(bad)} N m; valid range: 0 < rated_torque <= "
            f"{_fmt(limit)} N m ({why})")
    hz = _hertz_bound(design, model, q, rated)
    if hz is not None and hz[0] < rated:
        t_lim, fam, p0 = hz
        _check_preload(design, build, rated, fam)
        raise RvtoolInputError(
            f"rated_torque = {_fmt(rated)} N m: the {fam} contacts reach a Hertz peak of {_fmt(p0 / 1e9)} GPa at the "
            f"rated state, beyond the line-contact law's validity p0 <= {_fmt(hertz_limit_pressure(design) / 1e9)} "
            f"GPa (contact half-width <= {HERTZ_HALF_WIDTH_RATIO:g} x the radius of curvature); valid range: "
            f"0 < rated_torque <= {_fmt(t_lim)} N m (p0 ~ sqrt(torque))")
    return model, q
