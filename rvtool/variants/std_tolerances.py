"""Small-tooth-difference involute tolerances: declared distributions and seeded sampling of
``std-involute`` design variants (a variant is a design: the deviations are written into the
design's own sections), as :mod:`rvtool.variants.rv_tolerances` does for the RV reducer.

Fields (SI units; distributions and their TOML form as :mod:`rvtool.variants.tolerances`):

* ``eccentricity_error`` [m]: added to ``wheels.eccentricity`` (the working centre distance of the
  wheel--ring pairs; one value per reducer, the eccentric shaft is ground once),
* ``needle_clearance`` [m]: radial clearance of the needle sets (one value per reducer,
  ``eccentric_bearing.radial_clearance``; support must be non-negative),
* ``wheel_pitch_deviation`` [m]: single pitch deviations f_pt of the wheel (one draw per tooth,
  minus their mean so that they close the circle; ``wheel.single_pitch_deviations``; the wheels of
  one reducer share the wheel spec),
* ``ring_pitch_deviation`` [m]: single pitch deviations f_pt of the ring gear (as the wheel's;
  ``ring.single_pitch_deviations``).

Variant k draws from ``numpy.random.default_rng([seed, k])`` in the order of :data:`STD_FIELDS`.
"""
from dataclasses import dataclass

import numpy as np

from ..designs.tolerance_keys import STD_TOLERANCE_KEYS
from ..errors import RvtoolInputError
from .tolerances import check_design_distributions, load_design_tolerances

STD_FIELDS = tuple(STD_TOLERANCE_KEYS)
"""The fields in draw order (the keys of :data:`rvtool.designs.tolerance_keys.STD_TOLERANCE_KEYS`)."""


@dataclass(frozen=True, kw_only=True)
class StdToleranceSpec:
    """One distribution (or None) per field of :data:`STD_FIELDS`."""
    eccentricity_error: object = None
    needle_clearance: object = None
    wheel_pitch_deviation: object = None
    ring_pitch_deviation: object = None

    def __post_init__(self):
        check_design_distributions(self, STD_FIELDS)


def load_std_tolerances(path):
    """StdToleranceSpec from the ``[tolerances]`` table of a TOML file."""
    return load_design_tolerances(path, StdToleranceSpec, STD_FIELDS)


def sample_std_design(spec, design, k, seed):
    """(design of variant k, its drawn deviations {field: value(s)})."""
    if int(k) < 0 or int(seed) < 0:
        raise RvtoolInputError(f"variant index {k} and seed {seed}: valid range [0, inf) (integers)")
    rng = np.random.default_rng([int(seed), int(k)])
    drawn, changes = {}, {}
    for nm in STD_FIELDS:
        d = getattr(spec, nm)
        if d is None:
            continue
        if nm == "eccentricity_error":
            v = float(d.sample(rng))
            changes["wheels"] = {"eccentricity": design.wheels.eccentricity + v}
        elif nm == "needle_clearance":
            v = float(d.sample(rng))
            changes["eccentric_bearing"] = {"radial_clearance": v}
        else:
            gear = "wheel" if nm == "wheel_pitch_deviation" else "ring"
            f = np.asarray(d.sample(rng, getattr(design, gear).n_teeth), float)
            v = tuple(float(x) for x in f - f.mean())
            changes[gear] = {"single_pitch_deviations": v}
        drawn[nm] = v
    return design.replace(**changes), drawn
