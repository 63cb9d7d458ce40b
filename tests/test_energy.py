"""Energy account of the accepted-step driver (rvtool.observe.energy).

Reference: for the trapezoidal member of the generalized-alpha family
(rho_inf = 1, alpha_m = alpha_f = 1/2, gamma = 1/2, beta = 1/4) and linear
forces, the discrete equations of motion conserve
T + V - W_drive - W_load + D exactly when every work term is integrated as
1/2 (f_n + f_{n+1}) . (q_{n+1} - q_n), the rule the account uses; only the
Newton residual r (|r| <= abs_tol) does unaccounted work, at most
abs_tol |Delta q|_1 per step. With rho_inf < 1 the algorithm dissipates, and
the residual is that (positive) dissipation.
"""
import importlib.util
import os

import numpy as np
import pytest

pytest.importorskip("exudyn")

import exudyn as exu  # noqa: E402
from exudyn.itemInterface import (CoordinateConstraint, CoordinateSpringDamper, LoadCoordinate,  # noqa: E402
                                  MarkerNodeCoordinate, Node1D, NodeGenericODE2, NodePointGround, ObjectGenericODE2,
                                  ObjectMass1D, ObjectConnectorSpringDamper, MarkerNodePosition, NodePoint2D,
                                  ObjectMassPoint2D)

from rvtool.errors import RvtoolInputError  # noqa: E402
from rvtool.observe.energy import ContactEnergyLaw, EnergyAccount  # noqa: E402
from rvtool.solver import RunSpec, simulate  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ABS_TOL = 1e-10


def _small_system():
    """Drive x_d = A sin^3(w t) (zero initial velocity and acceleration, so the initial state
    is consistent) -- spring-damper -- mass m1 with a load F0 sin(w2 t) -- spring -- a 2-dof
    structure (GenericODE2 with M, K, D)."""
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ng = mbs.AddNode(NodePointGround())
    mg = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
    nd = mbs.AddNode(Node1D(referenceCoordinates=[0.0]))
    mbs.AddObject(ObjectMass1D(nodeNumber=nd, mass=0.3))
    md = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nd, coordinate=0))
    n1 = mbs.AddNode(Node1D(referenceCoordinates=[0.0]))
    mbs.AddObject(ObjectMass1D(nodeNumber=n1, mass=1.0))
    m1 = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=n1, coordinate=0))
    ns = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0, 0.0], initialCoordinates=[0.0, 0.0],
                                     initialCoordinates_t=[0.0, 0.0], numberOfODE2Coordinates=2))
    K = np.array([[3e3, -1e3], [-1e3, 2e3]])
    mbs.AddObject(ObjectGenericODE2(nodeNumbers=[ns], massMatrix=np.diag([0.5, 0.2]), stiffnessMatrix=K,
                                    dampingMatrix=0.002 * K))
    ms = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ns, coordinate=0))
    A, w = 0.01, 2 * np.pi * 3.0
    mbs.AddObject(CoordinateConstraint(markerNumbers=[mg, md],
                                       offsetUserFunction=lambda mbs_, t, i, off: A * np.sin(w * t) ** 3))
    mbs.AddObject(CoordinateSpringDamper(markerNumbers=[md, m1], stiffness=4e3, damping=5.0))
    mbs.AddObject(CoordinateSpringDamper(markerNumbers=[m1, ms], stiffness=2e3, damping=0.0, offset=0.0))
    mbs.AddLoad(LoadCoordinate(markerNumber=m1, load=0.0, loadUserFunction=lambda mbs_, t, load: 20.0 * np.sin(11.0 * t)))
    mbs.Assemble()
    return mbs


def _run(rho):
    mbs = _small_system()
    account = EnergyAccount(mbs)
    rec = simulate(mbs, RunSpec(end_time=0.5, step=1e-3, spectral_radius=rho, abs_tol=ABS_TOL, rel_tol=1e-12),
                   energy=account)
    return rec


def test_energy_identity_is_exact_for_the_trapezoidal_rule():
    rec = _run(1.0)
    e = rec.energy
    # every term is present: the check would not see a missing one otherwise
    assert abs(e["drive_work_J"]) > 1e-3 and abs(e["load_work_J"]) > 1e-3
    assert e["damping_dissipation_J"]["springs"] > 0 and e["damping_dissipation_J"]["structure"] > 0
    assert e["elastic_end_J"]["structure"] > 0 and e["kinetic_end_J"] > 0
    # Newton residual bound: abs_tol * |Delta q|_1 per step; |Delta q|_1 <= 4 coordinates * 0.05 m
    bound = rec.accepted_steps * ABS_TOL * 4 * 0.05
    assert abs(e["balance_residual_J"]) <= bound, e


def test_residual_is_the_algorithmic_dissipation_for_rho_below_one():
    e08 = _run(0.8).energy
    e10 = _run(1.0).energy
    # numerical damping removes energy the account does not attribute: r > 0, far above rho = 1
    assert e08["balance_residual_J"] > 0
    assert e08["balance_residual_J"] > 1e3 * abs(e10["balance_residual_J"])


def _jenkins():
    spec = importlib.util.spec_from_file_location("verify_jenkins", os.path.join(ROOT, "cases", "verification", "verify_jenkins.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_account_leaves_the_run_unchanged_and_off_computes_nothing():
    from exudyn_user_elements.scenes import jenkins_element
    runs = []
    for with_energy in (False, True):
        SC, mbs, el, items = jenkins_element(frequency=0.1, dwell=0.025)
        states = []
        account = EnergyAccount(mbs, [el]) if with_energy else None
        rec = simulate(mbs, RunSpec(end_time=3.0, step=0.025, abs_tol=1e-6, rel_tol=1e-8), [el], energy=account,
                       before_accept=lambda t, q, v: states.append(np.concatenate([[t], q, v])))
        runs.append((rec, np.array(states), el.n_evaluations))
    (off, s_off, n_off), (on, s_on, n_on) = runs
    assert off.energy is None and on.energy is not None
    np.testing.assert_array_equal(s_off, s_on)  # bitwise: the account only reads
    assert n_on - n_off <= 1  # its one extra evaluation: the initial state (cached thereafter)


def test_contact_family_terms_of_the_jenkins_run():
    mod = _jenkins()
    res = mod.run(quick=True)
    e = res["_detail"]["energy"]
    # the slider dissipates; its normal contact damping barely works (quasi-static normal motion)
    assert e["friction_dissipation_J"]["slider"] > 0.9 * e["drive_work_J"] - e["elastic_end_J"]["springs"] - 1e-3
    assert abs(e["damping_dissipation_J"]["contact/slider"]) < 1e-9 * e["drive_work_J"]
    assert e["elastic_end_J"]["contact_tangential/slider"] > 0


def test_unattributable_items_raise_naming_them():
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    n = mbs.AddNode(NodePoint2D(referenceCoordinates=[0.0, 0.0]))
    mbs.AddObject(ObjectMassPoint2D(nodeNumber=n, physicsMass=1.0))
    ng = mbs.AddNode(NodePointGround())
    mk = [mbs.AddMarker(MarkerNodePosition(nodeNumber=i)) for i in (ng, n)]
    mbs.AddObject(ObjectConnectorSpringDamper(markerNumbers=mk, stiffness=1.0))
    mbs.Assemble()
    with pytest.raises(RvtoolInputError, match="ConnectorSpringDamper"):
        EnergyAccount(mbs)


@pytest.mark.parametrize("change, name", [
    (dict(normal_stiffness=[np.nan]), "normal_stiffness"), (dict(normal_exponent=[0.5]), "normal_exponent"),
    (dict(tangential_stiffness=[-1.0]), "tangential_stiffness"), (dict(friction_model=[7]), "friction_model"),
    (dict(tangential_stiffness=[0.0]), "tangential_stiffness"),
])
def test_bad_contact_energy_laws_raise_naming_the_parameter(change, name):
    kw = dict(normal_stiffness=[1e10], normal_exponent=[1.5], tangential_stiffness=[1e6], friction_model=[2]) | change
    with pytest.raises(RvtoolInputError, match=name):
        ContactEnergyLaw(**kw)
