"""Cycloidal wheel profile of Eq. (cycloid_geometry), its modifications,
curvature, feasibility checks and the arc-length table used by the contact
search.

Profile (wheel coordinates, phi the generating angle):

    c(phi) = R_z [sin phi - (K1/z_b) sin(z_b phi), cos phi - (K1/z_b) cos(z_b phi)]
             + (r_c / D) [K1 sin(z_b phi) - sin phi, K1 cos(z_b phi) - cos phi],
    D(phi) = sqrt(1 + K1^2 - 2 K1 cos(z_g phi)),

with R_z the pin-circle radius, K1 = e_g z_b / R_z the eccentricity
coefficient (e_g the nominal generating eccentricity), z_b = z_g + 1 the pin
count and r_c the generating radius. Modifications (all lengths in m):
equidistant (r_c = r_p + delta_eq), offset (R_z -> R_z + delta_off),
rotation (the profile turned by delta_rot [rad]), a tabulated radial
modification r_c(phi) = r_c + table(phi), and lobe-by-lobe rotations (pitch
unit j, the tooth space about the root at phi = 2 pi j / z_g from tip to tip,
turned about the wheel centre by its own angle: the wheel's accumulated pitch
deviations, issue 30). The nominal generating eccentricity and the assembly eccentricity
are separate inputs.
"""
import functools
from dataclasses import dataclass, field, fields

import numpy as np

from warp_contacts.cycloid_pins_ref import lobe_turn

from ..errors import RvtoolInputError
from ..units import angle_field, angle_table_field
from ..validation import check_finite, check_nonnegative, check_positive, check_range


@dataclass(frozen=True, kw_only=True)
class CycloidProfile:
    """Cycloidal wheel profile specification.

    pin_circle_radius: R_z [m]. pin_radius: r_p [m]. n_pins: z_b.
    generating_eccentricity: e_g [m] (nominal; defines K1 = e_g z_b / R_z).
    equidistant_mod: delta_eq [m], added to the generating radius (positive removes material).
    offset_mod: delta_off [m], added to R_z in the profile (negative removes material).
    rotation_mod: delta_rot [rad], profile rotation about the wheel centre.
    radial_mod_table: optional (phi [rad], delta_r [m]) pairs of a tabulated
    generating-radius modification, periodic over one tooth (2 pi / z_g).
    lobe_rotations: optional rotation [rad] of each pitch unit about the wheel centre, z_g entries (unit j: the
    tooth space about the root at phi = 2 pi j / z_g with its two flanks, from tip to tip, as an indexed grinding
    pass places it; two units blend within 5 % of the pitch about the tip between them, :meth:`lobe_turn`): the
    accumulated pitch deviation of each unit as an angle. Not a design-file key (the
    design gives ``wheels.lobe_pitch_deviations`` per wheel, :func:`lobe_pitch_rotations`); None: every lobe at
    its nominal place (the profile as before, bit for bit).
    """
    pin_circle_radius: float
    pin_radius: float
    n_pins: int
    generating_eccentricity: float
    equidistant_mod: float = 0.0
    offset_mod: float = 0.0
    rotation_mod: float = angle_field(0.0)
    radial_mod_table: tuple | None = angle_table_field()  # (phi [rad], delta_r [m]) pairs; file: radial_mod_table_deg
    lobe_rotations: tuple | None = field(default=None, metadata={"file": False, "unit": "rad"})

    def __post_init__(self):
        check_positive("pin_circle_radius", self.pin_circle_radius)
        check_positive("pin_radius", self.pin_radius)
        if not isinstance(self.n_pins, (int, np.integer)) or self.n_pins < 3:
            raise RvtoolInputError(f"n_pins = {self.n_pins!r} is outside the valid range [3, inf) (integer)")
        check_positive("generating_eccentricity", self.generating_eccentricity)
        for nm in ("equidistant_mod", "offset_mod", "rotation_mod"):
            check_finite(nm, getattr(self, nm))
        # the profile's pin circle R = R_z + delta_off must stay a circle (R <= 0: a NaN profile)
        check_range("offset_mod", self.offset_mod, -self.pin_circle_radius, low_open=True)
        K1 = self.K1
        if K1 >= 1.0:
            raise RvtoolInputError(f"eccentricity coefficient K1 = e_g z_b / R_z = {K1:.4g} must be < 1 "
                                   "(valid range (0, 1) for a curtate epitrochoid; reduce generating_eccentricity)")
        # neighbouring pins must not overlap: 2 r_p < 2 R_z sin(pi / z_b)
        gap = 2 * self.pin_circle_radius * np.sin(np.pi / self.n_pins)
        if 2 * self.pin_radius >= gap:
            raise RvtoolInputError(f"pin_radius = {self.pin_radius} m makes neighbouring pins overlap; valid range "
                                   f"(0, {gap / 2:.6g}) m for {self.n_pins} pins on R_z = {self.pin_circle_radius} m")
        if self.radial_mod_table is not None:
            t = np.asarray(self.radial_mod_table, dtype=float)
            if t.ndim != 2 or t.shape[1] != 2 or t.shape[0] < 2:
                raise RvtoolInputError(f"radial_mod_table must be a sequence of (phi, delta_r) pairs; got shape {t.shape}")
            check_finite("radial_mod_table", t)
            if np.any(np.diff(t[:, 0]) <= 0):
                raise RvtoolInputError("radial_mod_table angles must increase strictly (valid: sorted phi in [0, 2 pi / z_g])")
        if self.lobe_rotations is not None:
            r = np.asarray(self.lobe_rotations, dtype=float)
            if r.shape != (self.n_teeth,):
                raise RvtoolInputError(f"lobe_rotations must have shape ({self.n_teeth},) (one angle per lobe); "
                                       f"got {r.shape}")
            check_finite("lobe_rotations", r)
            # a pitch deviation is micro-radians; a lobe turned by a tenth of its pitch is no longer a deviation
            lim = 0.1 * 2 * np.pi / self.n_teeth
            if np.max(np.abs(r)) > lim:
                raise RvtoolInputError(f"lobe_rotations = {np.max(np.abs(r)):.4g} rad is outside the valid range "
                                       f"[-{lim:.4g}, {lim:.4g}] rad (a tenth of the lobe pitch 2 pi / z_g)")
        _checked_undercut(self)

    @property
    def n_teeth(self):
        """z_g = z_b - 1 (the only tooth-count combination supported)."""
        return self.n_pins - 1

    @property
    def R(self):
        return self.pin_circle_radius + self.offset_mod

    @property
    def K1(self):
        return self.generating_eccentricity * self.n_pins / self.pin_circle_radius

    def generating_radius(self, phi):
        rc = self.pin_radius + self.equidistant_mod
        if self.radial_mod_table is None:
            return np.full_like(np.asarray(phi, float), rc)
        t = np.asarray(self.radial_mod_table, float)
        period = 2 * np.pi / self.n_teeth
        return rc + np.interp(np.mod(phi, period), t[:, 0], t[:, 1], period=period)

    # -- analytic curve -----------------------------------------------------
    def epitrochoid(self, phi):
        """Pin-centre path E(phi) and its first two derivatives (wheel coordinates)."""
        phi = np.asarray(phi, float)
        return self._epitrochoid(_trig(phi, self.n_pins))

    def _epitrochoid(self, trig):
        """:meth:`epitrochoid` from the angles' (sin phi, cos phi, sin z_b phi, cos z_b phi)."""
        R, K1, zb = self.R, self.K1, self.n_pins
        s, c, S, C = trig
        E = R * np.stack([s - K1 / zb * S, c - K1 / zb * C], axis=-1)
        dE = R * np.stack([c - K1 * C, -s + K1 * S], axis=-1)
        ddE = R * np.stack([-s + K1 * zb * S, -c + K1 * zb * C], axis=-1)
        return E, dE, ddE

    def points(self, phi):
        """Profile points c(phi) of Eq. (cycloid_geometry), turned by the rotation modification (and each
        lobe by its lobe rotation)."""
        phi = np.asarray(phi, float)
        return self._turn_lobes(phi, self._rotate(self._unrotated_points(phi, _trig(phi, self.n_pins))))

    def lobe_turn(self, phi):
        """(d(phi), d'(phi)) [rad, rad/rad]: the lobe rotation of the profile point of generating angle phi and
        its derivative (:func:`warp_contacts.cycloid_pins_ref.lobe_turn`: pitch unit j, the tooth space about the
        root at phi = 2 pi j / z_g from tip to tip, turns by ``lobe_rotations[j]``; two units blend linearly within
        5 % of the pitch about the tip between them); zeros without lobe rotations."""
        if self.lobe_rotations is None:
            z = np.zeros_like(np.asarray(phi, float))
            return z, z
        return lobe_turn(self.lobe_rotations, phi)

    def _turn_lobes(self, phi, xy):
        """``xy`` (points or vectors of generating angles phi) turned by their lobe rotation d(phi); unchanged (the
        same array) without lobe rotations."""
        if self.lobe_rotations is None:
            return xy
        a = self.lobe_turn(phi)[0]
        c, s = np.cos(a), np.sin(a)
        return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)

    def _turned_tangents(self, phi, pts, dE, ddE):
        """Unit tangents of the lobe-turned curve at generating angles phi from the unturned points ``pts`` and
        the epitrochoid's derivatives: R(d) (c_0' + d' J c_0) normalised (c_0' = ds/dphi dE/|dE|), turned by the
        profile rotation and d; where d' = 0 the unturned tangent turned (as without the blend)."""
        speed = _length(dE)
        tau = dE / speed[..., None]
        kE = -(dE[..., 0] * ddE[..., 1] - dE[..., 1] * ddE[..., 0]) / speed ** 3
        ds = speed * (1.0 - self.generating_radius(phi) * kE)
        d, dd = self.lobe_turn(phi)
        v = ds[..., None] * tau + dd[..., None] * np.stack([-pts[..., 1], pts[..., 0]], axis=-1)
        t = np.where((dd != 0.0)[..., None], v / _length(v)[..., None], tau)
        return self._turn_lobes(phi, self._rotate(t))

    def _unrotated_points(self, phi, trig, epi=None):
        """:meth:`points` before the rotation, from the angles' :func:`_trig` (the same operations;
        ``epi``: their :meth:`_epitrochoid` where the caller has it)."""
        E, dE, _ = self._epitrochoid(trig) if epi is None else epi
        D = _length(dE) / self.R   # = sqrt(1 + K1^2 - 2 K1 cos(z_g phi))
        K1 = self.K1
        s, c, S, C = trig
        inward = np.stack([K1 * S - s, K1 * C - c], axis=-1) / D[..., None]
        return E + self.generating_radius(phi)[..., None] * inward

    def _rotate(self, xy):
        if self.rotation_mod == 0.0:
            return xy
        c, s = np.cos(self.rotation_mod), np.sin(self.rotation_mod)
        return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)

    def curvature_of_points(self, phi, h=None):
        """Signed curvature of the profile (positive where it is convex outward), by the
        analytic offset-curve relation kappa = kappa_E / (1 - r_c kappa_E) for constant r_c."""
        _, dE, ddE = self.epitrochoid(phi)
        return self._curvature(phi, dE, ddE)

    def _curvature(self, phi, dE, ddE):
        """:meth:`curvature_of_points` from the epitrochoid's derivatives at ``phi`` (the same operations)."""
        cross = dE[..., 0] * ddE[..., 1] - dE[..., 1] * ddE[..., 0]
        speed = _length(dE)
        # the curve runs clockwise for increasing phi (x ~ sin, y ~ cos), so convex-outward is cross < 0
        kE = -cross / speed ** 3
        rc = self.generating_radius(phi)
        return kE / (1.0 - rc * kE)

    def _check_undercut(self):
        """Undercut / pointed teeth: the offset must not exceed the epitrochoid's convex radius."""
        phi = np.linspace(0, 2 * np.pi / self.n_teeth, 4001)
        E, dE, ddE = self.epitrochoid(phi)
        cross = dE[..., 0] * ddE[..., 1] - dE[..., 1] * ddE[..., 0]
        kE = -cross / _length(dE) ** 3
        rc = self.generating_radius(phi)
        worst = np.max(rc * kE)
        if worst >= 1.0 or np.min(rc) <= 0.0:
            rho_min = 1.0 / np.max(kE)
            # the design key a user moves: equidistant_mod, whose range follows from 0 < r_p + delta_eq (+ table) < rho_min
            eq = self.equidistant_mod
            tab = np.zeros(1) if self.radial_mod_table is None else self.generating_radius(phi) - (self.pin_radius + eq)
            lo, hi = -(self.pin_radius + np.min(tab)), rho_min - self.pin_radius - np.max(tab)
            what = (f"the generating radius pin_radius + equidistant_mod = {np.min(rc):.6g} m is not positive"
                    if np.min(rc) <= 0.0 else
                    f"the profile is undercut or pointed: generating radius {np.max(rc):.6g} m exceeds the minimum "
                    f"convex curvature radius {rho_min:.6g} m of the epitrochoid")
            raise RvtoolInputError(f"equidistant_mod = {eq:.6g} m is outside the valid range ({lo:.6g}, {hi:.6g}) m at "
                                   f"pin_radius = {self.pin_radius:.6g} m: {what} (valid range of pin_radius + "
                                   f"equidistant_mod: (0, {rho_min:.6g}) m)")

    # -- tables for the contact search ---------------------------------------
    def table(self, n_samples):
        """Arc-length resampled profile: (points (n,2), outward normals (n,2), curvature (n,),
        polar angle (n,), sample spacing [m], generating angle phi (n,)). Samples are ordered by
        increasing polar angle."""
        if n_samples < 8 * self.n_teeth:
            raise RvtoolInputError(f"n_samples = {n_samples} is too small; valid range [{8 * self.n_teeth}, inf) "
                                   f"(at least 8 per tooth)")
        dense, P = _dense_points(self, 16 * n_samples)
        seg = _length(np.diff(np.vstack([P, P[:1]]), axis=0))
        s = np.concatenate([[0.0], np.cumsum(seg)])
        total = s[-1]
        target = np.arange(n_samples) * total / n_samples
        phi_dense = np.concatenate([dense, [2 * np.pi]])
        phi = np.interp(target, s, phi_dense)
        # the samples' trigonometry and epitrochoid once for points, tangents and curvature (the same
        # operations as points(), epitrochoid() and curvature_of_points())
        trig = _trig(phi, self.n_pins)
        epi = self._epitrochoid(trig)
        unturned = self._unrotated_points(phi, trig, epi)
        pts = self._turn_lobes(phi, self._rotate(unturned))
        _, dE, ddE = epi
        if self.lobe_rotations is None:
            tang = self._rotate(dE / _length(dE)[..., None])
        else:
            tang = self._turned_tangents(phi, unturned, dE, ddE)
        # outward normal: the curve runs clockwise, so the outward normal is the tangent turned by +90 deg
        nrm = np.stack([-tang[..., 1], tang[..., 0]], axis=-1)
        kap = self._curvature(phi, dE, ddE)
        polar = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2 * np.pi)
        order = np.argsort(polar)
        return pts[order], nrm[order], kap[order], polar[order], total / n_samples, phi[order]

    def analytic_parameters(self):
        """(R, K1, z_b, r_c, rotation) for the analytic closest-point path, which supports the
        equidistant, offset and rotation modifications and the lobe rotations (then a sixth entry, the
        tuple of z_g lobe rotations [rad]) but not a tabulated r_c(phi)."""
        if self.radial_mod_table is not None:
            raise RvtoolInputError("search = 'analytic' does not support radial_mod_table; valid: search = 'discrete' "
                                   "for a tabulated generating-radius modification")
        base = (self.R, self.K1, float(self.n_pins), self.pin_radius + self.equidistant_mod, self.rotation_mod)
        if self.lobe_rotations is None:
            return base
        return base + (tuple(float(x) for x in self.lobe_rotations),)


def _length(v):
    """Euclidean length of 2-vectors ``v`` (..., 2): bit for bit ``np.linalg.norm(v, axis=-1)`` (the square
    root of x*x + y*y, what its reduction over a length-2 axis adds) without the reduction over a short
    axis (~1/3 of a profile table's time)."""
    x, y = v[..., 0], v[..., 1]
    return np.sqrt(x * x + y * y)


def _trig(phi, n_pins):
    """(sin phi, cos phi, sin z_b phi, cos z_b phi) of angles phi [rad]: the terms of
    :meth:`CycloidProfile.epitrochoid` and :meth:`CycloidProfile.points`."""
    zp = n_pins * phi
    return np.sin(phi), np.cos(phi), np.sin(zp), np.cos(zp)


_UNDERCUT_CHECKED = {}
"""Profiles (their fields but the rotations) whose undercut check passed, per process."""

_TURNS = ("rotation_mod", "lobe_rotations")
"""The profile's rigid turns (of the whole profile, of each lobe): they change neither its curvature nor its
unturned points, so the process caches key a profile without them."""


def _checked_undercut(profile):
    """:meth:`CycloidProfile._check_undercut`, once per profile up to its rotation (which does not change
    the curvature: the wheels of one reducer, turned to their phases, and the profile rebuilt for the
    dense points check it once)."""
    key = tuple((f.name, getattr(profile, f.name)) for f in fields(profile) if f.name not in _TURNS)
    try:
        if key in _UNDERCUT_CHECKED:
            return
    except TypeError:                     # an unhashable member (a list table): checked each time
        profile._check_undercut()
        return
    profile._check_undercut()
    if len(_UNDERCUT_CHECKED) > 4096:
        _UNDERCUT_CHECKED.clear()
    _UNDERCUT_CHECKED[key] = True


@functools.lru_cache(maxsize=4)
def _dense_trig(n_dense, n_pins):
    """The dense grid of :meth:`CycloidProfile.table` (n_dense angles in [0, 2 pi)) and its
    :func:`_trig`: the same for every profile of n_pins pins (Monte Carlo variants, the wheels of
    one reducer), so computed once per process; read-only."""
    dense = np.linspace(0, 2 * np.pi, n_dense, endpoint=False)
    out = (dense,) + _trig(dense, n_pins)
    for a in out:
        a.flags.writeable = False
    return out


@functools.lru_cache(maxsize=4)
def _dense_unrotated(key, n_dense):
    """Unrotated points of the profile of ``key`` (its fields but the rotation) on the dense grid:
    the wheels of one reducer differ in their rotation only (their assembly phases), so each
    wheel's table after the first rotates these; read-only."""
    profile = CycloidProfile(**dict(key))
    dense = _dense_trig(n_dense, profile.n_pins)[0]
    E_u, dE_u, W_u = _dense_units(profile.K1, profile.n_pins, n_dense)
    # _unrotated_points on the dense grid, its R-free stacks kept (the same operations on the same numbers)
    R = profile.R
    E, dE = R * E_u, R * dE_u
    D = _length(dE) / R
    out = E + profile.generating_radius(dense)[..., None] * (W_u / D[..., None])
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=4)
def _dense_units(K1, n_pins, n_dense):
    """The stacks of :meth:`CycloidProfile._epitrochoid` (E / R, dE / R) and of the inward offset direction
    (times D) of :meth:`CycloidProfile._unrotated_points` on the dense grid: they depend on the
    eccentricity coefficient K1 and the pin count only (Monte Carlo variants draw R and the generating
    radius, not K1), so computed once per process; read-only."""
    s, c, S, C = _dense_trig(n_dense, n_pins)[1:]
    zb = n_pins
    out = (np.stack([s - K1 / zb * S, c - K1 / zb * C], axis=-1), np.stack([c - K1 * C, -s + K1 * S], axis=-1),
           np.stack([K1 * S - s, K1 * C - c], axis=-1))
    for a in out:
        a.flags.writeable = False
    return out


def _dense_points(profile, n_dense):
    """(dense grid, the profile's points on it, its lobes unturned) of :meth:`CycloidProfile.table`: bit for bit
    what ``profile.points(np.linspace(0, 2 pi, n_dense, endpoint=False))`` gives without lobe rotations (the same operations
    on the same numbers; tests/test_cycloid_table.py), the grid's trigonometry and the unrotated
    points kept between calls (:func:`_dense_trig`, :func:`_dense_unrotated`; ~2/3 of a table's
    time on RD-40 variants, whose profiles differ per variant and per wheel)."""
    key = tuple((f.name, getattr(profile, f.name)) for f in fields(profile) if f.name not in _TURNS)
    try:
        hash(key)
    except TypeError:                     # an unhashable member (a list table): computed here
        dense = np.linspace(0, 2 * np.pi, n_dense, endpoint=False)
        return dense, profile._rotate(profile._unrotated_points(dense, _trig(dense, profile.n_pins)))
    return _dense_trig(n_dense, profile.n_pins)[0], profile._rotate(_dense_unrotated(key, n_dense))


def lobe_pitch_rotations(profile: CycloidProfile, single_pitch_deviations):
    """Lobe rotations [rad] (``CycloidProfile.lobe_rotations``) of a wheel whose lobes carry the single pitch
    deviations f_j [m] (f_j between lobe j-1 and lobe j, z_g entries summing to zero) on the reference circle of
    radius r = R_z z_g / z_b (the wheel as a gear of the pin ring's module 2 R_z / z_b): lobe j sits off its
    nominal place by the accumulated pitch deviation s_j = f_0 + ... + f_j minus the mean of s (no rigid turn of
    the wheel), along the direction of increasing lobe index (clockwise: the profile runs clockwise for
    increasing phi), i.e. turned by -s_j / r."""
    f = np.asarray(single_pitch_deviations, float)
    if f.shape != (profile.n_teeth,):
        raise RvtoolInputError(f"lobe single pitch deviations must have shape ({profile.n_teeth},); got {f.shape}")
    s = np.cumsum(f)
    s = s - s.mean()
    r = profile.pin_circle_radius * profile.n_teeth / profile.n_pins
    return tuple(float(x) for x in -s / r)


def pin_centres(profile: CycloidProfile, pin_centre_errors=None):
    """Ring pin centres in the housing frame [m]: pin k at angle 2 pi k / z_b from +y,
    clockwise, R_z (sin a, cos a) plus optional per-pin errors (z_b, 2)."""
    a = 2 * np.pi * np.arange(profile.n_pins) / profile.n_pins
    p = profile.pin_circle_radius * np.column_stack([np.sin(a), np.cos(a)])
    if pin_centre_errors is not None:
        e = np.asarray(pin_centre_errors, float)
        if e.shape != p.shape:
            raise RvtoolInputError(f"pin_centre_errors must have shape ({profile.n_pins}, 2); got {e.shape}")
        check_finite("pin_centre_errors", e)
        p = p + e
    return p


def modification_play(pin_circle_radius, n_pins, eccentricity, wheel_centres, *, clearance=0.0, equidistant_mod=0.0,
                      offset_mod=0.0, rotation_mod=0.0):
    """Angular free play [rad] of the wheels (turning together with the output) against the ring
    pins from the uniform clearance c_w and the profile modifications, first order in them: the
    closed-form kinematic estimate of their lost motion.

    For pin i at p_i (:func:`pin_centres`) and wheel centre O_w (``wheel_centres`` (n_wheels, 2)
    [m] about the ring centre), the conjugate contact normal passes through the pitch point
    P = z_b O_w (distance e z_b from the ring centre), n_i = (p_i - P)/|p_i - P| (from the wheel
    to the pin). In the pitch frame (pin i at phi_i from the line of centres, K_1 = e z_b / R_z,
    S_i = sqrt(1 - 2 K_1 cos phi_i + K_1^2)) the normal gaps and lever arms are
      r_i = (P - O_w) x n_i = -e z_c sin(phi_i)/S_i   (approach per unit wheel rotation; |r| <= e z_c),
      gap_i = c_w + delta_eq - (delta_off/R_z) (p_i - O_w) . n_i - delta_rot r_i,
    the offset scaling the pin-centre epitrochoid about the wheel centre and the rotation turning
    the profile about it. A wheel rotation theta changes gap_i by -theta r_i; the wheels' free
    range is theta in [max_{r<0} gap/r, min_{r>0} gap/r] (intersected over the wheels) and the
    play is its length. A rotation modification alone shifts the range by -delta_rot (a phase,
    no play); the uniform clearance and the equidistant modification give about 2 c / (e z_c).
    Returns (play [rad], lower and upper limit [rad])."""
    a = 2 * np.pi * np.arange(n_pins) / n_pins
    p = pin_circle_radius * np.column_stack([np.sin(a), np.cos(a)])
    lo, hi = -np.inf, np.inf
    for ow in np.atleast_2d(np.asarray(wheel_centres, float)):
        P = n_pins * ow
        d = p - P
        n = d / np.linalg.norm(d, axis=1)[:, None]
        w = P - ow
        r = w[0] * n[:, 1] - w[1] * n[:, 0]
        v = p - ow
        gap = (clearance + equidistant_mod - (offset_mod / pin_circle_radius) * np.einsum("ij,ij->i", v, n)
               - rotation_mod * r)
        tiny = 1e-9 * eccentricity * n_pins
        pos, neg = r > tiny, r < -tiny
        hi = min(hi, float(np.min(gap[pos] / r[pos])))
        lo = max(lo, float(np.max(gap[neg] / r[neg])))
    return hi - lo, lo, hi
