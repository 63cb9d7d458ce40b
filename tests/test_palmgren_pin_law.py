"""pin_contact.law = "palmgren" (issue 28): Palmgren's steel line contact as the force law F = k delta^(10/9) over
the wheel width, with no reference load."""
import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.assembly.cycloid import pin_meshes
from rvtool.contact.cycloid_set import PALMGREN_EXPONENT, palmgren_line_approach, palmgren_line_coefficient
from rvtool.errors import RvtoolInputError


@pytest.mark.parametrize("length", [0.008, 0.015, 0.030])
def test_coefficient_inverts_palmgren_approach(length):
    # F = k delta^(10/9) with delta = 3.84e-5 F^0.9 / L^0.8 (mm, N): round-off only (1e-12)
    F = np.array([1.0, 50.0, 1500.0, 2.0e4])
    delta = palmgren_line_approach(F, length)
    np.testing.assert_allclose(palmgren_line_coefficient(length) * delta ** PALMGREN_EXPONENT, F, rtol=1e-12)


def test_coefficient_by_hand():
    # L = 10 mm: delta [m] = 3.84e-8 F^0.9 / 10^0.8 -> k = (10^0.8 / 3.84e-8)^(10/9)
    assert palmgren_line_coefficient(0.010) == pytest.approx((10 ** 0.8 / 3.84e-8) ** (10 / 9), rel=1e-14)
    with pytest.raises(RvtoolInputError):
        palmgren_line_coefficient(0.0)


def test_rv80e_pin_law_is_palmgren_over_its_wheel_width():
    d = rvtool.load_design(designs.path("rv80e"))
    _, meshes = pin_meshes(d)
    for m in meshes:
        assert m.normal.exponent == pytest.approx(10 / 9, rel=1e-15)
        assert m.normal.stiffness == pytest.approx(palmgren_line_coefficient(d.wheels.width), rel=1e-15)
    # a wider wheel is stiffer by (L'/L)^(0.8 * 10/9): the law follows the width, no stored reference load
    wide = d.replace(wheels={"width": 2 * d.wheels.width})
    _, mw = pin_meshes(wide)
    assert mw[0].normal.stiffness / meshes[0].normal.stiffness == pytest.approx(2 ** (0.8 * 10 / 9), rel=1e-12)


def test_unknown_law_names_the_key():
    d = rvtool.load_design(designs.path("rv80e"))
    with pytest.raises(RvtoolInputError, match="pin_contact.law"):
        d.replace(pin_contact={"law": "hertz"})
