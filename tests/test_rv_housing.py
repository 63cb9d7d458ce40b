"""RV ring pins on the ported elastic housing (issue 16 Deliver 2: "rigid ring or the ported
housing"): the switch, the statics through the housing and its share of the stiffness budget."""
import numpy as np
import pytest

from rvtool import designs
from rvtool.assembly import build
from rvtool.assembly.rv import load_design
from rvtool.errors import RvtoolInputError
from rvtool.protocols.budget import stiffness_budget
from rvtool.protocols.load_sharing import torque_balance_error
from rvtool.solver.static import StaticSolver

# a coarse housing mesh (8 mm tetrahedra) keeps the reduction to seconds; the mechanism, not the figure
COARSE = {"model": "ports", "structure": {"mesh_size": 0.008}}


@pytest.fixture(scope="module")
def design():
    return load_design(designs.path("rv40e"))


@pytest.fixture(scope="module")
def rated(design):
    out = {}
    for key, d in (("rigid", design), ("ported", design.replace(housing=COARSE))):
        m = build(d)
        m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
        out[key] = (m, StaticSolver(m).solve(0.0))
    return out


def test_housing_errors_name_their_keys(design):
    with pytest.raises(RvtoolInputError, match=r"housing.structure.inner_radius = 0.06 m cuts through the ring pins"):
        design.replace(housing={"model": "ports", "structure": {"inner_radius": 0.06}})
    with pytest.raises(RvtoolInputError, match=r"housing.structure.n_ports = 12; valid value pins.n_pins = 40"):
        design.replace(housing={"model": "ports", "structure": {"n_ports": 12}})
    with pytest.raises(RvtoolInputError, match=r"housing.model = 'elastic'"):
        design.replace(housing={"model": "elastic"})
    with pytest.raises(RvtoolInputError, match=r"pins.support.model = 'simply_supported'.*not implemented for the RV"):
        build(design.replace(pins={"support": {"model": "simply_supported", "ends": [-0.02, 0.02]}}))


def test_ported_ring_statics(rated):
    mr, qr = rated["rigid"]
    mp, qp = rated["ported"]
    assert mr.housing is None and not mr.structures
    assert set(mp.structures) == {"housing"} and mp.housing is mp.structures["housing"]
    T = mp.design.rated_torque
    # the housing is a reaction path: the frictionless torque balance |T_out - i T_in| / T_out is the
    # pointwise energy-rate term (rvtool.protocols.load_sharing) as on the rigid ring: measured 1.8e-5
    # (rigid) and 1.1e-5 (ported) at this state, up to 3.3e-3 over the rigid ring's TE sequence;
    # bound 1e-3 (a housing force outside the balance would show at the level of its share, 0.2)
    assert torque_balance_error(mr, qr, T) < 1e-3
    assert torque_balance_error(mp, qp, T) < 1e-3
    # the ring yields under the pin forces: the ports move by microns, the carrier turns further
    # (a compliance in series), and the pins' loads change with the ring's deformation
    u = mp.housing.port_displacements().reshape(-1, 2)
    assert 1e-7 < np.linalg.norm(u, axis=1).max() < 2e-5
    th_r = qr[mr.output_index] - mr.kinematic_output(0.0)
    th_p = qp[mp.output_index] - mp.kinematic_output(0.0)
    assert abs(th_p) > abs(th_r)
    # the housing carries the summed pin forces into its mounts: eta is the static response of
    # K_eta eta = H^T f (the pins element's generalized force on eta balances the structure)
    el = mp.elements["pins"]
    ix = mp.housing.coordinate_indices()
    f_eta = el.evaluation_at(qp).Q[np.searchsorted(el.coordinate_indices, ix)]
    eta = qp[ix]
    K = mp.housing.stiffness()
    assert np.abs(K @ eta - f_eta).max() < 1e-6 * np.abs(f_eta).max()


def test_budget_with_the_ported_housing(rated):
    mr, qr = rated["rigid"]
    mp, qp = rated["ported"]
    br, bp = stiffness_budget(mr, qr), stiffness_budget(mp, qp)
    assert "housing_ports" not in br["shares"]
    s = bp["shares"]
    assert sum(s.values()) == pytest.approx(1.0, abs=1e-12)
    # the rows and the housing's strain energy carry the output compliance up to the geometric
    # stiffness and the regularization (measured 6e-4 at the 5 mm mesh; bound 1e-2)
    assert abs(s["geometric_and_regularization"]) < 1e-2
    assert s["housing_ports"] > 0.05
    # a structure in series: its share is the tangent compliance it adds (measured K_t 560 -> 428
    # N m/arcmin at this mesh; the shares of the other paths scale by (1 - share))
    assert bp["K_t_Nm_per_arcmin"] == pytest.approx(br["K_t_Nm_per_arcmin"] * (1 - s["housing_ports"]), rel=0.05)
    # Rayleigh: the energy share equals the compliance's sensitivity to the housing's stiffness
    # (central differences, 1e-5), bound 1e-4
    assert bp["sensitivity_shares"]["housing_ports"] == pytest.approx(s["housing_ports"], abs=1e-4)


def test_condensed_tangent_with_the_housing_matches_a_finite_increment(rated):
    # the assembled K^s carries the housing's own stiffness on eta (rvtool.protocols.stiffness): the
    # condensed tangent then equals dT/dtheta from a central +-0.1 % torque increment on a smooth
    # branch (truncation ~ (dT)^2 curvature and the Newton tolerance on the two angles: measured
    # 3.1e-8, 2.2e-8 on the rigid ring; bound 1e-5 as for RD-40 in tests/test_protocols_mechanical.py).
    # Without the housing's stiffness the tangent was 0.
    from rvtool.protocols.stiffness import tangent_check
    mp, _ = rated["ported"]
    tc = tangent_check(mp, 0.75 * mp.design.rated_torque)
    assert tc["Kt_condensed_Nm_per_arcmin"] > 100.0
    assert tc["rel_diff"] < 1e-5


def test_groove_stiffened_view_on_the_ported_housing(design, rated):
    # the grooves of the ring pins on the housing's port bodies (``rated`` first: the coarse housing's
    # reduction is cached, so this model builds in a fraction of a second). The budget's stiffened view
    # of a closure (SeriesBeam.stiffened) must be the element's tangent in the element's coordinates
    # [q_r; eta]: the closure condenses on its bodies (the port bodies' x, y, theta), which the element
    # contracts with the port map. Uncontracted, the switch-to-rigid and sensitivity views of
    # "pin_grooves" read the port bodies' rows as eta's (sensitivity share 0.227 against the energy
    # share 0.0246 at the 10 mm mesh).
    from rvtool.model import Family
    from rvtool.protocols.stiffness import free_stiffness
    d = design.replace(housing=COARSE, pins={"groove": "conformal", "groove_clearance": 5e-6})
    m = build(d)
    m.set_output_torque(-np.sign(m.ratio) * d.rated_torque)
    q = StaticSolver(m).solve(0.0)
    beam = m.series_compliance(Family.PINS)
    assert beam.path == "pin_grooves"
    el = m.elements["pins"]
    ltg, J1 = beam.stiffened(q, 1.0)
    assert np.array_equal(ltg, el.coordinate_indices)
    # the same closure state and the same contraction: equal to round-off (measured 0.0)
    J = el.evaluation_at(q).dQdq
    assert J1.shape == J.shape and np.abs(J1 - J).max() <= 1e-12 * np.abs(J).max()
    # Rayleigh through the stiffened view: -dC/dlambda / C at lambda = 1 (central differences over
    # 1 +- 1e-4, the budget's step) equals the grooves' energy share (measured 2.8e-8 apart at a share
    # of 0.0245; before the contraction 0.2 apart); bound 1e-5, the differences' round-off
    K, free, i_out = free_stiffness(m, q)
    e = np.zeros(len(free))
    e[i_out] = 1.0
    u = np.linalg.solve(K, e)
    C = u[i_out]
    dq = np.zeros(len(q))
    dq[free] = u
    share = beam.energy(q, dq) / C
    pos = {g: k for k, g in enumerate(free)}
    loc = [k for k, g in enumerate(ltg) if g in pos]
    glob = [pos[ltg[k]] for k in loc]
    assert any(g in pos for g in m.housing.coordinate_indices()) and set(m.housing.coordinate_indices()) <= set(ltg)

    def compliance(factor):
        Kr = K.copy()
        Kr[np.ix_(glob, glob)] -= (beam.stiffened(q, factor)[1] - J1)[np.ix_(loc, loc)]
        return np.linalg.solve(Kr, e)[i_out]
    h = 1e-4
    sensitivity = (compliance(1 - h) - compliance(1 + h)) / (2 * h * C)
    assert 0.005 < share < 0.1
    assert sensitivity == pytest.approx(share, abs=1e-5)
