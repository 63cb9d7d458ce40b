"""Thermal network of Eq. (obs_thermal), its single-node instance Eq.
(obs_single_node), the steady fixed-point protocol, and the expansion maps
(Eq. (obs_thermal_gap) and the bearing clearance) that turn temperatures into
gap offsets for the next contact evaluation.

Sources come from a declared sliding-loss model, P_c = mu_c I_s,c / tau_w
(Section "Thermal and lubrication feedback through geometry and friction"):
I_s is not heat by itself, and a tangential law with recoverable storage
would need its own dissipation definition. Temperatures are absolute [K];
an ambient node is held at T_amb and enters through the conductances G_amb.
"""
import math
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import RvtoolInputError
from ..validation import check_finite, check_nonnegative, check_positive, check_range
from .exposure import WindowExposure
from .offsets import GapOffsets, match_selector

#: Tolerance on the sum of a heat partition's fractions: they are declared inputs, exact up to round-off.
PARTITION_SUM_TOL = 1e-12


def _temperatures(name, value, n):
    T = np.array(value, dtype=np.float64)
    if T.shape != (n,):
        raise RvtoolInputError(f"{name} must have shape ({n},), one temperature per node; got {T.shape}")
    bad = ~np.isfinite(T)
    if bad.any():
        raise RvtoolInputError(f"{name} = {T[bad][:4].tolist()} at nodes {np.flatnonzero(bad)[:4].tolist()} is "
                               "outside the valid range: finite absolute temperatures (0, inf) K")
    check_range(name, T, 0.0, low_open=True)
    return T


def _vector(name, value, n):
    v = np.array(value, dtype=np.float64)
    if v.shape != (n,):
        raise RvtoolInputError(f"{name} must have shape ({n},), one value per node; got {v.shape}")
    check_finite(name, v)
    return v


@dataclass(frozen=True, kw_only=True, eq=False)
class ThermalNetwork:
    """C_T dT/dt + L_T T = Q of Eq. (obs_thermal), with an ambient node held at T_amb.

    nodes: node names (unique str). capacity: nodal heat capacities C_T [J/K]
    (> 0). links: ((node_a, node_b, G), ...) conductances between nodes [W/K]
    (>= 0). ambient_conductance: G_amb to the ambient per node [W/K] (>= 0;
    every connected group of nodes needs a path to ambient, otherwise no
    steady state exists). ambient_temperature: T_amb [K] (> 0).

    L_T is the weighted graph Laplacian of the links plus diag(G_amb); the
    ambient enters the right-hand side as G_amb T_amb.
    """
    nodes: tuple
    capacity: np.ndarray
    links: tuple = ()
    ambient_conductance: np.ndarray
    ambient_temperature: float
    conductance_matrix: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        nodes = tuple(self.nodes)
        if not nodes or not all(isinstance(x, str) and x for x in nodes) or len(set(nodes)) != len(nodes):
            raise RvtoolInputError(f"thermal.nodes must be unique non-empty str names; got {nodes!r}")
        object.__setattr__(self, "nodes", nodes)
        n = len(nodes)
        C = _vector("thermal.capacity", self.capacity, n)
        check_positive("thermal.capacity", C)
        Ga = _vector("thermal.ambient_conductance", self.ambient_conductance, n)
        check_nonnegative("thermal.ambient_conductance", Ga)
        check_finite("thermal.ambient_temperature", self.ambient_temperature)
        check_positive("thermal.ambient_temperature", self.ambient_temperature)
        L = np.diag(Ga)
        links = []
        for k, link in enumerate(self.links):
            try:
                a, b, g = link
            except (TypeError, ValueError):
                raise RvtoolInputError(f"thermal.links[{k}] = {link!r} must be (node_a, node_b, conductance)") from None
            for end in (a, b):
                if end not in nodes:
                    raise RvtoolInputError(f"thermal.links[{k}] names node {end!r}; valid: {list(nodes)}")
            if a == b:
                raise RvtoolInputError(f"thermal.links[{k}] joins node {a!r} to itself; valid: two different nodes")
            check_finite(f"thermal.links[{k}].conductance", g)
            check_nonnegative(f"thermal.links[{k}].conductance", g)
            i, j = nodes.index(a), nodes.index(b)
            L[i, i] += g
            L[j, j] += g
            L[i, j] -= g
            L[j, i] -= g
            links.append((a, b, float(g)))
        adjacency = csr_matrix((np.abs(L) > 0) & ~np.eye(n, dtype=bool))
        _, label = connected_components(adjacency, directed=False)
        for group in np.unique(label):
            members = label == group
            if not np.any(Ga[members] > 0.0):
                raise RvtoolInputError(
                    f"thermal.ambient_conductance is 0 for every node of the group {[nodes[i] for i in np.flatnonzero(members)]}; "
                    "valid: at least one node of each connected group with a conductance > 0 W/K to ambient "
                    "(otherwise no steady state exists)")
        for name, arr in (("capacity", C), ("ambient_conductance", Ga), ("conductance_matrix", L)):
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "links", tuple(links))
        object.__setattr__(self, "ambient_temperature", float(self.ambient_temperature))

    def index(self, node: str) -> int:
        try:
            return self.nodes.index(node)
        except ValueError:
            raise RvtoolInputError(f"node = {node!r} is not a thermal node; valid: {list(self.nodes)}") from None

    def _rhs(self, Q):
        return _vector("Q", Q, len(self.nodes)) + self.ambient_conductance * self.ambient_temperature

    def step(self, T, Q, dtau: float) -> np.ndarray:
        """One implicit update of Eq. (obs_thermal): (C/dtau + L) T+ = (C/dtau) T + Q + G_amb T_amb.

        T: nodal temperatures [K]; Q: mean nodal sources over the interval [W];
        dtau: thermal interval Delta tau_T [s] (> 0). Returns T+ [K].
        """
        T = _temperatures("T", T, len(self.nodes))
        check_finite("dtau", dtau)
        check_positive("dtau", dtau)
        c = self.capacity / dtau
        return np.linalg.solve(np.diag(c) + self.conductance_matrix, c * T + self._rhs(Q))

    def march(self, T, Q, duration: float, dtau: float) -> np.ndarray:
        """Eq. (obs_thermal) over ``duration`` [s] (>= 0) with constant Q: steps of dtau, the last one shortened.

        The step matrix C/dtau + L_T is factorized once for the full steps.
        """
        from scipy.linalg import lu_factor, lu_solve
        check_finite("duration", duration)
        check_nonnegative("duration", duration)
        check_finite("dtau", dtau)
        check_positive("dtau", dtau)
        T = _temperatures("T", T, len(self.nodes))
        rhs = self._rhs(Q)
        n_full = int(duration // dtau)
        if n_full:
            c = self.capacity / dtau
            lu = lu_factor(np.diag(c) + self.conductance_matrix)
            for _ in range(n_full):
                T = lu_solve(lu, c * T + rhs)
        rest = duration - n_full * dtau
        if rest > 1e-12 * dtau:  # a remainder at round-off level of the division is no step
            T = self.step(T, Q, rest)
        return T

    def steady(self, Q) -> np.ndarray:
        """Steady state L_T T = Q + G_amb T_amb [K] of Eq. (obs_thermal)."""
        return np.linalg.solve(self.conductance_matrix, self._rhs(Q))


@dataclass(frozen=True, kw_only=True, eq=False)
class SlidingLossSources:
    """Declared sliding-loss model P_c = mu_c I_s,c / tau_w, assigned to thermal nodes.

    friction: mu [-] (>= 0): one value, or selector -> value (a contact id or
    its set name; the id wins). partition: selector -> {node: fraction}; the
    fractions of one entry are >= 0 and sum to 1 (the heat of a contact
    shared by the two bodies in contact, as declared; none is lost).
    """
    friction: object
    partition: dict

    def __post_init__(self):
        if isinstance(self.friction, dict) or isinstance(self.friction, MappingProxyType):
            fr = {}
            for s, mu in self.friction.items():
                check_finite(f"friction[{s!r}]", mu)
                check_nonnegative(f"friction[{s!r}]", mu)
                fr[s] = float(mu)
            object.__setattr__(self, "friction", MappingProxyType(fr))
        else:
            check_finite("friction", self.friction)
            check_nonnegative("friction", self.friction)
            object.__setattr__(self, "friction", float(self.friction))
        part = {}
        for s, shares in dict(self.partition).items():
            shares = {str(node): float(f) for node, f in dict(shares).items()}
            for node, f in shares.items():
                check_finite(f"partition[{s!r}][{node!r}]", f)
                check_range(f"partition[{s!r}][{node!r}]", f, 0.0, 1.0)
            total = sum(shares.values())
            if abs(total - 1.0) > PARTITION_SUM_TOL:
                raise RvtoolInputError(f"partition[{s!r}] fractions sum to {total!r}; valid: 1 (the declared heat "
                                       "partition conserves the source)")
            part[s] = MappingProxyType(shares)
        object.__setattr__(self, "partition", MappingProxyType(part))

    def mu(self, contact_id: str) -> float:
        """mu of ``contact_id`` [-]."""
        if isinstance(self.friction, float):
            return self.friction
        return match_selector(self.friction, contact_id, "friction")

    def power(self, exposure: WindowExposure, friction=None) -> np.ndarray:
        """Mean source per contact, mu_c I_s,c / tau_w [W].

        friction: optional id -> mu overriding the declared values (the
        coupled lubrication mode writes mu per contact instance).
        """
        mu = np.array([(friction[i] if friction is not None and i in friction else self.mu(i))
                       for i in exposure.ids], dtype=np.float64)
        return mu * exposure.I_s / exposure.tau_w

    def node_sources(self, exposure: WindowExposure, network: ThermalNetwork, friction=None) -> np.ndarray:
        """Nodal source vector Q-bar [W] of Eq. (obs_thermal)."""
        Q = np.zeros(len(network.nodes))
        for cid, p in zip(exposure.ids, self.power(exposure, friction)):
            for node, f in match_selector(self.partition, cid, "partition").items():
                Q[network.index(node)] += f * p
        return Q


def combine_phase_sources(sources, weights) -> np.ndarray:
    """Weighted mean of the nodal sources of several phase samples sharing one temperature field [W]."""
    S = np.array(sources, dtype=np.float64)
    w = np.array(weights, dtype=np.float64)
    if S.ndim != 2 or w.shape != (S.shape[0],):
        raise RvtoolInputError(f"sources must be (n_samples, n_nodes) and weights (n_samples,); got {S.shape} and "
                               f"{w.shape}")
    check_finite("sources", S)
    check_finite("weights", w)
    check_range("weights", w, 0.0)
    if not w.sum() > 0.0:
        raise RvtoolInputError(f"weights = {w.tolist()} must have a positive sum")
    return w @ S / w.sum()


# -- the single-node instance -------------------------------------------------
def single_node_update(T_k: float, *, capacity: float, dtau: float, mu: float, I_s_total: float, tau_w: float,
                       conductance: float, ambient_temperature: float) -> float:
    """Eq. (obs_single_node): T^{k+1} = [(C/dtau) T^k + mu sum_c I_s,c / tau_w + G T_amb] / (C/dtau + G) [K].

    capacity C [J/K] (> 0), dtau [s] (> 0), mu [-] (>= 0), I_s_total = sum_c I_s,c
    [N m] (>= 0), tau_w [s] (> 0), conductance G [W/K] (> 0), ambient_temperature [K] (> 0).
    """
    _temperatures("T_k", [T_k], 1)
    for name, v in (("capacity", capacity), ("dtau", dtau), ("tau_w", tau_w), ("conductance", conductance),
                    ("ambient_temperature", ambient_temperature)):
        check_finite(name, v)
        check_positive(name, v)
    for name, v in (("mu", mu), ("I_s_total", I_s_total)):
        check_finite(name, v)
        check_nonnegative(name, v)
    c = capacity / dtau
    return (c * T_k + mu * I_s_total / tau_w + conductance * ambient_temperature) / (c + conductance)


def single_node_transient(t, *, T0: float, capacity: float, conductance: float, power: float,
                          ambient_temperature: float):
    """Closed form of C dT/dt + G (T - T_amb) = P: T(t) = T_inf + (T0 - T_inf) exp(-G t / C),
    T_inf = T_amb + P / G [K]; t [s] (scalar or array, >= 0)."""
    _temperatures("T0", [T0], 1)
    for name, v in (("capacity", capacity), ("conductance", conductance), ("ambient_temperature", ambient_temperature)):
        check_finite(name, v)
        check_positive(name, v)
    check_finite("power", power)
    check_finite("t", t)
    check_nonnegative("t", t)
    T_inf = ambient_temperature + power / conductance
    return T_inf + (T0 - T_inf) * np.exp(-conductance * np.asarray(t, dtype=np.float64) / capacity)


# -- steady protocol ------------------------------------------------------------
@dataclass(frozen=True, kw_only=True, eq=False)
class FixedPointResult:
    """Steady thermal fixed point.

    temperature: candidate field T_k at which the last sources were evaluated [K].
    sources: Q(T_k) [W]. iterations: source evaluations made.
    temperature_residual_K: max |T*(Q(T_k)) - T_k|, the unrelaxed residual [K].
    source_drift_rel: |Q(T_k) - Q(T_{k-1})| / |Q(T_k)| (2-norms) [-].
    converged: both below their tolerances. history: ((residual, drift), ...) per iteration.
    """
    temperature: np.ndarray
    sources: np.ndarray
    iterations: int
    temperature_residual_K: float
    source_drift_rel: float
    converged: bool
    history: tuple


class FixedPointNotConverged(RuntimeError):
    """The steady thermal fixed point did not meet its tolerances; ``result`` holds the last iterate."""

    def __init__(self, message, result):
        super().__init__(message)
        self.result = result


def steady_fixed_point(network: ThermalNetwork, source_of_temperature, T_start, *, relaxation: float = 0.5,
                       temperature_tol_K: float = 1e-3, source_tol_rel: float = 1e-4,
                       max_iterations: int = 100) -> FixedPointResult:
    """Steady operation as a fixed point of sources and temperatures, with under-relaxation.

    source_of_temperature: callable T [K] -> nodal sources Q [W] (the
    mechanical source window re-solved at the candidate field, several phase
    samples combined with :func:`combine_phase_sources`). Iteration k:
    Q_k = Q(T_k), T*_k = steady(Q_k), T_{k+1} = T_k + omega (T*_k - T_k).
    Stops when the unrelaxed residual max|T*_k - T_k| <= temperature_tol_K and
    the source drift |Q_k - Q_{k-1}| / |Q_k| <= source_tol_rel (both checked,
    as the appendix requires; the iteration count is not warm-up time).
    relaxation omega in (0, 1]. Raises :class:`FixedPointNotConverged` after
    max_iterations source evaluations, or earlier when an iterate leaves the
    physical range (non-finite or <= 0 K).
    """
    check_finite("relaxation", relaxation)
    check_range("relaxation", relaxation, 0.0, 1.0, low_open=True)
    check_positive("temperature_tol_K", temperature_tol_K)
    check_positive("source_tol_rel", source_tol_rel)
    if not isinstance(max_iterations, int) or max_iterations < 2:
        raise RvtoolInputError(f"max_iterations = {max_iterations!r} is outside the valid range: integers in "
                               "[2, inf) (the source drift needs two evaluations)")
    n = len(network.nodes)
    T = _temperatures("T_start", T_start, n)
    Q_prev, history = None, []
    for k in range(1, max_iterations + 1):
        Q = _vector("source_of_temperature(T)", source_of_temperature(T.copy()), n)
        T_star = network.steady(Q)
        residual = float(np.max(np.abs(T_star - T)))
        scale = float(np.linalg.norm(Q))
        if Q_prev is None:
            drift = math.inf
        else:
            diff = float(np.linalg.norm(Q - Q_prev))
            drift = 0.0 if diff == 0.0 else (diff / scale if scale > 0.0 else math.inf)
        history.append((residual, drift))
        if residual <= temperature_tol_K and drift <= source_tol_rel:
            return FixedPointResult(temperature=T, sources=Q, iterations=k, temperature_residual_K=residual,
                                    source_drift_rel=drift, converged=True, history=tuple(history))
        T_next = T + relaxation * (T_star - T)
        if not np.all(np.isfinite(T_next) & (T_next > 0.0)):  # the iteration diverged to a non-physical field
            break
        T, Q_prev = T_next, Q
    result = FixedPointResult(temperature=T, sources=Q, iterations=len(history), temperature_residual_K=residual,
                              source_drift_rel=drift, converged=False, history=tuple(history))
    raise FixedPointNotConverged(f"steady thermal fixed point not converged after {len(history)} iterations"
                                 f"{' (diverged to a non-physical temperature)' if len(history) < max_iterations else ''}"
                                 f": temperature residual {residual:.3e} K (tol {temperature_tol_K:.3e}), source drift "
                                 f"{drift:.3e} (tol {source_tol_rel:.3e}); try a smaller relaxation", result)


# -- expansion maps -----------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class CycloidEnvelopeExpansion:
    """Radial-envelope gap change of Eq. (obs_thermal_gap):

        Delta g_T = alpha_h dT_h R_z - alpha_p dT_p r_z - alpha_w dT_w (R_z - r_z)  [m].

    pin_circle_radius: R_z [m] (> 0). pin_radius: r_z, the reference pin
    radius of the envelope map [m] (in (0, R_z)). housing_expansion,
    pin_expansion, wheel_expansion: linear expansion coefficients alpha [1/K]
    (>= 0). Positive Delta g_T opens the gap (a hotter housing); R_z - r_z is
    the effective wheel radius of the envelope approximation.
    """
    pin_circle_radius: float
    pin_radius: float
    housing_expansion: float
    pin_expansion: float
    wheel_expansion: float

    def __post_init__(self):
        check_positive("pin_circle_radius", self.pin_circle_radius)
        check_range("pin_radius", self.pin_radius, 0.0, self.pin_circle_radius, low_open=True, high_open=True)
        for name in ("housing_expansion", "pin_expansion", "wheel_expansion"):
            check_nonnegative(name, getattr(self, name))

    def gap_change(self, dT_housing: float, dT_pins: float, dT_wheel: float) -> float:
        """Delta g_T [m] for temperature rises dT [K] of housing, pins and wheel over their references."""
        for name, v in (("dT_housing", dT_housing), ("dT_pins", dT_pins), ("dT_wheel", dT_wheel)):
            check_finite(name, v)
        R, r = self.pin_circle_radius, self.pin_radius
        return (self.housing_expansion * dT_housing * R - self.pin_expansion * dT_pins * r
                - self.wheel_expansion * dT_wheel * (R - r))


@dataclass(frozen=True, kw_only=True)
class BearingClearanceExpansion:
    """Radial clearance increment of a rolling bearing from thermal expansion [m]:

        Delta c = alpha_o dT_o R_o - alpha_i dT_i R_i - alpha_e dT_e D,

    the outer-raceway expansion minus the inner-raceway and rolling-element
    expansions (Section "Thermal and lubrication feedback ..."), with
    c = R_o - R_i - D. outer_raceway_radius R_o, inner_raceway_radius R_i,
    element_diameter D [m] (> 0, R_o > R_i); outer_expansion, inner_expansion,
    element_expansion: alpha [1/K] (>= 0). Equal alpha and dT give
    Delta c = alpha dT c: the race and element terms cancel to first order,
    leaving the expansion of the clearance itself.
    """
    outer_raceway_radius: float
    inner_raceway_radius: float
    element_diameter: float
    outer_expansion: float
    inner_expansion: float
    element_expansion: float

    def __post_init__(self):
        check_positive("inner_raceway_radius", self.inner_raceway_radius)
        check_positive("element_diameter", self.element_diameter)
        check_range("outer_raceway_radius", self.outer_raceway_radius, self.inner_raceway_radius, low_open=True)
        for name in ("outer_expansion", "inner_expansion", "element_expansion"):
            check_nonnegative(name, getattr(self, name))

    @property
    def clearance(self) -> float:
        """c = R_o - R_i - D [m] (negative: interference)."""
        return self.outer_raceway_radius - self.inner_raceway_radius - self.element_diameter

    def gap_change(self, dT_outer: float, dT_inner: float, dT_element: float) -> float:
        """Delta c [m] for temperature rises dT [K] of outer race, inner race and rolling elements."""
        for name, v in (("dT_outer", dT_outer), ("dT_inner", dT_inner), ("dT_element", dT_element)):
            check_finite(name, v)
        return (self.outer_expansion * dT_outer * self.outer_raceway_radius
                - self.inner_expansion * dT_inner * self.inner_raceway_radius
                - self.element_expansion * dT_element * self.element_diameter)


@dataclass(frozen=True, kw_only=True)
class InvoluteMeshExpansion:
    """Gap change of an external involute tooth pair along its line of action from thermal
    expansion [m] (the gear-pair analogue of Eq. (obs_thermal_gap)):

        Delta g_T = sin alpha_w (alpha_f dT_f a - alpha_A dT_A r_wA - alpha_B dT_B r_wB),

    the centre distance a held by a frame part (a housing, a carrier) minus the two gears'
    growth toward each other, all projected onto the line of action: a radial growth u of a
    gear at its working pitch point moves its flank by u sin alpha_w along the line of action,
    and a centre distance change Delta a opens the gap of a pair by Delta a sin alpha_w on either
    line. Equal alpha dT give 0 (a = r_wA + r_wB: a uniformly scaled pair keeps its gaps, up to
    alpha dT times the gap itself, neglected). Evaluated at the pitch point (declared): along the
    path of contact the gears' terms change by (alpha_B dT_B - alpha_A dT_A) (s - s_pitch) (s the
    roll distance), a flank-slope change that a constant per-flank offset cannot carry; it is
    bounded by that difference times half the path of contact.

    centre_distance a, working_pitch_radius_a / _b r_w [m] (> 0, a = r_wA + r_wB to 1e-9
    relative: external pairs only); working_pressure_angle alpha_w [rad] in (0, pi/2);
    frame_expansion, gear_a_expansion, gear_b_expansion: alpha [1/K] (>= 0).
    """
    centre_distance: float
    working_pitch_radius_a: float
    working_pitch_radius_b: float
    working_pressure_angle: float
    frame_expansion: float
    gear_a_expansion: float
    gear_b_expansion: float

    def __post_init__(self):
        for name in ("centre_distance", "working_pitch_radius_a", "working_pitch_radius_b"):
            check_positive(name, getattr(self, name))
        check_range("working_pressure_angle", self.working_pressure_angle, 0.0, 0.5 * math.pi, low_open=True,
                    high_open=True)
        for name in ("frame_expansion", "gear_a_expansion", "gear_b_expansion"):
            check_nonnegative(name, getattr(self, name))
        a, s = self.centre_distance, self.working_pitch_radius_a + self.working_pitch_radius_b
        if abs(s - a) > 1e-9 * a:
            raise RvtoolInputError(f"working_pitch_radius_a + working_pitch_radius_b = {s!r} is outside the valid "
                                   f"range: equal to centre_distance = {a!r} (an external pair)")

    def gap_change(self, dT_frame: float, dT_gear_a: float, dT_gear_b: float) -> float:
        """Delta g_T [m] of the pair for temperature rises dT [K] of the frame and the two gears."""
        for name, v in (("dT_frame", dT_frame), ("dT_gear_a", dT_gear_a), ("dT_gear_b", dT_gear_b)):
            check_finite(name, v)
        return math.sin(self.working_pressure_angle) * (
            self.frame_expansion * dT_frame * self.centre_distance
            - self.gear_a_expansion * dT_gear_a * self.working_pitch_radius_a
            - self.gear_b_expansion * dT_gear_b * self.working_pitch_radius_b)


@dataclass(frozen=True, kw_only=True)
class ThermalGapChannel:
    """Binds an expansion map to thermal nodes and to the contacts whose gap it offsets.

    name: channel name (e.g. ``"thermal/pins"``). contacts: contact selectors
    receiving the offset (ids or set names). expansion: a
    :class:`CycloidEnvelopeExpansion`, :class:`BearingClearanceExpansion` or
    :class:`InvoluteMeshExpansion` (or any map with ``gap_change(dT, dT, dT)``).
    nodes: the three thermal nodes in the map's argument order (housing,
    pins, wheel / outer race, inner race, elements). reference_temperature:
    the three reference temperatures [K] (> 0) from which dT is measured.
    """
    name: str
    contacts: tuple
    expansion: object
    nodes: tuple
    reference_temperature: tuple

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise RvtoolInputError(f"channel name must be a non-empty str; got {self.name!r}")
        contacts = (self.contacts,) if isinstance(self.contacts, str) else tuple(self.contacts)
        if not contacts or not all(isinstance(c, str) and c for c in contacts):
            raise RvtoolInputError(f"{self.name}.contacts must be contact selectors (str); got {self.contacts!r}")
        object.__setattr__(self, "contacts", contacts)
        if not callable(getattr(self.expansion, "gap_change", None)):
            raise RvtoolInputError(f"{self.name}.expansion must provide gap_change(dT, dT, dT); got "
                                   f"{type(self.expansion).__name__}")
        if len(tuple(self.nodes)) != 3 or len(tuple(self.reference_temperature)) != 3:
            raise RvtoolInputError(f"{self.name}.nodes and .reference_temperature need three entries each")
        object.__setattr__(self, "nodes", tuple(self.nodes))
        ref = _temperatures(f"{self.name}.reference_temperature", self.reference_temperature, 3)
        object.__setattr__(self, "reference_temperature", tuple(ref.tolist()))

    def gap_change(self, network: ThermalNetwork, T) -> float:
        """Gap offset [m] of this channel at nodal temperatures T [K]."""
        T = _temperatures("T", T, len(network.nodes))
        dT = [T[network.index(node)] - ref for node, ref in zip(self.nodes, self.reference_temperature)]
        return float(self.expansion.gap_change(*dT))


def thermal_gap_offsets(channels, network: ThermalNetwork, T) -> GapOffsets:
    """Gap offsets [m] of every channel at temperatures T [K], one table per channel."""
    return GapOffsets(by_channel={ch.name: {c: ch.gap_change(network, T) for c in ch.contacts} for ch in channels})
