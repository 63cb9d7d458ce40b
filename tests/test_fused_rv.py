"""The fused stepper on RV (issue 31, deliverable 1): not fused yet; its refusal names the topology
and every contact element whose rows the fused kernel lacks (no silent fallback)."""
import pytest

import rvtool
from rvtool.errors import RvtoolInputError
from rvtool.solver.backends import FusedBackend, choose


@pytest.fixture(scope="module")
def rv40e():
    return rvtool.build(rvtool.load_design("rv40e"))


def test_fused_refusal_names_every_unfused_rv_element(rv40e):
    reasons = FusedBackend().supports(rv40e, "dynamic").reasons
    assert reasons[0].startswith("topology RVDesign: the fused stepper runs cycloid reducers only")
    assert "'carrier'" in reasons[0]                  # the bodies it would have to carry
    named = {r.split("'")[1]: r for r in reasons[1:]}
    # RV-40E's sets without fused rows: the involute stage, needle and ball rows, tapered crank bearings
    assert set(named) == {"gears", "eccentric_bearings", "crank_bearings", "main_bearings"}
    assert "InvoluteContactSet" in named["gears"] and "TaperedBearingSet" in named["crank_bearings"]
    # the cycloid pins have fused rows: not named as a missing set type
    assert not any("'pins'" in r for r in reasons[1:])


def test_fused_named_for_rv_raises_with_the_reasons(rv40e):
    with pytest.raises(RvtoolInputError, match=r"fused.*'crank_bearings' \(TaperedBearingSet\)"):
        choose("fused", rv40e, "dynamic")


def test_row_stepper_equals_exudyn_generalized_alpha():
    """rv40e driven run, 12 steps of 2e-5 s at the rated speed and torque: the row stepper (Exudyn's
    generalized-alpha step on the device families' rows, rvtool.solver.row_dynamics) gives
    Exudyn's accepted steps and output angles; TE equal to 1e-6 arcsec (issue 31's bound; the same
    integrator on the same kernels' forces: measured 9e-12 arcsec)."""
    import numpy as np

    from rvtool.protocols.precision import dynamic_te, transmission_error
    from rvtool.solver import RunSpec
    from rvtool.solver.device_dynamics import DeviceDynamicsSettings
    from rvtool.solver.row_dynamics import row_driven_run
    from rvtool.units import ARCSEC_PER_RAD
    d = rvtool.load_design("rv40e")
    spec = RunSpec(end_time=12 * 2e-5, step=2e-5, abs_tol=1e-6, rel_tol=1e-8)
    ex = dynamic_te(rvtool.build(d), torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=spec.end_time,
                    run_spec=spec, solver="exudyn")
    m = rvtool.build(d)
    r = row_driven_run(m, torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=spec.end_time,
                       settings=DeviceDynamicsSettings.from_run_spec(spec))
    assert len(r["t"]) == len(ex["t"]) == 13 and r["rejected"] == 0
    np.testing.assert_array_equal(r["t"], ex["t"])
    te = transmission_error(r["theta_in"], r["theta_out"], m.ratio)
    assert np.max(np.abs(te - ex["te"])) * ARCSEC_PER_RAD <= 1e-6
    # the run moved: the output turned by the kinematic increment (not a frozen state)
    assert abs(r["theta_out"][-1] - r["theta_out"][0]) > 1e-5


@pytest.mark.skipif(not __import__("warp").get_cuda_device_count(), reason="no CUDA device")
def test_row_stepper_on_cuda_equals_exudyn():
    """The same short rv40e run with the families' kernels on cuda:0: TE equal to Exudyn's to 1e-6 arcsec."""
    import numpy as np

    from rvtool.protocols.precision import dynamic_te, transmission_error
    from rvtool.solver import RunSpec
    from rvtool.solver.device_dynamics import DeviceDynamicsSettings
    from rvtool.solver.row_dynamics import row_driven_run
    from rvtool.units import ARCSEC_PER_RAD
    d = rvtool.load_design("rv40e")
    spec = RunSpec(end_time=12 * 2e-5, step=2e-5, abs_tol=1e-6, rel_tol=1e-8)
    ex = dynamic_te(rvtool.build(d), torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=spec.end_time,
                    run_spec=spec, solver="exudyn")
    m = rvtool.build(d)
    r = row_driven_run(m, torque=d.rated_torque, speed_rpm=d.input_speed_rpm, duration=spec.end_time,
                       settings=DeviceDynamicsSettings.from_run_spec(spec), device="cuda:0")
    np.testing.assert_array_equal(r["t"], ex["t"])
    te = transmission_error(r["theta_in"], r["theta_out"], m.ratio)
    assert np.max(np.abs(te - ex["te"])) * ARCSEC_PER_RAD <= 1e-6
