"""Wear of Eq. (obs_wear) with a film-dependent coefficient, the
contact-to-surface association and the single-channel limiter.

For contact c with nominal area A_c,

    Delta h_c = k_w(lambda_c) I_s,c / A_c * s,   s = Delta tau_service / tau_w,

with k_w the dimensional wear coefficient [m^2/N] (= volume per load and
sliding distance, Archard's K / H). Delta h_c is the material loss of the
contact, i.e. its gap opens by Delta h_c; the association splits it over the
material surfaces that lose it (a pin, a lobe region of the wheel, a race
zone), each a *surface bin* that accumulates depth from every contact that
touches it. The wear gap offset of a contact is the summed depth of the bins
it touches at its current position, so a lobe region worn by several pins
opens all of their gaps, and a tooth-averaged increment is never presented
as a local scar.

The single-channel limiter (Section "Material evolution, damage, and renewed
mechanical observations") caps the largest contact increment at
max_increment and scales the represented service interval by the same
factor, so that the depth per represented service time is unchanged.
"""
import math
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_nonnegative, check_positive, check_range
from .exposure import WindowExposure
from .offsets import GapOffsets, match_selector


@dataclass(frozen=True, kw_only=True)
class ConstantWearCoefficient:
    """k_w(lambda) = k for every lambda [m^2/N] (k >= 0)."""
    k: float

    def __post_init__(self):
        _check_k("k", self.k)

    def __call__(self, lam):
        return np.full_like(np.asarray(lam, dtype=np.float64), self.k)


@dataclass(frozen=True, kw_only=True)
class FilmWearCoefficient:
    """k_w(lambda) = k_b f_a(lambda): the boundary coefficient k_b [m^2/N] (>= 0) on the asperity share
    of the load f_a of the declared mixed-friction law (``friction_law.asperity_share``)."""
    boundary_coefficient: float
    friction_law: object

    def __post_init__(self):
        _check_k("boundary_coefficient", self.boundary_coefficient)
        if not callable(getattr(self.friction_law, "asperity_share", None)):
            raise RvtoolInputError(f"friction_law must provide asperity_share(lambda); got "
                                   f"{type(self.friction_law).__name__}")

    def __call__(self, lam):
        return self.boundary_coefficient * self.friction_law.asperity_share(lam)


def _check_k(name, k):
    check_finite(name, k)
    if np.any(np.asarray(k, dtype=float) < 0.0):
        raise RvtoolInputError(f"{name} = {k!r} is outside the valid range [0, inf) m^2/N: a wear coefficient "
                               "cannot add material")


# -- contact-to-surface association -------------------------------------------
@dataclass(frozen=True, kw_only=True)
class IdentityBin:
    """The surface bin is the contact's own body part: ``surface/<suffix of the id>``
    (``"pins/17"`` -> ``"pins/17"`` for surface ``"pins"``)."""
    surface: str

    def __call__(self, contact_id, position):
        return f"{self.surface}/{contact_id.rsplit('/', 1)[-1]}"


@dataclass(frozen=True, kw_only=True)
class AngularBins:
    """Angular zones of a surface around ``center`` [m]: bin k of n_bins covers polar angles
    [offset + 2 pi k / n, offset + 2 pi (k+1) / n) of the contact position in the x-y plane.

    Positions are in the frame of the exposure record (global); zones of a
    body that rotates need the caller to supply positions in its frame.
    """
    surface: str
    center: tuple
    n_bins: int
    offset_rad: float = 0.0

    def __post_init__(self):
        if not isinstance(self.n_bins, int) or self.n_bins < 1:
            raise RvtoolInputError(f"n_bins = {self.n_bins!r} is outside the valid range: integers in [1, inf)")
        c = tuple(float(x) for x in self.center)
        if len(c) != 2:
            raise RvtoolInputError(f"center must be (x, y) [m]; got {self.center!r}")
        check_finite("center", c)
        check_finite("offset_rad", self.offset_rad)
        object.__setattr__(self, "center", c)

    def __call__(self, contact_id, position):
        phi = math.atan2(position[1] - self.center[1], position[0] - self.center[0]) - self.offset_rad
        k = int(math.floor((phi % (2 * math.pi)) / (2 * math.pi) * self.n_bins)) % self.n_bins
        return f"{self.surface}/{k}"


@dataclass(frozen=True, kw_only=True, eq=False)
class SurfaceAssociation:
    """Which material surfaces a contact's loss goes to.

    rules: selector -> ((binner, share), ...), where binner(contact_id,
    position) gives the surface bin name (:class:`IdentityBin`,
    :class:`AngularBins` or any callable) and the shares (>= 0) of one rule
    sum to 1 (e.g. 0.5 / 0.5 for two bodies of equal wear resistance).
    """
    rules: dict

    def __post_init__(self):
        rules = {}
        for s, parts in dict(self.rules).items():
            parts = tuple(parts)
            if not parts:
                raise RvtoolInputError(f"rules[{s!r}] is empty; valid: at least one (binner, share)")
            for b, share in parts:
                if not callable(b):
                    raise RvtoolInputError(f"rules[{s!r}] binner {b!r} is not callable")
                check_finite(f"rules[{s!r}].share", share)
                check_range(f"rules[{s!r}].share", share, 0.0, 1.0)
            total = sum(float(share) for _, share in parts)
            if abs(total - 1.0) > 1e-12:
                raise RvtoolInputError(f"rules[{s!r}] shares sum to {total!r}; valid: 1 (the contact's loss is "
                                       "split, not created)")
            rules[s] = parts
        object.__setattr__(self, "rules", MappingProxyType(rules))

    def bins(self, contact_id: str, position) -> dict:
        """bin name -> share for ``contact_id`` at ``position`` [m]."""
        out = {}
        for binner, share in match_selector(self.rules, contact_id, "association.rules"):
            name = binner(contact_id, position)
            out[name] = out.get(name, 0.0) + float(share)
        return out


# -- the update -----------------------------------------------------------------
@dataclass(frozen=True, kw_only=True, eq=False)
class WearIncrement:
    """One wear update.

    ids: contact identities; contact_increment: Delta h_c of Eq. (obs_wear)
    [m]; bin_increment: surface bin -> depth [m]; association: per contact,
    bin -> share; service_interval: represented Delta tau_service [s];
    factor: limiter factor applied (1 when not limited).
    """
    ids: tuple
    contact_increment: np.ndarray
    bin_increment: dict
    association: tuple
    service_interval: float
    factor: float = 1.0

    @property
    def max_increment(self) -> float:
        """Largest contact increment [m] (0 for an empty window)."""
        return float(self.contact_increment.max()) if self.contact_increment.size else 0.0

    def scaled(self, factor: float) -> "WearIncrement":
        """All increments and the service interval times ``factor`` in (0, 1]."""
        check_range("factor", factor, 0.0, 1.0, low_open=True)
        return WearIncrement(ids=self.ids, contact_increment=self.contact_increment * factor,
                             bin_increment={b: d * factor for b, d in self.bin_increment.items()},
                             association=self.association, service_interval=self.service_interval * factor,
                             factor=self.factor * factor)


@dataclass(frozen=True, kw_only=True, eq=False)
class WearModel:
    """Eq. (obs_wear) with a declared coefficient, nominal areas and association.

    coefficient: k_w(lambda) [m^2/N] (:class:`ConstantWearCoefficient`,
    :class:`FilmWearCoefficient` or a callable returning values >= 0).
    nominal_area: A_c [m^2] (> 0): one value or selector -> value.
    association: :class:`SurfaceAssociation`.
    """
    coefficient: object
    nominal_area: object
    association: SurfaceAssociation

    def __post_init__(self):
        if not callable(self.coefficient):
            raise RvtoolInputError(f"coefficient must be callable k_w(lambda); got {type(self.coefficient).__name__}")
        if isinstance(self.nominal_area, (dict, MappingProxyType)):
            for s, a in self.nominal_area.items():
                check_finite(f"nominal_area[{s!r}]", a)
                check_positive(f"nominal_area[{s!r}]", a)
            object.__setattr__(self, "nominal_area", MappingProxyType(dict(self.nominal_area)))
        else:
            check_finite("nominal_area", self.nominal_area)
            check_positive("nominal_area", self.nominal_area)
        if not isinstance(self.association, SurfaceAssociation):
            raise RvtoolInputError(f"association must be a SurfaceAssociation; got {type(self.association).__name__}")

    def area(self, contact_id: str) -> float:
        if isinstance(self.nominal_area, MappingProxyType):
            return float(match_selector(self.nominal_area, contact_id, "nominal_area"))
        return float(self.nominal_area)

    def increment(self, exposure: WindowExposure, service_interval: float, film_parameter=None) -> WearIncrement:
        """Eq. (obs_wear) over ``service_interval`` [s] (>= 0) represented by ``exposure``.

        film_parameter: id -> lambda (from :class:`rvtool.slow.lubrication.Lubrication`),
        or None for lambda = 0 (boundary lubrication, the coefficient's largest value
        for a film-dependent law).
        """
        check_finite("service_interval", service_interval)
        check_nonnegative("service_interval", service_interval)
        s = service_interval / exposure.tau_w
        lam = np.array([0.0 if film_parameter is None else film_parameter[i] for i in exposure.ids])
        k = np.asarray(self.coefficient(lam), dtype=np.float64)
        bad = ~np.isfinite(k) | (k < 0.0)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise RvtoolInputError(f"k_w(lambda = {float(lam[i])!r}) = {float(k[i])!r} at contact {exposure.ids[i]!r} is outside "
                                   "the valid range [0, inf) m^2/N")
        area = np.array([self.area(i) for i in exposure.ids])
        dh = k * exposure.I_s / area * s
        assoc, bins = [], {}
        for cid, pos, d in zip(exposure.ids, exposure.position, dh):
            shares = self.association.bins(cid, pos)
            assoc.append(shares)
            for b, share in shares.items():
                bins[b] = bins.get(b, 0.0) + share * d
        return WearIncrement(ids=exposure.ids, contact_increment=dh, bin_increment=bins, association=tuple(assoc),
                             service_interval=float(service_interval))


def limit_single_channel(increment: WearIncrement, max_increment: float) -> WearIncrement:
    """Cap the largest contact increment at ``max_increment`` [m] (> 0).

    Where max Delta h_c > max_increment, every increment and the represented
    service interval are multiplied by f = max_increment / max Delta h_c, so
    that the depth per represented service time is that of Eq. (obs_wear).
    """
    check_finite("max_increment", max_increment)
    check_positive("max_increment", max_increment)
    largest = increment.max_increment
    if largest <= max_increment:
        return increment
    return increment.scaled(max_increment / largest)


class SurfaceWear:
    """Accumulated depth per surface bin [m] and the wear channel's gap offsets."""

    def __init__(self, channel: str = "wear"):
        if not isinstance(channel, str) or not channel:
            raise RvtoolInputError(f"channel = {channel!r} must be a non-empty str")
        self.channel = channel
        self.depth = {}
        self.service_time = 0.0
        self.updates = 0
        self.limited_updates = 0
        self._association = {}

    def apply(self, increment: WearIncrement) -> None:
        """Add an update's bin depths and its represented service time."""
        for b, d in increment.bin_increment.items():
            self.depth[b] = self.depth.get(b, 0.0) + d
        for cid, shares in zip(increment.ids, increment.association):
            self._association[cid] = shares
        self.service_time += increment.service_interval
        self.updates += 1
        self.limited_updates += increment.factor < 1.0

    def contact_offset(self, contact_id: str) -> float:
        """Gap offset [m] of ``contact_id``: the summed recession of the surface bins it touches at its
        last associated position (a bin worn by other contacts too opens this gap as well)."""
        return sum(self.depth.get(b, 0.0) for b in self._association.get(contact_id, {}))

    def offsets(self) -> GapOffsets:
        """The wear channel's offsets, one entry per associated contact."""
        return GapOffsets(by_channel={self.channel: {cid: self.contact_offset(cid) for cid in self._association}})

    def max_depth(self) -> float:
        """Largest bin depth [m]."""
        return max(self.depth.values(), default=0.0)
