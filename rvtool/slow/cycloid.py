"""Slow-process inputs of a cycloid drive, derived from its design plus declared slow-process
parameters (:class:`CycloidSlowInputs`: heat capacities from the design's masses, declared
conductances, expansion coefficients, lubricant, friction law, wear and life laws).

Contact identities are those of :class:`rvtool.slow.reducer_windows.ReducerWindows`
(``"pins/wheel0/pin3"``, ``"output_pins/output_pins/pin2/wheel0"``,
``"eccentric_bearings/eccentric_bearing0"``, ...). Every number of
:class:`CycloidSlowInputs` is an input chosen here (the reference design gives none);
the cases report them with their results.
"""
import dataclasses
import math
from dataclasses import dataclass

from ..errors import RvtoolInputError
from ..model import Family
from .lubrication import FilmContact, Lubrication, MixedFriction, RoelandsViscosity, reduced_modulus
from .orchestrator import ThermalCoupling
from .thermal import (BearingClearanceExpansion, CycloidEnvelopeExpansion, SlidingLossSources, ThermalGapChannel,
                      ThermalNetwork)
from .wear import FilmWearCoefficient, IdentityBin, SurfaceAssociation, WearModel

NODES = ("housing", "pins", "wheels", "flange", "shaft", "needles")
T_AMBIENT = 293.15


@dataclass(frozen=True, kw_only=True)
class CycloidSlowInputs:
    """Declared slow-process parameters (SI units; chosen here, not from the reference design).

    specific_heat [J/(kg K)] of steel; housing_film [W/(m^2 K)]: convection on the housing's
    outer surface; housing_mount [W/K]: conduction from the housing into the machine frame; flange_ambient, shaft_ambient [W/K]: conduction to the mounting and the
    motor; links [W/K]: (node_a, node_b, G); expansion [1/K] of all steel parts; mu_pins,
    mu_output_pins: declared sliding-loss coefficients [-] (observation mode and heat
    sources); lubricant (Roelands: eta_ref [Pa s] at T_ref [K], S0, Z; an ISO VG 68-like
    gear oil); friction law (mu_b, mu_f, lambda_t, n); roughness Rq [m] of both surfaces;
    boundary wear coefficient k_b [m^2/N]; wear nominal areas [m^2] per family; contact
    fatigue: Hertz-pressure S--N curve N = N_ref (p_ref / p0)^k of every line contact (p_ref
    [Pa] at N_ref cycles: the contact endurance limit of case-hardened steel, ISO 6336-5 MQ
    sigma_H,lim = 1500 MPa at 5e7 cycles; k = 8: Lundberg--Palmgren's line-contact element
    exponent, life ~ Q^-4), i.e. a force--life exponent m = k / 2 = 4.
    """
    specific_heat: float = 460.0
    housing_film: float = 20.0
    flange_ambient: float = 0.3
    shaft_ambient: float = 0.2
    housing_mount: float = 3.0
    links: tuple = (("pins", "housing", 5.0), ("wheels", "pins", 3.0), ("wheels", "needles", 2.0),
                    ("needles", "shaft", 2.0), ("wheels", "flange", 1.0), ("flange", "housing", 2.0),
                    ("shaft", "housing", 1.0), ("wheels", "housing", 1.5))
    expansion: float = 11.5e-6
    mu_pins: float = 0.05
    mu_output_pins: float = 0.05
    eta_ref: float = 0.068
    T_ref: float = 313.15
    roelands_S0: float = 1.1
    roelands_Z: float = 0.6
    mu_boundary: float = 0.10
    mu_fluid: float = 0.02
    lambda_transition: float = 1.0
    friction_sharpness: float = 2.0
    roughness: float = 0.2e-6
    wear_boundary_coefficient: float = 2.5e-19
    wear_area_pins: float = 2.5e-5
    wear_area_output_pins: float = 3.0e-5
    fatigue_reference_pressure: float = 1.5e9
    fatigue_reference_cycles: float = 5e7
    fatigue_pressure_exponent: float = 8.0


def _housing_geometry(design):
    """The housing's annulus (``[housing.structure]``: inner_radius, outer_radius, height [m])."""
    if design.housing.structure is None:
        raise RvtoolInputError("the thermal network needs the housing geometry: give [housing.structure] "
                               "(inner_radius, outer_radius, height)")
    return design.housing.structure


def heat_capacities(design, inputs: CycloidSlowInputs) -> dict:
    """Node -> C_T [J/K] from the design's geometry and masses (steel, declared c_p)."""
    d, rho, cp = design, design.material.density, inputs.specific_heat
    h = _housing_geometry(design)
    m_housing = math.pi * (h.outer_radius ** 2 - h.inner_radius ** 2) * h.height * rho
    m_pins = d.pins.n_pins * math.pi * d.pins.pin_radius ** 2 * h.height * rho
    # wheel annulus between the pin envelope and the bearing bore (the assembly's wheel mass)
    r_o = d.pins.pin_circle_radius - d.pins.pin_radius
    r_i = d.eccentric_bearing.inner_radius + d.eccentric_bearing.roller_diameter
    m_wheels = d.n_wheels * math.pi * (r_o ** 2 - r_i ** 2) * d.wheels.width * rho
    eb = d.eccentric_bearing
    m_needles = d.n_wheels * eb.n_rollers * math.pi * (0.5 * eb.roller_diameter) ** 2 * eb.roller_length * rho
    masses = {"housing": m_housing, "pins": m_pins, "wheels": m_wheels, "flange": d.bodies.flange_mass,
              "shaft": d.bodies.shaft_mass, "needles": m_needles}
    return {k: cp * m for k, m in masses.items()}


def thermal_network(design, inputs: CycloidSlowInputs) -> ThermalNetwork:
    """Six-node network of Eq. (obs_thermal): housing, pins, wheels, flange, shaft, needles."""
    h = _housing_geometry(design)
    area = 2 * math.pi * h.outer_radius * h.height + 2 * math.pi * (h.outer_radius ** 2 - h.inner_radius ** 2)
    C = heat_capacities(design, inputs)
    G_amb = {"housing": inputs.housing_film * area + inputs.housing_mount, "flange": inputs.flange_ambient, "shaft": inputs.shaft_ambient}
    return ThermalNetwork(nodes=NODES, capacity=[C[n] for n in NODES], links=inputs.links,
                          ambient_conductance=[G_amb.get(n, 0.0) for n in NODES], ambient_temperature=T_AMBIENT)


def friction(inputs: CycloidSlowInputs) -> dict:
    """Declared sliding-loss mu per family selector (rolling bearings: no sliding exposure)."""
    return {Family.PINS.value: inputs.mu_pins, Family.OUTPUT_PINS.value: inputs.mu_output_pins,
            Family.ECCENTRIC_BEARINGS.value: 0.0, Family.MAIN_BEARINGS.value: 0.0, Family.INPUT_BEARINGS.value: 0.0}


HEAT_PARTITION = {Family.PINS.value: {"pins": 0.5, "wheels": 0.5},
                  Family.OUTPUT_PINS.value: {"wheels": 0.5, "flange": 0.5},
                  Family.ECCENTRIC_BEARINGS.value: {"needles": 1.0},
                  Family.MAIN_BEARINGS.value: {"flange": 0.5, "housing": 0.5},
                  Family.INPUT_BEARINGS.value: {"shaft": 0.5, "housing": 0.5}}
"""Declared heat partition: the sliding loss of a contact shared equally by the two bodies."""


def gap_channels(design, inputs: CycloidSlowInputs) -> tuple:
    """The two thermal gap channels: the radial envelope of Eq. (obs_thermal_gap) on every pin
    contact (housing, pins, wheels) and the eccentric needle bearing clearance increment
    (outer race = wheel bore, inner race = journal, needles), reference = ambient."""
    a = inputs.expansion
    eb = design.eccentric_bearing
    env = CycloidEnvelopeExpansion(pin_circle_radius=design.pins.pin_circle_radius, pin_radius=design.pins.pin_radius,
                                   housing_expansion=a, pin_expansion=a, wheel_expansion=a)
    brg = BearingClearanceExpansion(outer_raceway_radius=eb.inner_radius + eb.roller_diameter + eb.radial_clearance,
                                    inner_raceway_radius=eb.inner_radius, element_diameter=eb.roller_diameter,
                                    outer_expansion=a, inner_expansion=a, element_expansion=a)
    ref = (T_AMBIENT,) * 3
    return (ThermalGapChannel(name="thermal/pins", contacts=(Family.PINS.value,), expansion=env,
                              nodes=("housing", "pins", "wheels"), reference_temperature=ref),
            ThermalGapChannel(name="thermal/eccentric_bearings", contacts=(Family.ECCENTRIC_BEARINGS.value,),
                              expansion=brg, nodes=("wheels", "shaft", "needles"), reference_temperature=ref))


def thermal_coupling(design, inputs: CycloidSlowInputs, *, channels=True) -> ThermalCoupling:
    """Network, declared sliding-loss sources and (channels=True) the gap channels."""
    return ThermalCoupling(network=thermal_network(design, inputs),
                           sources=SlidingLossSources(friction=friction(inputs), partition=HEAT_PARTITION),
                           channels=gap_channels(design, inputs) if channels else ())


def friction_law(inputs: CycloidSlowInputs) -> MixedFriction:
    return MixedFriction(boundary_friction=inputs.mu_boundary, fluid_friction=inputs.mu_fluid,
                         transition_lambda=inputs.lambda_transition, sharpness=inputs.friction_sharpness)


#: Stribeck's ball-bearing constant, Q_max = 5 F_r / (Z cos alpha) (nominal clearance; Harris & Kotzalas
#: 2007, vol. 1, ch. 7): the most loaded ball of a lumped ball bearing.
STRIBECK_BALL = 5.0


def _ball_film(spec, omega_rel, E, rough, node, lumped):
    """Point-contact film of a ball bearing (or angular-contact pair, first row) at its inner race,
    the contact of the smaller reduced radius: R_x = D (1 - gamma) / 2, R_y = f_i D / (2 f_i - 1)
    (:func:`rvtool.bearings.hertz.race_radii`), entrainment u = omega_rel d_m (1 - gamma^2) / 4 (the
    rolling speed of both surfaces relative to the contact), gamma = D cos(alpha) / d_m; lumped: the
    most loaded ball's share STRIBECK_BALL / (Z cos alpha) of the bearing force."""
    from ..bearings.hertz import race_radii
    from ..bearings.reducer import ball_rows
    rows = ball_rows(spec)
    b = rows[0]
    (rx, ry), _ = race_radii(b.ball_diameter, b.pitch_diameter, b.contact_angle, b.inner_curvature,
                             b.outer_curvature)
    g = b.ball_diameter * math.cos(b.contact_angle) / b.pitch_diameter
    share = STRIBECK_BALL / (len(rows) * b.n_balls * math.cos(b.contact_angle)) if lumped else 1.0
    return FilmContact(kind="point", radius_x=float(rx), radius_y=float(ry),
                       entrainment_speed=0.25 * omega_rel * b.pitch_diameter * (1 - g * g), reduced_modulus=E,
                       roughness_1=rough, roughness_2=rough, node=node, load_share=share)


def lubrication(design, inputs: CycloidSlowInputs, exposure, radii: dict | None = None,
                bearing_model: str = "lumped") -> Lubrication:
    """Film contacts of the families. Entrainment u = (u1 + u2) / 2: pins (fixed in the housing)
    and plain output pins have one moving surface at the contact, so u = half the load-weighted
    sliding speed I_s / I_F of the family in ``exposure`` (the cold window); the needles roll at
    u = omega_rel R_i / 2 (inner-race surface speed relative to the wheel bore, halved: the
    cage-frame speed of both surfaces, declared approximation). Line contacts; the lumped eccentric bearing's load per length is that
    of the most loaded roller (Stribeck: Q_max = 4.08 F_r / Z), hence length = Z L / 4.08.

    Reduced radius of a ring-pin contact: radii (window contact id -> R [m], from
    :func:`rvtool.slow.contact_radius.window_radii` over the accepted states of a window) gives each
    loaded pin contact its local 1/R = 1/r_p + kappa_flank (on RD-40 the loaded flank is convex,
    R ~ 0.46 r_p); None keeps R = r_p for every pin (the pin's own radius only). Output pins and
    needles are circles on circles: their radii do not depend on the contact point.

    bearing_model: "lumped" (one contact per bearing: the needle line contact of the most loaded
    roller as above, the ball bearings' most loaded ball) or "rolling" (a contact per roller or
    ball: its own load, length L). Main and input ball bearings are point contacts at their inner
    race (:func:`_ball_film`); they turn at the output speed omega / (z_p - 1) and at omega."""
    if bearing_model not in ("lumped", "rolling"):
        raise RvtoolInputError(f"bearing_model = {bearing_model!r}; valid choices are ['lumped', 'rolling']")
    lumped = bearing_model == "lumped"
    E = reduced_modulus(design.material.youngs_modulus, design.material.poisson_ratio,
                        design.material.youngs_modulus, design.material.poisson_ratio)
    fam_u = {}
    for fam in (Family.PINS.value, Family.OUTPUT_PINS.value):
        idx = [k for k, c in enumerate(exposure.ids) if c.startswith(fam + "/")]
        I_s, I_F = sum(exposure.I_s[k] for k in idx), sum(exposure.I_F[k] for k in idx)
        fam_u[fam] = 0.5 * I_s / I_F
    d, eb, op = design, design.eccentric_bearing, design.output_pins
    rp = d.pins.pin_radius
    omega_in = d.input_speed_rpm * math.pi / 30.0
    omega_rel = omega_in * (1.0 + 1.0 / (d.pins.n_pins - 1))
    Rr, Ri = 0.5 * eb.roller_diameter, eb.inner_radius
    rough = inputs.roughness
    contacts = {
        Family.PINS.value: FilmContact(kind="line", radius_x=rp, entrainment_speed=fam_u[Family.PINS.value],
                                       reduced_modulus=E, roughness_1=rough, roughness_2=rough, node="pins",
                                       length=d.wheels.width),
        Family.OUTPUT_PINS.value: FilmContact(kind="line", radius_x=op.pin_radius * op.hole_radius / (op.hole_radius - op.pin_radius),
                                              entrainment_speed=fam_u[Family.OUTPUT_PINS.value], reduced_modulus=E,
                                              roughness_1=rough, roughness_2=rough, node="wheels", length=d.wheels.width),
        Family.ECCENTRIC_BEARINGS.value: FilmContact(kind="line", radius_x=Rr * Ri / (Rr + Ri),
                                                     entrainment_speed=0.5 * omega_rel * Ri, reduced_modulus=E,
                                                     roughness_1=rough, roughness_2=rough, node="needles",
                                                     length=eb.n_rollers * eb.roller_length / 4.08 if lumped
                                                     else eb.roller_length),
    }
    if d.main_bearing is not None:
        contacts[Family.MAIN_BEARINGS.value] = _ball_film(d.main_bearing, omega_in / (d.pins.n_pins - 1), E, rough,
                                                          "flange", lumped)
    if d.input_bearing is not None:
        contacts[Family.INPUT_BEARINGS.value] = _ball_film(d.input_bearing, omega_in, E, rough, "shaft", lumped)
    pin_film = contacts[Family.PINS.value]
    for cid, R in dict(radii or {}).items():
        if family_of(cid) != Family.PINS.value:
            raise RvtoolInputError(f"radii names contact {cid!r}; valid: ring-pin contacts 'pins/...' (the other "
                                   "families' radii do not depend on the contact point)")
        contacts[cid] = dataclasses.replace(pin_film, radius_x=float(R))   # the identity wins over the set name
    return Lubrication(lubricant=RoelandsViscosity(reference_viscosity=inputs.eta_ref, reference_temperature=inputs.T_ref,
                                                   temperature_index=inputs.roelands_S0, pressure_index=inputs.roelands_Z),
                       friction_law=friction_law(inputs), contacts=contacts)


class PinStationBin:
    """Surface bin of one body at one contact station: ``<surface>/<contact id without family>``
    (a ring pin at the axial station of wheel k: ``ring_pin/wheel0/pin3``)."""

    def __init__(self, surface):
        self.surface = surface

    def __call__(self, contact_id, position):
        return f"{self.surface}/{contact_id.split('/', 1)[1]}"


def wear_model(design, inputs: CycloidSlowInputs) -> WearModel:
    """Eq. (obs_wear) with k_w = k_b f_a(lambda) (the declared friction law's asperity share).

    Association (equal hardness: the loss of a contact is shared 0.5 / 0.5): a ring-pin contact
    wears the pin at the wheel's axial station and the wheel flank zone that pin passes over in
    the window (identified by the pin); an output-pin contact the pin at that wheel and the
    wheel's hole; rolling bearings have no sliding exposure (no wear)."""
    pins, opins = Family.PINS.value, Family.OUTPUT_PINS.value
    rules = {pins: ((PinStationBin("ring_pin"), 0.5), (PinStationBin("wheel_flank"), 0.5)),
             opins: ((PinStationBin("output_pin"), 0.5), (PinStationBin("wheel_hole"), 0.5))}
    for fam in (Family.ECCENTRIC_BEARINGS, Family.MAIN_BEARINGS, Family.INPUT_BEARINGS):
        rules[fam.value] = ((IdentityBin(surface=fam.value), 1.0),)
    area = {pins: inputs.wear_area_pins, opins: inputs.wear_area_output_pins,
            Family.ECCENTRIC_BEARINGS.value: 1.0, Family.MAIN_BEARINGS.value: 1.0, Family.INPUT_BEARINGS.value: 1.0}
    return WearModel(coefficient=FilmWearCoefficient(boundary_coefficient=inputs.wear_boundary_coefficient,
                                                     friction_law=friction_law(inputs)),
                     nominal_area=area, association=SurfaceAssociation(rules=rules))


def family_of(contact_id: str) -> str:
    """The family value of a window contact id."""
    return contact_id.split("/", 1)[0]


def _e_star(design):
    m = design.material
    return m.youngs_modulus / (2 * (1 - m.poisson_ratio ** 2))


def contact_line_geometry(design) -> dict:
    """Family -> (reduced radius R [m], loaded length b [m]) of the line contacts: ring pin against
    the flank (R = r_p, the pin's own radius: a nominal value; the local radius of a contact, with
    the flank's curvature, comes from :func:`rvtool.slow.contact_radius.window_radii` or
    :func:`rvtool.pressure.state.pin_contact`), output pin in its hole (conformal),
    needle on the journal (the inner, more conforming-less race)."""
    d, eb, op = design, design.eccentric_bearing, design.output_pins
    Rr, Ri = 0.5 * eb.roller_diameter, eb.inner_radius
    return {Family.PINS.value: (d.pins.pin_radius, d.wheels.width),
            Family.OUTPUT_PINS.value: (op.pin_radius * op.hole_radius / (op.hole_radius - op.pin_radius),
                                       d.wheels.width),
            Family.ECCENTRIC_BEARINGS.value: (Rr * Ri / (Rr + Ri), eb.roller_length)}


def life_laws(design, inputs: CycloidSlowInputs, *, per_roller: bool, radius: dict | None = None) -> dict:
    """Family -> :class:`~rvtool.slow.fatigue.ForceLifeLaw` of Eq. (obs_damage): the declared
    Hertz-pressure S--N curve in force, F_ref = pi R b p_ref^2 / E* of the family's line contact
    (``per_roller``: the eccentric bearing's contacts are single rollers (``bearing_model="rolling"``);
    otherwise the lumped bearing force, whose most loaded roller carries 4.08 F / Z). radius: family
    -> reduced radius R [m] replacing :func:`contact_line_geometry`'s (e.g. the ring pin's local
    radius at its peak load from :func:`rvtool.pressure.state.pin_contact`)."""
    from .fatigue import ForceLifeLaw, hertz_line_reference_force
    E = _e_star(design)
    m = 0.5 * inputs.fatigue_pressure_exponent
    out = {}
    geometry = contact_line_geometry(design)
    for fam, R in dict(radius or {}).items():
        if fam not in geometry:
            raise RvtoolInputError(f"radius names family {fam!r}; valid: {sorted(geometry)}")
        geometry[fam] = (R, geometry[fam][1])
    for fam, (R, b) in geometry.items():
        F_ref = hertz_line_reference_force(reference_pressure=inputs.fatigue_reference_pressure, radius=R,
                                           length=b, reduced_modulus=E)
        if fam == Family.ECCENTRIC_BEARINGS.value and not per_roller:
            F_ref *= design.eccentric_bearing.n_rollers / 4.08
        out[fam] = ForceLifeLaw(reference_life=inputs.fatigue_reference_cycles, reference_force=F_ref, exponent=m)
    return out


def cycle_rates(design, omega: float) -> dict:
    """Family -> stress-cycle rate nu_c [1/s] of one contact (declared): a ring pin and an output
    pin are loaded once per input revolution (the eccentricity direction turns with the input),
    a needle passes a point of the journal's load zone at the cage speed relative to the journal,
    (omega_rel / 2 pi)(1 + D / D_pw) / 2, omega_rel = omega z_p / (z_p - 1)."""
    eb = design.eccentric_bearing
    f_in = omega / (2 * math.pi)
    z = design.pins.n_pins
    f_rel = f_in * z / (z - 1)
    dpw = 2 * eb.inner_radius + eb.roller_diameter
    return {Family.PINS.value: f_in, Family.OUTPUT_PINS.value: f_in,
            Family.ECCENTRIC_BEARINGS.value: 0.5 * f_rel * (1 + eb.roller_diameter / dpw)}


def rating_geometries(design) -> dict:
    """Bearing name (``bearing_model="rolling"`` mountings) -> (:class:`~rvtool.slow.fatigue.RatingGeometry`,
    speed factor: relative ring speed / input speed)."""
    from .fatigue import RatingGeometry
    d, eb = design, design.eccentric_bearing
    z = d.pins.n_pins
    out = {}
    needle = RatingGeometry(element="roller", n_elements=eb.n_rollers, element_diameter=eb.roller_diameter,
                            pitch_diameter=2 * eb.inner_radius + eb.roller_diameter, roller_length=eb.roller_length)
    for k in range(d.n_wheels):
        out[f"eccentric_bearing{k}"] = (needle, z / (z - 1))
    from ..bearings.reducer import ball_rows
    mb, ib = d.main_bearing, d.input_bearing
    if mb is not None:           # None: kind = "locked"
        rows = ball_rows(mb)
        r0 = rows[0]
        out["main_bearing"] = (RatingGeometry(element="ball", n_elements=r0.n_balls, element_diameter=r0.ball_diameter,
                                              pitch_diameter=r0.pitch_diameter, n_rows=len(rows),
                                              contact_angle=r0.contact_angle), 1.0 / (z - 1))
    if ib is not None:
        g = RatingGeometry(element="ball", n_elements=ib.n_balls, element_diameter=ib.ball_diameter,
                           pitch_diameter=ib.pitch_diameter, contact_angle=ib.contact_angle)
        for k in range(2):
            out[f"input_bearing{k}"] = (g, 1.0)
    return out


__all__ = ["CycloidSlowInputs", "life_laws", "cycle_rates", "rating_geometries", "contact_line_geometry", "thermal_network", "thermal_coupling", "gap_channels", "lubrication", "wear_model",
           "friction_law", "friction", "heat_capacities", "HEAT_PARTITION", "NODES", "T_AMBIENT", "family_of"]
