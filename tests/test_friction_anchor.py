"""Anchor (stick--slip) friction on the reducer contact families (issue 17).

For the cycloid--pin slices (below: the output-pin slices and the involute tooth pairs):

* the Warp kernel against the NumPy reference on every available device, in a
  state with sticking and slipping rows;
* the analytic tangent against central differences in stick and in slip
  (the committed history held fixed, as in a Newton iteration);
* trial evaluations (rejected steps, extra Newton iterations) never change
  the committed anchors; the commit at an accepted state is a function of
  that state and the committed history only;
* stick: the anchor does not move (zero material slip); slip: |F_t| = mu F_n;
* an anchor whose material points have migrated beyond the release distance
  is released: no force from it, a new anchor at the current contact, no
  slip distance counted;
* mu = 0 runs the frictionless code path (bit-identical forces and figures);
* bad inputs raise named errors.
"""
import numpy as np
import pytest
import warp as wp

from rvtool.contact.circle_set import FrictionLaw, FrictionModel, NormalLaw
from rvtool.contact.cycloid_set import CycloidPinSet, WheelPinMesh
from rvtool.errors import RvtoolInputError
from rvtool.geometry.cycloid import CycloidProfile
from warp_contacts import anchor_ref
from warp_contacts import circle_pairs_ref as cref
from warp_contacts.precision import resolve_device

resolve_device("cpu")
DEVICES = ["cpu", pytest.param("cuda:0", marks=pytest.mark.skipif(
    wp.get_cuda_device_count() == 0, reason="no CUDA device"))]

MU = 0.1
KT = 1e8          # whole-contact tangential stiffness [N/m]
PROFILE = CycloidProfile(pin_circle_radius=0.05, pin_radius=0.003, n_pins=40, generating_eccentricity=0.0008)


def _pin_set(backend="numpy", device="cpu", precision="float64", mu=MU, model=FrictionModel.ANCHOR, search="discrete", **kw):
    mesh = WheelPinMesh(profile=PROFILE, wheel_body=0, pin_body=1, face_width=0.008, n_slices=2, clearance=5e-7,
                        normal=NormalLaw(law="line", stiffness=2e8, damping=0.0, ramp_depth=2e-6),
                        friction=FrictionLaw(model=model, mu_kinetic=mu, tangential_stiffness=KT), **kw)
    return CycloidPinSet([mesh], 2, backend=backend, device=device, precision=precision, search=search)


def _pose(dtheta=0.0):
    psi, e = 0.3, PROFILE.generating_eccentricity
    p = np.array([[-e * np.sin(psi) + 2e-6, e * np.cos(psi) - 1e-6, -psi / 39 + 1.5e-5], [1e-6, -2e-6, 1e-5]])
    p[0, 2] += dtheta
    return p


VEL = np.zeros((2, 3))


def _anchored(s):
    """Commit the anchors at the base pose (they form there), then return the set."""
    s.commit(_pose(), VEL)
    return s


# a wheel turn of 4e-7 rad slides the loaded pins by ~2e-8 m: some rows stick, the most
# loaded-to-least-loaded spread puts others beyond mu F_n / k_t (slip)
MIXED = 4e-7


def _branches(s, pose):
    ev = s.evaluate(pose, VEL)
    fn, ft = ev.obs[:, cref.O_FN], ev.obs[:, cref.O_FT]
    on = fn > 0
    slip = on & np.isclose(np.abs(ft), MU * fn, rtol=1e-12)
    stick = on & ~slip
    return ev, stick, slip


@pytest.mark.parametrize("device", DEVICES)
def test_cycloid_anchor_kernel_matches_reference(device):
    """Tolerance: the gap is a difference of ~5e-2 m positions for ~1e-6 m indentations
    (rounding amplified ~5e4, see test_cycloid); 1e-9 of the largest entry as there. The
    trial anchors are positions of ~5e-2 m: 1e-15 m absolute is a few ulps. The slip distance is
    a difference of two such positions (increments ~1e-9 m), so its bound is 2e-15 m absolute:
    CUDA contracts multiply-adds (FMA) where the CPU does not, which moved a 8e-10 m slip by 5e-18 m."""
    w, n = _anchored(_pin_set("warp", device)), _anchored(_pin_set("numpy"))
    np.testing.assert_array_equal(w.history.active, n.history.active)
    np.testing.assert_allclose(w.history.anchor_a, n.history.anchor_a, rtol=0, atol=1e-15)
    ew, stick, slip = _branches(w, _pose(MIXED))
    en, _, _ = _branches(n, _pose(MIXED))
    assert stick.any() and slip.any()
    for x, y in ((ew.Q, en.Q), (ew.dQdq, en.dQdq), (ew.obs, en.obs)):
        assert np.max(np.abs(x - y)) <= 1e-9 * np.max(np.abs(y))
    np.testing.assert_array_equal(ew.trial_history[0], en.trial_history[0])
    np.testing.assert_allclose(ew.trial_history[1], en.trial_history[1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(ew.trial_history[3], en.trial_history[3], rtol=0, atol=2e-15)


@pytest.mark.parametrize("backend", ["numpy", "warp"])
@pytest.mark.parametrize("dtheta,branch", [(2e-8, "stick"), (2e-6, "slip")])
def test_cycloid_anchor_tangent_matches_central_differences(backend, dtheta, branch):
    """dQ/dq against central differences with the committed history fixed. The steps (1e-10 m,
    1e-9 rad) change s = t.e by <= 1e-10 m, far less than the margin of every row to the
    stick/slip switch asserted below, so no row changes branch; the FD truncation error of
    the smooth branch is O(h^2) ~ 1e-8 relative, the round-off ~1e-16 * |Q| / h ~ 1e-6."""
    s = _anchored(_pin_set(backend))
    pose = _pose(dtheta)
    ev, stick, slip = _branches(s, pose)
    assert (stick if branch == "stick" else slip).sum() >= 4
    fn, ft = ev.obs[:, cref.O_FN], ev.obs[:, cref.O_FT]
    on = fn > 0
    # margin to the switch, in force: |MU F_n - |F_t|| for stick rows, vs k_t-weighted FD step
    kt_s = KT / 2
    margin = np.abs(MU * fn[stick] - np.abs(ft[stick]))
    assert np.all(margin > kt_s * 1e-9 * 0.06 * 10)
    K = np.zeros((6, 6))
    for j in range(6):
        b, c = divmod(j, 3)
        h = 1e-10 if c < 2 else 1e-9
        P = pose.copy()
        P[b, c] += h
        qp = s.evaluate(P, VEL).Q
        P[b, c] -= 2 * h
        K[:, j] = (qp - s.evaluate(P, VEL).Q) / (2 * h)
    assert np.linalg.norm(ev.dQdq - K) / np.linalg.norm(K) < 1e-5
    assert on.any()


def test_trials_do_not_move_the_committed_anchors():
    """Rejected steps and extra Newton iterations are trial evaluations: the committed history
    is unchanged by any number of them, and the commit at the accepted state equals the
    commit made without them (bit for bit)."""
    a, b = _anchored(_pin_set()), _anchored(_pin_set())
    before = a.history.copy()
    for k in range(5):                       # a rejected attempt and its Newton iterations
        a.evaluate(_pose(3e-6 * (k + 1)), VEL)
    for name in ("active", "anchor_a", "anchor_b", "slip_distance"):
        np.testing.assert_array_equal(getattr(a.history, name), getattr(before, name))
    a.commit(_pose(MIXED), VEL)
    b.commit(_pose(MIXED), VEL)
    for name in ("active", "anchor_a", "anchor_b", "slip_distance"):
        np.testing.assert_array_equal(getattr(a.history, name), getattr(b.history, name))


def test_stick_keeps_the_anchor_and_slip_obeys_the_bound():
    s = _anchored(_pin_set())
    ev, stick, slip = _branches(s, _pose(MIXED))
    old_a = s.history.anchor_a.copy()
    s.commit(_pose(MIXED), VEL, ev)
    # stick: the material anchor does not move (zero material slip), no slip distance
    np.testing.assert_array_equal(s.history.anchor_a[stick], old_a[stick])
    assert np.all(s.history.slip_distance[stick] == 0.0)
    # slip: |F_t| = mu F_n (round-off of the product), the anchor moved by the slip distance
    fn, ft = ev.obs[:, cref.O_FN], ev.obs[:, cref.O_FT]
    np.testing.assert_allclose(np.abs(ft[slip]), MU * fn[slip], rtol=1e-14)
    moved = np.linalg.norm(s.history.anchor_a[slip] - old_a[slip], axis=1)
    np.testing.assert_allclose(s.history.slip_distance[slip], moved, rtol=1e-14)
    assert np.all(moved > 0)
    # the committed slip leaves the anchor on the bound: re-evaluating there gives |k_t s| = mu F_n
    ev2, _, slip2 = _branches(s, _pose(MIXED))
    np.testing.assert_allclose(np.abs(ev2.obs[slip, cref.O_FT]), MU * fn[slip], rtol=1e-9)


def test_migrated_anchor_is_released_without_force():
    """A wheel turn that moves the material points apart by more than the release distance
    (here 1 um) releases every anchor: zero tangential force, new anchors at the current
    contact points (flag FORMED), and no slip distance counted for the jump."""
    s = _anchored(_pin_set(anchor_release_distance=1e-6))
    ev = s.evaluate(_pose(1e-4), VEL)           # ~5 um of sliding at the pins
    fn = ev.obs[:, cref.O_FN]
    on = fn > 0
    assert on.any()
    assert np.all(ev.obs[:, cref.O_FT] == 0.0)
    flags = ev.trial_history[0]
    assert np.all(flags[on] == anchor_ref.HISTORY_FORMED)
    assert np.all(ev.trial_history[3] == 0.0)
    # frictionless forces where every anchor is released
    plain = _pin_set(model=FrictionModel.NONE, mu=0.0).evaluate(_pose(1e-4), VEL)
    np.testing.assert_array_equal(ev.Q, plain.Q)
    # the re-formed anchors start at zero separation: the next trial at the same state sticks at zero force
    s.commit(_pose(1e-4), VEL, ev)
    ev2 = s.evaluate(_pose(1e-4), VEL)
    np.testing.assert_allclose(ev2.obs[:, cref.O_FT], 0.0, atol=1e-9 * fn.max())
    assert np.all(ev2.trial_history[0][on] == anchor_ref.HISTORY_KEPT)


@pytest.mark.parametrize("backend", ["numpy", "warp"])
def test_mu_zero_runs_the_frictionless_code(backend):
    """An anchor law with mu = 0 packs the frictionless contact: no anchor kernel, no history,
    forces and tangents bit-identical to friction NONE."""
    s0 = _pin_set(backend, mu=0.0)
    sn = _pin_set(backend, mu=0.0, model=FrictionModel.NONE)
    assert not s0.anchor and not hasattr(s0.history, "anchor_a")
    a, b = s0.evaluate(_pose(MIXED), VEL), sn.evaluate(_pose(MIXED), VEL)
    np.testing.assert_array_equal(a.Q, b.Q)
    np.testing.assert_array_equal(a.dQdq, b.dQdq)


def test_anchor_forces_add_nothing_at_formation():
    """Where the anchors form (first closed evaluation) the anchor kernel's forces equal the
    frictionless kernel's bit for bit: the anchor code adds exact zeros."""
    a = _pin_set("warp").evaluate(_pose(), VEL)
    b = _pin_set("warp", mu=0.0, model=FrictionModel.NONE).evaluate(_pose(), VEL)
    np.testing.assert_array_equal(a.Q, b.Q)


def test_bad_friction_inputs_are_named():
    with pytest.raises(RvtoolInputError, match="mu_kinetic"):
        FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=-0.1, tangential_stiffness=KT)
    with pytest.raises(RvtoolInputError, match="mu_kinetic"):
        FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=float("nan"), tangential_stiffness=KT)
    with pytest.raises(RvtoolInputError, match="tangential_stiffness"):
        FrictionLaw(model=FrictionModel.ANCHOR, mu_kinetic=0.1, tangential_stiffness=0.0)
    with pytest.raises(RvtoolInputError, match="anchor_release_distance"):
        _pin_set(anchor_release_distance=-1e-6)


# -- output pins (plain mode): anchors per slice row ------------------------------------------

def _output_pins(backend="numpy", device="cpu", mu=MU, model=FrictionModel.ANCHOR, **kw):
    from rvtool.output_pins import OutputPinEvaluator, PinMode, shared_pin_study_mechanism
    # the mechanism's friction law is the anchor model of its mu and tangential_stiffness (model
    # NONE: mu = 0)
    mech = shared_pin_study_mechanism(0.0, n_pins=4, mode=PinMode.PLAIN, compliance=None,
                                      mu=mu if model == FrictionModel.ANCHOR else 0.0, tangential_stiffness=KT, **kw)
    return OutputPinEvaluator(mech, backend=backend, device=device)


def _pin_pose(dtheta=0.0):
    """Flange at rest, both wheels displaced by ~70 um (every pin loaded on some slices) and
    the wheels turned by dtheta [rad] relative to the committed state."""
    q = np.array([[0.0, 0.0, 0.0], [60e-6, 20e-6, 1e-4 + dtheta], [-55e-6, -35e-6, -2e-4 + dtheta]])
    return q


def _pin_branches(ev, pose):
    e = ev.evaluate(pose, np.zeros((3, 3)))
    fn, ft = e.obs[:, cref.O_FN], e.obs[:, cref.O_FT]
    on = fn > 0
    slip = on & np.isclose(np.abs(ft), MU * fn, rtol=1e-12)
    return e, on & ~slip, slip


@pytest.mark.parametrize("device", DEVICES)
def test_output_pin_anchor_kernel_matches_reference(device):
    """Tolerance: positions of ~3.5e-2 m against approaches of ~1e-5 m (rounding amplified
    ~3e3, and ~5e4 by the 10/9 law's stiffness at small approaches): 1e-9 of the largest entry."""
    w, n = _output_pins("warp", device), _output_pins("numpy")
    for ev in (w, n):
        ev.commit(_pin_pose(), np.zeros((3, 3)))
    np.testing.assert_array_equal(w.history.active, n.history.active)
    np.testing.assert_allclose(w.history.anchor_a, n.history.anchor_a, rtol=0, atol=1e-15)
    ew, stick, slip = _pin_branches(w, _pin_pose(3e-5))
    en, _, _ = _pin_branches(n, _pin_pose(3e-5))
    assert stick.any() and slip.any()
    for x, y in ((ew.Q, en.Q), (ew.dQdq, en.dQdq), (ew.obs, en.obs)):
        assert np.max(np.abs(x - y)) <= 1e-9 * np.max(np.abs(y))
    np.testing.assert_array_equal(ew.trial_history[0], en.trial_history[0])
    np.testing.assert_allclose(ew.trial_history[1], en.trial_history[1], rtol=0, atol=1e-15)


@pytest.mark.parametrize("backend", ["numpy", "warp"])
@pytest.mark.parametrize("dtheta,branch", [(1e-6, "stick"), (1e-4, "slip")])
def test_output_pin_anchor_tangent_matches_central_differences(backend, dtheta, branch):
    """As for the pin slices: FD steps of 1e-10 m / 1e-9 rad change s by <= 4e-11 m, far inside
    every row's margin to the stick/slip switch (asserted); relative error 1e-5."""
    ev = _output_pins(backend)
    ev.commit(_pin_pose(), np.zeros((3, 3)))
    pose = _pin_pose(dtheta)
    e, stick, slip = _pin_branches(ev, pose)
    assert (stick if branch == "stick" else slip).sum() >= 4
    fn, ft = e.obs[:, cref.O_FN], e.obs[:, cref.O_FT]
    assert np.all(np.abs(MU * fn[stick] - np.abs(ft[stick])) > KT / 4 * 1e-10 * 10)
    K = np.zeros((9, 9))
    for j in range(9):
        b, c = divmod(j, 3)
        h = 1e-10 if c < 2 else 1e-9
        P = pose.copy()
        P[b, c] += h
        qp = ev.evaluate(P, np.zeros((3, 3))).Q
        P[b, c] -= 2 * h
        K[:, j] = (qp - ev.evaluate(P, np.zeros((3, 3))).Q) / (2 * h)
    assert np.linalg.norm(e.dQdq - K) / np.linalg.norm(K) < 1e-5


def test_output_pin_stick_slip_and_trials():
    ev = _output_pins()
    ev.commit(_pin_pose(), np.zeros((3, 3)))
    before = ev.history.copy()
    for k in range(3):                                      # trials never move the committed anchors
        ev.evaluate(_pin_pose(1e-5 * (k + 1)), np.zeros((3, 3)))
    for name in ("active", "anchor_a", "anchor_b", "slip_distance"):
        np.testing.assert_array_equal(getattr(ev.history, name), getattr(before, name))
    e, stick, slip = _pin_branches(ev, _pin_pose(3e-5))
    ev.commit(_pin_pose(3e-5), np.zeros((3, 3)), e)
    np.testing.assert_array_equal(ev.history.anchor_a[stick], before.anchor_a[stick])
    assert np.all(ev.history.slip_distance[stick] == 0.0) and np.all(ev.history.slip_distance[slip] > 0.0)
    np.testing.assert_allclose(np.abs(e.obs[slip, cref.O_FT]), MU * e.obs[slip, cref.O_FN], rtol=1e-14)
    # the friction forces balance between flange and wheels (an internal force pair)
    from rvtool.output_pins import diagnostics as diag
    force, _ = diag.balance(e.Q, _pin_pose(3e-5).reshape(-1))
    np.testing.assert_allclose(force, 0.0, atol=1e-12 * np.max(np.abs(e.Q)))


def test_output_pin_mu_zero_and_bad_inputs():
    from rvtool.output_pins import PinMode, shared_pin_study_mechanism
    a = _output_pins("warp", mu=0.0)
    b = _output_pins("warp", mu=0.0, model=FrictionModel.NONE)
    assert not a.anchor
    ea, eb = a.evaluate(_pin_pose(), np.zeros((3, 3))), b.evaluate(_pin_pose(), np.zeros((3, 3)))
    np.testing.assert_array_equal(ea.Q, eb.Q)
    np.testing.assert_array_equal(ea.dQdq, eb.dQdq)
    with pytest.raises(RvtoolInputError, match="plain"):
        shared_pin_study_mechanism(0.0, mu=0.1, tangential_stiffness=KT)
    with pytest.raises(RvtoolInputError, match="mu"):
        shared_pin_study_mechanism(0.0, mode=PinMode.PLAIN, compliance=None, mu=-0.1)
    with pytest.raises(RvtoolInputError, match="anchor_release_distance"):
        _output_pins(anchor_release_distance=0.0)


# -- involute tooth pairs: anchors per row (window slot), released when the slot's teeth change ----

def _gear_set(backend="numpy", device="cpu", mu=MU, model=FrictionModel.ANCHOR, **kw):
    from rvtool.contact.involute_set import GearMesh, InvoluteContactSet
    from test_involute_pairs import fzg
    mesh = GearMesh(pair=fzg(), body_a=0, body_b=1, n_slices=2,
                    friction=FrictionLaw(model=model, mu_kinetic=mu, tangential_stiffness=KT), **kw)
    return InvoluteContactSet([mesh], 2, backend=backend, device=device)


def _gear_pose(dy=0.0, turn=0.0):
    """FZG pair loaded by a turn of gear B (3e-4 rad), gear B shifted by dy [m] across the centre
    line (sliding at both tooth pairs in mesh); both gears turned rigidly by ``turn`` [rad of A]."""
    from test_involute_pairs import fzg, poses
    p = poses(fzg(), [0.01 + turn], 3e-4)[0]
    p[1, 1] += dy
    return p


def _gear_branches(s, pose):
    from warp_contacts import involute_pairs_ref as iref
    e = s.evaluate(pose, VEL)
    fn, ft = e.obs[:, iref.O_FN], e.obs[:, iref.O_FT]
    on = fn > 0
    slip = on & np.isclose(np.abs(ft), MU * fn, rtol=1e-12)
    return e, on & ~slip, slip


@pytest.mark.parametrize("device", DEVICES)
def test_involute_anchor_kernel_matches_reference(device):
    """Tolerance as test_involute_pairs' float64 kernel test (1e-9 of the largest entry); a shift
    of 4.5 um makes one tooth pair slip while the other sticks."""
    w, n = _gear_set("warp", device), _gear_set("numpy")
    for s in (w, n):
        s.commit(_gear_pose(), VEL)
    np.testing.assert_array_equal(w.history.active, n.history.active)
    np.testing.assert_allclose(w.history.anchor_a, n.history.anchor_a, rtol=0, atol=1e-15)
    ew, stick, slip = _gear_branches(w, _gear_pose(4.5e-6))
    en, _, _ = _gear_branches(n, _gear_pose(4.5e-6))
    assert stick.any() and slip.any()
    for x, y in ((ew.Q, en.Q), (ew.dQdq, en.dQdq), (ew.obs[:, :8], en.obs[:, :8])):
        assert np.max(np.abs(x - y)) <= 1e-9 * np.max(np.abs(y))
    np.testing.assert_array_equal(ew.trial_history[0], en.trial_history[0])
    np.testing.assert_allclose(ew.trial_history[1], en.trial_history[1], rtol=0, atol=1e-15)


@pytest.mark.parametrize("backend", ["numpy", "warp"])
@pytest.mark.parametrize("dy,branch", [(1e-7, "stick"), (1e-5, "slip")])
def test_involute_anchor_tangent_matches_central_differences(backend, dy, branch):
    """Steps of 1e-10 m / 1e-9 rad change s by ~1e-10 m, inside every stick row's margin (asserted);
    the series law's iteration stops at 1e-14 relative, so the FD round-off is ~1e-14 |Q| / h ~ 1e-6
    of the entries: relative error 1e-5."""
    s = _gear_set(backend)
    s.commit(_gear_pose(), VEL)
    pose = _gear_pose(dy)
    e, stick, slip = _gear_branches(s, pose)
    assert (stick if branch == "stick" else slip).sum() >= 2
    from warp_contacts import involute_pairs_ref as iref
    fn, ft = e.obs[:, iref.O_FN], e.obs[:, iref.O_FT]
    assert np.all(np.abs(MU * fn[stick] - np.abs(ft[stick])) > KT / 2 * 1e-10 * 10)
    K = np.zeros((6, 6))
    for j in range(6):
        b, c = divmod(j, 3)
        h = 1e-10 if c < 2 else 1e-9
        P = pose.copy()
        P[b, c] += h
        qp = s.evaluate(P, VEL).Q
        P[b, c] -= 2 * h
        K[:, j] = (qp - s.evaluate(P, VEL).Q) / (2 * h)
    assert np.linalg.norm(e.dQdq - K) / np.linalg.norm(K) < 1e-5


def test_involute_anchor_released_when_the_teeth_change():
    """Turning both gears rigidly by one pitch of A moves every window slot to the next tooth pair:
    the committed anchors of the old pair are a base pitch away, released (zero friction force,
    FORMED) and no slip distance is counted; a small sliding shift before that sticks."""
    from rvtool.contact.circle_set import FrictionModel as FM
    s = _gear_set()
    s.commit(_gear_pose(), VEL)
    pitch = 2 * np.pi / 16
    e = s.evaluate(_gear_pose(turn=pitch), VEL)
    on = e.obs[:, 0] > 0
    assert on.any()
    assert np.all(e.obs[:, 7] == 0.0)
    assert np.all(e.trial_history[0][on] == anchor_ref.HISTORY_FORMED)
    assert np.all(e.trial_history[3] == 0.0)
    plain = _gear_set(model=FM.NONE, mu=0.0).evaluate(_gear_pose(turn=pitch), VEL)
    np.testing.assert_array_equal(e.Q, plain.Q)
    # mu = 0 under the anchor law: the frictionless code, bit-identical
    z = _gear_set("warp", mu=0.0)
    assert not z.anchor
    np.testing.assert_array_equal(z.evaluate(_gear_pose(1e-6), VEL).Q,
                                  _gear_set("warp", mu=0.0, model=FM.NONE).evaluate(_gear_pose(1e-6), VEL).Q)
    with pytest.raises(RvtoolInputError, match="anchor_release_distance"):
        _gear_set(anchor_release_distance=-1.0)
