"""Second reduction of a grounded Craig--Bampton parent to structural coordinates with port maps.

Section "Dynamic reduction with a retained interface map":

* the parent eigenproblem K_r Phi_T = M_r Phi_T Omega_T^2 (mass-normalized) is
  solved once for all n_b + n_modes coordinates; K_r must be positive definite
  (an ungrounded block is rejected);
* the first ``n_modes`` parent modes are retained; optional residual attachment
  modes are built from the omitted static port response, Eq.
  (port_residual_flexibility),
  R_p = S_b K_r^{-1} S_b^T - H_T Omega_T^{-2} H_T^T,
  as the static responses to its dominant eigen-directions V minus their
  retained-mode part, psi = (K_r^{-1} - Phi_T Omega_T^{-2} Phi_T^T) S_b^T V. These are
  M- and K-orthogonal to the retained modes, so a Rayleigh--Ritz solve within
  span(psi) yields the final basis Phi with M = I and K = diag(Omega^2) exactly,
  while the retained modes stay exact parent modes; the static port compliance
  gains the rank-r truncation V Lambda V^T of R_p;
* the remaining port-self blocks of R_p after that basis are exported as the
  frequency-independent block-diagonal local correction (offline static
  reconstruction, not part of the runtime dynamics);
* H_g = S_g Phi maps coordinates to the components of port g (Eq.
  port_work_pair: u_g = H_g eta, Q_eta = sum_g H_g^T f_g); the projected damping
  Phi^T C_r Phi is kept as a full matrix.
"""
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..errors import RvtoolInputError
from .definiteness import require_positive_definite


@dataclass(frozen=True, kw_only=True)
class PortReductionSpec:
    """n_modes: retained parent modes; n_residual: residual attachment modes from R_p;
    local_correction: export the port self-blocks of the remaining residual compliance."""
    n_modes: int
    n_residual: int = 0
    local_correction: bool = False

    def __post_init__(self):
        for name in ("n_modes", "n_residual"):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or v < 0:
                raise RvtoolInputError(f"{name} = {v!r} is outside the valid range [0, inf) (integer)")
        if self.n_modes + self.n_residual < 1:
            raise RvtoolInputError("n_modes + n_residual = 0; valid range [1, n_parent]")

    @property
    def label(self):
        s = f"{self.n_modes} modes" if not self.n_residual else f"{self.n_modes} + {self.n_residual} residual"
        return s + (" + local correction" if self.local_correction else "")


@dataclass(frozen=True)
class ParentModes:
    """All modes of the parent: omega2 (n,) [rad^2/s^2] ascending, shapes (n, n) mass-normalized,
    reference port compliance C_ref = S_b K_r^{-1} S_b^T [m/N]."""
    omega2: np.ndarray
    shapes: np.ndarray
    reference_compliance: np.ndarray

    @property
    def hz(self):
        return np.sqrt(self.omega2) / (2 * np.pi)


@dataclass(frozen=True)
class PortReducedModel:
    """Structural coordinates eta with port maps.

    basis Phi (n_parent, n_eta) on the parent coordinates; omega2: diagonal of K_eta
    [rad^2/s^2] (M_eta = I); damping C_eta (n_eta, n_eta) [1/s]; maps H = S_b Phi
    (n_port_rows, n_eta) [m per unit eta]; port_rows: rows of H per port;
    local_correction: (n_ports, k, k) self-blocks [m/N] or None; n_modes, n_residual.
    """
    basis: np.ndarray
    omega2: np.ndarray
    damping: np.ndarray
    maps: np.ndarray
    port_rows: tuple
    local_correction: np.ndarray | None
    n_modes: int
    n_residual: int

    @property
    def n_coordinates(self):
        return len(self.omega2)

    @property
    def stiffness(self):
        """K_eta = diag(Omega^2) [N/m per unit modal mass]."""
        return np.diag(self.omega2)

    @property
    def mass(self):
        return np.eye(self.n_coordinates)

    def port_map(self, g):
        """H_g = S_g Phi of port g."""
        return self.maps[self.port_rows[int(g)]]

    def sampled_maps(self, ports):
        """Stacked H_g of the given ports (one structural basis, any contact resolution)."""
        return np.vstack([self.port_map(g) for g in ports])

    def local_block_matrix(self):
        """Block-diagonal R_local on the stacked port rows (zeros when not exported)."""
        n = self.maps.shape[0]
        R = np.zeros((n, n))
        if self.local_correction is not None:
            for rows, blk in zip(self.port_rows, self.local_correction):
                R[np.ix_(rows, rows)] = blk
        return R

    def static_compliance(self, *, include_local=False):
        """H Omega^{-2} H^T (+ R_local) [m/N] on the stacked port rows."""
        C = (self.maps / self.omega2) @ self.maps.T
        return C + self.local_block_matrix() if include_local else C


def parent_modes(cb) -> ParentModes:
    """Solve K_r Phi = M_r Phi Omega^2 for all parent coordinates (rejects an ungrounded K_r)."""
    lam, vec = require_positive_definite("K_r (Craig-Bampton parent stiffness)", cb.stiffness, cb.mass)
    Sb = cb.port_selector
    C_ref = Sb @ sla.cho_solve(sla.cho_factor(cb.stiffness), Sb.T)
    return ParentModes(omega2=lam, shapes=vec, reference_compliance=0.5 * (C_ref + C_ref.T))


def reduce_ports(cb, spec: PortReductionSpec, modes: ParentModes | None = None) -> PortReducedModel:
    """Port-reduced model of a Craig--Bampton parent (see module docstring)."""
    modes = parent_modes(cb) if modes is None else modes
    n_parent = len(modes.omega2)
    if spec.n_modes > n_parent:
        raise RvtoolInputError(f"n_modes = {spec.n_modes} is outside the valid range [0, {n_parent}]")
    Sb = cb.port_selector
    phi = modes.shapes[:, :spec.n_modes]
    w2 = modes.omega2[:spec.n_modes]
    H = Sb @ phi
    R_p = modes.reference_compliance - (H / w2) @ H.T           # Eq. (port_residual_flexibility)
    R_p = 0.5 * (R_p + R_p.T)
    if spec.n_residual:
        max_res = min(Sb.shape[0], n_parent - spec.n_modes)
        if spec.n_residual > max_res:
            raise RvtoolInputError(f"n_residual = {spec.n_residual} is outside the valid range [0, {max_res}]")
        lam_r, V = np.linalg.eigh(R_p)
        V = V[:, ::-1][:, :spec.n_residual]                     # dominant omitted port-compliance directions
        F = Sb.T @ V
        psi = sla.cho_solve(sla.cho_factor(cb.stiffness), F) - phi @ ((phi.T @ F) / w2[:, None])
        Kp, Mp = psi.T @ cb.stiffness @ psi, psi.T @ cb.mass @ psi
        lam_p, Q = sla.eigh(0.5 * (Kp + Kp.T), 0.5 * (Mp + Mp.T))
        phi = np.hstack([phi, psi @ Q])
        w2 = np.concatenate([w2, lam_p])
        H = Sb @ phi
    local = None
    if spec.local_correction:
        R_rem = modes.reference_compliance - (H / w2) @ H.T
        R_rem = 0.5 * (R_rem + R_rem.T)                          # exported blocks exactly symmetric
        local = np.array([R_rem[np.ix_(rows, rows)] for rows in cb.port_rows])
    Ceta = phi.T @ cb.damping @ phi
    return PortReducedModel(basis=phi, omega2=w2, damping=0.5 * (Ceta + Ceta.T), maps=H,
                            port_rows=tuple(cb.port_rows), local_correction=local,
                            n_modes=spec.n_modes, n_residual=spec.n_residual)
