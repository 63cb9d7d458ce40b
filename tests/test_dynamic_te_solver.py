"""The dynamic TE protocol's solver switch (issue 19): ``dynamic_te(..., solver="exudyn" | "fused" |
"auto")``. The fused stepper against Exudyn through the protocol on the same built model and
RunSpec; auto's choice; named errors for models and settings the fused stepper does not run; the
check that a built model equals what the fused path rebuilds from its design."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly.cycloid import build
from rvtool.assembly.spec import load_design
from rvtool.errors import RvtoolInputError
from rvtool.model.reducer import Family
from rvtool.protocols.precision import dynamic_te
from rvtool.solver import RunSpec
from rvtool.solver.device_dynamics import fused_support
from rvtool.units import ARCSEC_PER_RAD

STEP = 2e-5
N_STEPS = 100


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("rd40"))


@pytest.fixture(scope="module")
def model(design):
    return build(design)


def _spec(n=N_STEPS, **kw):
    return RunSpec(end_time=n * STEP, step=STEP, abs_tol=1e-6, rel_tol=1e-8, **kw)


def _run(model, design, solver, n=N_STEPS, **kw):
    return dynamic_te(model, torque=design.rated_torque, speed_rpm=design.input_speed_rpm, duration=n * STEP,
                      run_spec=_spec(n), solver=solver, **kw)


def test_fused_and_auto_match_exudyn(model, design):
    """RD-40 (lumped bearings, rigid housing, frictionless), rated torque, 1500 rpm, 100 steps of
    20 us, the same built model and RunSpec through the three choices. auto picks the fused
    stepper. The fused and Exudyn runs are the same integrator (warp_contacts.fused_step_ref) with
    the same Newton test, so the step sequences and Newton counts are equal and the TE differs by
    the Newton tolerance only: abs_tol 1e-6 N over the pin stiffness ~2.6e8 N/m is 4e-15 m, 8e-14
    rad (1.6e-8 arcsec) of output angle at the 50 mm pin circle per step, 1.6e-6 arcsec over 100
    steps if every step's error added up (measured 5.5e-11). The static starts (device Newton vs
    StaticSolver) are converged to 1e-9 relative or better and enter the TE only through
    theta - theta_0."""
    exu = _run(model, design, "exudyn")
    fused = _run(model, design, "fused", device="cpu")
    auto = _run(model, design, "auto")
    assert (exu["solver"], fused["solver"], auto["solver"]) == ("exudyn", "fused", "fused")
    assert set(exu) - {"solver"} <= set(fused)          # the Exudyn result's structure, plus the fused extras
    for r in (fused, auto):
        assert len(r["t"]) == len(exu["t"]) == N_STEPS + 1
        np.testing.assert_allclose(r["t"], exu["t"], rtol=0, atol=1e-15)
        assert r["record"].newton_iterations == exu["record"].newton_iterations
        assert np.max(np.abs(r["te"] - exu["te"])) * ARCSEC_PER_RAD < 1.6e-6
        assert np.max(np.abs(r["te_uniform"] - exu["te_uniform"])) * ARCSEC_PER_RAD < 1.6e-6
    # the TE is not trivially zero: the comparison above resolves it (p-p ~4 arcsec over 100 steps)
    assert np.ptp(exu["te"]) * ARCSEC_PER_RAD > 1.0


@pytest.mark.parametrize("device", ["cuda:0"])
def test_fused_switch_on_cuda(model, design, device):
    """The switch's device argument: the fused run on a GPU against Exudyn (the CPU run is the
    test above); same step sequence, same tolerance (the kernel is the same code; summation order
    and the dense solve are per thread as on the CPU)."""
    import warp as wp
    wp.init()
    if wp.get_cuda_device_count() == 0:
        pytest.skip(f"{device} not present")
    exu = _run(model, design, "exudyn")
    fused = _run(model, design, "fused", device=device)
    assert fused["solver"] == "fused" and fused["device_run"].accepted[0] == exu["record"].accepted_steps
    assert np.max(np.abs(fused["te"] - exu["te"])) * ARCSEC_PER_RAD < 1.6e-6


def test_auto_runs_exudyn_for_a_rolling_bearing_model(design):
    """Rolling-element bearings are outside the fused set: auto runs Exudyn and says why."""
    rolling = build(design, bearing_model="rolling")
    r = _run(rolling, design, "auto", n=3)
    assert r["solver"] == "exudyn" and len(r["t"]) == 4
    assert any("bearing_model='lumped'" in s for s in r["solver_reasons"])


def test_fused_on_ineligible_models_is_named(design):
    """solver='fused' on a model neither of its paths runs names why (the fused stepper's reasons
    and the row stepper's) and the valid choices (no run starts). A model only the row stepper
    takes (rolling elements, RV) is not refused: it runs there, the path named."""
    from rvtool.assembly import rv
    from rvtool.solver.backends import FusedBackend
    locked = build(design, rigid_supports=True)
    with pytest.raises(RvtoolInputError, match=r"backend = 'fused'.*fused stepper: rigid_supports=True.*"
                                               r"row stepper: rigid_supports=True \(journal locks\).*Valid choices"):
        _run(locked, design, "fused")
    rolling = build(design, bearing_model="rolling")
    rv_model = rv.build(load_design(designs.path("rv40e")))
    for m in (rolling, rv_model):
        assert not fused_support(m).eligible and FusedBackend().path(m) == ("row_stepper", [])
    with pytest.raises(RvtoolInputError, match=r"solver = 'gpu' is not one of the valid choices"):
        _run(rolling, design, "gpu")


def test_fused_on_rolling_elements_runs_the_row_stepper(design):
    """RD-40 with rolling-element bearings (outside the fused stepper's copy parameters) through
    solver='fused': the row stepper, the same accepted steps as Exudyn's, TE equal to issue 31's
    1e-6 arcsec (the same integrator on the same kernels' rows)."""
    rolling = build(design, bearing_model="rolling")
    exu = _run(build(design, bearing_model="rolling"), design, "exudyn", n=10)
    fused = _run(rolling, design, "fused", n=10)
    assert fused["solver"] == "fused" and fused["stats"]["path"] == "row_stepper"
    np.testing.assert_array_equal(fused["t"], exu["t"])
    assert np.max(np.abs(fused["te"] - exu["te"])) * ARCSEC_PER_RAD <= 1e-6


def test_fused_support_checks_the_model_against_its_design(design, model):
    """The fused path rebuilds the model from model.design: build options outside the design, run
    settings it does not have and model changes after the build are each named; the nominal
    model is eligible and its rebuilt pin rows are the model's, bit for bit."""
    ok = fused_support(model, _spec())
    assert ok.eligible and np.array_equal(ok.params.pin_f[0], model.pin_set.fparams)
    cases = [(build(design, rigid_supports=True), _spec(), "rigid_supports"),
             (build(design, precision="float32"), _spec(), "precision = 'float32'"),
             (model, _spec(newton_mode="modified"), "run_spec.newton_mode"),
             (model, _spec(adaptive=False), "run_spec.adaptive")]
    for m, spec, key in cases:
        reasons = fused_support(m, spec).reasons
        assert any(key in s for s in reasons), (key, reasons)
    shifted = build(design)
    first = next(iter(shifted.gap_offsets(Family.PINS)))
    shifted.set_gap_offsets(Family.PINS, {first: 1e-6})
    assert any("gap offsets" in s for s in fused_support(shifted).reasons)
    with pytest.raises(RvtoolInputError, match="observers"):
        _run(model, design, "fused", n=2, observers=[object()])
