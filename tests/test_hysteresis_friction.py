"""Hysteresis with friction memory on the reducer (issue 17): the cycle protocol, its catalogue
figures on a loop with known answers, mu = 0 as the frictionless code path with bit-identical
figures, a closed RD-40 loop against the recorded friction dissipation, named design errors."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design, replace
from rvtool.errors import RvtoolInputError
from rvtool.protocols import hysteresis_cycles as HC
from rvtool.protocols import stiffness as S
from rvtool.units import RAD_PER_ARCMIN

RATED = 140.0


def _design(mu=None, **pc):
    d = load_design(designs.path("rd40"))
    if mu is None:
        return d
    return replace(d, pin_contact={"mu": mu, "friction_model": "anchor", **pc}, output_pins={"mu": mu})


def test_cycle_levels_are_symmetric_and_avoid_zero():
    seq = HC.CycleSequence(rated_torque=RATED, step=0.25, fine_levels=(0.01, 0.03))
    fr, labels = seq.cycle()
    assert fr[0] == -1.0 and fr[-1] == -1.0 and not np.any(fr == 0.0)
    up = fr[[l == "pos_loading" for l in labels]]
    down = fr[[l == "pos_unloading" for l in labels]]
    np.testing.assert_array_equal(up, [0.01, 0.03, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_array_equal(down, [0.75, 0.5, 0.25, 0.03, 0.01])
    T, lab = seq.levels()
    assert len(T) == len(seq.preload()) + 2 * len(fr) and lab[0] == "preload"
    parts = seq.split(np.arange(len(T)))
    assert len(parts) == 2 and parts[1][0] == len(seq.preload()) + len(fr)
    with pytest.raises(RvtoolInputError, match="n_cycles"):
        HC.CycleSequence(rated_torque=RATED, n_cycles=1)
    with pytest.raises(RvtoolInputError, match="step"):
        HC.CycleSequence(rated_torque=RATED, step=float("nan"))


def test_catalogue_figures_of_a_parallelogram_loop():
    """Branches theta = T/K -+ h/2 (ascending torque on the left): width at zero torque h, the
    midpoints at +-3 % on the line T/K (lost motion 0.06 T_rated / K), branch slopes K."""
    seq = HC.CycleSequence(rated_torque=RATED, step=0.125)
    fr, labels = seq.cycle()
    T = fr * RATED
    K = 150.0 / RAD_PER_ARCMIN            # N m/rad
    h = 0.02 * RAD_PER_ARCMIN
    ascending = np.array([l in ("neg_unloading", "pos_loading") for l in labels])
    ascending[-1] = False                  # the closing -T_rated ends the descending branch
    theta = T / K + np.where(ascending, -h / 2, h / 2)
    theta[0] = T[0] / K + h / 2            # the cycle starts at the reversal point it ends on
    fig = HC.catalogue_figures(T, theta, labels, RATED)
    assert fig.hysteresis_loss_arcmin == pytest.approx(0.02, rel=1e-12)
    assert fig.lost_motion_arcmin == pytest.approx(0.06 * RATED / 150.0, rel=1e-12)
    # an unloading fit starts at the reversal level (one state in a real loop, a corner of the
    # parallelogram here): the loading branches lie on their lines
    for b in ("pos_loading", "neg_loading"):
        assert fig.branch_fits[b]["K_Nm_per_arcmin"] == pytest.approx(150.0, rel=1e-9), b
    assert fig.loop_integral_J > 0.0
    with pytest.raises(RvtoolInputError, match="lost motion"):
        HC.midpoint_lost_motion(T, theta, labels, RATED, fraction=0.02)


@pytest.fixture(scope="module")
def frictionless_figures():
    qs = S.quasi_static_stiffness(build(_design()), S.rd40_sequence(RATED))
    return qs["angle_arcmin"]


def test_mu_zero_reproduces_the_frictionless_figures_exactly(frictionless_figures):
    """mu = 0 under the anchor model packs the frictionless contacts: no anchor kernel, no
    history, and the 74-level stiffness sequence gives bit-identical angles."""
    model = build(_design(0.0))
    assert not model.pin_set.anchor
    assert not model.elements["output_pins"].evaluator.anchor
    qs = S.quasi_static_stiffness(model, S.rd40_sequence(RATED))
    np.testing.assert_array_equal(qs["angle_arcmin"], frictionless_figures)


def test_rd40_loop_closes_and_matches_the_recorded_dissipation():
    """mu = 0.05 on pin mesh and output pins, a coarse cycle sequence: the second cycle repeats
    the first (Masing: every cycle starts at a reversal point) to the Newton tolerance; ∮T dθ
    equals the friction dissipation of the committed anchors within the trapezoid's quadrature
    bound (HC.loop_quadrature_bound, under 10 % of it at this level spacing); unloading is stiffer than
    loading (the contacts stick on reversal)."""
    seq = HC.CycleSequence(rated_torque=RATED, step=0.125, fine_levels=(0.0005, 0.003, 0.03))
    r = HC.quasi_static_cycles(build(_design(0.05)), seq)
    prev, last = r["cycles"]
    closed = HC.closed_cycle(prev, last, angle_tolerance=1e-4 * RAD_PER_ARCMIN)
    D = last["friction_dissipation_J"]
    assert D["pins"] > 0 and D["output_pins"] > 0 and D["bearings"] == 0.0
    total = sum(D.values())
    T, th = last["torque_Nm"], last["angle_rad"]
    from rvtool.protocols.hysteresis import Cycle
    bound = HC.loop_quadrature_bound(Cycle(torque=T, angle=th))
    assert abs(closed.loop_integral - total) <= bound < 0.1 * total
    fig = HC.catalogue_figures(T, th, last["labels"], RATED)
    assert fig.branch_fits["pos_unloading"]["K_Nm_per_arcmin"] > fig.branch_fits["pos_loading"]["K_Nm_per_arcmin"]
    assert fig.hysteresis_loss_arcmin > 0


def test_design_friction_inputs_are_named():
    d = load_design(designs.path("rd40"))
    with pytest.raises(RvtoolInputError, match="pin_contact.mu"):
        replace(d, pin_contact={"mu": -0.1})
    with pytest.raises(RvtoolInputError, match="pin_contact.mu"):
        replace(d, pin_contact={"mu": float("nan")})
    with pytest.raises(RvtoolInputError, match="output_pins.mu"):
        replace(d, output_pins={"mu": -0.05})
    with pytest.raises(RvtoolInputError, match="output_pins.tangential_stiffness"):
        replace(d, output_pins={"tangential_stiffness": float("nan")})
    with pytest.raises(RvtoolInputError, match="pin_contact.friction_model"):
        replace(d, pin_contact={"friction_model": "coulomb"})
    with pytest.raises(RvtoolInputError, match="pin_contact.tangential_stiffness"):
        build(replace(d, pin_contact={"mu": 0.05, "friction_model": "anchor", "law": "power", "exponent": 1.5}))


def test_reducer_anchors_are_a_function_of_the_accepted_states_only():
    """RD-40 with anchors on both families under the production driver: a torque ramp at fixed
    input with forced rejections. Replaying the accepted states through a fresh model (its own
    commits from the same static start) reproduces every committed anchor, flag and slip distance
    bit for bit: rejected attempts and Newton iterations never reached the history."""
    import exudyn as exu

    from rvtool.solver import RunSpec, simulate
    from rvtool.solver.continuation import Continuation

    def start():
        model = build(_design(0.05))
        q = Continuation(model).go_to(60.0)
        return model, q

    model, q0 = start()
    fams = ("pins", "output_pins")
    rows = []

    def keep(t, q, v):
        rows.append((q.copy(), v.copy(), {f: model.elements[f].evaluator.history.copy() for f in fams}))

    model.set_output_torque_function(lambda t: 60.0 + 40.0 * min(t / 2e-4, 1.0))
    mbs = model.mbs
    mbs.systemData.SetODE2Coordinates(q0, configuration=exu.ConfigurationType.Initial)
    mbs.systemData.SetODE2Coordinates_t(np.zeros_like(q0), configuration=exu.ConfigurationType.Initial)
    rec = simulate(mbs, RunSpec(end_time=3e-4, step=2e-5, abs_tol=1e-6, rel_tol=1e-8), model.contact_elements(),
                   reject_attempts=(3, 7, 11), before_accept=keep)
    assert rec.rejected_steps >= 3 and len(rows) == rec.accepted_steps >= 10
    moved = rows[-1][2]["pins"].slip_distance.max() + rows[-1][2]["output_pins"].slip_distance.max()
    assert moved > 0.0                          # the ramp made anchors slip
    replay, q1 = start()
    np.testing.assert_array_equal(q1, q0)
    for q, v, hist in rows:
        replay.commit_contacts(q, v)
        for f in fams:
            h = replay.elements[f].evaluator.history
            for name in ("active", "anchor_a", "anchor_b", "slip_distance"):
                np.testing.assert_array_equal(getattr(h, name), getattr(hist[f], name))
