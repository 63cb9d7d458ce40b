"""Per-crank gear pitch deviations of the RV stage (issue 16, Monte Carlo tolerances): the design
key, its checks, the meshes that carry them, the tolerance sampling, and their physical effect."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.rv import load_design
from rvtool.errors import RvtoolInputError
from rvtool.solver.static import StaticSolver
from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("rv40e"))


def _devs(z, k, amp):
    """Single pitch deviations closing the circle: +amp at tooth k, -amp at tooth k + 1."""
    f = np.zeros(z)
    f[k], f[k + 1] = amp, -amp
    return tuple(f)


def test_crank_gear_pitch_deviations_reach_their_own_mesh(design):
    """Crank k's mesh carries crank k's deviations (tooth-angle table of gear B = F_j / r_b, the
    cumulative deviation over the base radius, exactly); the other cranks' meshes stay nominal."""
    z = design.crank_gear.n_teeth
    d = design.replace(cranks={"gear_pitch_deviations": (_devs(z, 3, 4e-6), (0.0,) * z, (0.0,) * z)})
    nominal = build(design).elements["gears"].evaluator.meshes
    meshes = build(d).elements["gears"].evaluator.meshes
    rb = design.crank_gear.base_radius
    tb0, tb = nominal[0].tooth_angle_table()[1], meshes[0].tooth_angle_table()[1]
    F = np.zeros(z)
    F[3] = 4e-6                        # F_j = sum_{i=1..j} f_i: only tooth 3 is displaced
    assert np.allclose(np.roll(tb - tb0, -int(np.argmax(np.abs(tb - tb0))) + 3), F / rb, atol=1e-15, rtol=0)
    for k in (1, 2):
        assert np.array_equal(meshes[k].tooth_angle_table()[1], nominal[k].tooth_angle_table()[1])


def test_crank_gear_pitch_deviation_errors_name_the_key(design):
    z = design.crank_gear.n_teeth
    with pytest.raises(RvtoolInputError, match=r"cranks.gear_pitch_deviations has 2 entries"):
        design.replace(cranks={"gear_pitch_deviations": ((0.0,) * z,) * 2})
    with pytest.raises(RvtoolInputError, match=r"cranks.gear_pitch_deviations\[1\] has 5 entries"):
        design.replace(cranks={"gear_pitch_deviations": ((0.0,) * z, (0.0,) * 5, (0.0,) * z)})
    with pytest.raises(RvtoolInputError, match=r"cranks.gear_pitch_deviations\[0\] sum to"):
        design.replace(cranks={"gear_pitch_deviations": ((1e-6,) + (0.0,) * (z - 1), (0.0,) * z, (0.0,) * z)})


def test_sampling_draws_each_crank_gear(design):
    """One set per crank, each closing its circle (sum 0 to round-off of the mean removal), the
    sets different; the other fields' draws of a seed are those drawn before the field existed
    (it is drawn last: the sun's deviations depend only on the generator state before it)."""
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    d, drawn = sample_rv_design(tol, design, 2, 11)
    devs = np.array(d.cranks.gear_pitch_deviations)
    assert devs.shape == (3, design.crank_gear.n_teeth)
    assert np.all(np.abs(devs.sum(axis=1)) < 1e-18)
    assert not np.allclose(devs[0], devs[1])
    import dataclasses
    d_old, drawn_old = sample_rv_design(dataclasses.replace(tol, crank_gear_pitch_deviation=None), design, 2, 11)
    assert {k: v for k, v in drawn.items() if k != "crank_gear_pitch_deviation"} == drawn_old


def _shares(design):
    m = build(design)
    m.set_output_torque(-np.sign(m.ratio) * design.rated_torque)
    return m.crank_load_share(StaticSolver(m).solve(0.0))


def test_a_shifted_block_of_teeth_is_a_crank_phase_error(design):
    """Pitch deviations that turn the 17 teeth of crank 0's gear around its sun contact by
    delta = F / r_b (f_pt = +F entering the block, -F leaving it) act on the rated state exactly
    as turning the eccentric journals by -delta against the gear: the crank shares equal those
    of ``cranks.phase_errors_deg = (-delta, 0, 0)`` (teeth outside the block are outside the
    mesh window; measured 1e-8, the static solve's tolerance), and differ from nominal."""
    import math
    z = design.crank_gear.n_teeth
    g = build(design).graph
    pitch = 2 * np.pi / z
    # crank 0's tooth facing the sun at input angle 0 (tooth 0 on the crank's x axis)
    j = int(round(((g.crank_angles[0] + np.pi - g.crank_gear_angles0[0]) % (2 * np.pi)) / pitch))
    F = 4e-6
    f = np.zeros(z)
    f[(j - 8) % z] += F
    f[(j + 9) % z] -= F
    assert 0 < (j - 8) % z < (j + 9) % z          # the block does not contain tooth 0 (F_0 = 0)
    s_dev = _shares(design.replace(cranks={"gear_pitch_deviations": (tuple(f), (0.0,) * z, (0.0,) * z)}))
    delta = F / design.crank_gear.base_radius
    s_phase = _shares(design.replace(cranks={"phase_errors_deg": (-math.degrees(delta), 0.0, 0.0)}))
    assert np.allclose(s_dev, s_phase, atol=1e-6, rtol=0)
    assert np.max(np.abs(s_dev - _shares(design))) > 3e-4
