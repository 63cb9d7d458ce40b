"""Bearing friction on the RV (issue 17): ``[bearing_friction]`` wires Palmgren's moment
(rvtool.bearings.friction_element.rolling_friction_evaluator) onto the tapered crank pairs and the
main bearing pair of the RV builder; off by default (no element, the quasi-static figures
unchanged); the moment at the committed element loads and the kinematic relative speeds; the
static equilibrium unchanged by a speed-law loss; named input errors."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.rv import build, load_design
from rvtool.bearings.friction_torque import palmgren_torque
from rvtool.errors import RvtoolInputError
from rvtool.solver.static import StaticSolver
from warp_contacts import circle_pairs_ref as cref

NAMES = ("crank_bearing_friction", "main_bearing_friction")


@pytest.fixture(scope="module")
def rv40e():
    return load_design(designs.path("rv40e"))


def _rated(model, torque):
    s = StaticSolver(model)
    model.set_output_torque(-np.sign(model.ratio) * torque)
    q = s.solve(0.0)
    model.commit_contacts(q)
    return q


def test_switched_off_by_default(rv40e):
    assert rv40e.bearing_friction.model == "none"
    m = build(rv40e)
    assert not any("friction" in name for name in m.elements)


def test_palmgren_moment_on_crank_and_main_bearings(rv40e):
    """At the rated state (committed: the loads are that state's element resultants) and the kinematic
    velocities at 1500 rpm, each row's |F_t| r is Palmgren's M(|omega|, P1) of its bearing
    (1e-9 relative: the same closed form, evaluated twice), with omega the crank's rotation relative
    to the carrier (tapered pairs) and the carrier's absolute rotation (main bearing). The static
    state is that of the model without friction (a speed-law loss is zero at rest; 1e-12 rad: the
    two Newton solves' tolerance)."""
    d = rv40e.replace(bearing_friction={"model": "palmgren"})
    m = build(d)
    assert all(name in m.elements for name in NAMES)
    q = _rated(m, d.rated_torque)
    q0 = _rated(build(rv40e), d.rated_torque)
    assert abs(q[m.output_index] - q0[m.output_index]) < 1e-12
    omega_in = d.input_speed_rpm * np.pi / 30
    v = m.body_vector(m.kinematic_state(0.0, omega_in).velocities)
    vel = m.kinematic_state(0.0, omega_in).velocities
    carrier = m.body_names.index("carrier")
    want_omega = {"crank_bearing_friction": [vel[m.body_names.index(f"crank{k}"), 2] - vel[carrier, 2]
                                             for k in range(d.cranks.count)],
                  "main_bearing_friction": [vel[carrier, 2]]}
    for name in NAMES:
        el = m.elements[name]
        ev = el.evaluator
        assert len(ev.bearings) == len(want_omega[name])
        e = el.evaluate(0.0, el.local(q), el.local(v))
        assert np.all(ev.history.load > 0)
        for k, b in enumerate(ev.bearings):
            r = 0.5 * b.model.pitch_diameter
            w = e.obs[k, cref.O_VT] / r
            assert w == pytest.approx(want_omega[name][k], rel=1e-12)
            M = palmgren_torque(b.model, abs(w), ev.history.load[k])[0]
            assert abs(e.obs[k, cref.O_FT]) * r == pytest.approx(M, rel=1e-9)
    # the crank pairs' load: the radial resultant of each pair's accepted element forces
    res = m.elements["crank_bearings"].evaluator.resultants(el_pose(m, q, "crank_bearings"))
    got = m.elements["crank_bearing_friction"].evaluator.history.load
    want = [np.linalg.norm(res[f"crank_bearing{k}"].force) for k in range(d.cranks.count)]
    np.testing.assert_allclose(got, want, rtol=1e-12)


def el_pose(model, q, name):
    """Body poses (n_bodies, 3) of element ``name`` at q."""
    el = model.elements[name]
    ql = el.local(q)
    return el.pose_velocity(ql, np.zeros_like(ql))[0]


def test_bad_bearing_friction_is_named(rv40e):
    with pytest.raises(RvtoolInputError, match="bearing_friction.model"):
        rv40e.replace(bearing_friction={"model": "skf"})
    with pytest.raises(RvtoolInputError, match="bearing_friction.f0_tapered"):
        rv40e.replace(bearing_friction={"model": "palmgren", "f0_tapered": -1.0})
