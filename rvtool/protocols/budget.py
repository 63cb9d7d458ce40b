"""Stiffness and lost-motion budgets (issue 21): which compliance and which clearance the
output rotation owes what. Topology-neutral: only the :class:`~rvtool.model.ReducerModel`
interface (``observe``, ``contact_elements``, ``series_compliance``, ``clearance_variants``,
``refined_design``).

**Stiffness budget.** At a static state q, the free-coordinate tangent K (Eq.
obs_condensed_stiffness, :func:`~rvtool.protocols.stiffness.free_stiffness`) and a unit output
torque give the condensed mode u = K^-1 e_theta, whose output component is the output
compliance C = 1/K_t. Each observed contact row r (a slice, a lamina, a ball) has an approach
delta_r = -gap_r and a normal force F_r; central differences of both along every free coordinate
give its approach Jacobian G_r and its normal stiffness k_r = (dF_r . G_r)/(G_r . G_r). A family's
elastic tangent is K_f = sum_r k_r G_r G_r^T, and its share of the output compliance is its strain
energy in the mode, u^T K_f u / C (the shares of springs in series are their compliance
fractions; Euler's theorem for a network homogeneous in its stiffnesses makes the energy shares
sum to one). The beams of elastic pins (``series_compliance``: one member or a tuple of members of the family,
e.g. the nested wheel bodies and pin grooves) are closed per pin with their full
station compliance (:mod:`rvtool.contact.pin_closure`): the rows observe the contact approach
only, and the beams' energy is sum_p du_p^T K_b du_p over the station deflections du_p along the
mode (K_b = C^-1; equal to f_p^T C f_p with f_p the increments of the station resultants,
including the turn of the forces' directions). An elastic structure of the model (a ported
housing, ``model.structures``) carries eta^T K_eta eta in the mode, the path ``housing_ports``.
What the rows and beams do not carry (the regularization springs and the
geometric stiffness of loaded contacts whose normals turn, F_r d^2 delta_r/dq^2) is the entry
``geometric_and_regularization``, so that the shares sum to one exactly.
The second view switches each family to rigid in turn: K' = K + (lambda - 1) K_f with
lambda = 1e6, and its share is (C - C'_f)/C; a family's beams likewise, by condensing the pins
with lambda K_b at the same state. For families in series along the torque path the
two views agree; a family that also positions other bodies (the bearings carrying the wheels)
loses, when rigid, the relaxation it permits elsewhere, and its rigid share differs from its
energy share by that coupling; both are reported with their difference. The two views meet in the
limit of a small switch: stiffening a path by (1 + epsilon) lowers the output compliance by
epsilon times its energy share (dC/dlambda = -u^T K_f u, Rayleigh), reported as
``sensitivity_shares``, which equal the energy shares up to the step's error. For the beams this is
a check of the decomposition against the element's own condensed tangent; the finite switch then
differs from it only by the load redistribution a rigid path causes.

**Lost-motion budget.** Lost motion at +-``fraction`` of the rated torque (spring control,
:func:`~rvtool.protocols.lost_motion.lost_motion`) with every clearance of
``model.clearance_variants()`` removed is the ``elastic`` part; the clearances are then restored
one at a time in the declared order, and each one's contribution is the increase it causes (the
contributions sum to the lost motion of the design exactly). Beside each, its closed-form
kinematic estimate from the model. It builds one model per clearance state, so it is a study:
:func:`rvtool.analysis.budget.lost_motion_budget`.
"""
import numpy as np

from ..units import RAD_PER_ARCMIN
from .stiffness import free_stiffness

RIGID_FACTOR = 1e6
"""lambda of the switch-to-rigid view (1e6 times a family's stiffness leaves 1e-6 of its compliance)."""

SENSITIVITY_STEP = 1e-4
"""epsilon of the infinitesimal switch: -(dC/dlambda)/C at lambda = 1 by central differences over
1 +- epsilon (truncation O(epsilon^2) = 1e-8; round-off of the two solves, ~1e-9 of C for RD-40's
tangent, over 2 epsilon: 1e-5)."""


def row_jacobians(model, q, free, step=1e-9):
    """{family value: (G (rows, n_free) approach Jacobian [m per m or rad], dF (rows, n_free) [N per
    m or rad], F (rows,) [N])} by central differences of the observations along each free coordinate
    (step [m or rad]: 1e-9 is 1e-3 of a typical contact approach at rated load, where the laws are
    smooth, and 1e7 times the round-off of the approaches)."""
    fams = list(model.families)
    base = {f.value: model.observe(q, f) for f in fams}
    G = {f.value: np.zeros((len(base[f.value].ids), len(free))) for f in fams}
    dF = {f.value: np.zeros_like(G[f.value]) for f in fams}
    # a coordinate outside a family's element leaves its rows unchanged (zero columns, not evaluated); the
    # families at +step first, then at -step, so that families sharing an element (a nested closure) reuse
    # its cached evaluation of that state
    coords = {f.value: set(int(c) for c in model.family_rows(f)[0].coordinate_indices) for f in fams}
    for j, i in enumerate(free):
        active = [f for f in fams if int(i) in coords[f.value]]
        if not active:
            continue
        qp, qm = q.copy(), q.copy()
        qp[i] += step
        qm[i] -= step
        op = {f: model.observe(qp, f) for f in active}
        om = {f: model.observe(qm, f) for f in active}
        for f in active:
            G[f.value][:, j] = -(op[f].obs[:, 2] - om[f].obs[:, 2]) / (2 * step)     # approach = -gap (O_GAP = 2)
            dF[f.value][:, j] = (op[f].normal_force - om[f].normal_force) / (2 * step)
    return {f: (G[f], dF[f], base[f].normal_force) for f in G}


def stiffness_budget(model, q):
    """Budget of the output compliance at the static state q (module docstring). Returns
    ``shares`` (path -> energy share, summing to one), ``rigid_shares`` (family -> (C - C'_f)/C),
    ``K_t_Nm_per_arcmin`` and the residual entry's meaning."""
    K, free, i_out = free_stiffness(model, q)
    e = np.zeros(len(free))
    e[i_out] = 1.0
    u = np.linalg.solve(K, e)
    C = float(u[i_out])
    rows = row_jacobians(model, q, free)
    shares, rigid, sens = {}, {}, {}
    for fam, (G, dF, F) in rows.items():
        gg = np.einsum("rj,rj->r", G, G)
        act = (gg > 0) & (F > 0)
        k = np.where(act, np.einsum("rj,rj->r", dF, G) / np.where(act, gg, 1.0), 0.0)
        dd = G @ u                                           # approach increments in the mode
        energy = float(np.sum(k * dd * dd))
        Kf = (G * k[:, None]).T @ G
        Cr = float(np.linalg.solve(K + (RIGID_FACTOR - 1.0) * Kf, e)[i_out])
        rigid[fam] = (C - Cr) / C
        cp, cm = (float(np.linalg.solve(K + s * SENSITIVITY_STEP * Kf, e)[i_out]) for s in (1.0, -1.0))
        sens[fam] = (cm - cp) / (2 * SENSITIVITY_STEP * C)
        beams = model.series_compliance(fam)
        for beam in (() if beams is None else beams if isinstance(beams, tuple) else (beams,)):
            dq = np.zeros(len(q))
            dq[free] = u
            shares[beam.path] = beam.energy(q, dq) / C
            rigid[beam.path] = (C - _stiffened_compliance(model, q, K, free, e, i_out, beam, RIGID_FACTOR)) / C
            cp, cm = (_stiffened_compliance(model, q, K, free, e, i_out, beam, 1.0 + s * SENSITIVITY_STEP)
                      for s in (1.0, -1.0))
            sens[beam.path] = (cm - cp) / (2 * SENSITIVITY_STEP * C)
        shares[fam] = energy / C
    for name, st in model.structures.items():
        # an elastic structure's coordinates eta (a ported housing): its strain energy in the mode
        # and its switch to rigid, as for a family (K_f = its own stiffness on eta)
        pos = {g: k for k, g in enumerate(free)}
        ix = [pos[g] for g in st.coordinate_indices()]
        Ks = np.zeros_like(K)
        Ks[np.ix_(ix, ix)] = st.stiffness()
        path = f"{name}_ports"
        shares[path] = float(u @ Ks @ u) / C
        rigid[path] = (C - float(np.linalg.solve(K + (RIGID_FACTOR - 1.0) * Ks, e)[i_out])) / C
        cp, cm = (float(np.linalg.solve(K + s * SENSITIVITY_STEP * Ks, e)[i_out]) for s in (1.0, -1.0))
        sens[path] = (cm - cp) / (2 * SENSITIVITY_STEP * C)
    shares["geometric_and_regularization"] = 1.0 - sum(shares.values())
    return {"shares": shares, "rigid_shares": rigid, "sensitivity_shares": sens, "K_t_Nm_per_arcmin": RAD_PER_ARCMIN / C,
            "residual": "geometric stiffness of loaded contacts and regularization springs (what the "
                        "rows' normal stiffness and the beams do not carry)"}


def _stiffened_compliance(model, q, K, free, e, i_out, beam, factor):
    """Output compliance with the beams of ``beam`` stiffened by ``factor`` at state q: the
    element's tangent replaced by its condensation with factor x K_b (module docstring)."""
    ltg, dQ_rigid = beam.stiffened(q, factor)
    _, dQ = beam.stiffened(q, 1.0)
    pos = {g: k for k, g in enumerate(free)}
    loc = [k for k, g in enumerate(ltg) if g in pos]
    glob = [pos[ltg[k]] for k in loc]
    Kr = K.copy()
    Kr[np.ix_(glob, glob)] -= (dQ_rigid - dQ)[np.ix_(loc, loc)]   # K^s = -dQ/dq
    return float(np.linalg.solve(Kr, e)[i_out])
