"""Influence-coefficient roller slices (paper Eq. (bearing_ic)): the supported alternative to
independent laminae for needle, cylindrical (and crossed) and tapered rollers.

A design selects the roller law per bearing section with ``slices = "laminae"`` (default: each
lamina its own Palmgren law, Eq. (normal_force)) or ``slices = "influence"``: the slice forces of a
roller solve the complementarity problem w = C_l f - s, f >= 0, w >= 0, f^T w = 0 with the
finite-width half-space compliance C_l of both race contacts (inner and outer, in series),
:mod:`warp_contacts.roller_slices_ref` (formula, sources). ``half_width = "fixed"`` (default) takes
the Hertz half-width of each race contact at the bearing's ``reference_roller_load``;
``"roller_load"`` updates it from the roller's current mean line load (the paper's total line
load), ``"slice_load"`` gives each slice the half-width of its own line load (the form that meets
the 2 % bound against the panel solve under tilt and at a straight roller's edges).

Race contact radii (Harris & Kotzalas, Rolling Bearing Analysis, 5th ed., 2007, vol. 1, ch. 2):
gamma = D cos(alpha) / d_m, inner R' = D (1 - gamma) / 2, outer R' = D (1 + gamma) / 2 (a tapered
row: its mean roller diameter and roller-axis angle). Two-body modulus of steel on steel (rollers
and rings of one material): E* = E / (2 (1 - nu^2)) (Johnson's E*, 1/E* = sum (1 - nu_i^2) / E_i).

The precomputed edge weight (:func:`edge_weights`) is the separate approximation the paper names:
per-slice lamina stiffness factors that make independent laminae reproduce the coupled solution
under uniform approach at the reference load; under tilt or crowning it differs from the solve
(``cases/verification/roller_influence_slices.py`` compares the three).
"""
import math
from enum import Enum

import numpy as np

from warp_contacts import roller_slices_ref as sref

from ..errors import RvtoolInputError


class SliceLaw(str, Enum):
    """Roller slice law: independent laminae (default) or the influence-coefficient solve."""
    LAMINAE = "laminae"
    INFLUENCE = "influence"


class HalfWidth(str, Enum):
    """Contact half-width of the influence slices: fixed at the reference load, or updated from the
    roller's mean line load, or from each slice's own line load."""
    FIXED = "fixed"
    ROLLER_LOAD = "roller_load"
    SLICE_LOAD = "slice_load"


_MODES = {HalfWidth.FIXED: sref.HALF_WIDTH_FIXED, HalfWidth.ROLLER_LOAD: sref.HALF_WIDTH_ROLLER_LOAD,
          HalfWidth.SLICE_LOAD: sref.HALF_WIDTH_SLICE_LOAD}


def set_choice(obj, name, cls):
    """Replace a string field of a frozen spec by its enum member (named error on a bad value)."""
    value = getattr(obj, name)
    try:
        object.__setattr__(obj, name, cls(value))
    except ValueError:
        raise RvtoolInputError(f"{name} = {value!r} is not one of the valid choices {[m.value for m in cls]}") from None


def two_body_modulus(youngs_modulus, poisson_ratio):
    """E* = E / (2 (1 - nu^2)) [Pa] of two bodies of one material (1/E* = sum (1 - nu_i^2) / E_i)."""
    return youngs_modulus / (2.0 * (1.0 - poisson_ratio ** 2))


def race_radii(roller_diameter, pitch_diameter, contact_angle):
    """Effective radii R' [m] of the inner- and outer-race line contacts (Harris & Kotzalas, ch. 2)."""
    g = roller_diameter * math.cos(contact_angle) / pitch_diameter
    return 0.5 * roller_diameter * (1.0 - g), 0.5 * roller_diameter * (1.0 + g)


def slice_parameters(*, roller_length, n_slices, roller_diameter, pitch_diameter, contact_angle, youngs_modulus,
                     poisson_ratio, reference_roller_load, half_width):
    """Per-roller parameter rows (float (N_SLICE_FLOAT,), int (N_SLICE_INT,)) of
    :mod:`warp_contacts.roller_slices_ref` for one roller of a bearing."""
    es = two_body_modulus(youngs_modulus, poisson_ratio)
    r_in, r_out = race_radii(roller_diameter, pitch_diameter, contact_angle)
    fp = np.zeros(sref.N_SLICE_FLOAT)
    fp[sref.SL_DY] = roller_length / n_slices
    fp[sref.SL_ESTAR] = es
    fp[sref.SL_RIN], fp[sref.SL_ROUT] = r_in, r_out
    fp[sref.SL_BIN] = sref.line_load_half_width(reference_roller_load, roller_length, r_in, es)
    fp[sref.SL_BOUT] = sref.line_load_half_width(reference_roller_load, roller_length, r_out, es)
    fp[sref.SL_LEN] = roller_length
    ip = np.zeros(sref.N_SLICE_INT, dtype=np.int32)
    ip[sref.SI_COUNT] = n_slices
    ip[sref.SI_MODE] = _MODES[HalfWidth(half_width)]
    return fp, ip


def bearing_slice_parameters(bearing):
    """:func:`slice_parameters` of a CylindricalRollerBearing (or needle, crossed) or a TaperedRollerBearing."""
    tapered = hasattr(bearing, "roller_axis_angle")
    return slice_parameters(
        roller_length=bearing.roller_length, n_slices=bearing.n_slices, roller_diameter=bearing.roller_diameter,
        pitch_diameter=bearing.pitch_diameter,
        contact_angle=bearing.roller_axis_angle if tapered else bearing.contact_angle,
        youngs_modulus=bearing.youngs_modulus, poisson_ratio=bearing.poisson_ratio,
        reference_roller_load=bearing.reference_roller_load, half_width=bearing.half_width)


def slice_mean_crowning(bearing):
    """Crowning drop per slice [m] as the influence slices take it: the mean over each slice (Galerkin
    collocation, :mod:`warp_contacts.roller_slices_ref`). A parabolic crown of end drop c_e (scalar
    ``crowning``) averages to c_e [(2 zeta / l)^2 + 1 / (3 n^2)] over a slice of width l / n; per-slice
    values are taken as the slices' mean drops."""
    crown = np.asarray(bearing.slice_crowning, float)
    if np.ndim(bearing.crowning) == 0:
        crown = crown + float(bearing.crowning) / (3.0 * bearing.n_slices ** 2)
    return crown


def check_lumped(design, bearing_model):
    """Named error for a design whose roller bearing asks for influence slices while the builder
    lumps each bearing into one circle contact (``bearing_model = "lumped"``: no slices to couple)."""
    if bearing_model != "lumped":
        return
    for key in ("eccentric_bearing", "main_bearing", "input_bearing"):
        b = getattr(design, key, None)
        if getattr(b, "slices", SliceLaw.LAMINAE) == SliceLaw.INFLUENCE:
            raise RvtoolInputError(f"{key}.slices = 'influence' needs bearing_model = 'rolling' (the lumped bearing "
                                   "is one circle contact without slices); valid with 'lumped': 'laminae'"
                                   f"{LUMPED_IN_ANALYZE}")


LUMPED_IN_ANALYZE = ("; `rvtool analyze` builds the cycloid and small-tooth-difference drives with lumped bearings "
                     "unless told otherwise: run such a design with `rvtool analyze DESIGN --bearing-model rolling` "
                     "(Python: rvtool.analyze(design, bearing_model='rolling') or rvtool.build(design, "
                     "bearing_model='rolling'))")
"""What a design-file user is told with a refusal of the lumped bearing model (the command line's
``--bearing-model`` default is the builders' lumped model)."""


class RollerSlices:
    """The complementarity solve of R rollers, one call per evaluation.

    fparams (R, N_SLICE_FLOAT), iparams (R, N_SLICE_INT); backend "numpy" (the reference) or "warp"
    (:class:`warp_contacts.roller_slices.RollerSliceKernel`, float64), device a Warp device.
    ``solve(s)``: slice approaches (R, n_max) [m] -> (f (R, n_max) [N], J = df/ds (R, n_max, n_max)
    [N/m], half-widths (R, 2, n_max) [m] (inner, outer race per slice), active counts (R,)).
    """

    def __init__(self, fparams, iparams, *, backend="warp", device="cpu"):
        self.fparams = np.asarray(fparams, float)
        self.iparams = np.asarray(iparams, np.int32)
        self.backend = backend
        self.n_max = int(self.iparams[:, sref.SI_COUNT].max())
        if backend == "warp":
            from warp_contacts.roller_slices import RollerSliceKernel
            self._kernel = RollerSliceKernel(self.fparams, self.iparams, device)
        elif backend != "numpy":
            raise RvtoolInputError(f"backend = {backend!r} is not valid; valid choices are ['warp', 'numpy']")

    def solve(self, s):
        if self.backend == "warp":
            return self._kernel.evaluate(s)
        return sref.evaluate(s, self.fparams, self.iparams)


def compliance_matrix(bearing, half_widths=None):
    """C_l (n, n) [m/N] of one roller of ``bearing`` (both races) at its fixed half-widths, or at
    ``half_widths`` = (b_in, b_out) [m]."""
    fp, ip = bearing_slice_parameters(bearing)
    n = int(ip[sref.SI_COUNT])
    b = (fp[sref.SL_BIN], fp[sref.SL_BOUT]) if half_widths is None else half_widths
    return sref.compliance(fp, n, np.array([np.full(n, b[0]), np.full(n, b[1])]))[0]


def edge_weights(bearing):
    """The precomputed edge weight: per-slice factors w_s (mean 1) of the lamina stiffness that make
    independent linear laminae carry the slice forces of the influence solve under a uniform approach
    (C_l f = s 1 -> w = f / mean(f)), at the bearing's fixed half-widths."""
    C = compliance_matrix(bearing)
    f = np.linalg.solve(C, np.ones(len(C)))
    return f / f.mean()


def rectangle_influence(xr, yr, x1, x2, y1, y2):
    """int_{x1}^{x2} int_{y1}^{y2} dx dy / sqrt((x - xr)^2 + (y - yr)^2) [m] (uniform pressure on a
    rectangle, Love 1929; Johnson 1985, Section 3.3) from the pressure module's panel integral
    (:func:`rvtool.pressure.panel_integral`, the y-interval symmetric about the receiver) by
    int_{y1}^{y2} = G(y2) - G(y1), G(y) = sgn(y) panel_integral(.., |y|) / 2 (receiver-relative y)."""
    from ..pressure import panel_integral

    def G(y):
        a = np.abs(y)
        return np.where(a > 0, np.sign(y) * 0.5 * panel_integral(x1 - xr, x2 - xr, np.where(a > 0, a, 1.0)), 0.0)

    return G(y2 - yr) - G(y1 - yr)


def block_pivot_lcp(C, s, max_iter=100):
    """w = C f - s >= 0, f >= 0, f^T w = 0 for a large SPD C (the panel reference) by block principal
    pivoting (Judice & Pires 1994): each iteration solves the active block and moves every violated
    index; on a repeated set it falls back to the exact Lawson--Hanson method
    (:func:`scipy.optimize.nnls` on the Cholesky form). Returns (f, iterations)."""
    import scipy.linalg
    import scipy.optimize
    n = len(s)
    act = s > 0
    seen = set()
    tol = 1e-12 * np.max(np.abs(s))
    for it in range(1, max_iter + 1):
        f = np.zeros(n)
        if act.any():
            f[act] = scipy.linalg.solve(C[np.ix_(act, act)], s[act], assume_a="pos")
        w = C @ f - s
        new = (act & (f > 0)) | (~act & (w < -tol))
        if np.array_equal(new, act) and np.all(f >= 0):
            return f, it
        key = new.tobytes()
        if key in seen:
            break
        seen.add(key)
        act = new
    # min 1/2 f^T C f - s^T f = 1/2 |L^T f - L^-1 s|^2 + const, C = L L^T
    L = scipy.linalg.cholesky(C, lower=True)
    f, _ = scipy.optimize.nnls(L.T, scipy.linalg.solve_triangular(L, s, lower=True), maxiter=50 * n)
    return f, max_iter


def panel_slice_forces(*, length, radius, e_star, approach, n_slices, panels_per_slice=8, nx=24,
                       x_extent=None):
    """The reference of the influence slices: one roller--race line contact of finite length on a
    grid of uniform rectangular panels (the pressure module's half-space panel integral), solved
    exactly as a complementarity problem with the undeformed gap h = x^2 / (2 R') - s(y), and its
    panel forces summed per slice.

    length: l [m]; radius: R' [m]; e_star: E* [Pa]; approach: callable s(y) [m] (rigid approach
    along the roller, y from its middle: approach, tilt, minus crowning); n_slices; panels_per_slice
    along y; nx panels across; x_extent: half-extent of the grid across [m] (default 1.6 times the
    Hertz half-width of the largest line load the approach can give, 2 sqrt(R' max s)).
    Returns (slice forces (n_slices,) [N], panel forces (ny, nx) [N], x centres, y centres)."""
    ny = n_slices * panels_per_slice
    dy = length / ny
    y = (np.arange(ny) + 0.5) * dy - 0.5 * length
    s = np.asarray([approach(v) for v in y], float)
    if x_extent is None:
        # the Hertz contact of a 2-D cylinder reaches |x| = sqrt(2 R' delta) at most geometrically
        x_extent = 1.6 * np.sqrt(2.0 * radius * max(np.max(s), 1e-30))
    dx = 2 * x_extent / nx
    x = (np.arange(nx) + 0.5) * dx - x_extent
    X, Y = np.meshgrid(x, y)
    X, Y = X.ravel(), Y.ravel()
    C = rectangle_influence(X[:, None], Y[:, None], X[None, :] - 0.5 * dx, X[None, :] + 0.5 * dx,
                            Y[None, :] - 0.5 * dy, Y[None, :] + 0.5 * dy) / (np.pi * e_star * dx * dy)
    rhs = np.repeat(s, nx) - X ** 2 / (2.0 * radius)
    f, _ = block_pivot_lcp(C, rhs)
    f = f.reshape(ny, nx)
    return f.sum(axis=1).reshape(n_slices, panels_per_slice).sum(axis=1), f, x, y
