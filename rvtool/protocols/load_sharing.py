"""Load sharing and torque balance at static states: per-contact peak loads of every family
(topology-neutral) and, for models with floating cranks (RV), the crank load shares over an
input-angle sequence.

Torque balance (frictionless statics). Along a static equilibrium path under a constant load
torque T the virtual work of the drive and the load equals the change of the stored elastic
energy U: T_in d(theta_in) - T d(theta_out) = dU with theta_out = theta_in / i + TE(theta_in),
so i T_in / T - 1 = i TE' + i U' / T, whose mean over a period of the meshes is zero. The
pointwise relative error |T - i T_in| / T is the energy-rate term (small, nonzero); its mean
over a periodic interval is zero up to the solver tolerance and the sampling. Signs: T_out =
sign(i) T is the output torque in the sense of the output coordinate, T_in the drive torque.
"""
import time

import numpy as np

from ..solver.static import StaticSolver


def contact_peaks(model, q, peaks=None):
    """{family value: largest normal force per physical contact [N]} at the static state q
    (slices and laminae summed per pin, tooth pair, roller or ball); merged into ``peaks``."""
    peaks = {} if peaks is None else peaks
    for fam in model.families:
        _, f = model.observe(q, fam).per_contact()
        peaks[fam.value] = max(peaks.get(fam.value, 0.0), float(np.max(f)))
    return peaks


def torque_balance_term(model, q, torque):
    """(i T_in - T_out) / T at the static state q under the load ``torque`` [N m] resisting the nominal
    output rotation: T_out = sign(i) T is the torque the output delivers in the sense of its coordinate,
    T_in the drive torque on the input rotation (frictionless: zero for a rigid mechanism)."""
    return (model.ratio * model.input_torque(q) - np.sign(model.ratio) * torque) / torque


def torque_balance_error(model, q, torque):
    """|T_out - i T_in| / T at the static state q (see :func:`torque_balance_term`)."""
    return abs(torque_balance_term(model, q, torque))


def crank_sharing_sequence(model, *, torque, input_angles, solver=None):
    """Equilibria at ``input_angles`` [rad] under output torque ``torque`` [N m] (resisting the
    nominal output rotation), warm-started: per point the crank load shares, the crank torques
    about the carrier axis [N m], the signed torque-balance term (i T_in - T_out) / T, the eccentric
    bearing resultants [N] and the per-contact family peaks. Returns a dict of arrays."""
    solver = solver or StaticSolver(model)
    model.set_output_torque(-np.sign(model.ratio) * torque)
    shares, torques, balance, ecc = [], [], [], []
    peaks = {}
    prev = None
    t0 = time.perf_counter()
    for a in input_angles:
        q = solver.solve(a, prev)
        prev = solver.last_angle
        shares.append(model.crank_load_share(q))
        torques.append(model.crank_torques(q))
        balance.append(torque_balance_term(model, q, torque))
        ecc.append(list(model.eccentric_bearing_resultants(q).values()))
        contact_peaks(model, q, peaks)
    return {"input_angle": np.asarray(input_angles, float), "share": np.array(shares), "crank_torque_Nm": np.array(torques),
            "torque_balance": np.array(balance), "eccentric_bearing_N": np.array(ecc),
            "eccentric_bearing_names": list(model.eccentric_bearing_resultants(q).keys()), "peaks_N": peaks,
            "wall_s": time.perf_counter() - t0, "stats": solver.stats.to_dict(), "q_last": q}
