"""Declared manufacturing-tolerance distributions and seeded sampling of
:class:`~rvtool.variants.Variant` s (the input of the tolerance Monte Carlo, issue 8).

A :class:`ToleranceSpec` assigns one distribution (or none: no deviation) to each
deviation field of :class:`~rvtool.variants.Variant`; all values in SI units [m]:

* ``eccentricity_error``: added to the assembly eccentricity e (profile keeps e_g),
* ``pin_centre_errors``: drawn independently for the x and the y component of every
  ring-pin centre (z_b x 2 draws per variant),
* ``pin_radius_error``: one value per reducer (the pins of one reducer come from one
  ground batch),
* ``equidistant_mod`` / ``offset_mod``: profile grinding deviations added to the
  design's modifications,
* ``pin_clearance``: uniform gap added at every pin contact,
* ``bearing_clearance``: eccentric-bearing radial clearance (replaces the design's);
  its support must be non-negative,
* ``pin_circle_coaxiality_error``: the x and y of the pin circle's centre off the output
  (main-bearing) axis, one draw per coordinate and reducer: one translation common to every
  ring-pin centre, fixed in the housing frame, added to the variant's ``pin_centre_errors``
  (zero where the file has no ``pin_centre_errors``). Drawn last, so that adding it left
  every other field's draws of a seed unchanged (a file without it draws what it drew
  before, bit for bit).

Distributions (frozen dataclasses): :class:`Normal` (mean, std), :class:`Uniform`
(low, high), :class:`TruncatedNormal` (mean, std of the parent normal, low, high) and
:class:`Fixed` (value). In TOML, a ``[tolerances]`` table holds inline tables::

    [tolerances]
    eccentricity_error = { dist = "normal", mean = 0.0, std = 1.0e-6 }
    pin_centre_errors  = { dist = "normal", std = 1.5e-6 }
    pin_clearance      = { dist = "truncnormal", mean = 5e-6, std = 2e-6, low = 0.0, high = 12e-6 }
    bearing_clearance  = { dist = "uniform", low = 3e-6, high = 8e-6 }

Sampling is reproducible per variant index: variant k draws from its own generator
``numpy.random.default_rng([seed, k])`` (a SeedSequence of the pair), so variant k is
the same whether it is drawn in a batch of 20, of 1000, or by a resumed study.
"""
import math
import tomllib
from dataclasses import MISSING, dataclass, fields

import numpy as np
from scipy.special import ndtr, ndtri

from ..designs.tolerance_keys import CYCLOID_TOLERANCE_KEYS
from ..errors import RvtoolInputError
from ..validation import check_finite, check_range

FIELDS = tuple(CYCLOID_TOLERANCE_KEYS)
"""Tolerance fields (each a Variant field, or, for ``pin_circle_coaxiality_error``, added to one), in the fixed
order in which a variant draws them (the keys of
:data:`rvtool.designs.tolerance_keys.CYCLOID_TOLERANCE_KEYS`, which documents each for the format doc)."""


@dataclass(frozen=True, kw_only=True)
class Normal:
    """Normal distribution: mean [m], standard deviation std [m] (> 0)."""
    mean: float = 0.0
    std: float

    def __post_init__(self):
        check_finite("mean", self.mean)
        check_range("std", self.std, 0.0, math.inf, low_open=True)

    def sample(self, rng, size=None):
        return self.mean + self.std * rng.standard_normal(size)

    def moments(self):
        """(mean, variance) of the distribution."""
        return self.mean, self.std ** 2

    def support(self):
        return -math.inf, math.inf


@dataclass(frozen=True, kw_only=True)
class Uniform:
    """Uniform distribution on [low, high] [m], low < high."""
    low: float
    high: float

    def __post_init__(self):
        check_finite("low", self.low)
        check_range("high", self.high, self.low, math.inf, low_open=True)

    def sample(self, rng, size=None):
        return self.low + (self.high - self.low) * rng.random(size)

    def moments(self):
        return 0.5 * (self.low + self.high), (self.high - self.low) ** 2 / 12.0

    def support(self):
        return self.low, self.high


@dataclass(frozen=True, kw_only=True)
class TruncatedNormal:
    """Normal(mean, std) [m] restricted to [low, high] [m] (either bound may be infinite;
    the interval must hold at least 1e-12 of the parent's probability). Sampled by the
    inverse CDF, x = mean + std Phi^-1(Phi(a) + u (Phi(b) - Phi(a))), a, b the standardized bounds."""
    mean: float = 0.0
    std: float
    low: float = -math.inf
    high: float = math.inf

    def __post_init__(self):
        check_finite("mean", self.mean)
        check_range("std", self.std, 0.0, math.inf, low_open=True)
        if not self.low < self.high or math.isnan(self.low) or math.isnan(self.high):
            raise RvtoolInputError(f"low = {self.low!r}, high = {self.high!r}: valid range low < high")
        a, b = self._ab()
        if ndtr(b) - ndtr(a) < 1e-12:
            raise RvtoolInputError(f"[low, high] = [{self.low}, {self.high}] holds < 1e-12 of Normal(mean={self.mean}, "
                                   f"std={self.std}); valid range: an interval within ~7 std of the mean")

    def _ab(self):
        return (self.low - self.mean) / self.std, (self.high - self.mean) / self.std

    def sample(self, rng, size=None):
        a, b = self._ab()
        pa, pb = ndtr(a), ndtr(b)
        x = self.mean + self.std * ndtri(pa + (pb - pa) * rng.random(size))
        # ndtri rounding can leave a draw a few ulp outside the bounds
        return np.clip(x, self.low, self.high)

    def moments(self):
        """Closed-form mean and variance of the truncated normal:
        mean + std (phi(a) - phi(b)) / Z, std^2 [1 + (a phi(a) - b phi(b)) / Z - ((phi(a) - phi(b)) / Z)^2]."""
        a, b = self._ab()
        z = ndtr(b) - ndtr(a)

        def phi(x):
            return 0.0 if math.isinf(x) else math.exp(-0.5 * x * x) / math.sqrt(2 * math.pi)

        def xphi(x):
            return 0.0 if math.isinf(x) else x * phi(x)

        d = (phi(a) - phi(b)) / z
        return self.mean + self.std * d, self.std ** 2 * (1 + (xphi(a) - xphi(b)) / z - d * d)

    def support(self):
        return self.low, self.high


@dataclass(frozen=True, kw_only=True)
class Fixed:
    """A deterministic deviation value [m] (no scatter)."""
    value: float

    def __post_init__(self):
        check_finite("value", self.value)

    def sample(self, rng, size=None):
        return np.full(size, float(self.value)) if size is not None else float(self.value)

    def moments(self):
        return self.value, 0.0

    def support(self):
        return self.value, self.value


DISTRIBUTIONS = {"normal": Normal, "uniform": Uniform, "truncnormal": TruncatedNormal, "fixed": Fixed}
"""TOML ``dist`` names of the distribution classes."""


@dataclass(frozen=True, kw_only=True)
class ToleranceSpec:
    """One distribution (or None: no deviation) per tolerance field of :data:`FIELDS` (module docstring)."""
    eccentricity_error: object = None
    pin_centre_errors: object = None
    pin_radius_error: object = None
    equidistant_mod: object = None
    offset_mod: object = None
    pin_clearance: object = None
    bearing_clearance: object = None
    pin_circle_coaxiality_error: object = None

    def __post_init__(self):
        for nm in FIELDS:
            d = getattr(self, nm)
            if d is not None and not isinstance(d, tuple(DISTRIBUTIONS.values())):
                raise RvtoolInputError(f"tolerances.{nm} = {d!r}; valid: one of {sorted(DISTRIBUTIONS)} or none")
        if self.bearing_clearance is not None and self.bearing_clearance.support()[0] < 0:
            raise RvtoolInputError(f"tolerances.bearing_clearance has support starting at "
                                   f"{self.bearing_clearance.support()[0]} m; valid range [0, inf) m "
                                   f"(use 'uniform' or 'truncnormal' with low >= 0)")

    def check_design(self, design):
        """Raise if a distribution's support can leave a physically impossible reducer:
        e + eccentricity_error <= 0 or r_p + pin_radius_error <= 0 (unbounded normals are
        checked at their mean -/+ 8 std, beyond which no draw of 1e15 lands)."""
        for nm, limit in (("eccentricity_error", -design.wheels.eccentricity),
                          ("pin_radius_error", -design.pins.pin_radius)):
            d = getattr(self, nm)
            if d is None:
                continue
            lo = d.support()[0]
            if math.isinf(lo):
                m, v = d.moments()
                lo = m - 8 * math.sqrt(v)
            if lo <= limit:
                raise RvtoolInputError(f"tolerances.{nm} reaches {lo} m; valid range ({limit}, inf) m for this design")

    def to_dict(self):
        out = {}
        for nm in FIELDS:
            d = getattr(self, nm)
            if d is not None:
                name = next(k for k, c in DISTRIBUTIONS.items() if isinstance(d, c))
                out[nm] = {"dist": name, **{f.name: getattr(d, f.name) for f in fields(d)}}
        return out


def distribution_from_dict(name, table):
    """A distribution from its TOML inline table; errors name ``tolerances.<name>``."""
    if not isinstance(table, dict):
        raise RvtoolInputError(f"tolerances.{name} = {table!r}; valid: an inline table with 'dist' = one of "
                               f"{sorted(DISTRIBUTIONS)}")
    table = dict(table)
    kind = table.pop("dist", None)
    if kind not in DISTRIBUTIONS:
        raise RvtoolInputError(f"tolerances.{name}.dist = {kind!r}; valid choices are {sorted(DISTRIBUTIONS)}")
    cls = DISTRIBUTIONS[kind]
    valid = {f.name for f in fields(cls)}
    unknown = set(table) - valid
    if unknown:
        raise RvtoolInputError(f"tolerances.{name} ({kind}) has unknown keys {sorted(unknown)}; valid keys are "
                               f"{sorted(valid | {'dist'})}")
    required = sorted(f.name for f in fields(cls) if f.default is MISSING)
    missing = [k for k in required if k not in table]
    if missing:
        optional = sorted(valid - set(required))
        raise RvtoolInputError(f"tolerances.{name} ({kind}) is missing {missing}; required keys are {required}"
                               + (f", optional {optional}" if optional else ""))
    for k, v in table.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise RvtoolInputError(f"tolerances.{name}.{k} = {v!r} is not a number; valid: a finite number")
    try:
        return cls(**{k: float(v) for k, v in table.items()})
    except RvtoolInputError as exc:
        raise RvtoolInputError(f"tolerances.{name}.{exc}") from None
    except (TypeError, ValueError) as exc:
        raise RvtoolInputError(f"tolerances.{name} ({kind}): {exc}; required keys are "
                               f"{sorted(f.name for f in fields(cls))}") from None


def check_design_distributions(spec, field_names):
    """Validate a design-variant tolerance spec (RV, small-tooth-difference): each field of
    ``field_names`` holds a distribution of :data:`DISTRIBUTIONS` or None, and a clearance's support
    starts at 0 or above (a negative clearance is no clearance)."""
    for nm in field_names:
        d = getattr(spec, nm)
        if d is not None and not isinstance(d, tuple(DISTRIBUTIONS.values())):
            raise RvtoolInputError(f"tolerances.{nm} = {d!r}; valid: one of {sorted(DISTRIBUTIONS)} or none")
    clearance = getattr(spec, "needle_clearance", None)
    if clearance is not None and clearance.support()[0] < 0:
        raise RvtoolInputError(f"tolerances.needle_clearance has support starting at "
                               f"{clearance.support()[0]} m; valid range [0, inf) m")


def load_design_tolerances(path, spec_type, field_names):
    """``spec_type`` from the ``[tolerances]`` table of a TOML file whose keys are ``field_names``
    (the design-variant tolerance files of the RV and small-tooth-difference reducers)."""
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    table = data.get("tolerances")
    if not isinstance(table, dict):
        raise RvtoolInputError(f"{path}: no [tolerances] table")
    unknown = set(table) - set(field_names)
    if unknown:
        raise RvtoolInputError(f"[tolerances] has unknown keys {sorted(unknown)}; valid keys are {list(field_names)}")
    return spec_type(**{k: distribution_from_dict(k, v) for k, v in table.items()})


def spec_from_dict(data):
    """ToleranceSpec from a dict holding a ``tolerances`` table (or the table itself)."""
    table = data.get("tolerances", data) if isinstance(data, dict) else data
    if not isinstance(table, dict):
        raise RvtoolInputError("[tolerances] must be a table")
    unknown = set(table) - set(FIELDS)
    if unknown:
        raise RvtoolInputError(f"[tolerances] has unknown keys {sorted(unknown)}; valid keys are {list(FIELDS)}")
    return ToleranceSpec(**{k: distribution_from_dict(k, v) for k, v in table.items()})


def load_tolerances(path):
    """ToleranceSpec from the ``[tolerances]`` table of a TOML file."""
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    if "tolerances" not in data:
        raise RvtoolInputError(f"{path}: no [tolerances] table")
    return spec_from_dict(data["tolerances"])


def sample_variant(spec, design, k, seed):
    """Variant with index k: every field drawn from ``default_rng([seed, k])`` in the order of
    FIELDS (a field without a distribution draws nothing). ``pin_circle_coaxiality_error`` has no
    Variant field of its own: its offset is added to every row of ``pin_centre_errors``."""
    from .variant import Variant
    if int(k) < 0 or int(seed) < 0:
        raise RvtoolInputError(f"variant index {k} and seed {seed}: valid range [0, inf) (integers)")
    rng = np.random.default_rng([int(seed), int(k)])
    kw = {}
    for nm in FIELDS:
        d = getattr(spec, nm)
        if d is None:
            continue
        if nm == "pin_centre_errors":
            kw[nm] = np.asarray(d.sample(rng, (design.pins.n_pins, 2)), float)
        elif nm == "pin_circle_coaxiality_error":
            offset = np.asarray(d.sample(rng, 2), float)
            base = kw.get("pin_centre_errors", np.zeros((design.pins.n_pins, 2)))
            kw["pin_centre_errors"] = base + offset
        else:
            kw[nm] = float(d.sample(rng))
    return Variant(index=int(k), **kw)


def sample_variants(spec, design, n, seed, start=0):
    """Variants with indices start .. start + n - 1 (each reproducible on its own, see
    :func:`sample_variant`)."""
    if int(n) < 0:
        raise RvtoolInputError(f"n = {n}; valid range [0, inf) (integer)")
    spec.check_design(design)
    return [sample_variant(spec, design, k, seed) for k in range(int(start), int(start) + int(n))]
