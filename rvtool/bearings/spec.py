"""Rolling-element bearing specifications: frozen, keyword-only, validated on
construction (errors name the parameter, its value and the valid range).

Element laws (paper, Section "Distributed bearing support"): balls follow
Eq. (ball_bearing) with Hertz constants (:mod:`rvtool.bearings.hertz`);
rollers are sliced along their length into laminae, each with the law of
Eq. (normal_force) (Palmgren's 10/9 power law, or its secant at a reference
roller load for the linear law) and a per-slice crowning drop.

RD-40 examples (issue 5)::

    needle = NeedleBearing(inner_radius=0.012, roller_diameter=0.003, roller_length=0.008,
                           n_rollers=16, radial_clearance=5e-6, n_slices=4)
    row = BallBearing(n_balls=16, ball_diameter=7.938e-3, pitch_diameter=0.068,
                      contact_angle=math.radians(25), inner_curvature=0.52, outer_curvature=0.52,
                      youngs_modulus=206e9, poisson_ratio=0.3, axial_preload=200.0)
    main = AngularContactPair(rows=(row, row), row_spacing=0.040, arrangement="back_to_back")
"""
import math
from dataclasses import dataclass
from enum import Enum
from functools import cached_property

import numpy as np

from warp_contacts.rolling_elements_ref import ball_stiffness

from ..errors import RvtoolInputError
from ..units import angle_field
from ..validation import check_finite, check_integer, check_nonnegative, check_positive, check_range
from .hertz import HertzConstants, effective_modulus, hertz_constants, roller_stiffness
from .influence import HalfWidth, SliceLaw, set_choice

#: Largest interference (negative radial clearance) as a fraction of the element diameter:
#: beyond it the small-deformation contact laws no longer describe the fit.
MAX_INTERFERENCE = 0.002
#: Largest radial clearance as a fraction of the element diameter.
MAX_CLEARANCE = 0.01


class LaminaLaw(str, Enum):
    """Elastic law of a roller lamina: Palmgren's power law (p = 10/9) or linear (p = 1)."""
    POWER = "power"
    LINEAR = "linear"


class Arrangement(str, Enum):
    """Paired angular-contact rows: back-to-back (O, DB) or face-to-face (X, DF)."""
    BACK_TO_BACK = "back_to_back"
    FACE_TO_FACE = "face_to_face"


def _enum(obj, name, cls):
    value = getattr(obj, name)
    try:
        object.__setattr__(obj, name, cls(value))
    except ValueError:
        raise RvtoolInputError(f"{name} = {value!r} is not one of the valid choices {[m.value for m in cls]}") from None



def _fit(count_name, n, diameter, pitch_diameter):
    """Elements must fit around the pitch circle without touching: n D < pi d_m."""
    ratio = math.pi * pitch_diameter / diameter
    if not math.isfinite(ratio):
        # finite radii can still overflow the pitch circle (found by tests/test_design_fuzz.py)
        raise RvtoolInputError(f"pitch diameter {pitch_diameter} m / element diameter {diameter} m is not finite; "
                               "valid: radii and diameters below ~1e300 m")
    n_max = math.ceil(ratio) - 1
    if n > n_max:
        raise RvtoolInputError(f"{count_name} = {n} elements of diameter {diameter} m do not fit on the pitch circle "
                               f"of diameter {pitch_diameter} m; valid range [3, {n_max}]")


def _per_slice(name, value, n_slices, check):
    """A scalar or one value per slice -> tuple of n_slices floats, each checked."""
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.shape not in ((1,), (n_slices,)):
        raise RvtoolInputError(f"{name} must be a number or hold n_slices = {n_slices} values; got {arr.size}")
    check(name, arr)
    return tuple(float(v) for v in np.broadcast_to(arr, (n_slices,)))


@dataclass(frozen=True, kw_only=True)
class CylindricalRollerBearing:
    """Cylindrical roller bearing, rollers sliced along their length (radial normal).

    inner_radius: raceway radius of the inner ring or journal [m].
    roller_diameter: D [m]. roller_length: effective length l [m]. n_rollers: Z, the number of
    rollers [-].
    radial_clearance: c [m] (half the diametral clearance; negative = interference,
    down to -0.2 % of D).
    n_slices: laminae per roller. crowning: drop of the generator [m], either the
    drop at the roller ends of a parabolic crown (scalar) or one drop per slice.
    law: "power" (Palmgren, k delta^(10/9)) or "linear" (the secant of the power
    law at the reference roller load). reference_roller_load: the roller load [N] at which the "linear" law is the
    power law's secant.
    lamina_stiffness: None (the law above, shared by the laminae in proportion to
    their length) or a coefficient per lamina [N m^-p] (scalar or one per slice).
    damping: c_d per roller [N s/m] (shared by the laminae); ramp_depth: delta_r [m]
    of Eq. (normal_force).
    slices: "laminae" (default, the law above per lamina) or "influence" (the slices coupled by
    the half-space compliance of both races, Eq. (bearing_ic), :mod:`rvtool.bearings.influence`;
    damping acts per slice in contact as for the laminae; a cycloid or std-involute design needs
    rolling-element bearings for it: ``rvtool analyze --bearing-model rolling``). half_width:
    "fixed" (the Hertz half-width at ``reference_roller_load``), "roller_load" or "slice_load"
    (updated from the roller's or each slice's line load), influence only.
    youngs_modulus: E [Pa] (rollers and rings; the influence compliance); poisson_ratio: nu [-].
    """
    inner_radius: float
    roller_diameter: float
    roller_length: float
    n_rollers: int
    radial_clearance: float = 0.0
    n_slices: int = 4
    crowning: float | tuple = 0.0
    law: LaminaLaw = LaminaLaw.POWER
    reference_roller_load: float = 1000.0
    lamina_stiffness: float | tuple | None = None
    damping: float = 0.0
    ramp_depth: float = 1e-6
    slices: SliceLaw = SliceLaw.LAMINAE
    half_width: HalfWidth = HalfWidth.FIXED
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3

    def __post_init__(self):
        check_positive("inner_radius", self.inner_radius)
        check_positive("roller_diameter", self.roller_diameter)
        check_positive("roller_length", self.roller_length)
        check_integer("n_rollers", self.n_rollers, 3, 1000)   # upper bound: a named error, not an hours-long build
        check_integer("n_slices", self.n_slices, 1, 64)
        check_range("radial_clearance", self.radial_clearance, -MAX_INTERFERENCE * self.roller_diameter,
                    MAX_CLEARANCE * self.roller_diameter)
        _enum(self, "law", LaminaLaw)
        check_positive("reference_roller_load", self.reference_roller_load)
        check_nonnegative("damping", self.damping)
        check_positive("ramp_depth", self.ramp_depth)
        _per_slice("crowning", self.crowning, self.n_slices, check_nonnegative)
        if self.lamina_stiffness is not None:
            _per_slice("lamina_stiffness", self.lamina_stiffness, self.n_slices, check_positive)
        set_choice(self, "slices", SliceLaw)
        set_choice(self, "half_width", HalfWidth)
        check_positive("youngs_modulus", self.youngs_modulus)
        check_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        _fit("n_rollers", self.n_rollers, self.roller_diameter, self.pitch_diameter)

    @property
    def pitch_diameter(self):
        """d_m = 2 r_i + D [m]."""
        return 2 * self.inner_radius + self.roller_diameter

    @property
    def contact_angle(self):
        """0: a radial roller."""
        return 0.0

    @property
    def exponent(self):
        """p of the lamina law."""
        return 10.0 / 9.0 if self.law == LaminaLaw.POWER else 1.0

    @property
    def slice_positions(self):
        """Lamina centres along the roller, from its middle [m] (n_slices,)."""
        n = self.n_slices
        return ((np.arange(n) + 0.5) / n - 0.5) * self.roller_length

    @property
    def slice_crowning(self):
        """Crowning drop of each lamina [m] (n_slices,): per-slice values, or the parabolic
        crown (2 zeta / l)^2 times the end drop."""
        if np.ndim(self.crowning) == 0:
            return float(self.crowning) * (2 * self.slice_positions / self.roller_length) ** 2
        return np.asarray(self.crowning, dtype=float)

    @property
    def roller_coefficient(self):
        """Coefficient of the whole roller [N m^-p] (both raceways): Palmgren's k for the
        power law, the secant Q_ref / delta(Q_ref) for the linear law."""
        k = roller_stiffness(self.roller_length)
        if self.law == LaminaLaw.POWER:
            return k
        return self.reference_roller_load / (self.reference_roller_load / k) ** 0.9

    @property
    def slice_stiffness(self):
        """Coefficient of each lamina [N m^-p] (n_slices,); with no override, the roller
        coefficient in proportion to the lamina length (a uniform approach then loads
        the roller as the unsliced law, whatever n_slices)."""
        if self.lamina_stiffness is None:
            return np.full(self.n_slices, self.roller_coefficient / self.n_slices)
        return np.array(_per_slice("lamina_stiffness", self.lamina_stiffness, self.n_slices, check_positive))


@dataclass(frozen=True, kw_only=True)
class NeedleBearing(CylindricalRollerBearing):
    """Needle roller bearing (long thin rollers, typically running directly on the
    journal, whose radius is ``inner_radius``); fields as :class:`CylindricalRollerBearing`.

    RD-40 eccentric bearing: ``NeedleBearing(inner_radius=0.012, roller_diameter=0.003,
    roller_length=0.008, n_rollers=16, radial_clearance=5e-6)``.
    """


@dataclass(frozen=True, kw_only=True)
class CrossedRollerBearing(CylindricalRollerBearing):
    """Crossed-roller row: consecutive rollers alternate the contact angle +alpha, -alpha
    (their axial components cancel pairwise; the planar model carries the radial parts).

    Fields as :class:`CylindricalRollerBearing` (crowning, law and slices act along
    each roller's generator) plus contact_angle: alpha [rad] in (0, pi/2), 45 deg typical.

    Geometry and stiffness model (a cycloid drive's main bearing: ``[main_bearing] kind =
    "crossed_roller"``, issue 32): one raceway of cylindrical rollers of diameter ~ length whose axes
    alternate by 90 deg, each contact along the roller at +-alpha to the radial plane (Harris &
    Kotzalas, Essential Concepts of Bearing Technology, 5th ed. (2007), ch. 1, "crossed roller
    bearings"; the pitch diameter d_m = 2 r_i + D as for any roller row). Each lamina carries
    Palmgren's line law Q = k delta^(10/9) for both contacts in series (Palmgren, Ball and Roller
    Bearing Engineering, 3rd ed. (1959): delta = 3.84e-5 Q^0.9 / l^0.8 [mm, N] per contact,
    :func:`rvtool.bearings.hertz.roller_stiffness`) with the lamina's approach delta = delta_r cos(alpha)
    + sigma delta_a sin(alpha) from the ring's radial, axial and tilt displacement
    (:mod:`rvtool.bearings.spatial_set`): one row carries radial, axial and tilting load, the +alpha
    and -alpha rollers on opposite sides of a tilt. A preload is declared as a negative
    radial_clearance (interference)."""
    contact_angle: float = angle_field(math.pi / 4)
    n_slices: int = 2

    def __post_init__(self):
        super().__post_init__()
        check_range("contact_angle", self.contact_angle, 0.0, math.pi / 2, low_open=True, high_open=True)


@dataclass(frozen=True, kw_only=True)
class BallBearing:
    """Ball bearing row (deep-groove for contact_angle = 0, else angular contact).

    n_balls: Z, the number of balls [-]. ball_diameter: D [m]. pitch_diameter: d_m [m].
    contact_angle: free contact angle alpha_0 [rad] in [0, pi/2).
    inner_curvature, outer_curvature: groove curvature ratios f_i, f_o = r_groove / D [-] in (0.5, 1].
    youngs_modulus: E [Pa]; poisson_ratio: nu [-] (balls and rings of one material).
    radial_clearance: c_b [m] of Eq. (ball_bearing) (negative = interference, down to -0.2 % of D).
    axial_preload: F_a [N] pressing the rings axially; it sets the axial approach
    s_a (:attr:`axial_preload_offset`) that the planar model then holds.
    damping: c_d per ball [N s/m]; ramp_depth: delta_r [m] of Eq. (normal_force).

    Planar model: the rings' axial displacement and tilts are held, so each ball's
    axial approach stays at its preload value and only the radial part F cos(alpha_w)
    acts on the bodies; the axial force and tilting moment are computed from the same
    element forces as observations (:meth:`BearingSet.resultants`). A ring body with
    retained axial and tilt coordinates (:class:`rvtool.bearings.spatial_set.SpatialBearingSet`)
    feeds them back.

    RD-40 main-bearing row: ``BallBearing(n_balls=16, ball_diameter=7.938e-3,
    pitch_diameter=0.068, contact_angle=math.radians(25), axial_preload=200.0)``.
    """
    n_balls: int
    ball_diameter: float
    pitch_diameter: float
    contact_angle: float = angle_field(0.0)
    inner_curvature: float = 0.52
    outer_curvature: float = 0.52
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3
    radial_clearance: float = 0.0
    axial_preload: float = 0.0
    damping: float = 0.0
    ramp_depth: float = 1e-6

    def __post_init__(self):
        check_integer("n_balls", self.n_balls, 3, 1000)   # upper bound: a named error, not an hours-long build
        check_positive("ball_diameter", self.ball_diameter)
        check_range("pitch_diameter", self.pitch_diameter, self.ball_diameter, math.inf, low_open=True)
        check_range("contact_angle", self.contact_angle, 0.0, math.pi / 2, high_open=True)
        check_range("inner_curvature", self.inner_curvature, 0.5, 1.0, low_open=True)
        check_range("outer_curvature", self.outer_curvature, 0.5, 1.0, low_open=True)
        check_positive("youngs_modulus", self.youngs_modulus)
        check_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        check_range("radial_clearance", self.radial_clearance, -MAX_INTERFERENCE * self.ball_diameter,
                    MAX_CLEARANCE * self.ball_diameter)
        check_nonnegative("axial_preload", self.axial_preload)
        check_finite("axial_preload", self.axial_preload)
        check_nonnegative("damping", self.damping)
        check_positive("ramp_depth", self.ramp_depth)
        _fit("n_balls", self.n_balls, self.ball_diameter, self.pitch_diameter)

    @property
    def groove_centre_distance(self):
        """A = (f_i + f_o - 1) D [m], the unloaded distance of the groove curvature centres."""
        return (self.inner_curvature + self.outer_curvature - 1.0) * self.ball_diameter

    @property
    def effective_modulus(self):
        """E' = E / (1 - nu^2) [Pa]."""
        return effective_modulus(self.youngs_modulus, self.poisson_ratio)

    @cached_property
    def hertz(self) -> HertzConstants:
        """Hertz constants at the free contact angle (complete elliptic integrals)."""
        return hertz_constants(ball_diameter=self.ball_diameter, pitch_diameter=self.pitch_diameter,
                               contact_angle=self.contact_angle, inner_curvature=self.inner_curvature,
                               outer_curvature=self.outer_curvature, youngs_modulus=self.youngs_modulus,
                               poisson_ratio=self.poisson_ratio, method="exact")

    @cached_property
    def stiffness_scale(self):
        """s_K = K_exact(alpha_0) / K_Hamrock-Brewe(alpha_0): the kernels' K(alpha) is the
        closed form times s_K, exact at the free angle (the curve fits give the angle dependence)."""
        return self.hertz.combined / float(ball_stiffness(np.cos(self.contact_angle), self.ball_diameter,
                                                          self.pitch_diameter, self.inner_curvature,
                                                          self.outer_curvature, self.effective_modulus)[0])

    @property
    def stiffness(self):
        """K [N m^-3/2] of one ball at the free contact angle (inner and outer contacts in series)."""
        return self.hertz.combined

    def stiffness_at(self, contact_angle):
        """K(alpha) [N m^-3/2] of one ball at working angle alpha [rad] (the kernels' law)."""
        return self.stiffness_scale * float(ball_stiffness(np.cos(contact_angle), self.ball_diameter,
                                                           self.pitch_diameter, self.inner_curvature,
                                                           self.outer_curvature, self.effective_modulus)[0])

    def axial_force_at(self, axial_approach):
        """Axial force [N] of the row at zero radial displacement and axial approach s_a [m]:
        Z K(alpha_w) delta^(3/2) sin(alpha_w), a = (A cos alpha_0, A sin alpha_0 + s_a), Eq. (ball_bearing)."""
        A, al = self.groove_centre_distance, self.contact_angle
        ar, az = A * math.cos(al), A * math.sin(al) + axial_approach
        L = math.hypot(ar, az)
        delta = max(L - A - self.radial_clearance, 0.0)
        return self.n_balls * self.stiffness_at(math.atan2(az, ar)) * delta ** 1.5 * az / L

    @cached_property
    def axial_preload_offset(self):
        """s_a [m]: the axial approach at which the row carries ``axial_preload`` (0 without preload)."""
        if self.axial_preload == 0:
            return 0.0
        from scipy.optimize import brentq
        hi = 1e-6
        while self.axial_force_at(hi) < self.axial_preload:
            hi *= 2
        return brentq(lambda s: self.axial_force_at(s) - self.axial_preload, 0.0, hi, xtol=1e-16, rtol=1e-14)


@dataclass(frozen=True, kw_only=True)
class AngularContactPair:
    """Two angular-contact rows ``rows`` = (row 0, row 1).

    row_spacing: the rows' axial distance [m] (row 0 at -spacing/2, row 1 at +spacing/2 from the
    mounting's axial centre). arrangement: "back_to_back" (contact lines diverge toward the
    axis: pressure centres outside the rows) or "face_to_face".

    end_play: the axial play of the pair [m] (each row held end_play / 2 off contact).
    interference: the axial overlap the pair is clamped through at assembly [m] (e.g. a ground
    spacer: each row pressed by interference / 2).
    Preload by axial displacement is declared one of three ways, at most one nonzero: the rows'
    ``axial_preload`` [N] (each row pressed to carry that force at zero external load), end_play or
    interference. Each row's axial approach s_a at zero external load is :attr:`axial_offsets`.

    In the planar model both rows carry radial load through their balls; the
    axial force and tilting moment of each row and of the pair are computed
    from the same element forces as observations (:meth:`BearingSet.resultants`).
    With a spatial flange (:class:`rvtool.bearings.spatial_set.SpatialBearingSet`) the
    axial and tilt displacements of the rings move every ball's approach and working
    angle, and the axial force and moments act on both bodies.

    RD-40 main bearing: ``AngularContactPair(rows=(row, row), row_spacing=0.040)``.
    """
    rows: tuple
    row_spacing: float
    arrangement: Arrangement = Arrangement.BACK_TO_BACK
    end_play: float = 0.0
    interference: float = 0.0

    def __post_init__(self):
        if not (isinstance(self.rows, (tuple, list)) and len(self.rows) == 2):
            raise RvtoolInputError(f"rows must hold 2 BallBearing rows; got {self.rows!r}")
        object.__setattr__(self, "rows", tuple(self.rows))
        for k, row in enumerate(self.rows):
            if not isinstance(row, BallBearing):
                raise RvtoolInputError(f"rows[{k}] must be a BallBearing; got {type(row).__name__}")
            if row.contact_angle <= 0:
                raise RvtoolInputError(f"rows[{k}].contact_angle = {row.contact_angle} is outside the valid range "
                                       "(0, pi/2) for an angular-contact pair")
        check_positive("row_spacing", self.row_spacing)
        _enum(self, "arrangement", Arrangement)
        d_min = min(r.ball_diameter for r in self.rows)
        # the small-deformation ball law: an axial play or overlap of at most 1 % of the ball diameter
        check_range("end_play", self.end_play, 0.0, 0.01 * d_min)
        check_range("interference", self.interference, 0.0, 0.01 * d_min)
        declared = [nm for nm, v in (("rows[].axial_preload", max(r.axial_preload for r in self.rows)),
                                     ("end_play", self.end_play), ("interference", self.interference)) if v > 0]
        if len(declared) > 1:
            raise RvtoolInputError(f"preload declared as {' and '.join(declared)}; valid: at most one of "
                                   "rows[].axial_preload [N], end_play [m], interference [m] > 0")

    @cached_property
    def axial_offsets(self):
        """(s_0, s_1) [m]: each row's axial approach at zero external load (positive presses the
        balls; Eq. (ball_bearing)'s s_a): the preload force's approach, -end_play / 2 or
        interference / 2."""
        if self.end_play > 0:
            return (-0.5 * self.end_play,) * 2
        if self.interference > 0:
            return (0.5 * self.interference,) * 2
        return tuple(r.axial_preload_offset for r in self.rows)

    def stations(self):
        """((axial position z [m], axial sense sigma) of row 0, of row 1): sigma is the sign
        of the axial component of a row's contact line; the line through a ball centre at
        (rho, z) meets the axis at z - sigma rho tan(alpha)."""
        s = 0.5 * self.row_spacing
        sig = 1.0 if self.arrangement == Arrangement.BACK_TO_BACK else -1.0
        return ((-s, sig), (s, -sig))


BEARING_TYPES = (CylindricalRollerBearing, BallBearing, AngularContactPair)
