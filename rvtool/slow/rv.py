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
  the line of action (cos of the free contact angle: the ball law's clearance acts along it);
* ``thermal/involute_stage/<mesh>`` (with the model, :func:`gap_channels`): each involute mesh's
  gap change along its line of action (:class:`~rvtool.slow.thermal.InvoluteMeshExpansion`: the
  centre distance held by the carrier for the sun--crank-gear meshes, by the housing for the
  three-stage input stage, minus the two gears' growth), written on gear A's tooth flanks (a
  pair's gap takes the offsets of both of its flanks; the pair's change is put on one of them).

The bearing channels are radial expansion only (declared): the axial expansion of a crank or of
the carrier against the housing, which changes the tapered and angular-contact preloads, has no
coordinate in the planar model. The involute stage (issue 18) enters where the model is given
(:func:`contact_bodies`, :func:`thermal_coupling`): its tooth flanks are window contacts
(:func:`rvtool.slow.reducer_windows.involute_stage_bodies`), their sliding loss mu_involute I_s /
tau_w is a heat source shared equally by the two gears' nodes (the sun and the three-stage
pinion and compound gear on ``input``, the crank gears on ``cranks``), and the meshes get the
flank channels above. Without the model the declaration is the one before issue 18 (no involute
heat, no flank offsets).
Every number of :class:`RvSlowInputs` is chosen here (the design gives none); the cases report them.
"""
import math
from dataclasses import dataclass

from ..errors import RvtoolInputError
from ..model import Family
from ..validation import check_nonnegative, check_positive, check_range
from .orchestrator import ThermalCoupling
from .reducer_windows import ContactBodies, involute_stage_bodies
from .thermal import (BearingClearanceExpansion, CycloidEnvelopeExpansion, InvoluteMeshExpansion, SlidingLossSources,
                      ThermalGapChannel, ThermalNetwork)

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
    the declared sliding-loss coefficient of the cycloid--pin contacts [-] (heat sources);
    mu_involute: that of the involute tooth flanks [-] (a lubricated spur mesh, chosen).
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
    mu_involute: float = 0.05

    def __post_init__(self):
        for name in ("specific_heat", "housing_outer_radius", "housing_height", "expansion"):
            check_positive(name, getattr(self, name))
        for name in ("housing_film", "housing_mount", "carrier_ambient", "input_ambient", "mu_pins", "mu_involute"):
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
            Family.CRANK_BEARINGS.value: 0.0, Family.MAIN_BEARINGS.value: 0.0,
            Family.INVOLUTE_STAGE.value: inputs.mu_involute}


HEAT_PARTITION = {Family.PINS.value: {"pins": 0.5, "wheels": 0.5},
                  Family.ECCENTRIC_BEARINGS.value: {"needles": 1.0},
                  Family.CRANK_BEARINGS.value: {"cranks": 0.5, "carrier": 0.5},
                  Family.MAIN_BEARINGS.value: {"carrier": 0.5, "housing": 0.5}}
"""Declared heat partition: the sliding loss of a contact shared equally by the two bodies."""


def contact_bodies(model=None) -> dict:
    """The RV's window declaration (:mod:`rvtool.assembly.rv.builder` contact ids): a pin contact
    ``wheel<k>/pin<j>`` joins wheel k and the housing (pins fixed in it); the bearings roll; with
    ``model`` (an RV ReducerModel) the tooth flanks of its involute meshes join the meshes' bodies
    (:func:`~rvtool.slow.reducer_windows.involute_stage_bodies`)."""
    out = {Family.PINS: ContactBodies(body_a=lambda c: c.split("/")[0], body_b=None),
           Family.ECCENTRIC_BEARINGS: ContactBodies(rolling=True),
           Family.CRANK_BEARINGS: ContactBodies(rolling=True),
           Family.MAIN_BEARINGS: ContactBodies(rolling=True)}
    if model is not None:
        out[Family.INVOLUTE_STAGE] = involute_stage_bodies(model)
    return out


def body_node(body: str) -> str:
    """Thermal node of an RV body (:attr:`ReducerModel.body_names`): the input-side gears (``sun``,
    the three-stage ``pinion``) on ``input``, ``crank<k>`` on ``cranks``, ``wheel<k>`` on ``wheels``."""
    if body in ("sun", "pinion"):
        return "input"
    for prefix, node in (("crank", "cranks"), ("wheel", "wheels")):
        if body.startswith(prefix):
            return node
    if body in NODES:
        return body
    raise RvtoolInputError(f"body {body!r} has no thermal node; valid: sun, pinion, crank<k>, wheel<k>, {NODES}")


def involute_meshes(model) -> tuple:
    """Per involute mesh of ``model``: (name, pair, node of gear A, node of gear B, frame node holding
    the centre distance: the carrier for a mesh with a crank gear, else the housing)."""
    names = model.body_names
    out = []
    for m in model.family_element(Family.INVOLUTE_STAGE).evaluator.meshes:
        a, b = body_node(names[m.body_a]), body_node(names[m.body_b])
        out.append((m.name, m.pair, a, b, "carrier" if "cranks" in (a, b) else "housing"))
    return tuple(out)


def heat_partition(model=None) -> dict:
    """:data:`HEAT_PARTITION` and, with ``model``, each involute mesh's flanks
    (``involute_stage/<mesh>``) shared equally by its two gears' nodes."""
    out = dict(HEAT_PARTITION)
    if model is not None:
        for name, _, a, b, _ in involute_meshes(model):
            share = {a: 0.5}
            share[b] = share.get(b, 0.0) + 0.5
            out[f"{Family.INVOLUTE_STAGE.value}/{name}"] = share
    return out


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


def gap_channels(design, inputs: RvSlowInputs, model=None) -> tuple:
    """The thermal gap channels of the module docstring, reference = ambient: the four of the pins
    and bearings, and with ``model`` one per involute mesh."""
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
    crank = ProjectedExpansion(radial(tp.pitch_diameter, tp.roller_diameter), math.cos(tp.cup_angle))
    main = ProjectedExpansion(radial(mb.pitch_diameter, mb.ball_diameter), math.cos(mb.contact_angle))
    ref = (T_AMBIENT,) * 3
    gears = ()
    if model is not None:
        gears = tuple(ThermalGapChannel(
            name=f"thermal/{Family.INVOLUTE_STAGE.value}/{name}",
            contacts=(f"{Family.INVOLUTE_STAGE.value}/{name}/gear_a",), expansion=mesh_expansion(pair, a),
            nodes=(frame, na, nb), reference_temperature=ref) for name, pair, na, nb, frame in involute_meshes(model))
    return (ThermalGapChannel(name="thermal/pins", contacts=(Family.PINS.value,), expansion=env,
                              nodes=("housing", "pins", "wheels"), reference_temperature=ref),
            ThermalGapChannel(name="thermal/eccentric_bearings", contacts=(Family.ECCENTRIC_BEARINGS.value,),
                              expansion=needles, nodes=("wheels", "cranks", "needles"), reference_temperature=ref),
            ThermalGapChannel(name="thermal/crank_bearings", contacts=(Family.CRANK_BEARINGS.value,),
                              expansion=crank, nodes=("carrier", "cranks", "cranks"), reference_temperature=ref),
            ThermalGapChannel(name="thermal/main_bearings", contacts=(Family.MAIN_BEARINGS.value,),
                              expansion=main, nodes=("housing", "carrier", "carrier"),
                              reference_temperature=ref)) + gears


def mesh_expansion(pair, expansion: float) -> InvoluteMeshExpansion:
    """The :class:`~rvtool.slow.thermal.InvoluteMeshExpansion` of an external involute pair, all parts
    at the one steel ``expansion`` [1/K]."""
    r_a, r_b = pair.working_pitch_radii
    return InvoluteMeshExpansion(centre_distance=pair.a, working_pitch_radius_a=r_a, working_pitch_radius_b=r_b,
                                 working_pressure_angle=pair.working_pressure_angle, frame_expansion=expansion,
                                 gear_a_expansion=expansion, gear_b_expansion=expansion)


def thermal_coupling(design, inputs: RvSlowInputs, *, channels=True, model=None) -> ThermalCoupling:
    """Network, declared sliding-loss sources and (channels=True) the gap channels; with ``model``
    (the RV ReducerModel of ``design``) the involute stage's heat partition and flank channels."""
    return ThermalCoupling(network=thermal_network(design, inputs),
                           sources=SlidingLossSources(friction=friction(inputs), partition=heat_partition(model)),
                           channels=gap_channels(design, inputs, model) if channels else ())
