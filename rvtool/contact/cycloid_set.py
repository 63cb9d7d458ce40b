"""Cycloid--pin contact sets: specification (data) and evaluator.

One :class:`WheelPinMesh` describes the engagement of one wheel with the ring
pins: the profile, the pins (in the pin body's coordinates, with individual
centre errors), the face-width slices with their axial stations, crowning,
declared relative tilt and skew (Eq. (skew)), clearance and wheel normal
deviations (Eq. (gap)), and the contact law. A :class:`CycloidPinSet`
evaluates any number of meshes in one kernel launch and follows the
evaluator protocol of :class:`exudyn_user_elements.contact_element.ContactElement`.
"""
from dataclasses import dataclass, field

import numpy as np

from warp_contacts import cycloid_pins_ref as ref

from ..errors import RvtoolInputError
from ..geometry.cycloid import CycloidProfile, pin_centres
from ..validation import check_finite, check_nonnegative, check_positive
from .assembly import PairAssembler
from .circle_set import GROUND, FrictionLaw, FrictionModel, NormalLaw
from .evaluator import Evaluation, all_finite


def palmgren_line_approach(force, length):
    """Approach [m] of a steel line contact under ``force`` [N] over ``length`` [m]
    (Palmgren: delta = 3.84e-5 F^0.9 / L^0.8 with F in N, L and delta in mm)."""
    return 3.84e-5 * np.asarray(force) ** 0.9 / (length * 1e3) ** 0.8 * 1e-3


def secant_line_stiffness(reference_force, length):
    """Two-body line-contact secant k = F_ref / delta(F_ref) [N/m] at a stored reference load."""
    check_positive("reference_force", reference_force)
    check_positive("length", length)
    return reference_force / palmgren_line_approach(reference_force, length)


@dataclass(frozen=True, kw_only=True)
class WheelPinMesh:
    """Engagement of one wheel (body ``wheel_body``) with the ring pins (body ``pin_body``).

    profile: the wheel's :class:`CycloidProfile` (wheel coordinates).
    pin_body: body carrying all pins; pin_bodies: optionally one body per pin (z_b,)
    overriding pin_body, e.g. the port bodies of an elastic housing whose pose is the
    port displacement (the pin centres are then given in the housing frame).
    pin_radius: actual pin radius r_p [m] (may differ from the generating radius).
    pin_centre_errors: (z_b, 2) pin-centre errors [m] in the pin body's frame.
    normal_deviation: (z_b,) wheel normal deviation per pin station [m] (positive = material removed).
    clearance: uniform added gap [m].
    face_width: b [m]; n_slices: number of equal slices; wheel_z: axial station of the wheel
    midplane [m] (lever arms of the width resultant, Eq. (width_resultant)).
    crowning: drop at the slice edges [m], parabolic across the width.
    tilt_x, tilt_y: declared relative tilt of wheel and pins [rad]; skew: psi [rad] (Eq. (skew)).
    normal: law for the whole contact; the coefficient is divided among the slices.
    friction: NONE or REGULARIZED.
    """
    profile: CycloidProfile
    wheel_body: int
    pin_body: int = GROUND
    pin_bodies: tuple | None = None
    pin_radius: float | None = None
    pin_centre_errors: tuple | None = None
    normal_deviation: tuple | None = None
    clearance: float = 0.0
    face_width: float
    n_slices: int = 1
    wheel_z: float = 0.0
    crowning: float = 0.0
    tilt_x: float = 0.0
    tilt_y: float = 0.0
    skew: float = 0.0
    normal: NormalLaw
    friction: FrictionLaw = field(default_factory=FrictionLaw)
    name: str = "wheel"

    def __post_init__(self):
        check_positive("face_width", self.face_width)
        if not isinstance(self.n_slices, (int, np.integer)) or self.n_slices < 1:
            raise RvtoolInputError(f"n_slices = {self.n_slices!r} is outside the valid range [1, inf) (integer)")
        check_nonnegative("crowning", self.crowning)
        for nm in ("clearance", "tilt_x", "tilt_y", "skew", "wheel_z"):
            check_finite(nm, getattr(self, nm))
        if self.pin_radius is not None:
            check_positive("pin_radius", self.pin_radius)
        if self.friction.model == FrictionModel.ANCHOR:
            raise RvtoolInputError("friction.model = ANCHOR is not available for cycloid-pin contacts; valid: NONE, REGULARIZED")
        zb = self.profile.n_pins
        if self.pin_bodies is not None and np.shape(self.pin_bodies) != (zb,):
            raise RvtoolInputError(f"pin_bodies must have shape ({zb},); got {np.shape(self.pin_bodies)}")
        if self.normal_deviation is not None and np.shape(self.normal_deviation) != (zb,):
            raise RvtoolInputError(f"normal_deviation must have shape ({zb},); got {np.shape(self.normal_deviation)}")

    @property
    def slice_z(self):
        """Axial stations of the slice midpoints relative to the wheel midplane [m]."""
        b, n = self.face_width, self.n_slices
        return (np.arange(n) + 0.5) * b / n - 0.5 * b


def auto_window(profile, table, pin_radius, margin=1.5):
    """Search half-window [samples] that always contains the closest sample: the largest
    index distance between a point at the pin distance off the profile and its foot."""
    P, Nn, K, polar, h = table[:5]
    probe = P + (pin_radius * 1.2) * Nn
    beta = np.mod(np.arctan2(probe[:, 1], probe[:, 0]), 2 * np.pi)
    i0 = np.searchsorted(polar, beta)
    n = len(P)
    off = np.abs(((i0 - np.arange(n)) + n // 2) % n - n // 2)
    return int(np.ceil(margin * off.max())) + 2


class CycloidPinSet:
    """Evaluator of cycloid--pin meshes between ``n_bodies`` planar bodies.

    samples_per_tooth: profile table resolution (arc-length resampled).
    search: "discrete" (window search and osculating-arc projection on the table) or
    "analytic" (Newton iterations on (c - p) . c' = 0 of the analytic profile from the
    nearest sample; equidistant, offset and rotation modifications only).
    backend "warp" (default, one launch) or "numpy"; precision "float64" or "float32".
    """

    def __init__(self, meshes, n_bodies, *, samples_per_tooth=120, backend="warp", precision="float64",
                 device="cpu", name="pins", search="discrete"):
        if len(meshes) == 0:
            raise RvtoolInputError("meshes must contain at least one WheelPinMesh")
        if backend not in ("warp", "numpy"):
            raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are ['warp', 'numpy']")
        if search not in ("discrete", "analytic"):
            raise RvtoolInputError(f"search = {search!r} is not valid; valid choices are ['discrete', 'analytic']")
        self.search = search
        if samples_per_tooth < 8:
            raise RvtoolInputError(f"samples_per_tooth = {samples_per_tooth} is outside the valid range [8, inf)")
        self.name = name
        self.meshes = tuple(meshes)
        self.n_bodies = n_bodies
        self.backend = backend
        self.precision = precision
        self.history = type("NoHistory", (), {})()
        self.tables = []
        fp, ip, ids, mesh_of, pin_of = [], [], [], [], []
        window = 0
        for m_i, m in enumerate(self.meshes):
            pin_bodies = (m.pin_body,) * m.profile.n_pins if m.pin_bodies is None else tuple(int(b) for b in m.pin_bodies)
            for nm, b in [("wheel_body", m.wheel_body), ("pin_body", m.pin_body)] + \
                    [(f"pin_bodies[{k}]", b) for k, b in enumerate(pin_bodies)]:
                if not (b == GROUND or 0 <= b < n_bodies):
                    raise RvtoolInputError(f"meshes[{m_i}].{nm} = {b} is outside the valid range [0, {n_bodies - 1}] or GROUND")
            prof = m.profile
            tab = prof.table(samples_per_tooth * prof.n_teeth)
            self.tables.append(tab)
            rp = prof.pin_radius if m.pin_radius is None else m.pin_radius
            window = max(window, auto_window(prof, tab, rp))
            pins = pin_centres(prof, m.pin_centre_errors)
            dev = np.zeros(prof.n_pins) if m.normal_deviation is None else np.asarray(m.normal_deviation, float)
            zs = m.slice_z
            crown = m.crowning * (2 * zs / m.face_width) ** 2
            ks = m.normal.stiffness / m.n_slices
            for k in range(prof.n_pins):
                for s_i, z in enumerate(zs):
                    row = np.zeros(ref.N_FLOAT)
                    row[ref.C_XI_B:ref.C_XI_B + 2] = pins[k]
                    row[ref.C_RP] = rp
                    row[ref.C_E] = m.clearance + dev[k] + crown[s_i] + z * np.tan(m.skew)
                    row[ref.C_K], row[ref.C_P] = ks, m.normal.p
                    row[ref.C_C], row[ref.C_DR] = m.normal.damping / m.n_slices, m.normal.ramp_depth
                    f = m.friction
                    row[ref.C_MUK], row[ref.C_MUS], row[ref.C_VS], row[ref.C_VREG] = (
                        f.mu_kinetic, f.mu_s, f.stribeck_speed, f.regularization_speed)
                    row[ref.C_Z], row[ref.C_TX], row[ref.C_TY] = z, m.tilt_x, m.tilt_y
                    fp.append(row)
                    g = n_bodies
                    pb = pin_bodies[k]
                    ip.append((g if m.wheel_body == GROUND else m.wheel_body, g if pb == GROUND else pb,
                               int(f.model), m_i))
                    ids.append(f"{m.name}/pin{k}/s{s_i}")
                    mesh_of.append(m_i)
                    pin_of.append(k)
        self.window = window
        self.fparams = np.array(fp)
        self.iparams = np.array(ip, dtype=np.int32)
        self.ids = tuple(ids)
        self.mesh_of = np.array(mesh_of)
        self.pin_of = np.array(pin_of)
        self.n_contacts = len(fp)
        self.assembler = PairAssembler(self.iparams[:, 0], self.iparams[:, 1], n_bodies)
        self._pose = np.zeros((n_bodies + 1, 3))
        self._vel = np.zeros((n_bodies + 1, 3))
        self.analytic = ([m.profile.analytic_parameters() for m in self.meshes] if search == "analytic" else None)
        if backend == "warp":
            from warp_contacts.cycloid_pins import CycloidPinKernel
            self._kernel = CycloidPinKernel(self.fparams, self.iparams, self.tables, window, n_bodies, precision, device,
                                            analytic=self.analytic)
        elif precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")

    def raw(self, pose, vel):
        self._pose[:-1] = pose
        self._vel[:-1] = vel
        if self.backend == "warp":
            return self._kernel.evaluate(self._pose, self._vel)
        return ref.evaluate(self._pose, self._vel, self.fparams, self.iparams, self.tables, self.window, self.analytic)

    def evaluate(self, pose, vel, history=None, check=True):
        if check:
            for nm, a in (("pose", pose), ("vel", vel)):
                a = np.asarray(a)
                if a.shape != (self.n_bodies, 3) or not np.all(np.isfinite(a)):
                    raise RvtoolInputError(f"{nm} must be a finite array of shape ({self.n_bodies}, 3); got {a.shape}")
        Qc, dq, dv, obs = self.raw(pose, vel)
        finite = all_finite(Qc, dq, dv)
        return Evaluation(self.assembler.vector(np.asarray(Qc, float)), self.assembler.matrix(np.asarray(dq, float)),
                          self.assembler.matrix(np.asarray(dv, float)), np.array(obs, float), (), finite)

    def commit(self, pose, vel, evaluation=None):
        if evaluation is not None:
            return np.array(evaluation.obs, float)
        return np.array(self.raw(pose, vel)[3], float)

    def pin_forces(self, obs):
        """Per mesh, per pin: normal force summed over the slices [N] -> (n_meshes, z_b)."""
        out = np.zeros((len(self.meshes), max(m.profile.n_pins for m in self.meshes)))
        np.add.at(out, (self.mesh_of, self.pin_of), obs[:, ref.O_FN])
        return out

    def width_moments(self, obs):
        """Eq. (width_resultant): per mesh, the moments (M_x, M_y) [N m] of the slice forces
        about the wheel midplane (x_s - O has the axial component z_s)."""
        z = self.fparams[:, ref.C_Z]
        f = -obs[:, ref.O_FN][:, None] * obs[:, ref.O_NX:ref.O_NY + 1]  # force on the wheel
        M = np.zeros((len(self.meshes), 2))
        np.add.at(M, self.mesh_of, np.column_stack([-z * f[:, 1], z * f[:, 0]]))
        return M
