"""Admissible load (issue 20): a rated torque beyond the Hertz law's validity or beyond any
equilibrium is an input error raised before anything is written."""
import math
from dataclasses import replace

import pytest

from rvtool.analysis import analyze, load
from rvtool.analysis.admissible import HERTZ_HALF_WIDTH_RATIO, hertz_limit_pressure
from rvtool.errors import RvtoolInputError


def test_hertz_limit_is_the_half_width_bound():
    # Hertz line contact (Johnson, Contact Mechanics, Eq. 4.45): b = 2 sqrt(F' R / (pi E*)),
    # p0 = 2 F' / (pi b). At b = 0.1 R the peak must equal the declared limit (closed form, so
    # only round-off separates them).
    design = load("rd40")[0]
    mat = design.material
    e_star = mat.youngs_modulus / (2 * (1 - mat.poisson_ratio ** 2))
    R = 3e-3
    b = HERTZ_HALF_WIDTH_RATIO * R
    f_line = math.pi * e_star * b ** 2 / (4 * R)
    p0 = 2 * f_line / (math.pi * b)
    assert hertz_limit_pressure(design) == pytest.approx(p0, rel=1e-12)


def test_torque_beyond_hertz_validity_is_an_input_error(tmp_path):
    # 5,000 N m on RD-40 (36 x rated) still equilibrates, but its needle contacts reach ~8.5 GPa,
    # beyond p0 <= 0.05 E* = 5.66 GPa: an input error naming rated_torque with the admissible range
    design = replace(load("rd40")[0], rated_torque=5000.0)
    with pytest.raises(RvtoolInputError, match=r"rated_torque = 5000 N m: the needles contacts reach a Hertz peak") as e:
        analyze(design, "stiffness", quick=True, out_dir=tmp_path / "out")
    limit = float(str(e.value).split("rated_torque <= ")[1].split()[0])
    assert 140.0 < limit < 5000.0
    assert not (tmp_path / "out").exists()
