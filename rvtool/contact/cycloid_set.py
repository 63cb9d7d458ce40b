"""Cycloid--pin contact sets: specification (data) and evaluator.

One :class:`WheelPinMesh` describes the engagement of one wheel with the ring
pins: the profile, the pins (in the pin body's coordinates, with individual
centre errors), the face-width slices with their axial stations, crowning,
declared relative tilt and skew (Eq. (skew)), clearance and wheel normal
deviations (Eq. (gap)), and the contact law. A :class:`CycloidPinSet`
evaluates any number of meshes in one kernel launch and follows the
evaluator protocol of :class:`exudyn_user_elements.contact_element.ContactElement`.
"""
import contextlib
import contextvars
import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np

from warp_contacts import anchor_ref
from warp_contacts import cycloid_pins_ref as ref
from warp_contacts.circle_pairs_ref import FRICTION_REGULARIZED

from ..errors import RvtoolInputError
from ..geometry.cycloid import CycloidProfile, pin_centres
from ..validation import check_finite, check_nonnegative, check_positive
from .circle_set import GROUND, FrictionLaw, FrictionModel, NormalLaw
from .evaluator import gap_offset_rows, moved_member, renamed_ids
from .pair_set import PairFamilySet, check_backend


def palmgren_line_approach(force, length):
    """Approach [m] of a steel line contact under ``force`` [N] over ``length`` [m]
    (Palmgren: delta = 3.84e-5 F^0.9 / L^0.8 with F in N, L and delta in mm)."""
    return 3.84e-5 * np.asarray(force) ** 0.9 / (length * 1e3) ** 0.8 * 1e-3


PALMGREN_EXPONENT = 10.0 / 9.0
"""Exponent p of Palmgren's line contact written as a force law F = k delta^p (p = 1/0.9)."""


def palmgren_line_coefficient(length):
    """Coefficient k [N/m^p] of Palmgren's steel line contact F = k delta^(10/9) over ``length``
    [m]: the inverse of :func:`palmgren_line_approach` (delta = 3.84e-5 F^0.9 / L^0.8, F in N, L
    and delta in mm; Palmgren, Ball and Roller Bearing Engineering, 1959; Harris & Kotzalas,
    Essential Concepts of Bearing Technology, 5th ed. 2007, Eq. (6.29)). No reference load: the
    law is the nonlinear approach itself."""
    check_positive("length", length)
    return ((length * 1e3) ** 0.8 / 3.84e-8) ** PALMGREN_EXPONENT     # delta [m] = 3.84e-8 F^0.9 / (L [mm])^0.8


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
    friction: NONE, REGULARIZED or ANCHOR (stick--slip anchors per slice, Eq. (friction) anchor
    model; the tangential stiffness k_t is the whole contact's and divided among the slices like
    the normal coefficient). An ANCHOR law with mu_kinetic = 0 runs the frictionless code.
    anchor_release_distance: d_rel [m] above which an anchor's separation releases it (the
    contact migrated, :mod:`warp_contacts.anchor_ref`); None: 10 % of the pin radius, three
    orders above the stick stroke mu F_n / k_t of a loaded pin and far below a lobe's length.
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
    anchor_release_distance: float | None = None

    def __post_init__(self):
        check_positive("face_width", self.face_width)
        if not isinstance(self.n_slices, (int, np.integer)) or self.n_slices < 1:
            raise RvtoolInputError(f"n_slices = {self.n_slices!r} is outside the valid range [1, inf) (integer)")
        check_nonnegative("crowning", self.crowning)
        for nm in ("clearance", "tilt_x", "tilt_y", "skew", "wheel_z"):
            check_finite(nm, getattr(self, nm))
        if self.pin_radius is not None:
            check_positive("pin_radius", self.pin_radius)
        if self.anchor_release_distance is not None:
            check_positive("anchor_release_distance", self.anchor_release_distance)
        zb = self.profile.n_pins
        if self.pin_bodies is not None and np.shape(self.pin_bodies) != (zb,):
            raise RvtoolInputError(f"pin_bodies must have shape ({zb},); got {np.shape(self.pin_bodies)}")
        if self.normal_deviation is not None and np.shape(self.normal_deviation) != (zb,):
            raise RvtoolInputError(f"normal_deviation must have shape ({zb},); got {np.shape(self.normal_deviation)}")

    @property
    def anchors(self):
        """True where the mesh carries anchors (ANCHOR law with mu > 0)."""
        return self.friction.model == FrictionModel.ANCHOR and self.friction.mu_kinetic > 0.0

    @property
    def slice_z(self):
        """Axial stations of the slice midpoints relative to the wheel midplane [m]."""
        b, n = self.face_width, self.n_slices
        return (np.arange(n) + 0.5) * b / n - 0.5 * b


@functools.lru_cache(maxsize=64)
def _sampled(profile, n_samples):
    arrays = profile.table(n_samples)
    for a in arrays:
        if isinstance(a, np.ndarray):
            a.flags.writeable = False          # shared by every set of this profile
    return arrays


def sampled_profile(profile, n_samples):
    """``profile.table(n_samples)``, computed once per (profile, n) in a process (the profile is a
    frozen dataclass: Monte Carlo variants that draw pin radii, phases or eccentricity
    differences share their wheel profile, and sampling it costs ~40 ms on RV-40E). The arrays
    are read-only; an unhashable profile is sampled each time."""
    try:
        hash(profile)
    except TypeError:
        return profile.table(n_samples)
    return _sampled(profile, int(n_samples))


def pin_curve_table(table, pin_radius):
    """The profile table ordered for the search of a pin of radius ``pin_radius`` [m].

    The kernel's first guess is a binary search of the pin centre's polar angle in the
    table's polar column. Keyed on the profile points' own polar angles, that guess is off
    by the angle between a pin centre and its foot on the profile (up to ~50 samples on
    RD-40), which the search window must cover for every slice and evaluation. Keyed on the
    polar angle of the pin-centre curve P + r_p N (where a touching pin's centre lies, the
    epitrochoid for an unmodified profile), the guess is the foot itself for a touching pin
    and a few samples off for a pin within +-0.2 r_p of contact, so the window shrinks by
    an order of magnitude at the same guarantee (:func:`auto_window`).

    Returns the table (points, normals, curvature, key polar angle, spacing, phi) circularly
    shifted so that the key starts at its smallest value in [0, 2 pi) (the kernel indexes
    modulo n), or the table unchanged when the pin-centre curve is not star-shaped about
    the wheel centre (its polar angle not monotone), where only the profile's key is sorted.
    """
    P, Nn, K, polar, h, phi = table
    probe = P + pin_radius * Nn
    key = np.arctan2(probe[:, 1], probe[:, 0])
    step = np.diff(np.unwrap(np.concatenate([key, key[:1]])))
    if not (np.all(step > 0.0) and abs(np.sum(step) - 2 * np.pi) < 1e-9):
        return table
    key = np.mod(key, 2 * np.pi)
    k0 = int(np.argmin(key))
    roll = lambda a: np.roll(a, -k0, axis=0)
    return roll(P), roll(Nn), roll(K), roll(key), h, roll(phi)


def auto_window(profile, table, pin_radius, band=0.05, margin=1.5):
    """Search half-window [samples] that contains the closest sample of every pin centre
    within ``band`` x r_p of contact (distance to the profile in [(1 - band) r_p,
    (1 + band) r_p]): the largest index distance between such a point and its foot, with a
    margin. Farther pins may be given a farther sample: their gap is then overestimated,
    never underestimated (the sample distance bounds the true distance from above), so a
    pin beyond the band off contact still carries no force."""
    P, Nn, K, polar, h = table[:5]
    n = len(P)
    off = 0
    for dist in np.linspace(1.0 - band, 1.0 + band, 9):
        probe = P + (pin_radius * dist) * Nn
        beta = np.mod(np.arctan2(probe[:, 1], probe[:, 0]), 2 * np.pi)
        i0 = np.searchsorted(polar, beta)
        off = max(off, int(np.abs(((i0 - np.arange(n)) + n // 2) % n - n // 2).max()))
    return int(np.ceil(margin * off)) + 2


PIN_RADIUS_SLACK = 0.01
"""Default relative pin-radius allowance of :func:`shared_profile_tables`: a mesh whose pin radius is within
1 % of its profile's generating radius (Monte Carlo pin-radius tolerances are ~0.1 %: h4 on 6-7 mm pins)
searches the profile's shared table."""

_SHARED_SLACK = contextvars.ContextVar("rvtool_shared_profile_tables", default=None)


@contextlib.contextmanager
def shared_profile_tables(slack=PIN_RADIUS_SLACK, *, defer=False):
    """Within this context a :class:`CycloidPinSet` takes its profile tables from one shared table per
    (profile, sampling) (:class:`ProfileTable`) instead of one per (profile, pin radius).

    A table depends on the pin radius r_p only through its search key (the polar angle of the pin-centre
    curve P + r_p N, :func:`pin_curve_table`) and its window (:func:`auto_window`); the points, normals,
    curvatures and generating angles are the profile's. The shared table is keyed at the profile's
    generating radius r_0 and its window covers every pin radius within ``slack`` x r_0 (the search band
    widened by the slack), so a mesh of pin radius r_p with |r_p - r_0| <= slack r_0 finds the same nearest
    sample as with its own table, and the contact (discrete projection or analytic Newton from that sample)
    is the same: Monte Carlo variants that differ in pin radius, clearances, pin positions or
    eccentricity share their wheel's table (the device holds one table per distinct profile, a pickled
    snapshot carries its key; tests/test_shared_tables.py). Only the window grows (by a sample or two).
    Builds outside the context are unchanged.

    defer: the sets built here do not compute their tables (nor their search windows): a table is computed
    where it is first read, or for many at once on a Warp device by :func:`compute_profile_tables` (a
    Monte Carlo's build helpers then send each variant's profile, not its tables: RD-40 ~8 of ~13 ms of a
    variant's build and 524 of 548 kB of its snapshot). Default off (the tables computed here)."""
    if not (isinstance(slack, (int, float)) and 0.0 <= slack <= 0.1):
        raise RvtoolInputError(f"slack = {slack!r} is outside the valid range [0, 0.1] (fraction of the pin radius)")
    token = _SHARED_SLACK.set((float(slack), bool(defer)))
    try:
        yield
    finally:
        _SHARED_SLACK.reset(token)


_TURN_WINDOWS = {}
"""Search windows of the shared tables by profile without its rotation (:func:`_shared_entry`)."""


@functools.lru_cache(maxsize=256)
def _shared_entry(profile, n_samples, search, band, slack):
    """(table, analytic parameters or None, window) of a :class:`ProfileTable` key, once per process.
    The table is the profile's own (:meth:`CycloidProfile.table`, bit for bit); profiles that differ in
    their rotation only (the wheels of one reducer: their assembly phases) take the search window of the
    first of them: the window counts samples between a pin's polar angle and its foot, which turning
    every sample keeps, so an RD-40 variant (its profile drawn per variant) searches its window once,
    not per wheel (~1-2 ms a wheel)."""
    rp = profile.pin_radius
    tab = pin_curve_table(sampled_profile(profile, n_samples), rp)
    key = (tuple((f.name, getattr(profile, f.name)) for f in dataclasses.fields(profile) if f.name != "rotation_mod"),
           n_samples, search, band, slack)
    try:
        window = _TURN_WINDOWS.get(key)
    except TypeError:                     # an unhashable member (a list table): its own window
        key = window = None
    if window is None:
        window = auto_window(profile, tab, rp, band=band + slack * (1.0 + band))
        if key is not None:
            if len(_TURN_WINDOWS) > 1024:
                _TURN_WINDOWS.clear()
            _TURN_WINDOWS[key] = window
    for a in tab:
        if isinstance(a, np.ndarray) and a.flags.owndata:
            a.flags.writeable = False
    return tab, profile.analytic_parameters() if search == "analytic" else None, window


class ProfileTable:
    """A profile table shared by every mesh of one profile and sampling (:func:`shared_profile_tables`):
    the sequence (points, normals, curvature, key polar angle, spacing, phi) of :func:`pin_curve_table` at
    the profile's generating radius, computed on first use once per process. ``key`` identifies it
    (equal keys: the same table). Pickled as its key where this process used it for more than one set
    (the receiving process computes it once), else with its arrays (a profile of one variant only, e.g.
    RD-40's drawn profile modifications: computing it again would move the build into the receiver). A table
    not computed in this process (deferred: :func:`shared_profile_tables` ``defer``) is pickled as its key;
    :meth:`provide` gives it arrays computed elsewhere (:func:`compute_profile_tables`)."""

    __slots__ = ("key", "_entry", "_arrays", "_device")
    _uses = {}

    def __init__(self, profile, n_samples, search, band, slack, arrays=None):
        self.key = (profile, int(n_samples), str(search), float(band), float(slack))
        self._entry = None
        self._arrays = arrays
        self._device = None             # (_DeviceTables, row, window, spacing): computed on a Warp device
        if len(ProfileTable._uses) > 65536:     # a process that saw 100,000 drawn profiles: forget the old ones
            ProfileTable._uses.clear()
        ProfileTable._uses[self.key] = ProfileTable._uses.get(self.key, 0) + 1

    @property
    def computed(self):
        """Whether this object holds its table (computed or provided, or being computed on a device:
        :func:`compute_profile_tables` ``wait=False``), i.e. it is not to be computed again."""
        return self._entry is not None or self._arrays is not None or self._device is not None

    def _settled(self):
        """This table's device row once its launch finished: a table launched without waiting
        (:func:`compute_profile_tables` ``wait=False``) reads its batch's host numbers at its first use
        (the device waited for there, once per batch); one that failed the device's checks is then left
        to the host (computed where read)."""
        dev = self._device
        if dev is not None and dev[2] is None:
            h, window, ok = dev[0].finish()
            self._device = (dev[0], dev[1], int(window[dev[1]]), float(h[dev[1]])) if ok[dev[1]] else None
        return self._device

    def provide(self, table, window):
        """Give this table its arrays ``table`` (points, normals, curvature, key, spacing, phi: as
        :func:`pin_curve_table`) and search ``window`` [samples] computed elsewhere (a no-op where it holds
        them already)."""
        if not self.computed:
            self._arrays = (tuple(table), int(window))

    def provide_device(self, batch, row, window=None, spacing=None):
        """Give this table its columns as row ``row`` of a batch computed on a Warp device
        (:func:`compute_profile_tables`): the device's kernels read them there (:meth:`device_column`);
        the host arrays are read back only where the host reads them. window, spacing: None while the
        batch's launch runs (read from it at this table's first use)."""
        if not self.computed:
            self._device = (batch, int(row), None if window is None else int(window),
                            None if spacing is None else float(spacing))

    @property
    def read_back(self):
        """Whether this table's arrays were computed on a Warp device and copied to the host since (a
        host reader asked for them: :attr:`entry`); False for a device table read in place only
        (:meth:`device_column`) and for a table computed or provided on the host."""
        return self._settled() is not None and self._device[0].read_back

    @property
    def n_samples(self):
        """Samples of the table (its key's count: every table of the key has that many)."""
        return self.key[1]

    @property
    def spacing(self):
        """The table's sample spacing [m] (without reading a device table back)."""
        if self._entry is None and self._arrays is None and self._settled() is not None:
            return self._device[3]
        return self.entry[0][4]

    def device_column(self, i, device):
        """(device array (T, n[, 2]), row) holding column ``i`` (0 points, 1 normals, 2 curvature, 3 key,
        5 phi) of this table on Warp ``device``, or None (not computed there)."""
        if self._settled() is None or i not in _DEVICE_COLUMN:
            return None
        return self._device[0].columns[_DEVICE_COLUMN[i]], self._device[1]

    @property
    def entry(self):
        """(table, analytic parameters or None, search window)."""
        if self._entry is None:
            if self._arrays is None and self._settled() is not None:
                batch, t, window, h = self._device
                pts, nrm, kap, key, phi = batch.host()
                self._arrays = ((pts[t], nrm[t], kap[t], key[t], h, phi[t]), window)
            if self._arrays is not None:
                prof, n, search, band, slack = self.key
                self._entry = (self._arrays[0], prof.analytic_parameters() if search == "analytic" else None,
                               self._arrays[1])
            else:
                self._entry = _shared_entry(*self.key)
        return self._entry

    @property
    def window(self):
        if self._entry is None and self._arrays is None and self._settled() is not None:
            return self._device[2]
        return self.entry[2]

    def __getitem__(self, i):
        return self.entry[0][i]

    def __len__(self):
        return len(self.entry[0])

    def __iter__(self):
        return iter(self.entry[0])

    def __eq__(self, other):
        """Equal keys: the same table (its arrays are a function of the key)."""
        return isinstance(other, ProfileTable) and self.key == other.key

    def __hash__(self):
        return hash(self.key)

    def __reduce__(self):
        if ProfileTable._uses.get(self.key, 0) > 1 or not self.computed:
            return ProfileTable, self.key
        return ProfileTable, self.key + ((self.entry[0], self.entry[2]),)


def _shared_table(prof, rp, samples_per_tooth, search, band):
    """(ProfileTable, analytic parameters or None, window) of a mesh of pin radius ``rp`` inside
    :func:`shared_profile_tables`, or None (outside it, or ``rp`` beyond the slack: a table of its own)."""
    mode = _SHARED_SLACK.get()
    if mode is None:
        return None
    slack, defer = mode
    if abs(rp - prof.pin_radius) > slack * prof.pin_radius:
        return None
    try:
        hash(prof)
    except TypeError:
        return None
    t = ProfileTable(prof, samples_per_tooth * prof.n_teeth, search, band, slack)
    if defer:                       # the window comes with the table (CycloidPinSet.window)
        return t, prof.analytic_parameters() if search == "analytic" else None, None
    return t, t.entry[1], t.window


_DEVICE_COLUMN = {0: 0, 1: 1, 2: 2, 3: 3, 5: 4}
"""Table column -> column of a device batch (the spacing, column 4, is a host number)."""


class _DeviceTables:
    """The columns (points, normals, curvature, key, phi) of a batch of profile tables on a Warp device
    (:class:`warp_contacts.profile_tables.PendingTables`), read back (once, read-only) only where the host
    reads a table of it."""

    __slots__ = ("columns", "_host", "_pending")

    def __init__(self, pending):
        self.columns, self._host, self._pending = tuple(pending.columns), None, pending

    def finish(self):
        """(spacing, window, ok) per row, the launch waited for once (PendingTables.finish)."""
        return self._pending.finish()

    @property
    def read_back(self):
        """Whether the host has read this batch back (:meth:`host`)."""
        return self._host is not None

    def host(self):
        if self._host is None:
            host = tuple(c.numpy() for c in self.columns)
            for a in host:
                a.flags.writeable = False
            self._host = host
        return self._host


DEVICE_TABLE_GROUP = {"cpu": 256, "cuda": 2048}
"""Profile tables per launch of :func:`compute_profile_tables` by device kind (its dense arc lengths: 16 x 8
bytes per sample and table, ~150 MB for 256 RD-40 tables; on a GPU the serial arc-length pass of a launch
takes as long for 2,048 tables as for 256, so fewer, larger launches)."""


def compute_profile_tables(tables, device="cpu", group=None, timing=None, wait=True):
    """Compute the deferred :class:`ProfileTable` objects among ``tables`` (:func:`shared_profile_tables`
    ``defer``) on Warp ``device``, each distinct key once, ``group`` tables per launch (None:
    :data:`DEVICE_TABLE_GROUP` of the device kind)
    (:func:`warp_contacts.profile_tables.profile_tables`: the host's operations, equal to its tables to
    rounding: on the cpu bit for bit but for ~1 ulp of the curvature and the key; the device's own sine
    and cosine on a GPU), and give them to every object of that key (:meth:`ProfileTable.provide`).
    Profiles with a tabulated radial modification or lobe rotations (the device kernels compute neither), and a
    table whose polar angle or key is not monotone (checked on the device), are left to the host (computed where first read). The columns stay on the
    device (:meth:`ProfileTable.device_column`: a cycloid pin kernel there reads them in place, nothing is
    read back); the host reads a table back where it reads its arrays. Returns the number of distinct tables
    computed on the device. timing: None or a dict receiving the stages' times [s] (the ``timing`` of
    :func:`warp_contacts.profile_tables.launch_profile_tables`, summed over the launches). wait: False
    launches the kernels and returns at once (the count is then of the tables launched): each table reads
    its batch's host numbers (window, spacing, whether it passed the device's checks) at its first use,
    where the device is waited for, so that host work between the call and that use runs while the device
    computes (:class:`rvtool.solver.device_rows.DeviceRowNewton`)."""
    from warp_contacts.profile_tables import launch_profile_tables
    todo = {}
    for t in tables:
        if isinstance(t, ProfileTable) and not t.computed:
            todo.setdefault(t.key, []).append(t)
    batches = {}
    for key in todo:
        prof, n, _, band, slack = key
        if prof.radial_mod_table is None and prof.lobe_rotations is None:
            batches.setdefault((n, band + slack * (1.0 + band)), []).append(key)
    if group is None:
        group = DEVICE_TABLE_GROUP["cpu" if str(device).startswith("cpu") else "cuda"]
    done = 0
    for (n, band), keys in batches.items():
        for g in range(0, len(keys), int(group)):
            chunk = keys[g:g + int(group)]
            profs = [k[0] for k in chunk]
            params = [(p.R, p.K1, float(p.n_pins), p.pin_radius + p.equidistant_mod, p.rotation_mod) for p in profs]
            pending = launch_profile_tables(params, [p.n_pins for p in profs], [p.pin_radius for p in profs], n,
                                            16 * n, band, device=device, timing=timing)
            batch = _DeviceTables(pending)      # left on the device (the cycloid pin kernel reads it there)
            if not wait:
                for i, k in enumerate(chunk):
                    for t in todo[k]:
                        t.provide_device(batch, i)
                done += len(chunk)
                continue
            h, window, ok = batch.finish()
            for i, k in enumerate(chunk):
                if ok[i]:
                    for t in todo[k]:
                        t.provide_device(batch, i, window[i], h[i])
                    done += 1
    return done


class CycloidPinSet(PairFamilySet):
    """Evaluator of cycloid--pin meshes between ``n_bodies`` planar bodies.

    samples_per_tooth: profile table resolution (arc-length resampled).
    search: "discrete" (window search and osculating-arc projection on the table) or
    "analytic" (Newton iterations on (c - p) . c' = 0 of the analytic profile from the
    nearest sample; equidistant, offset and rotation modifications only).
    search_band: the window holds the nearest sample of every pin centre within
    search_band x r_p of contact (see :func:`auto_window`); default 0.05 (150 um on RD-40,
    window 33 samples instead of 113 for the profile-keyed search).
    backend "warp" (default, one launch) or "numpy"; precision "float64" or "float32".
    tables: profile tables computed before, {(profile, pin radius): (table, analytic parameters
    or None, search window)} as :meth:`profile_tables` returns them for the same
    samples_per_tooth, search and search_band (a copy of built sets reuses them instead of
    sampling each profile again); a key not in it is computed.
    """

    def __init__(self, meshes, n_bodies, *, samples_per_tooth=120, backend="warp", precision="float64",
                 device="cpu", name="pins", search="discrete", search_band=0.05, tables=None):
        if len(meshes) == 0:
            raise RvtoolInputError("meshes must contain at least one WheelPinMesh")
        check_backend(backend, precision)
        if search not in ("discrete", "analytic"):
            raise RvtoolInputError(f"search = {search!r} is not valid; valid choices are ['discrete', 'analytic']")
        self.search = search
        if not (isinstance(search_band, (int, float)) and 0.0 < search_band <= 0.5):
            raise RvtoolInputError(f"search_band = {search_band!r} is outside the valid range (0, 0.5] "
                                   f"(fraction of the pin radius)")
        self.search_band = float(search_band)
        self.samples_per_tooth = samples_per_tooth
        if samples_per_tooth < 8:
            raise RvtoolInputError(f"samples_per_tooth = {samples_per_tooth} is outside the valid range [8, inf)")
        self.name = name
        self.meshes = tuple(meshes)
        self.backend = backend
        self.precision = precision
        self.tables = []
        self.table_windows = []
        self.analytic = [] if search == "analytic" else None
        table_of = {}            # identical tables are stored once (B copies of one design: one table)
        fp, ip, ids, mesh_of, pin_of, ap = [], [], [], [], [], []
        window = 0
        for m_i, m in enumerate(self.meshes):
            pin_bodies = (m.pin_body,) * m.profile.n_pins if m.pin_bodies is None else tuple(int(b) for b in m.pin_bodies)
            for nm, b in [("wheel_body", m.wheel_body), ("pin_body", m.pin_body)] + \
                    [(f"pin_bodies[{k}]", b) for k, b in enumerate(pin_bodies)]:
                if not (b == GROUND or 0 <= b < n_bodies):
                    raise RvtoolInputError(f"meshes[{m_i}].{nm} = {b} is outside the valid range [0, {n_bodies - 1}] or GROUND")
            prof = m.profile
            rp = prof.pin_radius if m.pin_radius is None else m.pin_radius
            # the table depends on the (frozen, hashable) profile and the pin radius only; inside
            # shared_profile_tables one table per profile (its key)
            shared = _shared_table(prof, float(rp), samples_per_tooth, search, self.search_band)
            if shared is None and tables is not None and isinstance(tables.get((prof, float(rp)), (None,))[0],
                                                                    ProfileTable):
                shared = tables[(prof, float(rp))]          # a copy of sets that shared their tables
            key = shared[0].key if shared is not None else (prof, float(rp))
            if key not in table_of:
                if shared is not None:
                    tab, ana, win = shared
                elif tables is not None and key in tables:
                    tab, ana, win = tables[key]
                else:
                    tab = pin_curve_table(sampled_profile(prof, samples_per_tooth * prof.n_teeth), rp)
                    ana = prof.analytic_parameters() if search == "analytic" else None
                    win = auto_window(prof, tab, rp, band=search_band)
                table_of[key] = len(self.tables)
                self.tables.append(tab)
                self.table_windows.append(win)
                if ana is not None:
                    self.analytic.append(ana)
                window = None if (window is None or win is None) else max(window, win)
            tb = table_of[key]
            pins = pin_centres(prof, m.pin_centre_errors)
            dev = np.zeros(prof.n_pins) if m.normal_deviation is None else np.asarray(m.normal_deviation, float)
            zs = m.slice_z
            crown = m.crowning * (2 * zs / m.face_width) ** 2
            ks = m.normal.stiffness / m.n_slices
            # the mesh's rows (pin k, slice s) in pin-major order, one array operation per column (the
            # same operations per element as a row at a time: the same rows bit for bit)
            zb, ns, f = prof.n_pins, m.n_slices, m.friction
            row = np.zeros((zb, ns, ref.N_FLOAT))
            row[:, :, ref.C_XI_B:ref.C_XI_B + 2] = np.asarray(pins, float)[:, None, :]
            row[:, :, ref.C_RP] = rp
            row[:, :, ref.C_E] = m.clearance + dev[:, None] + crown[None, :] + (zs * np.tan(m.skew))[None, :]
            row[:, :, ref.C_K], row[:, :, ref.C_P] = ks, m.normal.p
            row[:, :, ref.C_C], row[:, :, ref.C_DR] = m.normal.damping / m.n_slices, m.normal.ramp_depth
            row[:, :, ref.C_MUK], row[:, :, ref.C_MUS], row[:, :, ref.C_VS], row[:, :, ref.C_VREG] = (
                f.mu_kinetic, f.mu_s, f.stribeck_speed, f.regularization_speed)
            row[:, :, ref.C_Z] = zs[None, :]
            row[:, :, ref.C_TX], row[:, :, ref.C_TY] = m.tilt_x, m.tilt_y
            fp.append(row.reshape(zb * ns, ref.N_FLOAT))
            g = n_bodies
            irow = np.zeros((zb, ns, ref.N_INT), np.int32)
            irow[:, :, ref.J_BODY_A] = g if m.wheel_body == GROUND else m.wheel_body
            irow[:, :, ref.J_BODY_B] = np.array([g if pb == GROUND else pb for pb in pin_bodies], np.int32)[:, None]
            # mu = 0 under the anchor law is the frictionless contact (its code path, its figures)
            model = f.model if (f.model != FrictionModel.ANCHOR or m.anchors) else FrictionModel.NONE
            irow[:, :, ref.J_FRICTION], irow[:, :, ref.J_TABLE] = int(model), tb
            ip.append(irow.reshape(zb * ns, ref.N_INT))
            arow = np.zeros((zb * ns, anchor_ref.N_ANCHOR))
            if m.anchors:
                arow[:, anchor_ref.ANCHOR_KT] = f.tangential_stiffness / m.n_slices
                arow[:, anchor_ref.ANCHOR_MU] = f.mu_kinetic
                arow[:, anchor_ref.ANCHOR_RELEASE] = (0.1 * rp if m.anchor_release_distance is None
                                                      else m.anchor_release_distance)
            ap.append(arow)
            ids += [f"{m.name}/pin{k}/s{s_i}" for k in range(zb) for s_i in range(ns)]
            mesh_of.append(np.full(zb * ns, m_i, dtype=np.int64))
            pin_of.append(np.repeat(np.arange(zb, dtype=np.int64), ns))
        self._finish(window, np.concatenate(fp), np.concatenate(ip), ids, np.concatenate(mesh_of),
                     np.concatenate(pin_of), np.concatenate(ap), n_bodies, backend, precision, device)

    @classmethod
    def concatenated(cls, sets, nb, *, names=None, precision="float64", device="cpu"):
        """The set of B built sets side by side (copy c's bodies offset by c nb, the ground at
        B nb; mesh names ``names[c][k]``, default the built ones): their rows and profile tables
        concatenated (equal tables once), equal to the set built from the renamed, shifted meshes
        (tests/test_device_rows.py) without the per-row loop. Sets with stick--slip anchors, or
        whose sampling options differ, are built from the meshes."""
        s, B = sets[0], len(sets)
        names = names or [[m.name for m in sc.meshes] for sc in sets]
        shift = lambda b, c: b if b == GROUND else int(b) + c * nb
        meshes = [moved_member(m, name=nm, wheel_body=shift(m.wheel_body, c), pin_body=shift(m.pin_body, c),
                                      pin_bodies=None if m.pin_bodies is None
                                      else tuple(shift(b, c) for b in m.pin_bodies))
                  for c, sc in enumerate(sets) for m, nm in zip(sc.meshes, names[c])]
        opts = (s.samples_per_tooth, s.search, s.search_band, s.backend)
        if any(sc.anchor for sc in sets) or any((sc.samples_per_tooth, sc.search, sc.search_band, sc.backend) != opts
                                                for sc in sets):
            tables = {}
            for sc in sets:
                if (sc.samples_per_tooth, sc.search, sc.search_band) == opts[:3]:
                    tables.update(sc.profile_tables())
            return cls(meshes, B * nb, samples_per_tooth=s.samples_per_tooth, backend=s.backend, precision=precision,
                       device=device, name=s.name, search=s.search, search_band=s.search_band, tables=tables)
        self = object.__new__(cls)
        self.search, self.search_band, self.samples_per_tooth = s.search, s.search_band, s.samples_per_tooth
        self.name, self.meshes, self.backend, self.precision = s.name, tuple(meshes), s.backend, precision
        self.tables, self.table_windows = [], []
        self.analytic = [] if s.search == "analytic" else None
        table_of, ip, ids, mesh_of = {}, [], [], []
        n_mesh = 0
        for c, sc in enumerate(sets):
            local = {}                      # the set's table index -> the concatenation's (in mesh order)
            for m_i, m in enumerate(sc.meshes):
                rp = m.profile.pin_radius if m.pin_radius is None else m.pin_radius
                t = int(sc.iparams[np.flatnonzero(sc.mesh_of == m_i)[0], ref.J_TABLE])
                # a shared table (shared_profile_tables) once for every set that holds it
                key = sc.tables[t].key if isinstance(sc.tables[t], ProfileTable) else (m.profile, float(rp))
                if key not in table_of:
                    table_of[key] = len(self.tables)
                    self.tables.append(sc.tables[t])
                    self.table_windows.append(sc.table_windows[t])     # None: a deferred table's, read below
                    if self.analytic is not None:
                        self.analytic.append(sc.analytic[t])
                local[t] = table_of[key]
            i = sc.iparams.copy()
            for col in (ref.J_BODY_A, ref.J_BODY_B):
                i[:, col] = np.where(i[:, col] >= sc.n_bodies, B * nb, i[:, col] + c * nb)
            i[:, ref.J_TABLE] = np.vectorize(local.__getitem__, otypes=[np.int32])(i[:, ref.J_TABLE])
            ip.append(i)
            rename = {m.name: nm for m, nm in zip(sc.meshes, names[c])}
            ids += renamed_ids(sc.ids, rename)
            mesh_of.append(sc.mesh_of + n_mesh)
            n_mesh += len(sc.meshes)
        # the built rows (slow-state gap offsets and friction of a built set are not copied, as a set built from
        # the meshes)
        built = [getattr(sc, "_built_fparams", sc.fparams) for sc in sets]
        # the window read after the loop over the sets: a table still computed on the device is waited for
        # only here (None: the window property reads every table's)
        self._finish(None, np.concatenate(built), np.concatenate(ip), ids,
                     np.concatenate(mesh_of), np.concatenate([sc.pin_of for sc in sets]),
                     np.zeros((sum(sc.n_contacts for sc in sets), anchor_ref.N_ANCHOR)), B * nb, s.backend,
                     precision, device)
        return self

    @property
    def window(self):
        """The search half-window [samples] of every row: the largest of the tables' (a set built on
        deferred tables, :func:`shared_profile_tables`, reads them here: computed where not provided)."""
        if self._window is None:
            self._window = max(self.table_window(t) for t in range(len(self.tables)))
        return self._window

    @window.setter
    def window(self, value):
        self._window = value

    def table_window(self, t):
        """The search window [samples] of table ``t`` (a deferred table's once it is computed or provided)."""
        w = self.table_windows[t]
        if w is None:
            w = self.table_windows[t] = int(self.tables[t].window)
        return w

    def _finish(self, window, fparams, iparams, ids, mesh_of, pin_of, anchor_params, n_bodies, backend, precision,
                device):
        self.window = window
        self.fparams = fparams
        self.iparams = iparams
        self.ids = tuple(ids)
        self.mesh_of = mesh_of
        self.pin_of = pin_of
        self.n_contacts = len(fparams)
        anchor = bool(np.any(self.iparams[:, ref.J_FRICTION] == FrictionModel.ANCHOR))
        # committed anchors (wheel and pin-body coordinates) and slip distance per slice
        self.init_evaluation(self.iparams[:, ref.J_BODY_A], self.iparams[:, ref.J_BODY_B], n_bodies,
                             anchor_params=anchor_params if anchor else None)
        if backend == "warp":
            from warp_contacts.cycloid_pins import CycloidPinKernel
            self._kernel = CycloidPinKernel(self.fparams, self.iparams, self.tables, self.window, n_bodies, precision, device,
                                            analytic=self.analytic, anchor_params=self.anchor_params)
        elif precision != "float64":
            raise RvtoolInputError(f"precision = {precision!r} is not available for backend 'numpy' (valid: 'float64')")

    @property
    def table_source(self):
        """Where the warp kernel reads its profile tables from: "device_batch_view" (the rows of one batch
        computed on its device, read in place: :func:`compute_profile_tables`), "gathered" (device tables
        of several batches copied together on the device), "host" (host arrays uploaded); None for the
        numpy backend."""
        return self._kernel.table_source if self.backend == "warp" else None

    def profile_tables(self):
        """{(profile, pin radius [m]): (table, analytic parameters or None, search window)} of this
        set's meshes (the ``tables`` argument of a set with the same samples_per_tooth, search and
        search_band)."""
        out = {}
        for m_i, m in enumerate(self.meshes):
            rp = m.profile.pin_radius if m.pin_radius is None else m.pin_radius
            t = int(self.iparams[np.flatnonzero(self.mesh_of == m_i)[0], ref.J_TABLE])
            out[(m.profile, float(rp))] = (self.tables[t], None if self.analytic is None else self.analytic[t],
                                           self.table_window(t))
        return out

    def reference(self, pose, vel, anchor=None):
        return ref.evaluate(pose, vel, self.fparams, self.iparams, self.tables, self.window, self.analytic,
                            **({} if anchor is None else {"anchor": anchor}))

    def set_gap_offsets(self, offsets):
        """Gap offsets [m] per slice row (positive opens the gap), added to the deviation sum e of
        Eq. (gap), absolute over the built rows; zeros restore the built rows bit for bit."""
        self._slow_gap = gap_offset_rows(offsets, self.n_contacts, self.name)
        self._upload_slow_state()

    def set_friction_coefficients(self, mu):
        """Slow-state friction coefficient [-] per slice row (coupled lubrication), written as the
        kinetic and static coefficient of Eq. (friction) (no Stribeck peak), absolute over the built
        rows; None restores the built coefficients bit for bit. Only rows built with regularized
        friction carry it (a row built without friction has no tangential law to write into)."""
        if mu is None:
            self._slow_mu = None
        else:
            m = np.array(mu, dtype=np.float64)
            if m.shape != (self.n_contacts,):
                raise RvtoolInputError(f"friction coefficients of contact set {self.name!r} must have shape "
                                       f"({self.n_contacts},), one per observation row; got {m.shape}")
            if not np.all(np.isfinite(m)) or np.any(m < 0.0):
                raise RvtoolInputError(f"friction coefficients of contact set {self.name!r} are outside the valid "
                                       "range [0, inf)")
            off = self.iparams[:, ref.J_FRICTION] != FRICTION_REGULARIZED
            if np.any(off & (m != 0.0)):
                raise RvtoolInputError(f"contact set {self.name!r} was built without friction (pin_contact.mu = 0); "
                                       "a friction coefficient needs pin_contact.mu in (0, inf)")
            self._slow_mu = m
        self._upload_slow_state()

    def built_friction(self):
        """Kinetic friction coefficient [-] per row as built (the design's pin_contact.mu)."""
        return np.array(getattr(self, "_built_fparams", self.fparams)[:, ref.C_MUK])

    @property
    def friction_rows(self):
        """Rows built with regularized friction (bool, (N,))."""
        return self.iparams[:, ref.J_FRICTION] == FRICTION_REGULARIZED

    def _upload_slow_state(self):
        if not hasattr(self, "_built_fparams"):
            self._built_fparams = self.fparams.copy()
        fp = self._built_fparams.copy()
        gap = getattr(self, "_slow_gap", None)
        if gap is not None:
            fp[:, ref.C_E] += gap
        mu = getattr(self, "_slow_mu", None)
        if mu is not None:
            rows = self.friction_rows
            fp[rows, ref.C_MUK] = mu[rows]
            fp[rows, ref.C_MUS] = mu[rows]
        self.fparams = fp
        if self.backend == "warp":
            self._kernel.set_parameters(fp)

    def energy_law(self):
        """The per-slice constants of the energy account (:class:`rvtool.observe.energy.ContactEnergyLaw`):
        the slice's normal coefficient and exponent, anchor stiffness and friction code."""
        from ..observe.energy import ContactEnergyLaw
        kt = (self.anchor_params[:, anchor_ref.ANCHOR_KT] if self.anchor else np.zeros(self.n_contacts))
        return ContactEnergyLaw(normal_stiffness=self.fparams[:, ref.C_K], normal_exponent=self.fparams[:, ref.C_P],
                                tangential_stiffness=kt, friction_model=self.iparams[:, ref.J_FRICTION].copy())

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
