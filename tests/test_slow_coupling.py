"""Coupling path of Eq. (obs_coupling_path) on a small nonlinear spring
system: a rigid body in the plane held by three Hertzian contacts
F_c = k delta_c^(3/2), delta_c = n_c . q - zeta_c (zeta_c: gap offset,
positive opens), loaded by P. The linear load change from
R_q dq = -R_zeta dzeta must differ from the re-solved equilibrium by
O(dzeta^2): the error ratio is 4 per halving of dzeta, up to the O(dzeta)
relative correction (dzeta / delta <= 1 um / 18 um here, so ratios within 2.5 %
of 4).
"""
import numpy as np
import pytest

from rvtool.errors import RvtoolInputError
from rvtool.slow.coupling import compare_with_resolve, linearized_load_change, solve_equilibrium

K = 1e10                                                   # N / m^1.5
ANGLES = np.radians([-50.0, 10.0, 70.0])
N = np.column_stack([np.cos(ANGLES), np.sin(ANGLES)])      # (3, 2) contact normals (into the supports)
P = np.array([3000.0, 500.0])                              # N


def penetration(q, z):
    return N @ q - z


def forces(q, z):
    return K * np.maximum(penetration(q, z), 0.0) ** 1.5


def stiffness(q, z):
    return 1.5 * K * np.sqrt(np.maximum(penetration(q, z), 0.0))


def residual(q, z):
    return N.T @ forces(q, z) - P


def jac_q(q, z):
    return N.T @ (stiffness(q, z)[:, None] * N)


def jac_zeta(q, z):
    return -(N.T * stiffness(q, z))


def forces_q(q, z):
    return stiffness(q, z)[:, None] * N


def forces_zeta(q, z):
    return -np.diag(stiffness(q, z))


def _equilibrium():
    z0 = np.zeros(3)
    q0 = solve_equilibrium(residual, jac_q, np.array([2e-5, 2e-6]), z0, tol=1e-15)
    assert np.all(penetration(q0, z0) > 0)                   # all three contacts carry load
    return q0, z0


def test_linear_load_change_converges_at_second_order():
    q0, z0 = _equilibrium()
    errs = []
    for dz in (1e-6, 0.5e-6, 0.25e-6):
        cmp = compare_with_resolve(residual=residual, jacobian_q=jac_q, jacobian_zeta=jac_zeta, forces=forces,
                                   forces_q=forces_q, forces_zeta=forces_zeta, q0=q0, zeta0=z0,
                                   delta_zeta=[0.0, dz, 0.0])
        errs.append(cmp.rel_error)
        # an opened gap unloads its own contact and loads the others (the assembly redistributes)
        assert cmp.dF_nonlinear[1] < 0 and cmp.dF_linear[1] < 0
        # external load is unchanged: the load changes balance
        np.testing.assert_allclose(N.T @ cmp.dF_nonlinear, 0.0, atol=1e-9 * np.abs(forces(q0, z0)).max())
        np.testing.assert_allclose(N.T @ cmp.dF_linear, 0.0, atol=1e-9 * np.abs(forces(q0, z0)).max())
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all(np.abs(ratios - 4.0) < 0.1), ratios      # measured 3.981, 3.991


def test_named_errors():
    q0, z0 = _equilibrium()
    with pytest.raises(RvtoolInputError, match="q0 is not an equilibrium"):
        compare_with_resolve(residual=residual, jacobian_q=jac_q, jacobian_zeta=jac_zeta, forces=forces,
                             forces_q=forces_q, forces_zeta=forces_zeta, q0=q0 * 1.01, zeta0=z0,
                             delta_zeta=[0.0, 1e-6, 0.0])
    with pytest.raises(RvtoolInputError, match="R_q is singular"):
        linearized_load_change(np.zeros((2, 2)), np.zeros((2, 1)), np.zeros((1, 2)), np.zeros((1, 1)), [1e-6])
    with pytest.raises(RvtoolInputError, match="R_zeta must have shape"):
        linearized_load_change(np.eye(2), np.zeros((3, 1)), np.zeros((1, 2)), np.zeros((1, 1)), [1e-6])
