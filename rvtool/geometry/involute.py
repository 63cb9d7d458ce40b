"""Involute spur gears: basic rack, tooth geometry, flank modifications, pitch
deviations, the ISO 21771 quantities of a pair and its feasibility checks.

Flank, Eq. (involute_geometry): with roll angle u (= tan of the profile angle),

    c_inv(u) = r_b [cos u + u sin u, sin u - u cos u],   c_mod(u) = c_inv(u) + e(u) n(u),

the canonical flank that unwinds counter-clockwise from the base-circle point at
polar angle 0. A flank of tooth k is this curve (or its mirror image) turned to
its start angle phi_0 on the base circle; its normal line at roll u is the
tangent to the base circle at phi_T = phi_0 + omega u (omega = +1 counter-clockwise,
-1 clockwise unwinding), and the flank point lies r_b u along that tangent:

    c = O + r_b e(phi_T) + r_b u d_T,   d_T = -omega perp(e(phi_T)),   e(phi) = (cos phi, sin phi).

For an external tooth d_T is the outward normal (material behind the flank); for an
internal (ring) tooth the material lies ahead of it, so the outward normal is -d_T.

Conventions (stated because ISO 21771 writes internal gears with negative tooth
counts and we do not): ``n_teeth`` is always positive and ``internal`` selects a ring
gear. The profile shift x follows ISO 21771 / DIN 3960 in both cases: positive x moves
the basic rack away from the gear body, which thickens the tooth on the reference
circle, s = m (pi/2 + 2 x tan alpha) - A_s, and moves the tips outward (external,
r_a = r + m (h_aP* + x)) or inward (internal, r_a = r - m (h_aP* + x)). A_s is the
tooth thickness allowance (positive removes material; it makes the backlash).

Modification e(u, z) [m] along the outward normal, positive removing material:
tip relief C_a from the roll angle of its start diameter d_Ca to the tip, root relief
C_f from d_Cf to the root form circle, each linear or parabolic in the roll angle
(proportional to the roll length, as ISO 21771 measures them); profile crowning C_alpha
(parabolic over the involute from the root form circle to the tip, C_alpha at both ends);
lead crowning C_beta (parabolic, C_beta at both face ends) and helix slope deviation
f_Hbeta (linear, +f_Hbeta/2 at z = +b/2). Single pitch deviations f_pt,k turn tooth k
rigidly by F_k / r_b with F_k = sum_{i<=k} f_pt,i (the cumulative pitch deviation).

Internal gears are idealized as rack-generated (their root form circle follows from the
basic rack, mirrored); a pinion-type cutter, which makes real ring gears, is not modelled.
"""
from dataclasses import dataclass, field
import math

import numpy as np

from ..errors import RvtoolInputError
from ..units import angle_field
from ..validation import check_finite, check_nonnegative, check_positive, check_range


def inv(alpha):
    """Involute function inv(alpha) = tan(alpha) - alpha [rad]."""
    return np.tan(alpha) - alpha


def inv_inverse(value):
    """alpha with inv(alpha) = value (Newton on tan a - a, from a cube-root start; 1e-15 rad)."""
    value = float(value)
    if not value >= 0.0:
        raise RvtoolInputError(f"inv(alpha) = {value!r} has no solution; valid range [0, inf)")
    a = (3.0 * value) ** (1.0 / 3.0)
    for _ in range(50):
        step = (math.tan(a) - a - value) / math.tan(a) ** 2 if a > 0 else 0.0
        a -= step
        if abs(step) < 1e-16:
            break
    return a


MIN_MODULE = 1e-6
"""Smallest module accepted [m] (see :class:`InvoluteGear`)."""


@dataclass(frozen=True, kw_only=True)
class BasicRack:
    """Basic rack tooth profile (ISO 53), coefficients relative to the module.

    pressure_angle: alpha_P, the profile angle of the rack [rad]. addendum_coefficient: h_aP*,
    the gear addendum over the module [-]. dedendum_coefficient: h_fP*, the dedendum over the
    module [-]. root_radius_coefficient: rho_fP*, the tip rounding of the generating rack (the
    root fillet radius of the basic rack) over the module [-]. name: the rack's label.
    """
    pressure_angle: float = angle_field(math.radians(20.0))
    addendum_coefficient: float = 1.0
    dedendum_coefficient: float = 1.25
    root_radius_coefficient: float = 0.38
    name: str = "ISO 53 profile A"

    def __post_init__(self):
        check_range("rack.pressure_angle", self.pressure_angle, 0.0, math.radians(45.0), low_open=True, high_open=True)
        check_positive("rack.addendum_coefficient", self.addendum_coefficient)
        check_range("rack.dedendum_coefficient", self.dedendum_coefficient, self.addendum_coefficient, math.inf,
                    low_open=True)
        a = self.pressure_angle
        # the rounding must fit on the generating rack's tooth tip: its land half-width is
        # pi/4 - h_fP* tan(alpha), the rounding uses rho (1 - sin alpha) / cos alpha of it
        rho_max = (math.pi / 4 - self.dedendum_coefficient * math.tan(a)) * math.cos(a) / (1 - math.sin(a))
        check_range("rack.root_radius_coefficient", self.root_radius_coefficient, 0.0, rho_max)

    @property
    def form_height_coefficient(self):
        """h_FfP* = h_fP* - rho_fP* (1 - sin alpha): depth of the end of the straight flank."""
        return self.dedendum_coefficient - self.root_radius_coefficient * (1 - math.sin(self.pressure_angle))


ISO53_PROFILE_A = BasicRack()
ISO53_PROFILE_B = BasicRack(root_radius_coefficient=0.30, name="ISO 53 profile B")
ISO53_PROFILE_C = BasicRack(root_radius_coefficient=0.25, name="ISO 53 profile C")
ISO53_PROFILE_D = BasicRack(dedendum_coefficient=1.40, root_radius_coefficient=0.39, name="ISO 53 profile D")

RELIEF_EXPONENTS = {"linear": 1.0, "parabolic": 2.0}


@dataclass(frozen=True, kw_only=True)
class FlankModification:
    """Flank modification e(u, z) [m] along the outward normal (positive removes material).

    tip_relief: C_a [m] at the tip; tip_relief_diameter: d_Ca [m] where it starts.
    root_relief: C_f [m] at the root form circle; root_relief_diameter: d_Cf [m] where it starts.
    relief_shape: "linear" or "parabolic" in the roll angle (both reliefs).
    profile_crowning: C_alpha [m]; lead_crowning: C_beta [m]; helix_slope_deviation: f_Hbeta [m].
    """
    tip_relief: float = 0.0
    tip_relief_diameter: float | None = None
    root_relief: float = 0.0
    root_relief_diameter: float | None = None
    relief_shape: str = "linear"
    profile_crowning: float = 0.0
    lead_crowning: float = 0.0
    helix_slope_deviation: float = 0.0

    def __post_init__(self):
        for nm in ("tip_relief", "root_relief", "profile_crowning", "lead_crowning"):
            check_nonnegative(f"modification.{nm}", getattr(self, nm))
        check_finite("modification.helix_slope_deviation", self.helix_slope_deviation)
        if self.relief_shape not in RELIEF_EXPONENTS:
            raise RvtoolInputError(f"modification.relief_shape = {self.relief_shape!r} is not valid; "
                                   f"valid choices are {sorted(RELIEF_EXPONENTS)}")
        for amount, dia in (("tip_relief", "tip_relief_diameter"), ("root_relief", "root_relief_diameter")):
            if getattr(self, amount) > 0 and getattr(self, dia) is None:
                raise RvtoolInputError(f"modification.{dia} must be given when modification.{amount} > 0 "
                                       "(valid range: a diameter inside the involute) [m]")
            if getattr(self, dia) is not None:
                check_positive(f"modification.{dia}", getattr(self, dia))


@dataclass(frozen=True, kw_only=True)
class InvoluteGear:
    """One involute spur gear (external or internal).

    module: m [m]; n_teeth: z, the number of teeth [-]; face_width: b [m]; profile_shift: x [-];
    internal: true for a ring gear; rack: :class:`BasicRack` (ISO 53 profile A by default).
    tip_diameter: d_a [m] (default from the rack: d + 2 m (h_aP* + x), internal d - 2 m (h_aP* + x)).
    thickness_allowance: A_s [m], tooth thickness reduction on the reference circle (backlash).
    tip_edge_radius: rho_e [m] of the rounded tip edge used for corner contact
    (default 0.02 m: a chosen small edge break, declared here).
    bore_diameter: d_i [m] of the gear body (fillet-foundation compliance; default 0.5 d_f, chosen).
    youngs_modulus: E of the gear's material [Pa] (default steel, 206 GPa). poisson_ratio: nu of
    the gear's material [-] (default 0.3).
    modification: :class:`FlankModification` (the same on both flanks of every tooth).
    single_pitch_deviations: f_pt,k [m] for k = 0..z-1 (f_pt,k between tooth k-1 and k);
    they must sum to zero (a closed circle), see ISO 1328-1.
    min_tip_thickness: smallest admissible tooth thickness on the tip circle [m] (default 0: pointed).
    """
    module: float
    n_teeth: int
    face_width: float
    profile_shift: float = 0.0
    internal: bool = False
    rack: BasicRack = ISO53_PROFILE_A
    tip_diameter: float | None = None
    thickness_allowance: float = 0.0
    tip_edge_radius: float | None = None
    bore_diameter: float | None = None
    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3
    modification: FlankModification = field(default_factory=FlankModification)
    single_pitch_deviations: tuple | None = None
    min_tip_thickness: float = 0.0
    name: str = "gear"

    def __post_init__(self):
        p = self.name
        # assumed floor: 50x below the finest manufactured modules (0.05 mm, fine-pitch instrument
        # gears); below it squared lengths of the tooth geometry underflow (a module of 5e-324 m
        # divided by zero, found by tests/test_design_fuzz.py::test_template_in_range_fuzz)
        check_range(f"{p}.module", self.module, MIN_MODULE, math.inf)
        z = self.n_teeth
        if isinstance(z, bool) or not isinstance(z, (int, np.integer)) or z < 3:
            raise RvtoolInputError(f"{p}.n_teeth = {z!r} is outside the valid range [3, inf) (integer)")
        check_positive(f"{p}.face_width", self.face_width)
        check_range(f"{p}.profile_shift", self.profile_shift, -2.0, 2.0)
        check_finite(f"{p}.thickness_allowance", self.thickness_allowance)
        check_positive(f"{p}.youngs_modulus", self.youngs_modulus)
        check_range(f"{p}.poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        check_nonnegative(f"{p}.min_tip_thickness", self.min_tip_thickness)
        if self.tip_diameter is not None:
            check_positive(f"{p}.tip_diameter", self.tip_diameter)
        if self.tip_edge_radius is not None:
            check_range(f"{p}.tip_edge_radius", self.tip_edge_radius, 0.0, 0.2 * self.module, low_open=True)
        if self.bore_diameter is not None:
            check_range(f"{p}.bore_diameter", self.bore_diameter, 0.0, 2 * self.root_radius, low_open=True, high_open=True)
        if self.single_pitch_deviations is not None:
            f = np.asarray(self.single_pitch_deviations, float)
            if f.shape != (z,):
                raise RvtoolInputError(f"{p}.single_pitch_deviations must have shape ({z},); got {f.shape}")
            check_finite(f"{p}.single_pitch_deviations", f)
            if abs(f.sum()) > 1e-9 * max(1.0, np.abs(f).sum()) + 1e-15:
                raise RvtoolInputError(f"{p}.single_pitch_deviations sum to {f.sum():.3g} m; valid: sum 0 "
                                       "(the pitches of a closed circle add up to its circumference)")
        self._check_feasible()

    # -- ISO 21771 dimensions ------------------------------------------------
    @property
    def alpha(self):
        return self.rack.pressure_angle

    @property
    def eps(self):
        """+1 external, -1 internal: the outward normal is eps d_T."""
        return -1.0 if self.internal else 1.0

    @property
    def reference_radius(self):
        return 0.5 * self.module * self.n_teeth

    @property
    def base_radius(self):
        return self.reference_radius * math.cos(self.alpha)

    @property
    def base_pitch(self):
        return math.pi * self.module * math.cos(self.alpha)

    @property
    def tip_radius(self):
        if self.tip_diameter is not None:
            return 0.5 * self.tip_diameter
        return self.reference_radius + self.eps * self.module * (self.rack.addendum_coefficient + self.profile_shift)

    @property
    def root_radius(self):
        return self.reference_radius - self.eps * self.module * (self.rack.dedendum_coefficient - self.profile_shift)

    @property
    def edge_radius(self):
        """rho_e [m] (the declared default 0.02 m when not given)."""
        return 0.02 * self.module if self.tip_edge_radius is None else self.tip_edge_radius

    @property
    def bore_radius(self):
        return 0.5 * (self.bore_diameter if self.bore_diameter is not None else self.root_radius)

    @property
    def reference_thickness(self):
        """s = m (pi/2 + 2 x tan alpha) - A_s [m], arc on the reference circle."""
        return self.module * (math.pi / 2 + 2 * self.profile_shift * math.tan(self.alpha)) - self.thickness_allowance

    @property
    def base_half_angle(self):
        """psi_b [rad]: polar half-angle of the tooth where its flanks' involutes start (the
        flank start angles are gamma_k -+ psi_b, external; gamma_k +- psi_b, internal)."""
        return self.reference_thickness / (2 * self.reference_radius) + self.eps * float(inv(self.alpha))

    def half_angle(self, radius):
        """Polar half-angle of the tooth at ``radius`` [m] (involute part)."""
        a_r = np.arccos(self.base_radius / np.asarray(radius, float))
        return self.base_half_angle - self.eps * inv(a_r)

    def roll(self, radius):
        """Roll angle u = sqrt(r^2 / r_b^2 - 1) of the involute point at ``radius`` [m]."""
        return np.sqrt(np.asarray(radius, float) ** 2 / self.base_radius ** 2 - 1.0)

    def radius_of_roll(self, u):
        return self.base_radius * np.sqrt(1.0 + np.asarray(u, float) ** 2)

    @property
    def form_roll(self):
        """u_Ff: roll angle where the generated involute ends at the root (rack-generated)."""
        a = self.alpha
        h = (self.rack.form_height_coefficient - self.profile_shift) * self.module
        return (self.reference_radius * math.sin(a) - self.eps * h / math.sin(a)) / self.base_radius

    @property
    def tip_roll(self):
        return float(self.roll(self.tip_radius))

    @property
    def edge(self):
        """(u_e, rho_c, chi): roll angle where the flank meets the rounded tip edge, and the polar
        radius and angle (from the flank start, canonical flank) of the edge-rounding centre."""
        rb, rho, e = self.base_radius, self.edge_radius, self.eps
        rc = self.tip_radius - e * rho
        L = math.sqrt(rc * rc - rb * rb)
        ue = (L + e * rho) / rb
        return ue, rc, ue - math.atan2(L, rb)

    @property
    def involute_range(self):
        """(u_lo, u_hi): roll-angle interval of the flank that can carry conjugate contact
        (root form circle to the start of the edge rounding)."""
        ue = self.edge[0]
        return (self.form_roll, ue) if not self.internal else (ue, self.form_roll)

    def tooth_angles(self):
        """Angular positions [rad] of the tooth centre lines, pitch deviations included."""
        z = self.n_teeth
        g = 2 * np.pi * np.arange(z) / z
        return g + self.pitch_deviation_angles()

    def pitch_deviation_angles(self):
        """Rigid turn F_k / r_b [rad] of tooth k from the cumulative pitch deviation."""
        if self.single_pitch_deviations is None:
            return np.zeros(self.n_teeth)
        f = np.asarray(self.single_pitch_deviations, float)
        F = np.concatenate([[0.0], np.cumsum(f[1:])])
        return F / self.base_radius

    # -- modification e(u, z) ---------------------------------------------------
    def modification_parameters(self):
        """(u_tip, u_Ca, C_a, q_a, u_root, u_Cf, C_f, q_f, C_alpha, u_mid, u_half, C_beta, f_Hbeta, b):
        the numbers of e(u, z) (see :func:`modification_value`)."""
        md = self.modification
        q = RELIEF_EXPONENTS[md.relief_shape]
        u_tip, u_root = self.tip_roll, self.form_roll
        u_ca = float(self.roll(0.5 * md.tip_relief_diameter)) if md.tip_relief > 0 else u_tip
        u_cf = float(self.roll(0.5 * md.root_relief_diameter)) if md.root_relief > 0 else u_root
        return (u_tip, u_ca, md.tip_relief, q, u_root, u_cf, md.root_relief, q, md.profile_crowning,
                0.5 * (u_tip + u_root), 0.5 * abs(u_tip - u_root), md.lead_crowning, md.helix_slope_deviation,
                self.face_width)

    def _check_feasible(self):
        p, m, z, a = self.name, self.module, self.n_teeth, self.alpha
        rb, ra = self.base_radius, self.tip_radius
        if ra <= rb * (1 + 1e-9):
            raise RvtoolInputError(f"{p}.tip_diameter = {2 * ra:.6g} m lies inside the base circle (d_b = {2 * rb:.6g} m): "
                                   f"no involute at the tip; valid range ({2 * rb:.6g}, inf) m")
        if self.internal and ra >= self.root_radius:
            raise RvtoolInputError(f"{p}.tip_diameter = {2 * ra:.6g} m is outside the valid range (d_b, d_f) = "
                                   f"({2 * rb:.6g}, {2 * self.root_radius:.6g}) m of an internal gear")
        if not self.internal and self.form_roll < 0:
            x_min = self.rack.form_height_coefficient - 0.5 * z * math.sin(a) ** 2
            raise RvtoolInputError(f"{p}.profile_shift = {self.profile_shift} undercuts the tooth (the rack's straight "
                                   f"flank ends inside the base circle); valid range [{x_min:.4f}, inf) for z = {z} "
                                   f"and {p}.rack.pressure_angle_deg = {math.degrees(a):.6g}")
        s_a = 2 * ra * float(self.half_angle(ra))
        if s_a <= self.min_tip_thickness:
            raise RvtoolInputError(f"{p}.tip_diameter = {2 * ra:.6g} m gives a pointed tip (tooth thickness at the tip "
                                   f"{s_a:.4g} m); valid: tip thickness > {self.min_tip_thickness} m "
                                   f"(reduce {p}.profile_shift = {self.profile_shift} or {p}.tip_diameter"
                                   # "the allowance (KEY, X m)": a range probe reads "KEY =" as a message about KEY
                                   + (f", or the thickness allowance ({p}.thickness_allowance, "
                                      f"{self.thickness_allowance:.6g} m)" if self.thickness_allowance else "") + ")")
        if 2 * self.edge_radius >= s_a:
            raise RvtoolInputError(f"{p}.tip_edge_radius = {self.edge_radius:.4g} m is outside the valid range "
                                   f"(0, {0.5 * s_a:.4g}) m (half the tip thickness)")
        lo, hi = self.involute_range
        if not lo < hi:
            raise RvtoolInputError(f"{p}: the root form circle (u_Ff = {self.form_roll:.4f}) lies beyond the tip edge "
                                   f"(u_e = {self.edge[0]:.4f}); no usable involute (check profile_shift, tip_diameter)")

    # -- profile points (plots, tooth sections) ---------------------------------
    def flank_points(self, u, z=0.0, k=0, side=+1):
        """Points of flank ``side`` (+1: counter-clockwise side of the tooth) of tooth k at roll
        angles u, modification included (Eq. (involute_geometry)); gear coordinates [m]."""
        u = np.asarray(u, float)
        omega = -side * self.eps
        phi0 = self.tooth_angles()[k] + side * self.base_half_angle
        phit = phi0 + omega * u
        et = np.stack([np.cos(phit), np.sin(phit)], -1)
        dT = -omega * np.stack([-et[..., 1], et[..., 0]], -1)
        e = modification_value(self.modification_parameters(), u, z)[0]
        return self.base_radius * et + (self.base_radius * u)[..., None] * dT + (self.eps * e)[..., None] * dT

    def root_fillet(self, n=60):
        """Root fillet of the ccw flank of tooth 0 (external gears): the envelope of the generating
        rack's tip rounding (a trochoid offset), from the root circle to the root form circle.

        The rack rolls on the reference circle; its tip-rounding centre C sits rho above the tip
        line, rho / cos(alpha) inside the flank line; the generated point is the point of the
        rounding whose normal passes through the pitch point I (Willis), C - rho (I - C)/|I - C|.
        Returns (n, 2) points [m] in gear coordinates, root first.
        """
        if self.internal:
            raise RvtoolInputError(f"{self.name}.internal = True: the trochoid fillet is defined for rack-generated "
                                   "external gears only")
        m, a, r, x = self.module, self.alpha, self.reference_radius, self.profile_shift
        rho = self.rack.root_radius_coefficient * m
        y_c = r + x * m - self.rack.dedendum_coefficient * m + rho
        x_c = (math.pi * m / 4 + 0.5 * self.thickness_allowance - (r + x * m - y_c) * math.tan(a)) - rho / math.cos(a)
        phi_root = x_c / r
        phi_form = (x_c - (r - y_c) / math.tan(a)) / r
        phi = np.linspace(phi_root, phi_form, n)
        C = np.column_stack([x_c - r * phi, np.full(n, y_c)])
        I = np.array([0.0, r])
        d = I - C
        P = C - rho * d / np.linalg.norm(d, axis=1)[:, None]
        # into gear coordinates (gear turned by phi), then from the space at +y to tooth 0's ccw flank:
        # the tooth right of that space is centred at pi/2 - pi/z
        ang = -phi - (math.pi / 2 - math.pi / self.n_teeth)
        c, s = np.cos(ang), np.sin(ang)
        return np.column_stack([c * P[:, 0] - s * P[:, 1], s * P[:, 0] + c * P[:, 1]])

    def root_half_angle(self):
        """theta_f [rad]: half-angle of the tooth on the root circle (where the fillet starts)."""
        if self.internal:
            return float(self.half_angle(self.root_radius))
        P = self.root_fillet(2)[0]
        return float(math.atan2(P[1], P[0]))

    def half_section(self, n_fillet=60, n_involute=120):
        """Tooth half-section (xi, y): distance along the tooth centre line from the gear centre
        and half-thickness [m], from the root circle to the tip (fillet then involute). Internal
        gears: involute continued from the root form circle to the root circle (declared)."""
        u_lo = self.form_roll if not self.internal else self.tip_roll
        u_hi = self.tip_roll if not self.internal else float(self.roll(self.root_radius))
        u = np.linspace(u_lo, u_hi, n_involute)
        rr = self.radius_of_roll(u)
        ps = self.half_angle(rr)
        inv_pts = np.column_stack([rr * np.cos(ps), rr * np.sin(ps)])
        if self.internal:
            return inv_pts[::-1]
        return np.vstack([self.root_fillet(n_fillet), inv_pts[1:]])


def modification_value(params, u, z):
    """e(u, z) [m] and de/du of :class:`FlankModification` (params from
    :meth:`InvoluteGear.modification_parameters`). The reliefs grow as t^q with
    t = (u - u_start) / (u_end - u_start) > 0; the crowning terms are parabolic."""
    u_tip, u_ca, ca, qa, u_root, u_cf, cf, qf, cal, u_mid, u_half, cb, fhb, b = params
    u = np.asarray(u, float)
    e = np.zeros_like(u)
    de = np.zeros_like(u)
    for amount, start, end, q in ((ca, u_ca, u_tip, qa), (cf, u_cf, u_root, qf)):
        if amount > 0:
            t = (u - start) / (end - start)
            on = t > 0
            tp = np.where(on, t, 0.0)
            e = e + np.where(on, amount * tp ** q, 0.0)
            de = de + np.where(on, amount * q * tp ** (q - 1) / (end - start), 0.0)
    w = (u - u_mid) / u_half
    e = e + cal * w * w + cb * (2 * z / b) ** 2 + fhb * z / b
    de = de + 2 * cal * w / u_half
    return e, de


@dataclass(frozen=True, kw_only=True)
class InvolutePair:
    """A spur gear pair: external gear A with external or internal gear B at centre distance a.

    centre_distance: a [m] (default: the zero-backlash working centre distance of the shifts,
    thickness allowances not included). check_radial_assembly: also reject tip-to-tip
    interference when an internal pair is assembled radially.
    """
    gear_a: InvoluteGear
    gear_b: InvoluteGear
    centre_distance: float | None = None
    check_radial_assembly: bool = True

    def __post_init__(self):
        A, B = self.gear_a, self.gear_b
        if A.internal:
            raise RvtoolInputError("gear_a.internal = True is not valid; gear A is the external gear (valid: False)")
        if abs(A.module * math.cos(A.alpha) - B.module * math.cos(B.alpha)) > 1e-12 * A.module:
            raise RvtoolInputError(f"gear_b.module = {B.module} and its pressure angle give a base pitch different from "
                                   f"gear_a's ({A.base_pitch:.6g} m); valid: equal base pitches")
        if B.internal and B.n_teeth <= A.n_teeth:
            raise RvtoolInputError(f"gear_b.n_teeth = {B.n_teeth} is outside the valid range [{A.n_teeth + 1}, inf) "
                                   "for an internal gear meshing gear_a")
        if self.centre_distance is not None:
            rs = self.base_radius_sum
            check_range("centre_distance", self.centre_distance, rs, math.inf, low_open=True)
        self._check_interference()

    @property
    def eps(self):
        return self.gear_b.eps

    @property
    def base_radius_sum(self):
        """r_bB + eps r_bA: cos(alpha_w) = this / a (external r_bA + r_bB, internal r_bB - r_bA)."""
        return self.gear_b.base_radius + self.eps * self.gear_a.base_radius

    @property
    def reference_centre_distance(self):
        return self.gear_b.reference_radius + self.eps * self.gear_a.reference_radius

    @property
    def zero_backlash_pressure_angle(self):
        """alpha_w of inv alpha_w = inv alpha + 2 tan alpha eps (x_A + x_B) / (z_B + eps z_A): the tooth
        thicknesses on the working circles fill the working pitch (ISO 21771; for an internal gear
        this is ISO's formula with z_2 < 0 and its profile shift x_2 = x_B)."""
        A, B = self.gear_a, self.gear_b
        a = A.alpha
        shift = A.profile_shift + B.profile_shift
        value = float(inv(a)) + 2 * math.tan(a) * self.eps * shift / (B.n_teeth + self.eps * A.n_teeth)
        if not value > 0.0:
            # inv alpha_w > 0: eps (x_A + x_B) > -inv(alpha) (z_B + eps z_A) / (2 tan alpha), a lower bound on the
            # shift sum of an external pair and an upper one of an internal pair (z_B + eps z_A > 0 both ways)
            bound = float(inv(a)) * (B.n_teeth + self.eps * A.n_teeth) / (2 * math.tan(a))
            rng = f"({-bound:.6g}, inf)" if self.eps > 0 else f"(-inf, {bound:.6g})"
            raise RvtoolInputError(f"gear_a.profile_shift + gear_b.profile_shift = {shift:.6g} is outside the valid "
                                   f"range {rng} for z = {A.n_teeth} and {B.n_teeth}: the zero-backlash mesh has no "
                                   "working pressure angle")
        return inv_inverse(value)

    @property
    def a(self):
        if self.centre_distance is not None:
            return self.centre_distance
        return self.reference_centre_distance * math.cos(self.gear_a.alpha) / math.cos(self.zero_backlash_pressure_angle)

    @property
    def working_pressure_angle(self):
        """alpha_w [rad] at the centre distance: cos alpha_w = (r_bB + eps r_bA) / a."""
        return math.acos(self.base_radius_sum / self.a)

    @property
    def working_pitch_radii(self):
        """(r_wA, r_wB) [m]: r_b / cos alpha_w."""
        c = math.cos(self.working_pressure_angle)
        return self.gear_a.base_radius / c, self.gear_b.base_radius / c

    @property
    def line_length(self):
        """a sin alpha_w [m]: distance between the base-circle tangent points."""
        return self.a * math.sin(self.working_pressure_angle)

    def path_of_contact(self):
        """(SAP, EAP) as roll lengths on gear A, r_bA u [m], from the tip circles (ISO 21771)."""
        A, B = self.gear_a, self.gear_b
        sap = self.eps * (self.line_length - B.base_radius * B.tip_roll)
        return sap, A.base_radius * A.tip_roll

    def roll_b(self, roll_a):
        """Roll angle on gear B conjugate to roll angle u_A on gear A (same line of action)."""
        return self.eps * (self.line_length - self.gear_a.base_radius * np.asarray(roll_a)) / self.gear_b.base_radius

    @property
    def transverse_contact_ratio(self):
        """epsilon_alpha = (EAP - SAP) / p_b (ISO 21771, tip circles)."""
        sap, eap = self.path_of_contact()
        return (eap - sap) / self.gear_a.base_pitch

    def _check_interference(self):
        A, B = self.gear_a, self.gear_b
        sap, eap = self.path_of_contact()
        if sap < A.base_radius * A.form_roll:
            raise RvtoolInputError(
                f"involute interference: gear_b's tip (gear_b.tip_diameter = {2 * B.tip_radius:.6g} m, profile_shift = "
                f"{B.profile_shift}) meets gear_a below its root form circle (SAP roll {sap / A.base_radius:.4f} < "
                f"u_Ff {A.form_roll:.4f}); valid: SAP at or above the form circle (gear_a.profile_shift = {A.profile_shift})")
        ub_end = float(self.roll_b(A.tip_roll))
        if (ub_end - B.form_roll) * B.eps < 0:
            raise RvtoolInputError(
                f"involute interference: gear_a's tip (gear_a.tip_diameter = {2 * A.tip_radius:.6g} m, profile_shift = "
                f"{A.profile_shift}) meets gear_b beyond its root form circle (roll {ub_end:.4f} vs u_Ff {B.form_roll:.4f}); "
                f"valid: within gear_b's involute (gear_b.profile_shift = {B.profile_shift})")
        if self.eps < 0:
            depth = self.trochoid_interference_depth()
            if depth > 0:
                raise RvtoolInputError(
                    f"trochoid (tip) interference: gear_a's tip corner cuts gear_b's teeth by {depth:.3g} m outside the "
                    f"line of action (gear_a.profile_shift = {A.profile_shift}, gear_b.profile_shift = {B.profile_shift}, "
                    f"centre_distance = {self.a:.6g} m); valid: no penetration")
            if self.check_radial_assembly:
                depth = self.radial_assembly_interference_depth()
                if depth > 0:
                    raise RvtoolInputError(
                        f"tip-to-tip interference in radial assembly: the tips overlap by {depth:.3g} m while gear_a moves "
                        f"into mesh (gear_a.profile_shift = {A.profile_shift}, gear_b.profile_shift = {B.profile_shift}, "
                        f"centre_distance = {self.a:.6g} m); valid: no overlap (or check_radial_assembly = False "
                        "for axial assembly)")

    # -- kinematics --------------------------------------------------------------
    @property
    def ratio(self):
        """theta_B = ratio theta_A + phase (rigid, conjugate): -z_A/z_B external, +z_A/z_B internal."""
        return -self.eps * self.gear_a.n_teeth / self.gear_b.n_teeth

    def mesh_phase(self, line=0):
        """theta_B0 [rad]: gear B's angle at theta_A = 0 (centres at (0, 0) and (a, 0)) for which the
        nominal flanks on line ``line`` touch with zero gap (on line l the contact torque on gear A is
        omega F r_bA with omega = eps (+1 for line 0, -1 for line 1), see :func:`line_geometry`)."""
        th = 0.0
        for _ in range(3):
            g, omega = line_gap(self, 0.0, th, line)
            th -= g / (self.eps * omega * self.gear_b.base_radius)
        return th

    # -- tip-corner penetration checks (definition based) -------------------------
    def _corner_points(self, gear, theta, centre):
        """Both tip corners of every tooth of ``gear`` at angle theta, centre [m] (world)."""
        ra, psi = gear.tip_radius, float(gear.half_angle(gear.tip_radius))
        g = gear.tooth_angles()[:, None] + theta + np.array([-psi, psi])[None, :]
        return centre + ra * np.stack([np.cos(g), np.sin(g)], -1).reshape(-1, 2)

    @staticmethod
    def _material_depth(gear, theta, centre, pts, tol):
        """Depth [m] by which points lie inside the involute part of ``gear``'s teeth (<= 0: outside)."""
        d = pts - centre
        rho = np.linalg.norm(d, axis=1)
        ang = np.arctan2(d[:, 1], d[:, 0]) - theta
        pitch = 2 * np.pi / gear.n_teeth
        rel = np.abs((ang + 0.5 * pitch) % pitch - 0.5 * pitch)
        lo, hi = sorted((gear.tip_radius, gear.radius_of_roll(gear.form_roll)))
        inside = (rho > lo) & (rho < hi)
        psi = gear.half_angle(np.clip(rho, gear.base_radius, None))
        depth = np.where(inside, (psi - rel) * rho, -np.inf)
        return float(np.max(depth)) - tol

    def trochoid_interference_depth(self, n=240, tol=None):
        """Largest penetration [m] of gear A's tip corners into gear B's teeth over one pitch of
        rigid conjugate rotation (minus a tolerance of 1e-5 m_n against round-off)."""
        A, B = self.gear_a, self.gear_b
        tol = 1e-5 * A.module if tol is None else tol
        oa, ob = np.zeros(2), np.array([self.a, 0.0])
        th0 = self.mesh_phase(0)
        worst = -np.inf
        for t in np.linspace(0, 2 * np.pi / A.n_teeth, n, endpoint=False):
            tb = th0 + self.ratio * t
            worst = max(worst, self._material_depth(B, tb, ob, self._corner_points(A, t, oa), tol),
                        self._material_depth(A, t, oa, self._corner_points(B, tb, ob), tol))
        return worst

    def radial_assembly_interference_depth(self, n=200, tol=None):
        """Largest tip overlap [m] while gear A moves radially from the ring centre to its working
        centre at the conjugate phase (minus the tolerance of :meth:`trochoid_interference_depth`)."""
        A, B = self.gear_a, self.gear_b
        tol = 1e-5 * A.module if tol is None else tol
        th0 = self.mesh_phase(0)
        ob = np.array([self.a, 0.0])
        worst = -np.inf
        for s in np.linspace(0.0, 1.0, n):
            oa = np.array([(1 - s) * self.a, 0.0])
            worst = max(worst, self._material_depth(B, th0, ob, self._corner_points(A, 0.0, oa), tol),
                        self._material_depth(A, 0.0, oa, self._corner_points(B, th0, ob), tol))
        return worst


def line_geometry(pair_eps, rb_a, rb_b, oa, ob, line):
    """Line of action ``line`` (0 or 1) between base circles at centres oa, ob: returns
    (omega, phi_a, T_a, T_b, d, L): unwinding sense, tangent angle on A, tangent points, unit
    direction (A's outward flank normal) and L = (T_B - T_A) . d = eps a sin(alpha_w)."""
    s = 1.0 if line == 0 else -1.0
    dx = ob - oa
    a = math.hypot(*dx)
    beta = math.atan2(dx[1], dx[0])
    aw = math.acos((rb_b + pair_eps * rb_a) / a)
    phi_a = beta + s * aw if pair_eps > 0 else beta + s * (math.pi - aw)
    omega = s * pair_eps
    ea = np.array([math.cos(phi_a), math.sin(phi_a)])
    d = -omega * np.array([-ea[1], ea[0]])
    ta = oa + rb_a * ea
    tb = ob + rb_b * (-ea if pair_eps > 0 else ea)
    return omega, phi_a, ta, tb, d, pair_eps * a * math.sin(aw)


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def line_gap(pair, theta_a, theta_b, line):
    """Geometric gap [m] on line of action ``line`` between the nominal flanks of the tooth
    pair nearest the pitch point (centres (0, 0) and (a, 0)); returns (gap, omega)."""
    A, B = pair.gear_a, pair.gear_b
    eps = pair.eps
    omega, phi_a, ta, tb, d, L = line_geometry(eps, A.base_radius, B.base_radius, np.zeros(2), np.array([pair.a, 0.0]), line)
    u_ref = 0.5 * sum(pair.path_of_contact()) / A.base_radius
    sa, sb = -omega, -omega * eps
    ua = u_ref + _wrap(omega * (phi_a - theta_a - sa * A.base_half_angle) - u_ref)
    # the tooth of A nearest u_ref: shift by whole pitches
    pa = 2 * np.pi / A.n_teeth
    ua = u_ref + ((ua - u_ref + 0.5 * pa) % pa - 0.5 * pa)
    ub_t = eps * (L - A.base_radius * ua) / B.base_radius
    phi_b = phi_a + (math.pi if eps > 0 else 0.0)
    ub = omega * (phi_b - theta_b - sb * B.base_half_angle)
    pb = 2 * np.pi / B.n_teeth
    ub = ub_t + ((ub - ub_t + 0.5 * pb) % pb - 0.5 * pb)
    return L - A.base_radius * ua - eps * B.base_radius * ub, omega
