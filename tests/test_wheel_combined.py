"""The elastic wheel bodies combined with the other elastic members of the RV torque path (issue 30;
rvtool.assembly.rv.wheel_path): the nested closures' tangent against central differences and the all-rigid keys
bit-identical to today's model.

The members in series (compliances add, energy shares equal the switch-on shares, the stiffened views of the nested
members equal their energy shares) are checked by cases/rv/compliance_budget.py (its ``additivity_ok``,
``share_ok`` and ``sensitivity_ok``): those budgets solve several FE-reduced models at rated torque (12.3 min for
two designs on the 2-core machine), a case's work, not a unit test's.

Coarse meshes (8 mm wheels with 4 profile ports per tooth, 10 mm housing)."""
import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.model import Family
from rvtool.solver.static import StaticSolver

WHEELS = {"body": "ported", "structure": {"mesh_size": 0.008, "samples_per_tooth": 4, "layers": 1}}
GROOVE = {"groove": "conformal", "groove_clearance": 5e-6}
CRANKS = {"shaft": {"model": "simply_supported", "torsion": "elastic"}}
HOUSING = {"model": "ports", "structure": {"mesh_size": 0.010}}


@pytest.fixture(scope="module")
def rv40e():
    return rvtool.load_design(designs.path("rv40e"))


def rated_state(design):
    model = rvtool.build(design)
    model.set_output_torque(-np.sign(model.ratio) * design.rated_torque)
    return model, StaticSolver(model).solve(0.0)


def test_nested_tangent_matches_central_differences(rv40e):
    """The top closure's tangent (wheels, grooves, bending and twisting cranks, ported housing: every nested
    member) along random directions against central differences of its forces: 1e-6 relative. The element is
    piecewise smooth (a wheel's contact points interpolate linearly between its profile ports), so the step, 1e-10
    m or rad, stays far below a port spacing (measured without the housing: 1.2e-7 and 5.7e-8 at 1e-10; at 1e-8
    1.6e-4, a kink inside the step); round-off and the closures' tolerance (1e-13 of the largest contact force)
    leave ~1e-9. Without the wheels' pose derivative of their station stiffness the error was 1.3e-5.

    The state: the bodies' poses of the all-rigid model at rated torque, the housing's port coordinates at zero (a
    loaded state with every contact family active, not the all-on equilibrium, which costs ~100 s of continuation
    on the nested members and is not what a tangent check needs; measured max |Q| ~2e3 N there)."""
    d = rv40e.replace(wheels=WHEELS, pins=GROOVE, cranks=CRANKS, housing=HOUSING)
    model = rvtool.build(d)
    assert model.series_paths == {"cranks": 0, "crank_torsion": 1, "wheel_bodies": 2, "pin_grooves": 3}
    rigid, q_rigid = rated_state(rv40e)
    q = np.zeros(len(model.mbs.systemData.GetODE2Coordinates()))
    for body in rigid.body_names:
        for c in range(3):
            q[model.coordinate_index(body, c)] = q_rigid[rigid.coordinate_index(body, c)]
    el = model.elements["wheel_bodies"]
    ql = el.local(q)
    pose, vel = el.pose_velocity(ql, 0 * ql)
    ev = el.evaluator
    r = ev.evaluate(pose, vel)
    assert np.abs(r.Q).max() > 100.0      # loaded: the contacts carry the rated torque's forces
    K = r.dQdq
    # the stiffness budget's stiffened view of every nested member at factor 1 is the element's own tangent in its
    # coordinates [q_r; eta] (contracted with the housing's port map; before the contraction it was the (141, 141)
    # tangent on the port bodies' poses, read as eta's: the nested members' sensitivity shares 3x their energy
    # shares). Measured 0.0 (the same closure states); bound 1e-9, the closures' tolerance (1e-13 of the largest
    # contact force) carried through the condensation
    J = el.evaluation_at(q).dQdq
    for fam in (Family.PINS, Family.ECCENTRIC_BEARINGS):
        for member in model.series_compliance(fam):
            ltg, J1 = member.stiffened(q, 1.0)
            assert np.array_equal(ltg, el.coordinate_indices) and J1.shape == J.shape
            assert np.abs(J1 - J).max() <= 1e-9 * np.abs(J).max(), member.path
    rng = np.random.default_rng(3)
    step = 1e-10
    for _ in range(2):
        v = rng.standard_normal(pose.shape)
        v /= np.abs(v).max()
        fd = (ev.evaluate(pose + step * v, vel).Q - ev.evaluate(pose - step * v, vel).Q) / (2 * step)
        Kv = K @ v.ravel()
        assert np.abs(fd - Kv).max() <= 1e-6 * np.abs(Kv).max()


def test_rigid_keys_are_bit_identical(rv40e):
    """Every member switched off by key is today's model: the same rated state and tangent bit for bit."""
    from rvtool.protocols.stiffness import condensed_tangent
    m0, q0 = rated_state(rv40e)
    off = rv40e.replace(wheels={"body": "rigid"}, pins={"groove": "rigid"}, housing={"model": "rigid"},
                        cranks={"shaft": {"model": "rigid", "torsion": "rigid"}}, carrier={"body": "rigid"})
    m1, q1 = rated_state(off)
    assert np.array_equal(q0, q1)
    assert np.array_equal(condensed_tangent(m0, q0), condensed_tangent(m1, q1))
    assert "wheel_bodies" not in m1.elements and m1.series_paths == {}
