"""Net work of the frictionless cycloid--pin element around a closed path (issue 16: the rv40e
torque-balance drift). A conservative force field does no net work around a closed path; the
discrete profile search represents the profile by the osculating arc of the nearest table
sample, so the gap (the potential k delta^(p+1)/(p+1)) jumps where the nearest sample switches:
by O(kappa' h^3) per switch, with O(1/h) switches per revolution. The net work therefore
converges as h^2 (h the sample spacing) and vanishes with the analytic search (exact profile)."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.rv import load_design

N_PATH = 1000        # points on the path (trapezoidal line integral, error ~ N_PATH^-2)


def closed_path_work(design):
    """Line integral of the pin element's generalized force along the kinematic motion of one
    crank revolution with both wheels turned 3e-5 rad against the pins (rated-level loads: peak
    pin force ~555 N). After one crank revolution each wheel has advanced one tooth and sits
    where it started relative to the pins: for a conservative field the integral is zero."""
    m = build(design)
    el, L = m.elements["pins"], m.layout
    S = 2 * np.pi / abs(m.graph.crank_rate)
    W, prev = 0.0, None
    for a in np.arange(N_PATH + 1) * S / N_PATH:
        P = m.kinematic_state(a).poses.copy()
        P[[L.wheel(0), L.wheel(1)], 2] -= 3e-5
        q = m.body_vector(P - m.reference)
        Q = np.zeros_like(q)
        Q[el.coordinate_indices] = el.evaluation_at(q).Q
        if prev is not None:
            W += 0.5 * (Q + prev[0]) @ (q - prev[1])
        prev = (Q, q)
    return W


@pytest.mark.parametrize("topology", ["rv40e"])
def test_pin_element_work_converges_at_second_order(topology):
    """Measured (1000 points): 0.0511 J (60 samples per tooth), 0.0121 J (120, rv40e's setting;
    the 0.0107 J per revolution of the torque-balance account), analytic search 5.5e-4 J (the
    trapezoidal rule's error: 3.5e-5 J at 4000 points). Asserted: the ratio 60 -> 120 within
    [3, 5.5] (order 2: 4, less the quadrature error common to both), and the analytic search
    below 10 % of the 120-sample work."""
    d = load_design(designs.path(topology))
    w60 = closed_path_work(d.replace(wheels={"samples_per_tooth": 60, "search": "discrete"}))
    w120 = closed_path_work(d.replace(wheels={"samples_per_tooth": 120, "search": "discrete"}))
    wa = closed_path_work(d.replace(wheels={"samples_per_tooth": 120, "search": "analytic"}))
    assert w120 > 0 and 3.0 <= w60 / w120 <= 5.5
    assert abs(wa) < 0.1 * w120
