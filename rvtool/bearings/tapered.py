"""Tapered roller bearings: a single row and a paired support (back-to-back or
face-to-face) with preload or end play; frozen, keyword-only, validated on
construction (errors name the parameter, its value and the valid range).

Geometry (paper, Section "Distributed bearing support and spatial load
sharing": "Tapered rollers additionally resolve cone geometry and, where
enabled, rib contact"). In the meridional plane (r, z) of a row whose roller
large ends face sigma e_z (sigma = +1 or -1):

* cup (outer raceway) half-angle alpha_o, the row's contact angle; cone
  (inner raceway) half-angle alpha_i < alpha_o; roller half-angle
  phi = (alpha_o - alpha_i) / 2 and roller axis at alpha_m = (alpha_o + alpha_i) / 2
  (an on-apex design: raceway and roller generators meet on the axis);
* roller centre C = (d_m / 2, z_row) at mid-length, axis e_a = (sin alpha_m, sigma cos alpha_m)
  from the small to the large end; cup normal n_o = (cos alpha_o, -sigma sin alpha_o),
  cone normal n_i = (cos alpha_i, -sigma sin alpha_i); contact lines through
  C +- (D_m cos(phi) / 2) n_{o,i} along the generators t = (sin alpha, sigma cos alpha);
* laminae: n_slices slices along the generator, each with Palmgren's line
  contact law (:func:`rvtool.bearings.hertz.roller_stiffness`, delta = 3.84e-5 Q^0.9 / l^0.8
  per raceway in mm and N, both raceways in series: Q = k delta^(10/9),
  Eq. (normal_force)) shared in proportion to the slice length, or its
  secant (linear law), minus the slice's crowning drop;
* rib: on the cone at the roller large end. ``rib_contact=False`` lumps cone
  and rib (rigid rib: each lamina transmits its load along the cup normal,
  the classical model whose load distribution follows Sjoevall's integrals
  with alpha = alpha_o); ``rib_contact=True`` resolves the roller's axial
  position against an elastic rib (Hertz point contact of the roller's
  spherical end, radius ``rib_end_radius``, on the flat rib face:
  F_f = (2/3) E' sqrt(R_e) delta_f^(3/2), E' = E / (1 - nu^2)); see
  :mod:`warp_contacts.tapered_rollers_ref`.

The cup normal through the middle of the roller's contact line meets the
axis at the row's load centre, z_row + sigma :attr:`TaperedRollerBearing.load_centre_offset`
(on the large-end side); a pair's effective spread is the distance between
its two load centres.

RV crank support (chosen, plausible for a 30204-class bearing)::

    row = TaperedRollerBearing(n_rollers=14, pitch_diameter=0.0335, roller_diameter=0.0055,
                               roller_length=0.010, cup_angle=math.radians(14.0),
                               cone_angle=math.radians(11.0))
    crank_bearing = TaperedPair(rows=(row, row), row_spacing=0.040, arrangement="back_to_back",
                                axial_preload=300.0)
"""
import math
import sys
from dataclasses import MISSING, dataclass, fields
from functools import cached_property, lru_cache

import numpy as np

from warp_contacts import tapered_rollers_ref as ref

from ..errors import RvtoolInputError
from ..units import angle_field, file_key, is_angle
from ..validation import check_finite, check_integer, check_nonnegative, check_positive, check_range
from .hertz import effective_modulus, roller_stiffness
from .influence import HalfWidth, SliceLaw, set_choice, slice_mean_crowning
from .spec import Arrangement, LaminaLaw

#: Largest cup angle [deg]: steep-angle tapered bearings reach about 30 deg; beyond 60 deg
#: the row is a thrust bearing, which this radial-row geometry does not describe.
MAX_CUP_ANGLE_DEG = 60.0
#: Largest roller half-angle [deg]: tapered rollers have phi of 1-5 deg; the rib balance
#: (kappa = 2 sin(phi)) and the on-apex geometry are used up to this bound.
MAX_ROLLER_HALF_ANGLE_DEG = 10.0



def _choice(obj, name, cls):
    """Replace a string field by its enum member."""
    value = getattr(obj, name)
    try:
        object.__setattr__(obj, name, cls(value))
    except ValueError:
        raise RvtoolInputError(f"{name} = {value!r} is not one of the valid choices {[m.value for m in cls]}") from None


@dataclass(frozen=True, kw_only=True)
class TaperedRollerBearing:
    """One row of a tapered roller bearing.

    n_rollers: Z, the number of rollers [-]. pitch_diameter: d_m, diameter of the circle of roller centres at
    mid-length [m]. roller_diameter: mean roller diameter D_m [m]. roller_length:
    effective contact length l along the generator [m].
    cup_angle: alpha_o, the cup half-angle (the row's contact angle), in (0, 60) deg [rad]
    (file: ``cup_angle_deg``).
    cone_angle: alpha_i, the cone half-angle, in [alpha_o - 20 deg, alpha_o) and >= 0 [rad]
    (file: ``cone_angle_deg``; the roller half-angle phi = (alpha_o - alpha_i) / 2 is in (0, 10] deg).
    n_slices: laminae per roller. crowning: end drop of a parabolic crown (scalar) or one
    drop per slice [m]. law: "power" (Palmgren 10/9) or "linear" (its secant at the reference
    roller load). reference_roller_load: the roller load [N] at which the "linear" law is the power
    law's secant.
    rib_contact: False (cone and rib lumped, rigid rib) or True (elastic rib, the roller's
    axial position resolved per roller; requires damping = 0).
    rib_end_radius: radius of the roller's spherical large end [m]; None: the apex
    distance of the roller's large end (the usual design, R_e close to it).
    rib_clearance: play between the roller end and the rib c_f [m].
    youngs_modulus: E of the rollers and rings [Pa] (rib contact). poisson_ratio: nu of the
    rollers and rings [-] (rib contact).
    damping: c_d per roller [N s/m] (shared by the laminae); ramp_depth: delta_r [m]
    of Eq. (normal_force).
    slices: "laminae" (default) or "influence" (the slices coupled by the half-space compliance of
    both races, Eq. (bearing_ic), :mod:`rvtool.bearings.influence`; with rib_contact = False; damping
    acts per slice in contact as for the laminae). half_width: "fixed" (at ``reference_roller_load``), "roller_load" or "slice_load".
    """
    n_rollers: int
    pitch_diameter: float
    roller_diameter: float
    roller_length: float
    cup_angle: float = angle_field()
    cone_angle: float = angle_field()
    n_slices: int = 4
    crowning: float | tuple = 0.0
    law: LaminaLaw = LaminaLaw.POWER
    reference_roller_load: float = 1000.0
    rib_contact: bool = False
    rib_end_radius: float | None = None
    rib_clearance: float = 0.0
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3
    damping: float = 0.0
    ramp_depth: float = 1e-6
    slices: SliceLaw = SliceLaw.LAMINAE
    half_width: HalfWidth = HalfWidth.FIXED

    def __post_init__(self):
        check_positive("roller_diameter", self.roller_diameter)
        check_range("pitch_diameter", self.pitch_diameter, self.roller_diameter, math.inf, low_open=True)
        # n D_m < pi d_m: the rollers fit around the pitch circle without touching
        fit = math.pi * self.pitch_diameter / self.roller_diameter     # inf for a subnormal roller_diameter
        check_integer("n_rollers", self.n_rollers, 3, math.ceil(fit) - 1 if math.isfinite(fit) else sys.maxsize)
        check_positive("roller_length", self.roller_length)
        # checked in degrees under the design file's keys (the spec holds radians)
        check_finite("cup_angle", self.cup_angle)
        check_finite("cone_angle", self.cone_angle)
        cup_deg, cone_deg = _degrees(self.cup_angle), _degrees(self.cone_angle)
        check_range("cup_angle_deg", cup_deg, 0.0, MAX_CUP_ANGLE_DEG, low_open=True, high_open=True)
        check_range("cone_angle_deg", cone_deg, max(0.0, cup_deg - 2 * MAX_ROLLER_HALF_ANGLE_DEG), cup_deg,
                    high_open=True)
        check_integer("n_slices", self.n_slices, 1, 64)
        crown = np.atleast_1d(np.asarray(self.crowning, dtype=float))
        if crown.shape not in ((1,), (self.n_slices,)):
            raise RvtoolInputError(f"crowning must be a number or hold n_slices = {self.n_slices} values; "
                                   f"got {crown.size}")
        check_range("crowning", crown, 0.0, 0.01 * self.roller_diameter)
        _choice(self, "law", LaminaLaw)
        check_positive("reference_roller_load", self.reference_roller_load)
        if not isinstance(self.rib_contact, (bool, np.bool_)):
            raise RvtoolInputError(f"rib_contact = {self.rib_contact!r} must be True or False")
        if self.rib_end_radius is not None:
            check_positive("rib_end_radius", self.rib_end_radius)
        check_range("rib_clearance", self.rib_clearance, 0.0, 0.01 * self.roller_diameter)
        check_positive("youngs_modulus", self.youngs_modulus)
        check_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        check_nonnegative("damping", self.damping)
        check_positive("ramp_depth", self.ramp_depth)
        if self.rib_contact and self.damping != 0:
            raise RvtoolInputError(f"damping = {self.damping} with rib_contact = True; valid range [0, 0]: the elastic-rib "
                                   "path finds the roller's axial position from the elastic balance only")
        set_choice(self, "slices", SliceLaw)
        set_choice(self, "half_width", HalfWidth)
        if self.slices == SliceLaw.INFLUENCE and self.rib_contact:
            raise RvtoolInputError("rib_contact = True with slices = 'influence'; valid: rib_contact = False (the "
                                   "influence slices use the lumped rigid rib)")
        # the roller's inner contact line must stay off the axis
        if self.pitch_diameter * math.cos(self.cone_angle) <= self.roller_diameter:
            raise RvtoolInputError(f"pitch_diameter = {self.pitch_diameter} m leaves no cone under rollers of "
                                   f"diameter {self.roller_diameter} m; valid range "
                                   f"({self.roller_diameter / math.cos(self.cone_angle)}, inf)")

    @classmethod
    def from_mapping(cls, data, key="tapered_bearing"):
        """Build from a mapping (a TOML table); errors name ``key.field``."""
        return _keyed(cls, _file_angles(cls, dict(data), key), key)

    # -- angles ----------------------------------------------------------
    @property
    def roller_half_angle(self):
        """phi = (alpha_o - alpha_i) / 2 [rad]."""
        return 0.5 * (self.cup_angle - self.cone_angle)

    @property
    def roller_axis_angle(self):
        """alpha_m = (alpha_o + alpha_i) / 2 [rad], the roller axis to the bearing axis."""
        return 0.5 * (self.cup_angle + self.cone_angle)

    @property
    def contact_angle(self):
        """alpha = alpha_o [rad], the angle of the load path (cup normal) to the radial plane."""
        return self.cup_angle

    # -- laws ------------------------------------------------------------
    @property
    def exponent(self):
        """p of the lamina law."""
        return 10.0 / 9.0 if self.law == LaminaLaw.POWER else 1.0

    @property
    def roller_coefficient(self):
        """Coefficient of the whole roller [N m^-p] (both raceways): Palmgren's k, or the secant
        Q_ref / delta(Q_ref) for the linear law."""
        k = roller_stiffness(self.roller_length)
        if self.law == LaminaLaw.POWER:
            return k
        return self.reference_roller_load / (self.reference_roller_load / k) ** 0.9

    @property
    def slice_positions(self):
        """Lamina centres along the generator from the roller's mid-length [m] (n_slices,)."""
        n = self.n_slices
        return ((np.arange(n) + 0.5) / n - 0.5) * self.roller_length

    @property
    def slice_crowning(self):
        """Crowning drop of each lamina [m]: per-slice values or (2 zeta / l)^2 times the end drop."""
        if np.ndim(self.crowning) == 0:
            return float(self.crowning) * (2 * self.slice_positions / self.roller_length) ** 2
        return np.asarray(self.crowning, dtype=float)

    @property
    def slice_stiffness(self):
        """Coefficient of each lamina [N m^-p]: the roller's in proportion to the slice length."""
        return np.full(self.n_slices, self.roller_coefficient / self.n_slices)

    @property
    def apex_distance(self):
        """Distance from the raceways' common apex on the axis to the roller large end's centre [m]."""
        return 0.5 * self.pitch_diameter / math.sin(self.roller_axis_angle) + 0.5 * self.roller_length

    @property
    def rib_stiffness(self):
        """K_f [N m^-3/2] of the rib contact: sphere of radius R_e on a flat, (2/3) E' sqrt(R_e)."""
        radius = self.apex_distance if self.rib_end_radius is None else self.rib_end_radius
        return 2.0 / 3.0 * effective_modulus(self.youngs_modulus, self.poisson_ratio) * math.sqrt(radius)

    # -- meridional geometry (row frame, sense sigma) ----------------------
    def meridional(self, sigma=1.0):
        """Contact geometry in the meridional plane for a row whose large ends face sigma e_z,
        centred at z = 0: dict of (rho, z) points and (n_r, n_z) unit vectors: ``cup`` and
        ``cone`` lamina points (n_slices, 2), ``n_cup``, ``n_cone``, ``axis`` (e_a), ``rib``
        point (2,)."""
        ao, ai, am, phi = self.cup_angle, self.cone_angle, self.roller_axis_angle, self.roller_half_angle
        centre = np.array([0.5 * self.pitch_diameter, 0.0])
        n_o = np.array([math.cos(ao), -sigma * math.sin(ao)])
        n_i = np.array([math.cos(ai), -sigma * math.sin(ai)])
        t_o = np.array([math.sin(ao), sigma * math.cos(ao)])
        t_i = np.array([math.sin(ai), sigma * math.cos(ai)])
        e_a = np.array([math.sin(am), sigma * math.cos(am)])
        half = 0.5 * self.roller_diameter * math.cos(phi)
        zeta = self.slice_positions[:, None]
        return {"cup": centre + half * n_o + zeta * t_o, "cone": centre - half * n_i + zeta * t_i,
                "n_cup": n_o, "n_cone": n_i, "axis": e_a, "rib": centre + 0.5 * self.roller_length * e_a}

    @property
    def load_centre_offset(self):
        """Axial distance [m] from the row's station to the point where the cup normal through the
        contact line's mid-point meets the axis, toward the large ends (the effective load centre)."""
        m = self.meridional(1.0)
        rho, z = np.mean(m["cup"], axis=0)
        return float(z + rho * math.tan(self.cup_angle))

    def pack(self, *, station=0.0, sigma=1.0, axial_predisplacement=0.0):
        """Kernel parameters of this row: (roller rows (Z, N_ROLLER_FLOAT), roller int rows
        (Z, N_ROLLER_INT) with lamina indices from 0, lamina rows (Z n_slices, N_LAMINA_FLOAT)),
        for a row at axial ``station`` [m] with large ends toward sigma e_z and the cone pre-displaced
        axially by ``axial_predisplacement`` [m]."""
        m = self.meridional(sigma)
        shift = np.array([0.0, station])
        if self.rib_contact:
            pts, n = m["cone"] + shift, m["n_cone"]
        else:
            pts, n = m["cup"] + shift, m["n_cup"]
        ns, Z = self.n_slices, self.n_rollers
        lam = np.zeros((ns, ref.N_LAMINA_FLOAT))
        lam[:, ref.LA_RHO], lam[:, ref.LA_Z] = pts[:, 0], pts[:, 1]
        lam[:, ref.LA_NR], lam[:, ref.LA_NZ] = n
        lam[:, ref.LA_K], lam[:, ref.LA_P] = self.slice_stiffness, self.exponent
        lam[:, ref.LA_OFF] = slice_mean_crowning(self) if self.slices == SliceLaw.INFLUENCE else self.slice_crowning
        lam[:, ref.LA_DAMP], lam[:, ref.LA_RAMP] = self.damping / ns, self.ramp_depth
        roller = np.zeros(ref.N_ROLLER_FLOAT)
        roller[ref.RL_KF], roller[ref.RL_CF] = self.rib_stiffness, self.rib_clearance
        roller[ref.RL_FRHO], roller[ref.RL_FZ] = m["rib"] + shift
        roller[ref.RL_FNR], roller[ref.RL_FNZ] = m["axis"]
        roller[ref.RL_KAPPA] = 2.0 * math.sin(self.roller_half_angle)
        roller[ref.RL_ZPRE] = axial_predisplacement
        rint = np.zeros((Z, ref.N_ROLLER_INT), dtype=np.int32)
        rint[:, ref.RI_FIRST] = ns * np.arange(Z)
        rint[:, ref.RI_COUNT] = ns
        rint[:, ref.RI_RIB] = int(bool(self.rib_contact))
        return np.tile(roller, (Z, 1)), rint, np.tile(lam, (Z, 1))

    def axial_force_at(self, axial_approach):
        """Axial force [N] of the row (its rollers all alike) when the cone moves by ``axial_approach``
        [m] toward its loaded direction (-sigma e_z), no radial or tilt displacement."""
        rf, ri, lf = self.pack(sigma=1.0)
        q = np.array([[0.0, 0.0, -axial_approach, 0.0, 0.0]])
        if self.slices == SliceLaw.INFLUENCE:
            # the row's own law: the slice solve of one roller (the rollers all alike)
            from warp_contacts import roller_slices_ref as sref
            from .influence import bearing_slice_parameters
            s, g, h, qe, bf = ref.influence_approaches(q, np.zeros(1), rf[:1], lf, np.arange(self.n_slices)[None, :])
            sf, si = bearing_slice_parameters(self)
            F, J, _, _ = sref.evaluate(s, sf[None, :], si[None, :])
            f = ref.influence_wrench(F, J, g, h, qe, rf[:1, ref.RL_KAPPA], bf)[0]   # no damping at rest
        else:
            f = ref.evaluate(q, np.zeros((1, 5)), np.zeros(1), np.zeros(1), rf[:1], ri[:1], lf[:self.n_slices])[0]
        return float(f[0, 2]) * self.n_rollers

    def axial_approach_for(self, axial_force):
        """s_a [m]: the axial approach at which the row carries ``axial_force`` [N] (>= 0)."""
        check_nonnegative("axial_force", axial_force)
        if axial_force == 0:
            return 0.0
        from scipy.optimize import brentq
        off = float(np.max(self.slice_crowning))
        hi = 1e-6 + off / math.sin(self.cup_angle)
        while self.axial_force_at(hi) < axial_force:
            hi *= 2
        return brentq(lambda s: self.axial_force_at(s) - axial_force, 0.0, hi, xtol=1e-18, rtol=1e-14)


@dataclass(frozen=True, kw_only=True)
class TaperedPair:
    """Two tapered rows on one shaft: ``rows`` = (row 0, row 1).

    row_spacing: the rows' axial distance [m], row 0 at -row_spacing/2 and row 1 at +row_spacing/2
    from the mounting's axial centre (stations of the roller mid-points).

    arrangement: "back_to_back" (O: large ends face away from each other, load centres outside
    the rows, effective spread row_spacing + both load-centre offsets) or "face_to_face" (X:
    load centres inside, spread row_spacing - the offsets).
    axial_preload: F_p [N], the axial force each row carries at zero external load (the
    cones pressed into their cups by s_k = :meth:`TaperedRollerBearing.axial_approach_for`).
    end_play: axial play of the pair [m] (each cone held s_k = -end_play / 2 off its cup).
    At most one of axial_preload and end_play is nonzero.

    The pair's axial force and tilting moment are part of the 5-DOF wrench
    (:mod:`rvtool.bearings.tapered_set`); in planar use they are observations.
    """
    rows: tuple
    row_spacing: float
    arrangement: Arrangement = Arrangement.BACK_TO_BACK
    axial_preload: float = 0.0
    end_play: float = 0.0

    def __post_init__(self):
        if not (isinstance(self.rows, (tuple, list)) and len(self.rows) == 2):
            raise RvtoolInputError(f"rows must hold 2 TaperedRollerBearing rows; got {self.rows!r}")
        object.__setattr__(self, "rows", tuple(self.rows))
        for k, row in enumerate(self.rows):
            if not isinstance(row, TaperedRollerBearing):
                raise RvtoolInputError(f"rows[{k}] must be a TaperedRollerBearing; got {type(row).__name__}")
        _choice(self, "arrangement", Arrangement)
        # the rows' rollers must not overlap axially
        width = max(r.roller_length * math.cos(r.roller_axis_angle) + r.roller_diameter for r in self.rows)
        check_range("row_spacing", self.row_spacing, width, math.inf)
        check_nonnegative("axial_preload", self.axial_preload)
        check_finite("axial_preload", self.axial_preload)
        check_range("end_play", self.end_play, 0.0, 0.01 * min(r.roller_diameter for r in self.rows))
        if self.axial_preload > 0 and self.end_play > 0:
            raise RvtoolInputError(f"axial_preload = {self.axial_preload} N and end_play = {self.end_play} m are both "
                                   "nonzero; valid: at most one of them > 0")
        if self.arrangement == Arrangement.FACE_TO_FACE and self.effective_spread <= 0:
            raise RvtoolInputError(f"row_spacing = {self.row_spacing} m puts the load centres of the face-to-face pair "
                                   f"past each other; valid range ({self.row_spacing - self.effective_spread}, inf)")

    @classmethod
    def from_mapping(cls, data, key="tapered_pair"):
        """Build from a mapping with ``rows`` a list of two row tables (or ``row``, one table for
        both rows); errors name ``key.field`` or ``key.rows[k].field``."""
        data = dict(data)
        if "row" in data:
            table = data.pop("row")
            data["rows"] = (table, table)
        rows = data.get("rows")
        if not (isinstance(rows, (tuple, list)) and len(rows) == 2):
            raise RvtoolInputError(f"{key}.rows must hold 2 row tables; got {rows!r}")
        data["rows"] = tuple(r if isinstance(r, TaperedRollerBearing) else TaperedRollerBearing.from_mapping(
            r, f"{key}.rows[{k}]") for k, r in enumerate(rows))
        return _keyed(cls, data, key)

    @property
    def senses(self):
        """(sigma_0, sigma_1): the direction of each row's large ends along e_z."""
        return (-1.0, 1.0) if self.arrangement == Arrangement.BACK_TO_BACK else (1.0, -1.0)

    @property
    def stations(self):
        """(z_0, z_1) [m] of the rows' roller mid-points."""
        return (-0.5 * self.row_spacing, 0.5 * self.row_spacing)

    @property
    def load_centres(self):
        """(z_c0, z_c1) [m]: where each row's cup pressure line meets the axis."""
        return tuple(z + s * r.load_centre_offset for z, s, r in zip(self.stations, self.senses, self.rows))

    @property
    def effective_spread(self):
        """z_c1 - z_c0 [m]: the lever arm of the pair against a tilting moment."""
        c0, c1 = self.load_centres
        return c1 - c0

    @cached_property
    def axial_predisplacements(self):
        """(s_0, s_1) [m]: each cone's axial displacement into its cup (signed along e_z) that
        carries the preload, or opens half the end play."""
        out = []
        for row, sigma in zip(self.rows, self.senses):
            s = _axial_approach(row, self.axial_preload) if self.axial_preload > 0 else -0.5 * self.end_play
            out.append(-sigma * s)          # the loaded direction of a row is -sigma e_z
        return tuple(out)


@lru_cache(maxsize=256)
def _approach_cached(row, force):
    return row.axial_approach_for(force)


def _axial_approach(row, force):
    """``row.axial_approach_for(force)`` computed once per (row, force) in a process (rows are frozen:
    Monte Carlo variants share their crank bearings; a root search of ~14 ms); an unhashable row
    each time."""
    try:
        hash(row)
    except TypeError:
        return row.axial_approach_for(force)
    return _approach_cached(row, float(force))


def _degrees(x):
    """An angle [rad] in degrees, rounded to 12 digits so that a file's 14.0 deg reads back as 14.0."""
    return float(f"{math.degrees(x):.12g}") if math.isfinite(x) else x


def _file_angles(cls, data, key):
    """A design-file table with its ``NAME_deg`` keys [deg] as the angle fields NAME [rad] of ``cls``
    (the loader's unit rule, :func:`rvtool.assembly.spec.build_section`)."""
    out = dict(data)
    for f in fields(cls):
        if not is_angle(f):
            continue
        if f.name in out:
            raise RvtoolInputError(f"{key}.{f.name}: a design file gives this angle in degrees as {f.name}_deg")
        if f.name + "_deg" in out:
            v = out.pop(f.name + "_deg")
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise RvtoolInputError(f"{key}.{f.name}_deg = {v!r} must be a number of degrees")
            out[f.name] = math.radians(v)
    return out


def _keyed(cls, data, key):
    """cls(**data), every input error prefixed with ``key.``; unknown fields named with the valid ones."""
    names = {f.name for f in fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:     # the valid keys as the design file writes them (an angle as NAME_deg)
        raise RvtoolInputError(f"{key}.{unknown[0]} is not a parameter of {cls.__name__}; valid: "
                               f"{sorted(file_key(f) for f in fields(cls))}")
    try:
        return cls(**data)
    except TypeError as exc:            # a missing required field, named as the file writes it
        missing = [file_key(f) for f in fields(cls) if f.init and f.name not in data
                   and f.default is MISSING and f.default_factory is MISSING]
        if not missing:
            raise RvtoolInputError(f"{key}: {exc}") from None
        raise RvtoolInputError(f"[{key}] is missing the required key{'s' if len(missing) > 1 else ''} "
                               f"{', '.join(f'{key}.{m}' for m in missing)}; 'rvtool new' writes every key with its "
                               "unit and valid range") from None
    except RvtoolInputError as exc:
        msg = str(exc)
        raise RvtoolInputError(msg if msg.startswith(key) else f"{key}.{msg}") from None
