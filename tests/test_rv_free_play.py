"""rv40e with free play (1.5 um needle clearance, 10 um crank-gear thickness allowance): the load
continuation crosses the free play by the guide-spring homotopy, the accepted states carry no guide
force, the lost motion agrees with the spring-controlled march, and the clearance-free variant."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.rv import load_design
from rvtool.assembly.rv.free_play import free_play, without_free_play
from rvtool.errors import RvtoolInputError
from rvtool.protocols.lost_motion import lost_motion
from rvtool.protocols.stiffness import free_stiffness
from rvtool.solver.continuation import Continuation
from rvtool.solver.guide import GuideSprings, guided_newton
from rvtool.solver.static import StaticSolver


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("rv40e"))


def _springs(m):
    return [(m.mbs.GetObjectParameter(o, "stiffness"), m.mbs.GetObjectParameter(o, "offset"))
            for *_, o in m.reg_springs]


def test_zero_load_tangent_is_the_regularization_in_the_free_play(design):
    """Why the plain continuation stalls: at zero load the free stiffness's three smallest eigenvalues
    are the cranks' rotational regularization springs, 0.1 N m/rad (the crank rotations have no contact
    stiffness inside backlash plus needle clearance), against ~1e10 at the top; a full Newton step to
    6.18 N m (1.5 % of rated) then turns a crank by far more than a radian (measured 12-300 rad)."""
    m = build(design)
    cont = Continuation(m)
    K, free, _ = free_stiffness(m, cont.q)
    w, v = np.linalg.eigh(0.5 * (K + K.T))
    names = [f"{b}.{c}" for b in m.body_names for c in ("x", "y", "theta")]
    lowest = {names[free[int(np.argmax(np.abs(v[:, k])))]] for k in range(3)}
    assert lowest == {"crank0.theta", "crank1.theta", "crank2.theta"}
    assert np.allclose(w[:3], 0.1, rtol=1e-3)          # the regularization alone (k_rot = 0.1 N m/rad)
    m.set_output_torque(0.015 * design.rated_torque)
    ok, q = cont.static.newton(cont.q)
    assert not ok or np.max(np.abs(q - cont.q)) > 1.0


def test_continuation_through_free_play_matches_the_spring_march(design):
    """+-3 % lost motion by the load continuation (guided across the free play from zero load) and by
    the spring-controlled march from a loaded start: the same frictionless equilibria, so they agree to
    the Newton tolerance (measured 2e-12 arcmin; tolerance 1e-8 arcmin). The guides are released: the
    accepted states carry only the regularization springs, whose force stays below 1e-3 N (measured
    6.9e-4 N), and every spring parameter is back to its build value."""
    m = build(design)
    before = _springs(m)
    cont = Continuation(m)
    t = 0.03 * design.rated_torque
    qp = cont.go_to(t).copy()
    qm = cont.go_to(-t).copy()
    assert cont.stats.guided_levels >= 1
    assert _springs(m) == before
    assert max(m.regularization_force(qp), m.regularization_force(qm)) < 1e-3
    i = m.output_index
    lm_cont = (qp[i] - qm[i]) / np.radians(1 / 60)
    sm = lost_motion(build(design), torque_level=t)
    lm_sm = sm["lost_motion_rad"] / np.radians(1 / 60)
    assert abs(lm_cont - lm_sm) < 1e-8
    # the free play is visible: more than the zero-play model's elastic +-3 % (0.047 arcmin)
    assert lm_cont > 0.2


def test_guide_springs_restore_and_zero_load_static_point(design):
    """The static solver's last fallback: the guided homotopy from the kinematic state reaches the
    zero-load point at 1.3 rad (the stiffening ladder and the load ramps fail there, measured); the
    guide context restores every spring exactly."""
    m = build(design)
    before = _springs(m)
    with GuideSprings(m, np.zeros(m.mbs.systemData.ODE2Size())) as g:
        g.apply(1e3)
        assert _springs(m) != before
    assert _springs(m) == before
    s = StaticSolver(m)
    q = s.solve(1.3)
    assert s.stats.guided_levels == 1 and s.plausible(q, 1.3)
    assert m.regularization_force(q) < 1e-3
    ok, q2, rep = guided_newton(m, lambda q0: s.newton(q0), q)
    assert ok and rep["factors"][-1] == 0.0 and np.max(np.abs(q2 - q)) < 1e-9


def test_without_free_play(design):
    fp = free_play(design)
    assert fp["eccentric_bearing.radial_clearance"] == 1.5e-6 and fp["crank_gear.thickness_allowance"] == 10e-6
    z = without_free_play(design)
    assert set(free_play(z).values()) == {0.0}
    assert z.crank_bearing == design.crank_bearing and z.pins == design.pins
    with pytest.raises(RvtoolInputError, match="RVDesign"):
        free_play(object())
