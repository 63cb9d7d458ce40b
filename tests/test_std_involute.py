"""The small-tooth-difference involute reducer (issue 15, Deliver 3): design loading and its
named errors, the derived ratio, conjugate assembly of the wheels in the ring, torque balance
at the rated state, and the GearMesh tooth phase it relies on."""
import math
import tomllib

import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design
from rvtool.assembly.std_involute import StdInvoluteModel
from rvtool.assembly.std_spec import StdInvoluteDesign, design_from_dict
from rvtool.contact.involute_set import GearMesh, InvoluteContactSet
from rvtool.errors import RvtoolInputError
from rvtool.geometry.involute import InvoluteGear, InvolutePair, line_gap
from rvtool.model import Family
from rvtool.solver.static import StaticSolver
from warp_contacts import involute_pairs_ref as ref


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("std_involute"))


@pytest.fixture(scope="module")
def model(design):
    return build(design)


def raw_design():
    with open(designs.path("std_involute"), "rb") as fh:
        d = tomllib.load(fh)
    d.pop("topology")
    return d


def test_design_loads_by_topology_key_and_ratio_is_derived(design, model):
    assert isinstance(design, StdInvoluteDesign) and isinstance(model, StdInvoluteModel)
    z_w, z_r = design.wheel.n_teeth, design.ring.n_teeth
    assert model.ratio == -z_w / (z_r - z_w) == -39.0
    assert model.main_mesh == Family.INVOLUTE_STAGE and model.mesh_period == pytest.approx(2 * np.pi / z_r)
    assert set(model.families) == {Family.INVOLUTE_STAGE, Family.OUTPUT_PINS, Family.ECCENTRIC_BEARINGS,
                                   Family.MAIN_BEARINGS, Family.INPUT_BEARINGS}
    # the eccentricity is the pair's centre distance; the pair passed its interference checks on load
    assert design.pair.a == design.wheels.eccentricity


def test_kinematics_velocities_and_output(model):
    a, w, h = 0.7, 150.0, 1e-6
    ks = model.kinematic_state(a, w)
    dp = (model.kinematic_state(a + h).poses - model.kinematic_state(a - h).poses) / (2 * h)
    np.testing.assert_allclose(ks.velocities, dp * w, rtol=1e-7, atol=1e-9)
    assert model.kinematic_output(a) == pytest.approx(a / model.ratio, rel=1e-14)


def test_wheels_assemble_conjugate_with_backlash_on_the_coast_flanks(design, model):
    """At the kinematic poses the drive flanks (line 0) of every wheel touch with zero gap (conjugate
    action holds at any input angle) and the coast flanks (line 1) open by the design's backlash."""
    backlash, _ = line_gap(design.pair, 0.0, design.pair.mesh_phase(0), 1)
    gs = model.gear_set
    for a in (0.0, 0.37, 2.9, 11.0):
        ks = model.kinematic_state(a)
        obs = gs.evaluate(ks.poses, np.zeros_like(ks.poses)).obs
        for k in range(design.n_wheels):
            for line, expected in ((0, 0.0), (1, backlash)):
                rows = [i for i, c in enumerate(gs.ids) if c.startswith(f"wheel{k}/line{line}/")]
                # 1e-12 m: round-off of the flank positions at radii of 5e-2 m
                assert np.min(obs[rows, ref.O_GAP]) == pytest.approx(expected, abs=1e-12)


def test_torque_balance_and_contact_driven_ratio(design, model):
    """Rated state: the moment of the mesh forces on the ring (the housing) carries input and output
    torque, M_ring = T_in + T_out (statics of the whole reducer; exact up to the weak regularization), and the input torque is -T_out / i (frictionless gearing, to the
    1e-3 that off-line-of-action contact of deflected teeth moves the lever arms); over one period of
    the mechanism the equilibrium output rotation gives the ratio (lumped bearings: the same state)."""
    T = design.rated_torque
    model.set_output_torque(-np.sign(model.ratio) * T)
    solver = StaticSolver(model)
    q = solver.solve(0.0)
    ob = model.observe(q, Family.INVOLUTE_STAGE)
    obs = model.elements["gears"].evaluation_at(q).obs
    n = ob.normal
    f_on_wheel = -ob.normal_force[:, None] * n + obs[:, ref.O_FT][:, None] * np.column_stack([-n[:, 1], n[:, 0]])
    p = ob.position
    ring_moment = float(np.sum(p[:, 0] * -f_on_wheel[:, 1] - p[:, 1] * -f_on_wheel[:, 0]))   # -f acts on the ring
    i_shaft = model.input_index
    contact_torque_on_shaft = sum(el.evaluation_at(q).Q[list(el.coordinate_indices).index(i_shaft)]
                                  for el in model.contact_elements() if i_shaft in list(el.coordinate_indices))
    t_in = -contact_torque_on_shaft
    t_out = -np.sign(model.ratio) * T
    # 1e-3 N m: the regularization springs carry <= 1e-3 N m at this state (reported by the model)
    assert ring_moment == pytest.approx(t_in + t_out, abs=1e-3)
    assert t_in == pytest.approx(-t_out / model.ratio, rel=5e-3)
    # contact-driven ratio over one period of the mechanism (shaft, tooth phase and pin pattern repeat)
    z_w = design.wheel.n_teeth
    a_period = 2 * np.pi * z_w / math.gcd(z_w, design.tooth_difference)
    th0 = q[model.output_index]
    th1 = StaticSolver(model).solve(a_period)[model.output_index]
    assert a_period / (th1 - th0) == pytest.approx(model.ratio, rel=1e-9)


def test_multi_tooth_contact_grows_with_load(design, model):
    solver = StaticSolver(model)
    counts = []
    for frac in (0.1, 1.0):
        model.set_output_torque(-np.sign(model.ratio) * frac * design.rated_torque)
        f = model.observe(solver.solve(0.0), Family.INVOLUTE_STAGE).per_member()["wheel0"]
        counts.append(int(np.sum(f > 0.005 * f.sum())))
    # the ISO contact ratio is 1.49; deflection brings teeth beyond the path of contact in
    assert counts[0] >= 2 and counts[1] > counts[0]


@pytest.mark.parametrize("edit, match", [
    (lambda d: d["ring"].update(n_teeth=83), r"ring.n_teeth - wheel.n_teeth = 83 - 78 = 5 is outside the valid range \[1, 4\]"),
    (lambda d: d["wheels"].update(eccentricity=0.0016), r"trochoid \(tip\) interference.*wheels.eccentricity = 0.0016"),
    (lambda d: d["ring"].update(profile_shift=0.0), r"interference.*ring"),
    (lambda d: [d["wheel"].update(thickness_allowance=-20e-6), d["ring"].update(thickness_allowance=-20e-6)],
     # overlapping flanks: the tip corners penetrate first (the backlash check is the guard behind it)
     r"(trochoid \(tip\) interference|negative backlash).*wheels.eccentricity = 0.00165"),
    (lambda d: d["wheel"].update(face_width=0.01), r"wheel.face_width is set by the design"),
    (lambda d: d["wheel"].update(module=float("nan")), r"wheel.module"),
    (lambda d: d["wheel"].update(module=-1e-3), r"wheel.module"),
    (lambda d: d["wheel"].update(n_teeth=78.5), r"wheel.n_teeth = 78.5"),
    (lambda d: d["ring"].update(internal=False), r"ring.internal is set by the design"),
    (lambda d: d["output_pins"].update(hole_radius=0.0050), r"output_pins.hole_radius = 0.005 m cannot pass"),
    (lambda d: [d["housing"].update(model="ports"), d["housing"]["structure"].update(inner_radius=0.05)],
         r"housing.structure.inner_radius = 0.05 m cuts through"),
    (lambda d: d["mesh"].update(n_slices=0), r"mesh.n_slices = 0"),
    (lambda d: d["mesh"].update(tilt=0.1), r"\[mesh\] has unknown keys \['tilt'\]"),
    (lambda d: d["wheels"].update(eccentricity=-1e-3), r"wheels.eccentricity"),
])
def test_bad_inputs_name_the_design_key(edit, match):
    d = raw_design()
    edit(d)
    with pytest.raises(RvtoolInputError, match=match):
        design_from_dict(d)


def test_unknown_topology_is_named(tmp_path):
    p = tmp_path / "x.toml"
    p.write_text('topology = "rv"\n')
    with pytest.raises(RvtoolInputError, match=r"topology = 'rv' is not a known topology; valid choices are"):
        load_design(str(p))


def test_gear_mesh_phase_equals_turning_the_body():
    """A tooth phase turns the tooth pattern against the body frame: the forces equal those of the
    body turned by the phase, also when the phase spans whole pitches with pitch deviations (the
    teeth are renumbered so each keeps its deviation)."""
    z = 16
    rng = np.random.default_rng(3)
    f = rng.normal(0, 3e-6, z)
    f -= f.mean()
    A = InvoluteGear(module=4.5e-3, n_teeth=z, face_width=14e-3, profile_shift=0.1817, tip_diameter=82.46e-3,
                     single_pitch_deviations=tuple(f), name="gear_a")
    B = InvoluteGear(module=4.5e-3, n_teeth=24, face_width=14e-3, profile_shift=0.1715, tip_diameter=118.36e-3,
                     name="gear_b")
    pair = InvolutePair(gear_a=A, gear_b=B, centre_distance=91.5e-3)
    phase = 3 * 2 * np.pi / z + 0.013
    sets = [InvoluteContactSet([GearMesh(pair=pair, body_a=0, body_b=1, phase_a=ph)], 2, backend="numpy")
            for ph in (phase, 0.0)]
    th_b = pair.mesh_phase(0) - 2e-4
    for th in (0.0, 0.05, 0.21):
        pose = np.array([[0.0, 0.0, th], [pair.a, 0.0, th_b + pair.ratio * (th + phase)]])
        turned = pose.copy()
        turned[0, 2] += phase
        Q1 = sets[0].evaluate(pose, np.zeros((2, 3))).Q
        Q0 = sets[1].evaluate(turned, np.zeros((2, 3))).Q
        assert np.max(np.abs(Q0)) > 1.0
        # 1e-9 relative: the phase enters the kernel as a tooth angle instead of a body angle (round-off)
        np.testing.assert_allclose(Q1, Q0, rtol=0, atol=1e-9 * np.max(np.abs(Q0)))


def test_ported_housing_turns_the_ring_and_the_output_by_the_kinematic_factor(design, model):
    """housing.model = "ports": the ring gear moves with the rigid fit of the bore ports of the elastic
    housing. With the input held, a ring turned by theta_r turns the output by theta_r (1 - 1/i)
    (kinematics in the ring's frame), so the extra output angle over the rigid housing at rated
    torque equals that of the ring's torsion; to 1e-3 (measured 2e-5: the ring's micrometre
    translation and the stiffening of the tooth contacts are the difference). A coarse housing
    mesh (8 mm) keeps the reduction at ~20 s."""
    from rvtool.solver.continuation import Continuation
    T = design.rated_torque
    ported = build(design.replace(housing={"model": "ports", "structure": {"mesh_size": 0.008}}))
    assert "housing" in ported.structures
    th = {}
    for name, m in (("rigid", model), ("ports", ported)):
        q = Continuation(m).go_to(-np.sign(m.ratio) * T)
        th[name] = q[m.output_index]
    el = ported.elements["gears"]
    ql = el.local(q)
    ring = el.pose_velocity(ql, np.zeros_like(ql))[0][-1]
    assert abs(ring[0]) < 1e-6 and abs(ring[1]) < 1e-6 and ring[2] > 0
    assert th["ports"] - th["rigid"] == pytest.approx(ring[2] * (1 - 1 / ported.ratio), rel=1e-3)


def test_single_wheel_variant(design):
    """One wheel (the topology takes one or two): it assembles conjugate, carries the rated torque
    alone, and its unbalanced radial mesh force reaches the main and input bearings."""
    from rvtool.solver.continuation import Continuation
    # one wheel of twice the width (as RD-40's single-wheel variant; the wheel's face width follows)
    one = design.replace(n_wheels=1, wheels={"midplanes": (0.0,), "phases_deg": (0.0,), "width": 0.016},
                         eccentric_bearing={"roller_length": 0.016})
    assert one.wheel.face_width == 0.016
    m = build(one)
    assert m.body_names == ("shaft", "wheel0", "flange") and m.ratio == design.ratio
    q = Continuation(m, input_angle=0.3).go_to(-np.sign(m.ratio) * one.rated_torque)
    peaks = m.family_peaks(q)
    assert peaks["main_bearings"] > 100.0 and peaks["input_bearings"] > 100.0
    forces = m.observe(q, Family.INVOLUTE_STAGE).per_member()["wheel0"]
    assert int(np.sum(forces > 0.005 * forces.sum())) >= 3
