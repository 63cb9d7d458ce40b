"""Runtime map between integrated and expanded contact coordinates (Eq. port_runtime_transform).

Integrated coordinates q_s = [q_r; eta] (rigid-body coordinates, then structural
coordinates); the expanded workspace q_e = T_e q_s appends the physical port
displacements u = H eta:

    T_e = [I; B],  B = [0, H],  Q_s = T_e^T Q_e,  J_s = T_e^T J_e T_e.

T_e is constant, so the contracted tangent is exact and keeps the rigid--port and
port--port cross blocks of J_e. The workspace adds no unknowns. Pure NumPy: the
Exudyn element in ``exudyn_user_elements.reduced_structure`` only calls these.
"""
import numpy as np

from ..errors import RvtoolInputError


def expanded_map(n_rigid, maps):
    """T_e (n_rigid + n_eta + n_port_rows, n_rigid + n_eta) for port maps H (n_port_rows, n_eta)."""
    if not isinstance(n_rigid, (int, np.integer)) or n_rigid < 0:
        raise RvtoolInputError(f"n_rigid = {n_rigid!r} is outside the valid range [0, inf) (integer)")
    H = np.asarray(maps, float)
    ns = n_rigid + H.shape[1]
    T = np.zeros((ns + H.shape[0], ns))
    T[:ns] = np.eye(ns)
    T[ns:, n_rigid:] = H
    return T


def expand(T_e, q_s):
    """q_e = T_e q_s (also for velocities)."""
    return T_e @ q_s


def reduce_force(T_e, Q_e):
    """Q_s = T_e^T Q_e (work-conjugate generalized force)."""
    return T_e.T @ Q_e


def reduce_tangent(T_e, J_e):
    """J_s = T_e^T J_e T_e (all cross blocks kept)."""
    return T_e.T @ J_e @ T_e
