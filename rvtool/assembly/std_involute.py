"""Builder: a :class:`~rvtool.assembly.std_spec.StdInvoluteDesign` -> a
:class:`StdInvoluteModel` (the small-tooth-difference involute reducer).

Bodies (planar rigid, x, y, theta), as in the cycloid drive (:func:`rvtool.assembly.cycloid.add_bodies`):
0 the eccentric input shaft, 1..n the external involute wheels on its journals, n+1 the
output flange. The internal ring gear is the ground (rigid housing, ``housing.model = "rigid"``) or,
with ``"ports"``, a port body that moves rigidly with the least-squares rigid motion of
``housing.structure.n_ports`` bore ports (16 in the shipped design: equally spaced ports average
the bore's translation and torsion; a rigid fit needs 2) of the elastic annular housing of
:mod:`rvtool.assembly.housing`
(the housing's translation and torsion under the tooth forces; the bore's ovalization is not
represented, the bearings stay grounded as in the cycloid drive). Contact sets, each one
Exudyn contact element with one kernel launch per evaluation:

* ``gears``: the wheel--ring meshes (:class:`~rvtool.contact.involute_set.InvoluteContactSet`,
  family :attr:`Family.INVOLUTE_STAGE`): per wheel both lines of action, a window of teeth around
  the pitch point and the face-width slices; Eq. (series_contact) with the potential-energy
  tooth compliance and Weber's line-contact approach, off-line-of-action tip-edge contact of
  teeth beyond the path of contact (the load-dependent multi-tooth contact of these drives);
* ``output_pins``: flange pins in wheel holes (the cycloid drive's mechanism,
  :class:`~rvtool.output_pins.spec.OutputPinMechanism`, the design's ``output_pins``);
* bearings: the eccentric needle bearings, the main and the input bearings, from rolling
  elements (:func:`rvtool.bearings.reducer.rolling_bearing_sets`) or lumped
  (:func:`rvtool.assembly.cycloid.lumped_bearing_contacts`).

Kinematics (fixed ring, output through the wheels' rotation): with the shaft at input angle a,
wheel k rides on the journal of phase phi_k (:mod:`rvtool.geometry.eccentric`) and turns, like
the flange, by a / i with the signed ratio i = -z_w / (z_r - z_w)
(:attr:`StdInvoluteDesign.ratio`): in the shaft's frame the ring turns by -a and the wheel,
meshing it internally, by -a z_r / z_w, so theta_w = a - a z_r / z_w.

Assembly phase: every wheel body starts at angle 0 (its output holes on the flange pins);
its teeth are turned against the body frame by :func:`wheel_tooth_phase` so that the drive
flanks (line of action 0, loaded by the protocols' resisting torque) touch with zero gap
at input angle 0 (conjugate action keeps them touching at every angle).
"""
import math
from dataclasses import dataclass

import numpy as np
import exudyn as exu
from exudyn.itemInterface import MarkerNodeCoordinate, NodePointGround


from ..contact.circle_set import GROUND, CircleContactSet, FrictionLaw, FrictionModel
from ..contact.involute_set import GearMesh, InvoluteContactSet
from ..bearings.influence import check_lumped
from ..errors import RvtoolInputError
from ..geometry.eccentric import journal_centre
from ..model import BodyCoordinate, Family, ReducerModel
from .contact_layout import ContactElements
from .cycloid import (CycloidKinematics, add_bodies, body_names, contact_families, eccentric_drive_markers,
                      lumped_bearing_contacts)
from .spec import replace
from .std_spec import StdInvoluteDesign

LOADED_LINE = 0
"""The line of action that carries the protocols' resisting output torque -sign(i) T (i < 0 for
this topology, so a positive torque on the flange): the output pins turn each wheel
counter-clockwise and the ring must turn it back, which line 0 does (its contact torque on the
wheel is eps F r_bw = -F r_bw for the internal pair, Eq. of :func:`rvtool.geometry.involute.line_geometry`)."""


class StdKinematics(CycloidKinematics):
    """Rigid, clearance-free kinematics of the small-tooth-difference drive: the eccentric-wheel
    kinematics of :class:`~rvtool.assembly.cycloid.CycloidKinematics` (one definition: shaft at a,
    wheels on the journals, wheels and flange turned by -a / z_g) with the reduction
    z_g = -i = z_w / (z_r - z_w) of this topology (not an integer in general)."""

    def __init__(self, design: StdInvoluteDesign):
        self.eccentricity = design.wheels.eccentricity
        self.phases = np.asarray(design.wheels.phases[:design.n_wheels], float)
        self.z_g = -design.ratio
        self.n_wheels = design.n_wheels


def wheel_tooth_phase(pair, centre_angle, line=LOADED_LINE):
    """Angle [rad] of wheel tooth 0 from the wheel body's x axis for a wheel whose centre lies at
    polar angle ``centre_angle`` [rad] about the ring centre (ring at angle 0), such that the
    flanks on ``line`` touch with zero gap.

    From the pair frame of :meth:`InvolutePair.mesh_phase` (wheel at the origin at angle 0, ring at
    (a, 0) at angle phi_r): moving the ring to the origin and turning everything by
    beta = centre_angle - pi puts the wheel centre at ``centre_angle``, the wheel at beta and the
    ring at phi_r + beta; turning the ring back to 0 about its fixed centre turns the wheel
    conjugately by -(phi_r + beta) z_r / z_w."""
    beta = centre_angle - math.pi
    phi_r = pair.mesh_phase(line)
    return beta - (phi_r + beta) * pair.gear_b.n_teeth / pair.gear_a.n_teeth


@dataclass
class StdInvoluteModel(ReducerModel):
    """An assembled small-tooth-difference involute reducer: the :class:`ReducerModel` plus its
    own handles (the wheel--ring gear set, the pair, the wheels' tooth phases)."""
    gear_set: InvoluteContactSet = None
    pair: object = None
    n_wheels: int = 1
    tooth_phases: tuple = ()
    housing: object = None          # ReducedStructure of an elastic housing, or None (rigid)
    #: the backlashed wheel--ring mesh leaves the wheels without contact stiffness at light load: a
    #: cold start there (a replica segment's first point) needs the guide-spring homotopy (STD-39 at
    #: 1 N m, input angle 2.258 rad: every other fallback failed)
    guided_free_play: bool = True

    @property
    def flange(self):
        return self.n_wheels + 1

    def mesh_width_moments(self, q):
        return self.gear_set.width_moments(self.elements["gears"].evaluation_at(q).obs)

    def mesh_stiffness(self, q):
        """Per wheel: the mesh stiffness along the line of action [N/m] at state q (sum of the loaded
        rows' series tangents)."""
        return self.gear_set.mesh_stiffness(self.elements["gears"].evaluation_at(q).obs)

    def refined_design(self):
        """Two more teeth on each side of the window and twice the face-width slices."""
        m = self.design.mesh
        return replace(self.design, mesh={"window": self.gear_set.meshes[0].window_teeth + 2, "n_slices": 2 * m.n_slices})

    def resolution_settings(self):
        return {"mesh_window_teeth": self.gear_set.meshes[0].window_teeth, "mesh_n_slices": self.design.mesh.n_slices}

    def marker_frequencies(self, speed_rpm):
        """Mesh and bearing marker frequencies [Hz] at input speed [rpm]: the eccentric turns the
        wheels' mesh point once round the fixed ring per input revolution, so z_ring teeth mesh per
        revolution (:func:`rvtool.assembly.cycloid.eccentric_drive_markers`)."""
        return eccentric_drive_markers(self.design, speed_rpm, self.design.ring.n_teeth)

    def draw_section(self, ax, q):
        """Tip and root circles of the wheels (at their state-q centres) and of the ring, and the
        contact forces."""
        t = np.linspace(0, 2 * np.pi, 721)
        ring = self.design.ring
        for r, label in ((ring.tip_radius, "ring, tip and root circles"), (ring.root_radius, None)):
            ax.plot(r * np.cos(t), r * np.sin(t), "k", lw=0.6, label=label)
        wheel = self.design.wheel
        for k in range(self.n_wheels):      # one colour per wheel for both of its circles
            c = self.reference[1 + k, :2] + q[[self.coordinate_index(1 + k, i) for i in range(2)]]
            for r, label in ((wheel.tip_radius, f"wheel {k}, tip and root circles"), (wheel.root_radius, None)):
                ax.plot(c[0] + r * np.cos(t), c[1] + r * np.sin(t), color=f"C{k}", lw=0.6, label=label)
        super().draw_section(ax, q)


def wheel_mass(design):
    """(mass [kg], polar inertia [kg m^2]) of one wheel: a steel annulus from the bore to the root circle."""
    d = design
    r_o, r_i = d.wheel.root_radius, d.wheel.bore_radius
    m = np.pi * (r_o ** 2 - r_i ** 2) * d.wheels.width * d.material.density
    return m, 0.5 * m * (r_o ** 2 + r_i ** 2)


def gear_meshes(design, *, offset=0, prefix="", ring=GROUND):
    """(:class:`GearMesh` per wheel, tooth phases [rad]) of one reducer whose bodies start at index
    ``offset`` (wheel k is body offset + 1 + k; the ring is body ``ring``, default ground); names
    ``prefix + "wheel{k}"``."""
    d = design
    ms = d.mesh
    friction = FrictionLaw(model=FrictionModel.REGULARIZED if ms.mu > 0 else FrictionModel.NONE, mu_kinetic=ms.mu)
    meshes, phases = [], []
    for k in range(d.n_wheels):
        c = journal_centre(d.wheels.eccentricity, d.wheels.phases[k])
        phase = wheel_tooth_phase(d.pair, math.atan2(c[1], c[0]))
        phases.append(phase)
        meshes.append(GearMesh(pair=d.pair, body_a=offset + 1 + k, body_b=ring, n_slices=ms.n_slices, window=ms.window,
                               clearance=ms.clearance, gear_z=d.wheels.midplanes[k], damping=ms.damping,
                               ramp_depth=ms.ramp_depth, friction=friction, phase_a=phase, name=f"{prefix}wheel{k}"))
    return meshes, tuple(phases)


def build(design: StdInvoluteDesign, *, bearing_model="lumped", backend="warp", precision="float64", device="cpu",
          regularization=(100.0, 0.1), contact_element=None):
    """Assemble ``design`` into an Exudyn system; returns a :class:`StdInvoluteModel`.

    bearing_model: "lumped" (one internal circle contact per bearing) or "rolling" (rolling
    elements). regularization: (k_translation [N/m], k_rotation [N m/rad]) of the weak springs
    from every free coordinate to its kinematic position (as :func:`rvtool.assembly.cycloid.build`).
    contact_element: ``"merged"`` (every family in one Exudyn element) or ``"per_family"`` (one
    element per family); None reads ``RVTOOL_CONTACT_ELEMENT`` (default ``"merged"``;
    :mod:`rvtool.assembly.contact_layout`).
    """
    if not isinstance(design, StdInvoluteDesign):
        raise RvtoolInputError(f"design must be a StdInvoluteDesign; got {type(design).__name__}")
    if bearing_model not in ("lumped", "rolling"):
        raise RvtoolInputError(f"bearing_model = {bearing_model!r}; valid choices are ['lumped', 'rolling']")
    check_lumped(design, bearing_model)
    for key in ("flange_coordinates", "wheel_coordinates"):
        if getattr(design.bodies, key) != "planar":
            # issue 32: the involute wheel--ring meshes and the STD bearing sets are not sliced with tilts
            raise RvtoolInputError(f"bodies.{key} = {getattr(design.bodies, key)!r} is not implemented for the "
                                   "small-tooth-difference topology (its meshes and bearings take planar bodies); "
                                   "valid: 'planar'")
    d = design
    nw = d.n_wheels
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    bodies = add_bodies(mbs, d, mg, regularization=regularization, wheel_mass=wheel_mass(d))
    nodes = bodies["nodes"]

    housing, ports, ring = None, None, GROUND
    if d.housing.model == "ports":
        from exudyn_user_elements.contact_element import PortBodies
        from exudyn_user_elements.reduced_structure import ReducedStructure
        from .housing import annulus_ports, pin_port_angles
        n_ports = d.housing.structure.n_ports
        reduced, _, _ = annulus_ports(d.housing, n_ports)
        housing = ReducedStructure(mbs, reduced, name="housing")
        ports = PortBodies.rigid_fit(housing, np.array([reduced.port_rows[k][:2] for k in range(n_ports)]),
                                     pin_port_angles(n_ports), d.housing.structure.inner_radius)
        ring = nw + 2
    meshes, phases = gear_meshes(d, ring=ring)
    gear_set = InvoluteContactSet(meshes, nw + 2 + (ports is not None), backend=backend, precision=precision,
                                  device=device, name="gears")
    element = ContactElements(mbs, nodes, contact_element, structure=housing)
    elements = {"gears": element(gear_set, ports=ports)}

    from ..output_pins.evaluator import OutputPinEvaluator
    op_eval = OutputPinEvaluator(d.output_pins, name="output_pins", flange=nw + 1,
                                 wheels=tuple(range(1, nw + 1)), n_bodies=nw + 2, backend=backend,
                                 precision=precision, device=device)
    elements["output_pins"] = element(op_eval)

    if bearing_model == "rolling":
        from ..bearings.reducer import rolling_bearing_sets
        for name, ev in rolling_bearing_sets(d, nw, backend=backend, precision=precision, device=device).items():
            elements[name] = element(ev)
    else:
        bset = CircleContactSet(name="bearings", n_bodies=nw + 2, contacts=tuple(lumped_bearing_contacts(d)))
        elements["bearings"] = element(bset, backend=backend, precision=precision, device=device)
    mbs.Assemble()
    return StdInvoluteModel(design=d, SC=SC, mbs=mbs, body_names=body_names(nw), nodes=nodes, elements=elements,
                            families=contact_families(elements, mesh=("gears", Family.INVOLUTE_STAGE)), input=BodyCoordinate("shaft", "theta"),
                            output=BodyCoordinate("flange", "theta"), ratio=d.ratio, kinematics=StdKinematics(d),
                            drive=bodies["drive"], load=bodies["load"], reference=bodies["reference"],
                            locks=bodies["locks"], reg_springs=bodies["reg_springs"],
                            journal_locks=bodies["journal_locks"], main_mesh=Family.INVOLUTE_STAGE,
                            continuation_restarts=True, material=d.material,
                            family_specs={fam: spec for fam, spec in (
                                (Family.OUTPUT_PINS, d.output_pins), (Family.ECCENTRIC_BEARINGS, d.eccentric_bearing),
                                (Family.MAIN_BEARINGS, d.main_bearing), (Family.INPUT_BEARINGS, d.input_bearing))
                                if spec is not None},
                            mesh_period=2 * np.pi / d.ring.n_teeth, gear_set=gear_set, pair=d.pair, n_wheels=nw,
                            tooth_phases=phases, structures={} if housing is None else {"housing": housing},
                            housing=housing, contact_host=element.host)
