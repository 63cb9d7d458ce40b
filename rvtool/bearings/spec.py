"""Rolling-element bearing specifications (frozen, validated on construction).

Element stiffness from Palmgren's empirical steel contact approaches (Harris &
Kotzalas, Rolling Bearing Analysis, ch. 6): a ball on one race
delta = 2.18e-4 Q^(2/3) D^(-1/3) [mm, N] (so 4.36e-4 for inner plus outer), a
roller on one race delta = 1.92e-5 Q^0.9 L^(-0.8) [mm, N, mm] (3.84e-5 for both).
Point contacts that carry the same load combine as
K = (K_i^(-2/3) + K_o^(-2/3))^(-3/2) (paper, after Eq. (ball_bearing)).
"""
import math
from dataclasses import dataclass

from ..errors import RvtoolInputError
from ..validation import check_nonnegative, check_positive, check_range


def ball_race_stiffness(ball_diameter):
    """K of one ball--race point contact [N m^-3/2] (Palmgren, one race)."""
    k_mm = (1.0 / (2.18e-4 * (ball_diameter * 1e3) ** (-1 / 3))) ** 1.5   # Q = k delta^1.5, N and mm
    return k_mm * 1e3 ** 1.5


def combine_point_contacts(k_inner, k_outer):
    """Series combination of two point contacts carrying the same load (exponent 3/2)."""
    return (k_inner ** (-2 / 3) + k_outer ** (-2 / 3)) ** (-1.5)


def roller_lamina_stiffness(length, n_slices):
    """Coefficient k [N m^-10/9] of one lamina of length L/n of a roller on both races
    (Palmgren 3.84e-5 Q^0.9 L^-0.8 [mm], per lamina the length share L / n)."""
    lam = length / n_slices * 1e3
    k_mm = (1.0 / (3.84e-5 * lam ** (-0.8))) ** (1 / 0.9)
    return k_mm * 1e3 ** (1 / 0.9)


def _count(name, n, low):
    if not isinstance(n, int) or n < low:
        raise RvtoolInputError(f"{name} = {n!r} is outside the valid range [{low}, inf) (integer)")


@dataclass(frozen=True, kw_only=True)
class RollerBearing:
    """Cylindrical or needle roller bearing, rollers sliced along their length.

    inner_radius: raceway radius of the inner ring (journal) [m]; roller_diameter D [m];
    roller_length L [m]; n_rollers Z; radial_clearance c [m] (diametral / 2);
    n_slices laminae; crowning: drop at the roller ends [m] (parabolic).
    """
    inner_radius: float
    roller_diameter: float
    roller_length: float
    n_rollers: int
    radial_clearance: float = 0.0
    n_slices: int = 4
    crowning: float = 0.0

    def __post_init__(self):
        check_positive("inner_radius", self.inner_radius)
        check_positive("roller_diameter", self.roller_diameter)
        check_positive("roller_length", self.roller_length)
        _count("n_rollers", self.n_rollers, 3)
        _count("n_slices", self.n_slices, 1)
        check_range("radial_clearance", self.radial_clearance, -0.01 * self.roller_diameter, 0.01 * self.roller_diameter)
        check_nonnegative("crowning", self.crowning)
        pitch = 2 * self.inner_radius + self.roller_diameter
        if self.n_rollers * self.roller_diameter >= math.pi * pitch:
            raise RvtoolInputError(f"n_rollers = {self.n_rollers} rollers of {self.roller_diameter} m do not fit on the "
                                   f"pitch circle of {pitch} m; valid range [3, {int(math.pi * pitch / self.roller_diameter)}]")

    @property
    def pitch_diameter(self):
        return 2 * self.inner_radius + self.roller_diameter


@dataclass(frozen=True, kw_only=True)
class BallBearing:
    """Ball bearing row: n_balls Z, ball_diameter D [m], pitch_diameter d_m [m], contact_angle
    alpha_0 [rad], inner/outer groove curvature ratios f_i, f_o (> 0.5), radial_clearance c [m],
    axial_preload_offset s_a [m] (axial approach of the rings from preload; light preload ~ 5 um)."""
    n_balls: int
    ball_diameter: float
    pitch_diameter: float
    contact_angle: float = 0.0
    inner_curvature: float = 0.52
    outer_curvature: float = 0.52
    radial_clearance: float = 0.0
    axial_preload_offset: float = 0.0

    def __post_init__(self):
        _count("n_balls", self.n_balls, 3)
        check_positive("ball_diameter", self.ball_diameter)
        check_range("pitch_diameter", self.pitch_diameter, self.ball_diameter, math.inf, low_open=True)
        check_range("contact_angle", self.contact_angle, 0.0, math.pi / 2, high_open=True)
        check_range("inner_curvature", self.inner_curvature, 0.5, 1.0, low_open=True)
        check_range("outer_curvature", self.outer_curvature, 0.5, 1.0, low_open=True)
        check_range("radial_clearance", self.radial_clearance, -0.01 * self.ball_diameter, 0.01 * self.ball_diameter)
        check_range("axial_preload_offset", self.axial_preload_offset, 0.0, 0.01 * self.ball_diameter)
        if self.n_balls * self.ball_diameter >= math.pi * self.pitch_diameter:
            raise RvtoolInputError(f"n_balls = {self.n_balls} balls of {self.ball_diameter} m do not fit on the pitch circle "
                                   f"of {self.pitch_diameter} m; valid range [3, {int(math.pi * self.pitch_diameter / self.ball_diameter)}]")

    @property
    def groove_centre_distance(self):
        """A = (f_i + f_o - 1) D [m]."""
        return (self.inner_curvature + self.outer_curvature - 1.0) * self.ball_diameter

    @property
    def stiffness(self):
        """K [N m^-3/2] of one ball (inner and outer contacts in series)."""
        k = ball_race_stiffness(self.ball_diameter)
        return combine_point_contacts(k, k)


@dataclass(frozen=True, kw_only=True)
class AngularContactPair:
    """Two angular-contact rows with opposite contact angles (back-to-back or face-to-face),
    row_spacing [m] apart; in the planar model both carry radial load, their axial force
    and tilting moment are observations."""
    row: BallBearing
    row_spacing: float
    arrangement: str = "back_to_back"

    def __post_init__(self):
        check_positive("row_spacing", self.row_spacing)
        if self.arrangement not in ("back_to_back", "face_to_face"):
            raise RvtoolInputError(f"arrangement = {self.arrangement!r}; valid: ['back_to_back', 'face_to_face']")
        if self.row.contact_angle <= 0:
            raise RvtoolInputError("row.contact_angle must be > 0 for an angular-contact pair (valid range (0, pi/2))")


@dataclass(frozen=True, kw_only=True)
class CrossedRollerBearing:
    """Crossed-roller row: rollers alternate the contact angle +-alpha (45 deg typical)."""
    inner_radius: float
    roller_diameter: float
    roller_length: float
    n_rollers: int
    contact_angle: float = math.pi / 4
    radial_clearance: float = 0.0
    n_slices: int = 2

    def __post_init__(self):
        RollerBearing(inner_radius=self.inner_radius, roller_diameter=self.roller_diameter,
                      roller_length=self.roller_length, n_rollers=self.n_rollers,
                      radial_clearance=self.radial_clearance, n_slices=self.n_slices)
        check_range("contact_angle", self.contact_angle, 0.0, math.pi / 2, low_open=True, high_open=True)

    @property
    def pitch_diameter(self):
        return 2 * self.inner_radius + self.roller_diameter
