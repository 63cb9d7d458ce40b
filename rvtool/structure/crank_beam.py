"""An RV crankshaft as a beam between its tapered-roller supports: the station compliance of its
bending and shear deflection at the two eccentric journals and the spur gear (issue 21,
Deliver 2: "for RV, the same for crankshaft bending between its bearings").

The crank is a prismatic solid circular shaft of radius r (one section for the journals, the
bearing seats and the gear seat: a declared simplification), simply supported at the axial
positions of its two tapered rows (deflection held, rotation free: a row carries no moment;
the rows' own compliance is their contact law, allocated there), loaded by uniform line loads
over the needle rollers' length at each journal (the wheel midplanes) and over the gear's face
width at the gear seat, which may overhang a support (the input-side spur gear of an RV crank).
Axial positions z [m] are in the frame of the wheel midplanes.

Station compliance C_ij [m/N]: the mean deflection over station i under a unit resultant spread
uniformly over station j, from the influence function g(x, xi) of the exact two-node Timoshenko
discretization (:func:`rvtool.structure.pin_beam.timoshenko_element`; a node at each support
and quadrature point), as for the pins (:mod:`rvtool.structure.pin_beam`). The deflection is
relative to the line through the two supports: the crank body's planar pose is that line, which
the tapered pairs carry (the crank's tilt coordinates are held, declared in
:mod:`rvtool.assembly.rv.builder`). The compliance enters the journals' and the gear's contacts in
series with the needle and involute laws through the per-crank closure of
:mod:`rvtool.contact.pin_closure` (Eq. (series_contact); "each elastic region is allocated once").

The reference :func:`determinate_influence` is the same influence function by virtual work on
the statically determinate beam, g = int M_x M_xi / EI dz + int V_x V_xi / kappa G A dz, integrated
exactly (moments piecewise linear, shears piecewise constant): an independent closed form.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_positive, check_range
from .pin_beam import cowper_circle, line_load_points, timoshenko_element

MODELS = ("rigid", "simply_supported")


@dataclass(frozen=True, kw_only=True)
class CrankShaft:
    """The crankshaft as a beam (design sub-table ``[cranks.shaft]``).

    model: "rigid" (the default and the "nothing" variant: no beam, no cost) or
        "simply_supported" (a beam on its two tapered rows).
    radius: shaft radius r of one solid section [m].
    supports: axial load centres of the two rows [m] (z_a < z_b).
    gear_position: gear mid-face position z_g [m] (inside or overhanging the supports).
    shear: True = Timoshenko (bending + shear), False = Euler--Bernoulli.
    shear_coefficient: Timoshenko's kappa [-] (None: Cowper's value of a solid circle).
    tilt: true = the crank also tilts on its tapered pair (the pair's tilting compliance 1/K_gamma
        at the rated crank-bearing load, in series with the beam: z z^T / K_gamma added to the
        station compliance, z from the pair's centre; condensed, not a retained coordinate).
    torsion: "rigid" (the default: today's figures) or "elastic": the shaft twists between its
        spur gear and its eccentric journals (:mod:`rvtool.structure.crank_torsion`; needs radius
        and gear_position; with ``model = "simply_supported"`` the journals twist on their bending
        stations).
    """
    model: str = "rigid"
    radius: float | None = None
    supports: tuple | None = None
    gear_position: float | None = None
    shear: bool = True
    shear_coefficient: float | None = None
    tilt: bool = False
    torsion: str = "rigid"

    def __post_init__(self):
        if self.model not in MODELS:
            raise RvtoolInputError(f"model = {self.model!r}; valid choices are {list(MODELS)}")
        if not isinstance(self.shear, bool):
            raise RvtoolInputError(f"shear = {self.shear!r} must be true or false")
        if not isinstance(self.tilt, bool):
            raise RvtoolInputError(f"tilt = {self.tilt!r} must be true or false")
        if self.tilt and not self.elastic:
            raise RvtoolInputError("tilt = true needs model = 'simply_supported' (the tilt compliance is added to "
                                   "the beam's; valid: tilt = false or an elastic crank)")
        if self.torsion not in ("rigid", "elastic"):
            raise RvtoolInputError(f"torsion = {self.torsion!r}; valid choices are ['rigid', 'elastic']")
        if self.torsion == "elastic":
            for nm in ("radius", "gear_position"):
                if getattr(self, nm) is None:
                    raise RvtoolInputError(f"{nm} is required for torsion = 'elastic'; valid: see "
                                           "rvtool/designs/rv40e.toml [cranks.shaft]")
        if self.shear_coefficient is not None:
            check_range("shear_coefficient", self.shear_coefficient, 0.0, 1.0, low_open=True)
        # the geometry is checked where given (a rigid crank may keep it declared for the switch)
        # and required where the beam is used
        if self.elastic:
            for nm in ("radius", "supports", "gear_position"):
                if getattr(self, nm) is None:
                    raise RvtoolInputError(f"{nm} is required for model = {self.model!r} (an elastic crank); "
                                           "valid: see rvtool/designs/rv40e.toml [cranks.shaft]")
        if self.radius is not None:
            check_positive("radius", self.radius)
        if self.supports is not None:
            sup = tuple(float(v) for v in np.ravel(self.supports))
            if len(sup) != 2:
                raise RvtoolInputError(f"supports = {self.supports!r} must be two axial positions (z_a, z_b) [m]")
            check_finite("supports", sup)
            if not sup[0] < sup[1]:
                raise RvtoolInputError(f"supports = {sup} m; valid: z_a < z_b (a span between the two tapered rows)")
            object.__setattr__(self, "supports", sup)
        if self.gear_position is not None:
            check_finite("gear_position", self.gear_position)

    @property
    def elastic(self):
        return self.model != "rigid"


@dataclass(frozen=True)
class CrankBeam:
    """A prismatic solid circular crank of ``radius`` [m] simply supported at ``supports``
    (z_a, z_b) [m]; Young's modulus E [Pa], Poisson's ratio nu [-]; ``shear``: Timoshenko
    (True) or Euler--Bernoulli; ``shear_coefficient``: kappa (None: Cowper's)."""
    radius: float
    supports: tuple
    youngs_modulus: float
    poisson_ratio: float
    shear: bool = True
    shear_coefficient: float | None = None

    def __post_init__(self):
        check_positive("radius", self.radius)
        check_positive("youngs_modulus", self.youngs_modulus)
        check_range("poisson_ratio", self.poisson_ratio, 0.0, 0.5, high_open=True)
        if not (len(self.supports) == 2 and self.supports[0] < self.supports[1]):
            raise RvtoolInputError(f"supports = {self.supports!r}; valid: (z_a, z_b) with z_a < z_b [m]")

    @property
    def EI(self):
        """Bending stiffness E pi r^4 / 4 [N m^2]."""
        return self.youngs_modulus * math.pi * self.radius ** 4 / 4.0

    @property
    def kGA(self):
        """Shear stiffness kappa G pi r^2 [N] (inf for Euler--Bernoulli)."""
        if not self.shear:
            return math.inf
        kappa = self.shear_coefficient or cowper_circle(self.poisson_ratio)
        return kappa * self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio)) * math.pi * self.radius ** 2

    def influence(self, x, xi):
        """g(x_a, xi_b) [m/N] (m, n): deflection at x (m,) under a unit transverse point load at
        xi (n,); points anywhere along the crank (between or beyond the supports)."""
        x, xi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(xi, float))
        check_finite("x", x)
        check_finite("xi", xi)
        za, zb = self.supports
        nodes = np.unique(np.concatenate([[za, zb], x, xi]))
        n = len(nodes)
        K = np.zeros((2 * n, 2 * n))
        for e in range(n - 1):
            s = slice(2 * e, 2 * e + 4)
            K[s, s] += timoshenko_element(self.EI, self.kGA, nodes[e + 1] - nodes[e])
        held = [2 * int(np.searchsorted(nodes, za)), 2 * int(np.searchsorted(nodes, zb))]
        free = np.setdiff1d(np.arange(2 * n), held)
        F = np.zeros((2 * n, len(xi)))
        F[2 * np.searchsorted(nodes, xi), np.arange(len(xi))] = 1.0
        U = np.zeros_like(F)
        U[free] = np.linalg.solve(K[np.ix_(free, free)], F[free])
        return U[2 * np.searchsorted(nodes, x)]

    def station_compliance(self, centres, widths, n_sub=16):
        """C (k, k) [m/N] between stations of ``widths`` (k,) [m] centred at ``centres`` (k,) [m]
        (module docstring). Composite 2-point Gauss--Legendre over ``n_sub`` sub-intervals per
        station: only the sub-squares on the diagonal carry a quadrature error, where the shear
        part of g (piecewise linear in x - xi) has its kink; second order in the sub-interval,
        2.6e-5 relative at 16 for rv40e's crank (tests/test_rv_crank_beam.py)."""
        centres = np.atleast_1d(np.asarray(centres, float))
        widths = np.broadcast_to(np.asarray(widths, float), centres.shape)
        for w in widths:
            check_positive("widths", float(w))
        pts, wts = station_points(centres, widths, n_sub)
        g = self.influence(pts.ravel(), pts.ravel())
        k, m = pts.shape
        W = wts.ravel()
        return (W[:, None] * g * W[None, :]).reshape(k, m, k, m).sum(axis=(1, 3))


def station_points(centres, widths, n_sub):
    """(points (k, 2 n_sub), weights (k, 2 n_sub)) of composite Gauss--Legendre over stations of
    individual widths (:func:`rvtool.structure.pin_beam.line_load_points` per station)."""
    out = [line_load_points(np.array([c]), float(w), n_sub) for c, w in zip(centres, widths)]
    return np.vstack([p for p, _ in out]), np.vstack([w for _, w in out])


def determinate_influence(x, xi, supports, EI, kGA):
    """Closed-form reference of :meth:`CrankBeam.influence`: g(x, xi) [m/N] of the simply
    supported beam (overhangs allowed) by virtual work, sum over segments of
    int (M_x M_xi / EI + V_x V_xi / kGA) dz with the unit-load moment and shear diagrams
    (reactions R_a = (z_b - p) / L, R_b = (p - z_a) / L of a unit load at p); the products are
    quadratic (moments) and constant (shears) per segment, integrated exactly by Simpson's rule
    and the midpoint. kGA = inf: Euler--Bernoulli."""
    za, zb = supports
    L = zb - za
    x, xi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(xi, float))

    def diagram(p):
        # point forces (position, value): the unit load at p and the support reactions against it
        return ((p, 1.0), (za, -(zb - p) / L), (zb, -(p - za) / L))

    def mv(forces, z):
        m = sum(f * (z - zf) for zf, f in forces if zf < z)
        v = sum(f for zf, f in forces if zf < z)
        return m, v

    out = np.zeros((len(x), len(xi)))
    for a, pa in enumerate(x):
        fa = diagram(pa)
        for b, pb in enumerate(xi):
            fb = diagram(pb)
            br = np.unique([za, zb, pa, pb])
            total = 0.0
            for z0, z1 in zip(br[:-1], br[1:]):
                h = z1 - z0
                zm = 0.5 * (z0 + z1)
                # moments are continuous (a point force at a breakpoint has zero arm there)
                m0a, m1a = mv(fa, z0)[0], mv(fa, z1)[0]
                m0b, m1b = mv(fb, z0)[0], mv(fb, z1)[0]
                mma, va = mv(fa, zm)
                mmb, vb = mv(fb, zm)
                total += h / 6.0 * (m0a * m0b + 4.0 * mma * mmb + m1a * m1b) / EI
                if math.isfinite(kGA):
                    total += h * va * vb / kGA
            out[a, b] = total
    return out
