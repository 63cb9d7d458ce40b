"""The TE peak-to-peak's sampling error (rvtool analyze's te_pp error): the extrema a grid misses between its
points, estimated from a run at twice the points (rvtool.protocols.precision.peak_to_peak_sampling_error)."""
import numpy as np

from rvtool.protocols.precision import peak_to_peak_sampling_error


def test_a_sine_whose_extrema_fall_between_the_coarse_points():
    """sin over one period at 2 n + 1 points, phased so that its maximum and minimum sit on odd (fine-only)
    points: the estimate is the closed form 2 (1 - cos(pi / n)) (the coarse grid's extreme samples lie half a
    coarse step, 2 pi / (2 n), off the extrema), to round-off."""
    n = 12
    t = np.arange(2 * n + 1) / (2 * n)
    fine = np.sin(2 * np.pi * t + np.pi / 2 - 2 * np.pi / (2 * n))   # maximum at fine index 1
    assert np.isclose(peak_to_peak_sampling_error(fine), 2 * (1 - np.cos(np.pi / n)), rtol=1e-12)


def test_extrema_on_common_points_give_zero_and_never_negative():
    fine = np.array([0.0, 0.4, 1.0, 0.2, -1.0, -0.5, 0.0])      # extrema at even (common) indices
    assert peak_to_peak_sampling_error(fine) == 0.0
    rng = np.random.default_rng(1)
    assert all(peak_to_peak_sampling_error(rng.normal(size=25)) >= 0.0 for _ in range(50))
