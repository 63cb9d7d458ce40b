"""What the flexible-body tests share (tests/test_flexible_dynamics.py, test_flexible_rv.py,
test_flexible_cranks.py; not a test module): the small bases on a coarse wheel mesh, frozen = rigid,
the element tangent against the linear model, the backends' refusals and a short driven run."""
import numpy as np

import rvtool
from rvtool.assembly.spec import replace
from rvtool.protocols import flexible_modes as F
from rvtool.solver.continuation import Continuation
from rvtool.units import ARCSEC_PER_RAD

COARSE = {"mesh_size": 0.006, "samples_per_tooth": 4}
"""A coarse wheel body (issue 30's mesh) for short tests."""
STEP = 2e-5
"""Driven-run step [s], as the cases'."""


def flexible_wheels(design, **kw):
    """``design`` with flexible wheels: 4 modes, static orders 0-1, the coarse mesh (``kw`` into [wheels.dynamics])."""
    return replace(design, wheels={"dynamics": {"model": "flexible", "n_modes": 4, "static_orders": 1, **kw},
                                   "structure": COARSE})


def flexible_cranks(design, **kw):
    """``design`` with flexible cranks of 4 modes (``kw`` into [cranks.dynamics])."""
    return replace(design, cranks={"dynamics": {"model": "flexible", "n_modes": 4, **kw}})


def rated_state(model, design):
    """The static state of ``model`` at the rated torque, input angle 0 (by continuation)."""
    return Continuation(model, input_angle=0.0).go_to(-np.sign(model.ratio) * design.rated_torque)


def assert_frozen_is_rigid(design, frozen_design, angles, *, te_abs_arcsec=1e-6, states_rel=1e-9, structure=None):
    """Frozen modal coordinates reproduce the rigid model (quasi-static TE and equilibria at the rated torque
    over ``angles``, on the Exudyn path) within the bounds given, and ``structure``'s coordinates are held.
    Held modal coordinates put the virtual bodies exactly on their bases, so only the larger Newton system's
    round-off and stopping point differ: the golden backends' bounds (TE 1e-6 arcsec, states 1e-9
    relative). Returns the frozen model."""
    rigid = F.te_and_states(rvtool.build(design), design.rated_torque, angles)
    frozen = rvtool.build(frozen_design)
    d = F.frozen_differences(rigid, F.te_and_states(frozen, design.rated_torque, angles))
    assert d["te_max_abs_diff_arcsec"] < te_abs_arcsec, d
    assert d["states_max_rel_diff"] <= states_rel, d
    if structure is not None:
        assert set(frozen.structures[structure].coordinate_indices()) <= frozen.fixed_coordinates()
    return frozen


def assert_tangent_is_the_linear_model(model, q, linear):
    """The contact elements' contracted tangent (what Newton and the stiffness protocols use) and an
    independent assembly ``linear`` = (K, M, free, asymmetry) of rvtool.protocols.flexible_modes are the
    same operator: equal spectra of the symmetric part over the free coordinates, to the round-off of the
    two summation orders relative to the largest eigenvalue (contact stiffness ~1e9)."""
    from rvtool.protocols.stiffness import assembled_stiffness
    K = assembled_stiffness(model, q)
    free = sorted(set(range(len(q))) - set(model.fixed_coordinates()))
    Ke = K[np.ix_(free, free)]
    Kl, _, fl, _ = linear
    Kl = Kl[fl][:, fl]
    Kl = Kl.toarray() if hasattr(Kl, "toarray") else Kl
    ev_e = np.sort(np.linalg.eigvalsh(0.5 * (Ke + Ke.T)))
    ev_l = np.sort(np.linalg.eigvalsh(0.5 * (Kl + Kl.T)))
    assert len(ev_e) == len(ev_l) and np.abs(ev_e - ev_l).max() < 1e-9 * np.abs(ev_e).max()


def assert_backends_refuse(model, tasks):
    """Every backend of ``tasks`` ((name, task), ...) refuses ``model`` naming its flexible bodies."""
    from rvtool.solver.backends import get as get_backend
    from rvtool.solver.backends.base import FLEXIBLE_BODIES_REASON
    for name, task in tasks:
        sup = get_backend(name).supports(model, task)
        assert not sup.ok and any(FLEXIBLE_BODIES_REASON in r for r in sup.reasons), (name, sup.reasons)


def short_driven_run(model, design, steps):
    """A driven run of ``model`` at rated speed and torque over ``steps`` steps: every step accepted, the
    torsion finite. Returns the run."""
    revs = steps * STEP * design.input_speed_rpm / 60.0
    run = F.driven_run(model, design.input_speed_rpm, design.rated_torque, revs, STEP)[0]
    assert run["record"].accepted_steps >= steps
    assert np.all(np.isfinite(run["responses"]["torsion"])) and ARCSEC_PER_RAD > 0
    return run
