"""Nested series closures solved as one network (rvtool.contact.pin_closure.JointNetwork, ``joint=True``) against
the same closures solved level by level (each inner closure to convergence at every iterate of the one outside it):
same forces, same condensed tangent, same stiffened views, fewer contact evaluations.

The tiny model: one output pin in the holes of two wheels (tests/test_pin_closure.py's closed-form fixture) on a
three-level chain: the pin's beam stations (linear, the pin closure), each carried by a station of a groove-like
nonlinear support (Persson's conformal law, rvtool.contact.groove), carried by a linear flange station."""
import numpy as np
import pytest

from rvtool.contact.groove import GrooveLaw, GrooveSupport
from rvtool.contact.pin_closure import ElasticPinClosure
from rvtool.output_pins.evaluator import OutputPinEvaluator
from rvtool.output_pins.spec import OutputPinMechanism, PinMode

R, R_PIN, R_HOLE = 0.05, 0.004, 0.00401       # pin circle, pin and hole radius [m]
C_PIN = np.array([[2.0e-9, 1.2e-9], [1.2e-9, 3.0e-9]])   # the pin beam's station compliance [m/N], SPD
C_FLANGE = np.array([[1.5e-9]])                           # the flange station [m/N]
LAW = GrooveLaw(clearance=5e-6, length=0.01, contact_modulus=1.1e11)


def chain(joint):
    """Bodies 0 flange, 1-2 wheels; 3 the flange station (level 0); 4-5 the support stations of the two wheel
    stations (level 1); 6-7 the pin at the wheel stations (level 2, the leaf's flange bodies)."""
    mech = OutputPinMechanism(pin_circle_radius=R, hole_circle_radius=R, n_pins=1, phase=0.0, pin_radius=R_PIN,
                              hole_radius=R_HOLE, coefficient=2e8, exponent=1.5, contact_length=0.01, n_slices=2,
                              wheel_midplanes=(-0.006, 0.006), mode=PinMode.PLAIN)
    leaf = OutputPinEvaluator(mech, flange=0, wheels=(1, 2), n_bodies=8, backend="numpy", flange_bodies=[6, 7])
    pin = ElasticPinClosure(leaf, n_bodies=6, carrier=[[4, 5]], station_compliance=C_PIN, station=[[0, 1]],
                            joint=joint)
    support = ElasticPinClosure(pin, n_bodies=4, carrier=[[3, 3]], station_compliance=None, station=[[0, 1]],
                                support=GrooveSupport(LAW), joint=joint)
    return ElasticPinClosure(support, n_bodies=3, carrier=0, station_compliance=C_FLANGE, station=[[0]],
                             joint=joint)


def loaded_pose(dx, dy, turn):
    """Wheels 1 and 2 moved against the pin (clearance 10 um) and turned; the flange at the origin."""
    pose = np.zeros((3, 3))
    pose[1] = (dx, dy, turn)
    pose[2] = (-0.4 * dx, 1.3 * dy, -turn)
    return pose


@pytest.mark.parametrize("state", [(2.5e-5, 4e-6, 1e-5), (-1.8e-5, 2.2e-5, -3e-5)])
def test_joint_network_equals_the_nested_solve(state):
    """Q and dQ/dq of the joint network equal the nested solve's within 1e-9 relative (both converge their
    stations to the closures' tolerance, 1e-13 of the largest contact force: the difference is round-off of the
    iterates, ~1e-12 measured), with fewer contact evaluations; a wrong station law or map would move Q by the
    member's share (~1e-1)."""
    pose, vel = loaded_pose(*state), np.zeros((3, 3))
    evs, counts = {}, {}
    for joint in (False, True):
        top = chain(joint)
        leaf = top.inner.inner.inner
        n = [0]
        orig = leaf.evaluate

        def counted(*a, **k):
            n[0] += 1
            return orig(*a, **k)
        leaf.evaluate = counted
        evs[joint] = top.evaluate(pose, vel)
        counts[joint] = n[0]
        assert evs[joint].finite
    a, b = evs[False], evs[True]
    assert np.abs(a.Q).max() > 1.0                    # loaded: the pin touches both holes
    assert np.abs(a.Q - b.Q).max() <= 1e-9 * np.abs(a.Q).max()
    assert np.abs(a.dQdq - b.dQdq).max() <= 1e-9 * np.abs(a.dQdq).max()
    assert np.array_equal(a.obs.shape, b.obs.shape)
    assert counts[True] < counts[False]


def test_joint_stiffened_view_equals_the_nested_one():
    """An inner closure's stiffened view (its station stiffness times 2 in the condensation, the budget's series
    paths) condenses the same in the joint network as nested: 1e-9 relative; and it differs from the unstiffened
    tangent by more than 1e-4 (measured 9e-4 for the support, the view is not ignored)."""
    pose, vel = loaded_pose(2.5e-5, 4e-6, 1e-5), np.zeros((3, 3))
    K = {}
    for joint in (False, True):
        top = chain(joint)
        top.evaluate(pose, vel)
        for depth in (1, 2):
            inner = top if depth == 0 else (top.inner if depth == 1 else top.inner.inner)
            u, _, red, ok = top.solve(pose, vel)
            assert ok
            with inner.stiffened_view(2.0):
                _, _, red2, ok = top.solve(pose, vel, u0=u)
            K[joint, depth] = (top.condense(red)[1], top.condense(red2)[1])
    for depth in (1, 2):
        base, stiff = K[False, depth]
        assert np.abs(stiff - base).max() > 1e-4 * np.abs(base).max()
        for m in (0, 1):
            assert np.abs(K[True, depth][m] - K[False, depth][m]).max() <= 1e-9 * np.abs(base).max()


def test_groove_law_inversion_converges_without_restarts(monkeypatch):
    """psi_inverse (the groove law's force from its approach, evaluated at every station solve) converges by Newton in
    ln x: a vector of loads from 1e-9 to 1e3 needs at most 15 evaluations of psi (measured 11; a converged step below
    the round-off of ln x used to be bisected from the initial bracket's far end: 61), and psi(x) returns the loads to
    1e-12 relative (psi_inverse's own check)."""
    import rvtool.contact.conformal_pin as cp
    calls = [0]
    orig = cp.psi

    def counted(x):
        calls[0] += 1
        return orig(x)
    monkeypatch.setattr(cp, "psi", counted)
    rng = np.random.default_rng(0)
    y = np.concatenate([np.abs(rng.normal(size=200)) * s for s in (1e-9, 1e-6, 1e-3, 1e-1, 1.0, 1e3)])
    calls[0] = 0
    x = cp.psi_inverse(y)
    assert calls[0] <= 15
    assert np.all(np.abs(orig(x)[0] - y) <= 1e-12 * y)


def _network_answer(top, pose, vel):
    ev = top.evaluate(pose, vel)
    assert ev.finite
    return ev


def test_network_continuation_reaches_a_far_trial_state():
    """With every closure limited to 3 Newton iterations, the loaded state (forces ~12 N) is too far from the
    converged near-contact state (1 um) for the direct Newton (measured: the former network, warm start then zero
    start, did not converge and fell back to the nested solve; it needs 4 iterations); the continuation in the poses
    from the last converged solve reaches it (counted in ``continued``, no fallback), and its answer equals the
    nested solve at the default iterations within 1e-9 relative (both converge to the closures' tolerance)."""
    vel = np.zeros((3, 3))
    top = chain(True)
    for c in (top, top.inner, top.inner.inner):
        c.max_iterations = 3
    _network_answer(top, loaded_pose(1e-6, 1e-6, 0.0), vel)
    far = loaded_pose(2.5e-5, 4e-6, 1e-5)
    ev = _network_answer(top, far, vel)
    assert top.network.continued == 1 and top.network.failures == 0 and top.fallbacks == 0
    ref = _network_answer(chain(False), far, vel)
    assert np.abs(ref.Q).max() > 1.0
    assert np.abs(ev.Q - ref.Q).max() <= 1e-9 * np.abs(ref.Q).max()
    assert np.abs(ev.dQdq - ref.dQdq).max() <= 1e-9 * np.abs(ref.dQdq).max()


def test_unloaded_groove_stations_rest_at_zero():
    """From a state where both wheels press on the pin to one where wheel 2 is clear of it: the groove stations of the
    unloaded wheel carry no contact force and rest at exactly zero deflection in the network (the isolated law's exact
    solution; Newton alone approaches it by a factor ~ln(Delta R/|u|) per iteration and stops at ~1e-16 m within
    the force tolerance), and the answer equals the nested solve's within 1e-9 relative."""
    vel = np.zeros((3, 3))
    top = chain(True)
    _network_answer(top, loaded_pose(2.5e-5, 4e-6, 1e-5), vel)
    clear = loaded_pose(2.5e-5, 4e-6, 1e-5)
    clear[2] = (0.0, 0.0, 0.0)                     # wheel 2 centred: 10 um of clearance all round
    ev = _network_answer(top, clear, vel)
    net = top.network
    ref = _network_answer(chain(False), clear, vel)
    assert np.abs(ev.Q - ref.Q).max() <= 1e-9 * np.abs(ref.Q).max()
    # the network's stations: [flange (x, y); support stations (2 x (x, y)); pin stations (2 x (x, y))], the
    # support's second station (wheel 2's) at U[4:6]
    U = net.stations
    assert np.all(U[4:6] == 0.0)
    assert np.all(U[2:4] != 0.0)
    assert net.failures == 0


@pytest.mark.parametrize("fallback", ["reject", "nested"])
def test_network_failure_fallback(fallback):
    """A network that does not converge (every closure limited to one Newton iteration, no converged state to
    continue from) is counted in ``fallbacks``; ``"reject"`` answers the trial as non-finite (NaN forces, which the
    outer solver rejects), ``"nested"`` with the nested solve's finite numbers (the former behaviour)."""
    from rvtool.contact.pin_closure import ElasticPinClosure
    top = chain(True)
    closures = (top, top.inner, top.inner.inner)
    for c in closures:
        c.max_iterations = 1
    top = ElasticPinClosure(top.inner, n_bodies=3, carrier=0, station_compliance=C_FLANGE, station=[[0]], joint=True,
                            fallback=fallback, max_iterations=1)
    ev = top.evaluate(loaded_pose(2.5e-5, 4e-6, 1e-5), np.zeros((3, 3)))
    assert top.fallbacks == 1 and top.network.failures == 1
    assert not ev.finite
    assert np.all(np.isnan(ev.Q)) == (fallback == "reject")
    assert np.all(np.isfinite(ev.Q)) == (fallback == "nested")
