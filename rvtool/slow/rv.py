"""Slow-process inputs of an RV reducer (:mod:`rvtool.assembly.rv`), derived from its design plus
declared thermal parameters (:class:`RvSlowInputs`): the thermal network of Eq. (obs_thermal)
over the RV's bodies, the declared sliding-loss sources, and the thermal gap channels of the RV's
contact families written through ``ReducerModel.set_gap_offsets``:

* ``thermal/pins``: the radial envelope of Eq. (obs_thermal_gap) on every cycloid--pin contact
  (housing, pins, wheels);
* ``thermal/eccentric_bearings``: the needle clearance increment (outer race = wheel bore,
  inner race = crank journal, needles);
* ``thermal/crank_bearings``: the tapered pairs' radial clearance increment (cup in the carrier,
  cone on the crank, rollers at the crank's temperature), projected onto each lamina's normal
  (n_r = cos of the cup angle: the gap offset of a tapered lamina acts along its normal);
* ``thermal/main_bearings``: the angular-contact pair's radial clearance increment (outer race
  in the housing, inner race on the carrier, balls at the carrier's temperature), projected onto
  the line of action (cos of the free contact angle: the ball law's clearance acts along it).

The bearing channels are radial expansion only (declared): the axial expansion of a crank or of
the carrier against the housing, which changes the tapered and angular-contact preloads, has no
coordinate in the planar model. The involute stage is not a window family here: its sliding
heat and flank offsets come with the involute-stage window bodies and flank offsets (wip/slowfric).
Every number of :class:`RvSlowInputs` is chosen here (the design gives none); the cases report them.
"""
import math
from dataclasses import dataclass

from ..model import Family
from ..validation import check_nonnegative, check_positive, check_range
from .orchestrator import ThermalCoupling
from .reducer_windows import ContactBodies
from .thermal import (BearingClearanceExpansion, CycloidEnvelopeExpansion, SlidingLossSources, ThermalGapChannel,
                      ThermalNetwork)

NODES = ("housing", "pins", "wheels", "cranks", "needles", "carrier", "input")
T_AMBIENT = 293.15


@dataclass(frozen=True, kw_only=True)
class RvSlowInputs:
    """Declared slow-process parameters of an RV reducer (SI units; chosen here, not from the design).

    specific_heat [J/(kg K)] of steel; housing_outer_radius, housing_height [m]: the housing
    annulus around the pin circle (its inner radius is the pin circle radius: the pins sit
    half in its bore); housing_film [W/(m^2 K)]: convection on its outer surface; housing_mount,
    carrier_ambient, input_ambient [W/K]: conduction into the machine frame, the driven machine
    and the motor; links [W/K]: (node_a, node_b, G); expansion [1/K] of all steel parts; mu_pins:
    the declared sliding-loss coefficient of the cycloid--pin contacts [-] (heat sources).
    """
    specific_heat: float = 460.0
    housing_outer_radius: float = 0.085
    housing_height: float = 0.060
    housing_film: float = 20.0
    housing_mount: float = 3.0
    carrier_ambient: float = 0.3
    input_ambient: float = 0.2
    links: tuple = (("pins", "housing", 5.0), ("wheels", "pins", 3.0), ("wheels", "needles", 2.0),
                    ("needles", "cranks", 2.0), ("cranks", "carrier", 2.0), ("carrier", "housing", 2.0),
                    ("wheels", "carrier", 1.0), ("wheels", "housing", 1.5), ("input", "cranks", 0.5),
                    ("input", "housing", 0.5))
    expansion: float = 11.5e-6
    mu_pins: float = 0.05

    def __post_init__(self):
        for name in ("specific_heat", "housing_outer_radius", "housing_height", "expansion"):
            check_positive(name, getattr(self, name))
        for name in ("housing_film", "housing_mount", "carrier_ambient", "input_ambient", "mu_pins"):
            check_nonnegative(name, getattr(self, name))


def heat_capacities(design, inputs: RvSlowInputs) -> dict:
    """Node -> C_T [J/K]: housing annulus and pins over the declared height, the wheels' annuli
    (:func:`rvtool.assembly.rv.builder.wheel_mass`), the needles, and the declared masses of the
    cranks, the carrier and the input shaft (steel, declared c_p)."""
    from ..assembly.rv.builder import wheel_mass
    from ..assembly.rv.gear_graph import GearGraph
    d, rho, cp = design, design.material.density, inputs.specific_heat
    R = d.pins.pin_circle_radius
    check_range("housing_outer_radius", inputs.housing_outer_radius, R, low_open=True)
    h = inputs.housing_height
    eb = d.eccentric_bearing
    masses = {"housing": math.pi * (inputs.housing_outer_radius ** 2 - R ** 2) * h * rho,
              "pins": d.pins.n_pins * math.pi * d.pins.pin_radius ** 2 * h * rho,
              "wheels": 2 * wheel_mass(d, GearGraph.of(d))[0],
              "cranks": d.cranks.count * d.cranks.mass,
              "needles": 2 * d.cranks.count * eb.n_rollers * math.pi * (0.5 * eb.roller_diameter) ** 2
              * eb.roller_length * rho,
              "carrier": d.bodies.carrier_mass, "input": d.bodies.sun_mass}
    return {k: cp * m for k, m in masses.items()}


def thermal_network(design, inputs: RvSlowInputs) -> ThermalNetwork:
    """Seven-node network of Eq. (obs_thermal): housing, pins, wheels, cranks, needles, carrier, input."""
    ro, h = inputs.housing_outer_radius, inputs.housing_height
    area = 2 * math.pi * ro * h + 2 * math.pi * (ro ** 2 - design.pins.pin_circle_radius ** 2)
    C = heat_capacities(design, inputs)
    G_amb = {"housing": inputs.housing_film * area + inputs.housing_mount, "carrier": inputs.carrier_ambient,
             "input": inputs.input_ambient}
    return ThermalNetwork(nodes=NODES, capacity=[C[n] for n in NODES], links=inputs.links,
                          ambient_conductance=[G_amb.get(n, 0.0) for n in NODES], ambient_temperature=T_AMBIENT)


def friction(inputs: RvSlowInputs) -> dict:
    """Declared sliding-loss mu per family (rolling bearings: no sliding exposure)."""
    return {Family.PINS.value: inputs.mu_pins, Family.ECCENTRIC_BEARINGS.value: 0.0,
            Family.CRANK_BEARINGS.value: 0.0, Family.MAIN_BEARINGS.value: 0.0}


HEAT_PARTITION = {Family.PINS.value: {"pins": 0.5, "wheels": 0.5},
                  Family.ECCENTRIC_BEARINGS.value: {"needles": 1.0},
                  Family.CRANK_BEARINGS.value: {"cranks": 0.5, "carrier": 0.5},
                  Family.MAIN_BEARINGS.value: {"carrier": 0.5, "housing": 0.5}}
"""Declared heat partition: the sliding loss of a contact shared equally by the two bodies."""


def contact_bodies() -> dict:
    """The RV's window declaration (:mod:`rvtool.assembly.rv.builder` contact ids): a pin contact
    ``wheel<k>/pin<j>`` joins wheel k and the housing (pins fixed in it); the bearings roll."""
    return {Family.PINS: ContactBodies(body_a=lambda c: c.split("/")[0], body_b=None),
            Family.ECCENTRIC_BEARINGS: ContactBodies(rolling=True),
            Family.CRANK_BEARINGS: ContactBodies(rolling=True),
            Family.MAIN_BEARINGS: ContactBodies(rolling=True)}


@dataclass(frozen=True)
class ProjectedExpansion:
    """A radial clearance increment (``expansion.gap_change``) projected onto the direction along
    which a contact law takes its gap offset: ``factor`` [-] in (0, 1] (a cosine)."""
    expansion: object
    factor: float

    def __post_init__(self):
        check_range("factor", self.factor, 0.0, 1.0, low_open=True)

    def gap_change(self, dT_outer: float, dT_inner: float, dT_elements: float) -> float:
        return self.factor * self.expansion.gap_change(dT_outer, dT_inner, dT_elements)


def gap_channels(design, inputs: RvSlowInputs) -> tuple:
    """The four thermal gap channels of the module docstring, reference = ambient."""
    a = inputs.expansion
    d = design
    eb = d.eccentric_bearing
    env = CycloidEnvelopeExpansion(pin_circle_radius=d.pins.pin_circle_radius, pin_radius=d.pins.pin_radius,
                                   housing_expansion=a, pin_expansion=a, wheel_expansion=a)
    needles = BearingClearanceExpansion(outer_raceway_radius=eb.inner_radius + eb.roller_diameter + eb.radial_clearance,
                                        inner_raceway_radius=eb.inner_radius, element_diameter=eb.roller_diameter,
                                        outer_expansion=a, inner_expansion=a, element_expansion=a)

    def radial(dm, D):
        return BearingClearanceExpansion(outer_raceway_radius=0.5 * (dm + D), inner_raceway_radius=0.5 * (dm - D),
                                         element_diameter=D, outer_expansion=a, inner_expansion=a, element_expansion=a)

    tp, mb = d.crank_bearing.rows[0], d.main_bearing.rows[0]
    crank = ProjectedExpansion(radial(tp.pitch_diameter, tp.roller_diameter), math.cos(math.radians(tp.cup_angle_deg)))
    main = ProjectedExpansion(radial(mb.pitch_diameter, mb.ball_diameter), math.cos(mb.contact_angle))
    ref = (T_AMBIENT,) * 3
    return (ThermalGapChannel(name="thermal/pins", contacts=(Family.PINS.value,), expansion=env,
                              nodes=("housing", "pins", "wheels"), reference_temperature=ref),
            ThermalGapChannel(name="thermal/eccentric_bearings", contacts=(Family.ECCENTRIC_BEARINGS.value,),
                              expansion=needles, nodes=("wheels", "cranks", "needles"), reference_temperature=ref),
            ThermalGapChannel(name="thermal/crank_bearings", contacts=(Family.CRANK_BEARINGS.value,),
                              expansion=crank, nodes=("carrier", "cranks", "cranks"), reference_temperature=ref),
            ThermalGapChannel(name="thermal/main_bearings", contacts=(Family.MAIN_BEARINGS.value,),
                              expansion=main, nodes=("housing", "carrier", "carrier"), reference_temperature=ref))


def thermal_coupling(design, inputs: RvSlowInputs, *, channels=True) -> ThermalCoupling:
    """Network, declared sliding-loss sources and (channels=True) the gap channels."""
    return ThermalCoupling(network=thermal_network(design, inputs),
                           sources=SlidingLossSources(friction=friction(inputs), partition=HEAT_PARTITION),
                           channels=gap_channels(design, inputs) if channels else ())
