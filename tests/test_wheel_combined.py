"""The elastic wheel bodies combined with the other elastic members of the RV torque path (issue 30;
rvtool.assembly.rv.wheel_path): the nested closures' tangent against central differences, the members in
series (each switched alone against all on: compliances add, energy shares equal the switch-on shares and sum to
one), and the stiffened views of the nested members against their energy shares.

Coarse meshes (8 mm wheels with 4 profile ports per tooth, 8 mm housing): the machine is shared; the budget case
(cases/rv/compliance_budget.py) runs the same combination at its own resolution."""
import numpy as np
import pytest

# the nested elastic wheels' budgets build several FE-reduced models of rv40e (the compliance budget case with the
# same members took 12.3 min for two designs on the shared 2-core machine): longer than setup.cfg's 600 s per
# test, which guards against hung tests, not against these
pytestmark = [pytest.mark.slow, pytest.mark.timeout(2400)]

import rvtool
from rvtool import designs
from rvtool.protocols.budget import stiffness_budget
from rvtool.solver.static import StaticSolver

WHEELS = {"body": "ported", "structure": {"mesh_size": 0.008, "samples_per_tooth": 4, "layers": 1}}
GROOVE = {"groove": "conformal", "groove_clearance": 5e-6}
CRANKS = {"shaft": {"model": "simply_supported", "torsion": "elastic"}}
HOUSING = {"model": "ports", "structure": {"mesh_size": 0.008}}
MEMBERS = {"wheels": {"wheels": WHEELS}, "pins": {"pins": GROOVE}, "cranks": {"cranks": CRANKS}}


@pytest.fixture(scope="module")
def rv40e():
    return rvtool.load_design(designs.path("rv40e"))


def rated_state(design):
    model = rvtool.build(design)
    model.set_output_torque(-np.sign(model.ratio) * design.rated_torque)
    return model, StaticSolver(model).solve(0.0)


@pytest.fixture(scope="module")
def budgets(rv40e):
    """Budgets at T_R of the all-rigid design, each member alone and all of them on."""
    out = {"rigid": stiffness_budget(*rated_state(rv40e))}
    for name, change in MEMBERS.items():
        out[name] = stiffness_budget(*rated_state(rv40e.replace(**change)))
    every = {k: v for change in MEMBERS.values() for k, v in change.items()}
    out["all"] = stiffness_budget(*rated_state(rv40e.replace(**every)))
    return out


def test_nested_tangent_matches_central_differences(rv40e):
    """The top closure's tangent (wheels, grooves, bending and twisting cranks, ported housing: every nested
    member) along random directions against central differences of its forces: 1e-6 relative. The element is
    piecewise smooth (a wheel's contact points interpolate linearly between its profile ports), so the step, 1e-10
    m or rad, stays far below a port spacing (measured without the housing: 1.2e-7 and 5.7e-8 at 1e-10; at 1e-8
    1.6e-4, a kink inside the step); round-off and the closures' tolerance (1e-13 of the largest contact force)
    leave ~1e-9. Without the wheels' pose derivative of their station stiffness the error was 1.3e-5."""
    d = rv40e.replace(wheels=WHEELS, pins=GROOVE, cranks=CRANKS, housing=HOUSING)
    model, q = rated_state(d)
    assert model.series_paths == {"cranks": 0, "crank_torsion": 1, "wheel_bodies": 2, "pin_grooves": 3}
    el = model.elements["wheel_bodies"]
    ql = el.local(q)
    pose, vel = el.pose_velocity(ql, 0 * ql)
    ev = el.evaluator
    K = ev.evaluate(pose, vel).dQdq
    rng = np.random.default_rng(3)
    step = 1e-10
    for _ in range(2):
        v = rng.standard_normal(pose.shape)
        v /= np.abs(v).max()
        fd = (ev.evaluate(pose + step * v, vel).Q - ev.evaluate(pose - step * v, vel).Q) / (2 * step)
        Kv = K @ v.ravel()
        assert np.abs(fd - Kv).max() <= 1e-6 * np.abs(Kv).max()


def test_members_in_series(budgets):
    """Each member alone adds dC_i to the all-rigid compliance; all on, the compliances add within 2 % (load
    redistribution among cranks and pins, compliance_budget's ADDITIVITY_TOL), each member's energy share in the
    all-on model equals dC_i / C_all within 0.02 (the redistribution a switch causes), and the shares sum to one
    with a residual under 1 % (geometric stiffness and regularization)."""
    C = {k: 1.0 / b["K_t_Nm_per_arcmin"] for k, b in budgets.items()}
    dC = {k: C[k] - C["rigid"] for k in MEMBERS}
    assert all(v > 0 for v in dC.values())
    assert abs(C["all"] - C["rigid"] - sum(dC.values())) <= 0.02 * C["all"]
    sh = budgets["all"]["shares"]
    assert abs(sum(sh.values()) - 1.0) < 1e-12
    assert abs(sh["geometric_and_regularization"]) < 0.01
    paths = {"wheels": ("wheel_bodies",), "pins": ("pin_grooves",), "cranks": ("cranks", "crank_torsion")}
    for member, p in paths.items():
        assert abs(sum(sh[x] for x in p) - dC[member] / C["all"]) < 0.02, member
    # each path alone carries the same energy share as in its one-member model, scaled by the compliances
    assert abs(sh["wheel_bodies"] * C["all"] - budgets["wheels"]["shares"]["wheel_bodies"] * C["wheels"]) \
        < 0.1 * sh["wheel_bodies"] * C["all"]


def test_nested_stiffened_views_agree_with_energy(budgets):
    """The infinitesimal switch of every nested member (its station stiffness times 1 +- 1e-4 inside the nesting,
    NestedSeries.stiffened) equals its energy share (Rayleigh: dC/dlambda = -u^T K_f u) within 1e-3 absolute,
    which it would not if the stiffened view missed the member or the nesting dropped a coupling."""
    b = budgets["all"]
    for path in ("cranks", "crank_torsion", "wheel_bodies", "pin_grooves"):
        assert abs(b["sensitivity_shares"][path] - b["shares"][path]) < 1e-3, path
        assert 0.0 < b["rigid_shares"][path] < 1.0, path


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
