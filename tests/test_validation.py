"""Input checks: errors name the parameter, its value and the valid range."""
import math

import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.validation import check_choice, check_positive, check_range, check_shape


def test_nan_and_inf_are_rejected_with_the_name():
    with pytest.raises(RvtoolInputError, match="stiffness must not be NaN"):
        check_positive("stiffness", math.nan)
    with pytest.raises(RvtoolInputError, match="stiffness must be finite"):
        check_positive("stiffness", math.inf)
    with pytest.raises(RvtoolInputError, match="radius must be a real number"):
        check_positive("radius", "three")


def test_range_message_gives_bounds():
    with pytest.raises(RvtoolInputError, match=r"rho = 1.5 is outside the valid range \[0.0, 1.0\]"):
        check_range("rho", 1.5, 0.0, 1.0)
    with pytest.raises(RvtoolInputError, match=r"\(0.0, inf\)"):
        check_positive("k", np.array([1.0, -2.0]))
    assert check_range("x", 1.0, 0.0, 1.0) == 1.0


def test_shape_and_choice():
    with pytest.raises(RvtoolInputError, match=r"q must have shape \(N, 3\)"):
        check_shape("q", np.zeros((4, 2)), (None, 3))
    with pytest.raises(RvtoolInputError, match="mode = 'x' is not one of"):
        check_choice("mode", "x", ("a", "b"))


def test_check_range_fast_path_gives_the_array_paths_verdicts():
    """A Python float with Python-number bounds takes check_range's scalar path; the same value
    with a NumPy bound the array path: the same verdict (pass, or the same error) at the bounds
    (open and closed), inside, outside, NaN and inf."""
    import math

    import numpy as np

    from rvtool.errors import RvtoolInputError
    from rvtool.validation import check_range

    def verdict(v, **kw):
        try:
            check_range("x", v, **kw)
            return "ok"
        except RvtoolInputError as exc:
            return str(exc)
    cases = [dict(low=0.0, high=1.0), dict(low=0.0, high=1.0, low_open=True), dict(low=0.0, high=1.0, high_open=True),
             dict(low=-math.inf, high=2.0), dict(low=0.0, high=math.inf, low_open=True)]
    for kw in cases:
        for v in (0.0, 1.0, 0.5, -1e-300, 1.0 + 1e-16, 2.0, 3.0, -math.inf, math.inf, math.nan):
            slow = dict(kw, low=np.float64(kw["low"]))
            assert verdict(v, **kw) == verdict(v, **slow), (v, kw)
    assert verdict(0.5, low=0, high=1) == "ok" and verdict(1.5, low=0, high=1) != "ok"     # integer bounds
