"""The gear graph of an RV reducer: the signed ratio, the crank placement and the assembly
phases, derived from the tooth counts (paper, "Transmission topology and reaction-force
closure": "Two-stage: sun -> cranks. Three-stage: offset input -> compound gear -> cranks.").

Members and their rotation rates: the input (the sun, or the three-stage pinion), the
compound gear (three-stage; it carries the sun), the cranks (absolute rate omega_k, all
equal: the two wheels ride on all cranks' journals), the wheels (omega_w) and the carrier
(omega_c, the output). Edges, each one linear relation between rates:

* external involute pair A -> B on fixed centres: omega_B = r omega_A, r = -z_A / z_B;
* sun -> crank gear on the carrier: omega_k - omega_c = r (omega_s - omega_c) (the crank
  axes ride on the carrier);
* wheel -- fixed pin ring (z_b pins, z_g = z_b - 1 teeth): the wheel centre orbits at the
  crank rate and the wheel turns by omega_w = -omega_k / z_g (as in the cycloid drive);
* wheel -- carrier through the parallel cranks: omega_w = omega_c (the wheel translates
  relative to the carrier).

The ratio i = omega_in / omega_c is the solution of these relations at omega_in = 1 (a
linear solve over the edges, never typed in); for the two-stage RV it equals
i = 1 + (z_crank gear / z_sun) z_b, for the three-stage one -(z_compound / z_pinion) times that.

Assembly phase. Crank k sits at beta_k = 2 pi k / N_c on the crank circle of radius
a (the sun--crank-gear centre distance). Its gear's angle at the reference (input angle 0)
follows from conjugate action in the frame turned by beta_k, theta_k0 = beta_k + p_0 +
r (theta_s0 - beta_k) with p_0 the mid-backlash mesh phase; the eccentric journals sit at the
absolute phases phi_j of the wheels (plus a declared crank phase error), i.e. at phi_j -
theta_k0 in the crank's own frame. Identical cranks (one gear clocking relative to the
eccentrics) then need theta_k0 equal modulo one crank-gear pitch: (z_sun + z_crank gear) k / N_c
an integer, i.e. z_sun + z_crank gear divisible by N_c.
"""
import math
from dataclasses import dataclass

import numpy as np

from ...errors import RvtoolInputError
from ...geometry.involute import InvolutePair


def centred_phase(pair):
    """Gear B's angle at theta_A = 0 midway between the flank contacts on line 0 and on line 1
    (centres at (0, 0) and (a, 0)): the kinematic position centred in the backlash [rad]."""
    p0, p1 = pair.mesh_phase(0), pair.mesh_phase(1)
    pitch = 2 * math.pi / pair.gear_b.n_teeth
    d = (p1 - p0 + 0.5 * pitch) % pitch - 0.5 * pitch
    return p0 + 0.5 * d


def placed_phase(pair, direction, theta_a):
    """Gear B's conjugate (mid-backlash) angle [rad] when gear A is at the origin at angle theta_a
    and gear B's centre lies in ``direction`` [rad] at the centre distance: the pair's phase in
    the frame turned by ``direction``."""
    return direction + centred_phase(pair) + pair.ratio * (theta_a - direction)


def solve_rates(edges, members, given):
    """Rates of ``members`` from linear edge relations [(coefficients {member: c}), ...] (sum c omega = 0)
    and the given rates {member: value}; raises when the graph leaves a member undetermined."""
    idx = {m: i for i, m in enumerate(members)}
    rows, rhs = [], []
    for eq in edges:
        r = np.zeros(len(members))
        for m, c in eq.items():
            r[idx[m]] += c
        rows.append(r)
        rhs.append(0.0)
    for m, v in given.items():
        r = np.zeros(len(members))
        r[idx[m]] = 1.0
        rows.append(r)
        rhs.append(v)
    A, b = np.array(rows), np.array(rhs)
    if np.linalg.matrix_rank(A) < len(members):
        raise RvtoolInputError("the gear graph leaves a member's rotation undetermined")
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    return dict(zip(members, x))


_GRAPHS = {}
"""GearGraph.of's graphs by their inputs (at most 64, the oldest dropped)."""


@dataclass(frozen=True)
class GearGraph:
    """Derived RV gear graph (module docstring). Angles [rad], lengths [m]."""
    sun_pair: InvolutePair
    input_pair: InvolutePair | None
    input_centre: tuple | None
    crank_radius: float
    crank_angles: tuple
    sun_angle0: float
    crank_gear_angles0: tuple
    rates: dict
    z_g: int

    @property
    def ratio(self):
        """Signed i = omega_in / omega_carrier."""
        return 1.0 / self.rates["carrier"]

    @property
    def sun_ratio(self):
        """omega_sun / omega_in (1 for the two-stage topology)."""
        return self.rates["sun"]

    @property
    def crank_rate(self):
        """omega_crank / omega_in: the eccentric orbit rate."""
        return self.rates["crank"]

    @classmethod
    def of(cls, design):
        """The graph of ``design`` (its tooth counts, gears, crank count, topology and declared ratio), made
        once per distinct set of those inputs in a process (a variant's design is checked at load and built
        after: the same graph twice, ~2 ms each)."""
        d = design
        rv3 = d.topology == "rv3"
        key = (cls, d.topology, d.cranks.count, d.sun_gear, d.crank_gear, d.pins.n_pins, d.ratio_target,
               d.input_pinion if rv3 else None, d.compound_gear if rv3 else None,
               d.input_stage.direction if rv3 else None)
        try:
            hit = _GRAPHS.get(key)
        except TypeError:                 # an unhashable member: made each time
            return cls._made(d)
        if hit is None:
            hit = cls._made(d)
            if len(_GRAPHS) >= 64:
                _GRAPHS.pop(next(iter(_GRAPHS)))
            _GRAPHS[key] = hit
        return hit

    @classmethod
    def _made(cls, design):
        d = design
        n = d.cranks.count
        sun_pair = InvolutePair(gear_a=d.sun_gear, gear_b=d.crank_gear)
        a = sun_pair.a
        z_s, z_c = d.sun_gear.n_teeth, d.crank_gear.n_teeth
        # a crank count the sun cannot mesh with: neighbouring crank gears overlap
        gap = 2 * a * math.sin(math.pi / n) - 2 * d.crank_gear.tip_radius
        if gap <= 0:
            n_max = max(k for k in range(2, 13) if 2 * a * math.sin(math.pi / k) > 2 * d.crank_gear.tip_radius) \
                if 2 * a > 2 * d.crank_gear.tip_radius else 1
            raise RvtoolInputError(
                f"cranks.count = {n}: crank gears of tip diameter {2 * d.crank_gear.tip_radius:.6g} m on the crank circle "
                f"of radius {a:.6g} m (the sun--crank-gear centre distance) overlap their neighbours by {-gap:.3g} m; "
                f"valid range [2, {n_max}] for these gears")
        if (z_s + z_c) % n:
            raise RvtoolInputError(
                f"sun_gear.n_teeth + crank_gear.n_teeth = {z_s} + {z_c} = {z_s + z_c} is not divisible by cranks.count = "
                f"{n}: identical cranks at equal spacing (360/{n} deg) cannot all mesh the sun with their eccentrics in "
                f"phase; valid: z_sun + z_crank gear a multiple of {n}")
        z_g = d.pins.n_pins - 1
        members = ["input", "sun", "crank", "wheel", "carrier"]
        # omega_k - omega_c = r (omega_s - omega_c); omega_w = -omega_k / z_g; omega_w = omega_c
        edges = [{"crank": 1.0, "carrier": -1.0 + sun_pair.ratio, "sun": -sun_pair.ratio},
                 {"wheel": 1.0, "crank": 1.0 / z_g},
                 {"wheel": 1.0, "carrier": -1.0}]
        input_pair, input_centre, sun0 = None, None, 0.0
        if d.topology == "rv3":
            input_pair = InvolutePair(gear_a=d.input_pinion, gear_b=d.compound_gear)
            gam = d.input_stage.direction
            input_centre = (input_pair.a * math.cos(gam), input_pair.a * math.sin(gam))
            # compound gear at the origin, pinion at input_centre: gear B lies in direction gam + pi from A
            sun0 = placed_phase(input_pair, gam + math.pi, 0.0)
            edges.append({"sun": 1.0, "input": -input_pair.ratio})
        else:
            edges.append({"sun": 1.0, "input": -1.0})
        rates = solve_rates(edges, members, {"input": 1.0})
        betas = tuple(2 * math.pi * k / n for k in range(n))
        theta0 = tuple(placed_phase(sun_pair, b, sun0) for b in betas)
        g = cls(sun_pair=sun_pair, input_pair=input_pair, input_centre=input_centre, crank_radius=a,
                crank_angles=betas, sun_angle0=sun0, crank_gear_angles0=theta0, rates=rates, z_g=z_g)
        if d.ratio_target is not None and abs(g.ratio - d.ratio_target) > 1e-9 * abs(d.ratio_target):
            raise RvtoolInputError(
                f"ratio_target = {d.ratio_target:g} is inconsistent with the gear graph: the tooth counts (sun "
                f"{z_s}, crank gear {z_c}, pins {d.pins.n_pins}"
                + (f", pinion {d.input_pinion.n_teeth}, compound {d.compound_gear.n_teeth}" if input_pair else "")
                + f") give i = {g.ratio:.9g}; valid: ratio_target = {g.ratio:.9g} or tooth counts that give the target")
        return g
