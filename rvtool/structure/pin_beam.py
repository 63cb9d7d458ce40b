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

    model: the support of the pin, a :class:`Support` value ("rigid" = rigid pin, the default and the "nothing"
    variant).
    ends: (z_a, z_b) axial positions of the supports [m], in the frame of the wheel
        midplanes (cantilever: clamped at z_a, free end at z_b).
    shear: True = Timoshenko (bending + shear), False = Euler--Bernoulli (bending only).
    shear_coefficient: kappa [-]; None = Cowper's value of a solid circle from the material.
    support_compliance: radial compliance [m/N] of each support (the groove or bore the pin
        sits in; a spring on the deflection at z_a and, where held, z_b; rotations stay held
        where the model holds them); 0 = rigid supports.
    """
    model: Support = Support.RIGID
    ends: tuple = (0.0, 0.0)
    shear: bool = True
    shear_coefficient: float | None = None
    support_compliance: float = 0.0

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
        check_range("support_compliance", self.support_compliance, 0.0, math.inf)

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

    def internal_forces(self, points, loads):
        """Bending moment and shear along the pin under point loads (n, 2) [N] (x and y
        components) at axial positions points (n,) [m]: (nodes (m,) [m], moment (m, 2) [N m] at
        the nodes, shear (m - 1, 2) [N] per segment between nodes). With nodal loads only, the
        Timoshenko element's end forces k_e u_e are exact, the moment is linear and the shear
        constant between nodes, so the extremes lie at the nodes (support reactions included)."""
        points = np.atleast_1d(np.asarray(points, float))
        loads = np.asarray(loads, float).reshape(len(points), 2)
        za, zb = self.support.ends
        lo, hi = min(za, zb), max(za, zb)
        tol = 1e-12 * (hi - lo)
        if np.any(points < lo - tol) or np.any(points > hi + tol):
            raise RvtoolInputError(f"support.ends = {self.support.ends} m do not span the loads (z in "
                                   f"[{points.min():.6g}, {points.max():.6g}] m); valid: loads inside [{lo:.6g}, {hi:.6g}] m")
        nodes = np.unique(np.concatenate([[lo, hi], np.clip(points, lo, hi)]))
        K = self._stiffness(nodes)
        free = np.setdiff1d(np.arange(2 * len(nodes)), self._held_dofs(nodes))
        F = np.zeros((2 * len(nodes), 2))
        np.add.at(F, 2 * np.searchsorted(nodes, np.clip(points, lo, hi)), loads)
        U = np.zeros_like(F)
        U[free] = np.linalg.solve(K[np.ix_(free, free)], F[free])
        n = len(nodes)
        M, V = np.zeros((n, 2)), np.zeros((n - 1, 2))
        for e in range(n - 1):
            f = self._element(nodes[e + 1] - nodes[e]) @ U[2 * e:2 * e + 4]     # end forces on the element
            M[e] = -f[1]
            V[e] = f[0]
        M[-1] = f[3]
        return nodes, M, V

    def station_stresses(self, centres, width, resultants, n_sub=16):
        """Largest bending stress |M|/W and shear stress 4 |V|/(3 A) [Pa] of the pin (solid
        circle: W = pi r^3/4, A = pi r^2; the shear stress at the neutral axis) under the vector
        resultants (k, 2) [N] spread uniformly over stations of ``width`` [m] centred at
        ``centres`` (k,) [m], each station as 2 n_sub point loads at its composite Gauss points
        (the moment of the lumped load differs from the uniform one by O((width / n_sub)^2)).
        Returns (sigma_max, tau_max, z of sigma_max [m])."""
        pts, wts = line_load_points(np.atleast_1d(np.asarray(centres, float)), width, n_sub)
        loads = wts[:, :, None] * np.asarray(resultants, float)[:, None, :]
        nodes, M, V = self.internal_forces(pts.ravel(), loads.reshape(-1, 2))
        m = np.hypot(M[:, 0], M[:, 1])
        r = self.radius
        W, A = math.pi * r ** 3 / 4.0, math.pi * r ** 2
        return float(m.max() / W), float(4.0 * np.hypot(V[:, 0], V[:, 1]).max() / (3.0 * A)), float(nodes[m.argmax()])

    def station_stress_map(self, centres, width, n_sub=16):
        """The linear map from station resultants to the pin's internal forces
        (:class:`StationStressMap`): :meth:`internal_forces` under a unit load on each station in
        turn (the beam is linear and its two transverse planes are alike), so that many load
        states (e.g. every point of a TE sequence) cost one matrix product each instead of one
        beam solve (:meth:`station_stresses`, the same figures to round-off)."""
        centres = np.atleast_1d(np.asarray(centres, float))
        pts, wts = line_load_points(centres, width, n_sub)
        k = len(centres)
        GM, GV = [], []
        for j in range(k):
            loads = np.zeros((k, pts.shape[1], 2))
            loads[j, :, 0] = wts[j]
            nodes, M, V = self.internal_forces(pts.ravel(), loads.reshape(-1, 2))
            GM.append(M[:, 0])
            GV.append(V[:, 0])
        r = self.radius
        return StationStressMap(nodes=nodes, moment=np.array(GM).T, shear=np.array(GV).T,
                                section_modulus=math.pi * r ** 3 / 4.0, area=math.pi * r ** 2)

    def _element(self, L):
        """Timoshenko element stiffness (w, rotation at both ends) of length L."""
        return timoshenko_element(self.EI, self.kGA, L)

    def _stiffness(self, nodes):
        """Assembled Timoshenko beam stiffness (dofs w, rotation per node)."""
        n = len(nodes)
        K = np.zeros((2 * n, 2 * n))
        for e in range(n - 1):
            s = slice(2 * e, 2 * e + 4)
            K[s, s] += self._element(nodes[e + 1] - nodes[e])
        if self.support.support_compliance > 0.0:
            for d in self._support_springs(nodes):
                K[d, d] += 1.0 / self.support.support_compliance
        return K

    def _held_dofs(self, nodes):
        """Held dofs; with a support compliance the deflection dofs at the supports are free and
        carry springs instead (added to the stiffness by :meth:`_stiffness`)."""
        za, zb = self.support.ends
        ia, ib = np.searchsorted(nodes, za), np.searchsorted(nodes, zb)
        m = self.support.model
        if m == Support.CANTILEVER:
            held = [2 * ia, 2 * ia + 1]
        elif m == Support.SIMPLY_SUPPORTED:
            held = [2 * ia, 2 * ib]
        else:
            held = [2 * ia, 2 * ia + 1, 2 * ib, 2 * ib + 1]
        if self.support.support_compliance > 0.0:
            held = [h for h in held if h % 2 == 1]
        return held

    def _support_springs(self, nodes):
        """Deflection dofs of the supports (the springs of a support compliance)."""
        za, zb = self.support.ends
        ia, ib = np.searchsorted(nodes, za), np.searchsorted(nodes, zb)
        return [2 * ia] if self.support.model == Support.CANTILEVER else [2 * ia, 2 * ib]

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
        [start, end] (the closed-form checks of cases/cycloid/pin_bending.py)."""
        pts, wts = line_load_points(np.array([0.5 * (start + end)]), end - start, n_sub)
        return self.influence(np.atleast_1d(x), pts.ravel()) @ (wts.ravel() * (end - start))


def timoshenko_element(EI, kGA, L):
    """Stiffness (4, 4) of the two-node interdependent-interpolation Timoshenko element of length
    L [m] (dofs: deflection, rotation at both ends), bending stiffness EI [N m^2], shear stiffness
    kGA [N] (inf: Euler--Bernoulli). Its nodal displacements are exact for nodal loads on a
    prismatic beam (shared by the pin and crank beams)."""
    phi = 12.0 * EI / (kGA * L * L)
    return EI / ((1.0 + phi) * L ** 3) * np.array([
        [12.0, 6 * L, -12.0, 6 * L],
        [6 * L, (4 + phi) * L * L, -6 * L, (2 - phi) * L * L],
        [-12.0, -6 * L, 12.0, -6 * L],
        [6 * L, (2 - phi) * L * L, -6 * L, (4 + phi) * L * L]])


@dataclass(frozen=True)
class StationStressMap:
    """Internal forces of a pin as linear maps of its station resultants R (k, 2) [N]: moment at
    the nodes M = moment @ R (m, 2) [N m], shear per segment V = shear @ R (m - 1, 2) [N];
    section modulus W = pi r^3/4 [m^3] and area A = pi r^2 [m^2] of the solid circle."""
    nodes: np.ndarray
    moment: np.ndarray
    shear: np.ndarray
    section_modulus: float
    area: float

    def stresses(self, resultants):
        """(sigma_max = max |M|/W, tau_max = max 4 |V|/(3 A) [Pa], z of sigma_max [m]) under the
        station resultants (k, 2) [N]."""
        R = np.asarray(resultants, float)
        M, V = self.moment @ R, self.shear @ R
        m = np.hypot(M[:, 0], M[:, 1])
        i = int(m.argmax())
        return (float(m[i] / self.section_modulus), float(4.0 * np.hypot(V[:, 0], V[:, 1]).max() / (3.0 * self.area)),
                float(self.nodes[i]))


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
