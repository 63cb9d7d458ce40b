"""Static structural operators (Section "Static operators and their physical boundaries").

* :class:`SupportedCompliance`: C_b = P_f K_f^{-1} P_f^T (Eq. body_compliance), by
  back-substitution on one stored sparse factorization of the supported K_f;
* :class:`InertiaReliefCompliance`: a free body; the stiffness is bordered by the
  mass-weighted rigid modes, [[K, M R], [R^T M, 0]] [u; lambda] = [f; 0], so that the
  multiplier balances the rigid component of f and R^T M u = 0 (deformation relative
  to the mass-weighted rigid frame; not a clamped bore);
* :func:`condense_ports`: C_{t|h} = C_tt - C_th C_hh^{-1} C_ht with the declared
  support ports held (Eq. port_condensation);
* :class:`DelayedOffsetFeedback`: the relaxed, delayed quasistatic offset update
  u_{k+1} = (1 - omega) u_k + omega C(f_k), 0 < omega <= 1 (Eq. weak_coupling),
  applied after accepted steps and constant within a mechanical trial.
"""
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import RvtoolInputError
from ..validation import check_range
from .craig_bampton import factorize
from .definiteness import GROUNDING_TOLERANCE, require_grounded, require_symmetric


class SupportedCompliance:
    """Factorized supported stiffness K_f with port projection P_f (Eq. body_compliance).

    stiffness: sparse K_f [N/m] on the free coordinates (supports included);
    port_matrix: sparse or dense P_f (n_rows, n); rigid_modes: optional (n, k) rigid fields
    for the grounding check (an unsupported K_f raises instead of returning garbage).
    """

    def __init__(self, stiffness, port_matrix, *, rigid_modes=None, grounding_tolerance=GROUNDING_TOLERANCE):
        require_symmetric("K_f", stiffness)
        if rigid_modes is not None:
            self.grounding_ratio = require_grounded("K_f", stiffness, rigid_modes, grounding_tolerance)
        self.port_matrix = sp.csr_matrix(port_matrix)
        self._lu = factorize(stiffness, "K_f")

    def solve(self, f):
        """u = K_f^{-1} f by back-substitution [m] (f [N], one column or several)."""
        return self._lu.solve(np.asarray(f, float))

    def compliance(self, port_matrix=None):
        """Dense P K_f^{-1} P^T [m/N] (default P: the stored port matrix)."""
        P = self.port_matrix if port_matrix is None else sp.csr_matrix(port_matrix)
        C = P @ self.solve(P.T.toarray())
        return 0.5 * (C + C.T)


class InertiaReliefCompliance:
    """Inertia-relief compliance of a free body.

    stiffness K [N/m] and mass M [kg] (sparse, free-free); rigid_modes R (n, k), e.g.
    ``FEModel.rigid_body_modes()``; port_matrix P optional.
    """

    def __init__(self, stiffness, mass, rigid_modes, port_matrix=None):
        require_symmetric("K", stiffness)
        R = np.asarray(rigid_modes, float)
        self.rigid_modes = R
        self.mass_weighted = np.asarray(mass @ R)                 # M R
        G = sp.csr_matrix(self.mass_weighted)
        k = R.shape[1]
        A = sp.bmat([[sp.csr_matrix(stiffness), G], [G.T, None]], format="csc")
        # the bordered matrix is symmetric indefinite and nonsingular exactly when R spans the
        # kernel of K and R^T M R is positive definite
        self._n = stiffness.shape[0]
        self._k = k
        self._lu = factorize(A, "inertia-relief system [[K, M R], [R^T M, 0]]")
        self.port_matrix = None if port_matrix is None else sp.csr_matrix(port_matrix)

    def solve(self, f):
        """(u [m], lambda) for load f [N]: K u + M R lambda = f and R^T M u = 0."""
        f = np.asarray(f, float)
        rhs = np.concatenate([f, np.zeros((self._k,) + f.shape[1:])])
        x = self._lu.solve(rhs)
        return x[:self._n], x[self._n:]

    def compliance(self, port_matrix=None):
        """Dense P u(P^T) [m/N]: the relative deformation at the ports per unit port load."""
        P = self.port_matrix if port_matrix is None else sp.csr_matrix(port_matrix)
        if P is None:
            raise RvtoolInputError("port_matrix is None; give the ports to project on")
        u, _ = self.solve(P.T.toarray())
        C = P @ u
        return 0.5 * (C + C.T)


def condense_ports(C, keep, held):
    """C_{t|h} = C_tt - C_th C_hh^{-1} C_ht (Eq. port_condensation) [m/N].

    C: port compliance (Eq. multiport_body); keep, held: row indices of the kept (t) and held
    (h) port components; C_hh must be positive definite (held ports that are independent).
    """
    C = np.asarray(C, float)
    keep, held = np.asarray(keep, int), np.asarray(held, int)
    if np.intersect1d(keep, held).size:
        raise RvtoolInputError(f"keep and held share rows {np.intersect1d(keep, held)[:4].tolist()}; they must be disjoint")
    Chh = C[np.ix_(held, held)]
    try:
        cf = sla.cho_factor(Chh)
    except np.linalg.LinAlgError:
        raise RvtoolInputError("C_hh of the held ports is not positive definite; the held components must be "
                               "independent (nonsingular constrained subspace)") from None
    Ct = C[np.ix_(keep, keep)] - C[np.ix_(keep, held)] @ sla.cho_solve(cf, C[np.ix_(held, keep)])
    return 0.5 * (Ct + Ct.T)


def relaxed_offset_update(offset, response, relaxation):
    """(1 - omega) u_k + omega C(f_k) of Eq. (weak_coupling) [m]; ``response`` = C(f_k)."""
    check_range("relaxation", relaxation, 0.0, 1.0, low_open=True)
    return (1.0 - relaxation) * np.asarray(offset, float) + relaxation * np.asarray(response, float)


@dataclass(frozen=True, kw_only=True)
class OffsetFeedbackSpec:
    """relaxation: omega of Eq. (weak_coupling), in (0, 1]; interval: accepted steps per update (>= 1)."""
    relaxation: float = 1.0
    interval: int = 1

    def __post_init__(self):
        check_range("relaxation", self.relaxation, 0.0, 1.0, low_open=True)
        if not isinstance(self.interval, (int, np.integer)) or self.interval < 1:
            raise RvtoolInputError(f"interval = {self.interval!r} is outside the valid range [1, inf) (integer)")


class DelayedOffsetFeedback:
    """Quasistatic offsets u^off updated from accepted-step forces (Eq. weak_coupling).

    compliance: matrix C [m/N] or callable f -> u; spec: :class:`OffsetFeedbackSpec`;
    initial: starting offsets [m] (default zero). The offsets carry no inertia and stay
    fixed between updates, i.e. within every Newton trial of a step.
    """

    def __init__(self, compliance, spec: OffsetFeedbackSpec, n, initial=None):
        self._apply = compliance if callable(compliance) else (lambda f, C=np.asarray(compliance, float): C @ f)
        self.spec = spec
        self.offset = np.zeros(n) if initial is None else np.array(initial, float)
        self.accepted_steps = 0
        self.updates = 0

    def on_accepted_step(self, force):
        """Count one accepted step; every ``interval`` steps relax toward C(force). Returns the offsets."""
        self.accepted_steps += 1
        if self.accepted_steps % self.spec.interval == 0:
            self.offset = relaxed_offset_update(self.offset, self._apply(np.asarray(force, float)), self.spec.relaxation)
            self.updates += 1
        return self.offset
