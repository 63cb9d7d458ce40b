"""Vibration in the matched re-runs: the driven run leaves the static protocols bit for bit as they
were, its figures enter the changes and their attribution, and its mounting is checked."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.model import Family
from rvtool.slow.rerun import VIBRATION_FIGURES, MatchedProtocol, figure_changes, run_matched

DESIGN = load_design(designs.path("rd40"))
T = DESIGN.rated_torque


def _protocol(model, **kw):
    mesh = model.mesh_period
    return MatchedProtocol(torque=T, te_angles=tuple(np.arange(8) * mesh / 2), output_revolutions=4 / 39 / 40 * 2,
                           lost_motion_torque=0.03 * T, rated_torque=T, stiffness_fractions=(0.5, 1.0), **kw)


def test_vibration_run_restores_the_static_protocols_and_reports_its_changes():
    m = build(DESIGN)
    static = _protocol(m)
    vib = _protocol(m, vibration_revolutions=0.1, vibration_speed_rpm=DESIGN.input_speed_rpm)
    a = run_matched(m, static)
    b = run_matched(m, vib)
    c = run_matched(m, static)
    for k in ("te_pp_arcsec", "lost_motion_arcmin", "K_Nm_per_arcmin"):
        assert a[k] == b[k] == c[k]                     # the driven run changed nothing of the static model
    assert b["vibration_rejected_steps"] == 0 and b["vibration_accepted_steps"] >= 0.1 * 60 / 1500 / 2e-5
    assert 0 < b["torsion_pp_arcsec"] < 100
    # a bearing clearance change moves the vibration figures; the changes carry them
    names = m.observe(np.zeros(m.mbs.systemData.ODE2Size()), Family.ECCENTRIC_BEARINGS).per_contact()[0]
    m.set_gap_offsets(Family.ECCENTRIC_BEARINGS, {n: 2e-6 for n in names})
    d = run_matched(m, vib)
    ch = figure_changes(b, d)
    assert set(VIBRATION_FIGURES) <= set(ch)
    assert ch["torsion_pp_arcsec"] != 0.0
    assert set(figure_changes(a, c)) == {"te_pp_arcsec", "te_rms_arcsec", "lost_motion_arcmin", "K_Nm_per_arcmin"}


def test_vibration_protocol_inputs():
    m = build(DESIGN)
    with pytest.raises(RvtoolInputError, match="input_angle"):
        _protocol(m, input_angle=0.1, vibration_revolutions=0.1, vibration_speed_rpm=1500.0)
    with pytest.raises(RvtoolInputError, match="vibration_speed_rpm"):
        _protocol(m, vibration_revolutions=0.1)
    with pytest.raises(RvtoolInputError, match="vibration_revolutions"):
        _protocol(m, vibration_revolutions=-1.0, vibration_speed_rpm=1500.0)
