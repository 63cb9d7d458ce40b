"""Fatigue: Eq. (obs_damage) from the load moment I_m, Miner's sum over a
rainflow-counted stress spectrum, and the bearing rating life L10 of ISO 281.

Damage is a downstream state here: nothing in this module writes back to the
contact geometry (no spatial defect adapter, Section "Material evolution,
damage, and renewed mechanical observations").

Force--life path (Eq. (obs_damage)), for N(F) = N_ref (F_ref / F)^m and a
declared stress-cycle rate nu_c:

    Delta D_c = nu_c Delta tau_service / (N_ref F_ref^m) * I_m,c / tau_w.

Replacing I_m / tau_w by the m-th power of the mean load underestimates the
damage of a varying load for m > 1 (Jensen); :func:`mean_load_underestimate`
gives that ratio.

Stress-spectrum path: D = sum_r n_r / N(sigma_r), with the cycles of a
scalar stress history (e.g. the subsurface stress of a selected contact from
``rvtool.pressure``) counted by the ``rainflow`` package (ASTM E1049-85), an
S--N curve in the amplitude sigma_a = range / 2, and no mean-stress
correction (declared).

Bearing rating life, ISO 281:2007: basic dynamic radial load rating (N, mm)

    ball,   D_w <= 25.4 mm: C_r = b_m f_c (i cos a)^0.7 Z^(2/3) D_w^1.8,
    ball,   D_w >  25.4 mm: C_r = 3.647 b_m f_c (i cos a)^0.7 Z^(2/3) D_w^1.4,
    roller:                 C_r = b_m f_c (i L_we cos a)^(7/9) Z^(3/4) D_we^(29/27),

with f_c linearly interpolated in gamma = D cos(a) / D_pw from ISO 281
Table 2 (radial ball bearings, single-row radial and angular contact groove
types) or Table 7 (radial roller bearings), b_m = 1.3 (groove ball
bearings) or 1.1 (roller bearings) from Table 1, and

    L10 = (C / P)^p  [10^6 revolutions],  p = 3 (ball), 10/3 (roller).
"""
import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_nonnegative, check_positive, check_range
from .exposure import WindowExposure

# ISO 281:2007 Table 2, f_c of single-row radial and angular contact groove ball bearings,
# gamma = D_w cos(alpha) / D_pw = 0.01, 0.02, ..., 0.40.
ISO281_BALL_FC = (29.1, 35.8, 40.3, 43.8, 46.7, 49.1, 51.1, 52.8, 54.3, 55.5, 56.6, 57.5, 58.2, 58.8, 59.3, 59.6,
                  59.8, 59.9, 60.0, 59.9, 59.8, 59.6, 59.3, 59.0, 58.6, 58.2, 57.7, 57.1, 56.6, 56.0, 55.3, 54.6,
                  53.9, 53.2, 52.4, 51.7, 50.9, 50.0, 49.2, 48.4)
# ISO 281:2007 Table 7, f_c of radial roller bearings, gamma = D_we cos(alpha) / D_pw = 0.01, ..., 0.30.
ISO281_ROLLER_FC = (52.1, 60.8, 66.5, 70.7, 74.1, 76.9, 79.2, 81.2, 82.8, 84.2, 85.4, 86.4, 87.1, 87.7, 88.2, 88.5,
                    88.7, 88.8, 88.8, 88.7, 88.5, 88.2, 87.9, 87.5, 87.0, 86.4, 85.8, 85.2, 84.5, 83.8)
ISO281_GAMMA_STEP = 0.01
# ISO 281:2007 Table 1 rating factors b_m: groove ball bearings, and cylindrical/tapered/needle roller bearings.
ISO281_BM_BALL = 1.3
ISO281_BM_ROLLER = 1.1
# Ball diameter [mm] above which ISO 281 uses the D_w^1.4 form with factor 3.647.
ISO281_LARGE_BALL_MM = 25.4
ISO281_LARGE_BALL_FACTOR = 3.647
MM_PER_M = 1e3
SECONDS_PER_HOUR = 3600.0


# -- force--life path -------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class ForceLifeLaw:
    """Calibrated N(F) = N_ref (F_ref / F)^m (declared inputs).

    reference_life: N_ref [cycles] (> 0) at reference_force F_ref [N] (> 0);
    exponent: m [-] (> 0), the exponent of the I_m the exposure must carry.
    """
    reference_life: float
    reference_force: float
    exponent: float

    def __post_init__(self):
        for name in ("reference_life", "reference_force", "exponent"):
            check_finite(name, getattr(self, name))
            check_positive(name, getattr(self, name))

    def life(self, force):
        """N(F) [cycles] for F [N] (> 0)."""
        check_finite("force", force)
        check_positive("force", force)
        return self.reference_life * (self.reference_force / np.asarray(force, dtype=np.float64)) ** self.exponent

    def damage_rate(self, exposure: WindowExposure, cycle_rate) -> np.ndarray:
        """dD/dtau per contact [1/s]: nu_c / (N_ref F_ref^m) I_m,c / tau_w (Eq. (obs_damage) per service second).

        cycle_rate: nu_c [1/s] (>= 0), one value or one per contact of ``exposure``.
        """
        if not math.isclose(exposure.m, self.exponent, rel_tol=1e-12):
            raise RvtoolInputError(f"exposure.m = {exposure.m} differs from the life law's exponent m = "
                                   f"{self.exponent}; valid: I_m accumulated with the consumer's exponent")
        nu = np.broadcast_to(np.asarray(cycle_rate, dtype=np.float64), (len(exposure),))
        check_finite("cycle_rate", nu)
        check_nonnegative("cycle_rate", nu)
        return nu / (self.reference_life * self.reference_force ** self.exponent) * exposure.I_m / exposure.tau_w

    def damage_increment(self, exposure: WindowExposure, cycle_rate, service_interval: float) -> np.ndarray:
        """Delta D_c of Eq. (obs_damage) over ``service_interval`` [s] (>= 0) [-]."""
        check_finite("service_interval", service_interval)
        check_nonnegative("service_interval", service_interval)
        return self.damage_rate(exposure, cycle_rate) * service_interval


def mean_load_underestimate(I_F, I_m, tau_w: float, m: float):
    """(I_F / tau_w)^m / (I_m / tau_w): damage from the m-th power of the mean load over damage from I_m [-].

    I_F [N s] (>= 0), I_m [N^m s] (> 0), tau_w [s] (> 0), m [-] (> 0). <= 1 for m >= 1
    (Jensen's inequality), = 1 for a constant load.
    """
    check_finite("I_F", I_F)
    check_nonnegative("I_F", I_F)
    check_finite("I_m", I_m)
    check_positive("I_m", I_m)
    check_positive("tau_w", tau_w)
    check_positive("m", m)
    return (np.asarray(I_F, dtype=np.float64) / tau_w) ** m / (np.asarray(I_m, dtype=np.float64) / tau_w)


# -- stress-spectrum path ---------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class SNCurve:
    """N(sigma_a) = N_ref (sigma_ref / sigma_a)^k in the stress amplitude (declared inputs).

    reference_amplitude: sigma_ref [Pa] (> 0); reference_life: N_ref [cycles] (> 0); exponent: k [-] (> 0).
    """
    reference_amplitude: float
    reference_life: float
    exponent: float

    def __post_init__(self):
        for name in ("reference_amplitude", "reference_life", "exponent"):
            check_finite(name, getattr(self, name))
            check_positive(name, getattr(self, name))

    def life(self, amplitude):
        """N [cycles] at amplitude sigma_a [Pa] (> 0)."""
        check_positive("amplitude", amplitude)
        a = np.asarray(amplitude, dtype=np.float64)
        return self.reference_life * (self.reference_amplitude / a) ** self.exponent


@dataclass(frozen=True, kw_only=True, eq=False)
class SpectrumDamage:
    """Miner's sum D = sum_r n_r / N(sigma_r) of one stress history.

    damage [-]; amplitude [Pa], mean [Pa], count [cycles] per counted cycle
    (half cycles count 0.5); repeats: how often the history was applied.
    """
    damage: float
    amplitude: np.ndarray
    mean: np.ndarray
    count: np.ndarray
    repeats: float


def miner_damage(stress_history, curve: SNCurve, *, repeats: float = 1.0, periodic: bool = False) -> SpectrumDamage:
    """Rainflow-count ``stress_history`` [Pa] (ASTM E1049-85, ``rainflow`` package) and sum
    ``repeats`` (> 0) applications of it with Miner's rule on ``curve``.

    periodic=False: the history is counted once; a repeated block's closing half cycles are
    counted as halves in every repetition (conservative by at most one cycle of the largest
    range per block). periodic=True: the history is one period of a repeated block (e.g. one
    input revolution); it is rotated to start at its minimum and closed with it, so every
    reversal closes a full cycle (the steady-state count of the repeated block).
    """
    import rainflow
    s = np.asarray(stress_history, dtype=np.float64)
    if s.ndim != 1 or s.size < 2:
        raise RvtoolInputError(f"stress_history must be a 1-D array of at least 2 samples; got shape {s.shape}")
    check_finite("stress_history", s)
    check_finite("repeats", repeats)
    check_positive("repeats", repeats)
    if periodic:
        i = int(np.argmin(s))
        s = np.concatenate([s[i:], s[:i], s[i:i + 1]])
    cycles = [(rng, mean, count) for rng, mean, count, _, _ in rainflow.extract_cycles(s) if rng > 0.0]
    if not cycles:
        return SpectrumDamage(damage=0.0, amplitude=np.zeros(0), mean=np.zeros(0), count=np.zeros(0),
                              repeats=float(repeats))
    rng, mean, count = (np.array(c, dtype=np.float64) for c in zip(*cycles))
    amplitude = 0.5 * rng
    damage = float(repeats * np.sum(count / curve.life(amplitude)))
    return SpectrumDamage(damage=damage, amplitude=amplitude, mean=mean, count=count, repeats=float(repeats))


# -- bearing rating life, ISO 281 -----------------------------------------------
class RollingElement(str, Enum):
    BALL = "ball"
    ROLLER = "roller"


def _fc(table, gamma, kind):
    g_max = ISO281_GAMMA_STEP * len(table)
    check_range(f"gamma (D cos(alpha) / D_pw of the {kind} bearing)", gamma, ISO281_GAMMA_STEP, g_max)
    grid = ISO281_GAMMA_STEP * np.arange(1, len(table) + 1)
    return float(np.interp(gamma, grid, table))


@dataclass(frozen=True, kw_only=True)
class RatingGeometry:
    """Geometry of a radial rolling bearing for ISO 281.

    element: ball or roller. n_elements: Z per row (>= 3). n_rows: i (>= 1).
    element_diameter: D_w / D_we [m] (> 0). pitch_diameter: D_pw [m]
    (> element_diameter). contact_angle: alpha [rad] in [0, pi/4] (radial
    bearings). roller_length: L_we [m] (> 0) for rollers.
    """
    element: RollingElement
    n_elements: int
    element_diameter: float
    pitch_diameter: float
    n_rows: int = 1
    contact_angle: float = 0.0
    roller_length: float | None = None

    def __post_init__(self):
        try:
            object.__setattr__(self, "element", RollingElement(self.element))
        except ValueError:
            raise RvtoolInputError(f"element = {self.element!r} is not one of the valid choices "
                                   f"{[e.value for e in RollingElement]}") from None
        for name, low in (("n_elements", 3), ("n_rows", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise RvtoolInputError(f"{name} = {v!r} is outside the valid range: integers in [{low}, inf)")
        check_positive("element_diameter", self.element_diameter)
        check_range("pitch_diameter", self.pitch_diameter, self.element_diameter, low_open=True)
        check_range("contact_angle", self.contact_angle, 0.0, math.pi / 4)
        if self.element is RollingElement.ROLLER:
            if self.roller_length is None:
                raise RvtoolInputError("roller_length is required for a roller bearing (L_we of ISO 281)")
            check_positive("roller_length", self.roller_length)

    @property
    def gamma(self) -> float:
        """D cos(alpha) / D_pw [-]."""
        return self.element_diameter * math.cos(self.contact_angle) / self.pitch_diameter

    @property
    def life_exponent(self) -> float:
        """p = 3 (ball), 10/3 (roller)."""
        return 3.0 if self.element is RollingElement.BALL else 10.0 / 3.0

    def dynamic_load_rating(self) -> float:
        """Basic dynamic radial load rating C_r [N] by ISO 281."""
        D = self.element_diameter * MM_PER_M
        i, Z, ca = self.n_rows, self.n_elements, math.cos(self.contact_angle)
        if self.element is RollingElement.BALL:
            fc = _fc(ISO281_BALL_FC, self.gamma, "ball")
            if D <= ISO281_LARGE_BALL_MM:
                return ISO281_BM_BALL * fc * (i * ca) ** 0.7 * Z ** (2 / 3) * D ** 1.8
            return ISO281_LARGE_BALL_FACTOR * ISO281_BM_BALL * fc * (i * ca) ** 0.7 * Z ** (2 / 3) * D ** 1.4
        fc = _fc(ISO281_ROLLER_FC, self.gamma, "roller")
        L = self.roller_length * MM_PER_M
        return ISO281_BM_ROLLER * fc * (i * L * ca) ** (7 / 9) * Z ** 0.75 * D ** (29 / 27)


def radial_load_from_elements(element_loads, load_directions) -> float:
    """Radial load [N] of a bearing from its rolling-element loads: |sum_j Q_j n_j|.

    element_loads: Q_j [N] (>= 0), shape (Z,); load_directions: unit vectors
    n_j of the loads on the inner ring in the radial plane, shape (Z, 2).
    """
    Q = np.asarray(element_loads, dtype=np.float64)
    n = np.asarray(load_directions, dtype=np.float64)
    if Q.ndim != 1 or n.shape != (Q.size, 2):
        raise RvtoolInputError(f"element_loads (Z,) and load_directions (Z, 2) must match; got {Q.shape} and {n.shape}")
    check_finite("element_loads", Q)
    check_nonnegative("element_loads", Q)
    check_finite("load_directions", n)
    return float(np.linalg.norm(Q @ n))


def mean_equivalent_load(I_p: float, tau_w: float, p: float) -> float:
    """P_m = (I_p / tau_w)^(1/p) [N] with I_p = sum P^p dt over the window (ISO 281 mean load at
    constant speed; a contact exposure with m = p supplies I_p)."""
    check_finite("I_p", I_p)
    check_nonnegative("I_p", I_p)
    check_positive("tau_w", tau_w)
    check_positive("p", p)
    return (I_p / tau_w) ** (1.0 / p)


@dataclass(frozen=True, kw_only=True)
class RatingLife:
    """C [N], P [N], p [-], L10 [10^6 rev] and L10h [h] at the relative speed [rad/s]."""
    dynamic_load_rating: float
    equivalent_load: float
    exponent: float
    L10_million_rev: float
    L10_hours: float


def rating_life(geometry: RatingGeometry, equivalent_load: float, speed_rad_s: float) -> RatingLife:
    """L10 = (C / P)^p [10^6 rev] and L10h = 10^6 L10 / (n 3600) with n = speed / (2 pi) [rev/s].

    equivalent_load: P [N] (> 0, pure radial: X = 1, Y = 0). speed_rad_s:
    speed of the rotating ring relative to the stationary one [rad/s] (> 0).
    """
    check_finite("equivalent_load", equivalent_load)
    check_positive("equivalent_load", equivalent_load)
    check_finite("speed_rad_s", speed_rad_s)
    check_positive("speed_rad_s", speed_rad_s)
    C = geometry.dynamic_load_rating()
    p = geometry.life_exponent
    L10 = (C / equivalent_load) ** p
    rev_per_s = speed_rad_s / (2 * math.pi)
    return RatingLife(dynamic_load_rating=C, equivalent_load=float(equivalent_load), exponent=p, L10_million_rev=L10,
                      L10_hours=L10 * 1e6 / (rev_per_s * SECONDS_PER_HOUR))


# -- contact-stress reference of the force--life and stress-spectrum paths ------------------
def hertz_line_reference_force(*, reference_pressure: float, radius: float, length: float,
                               reduced_modulus: float) -> float:
    """Force [N] at which a line contact of reduced radius R [m] and length b [m] reaches the Hertz
    peak pressure p_ref [Pa]: p0^2 = F E* / (pi R b), so F_ref = pi R b p_ref^2 / E*, with E* the
    plane-strain two-body modulus [Pa] (E / (2 (1 - nu^2)) for equal steels; the convention of
    :mod:`rvtool.pressure`). A Hertz-pressure S--N curve N = N_ref (p_ref / p0)^k is then the
    force--life law N = N_ref (F_ref / F)^(k/2) of Eq. (obs_damage)."""
    for name, v in (("reference_pressure", reference_pressure), ("radius", radius), ("length", length),
                    ("reduced_modulus", reduced_modulus)):
        check_finite(name, v)
        check_positive(name, v)
    return math.pi * radius * length * reference_pressure ** 2 / reduced_modulus


def hertz_line_tresca_ratio(nu: float = 0.3) -> float:
    """max tau_max / p0 [-] of a frictionless Hertz line contact (plane strain, Poisson ratio nu),
    from the closed-form field :func:`rvtool.pressure.sliding_hertz_stress` on the load axis
    (about 0.300 at z = 0.786 a; Johnson 1985, Sec. 4.2)."""
    from ..pressure import sliding_hertz_stress
    z = np.linspace(0.70, 0.87, 3401)       # brackets the depth of the maximum, resolution 5e-5 a
    return float(np.max(sliding_hertz_stress([0.0], z, 1.0, 1.0, 0.0, nu)["tau_max"]))


@dataclass(frozen=True, kw_only=True, eq=False)
class StressHistory:
    """Peak subsurface Tresca stress of one contact over accepted states.

    tau_max [Pa] per state (0 where the contact carries no load); force [N]; hertz_tau [Pa]:
    the closed-form Hertz value of the same force and geometry (reference); depth [m] of the
    peak; panels: the panel count of each solve.
    """
    tau_max: np.ndarray
    force: np.ndarray
    hertz_tau: np.ndarray
    depth: np.ndarray
    panels: int


def subsurface_stress_history(local_contacts, *, panels: int = 201, depths: int = 61, domain_factor: float = 3.0,
                              nu: float = 0.3) -> StressHistory:
    """Peak subsurface Tresca stress tau_max [Pa] of one contact at each accepted state.

    local_contacts: one :class:`rvtool.pressure.state.LocalContact` per state, or None where the
    contact carries no load (tau = 0). Each loaded state is solved by the panel method of
    :mod:`rvtool.pressure` (``panels`` uniform panels over +-domain_factor Hertz half-widths) and
    its plane-strain stress field (:func:`rvtool.pressure.subsurface_stress`, Coulomb traction of
    the contact's own sliding mu) evaluated on ``depths`` depths in [0, 2 a]; the history is the
    field's maximum per state (the peak follows the contact zone over the surface: conservative
    for a material point the zone moves across).
    """
    from ..pressure import subsurface_stress
    from ..pressure.study import domain_halfwidth, solve_contact
    if isinstance(panels, bool) or not isinstance(panels, (int, np.integer)) or panels < 11:
        raise RvtoolInputError(f"panels = {panels!r} is outside the valid range: integers in [11, inf)")
    if isinstance(depths, bool) or not isinstance(depths, (int, np.integer)) or depths < 5:
        raise RvtoolInputError(f"depths = {depths!r} is outside the valid range: integers in [5, inf)")
    ratio = hertz_line_tresca_ratio(nu)
    n = len(local_contacts)
    tau, F, ref, depth = (np.zeros(n) for _ in range(4))
    for k, c in enumerate(local_contacts):
        if c is None:
            continue
        half = domain_halfwidth(c, domain_factor)
        sol = solve_contact(c, panels, half, 0.0)
        z = np.linspace(0.0, 2.0 * c.hertz_halfwidth, depths)
        field = subsurface_stress(sol.x, sol.pressure, z, nu=nu, mu=c.sliding_mu)["tau_max"]
        i = np.unravel_index(int(np.argmax(field)), field.shape)
        tau[k], depth[k], F[k] = field[i], z[i[0]], c.force
        ref[k] = ratio * c.hertz_peak
    return StressHistory(tau_max=tau, force=F, hertz_tau=ref, depth=depth, panels=int(panels))
