"""RV manufacturing tolerances: declared distributions and seeded sampling of RV design variants
(a variant is a design: the deviations are written into the design's own sections).

Fields (SI units; distributions and their TOML form as :mod:`rvtool.variants.tolerances`):

* ``crank_phase_error`` [arcmin]: eccentric phase error of each crank (one draw per crank,
  ``cranks.phase_errors_deg``),
* ``crank_eccentricity_error`` [m]: e_k - e of each crank (one draw per crank,
  ``cranks.eccentricity_errors``),
* ``pin_radius_error`` [m]: actual minus nominal pin radius, one value per reducer (``pins.radius_error``),
* ``needle_clearance`` [m]: radial clearance of the needle sets (one value per reducer,
  ``eccentric_bearing.radial_clearance``; support must be non-negative),
* ``sun_pitch_deviation`` [m]: single pitch deviations f_pt of the sun gear (one draw per tooth,
  minus their mean so that they close the circle; ``sun_gear.single_pitch_deviations``),
* ``crank_gear_pitch_deviation`` [m]: single pitch deviations f_pt of each crank's spur gear (one
  draw per tooth and crank, each crank's minus its mean; ``cranks.gear_pitch_deviations``). Drawn
  after the fields above, so that adding it left their draws of a seed unchanged.
* ``pin_pitch_deviation`` [m]: single pitch deviations of the ring pins' seats in the housing, along the
  pin circle (one draw per pin, minus their mean so that they close the circle). Pin k's position deviation
  is the accumulated pitch deviation (the cumulative sum, minus its mean: no rigid rotation of the ring),
  along the pin circle's tangent (``pins.centre_errors``, added to the design's). Drawn last (after
  ``crank_gear_pitch_deviation``), so that adding it left the other fields' draws of a seed unchanged.

Position and profile fields (issue 30, Deliver 3), drawn after ``pin_pitch_deviation`` in this order, so that
adding them left the fields above drawn the same for a seed. A position tolerance (ISO 1101) of diameter t
confines a centre to a circle of radius t / 2; a file states it as the distribution of each coordinate of the
deviation (e.g. normal with std = t / 6, so that 99 % of the centres fall in the zone):

* ``pin_radial_position_error`` [m]: radial deviation of each ring pin's seat from the pin circle (one draw per
  pin, outward positive; the tangential part is ``pin_pitch_deviation``'s), added to ``pins.centre_errors``,
* ``wheel_bore_position_error`` [m]: the x and y deviation of crank k's bore in wheel j from its true position
  (one draw per coordinate, crank and wheel; ``cranks.wheel_bore_errors``, wheel frame),
* ``carrier_bore_position_error`` [m]: the x and y deviation of crank k's bearing seat in the carrier (one draw
  per coordinate and crank; ``cranks.carrier_bore_errors``, carrier frame),
* ``profile_equidistant_error`` [m]: the ground wheel profile's equidistant deviation, one value per reducer
  (both wheels ground alike), added to ``profile.equidistant_mod`` (positive removes material),
* ``profile_offset_error`` [m]: the ground profile's offset (pin-circle radius) deviation, one value per
  reducer, added to ``profile.offset_mod``.
* ``wheel_lobe_pitch_deviation`` [m]: single pitch deviations of the lobes of each cycloid wheel (one draw per
  lobe and wheel, each wheel's minus its mean so that they close the circle; ``wheels.lobe_pitch_deviations``,
  on the wheel's reference circle of radius R_z z_g / z_b): lobe j turns about the wheel centre by its
  accumulated pitch deviation (:func:`rvtool.geometry.cycloid.lobe_pitch_rotations`). Drawn last (after
  ``profile_offset_error``), so that adding it left the other fields' draws of a seed unchanged.

The two sources of Yang et al.'s (2021) list the fields above lacked (issue 30, Deliver 3, helper tecoax), drawn
last in this order, so that adding them left every field above drawn the same for a seed:

* ``pin_circle_coaxiality_error`` [m]: the x and y of the pin circle's centre off the main-bearing (carrier) axis
  (one draw per coordinate and reducer): one translation common to every ring-pin seat, fixed in the housing
  frame, added to ``pins.centre_errors`` (:func:`coaxial_centre_errors`),
* ``sun_runout`` [m]: the x and y of the sun's pitch-circle eccentricity (one draw per coordinate and reducer),
  written onto ``sun_gear.single_pitch_deviations`` (added) as the first differences of the once-around
  accumulated pitch it gives (:func:`runout_pitch_deviations`),
* ``crank_gear_runout`` [m]: the same for each crank's spur gear (one draw per coordinate and crank), added to
  ``cranks.gear_pitch_deviations``.

Variant k draws from ``numpy.random.default_rng([seed, k])`` in the order of :data:`RV_FIELDS`.
"""
from dataclasses import dataclass

import numpy as np

from ..designs.tolerance_keys import RV_TOLERANCE_KEYS
from ..errors import RvtoolInputError
from .tolerances import check_design_distributions, load_design_tolerances

RV_FIELDS = tuple(RV_TOLERANCE_KEYS)
"""The fields in the order a variant draws them (the keys of :data:`rvtool.designs.tolerance_keys.RV_TOLERANCE_KEYS`,
which documents each for the format doc)."""


@dataclass(frozen=True, kw_only=True)
class RvToleranceSpec:
    """One distribution (or None) per field of :data:`RV_FIELDS`."""
    crank_phase_error: object = None
    crank_eccentricity_error: object = None
    pin_radius_error: object = None
    needle_clearance: object = None
    sun_pitch_deviation: object = None
    crank_gear_pitch_deviation: object = None
    pin_pitch_deviation: object = None
    pin_radial_position_error: object = None
    wheel_bore_position_error: object = None
    carrier_bore_position_error: object = None
    profile_equidistant_error: object = None
    profile_offset_error: object = None
    wheel_lobe_pitch_deviation: object = None
    pin_circle_coaxiality_error: object = None
    sun_runout: object = None
    crank_gear_runout: object = None

    def __post_init__(self):
        check_design_distributions(self, RV_FIELDS)


def load_rv_tolerances(path):
    """RvToleranceSpec from the ``[tolerances]`` table of a TOML file."""
    return load_design_tolerances(path, RvToleranceSpec, RV_FIELDS)


def _current(changes, design, section, key):
    """``section.key`` as the variant has it so far: the value an earlier field wrote into ``changes``, else the
    design's own (fields that add onto a key -- pin centres, pitch deviations -- build on both)."""
    return changes.get(section, {}).get(key, getattr(getattr(design, section), key))


def sample_rv_design(spec, design, k, seed):
    """(design of variant k, its drawn deviations {field: value(s)})."""
    changes, drawn = rv_design_changes(spec, design, k, seed)
    return design.replace(**changes), drawn


def rv_design_changes(spec, design, k, seed):
    """(the file-form changes of variant k, {section: {key: value}}, as ``design.replace`` takes them, its
    drawn deviations {field: value(s)}): what :func:`sample_rv_design` writes into ``design``."""
    if int(k) < 0 or int(seed) < 0:
        raise RvtoolInputError(f"variant index {k} and seed {seed}: valid range [0, inf) (integers)")
    rng = np.random.default_rng([int(seed), int(k)])
    n = design.cranks.count
    drawn, changes = {}, {}
    for nm in RV_FIELDS:
        d = getattr(spec, nm)
        if d is None:
            continue
        if nm == "crank_phase_error":
            v = tuple(float(x) for x in d.sample(rng, n))
            # drawn in arcmin (the tolerance file's unit); the design file gives the angle in degrees
            changes.setdefault("cranks", {})["phase_errors_deg"] = tuple(x / 60.0 for x in v)
        elif nm == "crank_eccentricity_error":
            v = tuple(float(x) for x in d.sample(rng, n))
            changes.setdefault("cranks", {})["eccentricity_errors"] = v
        elif nm == "pin_radius_error":
            v = float(d.sample(rng))
            changes.setdefault("pins", {})["radius_error"] = v
        elif nm == "needle_clearance":
            v = float(d.sample(rng))
            changes["eccentric_bearing"] = {"radial_clearance": v}
        elif nm == "sun_pitch_deviation":
            f = np.asarray(d.sample(rng, design.sun_gear.n_teeth), float)
            v = tuple(float(x) for x in f - f.mean())
            changes["sun_gear"] = {"single_pitch_deviations": v}
        elif nm == "crank_gear_pitch_deviation":
            f = np.asarray(d.sample(rng, n * design.crank_gear.n_teeth), float).reshape(n, -1)
            v = tuple(tuple(float(x) for x in row - row.mean()) for row in f)
            changes.setdefault("cranks", {})["gear_pitch_deviations"] = v
        elif nm == "pin_pitch_deviation":
            f = np.asarray(d.sample(rng, design.pins.n_pins), float)
            v = tuple(float(x) for x in f - f.mean())
            changes.setdefault("pins", {})["centre_errors"] = pin_pitch_centre_errors(design.pins, v)
        elif nm == "pin_radial_position_error":
            v = tuple(float(x) for x in d.sample(rng, design.pins.n_pins))
            base = _current(changes, design, "pins", "centre_errors")
            changes.setdefault("pins", {})["centre_errors"] = pin_radial_centre_errors(design.pins, v, base)
        elif nm == "wheel_bore_position_error":
            f = np.asarray(d.sample(rng, (n, design.n_wheels, 2)), float)
            v = tuple(tuple(tuple(float(x) for x in xy) for xy in row) for row in f)
            changes.setdefault("cranks", {})["wheel_bore_errors"] = v
        elif nm == "carrier_bore_position_error":
            f = np.asarray(d.sample(rng, (n, 2)), float)
            v = tuple(tuple(float(x) for x in xy) for xy in f)
            changes.setdefault("cranks", {})["carrier_bore_errors"] = v
        elif nm == "profile_equidistant_error":
            v = float(d.sample(rng))
            changes.setdefault("profile", {})["equidistant_mod"] = design.profile.equidistant_mod + v
        elif nm == "profile_offset_error":
            v = float(d.sample(rng))
            changes.setdefault("profile", {})["offset_mod"] = design.profile.offset_mod + v
        elif nm == "wheel_lobe_pitch_deviation":
            zg = design.pins.n_pins - 1
            f = np.asarray(d.sample(rng, design.n_wheels * zg), float).reshape(design.n_wheels, zg)
            v = tuple(tuple(float(x) for x in row - row.mean()) for row in f)
            changes.setdefault("wheels", {})["lobe_pitch_deviations"] = v
        elif nm == "pin_circle_coaxiality_error":
            v = tuple(float(x) for x in d.sample(rng, 2))
            base = _current(changes, design, "pins", "centre_errors")
            changes.setdefault("pins", {})["centre_errors"] = coaxial_centre_errors(design.pins, v, base)
        elif nm == "sun_runout":
            v = tuple(float(x) for x in d.sample(rng, 2))
            z = design.sun_gear.n_teeth
            base = _current(changes, design, "sun_gear", "single_pitch_deviations")
            f = runout_pitch_deviations(z, v) + (0.0 if base is None else np.asarray(base, float))
            changes.setdefault("sun_gear", {})["single_pitch_deviations"] = tuple(float(x) for x in f)
        elif nm == "crank_gear_runout":
            e = np.asarray(d.sample(rng, (n, 2)), float)
            v = tuple(tuple(float(x) for x in xy) for xy in e)
            z = design.crank_gear.n_teeth
            base = _current(changes, design, "cranks", "gear_pitch_deviations")
            base = np.zeros((n, z)) if not len(base) else np.asarray(base, float)
            changes.setdefault("cranks", {})["gear_pitch_deviations"] = tuple(
                tuple(float(x) for x in runout_pitch_deviations(z, e[k]) + base[k]) for k in range(n))
        else:                               # never reached: RV_FIELDS and the branches above name the same fields
            raise RvtoolInputError(f"tolerance field {nm!r} has no sampler")
        drawn[nm] = v
    return changes, drawn


def pin_pitch_centre_errors(pins, single_pitch_deviations):
    """Pin-centre errors (z_b, 2) [m] of ring pins whose seats carry the single pitch deviations f_k [m]
    (f_k between pin k-1 and pin k along the pin circle, summing to zero): pin k moves along the pin
    circle's tangent by the accumulated pitch deviation s_k = f_1 + ... + f_k minus the mean of s (no rigid
    rotation), added to the design's ``pins.centre_errors``. Pin k sits at angle a_k = 2 pi k / z_b from +y,
    clockwise (:func:`rvtool.geometry.cycloid.pin_centres`); its tangent is (cos a_k, -sin a_k)."""
    f = np.asarray(single_pitch_deviations, float)
    if f.shape != (pins.n_pins,):
        raise RvtoolInputError(f"pin single pitch deviations must have shape ({pins.n_pins},); got {f.shape}")
    s = np.cumsum(f)
    s = s - s.mean()
    a = 2 * np.pi * np.arange(pins.n_pins) / pins.n_pins
    e = s[:, None] * np.column_stack([np.cos(a), -np.sin(a)])
    if pins.centre_errors is not None:
        e = e + np.asarray(pins.centre_errors, float)
    return tuple(tuple(float(x) for x in row) for row in e)


def pin_radial_centre_errors(pins, radial, base=None):
    """Pin-centre errors (z_b, 2) [m] of ring pins whose seats lie off the pin circle by ``radial`` [m] (one per
    pin, outward positive), added to ``base`` ((z_b, 2) or None). Pin k sits at angle a_k = 2 pi k / z_b from +y,
    clockwise (:func:`rvtool.geometry.cycloid.pin_centres`); its outward normal is (sin a_k, cos a_k)."""
    r = np.asarray(radial, float)
    if r.shape != (pins.n_pins,):
        raise RvtoolInputError(f"pin radial position errors must have shape ({pins.n_pins},); got {r.shape}")
    a = 2 * np.pi * np.arange(pins.n_pins) / pins.n_pins
    e = r[:, None] * np.column_stack([np.sin(a), np.cos(a)])
    if base is not None:
        e = e + np.asarray(base, float)
    return tuple(tuple(float(x) for x in row) for row in e)


def coaxial_centre_errors(pins, offset, base=None):
    """Pin-centre errors (z_b, 2) [m] of a pin circle whose centre lies off the main-bearing (carrier) axis by
    ``offset`` = (x, y) [m]: the same translation for every ring-pin seat, fixed in the housing frame (the frame of
    ``pins.centre_errors``), added to ``base`` ((z_b, 2) or None)."""
    o = np.asarray(offset, float)
    if o.shape != (2,):
        raise RvtoolInputError(f"pin circle coaxiality offset must have shape (2,); got {o.shape}")
    e = np.zeros((pins.n_pins, 2)) + o
    if base is not None:
        e = e + np.asarray(base, float)
    return tuple(tuple(float(x) for x in row) for row in e)


def runout_pitch_deviations(n_teeth, eccentricity):
    """Single pitch deviations f_k [m] (k = 0 .. z-1, f_k between tooth k-1 and k, summing to zero) of a gear
    whose pitch circle is eccentric to its axis by ``eccentricity`` = (e_x, e_y) [m] (runout).

    Geometry: the teeth of an eccentric gear are its nominal teeth translated by e. An involute flank's normal at
    every point is tangent to the base circle, so tooth k's flank (its normal n_k at the angle 2 pi k / z of the
    tooth in the gear frame, less the pressure angle, a common phase) moves along the line of action by
    s_k = e . n_k = e_x cos(2 pi k / z) + e_y sin(2 pi k / z) = e_r sin(2 pi k / z + phi), of amplitude
    e_r = |e| (the tangential component of e enters with cos(alpha), the radial one with sin(alpha): together
    e_r, whatever the pressure angle); the radial part perpendicular to the line of action changes only the
    centre distance, which an involute pair transmits without TE to first order. The model turns tooth k by its
    accumulated pitch F_k / r_b with F_k = f_1 + ... + f_k, F_0 = 0
    (:meth:`rvtool.geometry.involute.InvoluteGear.pitch_deviation_angles`), i.e. moves its flanks along the line
    of action by F_k: the first differences f_k = s_k - s_{k-1} (cyclic) give F_k = s_k - s_0, the sinusoid less
    tooth 0's value (tooth 0 the angular reference of the gear, as for the single-pitch fields). The phase of
    the loaded flank is the sampled phase; the other flank's differs by 2 alpha (both flanks turn alike here)."""
    e = np.asarray(eccentricity, float)
    if e.shape != (2,):
        raise RvtoolInputError(f"gear runout eccentricity must have shape (2,); got {e.shape}")
    a = 2 * np.pi * np.arange(int(n_teeth)) / int(n_teeth)
    s = e[0] * np.cos(a) + e[1] * np.sin(a)
    return s - np.roll(s, 1)
