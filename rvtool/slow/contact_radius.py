"""Local equivalent radius of the film contacts from the accepted contact records.

The film formulas of :mod:`rvtool.slow.lubrication` take the reduced radius R_x of
the two surfaces at the contact in the entrainment direction,

    1 / R_x = kappa_1 + kappa_2,

with the signed curvatures kappa of both surfaces at the contact point (positive
convex, negative concave). The curvatures are read at each accepted state of a
mechanical window from the family observation (contact point, row forces) and the
family's geometry:

* ring pin against the cycloid flank (``PINS``): kappa_1 = 1 / r_p, kappa_2 the
  signed curvature of the wheel profile at the contact point (Eq. (cycloid_geometry),
  :meth:`rvtool.geometry.cycloid.CycloidProfile.curvature_of_points`), located as the
  profile point nearest the observed contact point in wheel coordinates;
* involute tooth pair (``INVOLUTE_STAGE``): on the line of action the flank curvature
  radius is the roll length, rho = r_b u (u the roll angle of the observation), so
  1 / R = 1 / (r_bA u_A) + s_B / (r_bB u_B) with s_B = +1 for an external and -1 for
  an internal gear B (the kernel's curvature sum K of Eq. (series_contact)); a
  tip-edge contact (corner mode) has the convex edge radius rho_e on the cornering tooth.

Rolling-element and lumped bearings and the output pins keep their constant radii
(circles on circles: the curvature does not depend on the contact point), declared
by the topology's film contacts.

Over a window the radius of contact c is the reciprocal of its load-weighted mean
curvature sum, R_c = sum_n F_c,n dt_n / sum_n F_c,n kappa_c,n dt_n (accepted steps
only), the curvature that the window-mean load of the film formula meets on average.
"""
import numpy as np

from warp_contacts import involute_pairs_ref as iref

from ..errors import RvtoolInputError
from ..model import Family, physical_contact

#: Samples per tooth of the nearest-point search on the cycloid profile (a window of a quarter
#: tooth around the point's polar angle), refined by Newton iterations on
#: (c(phi) - p) . c'(phi) = 0; the refinement converges from one sample spacing.
PROFILE_SAMPLES_PER_TOOTH = 256
NEWTON_ITERATIONS = 4
#: phi step of the central differences of c(phi) in the Newton refinement [rad]
PHI_STEP = 1e-6

SUPPORTED = (Family.PINS, Family.INVOLUTE_STAGE)


def _rot(theta, p):
    c, s = np.cos(theta), np.sin(theta)
    return np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]])


class ProfileLocator:
    """Nearest point of a cycloid profile (wheel coordinates) and its curvature."""

    def __init__(self, profile):
        self.profile = profile
        n = PROFILE_SAMPLES_PER_TOOTH * profile.n_teeth
        phi = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        pts = profile.points(phi)
        polar = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2 * np.pi)
        order = np.argsort(polar)
        self.phi, self.points, self.polar = phi[order], pts[order], polar[order]

    def curvature_at(self, p):
        """Signed profile curvature [1/m] (positive convex) at the profile points nearest p (n, 2)."""
        p = np.atleast_2d(p)
        # nearest sample among a quarter tooth of samples around the point's polar angle (a contact
        # point lies within micrometres of the profile), then the Newton refinement
        n, W = len(self.phi), PROFILE_SAMPLES_PER_TOOTH // 4
        i0 = np.searchsorted(self.polar, np.mod(np.arctan2(p[:, 1], p[:, 0]), 2 * np.pi))
        idx = (i0[:, None] + np.arange(-W, W + 1)[None, :]) % n
        d2 = np.sum((self.points[idx] - p[:, None, :]) ** 2, axis=2)
        phi = self.phi[idx[np.arange(len(p)), np.argmin(d2, axis=1)]]
        h = PHI_STEP
        for _ in range(NEWTON_ITERATIONS):
            c0, cp, cm = (self.profile.points(phi + d) for d in (0.0, h, -h))
            d1 = (cp - cm) / (2 * h)
            d2 = (cp - 2 * c0 + cm) / h ** 2
            f = np.sum((c0 - p) * d1, axis=1)
            df = np.sum(d1 * d1, axis=1) + np.sum((c0 - p) * d2, axis=1)
            phi = phi - f / df
        return self.profile.curvature_of_points(phi)


class ContactCurvature:
    """Curvature sums kappa_1 + kappa_2 [1/m] of the rows of the supported families of ``model``.

    Reads the model through its public interface: ``observe``, ``family_spec`` (cycloid meshes),
    ``family_element(...).evaluator.meshes`` (involute meshes) and ``body_pose``.
    """

    def __init__(self, model):
        self.model = model
        self.families = tuple(f for f in SUPPORTED if f in model.families)
        self._locators = {}

    def _pins(self, q, ob):
        meshes = {m.name: m for m in self.model.family_spec(Family.PINS)}
        kap = np.zeros(len(ob.ids))
        mesh_of = np.array([rid.split("/")[0] for rid in ob.ids])
        for name in np.unique(mesh_of):
            m = meshes[name]
            rows = np.flatnonzero(mesh_of == name)
            on = rows[ob.normal_force[rows] > 0.0]
            if on.size == 0:
                continue
            loc = self._locators.get(id(m.profile))
            if loc is None:
                loc = self._locators[id(m.profile)] = ProfileLocator(m.profile)
            pose = self.model.body_pose(q, m.wheel_body)
            local = _rot(-pose[2], ob.position[on] - pose[:2])
            rp = m.pin_radius if m.pin_radius is not None else m.profile.pin_radius
            kap[on] = 1.0 / rp + loc.curvature_at(local)
        return kap

    def _involute(self, ob):
        obs = ob.obs
        meshes = {m.name: m for m in self.model.family_element(Family.INVOLUTE_STAGE).evaluator.meshes}
        kap = np.zeros(len(ob.ids))
        for r, rid in enumerate(ob.ids):
            if not obs[r, iref.O_FN] > 0.0:
                continue
            m = meshes[rid.split("/")[0]]
            A, B = m.pair.gear_a, m.pair.gear_b
            mode = int(obs[r, iref.O_MODE])
            ra = A.edge_radius if mode == iref.MODE_CORNER_A else A.base_radius * obs[r, iref.O_UA]
            rb = B.edge_radius if mode == iref.MODE_CORNER_B else B.base_radius * abs(obs[r, iref.O_UB])
            s_b = 1.0 if mode == iref.MODE_CORNER_B else float(m.pair.eps)   # B's tip edge is convex
            kap[r] = 1.0 / ra + s_b / rb
        return kap

    def rows(self, q, family):
        """(observation, curvature sum per row [1/m]; 0 on unloaded rows) of ``family`` at q."""
        fam = Family(family)
        ob = self.model.observe(q, fam)
        kap = self._pins(q, ob) if fam == Family.PINS else self._involute(ob)
        return ob, kap


def window_radii(model, states, families=None) -> dict:
    """{window contact id ``"<family>/<contact>"`` (:meth:`ReducerWindows.contact_ids`): R_c [m]} over accepted ``states``
    ((input angle [rad], accepted duration [s], q) as :attr:`ReducerWindows.last_states`):
    the reciprocal of the load-weighted mean curvature sum (rows of a physical contact merged).
    Contacts without load in the window are left out."""
    cc = ContactCurvature(model)
    fams = cc.families if families is None else tuple(Family(f) for f in families)
    bad = [f.value for f in fams if f not in cc.families]
    if bad:
        raise RvtoolInputError(f"families {bad} have no local curvature model; valid: "
                               f"{[f.value for f in cc.families]}")
    num, den = {}, {}
    for _, dt, q in states:
        for fam in fams:
            ob, kap = cc.rows(q, fam)
            ev = model.family_element(fam).evaluator
            if getattr(ev, "gap_offset_ids", None) is not None:
                # window identities of a mesh are its tooth flanks: both flanks of a row meet its curvature
                fa, fb = ev.flank_ids(ob.obs)
                owners = [(a, b) for a, b in zip(fa, fb)]
            else:
                owners = [(physical_contact(rid),) for rid in ob.ids]
            for own, f, k in zip(owners, ob.normal_force, kap):
                if f > 0.0:
                    for c in own:
                        cid = f"{fam.value}/{c}"
                        num[cid] = num.get(cid, 0.0) + f * k * dt
                        den[cid] = den.get(cid, 0.0) + f * dt
    out = {}
    for cid, n in num.items():
        if not n > 0.0:
            raise RvtoolInputError(f"contact {cid!r}: load-weighted curvature sum {n / den[cid]!r} 1/m is not "
                                   "positive (a conformal contact beyond the film formula's range)")
        out[cid] = den[cid] / n
    return out
