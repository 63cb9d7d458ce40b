"""Static load distribution of tapered roller bearings, solved with the
5-DOF wrench and analytic tangent of the tapered-roller family, and the
classical references it is checked against.

Sjoevall's integrals (Harris & Kotzalas, *Rolling Bearing Analysis*, 5th ed.,
vol. 1, ch. 7): a row with contact angle alpha under radial and axial load,
approach delta_psi = delta_r cos(alpha) cos(psi) + delta_a sin(alpha) on
azimuth psi, load Q_psi = Q_max [1 - (1 - cos psi) / (2 epsilon)]^n with
epsilon = (1 + delta_a tan(alpha) / delta_r) / 2 and n = 10/9 for line contact:

    F_r = Z Q_max J_r(epsilon) cos(alpha),  F_a = Z Q_max J_a(epsilon) sin(alpha),
    J_r = 1/(2 pi) int_{-psi_l}^{psi_l} [1 - (1 - cos psi)/(2 epsilon)]^n cos(psi) dpsi,
    J_a = 1/(2 pi) int_{-psi_l}^{psi_l} [1 - (1 - cos psi)/(2 epsilon)]^n dpsi,

psi_l = arccos(1 - 2 epsilon) for epsilon <= 1 and pi beyond (every roller loaded).
"""
import math

import numpy as np

from ..errors import RvtoolInputError, SolverFailure
from ..validation import check_positive
from .tapered_set import TaperedBearingSet

#: exponent of Palmgren's line-contact law
LINE_CONTACT_EXPONENT = 10.0 / 9.0


def sjovall_integrals(epsilon, exponent=LINE_CONTACT_EXPONENT):
    """(J_r(epsilon), J_a(epsilon)) by adaptive quadrature for epsilon > 0."""
    from scipy.integrate import quad
    check_positive("epsilon", epsilon)
    psi_l = math.acos(1 - 2 * epsilon) if epsilon <= 1 else math.pi

    def load(p):
        return max(1 - (1 - math.cos(p)) / (2 * epsilon), 0.0) ** exponent

    # the integrands are even: integrate over [0, psi_l] with the kink of the loaded-zone edge at the end
    jr = quad(lambda p: load(p) * math.cos(p), 0.0, psi_l, epsabs=1e-13, epsrel=1e-11, limit=200)[0]
    ja = quad(load, 0.0, psi_l, epsabs=1e-13, epsrel=1e-11, limit=200)[0]
    return jr / math.pi, ja / math.pi


def epsilon_from_loads(radial_load, axial_load, contact_angle, exponent=LINE_CONTACT_EXPONENT):
    """epsilon of Sjoevall's distribution for F_r tan(alpha) / F_a = J_r / J_a (root in (0, 1e3))."""
    from scipy.optimize import brentq
    check_positive("radial_load", radial_load)
    check_positive("axial_load", axial_load)
    target = radial_load * math.tan(contact_angle) / axial_load

    def residual(eps):
        jr, ja = sjovall_integrals(eps, exponent)
        return jr / ja - target
    # J_r / J_a falls from 1 (epsilon -> 0) to 0 (pure axial): one root, where it exists
    if target >= 1.0:
        raise RvtoolInputError(f"F_r tan(alpha) / F_a = {target} is outside the valid range (0, 1): the row "
                               "cannot carry that radial load with so little axial load")
    return brentq(residual, 1e-6, 1e3, xtol=1e-14, rtol=1e-13)


def static_equilibrium(bearing_set, load, *, free=(0, 1, 2, 3, 4), q0=None, cage_angle=0.0, tol=1e-11,
                       max_iterations=80):
    """Relative displacement q (5,) of the cone of the single mounting of ``bearing_set`` at which its
    wrench balances the external ``load`` (5,) on the cone (F_x, F_y, F_z, M_x, M_y about the
    mounting centre): W(q) + load = 0 in the ``free`` components, the others held at ``q0``.

    Newton's method with the analytic tangent and residual-halving backtracking; a tangent that
    is singular at the start (no roller loaded) is regularised by the smallest positive diagonal.
    Returns (q, RelativeEvaluation, iterations, |R| / |load|).
    """
    if not isinstance(bearing_set, TaperedBearingSet) or len(bearing_set.mountings) != 1:
        raise RvtoolInputError("bearing_set must be a TaperedBearingSet with exactly one mounting")
    load = np.asarray(load, float)
    free = np.asarray(free, int)
    scale = float(np.linalg.norm(load)) or 1.0
    q = np.zeros(5) if q0 is None else np.array(q0, float)
    ca = np.array([cage_angle])

    def residual(x):
        ev = bearing_set.relative(x[None], cage_angle=ca)
        return ev.wrench[0] + load, ev
    R, ev = residual(q)
    for it in range(max_iterations + 1):
        rel = float(np.linalg.norm(R[free]) / scale)
        if rel < tol:
            return q, ev, it, rel
        if it == max_iterations:
            break
        K = ev.stiffness[0][np.ix_(free, free)]
        d = np.abs(np.diag(K))
        if np.min(d) <= 1e-12 * max(np.max(d), 1.0):
            K = K - np.diag(np.where(d > 0, 0.0, max(np.max(d), 1e6)))
        step = np.linalg.solve(K, -R[free])
        t = 1.0
        while t > 1e-8:
            trial = q.copy()
            trial[free] += t * step
            Rt, evt = residual(trial)
            if np.linalg.norm(Rt[free]) < np.linalg.norm(R[free]):
                break
            t *= 0.5
        q, R, ev = trial, Rt, evt
    raise SolverFailure(f"static_equilibrium: no equilibrium for load = {load.tolist()} after {max_iterations} Newton "
                        f"iterations (|R|/|load| = {rel:.2e})")
