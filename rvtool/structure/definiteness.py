"""Symmetry, positive-definiteness and grounding checks for structural operators.

A structural block that is not grounded (no supports against some rigid-body
motion) has a stiffness with near-zero eigenvalues; the supported compliance of
Eq. (body_compliance) and the port reduction (Section "Dynamic reduction with a
retained interface map") require positive-definite K and reject it with an
error that names the block, the measured ratio and the valid range.

Tolerances: the rigid-body eigenvalues of an unsupported assembled stiffness
are round-off, |lambda| ~ c eps lambda_max with c up to ~1e3 for the meshes here,
i.e. ratios below ~1e-12; the mounted annulus has ratios ~1e-5 (its 18 mounting
springs against elastic stiffness), so ``GROUNDING_TOLERANCE = 1e-10`` separates
both cases with two decades of margin on either side.
"""
import numpy as np
import scipy.linalg as sla

from ..errors import RvtoolInputError

GROUNDING_TOLERANCE = 1e-10
SYMMETRY_TOLERANCE = 1e-10
"""Relative asymmetry max|A - A^T| / max|A| accepted as round-off of a symmetric assembly."""

_UNGROUNDED_HINT = ("the structure is not grounded against every rigid-body motion: declare supports (springs or "
                    "clamps) or use InertiaReliefCompliance for a free body")


def require_symmetric(name, A, tol=SYMMETRY_TOLERANCE):
    """Raise unless max|A - A^T| <= tol max|A| (dense or sparse)."""
    asym = abs(A - A.T).max()
    scale = abs(A).max()
    if not np.isfinite(asym) or asym > tol * scale:
        raise RvtoolInputError(f"{name} is not symmetric: max|A - A^T| / max|A| = {asym / scale:.3e}; "
                               f"valid range [0, {tol}]")


def require_positive_definite(name, A, reference=None, tol=GROUNDING_TOLERANCE):
    """Check a dense symmetric matrix (or pencil (A, reference)) for positive definiteness.

    Returns the (generalized) eigenvalues and mass-normalized eigenvectors (ascending).
    Raises when the smallest eigenvalue is below ``tol`` times the largest (an ungrounded
    or singular block) or when ``reference`` is not positive definite.
    """
    A = np.asarray(A, float)
    require_symmetric(name, A)
    if reference is not None:
        reference = np.asarray(reference, float)
        require_symmetric(f"mass of {name}", reference)
        try:
            np.linalg.cholesky(reference)
        except np.linalg.LinAlgError:
            raise RvtoolInputError(f"the mass (reference) matrix of {name} is not positive definite") from None
    lam, vec = sla.eigh(A, reference)
    ratio = lam[0] / lam[-1] if lam[-1] > 0 else -np.inf
    if not ratio > tol:
        raise RvtoolInputError(f"{name} is not positive definite: smallest/largest eigenvalue = {ratio:.3e}, "
                               f"valid range ({tol}, 1]; {_UNGROUNDED_HINT}")
    return lam, vec


def grounding_ratio(K, rigid_modes):
    """Smallest rigid-body energy ratio lambda_min(R^T K R, R^T diag(K) R) [-] of a sparse stiffness.

    Zero (round-off) when some rigid motion is unresisted; the diagonal scaling makes it
    independent of units and mesh size.
    """
    R = np.asarray(rigid_modes, float)
    KR = R.T @ (K @ R)
    DR = R.T @ (K.diagonal()[:, None] * R)
    return float(sla.eigvalsh(0.5 * (KR + KR.T), DR)[0])


def require_grounded(name, K, rigid_modes, tol=GROUNDING_TOLERANCE):
    """Raise when a rigid-body motion of ``rigid_modes`` (n, k) is unresisted by ``K``."""
    ratio = grounding_ratio(K, rigid_modes)
    if not ratio > tol:
        raise RvtoolInputError(f"{name} is not grounded: rigid-body energy ratio = {ratio:.3e}, valid range "
                               f"({tol}, 1]; {_UNGROUNDED_HINT}")
    return ratio
