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
