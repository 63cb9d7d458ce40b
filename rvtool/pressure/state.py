"""Local contact geometry and load at a selected contact of an accepted state (Eqs. public_pressure_pose,
public_pressure_tangent).

A :class:`LocalContact` is built once from the state: contact identity, normal force, face width,
materials, local frame and the undeformed gap as a function of the tangent coordinate. Everything is
fixed before a panel resolution is chosen, so refining the panel grid never reselects the contact or
changes its load. Everything comes through the :class:`~rvtool.model.ReducerModel` interface, so
any topology with these families is served: the loads from the family observation
(``model.observe``; a physical contact is its rows merged, :func:`rvtool.model.physical_contact`),
the contact geometry from the family's component spec (``model.family_spec``), the elastic
constants from ``model.material`` and body poses from ``model.body_pose``. Families:

* ``PINS`` (:func:`pin_contact`): a wheel--pin mesh spec (profile, pin radius, face width; contacts
  ``wheel{k}/pin{j}``): final wheel profile at its pose against the ring pin, five-point tangent of
  Eq. (public_pressure_tangent), mating-circle branch facing the wheel;
* ``OUTPUT_PINS`` (:func:`output_pin_contact`): an output-pin mechanism spec (contacts
  ``output_pins/pin{j}/wheel{k}``): convex pin in its concave wheel hole (conformal);
* ``ECCENTRIC_BEARINGS`` (:func:`needle_contact`): a needle-bearing spec (contacts
  ``eccentric_bearing{k}/roller{j}``, or one ``eccentric_bearing{k}`` for the lumped bearing): a
  roller against the journal (convex--convex) or against the wheel bore (convex--concave), from the
  rolling-element observations or, for the lumped bearing, from Stribeck's line-contact sharing
  Q_max = 4.08 F_r / Z at the bearing force direction.

Slices (laminae) of one pin/roller and wheel lie on one line and carry equal loads in the planar
model, so a contact is their sum over the full face width; the spread of the slice forces is kept
(``slice_force_ratio``). For two circles touching along the force normal the undeformed gap depends
only on the radii (the overlap of the state is a constant datum, absorbed by the approach).
"""
from dataclasses import dataclass, field

import numpy as np
import scipy.interpolate

from rvtool.errors import RvtoolInputError
from rvtool.geometry.cycloid import pin_centres
from rvtool.model import Family, physical_contact
from warp_contacts.circle_pairs_ref import O_FN, O_FT, O_NX, O_NY, O_PX, O_PY

#: Stribeck's factor of a line-contact bearing with zero clearance, Q_max = 4.08 F_r / Z
#: (Harris & Kotzalas 2007, vol. 1, ch. 7); the lumped needle law of the builder uses the same.
STRIBECK_LINE = 4.08


@dataclass(frozen=True, kw_only=True)
class LocalContact:
    """One contact of an accepted state, frozen for a pressure-resolution study."""

    name: str
    """Contact id (the observation id, slices merged)."""
    family: str
    """"pins", "output_pins", "needle_journal" or "needle_bore"."""
    wheel: int
    """Wheel index (0-based)."""
    force: float
    """Normal force F_n [N] from the state's observation arrays."""
    face_width: float
    """Face width b [m] carrying F_n."""
    e_star: float
    """Two-body modulus E* of Eq. (obs_panel_influence) [Pa]."""
    poisson_ratio: float
    """Poisson ratio of the equivalent half-space [-]."""
    radius: float
    """Equivalent radius R of the undeformed gap, g ~ x^2 / (2 R) [m] (Hertz estimates only)."""
    point: np.ndarray
    """Contact point [m] (global)."""
    tangent: np.ndarray
    """Unit tangent t of the local frame (global); x runs along it."""
    normal: np.ndarray
    """Unit normal of the local frame, the direction of the force on the wheel (or outer ring)."""
    friction_coefficient: float = 0.0
    """Coulomb coefficient mu of the contact law in the state [-] (0: no friction)."""
    traction_sign: float = 1.0
    """Sign of the friction force on the wheel along t (+1 when there is none)."""
    slice_force_ratio: float = 1.0
    """max/min slice force of the merged slices [-] (1: equal)."""
    extent: float = np.inf
    """Largest |x| [m] at which the gap is defined."""
    _gap: object = field(default=None, repr=False, compare=False)

    def gap(self, x):
        """Undeformed gap [m] at local tangent coordinates x [m] (datum: zero at its minimum over x)."""
        x = np.asarray(x, float)
        if np.max(np.abs(x)) > self.extent:
            raise RvtoolInputError(f"x: |x| up to {np.max(np.abs(x)):.3e} m; valid range for contact "
                                   f"{self.name} is |x| <= {self.extent:.3e} m")
        g = self._gap(x)
        return g - g.min()

    @property
    def hertz_halfwidth(self):
        """Hertz line-contact half-width a = sqrt(4 F' R / (pi E*)) [m], F' = F_n / b."""
        return float(np.sqrt(4 * self.force / self.face_width * self.radius / (np.pi * self.e_star)))

    @property
    def hertz_peak(self):
        """Hertz peak pressure p0 = 2 F' / (pi a) [Pa]."""
        return float(2 * self.force / self.face_width / (np.pi * self.hertz_halfwidth))

    @property
    def sliding_mu(self):
        """Signed coefficient of the Coulomb traction q = mu p on the wheel along +x [-]."""
        return float(self.traction_sign * self.friction_coefficient)


def _e_star(model):
    m = model.material
    return m.youngs_modulus / (2 * (1 - m.poisson_ratio ** 2))


def _observation(model, q, family, obs):
    """The :class:`~rvtool.model.FamilyObservation` of ``family`` at the accepted state q (zero
    velocity), or ``obs`` where the caller already holds it."""
    return model.observe(q, family) if obs is None else obs


def _contact_rows(ob, contact):
    """Observation rows of the physical contact ``contact`` (its slices or laminae)."""
    return np.array([i for i, rid in enumerate(ob.ids) if physical_contact(rid) == contact], dtype=int)


def _circle_pair_gap(r1, r2, conformal):
    """Gap of a convex circle r1 against a convex (r2 > 0, ``conformal`` False) or a concave circle
    (the bore or hole of radius r2 around it), touching at x = 0 [m]."""
    def gap(x):
        g = r1 - np.sqrt(r1 ** 2 - x ** 2)
        s = r2 - np.sqrt(r2 ** 2 - x ** 2)
        return g - s if conformal else g + s
    return gap


def _equivalent_radius(gap, x_probe):
    """R from the gap curvature, g(x) - g(0) ~ x^2 / (2 R), by the central second difference."""
    g = gap(np.array([-x_probe, 0.0, x_probe]))
    return float(x_probe ** 2 / (g[0] + g[2] - 2 * g[1]))


def _merge(obs, rows):
    """Summed force, force-weighted point and normal, slice spread of observation rows."""
    f = obs[rows, O_FN]
    F = float(f.sum())
    if not F > 0:
        return 0.0, None, None, np.inf
    pt = (f[:, None] * obs[rows, O_PX:O_PY + 1]).sum(axis=0) / F
    n = (f[:, None] * obs[rows, O_NX:O_NY + 1]).sum(axis=0)
    ratio = float(f.max() / f.min()) if f.min() > 0 else np.inf
    return F, pt, n / np.linalg.norm(n), ratio


def _wheel_points(profile, pose, phi):
    c, s = np.cos(pose[2]), np.sin(pose[2])
    p = profile.points(phi)
    return np.stack([c * p[:, 0] - s * p[:, 1] + pose[0], s * p[:, 0] + c * p[:, 1] + pose[1]], axis=-1)


def pin_contact(model, q, wheel, pin, *, obs=None, extent=1e-3):
    """Cycloid wheel ``wheel`` against ring pin ``pin`` at the accepted state q (all slices merged).

    The wheel profile is sampled at its final pose; the five-point tangent of Eq.
    (public_pressure_tangent) at the profile point nearest the contact point gives the local frame
    (normal oriented along the force on the wheel); the pin enters through its mating-circle branch,
    the side facing the wheel. extent: half-length [m] of the profile neighbourhood, tabulated at
    20,001 points and interpolated by a cubic spline: linear interpolation put curvature kinks every
    0.12 um into the gap, finer than the 4097-panel spacing of a pin contact (28 nm), and moved its
    peak pressure by 0.2 %.
    """
    ob = _observation(model, q, Family.PINS, obs)
    rows = _contact_rows(ob, f"wheel{wheel}/pin{pin}")
    if rows.size == 0:
        raise RvtoolInputError(f"wheel = {wheel}, pin = {pin}: no such cycloid pin contact")
    obs = ob.obs
    F, pc, nrm, ratio = _merge(obs, rows)
    if not F > 0:
        raise RvtoolInputError(f"wheel = {wheel}, pin = {pin}: the contact carries no load at this state")
    mesh = model.family_spec(Family.PINS)[int(wheel)]
    prof = mesh.profile
    rp = mesh.pin_radius if mesh.pin_radius is not None else prof.pin_radius
    if not 0 < extent < rp:
        raise RvtoolInputError(f"extent = {extent!r} m is outside the valid range (0, pin radius {rp} m)")
    wpose = model.body_pose(q, mesh.wheel_body)
    phi = np.linspace(0, 2 * np.pi, 200001)
    pts = _wheel_points(prof, wpose, phi)
    i = int(np.argmin(np.sum((pts - pc) ** 2, axis=1)))
    h = phi[1] - phi[0]
    s5 = _wheel_points(prof, wpose, phi[i] + h * np.arange(-2, 3))
    tan = (s5[0] - 8 * s5[1] + 8 * s5[3] - s5[4]) / (12 * h)  # Eq. (public_pressure_tangent)
    t = tan / np.linalg.norm(tan)
    n = np.array([-t[1], t[0]]) * np.sign(np.dot([-t[1], t[0]], nrm))
    p0 = pts[i]
    dphi = 1.2 * extent / np.linalg.norm(tan)
    ph = np.linspace(phi[i] - dphi, phi[i] + dphi, 20001)
    w = _wheel_points(prof, wpose, ph) - p0
    ws, wn = w @ t, w @ n
    order = np.argsort(ws)
    wheel_n = scipy.interpolate.CubicSpline(ws[order], wn[order])
    c = pin_centres(prof)[int(pin)] - p0
    cs, cn = c @ t, c @ n

    def gap(x):
        # mating-circle branch: the side of the pin facing the wheel (towards -sign(cn))
        pin_n = cn - np.sign(cn) * np.sqrt(np.maximum(rp ** 2 - (x - cs) ** 2, 0.0))
        return np.sign(cn) * (pin_n - wheel_n(x))

    ft = obs[rows, O_FT].sum()
    nt = np.array([-nrm[1], nrm[0]])  # the observation's tangent perp(n)
    sign = float(np.sign(ft * np.dot(nt, t))) if ft != 0 else 1.0
    mu = mesh.friction.mu_kinetic if mesh.friction is not None else 0.0
    return LocalContact(name=f"wheel{wheel}/pin{pin}", family="pins", wheel=int(wheel), force=F,
                        face_width=mesh.face_width, e_star=_e_star(model), poisson_ratio=model.material.poisson_ratio,
                        radius=_equivalent_radius(gap, 0.02 * extent), point=p0, tangent=t, normal=n,
                        friction_coefficient=float(mu), traction_sign=sign, slice_force_ratio=ratio,
                        extent=float(extent), _gap=gap)


def pin_contact_gap(model, q, contact, x):
    """Gap [m] at x [m] and force [N] of the cycloid pin contact of observation row ``contact``
    (its wheel and pin; slices merged). Kept for callers of the row-based interface."""
    wheel, pin = physical_contact(model.observe(q, Family.PINS).ids[contact]).split("/")
    c = pin_contact(model, q, int(wheel.removeprefix("wheel")), int(pin.removeprefix("pin")))
    return c.gap(x), c.force


def _frame(n):
    n = np.asarray(n, float) / np.linalg.norm(n)
    return np.array([-n[1], n[0]]), n


def output_pin_contact(model, q, wheel, pin, *, obs=None):
    """Output pin ``pin`` in its hole of wheel ``wheel`` (convex pin in a concave hole, conformal)."""
    ob = _observation(model, q, Family.OUTPUT_PINS, obs)
    rows = _contact_rows(ob, f"output_pins/pin{pin}/wheel{wheel}")
    if rows.size == 0:
        raise RvtoolInputError(f"wheel = {wheel}, pin = {pin}: no such output-pin contact")
    F, pc, nrm, ratio = _merge(ob.obs, rows)
    if not F > 0:
        raise RvtoolInputError(f"wheel = {wheel}, pin = {pin}: the output-pin contact carries no load at this state")
    op = model.family_spec(Family.OUTPUT_PINS)
    t, n = _frame(nrm)
    gap = _circle_pair_gap(op.pin_radius, op.hole_radius, conformal=True)
    r_eq = op.pin_radius * op.hole_radius / (op.hole_radius - op.pin_radius)
    return LocalContact(name=f"output_pins/pin{pin}/wheel{wheel}", family="output_pins", wheel=int(wheel), force=F,
                        face_width=op.contact_length, e_star=_e_star(model),
                        poisson_ratio=model.material.poisson_ratio, radius=r_eq, point=pc, tangent=t,
                        normal=n, slice_force_ratio=ratio, extent=0.5 * op.pin_radius, _gap=gap)


def needle_contact(model, q, wheel, roller, race, *, obs=None):
    """Needle ``roller`` of the eccentric bearing of wheel ``wheel`` against ``race`` ("journal":
    convex--convex, or "bore": convex--concave).

    Rolling model: the roller load is the sum of its laminae. Lumped model (one circle contact per
    bearing): roller=None stands for the most loaded roller, Q_max = 4.08 F_r / Z (Stribeck, zero
    clearance) along the bearing force."""
    if race not in ("journal", "bore"):
        raise RvtoolInputError(f"race = {race!r}; valid choices are ['journal', 'bore']")
    eb = model.family_spec(Family.ECCENTRIC_BEARINGS)
    ob = _observation(model, q, Family.ECCENTRIC_BEARINGS, obs)
    name = f"eccentric_bearing{wheel}"
    if any(cid.startswith(name + "/roller") for cid in ob.ids):
        if roller is None:
            raise RvtoolInputError("roller = None is only valid for the lumped bearing model; give a roller index")
        rows = _contact_rows(ob, f"{name}/roller{roller}")
        if rows.size == 0:
            raise RvtoolInputError(f"roller = {roller} is outside the valid range [0, {eb.n_rollers - 1}]")
        F, pc, nrm, ratio = _merge(ob.obs, rows)
        cid = f"{name}/roller{roller}"
    else:
        if roller is not None:
            raise RvtoolInputError(f"roller = {roller!r}: the lumped bearing model has no rollers; pass None")
        rows = _contact_rows(ob, name)
        if rows.size == 0:
            raise RvtoolInputError(f"wheel = {wheel}: no eccentric bearing contact '{name}'")
        Fr, pc, nrm, ratio = _merge(ob.obs, rows)
        F = STRIBECK_LINE * Fr / eb.n_rollers
        cid = f"{name}/stribeck_max"
    if not F > 0:
        raise RvtoolInputError(f"{cid}: the needle carries no load at this state")
    r_roll = 0.5 * eb.roller_diameter
    if race == "journal":
        gap = _circle_pair_gap(r_roll, eb.inner_radius, conformal=False)
        r_eq = r_roll * eb.inner_radius / (r_roll + eb.inner_radius)
    else:
        r_bore = eb.inner_radius + eb.roller_diameter + eb.radial_clearance
        gap = _circle_pair_gap(r_roll, r_bore, conformal=True)
        r_eq = r_roll * r_bore / (r_bore - r_roll)
    t, n = _frame(nrm)
    return LocalContact(name=f"{cid}/{race}", family=f"needle_{race}", wheel=int(wheel), force=float(F),
                        face_width=eb.roller_length, e_star=_e_star(model), poisson_ratio=model.material.poisson_ratio,
                        radius=r_eq, point=pc, tangent=t, normal=n, slice_force_ratio=ratio, extent=0.5 * r_roll,
                        _gap=gap)


def candidates(model, q, family, wheel, race="journal"):
    """All loaded contacts of ``family`` ("pins", "output_pins", "needles") of wheel ``wheel`` at q."""
    fam = {"pins": Family.PINS, "output_pins": Family.OUTPUT_PINS, "needles": Family.ECCENTRIC_BEARINGS}.get(family)
    if fam is None:
        raise RvtoolInputError(f"family = {family!r}; valid choices are ['pins', 'output_pins', 'needles']")
    ob = model.observe(q, fam)
    names, forces = ob.per_contact()
    loaded = [n for n, f in zip(names, forces) if f > 0]
    if fam == Family.PINS:
        pins = sorted(int(p.removeprefix("pin")) for w, p in (n.split("/") for n in loaded) if w == f"wheel{wheel}")
        return [pin_contact(model, q, wheel, p, obs=ob) for p in pins]
    if fam == Family.OUTPUT_PINS:
        pins = sorted(int(p.removeprefix("pin")) for _, p, w in (n.split("/") for n in loaded) if w == f"wheel{wheel}")
        return [output_pin_contact(model, q, wheel, p, obs=ob) for p in pins]
    name = f"eccentric_bearing{wheel}"
    if not any(cid.startswith(name + "/roller") for cid in ob.ids):   # lumped: one contact, if it is loaded
        return [needle_contact(model, q, wheel, None, race, obs=ob)] if name in loaded else []
    rollers = sorted(int(n.split("/")[1].removeprefix("roller")) for n in loaded if n.startswith(name + "/roller"))
    return [needle_contact(model, q, wheel, j, race, obs=ob) for j in rollers]
