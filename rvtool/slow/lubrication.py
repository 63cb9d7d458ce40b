"""Lubrication: viscosity eta(T), minimum film thickness, film parameter
lambda = h_min / sqrt(Rq1^2 + Rq2^2) and a mixed-friction law mu(lambda)
(Section "Thermal and lubrication feedback through geometry and friction").

Declared forms
--------------
Viscosity (either, declared by the model chosen):

* Vogel: eta(T) = A exp(B / (T - C)), with a declared constant
  pressure-viscosity coefficient alpha.
* Roelands at ambient pressure (Roelands 1966, as written by Hamrock,
  *Fundamentals of Fluid Film Lubrication*, NASA RP-1255, 1991, ch. 4):
  eta(T) = eta_ref exp{(ln eta_ref + 9.67) [((T - 138) / (T_ref - 138))^(-S0) - 1]}
  (eta in Pa s, T in K); its pressure term (1 + p / p_r)^Z, p_r = 1.96e8 Pa,
  has the initial slope alpha(T) = Z (ln eta(T) + 9.67) / p_r.

Minimum film thickness (isothermal EHL, dimensionless groups with the
reduced modulus E' = 2 / [(1 - nu1^2)/E1 + (1 - nu2^2)/E2] and the mean
entrainment speed u = (u1 + u2) / 2):

* line contact, Dowson & Higginson (1977, *Elasto-hydrodynamic Lubrication*, SI ed.):
  h_min / R_x = 2.65 U^0.70 G^0.54 W'^-0.13,
  U = eta0 u / (E' R_x), G = alpha E', W' = w' / (E' R_x), w' load per length;
* point contact, Hamrock & Dowson (1977):
  h_min / R_x = 3.63 U^0.68 G^0.49 W^-0.073 (1 - exp(-0.68 k)),
  W = w / (E' R_x^2), ellipticity k = 1.0339 (R_y / R_x)^0.636
  (Brewe & Hamrock 1977 approximation), R_x along the entrainment.

Mixed friction (a Stribeck-type interpolation, declared here; its three
parameters are inputs, not calibrated values):
  f_a(lambda) = exp(-(lambda / lambda_t)^n)   (asperity share of the load),
  mu(lambda) = mu_f + (mu_b - mu_f) f_a(lambda),
which tends to the boundary coefficient mu_b as lambda -> 0 and to the
full-film coefficient mu_f for lambda >> lambda_t.

Observation mode returns h_min, lambda and mu as outputs only; coupled mode
writes mu per contact instance for the next mechanical window (the
orchestrator's choice). This is a staggered constitutive update, not a
thermal-EHL solution, and the film's modulus does not change the structural
stiffness.
"""
import math
from dataclasses import dataclass
from enum import Enum
from types import MappingProxyType

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_nonnegative, check_positive, check_range
from .exposure import WindowExposure
from .offsets import match_selector

#: Roelands' reference pressure p_r [Pa] and constant ln(63.15e-6 Pa s) = -9.67 of the pressure-viscosity law.
ROELANDS_PRESSURE = 1.96e8
ROELANDS_LN_ETA_INF = 9.67
#: Temperature [K] at which Roelands' temperature term diverges (T - 138 K).
ROELANDS_T_INF = 138.0


def _positive_all(name, value):
    check_finite(name, value)
    check_positive(name, value)
    return np.asarray(value, dtype=np.float64)


@dataclass(frozen=True, kw_only=True)
class VogelViscosity:
    """eta(T) = A exp(B / (T - C)) [Pa s].

    A: [Pa s] (> 0). B: [K] (> 0). C: [K] (>= 0). pressure_viscosity: alpha
    [1/Pa] (> 0), declared constant.
    """
    A: float
    B: float
    C: float
    pressure_viscosity: float

    def __post_init__(self):
        check_positive("A", self.A)
        check_positive("B", self.B)
        check_nonnegative("C", self.C)
        check_positive("pressure_viscosity", self.pressure_viscosity)

    def viscosity(self, T):
        """eta [Pa s] at T [K] (T > C)."""
        check_finite("T", T)
        check_range("T", T, self.C, low_open=True)
        return self.A * np.exp(self.B / (np.asarray(T, dtype=np.float64) - self.C))

    def alpha(self, T):
        """Pressure-viscosity coefficient [1/Pa] (declared constant)."""
        check_finite("T", T)
        return np.full_like(np.asarray(T, dtype=np.float64), self.pressure_viscosity)


@dataclass(frozen=True, kw_only=True)
class RoelandsViscosity:
    """Roelands' temperature law at ambient pressure and its pressure-viscosity coefficient.

    reference_viscosity: eta_ref [Pa s] (> 0) at reference_temperature T_ref
    [K] (> 138 K). temperature_index: S0 [-] (> 0). pressure_index: Z [-] (> 0).
    """
    reference_viscosity: float
    reference_temperature: float
    temperature_index: float
    pressure_index: float

    def __post_init__(self):
        check_positive("reference_viscosity", self.reference_viscosity)
        check_range("reference_temperature", self.reference_temperature, ROELANDS_T_INF, low_open=True)
        check_positive("temperature_index", self.temperature_index)
        check_positive("pressure_index", self.pressure_index)

    def viscosity(self, T):
        """eta [Pa s] at T [K] (T > 138 K)."""
        check_finite("T", T)
        check_range("T", T, ROELANDS_T_INF, low_open=True)
        ratio = (np.asarray(T, dtype=np.float64) - ROELANDS_T_INF) / (self.reference_temperature - ROELANDS_T_INF)
        a = math.log(self.reference_viscosity) + ROELANDS_LN_ETA_INF
        return self.reference_viscosity * np.exp(a * (ratio ** -self.temperature_index - 1.0))

    def alpha(self, T):
        """alpha(T) = Z (ln eta(T) + 9.67) / p_r [1/Pa], the initial slope of ln eta over p."""
        return self.pressure_index * (np.log(self.viscosity(T)) + ROELANDS_LN_ETA_INF) / ROELANDS_PRESSURE


def reduced_modulus(youngs_1: float, poisson_1: float, youngs_2: float, poisson_2: float) -> float:
    """E' = 2 / [(1 - nu1^2)/E1 + (1 - nu2^2)/E2] [Pa]."""
    for name, v in (("youngs_1", youngs_1), ("youngs_2", youngs_2)):
        check_positive(name, v)
    for name, v in (("poisson_1", poisson_1), ("poisson_2", poisson_2)):
        check_range(name, v, -1.0, 0.5, low_open=True, high_open=True)
    return 2.0 / ((1.0 - poisson_1 ** 2) / youngs_1 + (1.0 - poisson_2 ** 2) / youngs_2)


def film_thickness_line(*, load_per_length, radius, entrainment_speed, viscosity, pressure_viscosity,
                        reduced_modulus):
    """Dowson--Higginson minimum film thickness of a line contact [m].

    load_per_length w' [N/m], radius R_x (reduced radius in the entrainment
    direction) [m], entrainment_speed u [m/s], viscosity eta0 [Pa s],
    pressure_viscosity alpha [1/Pa], reduced_modulus E' [Pa]; all > 0.
    """
    w = _positive_all("load_per_length", load_per_length)
    R = _positive_all("radius", radius)
    u = _positive_all("entrainment_speed", entrainment_speed)
    eta = _positive_all("viscosity", viscosity)
    a = _positive_all("pressure_viscosity", pressure_viscosity)
    E = _positive_all("reduced_modulus", reduced_modulus)
    U, G, W = eta * u / (E * R), a * E, w / (E * R)
    return 2.65 * U ** 0.70 * G ** 0.54 * W ** -0.13 * R


def ellipticity(radius_x, radius_y):
    """k = 1.0339 (R_y / R_x)^0.636 (Brewe & Hamrock 1977) [-]."""
    return 1.0339 * (_positive_all("radius_y", radius_y) / _positive_all("radius_x", radius_x)) ** 0.636


def film_thickness_point(*, load, radius_x, radius_y, entrainment_speed, viscosity, pressure_viscosity,
                         reduced_modulus):
    """Hamrock--Dowson minimum film thickness of a point contact [m].

    load w [N], radius_x R_x (entrainment direction), radius_y R_y [m],
    entrainment_speed u [m/s], viscosity eta0 [Pa s], pressure_viscosity
    alpha [1/Pa], reduced_modulus E' [Pa]; all > 0.
    """
    w = _positive_all("load", load)
    R = _positive_all("radius_x", radius_x)
    k = ellipticity(radius_x, radius_y)
    u = _positive_all("entrainment_speed", entrainment_speed)
    eta = _positive_all("viscosity", viscosity)
    a = _positive_all("pressure_viscosity", pressure_viscosity)
    E = _positive_all("reduced_modulus", reduced_modulus)
    U, G, W = eta * u / (E * R), a * E, w / (E * R ** 2)
    return 3.63 * U ** 0.68 * G ** 0.49 * W ** -0.073 * (1.0 - np.exp(-0.68 * k)) * R


def film_parameter(h_min, roughness_1, roughness_2):
    """lambda = h_min / sqrt(Rq1^2 + Rq2^2) [-]; h_min [m] (>= 0), RMS roughnesses [m] (>= 0, not both 0)."""
    check_finite("h_min", h_min)
    check_nonnegative("h_min", h_min)
    for name, v in (("roughness_1", roughness_1), ("roughness_2", roughness_2)):
        check_finite(name, v)
        check_nonnegative(name, v)
    s = np.hypot(roughness_1, roughness_2)
    check_positive("sqrt(roughness_1^2 + roughness_2^2)", s)
    return np.asarray(h_min, dtype=np.float64) / s


@dataclass(frozen=True, kw_only=True)
class MixedFriction:
    """mu(lambda) = mu_f + (mu_b - mu_f) exp(-(lambda / lambda_t)^n) (the declared form above).

    boundary_friction mu_b [-] (>= 0), fluid_friction mu_f [-] (>= 0),
    transition_lambda lambda_t [-] (> 0), sharpness n [-] (> 0).
    """
    boundary_friction: float
    fluid_friction: float
    transition_lambda: float
    sharpness: float

    def __post_init__(self):
        check_nonnegative("boundary_friction", self.boundary_friction)
        check_nonnegative("fluid_friction", self.fluid_friction)
        check_positive("transition_lambda", self.transition_lambda)
        check_positive("sharpness", self.sharpness)

    def asperity_share(self, lam):
        """f_a(lambda) = exp(-(lambda / lambda_t)^n) [-], lambda in [0, inf] (inf: an unloaded contact, f_a = 0)."""
        lam = np.asarray(lam, dtype=np.float64)
        bad = np.isnan(lam) | (lam < 0.0)
        if np.any(bad):
            shown = np.atleast_1d(lam[bad])[:4].tolist()
            # a number as written (the input messages' convention), the first few of an array as a list
            raise RvtoolInputError(f"lambda = {shown[0] if lam.ndim == 0 else shown} is outside the valid range "
                                   "[0, inf]")
        return np.exp(-(lam / self.transition_lambda) ** self.sharpness)

    def mu(self, lam):
        """Mixed friction coefficient [-]."""
        return self.fluid_friction + (self.boundary_friction - self.fluid_friction) * self.asperity_share(lam)


class ContactKind(str, Enum):
    LINE = "line"
    POINT = "point"


@dataclass(frozen=True, kw_only=True)
class FilmContact:
    """Film geometry and surfaces of one contact family (a selector of :class:`Lubrication`).

    kind: line or point. radius_x: reduced radius in the entrainment direction [m].
    radius_y: transverse reduced radius [m] (point contacts). length: loaded
    length [m] (line contacts; w' = F / length). entrainment_speed: u [m/s]
    (> 0). reduced_modulus: E' [Pa]. roughness_1, roughness_2: RMS Rq [m].
    node: thermal node whose temperature sets eta and alpha. load_share: film load per unit of the
    contact's window-mean force [-] (> 0; e.g. the most loaded ball's share of a lumped bearing).
    """
    kind: ContactKind
    radius_x: float
    entrainment_speed: float
    reduced_modulus: float
    roughness_1: float
    roughness_2: float
    node: str
    radius_y: float | None = None
    length: float | None = None
    load_share: float = 1.0

    def __post_init__(self):
        try:
            object.__setattr__(self, "kind", ContactKind(self.kind))
        except ValueError:
            raise RvtoolInputError(f"kind = {self.kind!r} is not one of the valid choices "
                                   f"{[k.value for k in ContactKind]}") from None
        for name in ("radius_x", "entrainment_speed", "reduced_modulus"):
            check_positive(name, getattr(self, name))
        for name in ("roughness_1", "roughness_2"):
            check_nonnegative(name, getattr(self, name))
        if self.kind is ContactKind.LINE and self.length is None:
            raise RvtoolInputError("length is required for a line contact (w' = F / length)")
        if self.kind is ContactKind.POINT and self.radius_y is None:
            raise RvtoolInputError("radius_y is required for a point contact")
        if self.length is not None:
            check_positive("length", self.length)
        if self.radius_y is not None:
            check_positive("radius_y", self.radius_y)
        check_finite("load_share", self.load_share)
        check_positive("load_share", self.load_share)


@dataclass(frozen=True, kw_only=True, eq=False)
class FilmState:
    """Per-contact film results: ids, temperature [K], viscosity [Pa s], h_min [m], lambda [-], mu [-].

    Contacts without load in the window (no film load) carry h_min = inf,
    lambda = inf and mu = mu_f.
    """
    ids: tuple
    temperature: np.ndarray
    viscosity: np.ndarray
    h_min: np.ndarray
    film_parameter: np.ndarray
    mu: np.ndarray

    def friction(self) -> dict:
        """id -> mu, as the coupled mode writes it for the next window."""
        return dict(zip(self.ids, self.mu.tolist()))

    def lambdas(self) -> dict:
        """id -> lambda."""
        return dict(zip(self.ids, self.film_parameter.tolist()))


@dataclass(frozen=True, kw_only=True, eq=False)
class Lubrication:
    """eta(T), h_min, lambda and mu(lambda) per contact from the window's mean loads.

    lubricant: :class:`VogelViscosity` or :class:`RoelandsViscosity`.
    friction_law: :class:`MixedFriction`. contacts: selector -> :class:`FilmContact`.
    """
    lubricant: object
    friction_law: MixedFriction
    contacts: dict

    def __post_init__(self):
        if not (callable(getattr(self.lubricant, "viscosity", None)) and callable(getattr(self.lubricant, "alpha", None))):
            raise RvtoolInputError(f"lubricant must provide viscosity(T) and alpha(T); got "
                                   f"{type(self.lubricant).__name__}")
        if not isinstance(self.friction_law, MixedFriction):
            raise RvtoolInputError(f"friction_law must be a MixedFriction; got {type(self.friction_law).__name__}")
        for s, c in dict(self.contacts).items():
            if not isinstance(c, FilmContact):
                raise RvtoolInputError(f"contacts[{s!r}] must be a FilmContact; got {type(c).__name__}")
        object.__setattr__(self, "contacts", MappingProxyType(dict(self.contacts)))

    def nodes(self) -> set:
        return {c.node for c in self.contacts.values()}

    def evaluate(self, exposure: WindowExposure, temperature_of_node) -> FilmState:
        """Film state of every contact of ``exposure`` at mean load I_F / tau_w.

        temperature_of_node: node name -> T [K] (a mapping).
        """
        n = len(exposure)
        T, eta, h, lam, mu = (np.zeros(n) for _ in range(5))
        F = exposure.mean_force
        for k, cid in enumerate(exposure.ids):
            c = match_selector(self.contacts, cid, "lubrication.contacts")
            try:
                T[k] = float(temperature_of_node[c.node])
            except KeyError:
                raise RvtoolInputError(f"no temperature for thermal node {c.node!r} of contact {cid!r}") from None
            eta[k] = self.lubricant.viscosity(T[k])
            if F[k] <= 0.0:  # unloaded in this window: no film load, no asperity load
                h[k] = lam[k] = math.inf
                mu[k] = self.friction_law.fluid_friction
                continue
            alpha = float(self.lubricant.alpha(T[k]))
            w = F[k] if c.load_share == 1.0 else c.load_share * F[k]
            if c.kind is ContactKind.LINE:
                h[k] = film_thickness_line(load_per_length=w / c.length, radius=c.radius_x,
                                           entrainment_speed=c.entrainment_speed, viscosity=eta[k],
                                           pressure_viscosity=alpha, reduced_modulus=c.reduced_modulus)
            else:
                h[k] = film_thickness_point(load=w, radius_x=c.radius_x, radius_y=c.radius_y,
                                            entrainment_speed=c.entrainment_speed, viscosity=eta[k],
                                            pressure_viscosity=alpha, reduced_modulus=c.reduced_modulus)
            lam[k] = film_parameter(h[k], c.roughness_1, c.roughness_2)
            mu[k] = self.friction_law.mu(lam[k])
        return FilmState(ids=exposure.ids, temperature=T, viscosity=eta, h_min=h, film_parameter=lam, mu=mu)
