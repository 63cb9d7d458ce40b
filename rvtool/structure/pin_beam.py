"""A pin as a beam on declared supports: the station compliance of its bending and
shear deflection (the elastic pin of issue 21).

A ring pin or an output pin is a prismatic circular beam of radius r on one of
the supports of :class:`Support` at the axial positions ``ends`` = (z_a, z_b):

* ``cantilever``: clamped at z_a, free at z_b (an output pin pressed into the flange),
* ``simply_supported``: deflection held, rotation free at z_a and z_b (a pin in two
  end-cover bores),
* ``clamped_clamped``: deflection and rotation held at z_a and z_b,
* ``rigid``: the "nothing" variant, no beam (zero compliance, no cost).

Loads are uniform line loads over each wheel's contact width (a station). The
station compliance C_ij [m/N] is the mean deflection over station i under a unit
resultant uniformly spread over station j (the work-conjugate deflection of a
uniform line load), from the beam's influence function g(x, xi):
C_ij = (1/w_i w_j) int_i int_j g(x, xi) dxi dx. g comes from an exact two-node
Timoshenko beam discretization (the interdependent-interpolation element, whose
nodal displacements are exact for nodal loads on a prismatic beam) with a node at
every support and quadrature point; ``shear = False`` gives Euler--Bernoulli
(phi = 0). The shear coefficient of a solid circular section is Cowper's
kappa = 6 (1 + nu) / (7 + 6 nu).

The compliance enters the pin's contacts in series with the contact law, each
elastic region allocated once (paper, "each elastic region is allocated once";
Eq. (series_contact)): see :func:`rvtool.assembly.cycloid.build`.
"""
import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_positive, check_range


class Support(str, Enum):
    """Support of a pin beam (the design's ``support.model``)."""
    RIGID = "rigid"
    CANTILEVER = "cantilever"
    SIMPLY_SUPPORTED = "simply_supported"
    CLAMPED_CLAMPED = "clamped_clamped"


@dataclass(frozen=True, kw_only=True)
class PinSupport:
    """Declared support of a pin (design sub-table ``[pins.support]`` or ``[output_pins.support]``).

    model: :class:`Support` value ("rigid" = rigid pin, the default and the "nothing" variant).
    ends: (z_a, z_b) axial positions of the supports [m], in the frame of the wheel
        midplanes (cantilever: clamped at z_a, free end at z_b).
    shear: True = Timoshenko (bending + shear), False = Euler--Bernoulli (bending only).
    shear_coefficient: kappa [-]; None = Cowper's value of a solid circle from the material.
    """
    model: Support = Support.RIGID
    ends: tuple = (0.0, 0.0)
    shear: bool = True
    shear_coefficient: float | None = None

    def __post_init__(self):
        try:
            object.__setattr__(self, "model", Support(self.model))
        except ValueError:
            raise RvtoolInputError(f"model = {self.model!r}; valid choices are {[s.value for s in Support]}") from None
        ends = tuple(float(v) for v in np.ravel(self.ends))
        if len(ends) != 2:
            raise RvtoolInputError(f"ends = {self.ends!r} must be two axial positions (z_a, z_b) [m]")
        check_finite("ends", ends)
        object.__setattr__(self, "ends", ends)
        if self.model != Support.RIGID and abs(ends[1] - ends[0]) <= 0.0:
            raise RvtoolInputError(f"ends = {ends} m: an elastic pin needs a span; valid: z_a != z_b")
        if not isinstance(self.shear, bool):
            raise RvtoolInputError(f"shear = {self.shear!r} must be true or false")
        if self.shear_coefficient is not None:
            check_range("shear_coefficient", self.shear_coefficient, 0.0, 1.0, low_open=True)

    @property
    def elastic(self):
        return self.model != Support.RIGID


def cowper_circle(poisson_ratio):
    """Cowper's shear coefficient of a solid circular section: 6 (1 + nu) / (7 + 6 nu)."""
    return 6.0 * (1.0 + poisson_ratio) / (7.0 + 6.0 * poisson_ratio)


@dataclass(frozen=True)
class PinBeam:
    """A prismatic solid circular pin of ``radius`` [m] on ``support``, Young's modulus E [Pa]
    and Poisson's ratio nu [-]."""
    support: PinSupport
    radius: float
    youngs_modulus: float
    poisson_ratio: float

    def __post_init__(self):
        check_positive("radius", self.radius)
        check_positive("youngs_modulus", self.youngs_modulus)
        check_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        if not self.support.elastic:
            raise RvtoolInputError("support.model = 'rigid' has no beam; a PinBeam needs an elastic support")

    @property
    def EI(self):
        """Bending stiffness E pi r^4 / 4 [N m^2]."""
        return self.youngs_modulus * math.pi * self.radius ** 4 / 4.0

    @property
    def kGA(self):
        """Shear stiffness kappa G pi r^2 [N] (inf for Euler--Bernoulli)."""
        if not self.support.shear:
            return math.inf
        kappa = self.support.shear_coefficient or cowper_circle(self.poisson_ratio)
        return kappa * self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio)) * math.pi * self.radius ** 2

    def influence(self, x, xi):
        """g(x_a, xi_b) [m/N]: deflection at x (m,) under a unit transverse point load at xi (n,)
        (all inside the span [min(ends), max(ends)]; cantilever: the clamp at z_a)."""
        x, xi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(xi, float))
        za, zb = self.support.ends
        lo, hi = min(za, zb), max(za, zb)
        tol = 1e-12 * (hi - lo)
        for nm, v in (("x", x), ("xi", xi)):
            if np.any(v < lo - tol) or np.any(v > hi + tol):
                raise RvtoolInputError(f"support.ends = {self.support.ends} m do not span the loaded stations "
                                       f"({nm} in [{v.min():.6g}, {v.max():.6g}] m); valid: stations inside "
                                       f"[{lo:.6g}, {hi:.6g}] m")
        nodes = np.unique(np.concatenate([[lo, hi], np.clip(x, lo, hi), np.clip(xi, lo, hi)]))
        K = self._stiffness(nodes)
        held = self._held_dofs(nodes)
        free = np.setdiff1d(np.arange(2 * len(nodes)), held)
        ix = np.searchsorted(nodes, np.clip(x, lo, hi))
        jx = np.searchsorted(nodes, np.clip(xi, lo, hi))
        F = np.zeros((2 * len(nodes), len(xi)))
        F[2 * jx, np.arange(len(xi))] = 1.0
        U = np.zeros_like(F)
        U[free] = np.linalg.solve(K[np.ix_(free, free)], F[free])
        return U[2 * ix]

    def _stiffness(self, nodes):
        """Assembled Timoshenko beam stiffness (dofs w, rotation per node)."""
        n = len(nodes)
        K = np.zeros((2 * n, 2 * n))
        EI, kGA = self.EI, self.kGA
        for e in range(n - 1):
            L = nodes[e + 1] - nodes[e]
            phi = 12.0 * EI / (kGA * L * L)
            ke = EI / ((1.0 + phi) * L ** 3) * np.array([
                [12.0, 6 * L, -12.0, 6 * L],
                [6 * L, (4 + phi) * L * L, -6 * L, (2 - phi) * L * L],
                [-12.0, -6 * L, 12.0, -6 * L],
                [6 * L, (2 - phi) * L * L, -6 * L, (4 + phi) * L * L]])
            s = slice(2 * e, 2 * e + 4)
            K[s, s] += ke
        return K

    def _held_dofs(self, nodes):
        za, zb = self.support.ends
        ia, ib = np.searchsorted(nodes, za), np.searchsorted(nodes, zb)
        m = self.support.model
        if m == Support.CANTILEVER:
            return [2 * ia, 2 * ia + 1]
        if m == Support.SIMPLY_SUPPORTED:
            return [2 * ia, 2 * ib]
        return [2 * ia, 2 * ia + 1, 2 * ib, 2 * ib + 1]

    def station_compliance(self, centres, width, n_sub=16):
        """C (k, k) [m/N] between stations of ``width`` [m] centred at ``centres`` (k,) [m]:
        mean deflection over station i under a unit resultant spread uniformly over station j.
        Composite 2-point Gauss--Legendre over ``n_sub`` sub-intervals per station (the
        influence function is piecewise cubic, so only the sub-squares on the diagonal,
        where g has its kink, carry a quadrature error; measured below 1e-5 relative at 16)."""
        check_positive("width", width)
        centres = np.atleast_1d(np.asarray(centres, float))
        pts, wts = line_load_points(centres, width, n_sub)
        g = self.influence(pts.ravel(), pts.ravel())
        k = len(centres)
        W = wts.ravel()
        Gw = (W[:, None] * g * W[None, :]).reshape(k, pts.shape[1], k, pts.shape[1])
        return Gw.sum(axis=(1, 3))

    def line_load_deflection(self, x, start, end, n_sub=64):
        """Deflection [m] at x under a uniform line load of unit intensity (1 N/m) over
        [start, end] (the closed-form checks of cases/pin_bending.py)."""
        pts, wts = line_load_points(np.array([0.5 * (start + end)]), end - start, n_sub)
        return self.influence(np.atleast_1d(x), pts.ravel()) @ (wts.ravel() * (end - start))


def line_load_points(centres, width, n_sub):
    """(points (k, 2 n_sub), weights (k, 2 n_sub)) of composite 2-point Gauss--Legendre over
    each station [c - w/2, c + w/2]; the weights of a station sum to one."""
    h = width / n_sub
    a = np.asarray(centres, float)[:, None] - 0.5 * width + h * np.arange(n_sub)[None, :]
    g = 0.5 * h * np.array([1 - 1 / math.sqrt(3), 1 + 1 / math.sqrt(3)])
    pts = (a[:, :, None] + g[None, None, :]).reshape(len(centres), -1)
    return pts, np.full(pts.shape, 1.0 / (2 * n_sub))


def pin_beam(support, radius, material):
    """The :class:`PinBeam` of a pin of ``radius`` [m] on ``support`` in ``material``
    (a design's ``[material]``), or None for the rigid pin."""
    if support is None or not support.elastic:
        return None
    return PinBeam(support, radius, material.youngs_modulus, material.poisson_ratio)
