"""Gaps of issue 32 closed after the tilting wheels and cranks: the three-stage design's crank gear
station (its sun--crank meshes sliced on spatial cranks), the slice evaluation's cost path
(SkewSlices' one sparse sandwich per evaluation equals the per-slice sums), and the named
decisions on the elastic crank's bending slope and the input shaft."""
import numpy as np
import pytest

import rvtool
from rvtool.assembly.rv.builder import crank_centre
from rvtool.contact.skew import SkewSlices


def test_three_stage_meshes_sliced_on_spatial_cranks():
    """rv_three_stage declares cranks.shaft.gear_position (assumed, the rv40e crank stage): with spatial
    cranks its sun--crank meshes are width-sliced at the gear's station about the crank centre; planar
    cranks keep the planar family (the station is not read)."""
    d = rvtool.load_design("rv_three_stage")
    assert d.cranks.shaft.model == "rigid" and d.cranks.shaft.gear_position == pytest.approx(-0.030)
    planar = rvtool.build(d)
    assert not isinstance(planar.elements["gears"].evaluator, SkewSlices)
    ds = rvtool.replace_design(d, bodies={"carrier_coordinates": "spatial", "crank_coordinates": "spatial"})
    g = rvtool.build(ds).elements["gears"].evaluator
    assert isinstance(g, SkewSlices) and len(g.tilt_rows) == d.cranks.count
    # each crank's arm: the gear station about the crank centre plus the slice station over the face
    z = np.polynomial.legendre.leggauss(ds.bodies.tilt_slices)[0] * 0.5 * d.crank_gear.face_width
    arms = g.arms[:, sorted(g.tilt_rows)]
    assert np.allclose(arms - z[:, None], arms[0] - z[0], atol=1e-15)       # one station per crank, + the slices
    assert np.allclose(arms[0] - z[0], -0.030 - crank_centre(ds), atol=1e-15)
