"""The device TE's points solved in the order of their crank phase (device_rows_variants(te_order=
"phase"), the default) against the order given: the same TE, fewer batch iterations, the Exudyn
oracle's TE."""
import numpy as np
import pytest

from rvtool import designs, load_design
from rvtool.batched.device_rows_variants import device_rows_variants
from rvtool.errors import RvtoolInputError
from rvtool.units import ARCSEC_PER_RAD
from rvtool.variants.multi_device import variant_snapshots

RD_KW = {"bearing_model": "lumped", "regularization": (1.0e4, 100.0)}   # cases/cycloid/monte_carlo_te.py's build
RD_SEED = 2026                                                          # cases/cycloid/monte_carlo_te.py


def test_crank_phase_order_gives_the_te_in_fewer_iterations():
    """Two RD-40 variants over one output revolution at 23 points (0.74 crank revolutions apart): TE
    equal to the given order's within 1e-9 arcsec (two Newton iterates of each equilibrium, abs_tol
    1e-6 N; measured 1.8e-10 over 24 variants at 53 points), in fewer batch iterations (measured 390
    vs 544 at 53 points), and equal to the Exudyn reference run's TE peak-to-peak within 1e-6 arcsec
    (issue 31). Fails if the order moved an equilibrium or bought nothing."""
    from rvtool.variants import VariantProtocol, variant_figures
    from rvtool.variants.tolerances import load_tolerances, sample_variant
    d = load_design(designs.path("rd40"))
    tol = load_tolerances(designs.path("rd40_tolerances"))
    protocol = VariantProtocol(n_te_points=23)
    models = [s for _, s, _ in variant_snapshots([(d, tol, RD_SEED, k, RD_KW) for k in (4, 5)])]
    angles = protocol.input_angles(d)
    assert not np.all(np.diff(np.mod(angles, 2 * np.pi)) > 0)          # the given order is not the phase order
    run = lambda order: device_rows_variants(models, torque=protocol.te_torque_fraction * d.rated_torque,
                                             input_angles=angles, device="cpu", te_order=order)
    phase, given = run("phase"), run("given")
    assert phase.status == given.status == ["ok", "ok"] and phase.exudyn_points == given.exudyn_points == 0
    assert np.max(np.abs(phase.te - given.te)) * ARCSEC_PER_RAD <= 1e-9
    assert phase.stats["sweeps"] < given.stats["sweeps"]
    ref = variant_figures(d, sample_variant(tol, d, 4, RD_SEED), protocol, regularization=RD_KW["regularization"])
    assert abs(np.ptp(phase.te[0]) * ARCSEC_PER_RAD - ref["te_pp_arcsec"]) <= 1e-6
    with pytest.raises(RvtoolInputError, match="te_order"):
        device_rows_variants(models, torque=1.0, input_angles=angles, te_order="sorted")


def test_rv_points_in_crank_phase_take_the_oracles_branch():
    """RV-40E Monte Carlo variant 148 (cases/rv/monte_carlo_rv.py's seed) over one crank revolution at
    37 points: the crank phase is the input angle times the kinematics' crank_rate (-0.322), so the
    phase order is the order given (the input angle modulo 2 pi, the order before, interleaved the
    points three ways). At point 18 the variant has two equilibria (the sun--crank 0 mesh's force
    jumps 8 % where a contact passes from the flank to the rounded tip edge: two states 1.4e-6 rad of
    crank 0 apart); the interleaved order landed on the other one, 2.3e-3 arcsec off the Exudyn
    reference run (the GPU run of record at c4aad5b), which marches the points as given. TE equal to
    the oracle's within 1e-6 arcsec at every point (issue 31; measured 2.9e-8)."""
    from rvtool import build
    from rvtool.batched.device_rows_variants import te_point_order
    from rvtool.protocols.precision import quasi_static_te
    from rvtool.variants.rv_tolerances import load_rv_tolerances, sample_rv_design
    d = load_design(designs.path("rv40e"))
    tol = load_rv_tolerances(designs.path("rv40e_tolerances"))
    seed, k = 20261124, 148                                   # cases/rv/monte_carlo_rv.py's seed
    models = [s for _, s, _ in variant_snapshots([(d, tol, seed, k, {})])]
    rate = models[0].kinematics.crank_rate
    assert abs(rate + 0.3223140495867777) < 1e-12             # the cranks turn slower than the input
    angles = np.arange(37) * 2 * np.pi / abs(rate) / 37
    assert np.array_equal(te_point_order(models, angles), np.arange(37))
    dev = device_rows_variants(models, torque=d.rated_torque, input_angles=angles, device="cpu")
    assert dev.status == ["ok"] and dev.exudyn_points == 0
    ref = quasi_static_te(build(sample_rv_design(tol, d, k, seed)[0]), torque=d.rated_torque, input_angles=angles,
                          backend="exudyn")["te"]
    assert np.max(np.abs(dev.te[0] - ref)) * ARCSEC_PER_RAD <= 1e-6
