"""Mode bases for floating flexible bodies (wheels, cranks) in a floating frame of reference.

Two bases on the node-interleaved coordinates of an unsupported parent (the
layout of ``exudyn.FEM.FEMinterface``), for ``ObjectFFRFreducedOrder``:

* ``frame_vertices=None``: free-free elastic modes, mass-normalized, the six
  rigid-body modes excluded (the frame carries them);
* ``frame_vertices`` given (e.g. the bore that carries a bearing): the frame
  follows those vertices (zero displacement relative to the frame); the basis is
  the Craig--Bampton basis of Eq. (cb_reduction) with the frame vertices held,
  static constraint modes of ``boundary_vertices`` (the contact ports) and
  ``n_modes`` fixed-interface modes, so the static response to loads at the ports
  is exact in the frame.
"""
import numpy as np
import scipy.sparse.linalg as spla

from ..errors import RvtoolInputError
from .craig_bampton import craig_bampton_matrices, factorize

RIGID_MODES = 6
RIGID_SEPARATION = 1e-6
"""A free body's six rigid eigenvalues must lie below this fraction of the first elastic one
(they are round-off, ~1e-12 relative); otherwise the body is supported or a mechanism."""


def floating_basis(model, *, n_modes, frame_vertices=None, boundary_vertices=()):
    """dict(matrix=(3 nv, m), type, eigenvalues [rad^2/s^2]) for :func:`add_floating_flexible_body`."""
    if len(model.clamped_vertices) or model.n_dofs != 3 * len(model.vertices):
        raise RvtoolInputError("a floating body needs an unsupported model (no clamps); got "
                               f"{len(model.clamped_vertices)} clamped vertices")
    if not isinstance(n_modes, (int, np.integer)) or n_modes < 0:
        raise RvtoolInputError(f"n_modes = {n_modes!r} is outside the valid range [0, inf) (integer)")
    K, M = model.elastic_stiffness, model.mass
    n = model.n_dofs
    if frame_vertices is None:
        if n_modes < 1:
            raise RvtoolInputError("n_modes = 0: a free-free basis needs at least one elastic mode (valid [1, inf))")
        # K is singular for a free body: shift-invert about a negative shift, where K - sigma M is positive definite
        scale = float(np.max(K.diagonal() / M.diagonal()))
        sigma = -1e-6 * scale
        # the shifted operator factorized once with the symmetric ordering of craig_bampton.factorize
        # (ARPACK's default SuperLU options took ~4x longer on a 16k-coordinate wheel, measured)
        lu = factorize((K - sigma * M).tocsc(), "K - sigma M")
        op = spla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
        lam, vec = spla.eigsh(K.tocsc(), k=n_modes + RIGID_MODES, M=M.tocsc(), sigma=sigma, which="LM", OPinv=op)
        order = np.argsort(lam)
        lam, vec = lam[order], vec[:, order]
        if np.max(np.abs(lam[:RIGID_MODES])) > RIGID_SEPARATION * lam[RIGID_MODES]:
            raise RvtoolInputError(f"the model does not have six rigid-body modes (eigenvalues "
                                   f"{lam[:RIGID_MODES + 1].tolist()}); a floating body must be free")
        lam, vec = lam[RIGID_MODES:], vec[:, RIGID_MODES:]
        vec = vec / np.sqrt(np.einsum("ij,ij->j", vec, M @ vec))
        return {"matrix": vec, "type": "NormalModes", "eigenvalues": lam}
    frame = np.concatenate([3 * int(v) + np.arange(3) for v in np.atleast_1d(frame_vertices)])
    free = np.setdiff1d(np.arange(n), frame)
    position = np.full(n, -1)
    position[free] = np.arange(len(free))
    b_full = (np.concatenate([3 * int(v) + np.arange(3) for v in np.atleast_1d(boundary_vertices)])
              if len(boundary_vertices) else np.zeros(0, int))
    if np.any(position[b_full] < 0):
        raise RvtoolInputError("boundary_vertices overlap frame_vertices; a port cannot lie on the frame")
    Kf, Mf = K[free][:, free], M[free][:, free]
    _, _, _, T, hz = craig_bampton_matrices(Kf, Mf, 0 * Kf, position[b_full], n_modes)
    basis = np.zeros((n, T.shape[1]))
    basis[free] = T
    return {"matrix": basis, "type": "HCBmodes", "eigenvalues": (2 * np.pi * hz) ** 2}
