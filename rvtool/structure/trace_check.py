"""Linear trace contacts between a common planar translation and structural ports, and the
work / tangent consistency check of Appendix "Reproducing the structural port comparison".

Trace j measures the difference between the common translation c = (c_x, c_y, 0)
(the first two integrated coordinates) and the displacement u_j of port j along
the nominal radial direction n_j = (cos theta_j, sin theta_j, 0):

    g_j = n_j^T (c - u_j) = a_j^T q_e,   V = 1/2 sum_j k_j g_j^2,
    Q_e = -sum_j k_j a_j a_j^T q_e,     J_e = dQ_e/dq_e = -sum_j k_j a_j a_j^T,

in the expanded coordinates q_e = T_e q_s of Eq. (port_runtime_transform). The
check compares (a) the reduced virtual work delta q_s^T T_e^T Q_e with a central
difference of the energy evaluated from the physical traces n_j^T (c - H_j eta)
(exact for a quadratic energy, so only round-off remains), and (b) the
contracted tangent T_e^T J_e T_e with the tangent assembled from the transformed
trace vectors T_e^T a_j (Eq. supp_port_transform).
"""
from dataclasses import dataclass

import numpy as np

from ..errors import RvtoolInputError
from .port_map import expanded_map, reduce_force, reduce_tangent

N_RIGID = 2   # the two auxiliary common translations (c_x, c_y)


@dataclass(frozen=True)
class LinearTraces:
    """normals (n_ports, 3) [-]; stiffness (n_ports,) [N/m]; port_rows: expanded-vector rows of
    each port's (x, y, z) components; n_expanded: length of q_e."""
    normals: np.ndarray
    stiffness: np.ndarray
    port_rows: tuple
    n_expanded: int

    def trace_vectors(self):
        """A (n_ports, n_expanded), one row a_j per trace."""
        A = np.zeros((len(self.stiffness), self.n_expanded))
        for j, (n, rows) in enumerate(zip(self.normals, self.port_rows)):
            A[j, :N_RIGID] = n[:N_RIGID]
            A[j, rows] = -n
        return A

    def force(self, q_e):
        """Q_e = -A^T diag(k) A q_e [N]."""
        A = self.trace_vectors()
        return -A.T @ (self.stiffness * (A @ q_e))

    def tangent(self):
        """J_e = dQ_e/dq_e [N/m] (constant)."""
        A = self.trace_vectors()
        return -(A.T * self.stiffness) @ A


def radial_traces(maps, port_rows, angles, stiffness):
    """Traces for a reduced model: maps H (n_rows, n_eta), port_rows of H per port (3 rows each),
    angles theta_j [rad], stiffness k_j [N/m]; expanded layout [c_x, c_y, eta, u]."""
    angles = np.asarray(angles, float)
    if len(angles) != len(port_rows) or np.shape(stiffness) != angles.shape:
        raise RvtoolInputError(f"angles ({len(angles)}), stiffness ({np.size(stiffness)}) and port_rows "
                               f"({len(port_rows)}) must have equal lengths")
    n_eta = maps.shape[1]
    offset = N_RIGID + n_eta
    normals = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    return LinearTraces(normals=normals, stiffness=np.asarray(stiffness, float),
                        port_rows=tuple(offset + np.asarray(r) for r in port_rows),
                        n_expanded=offset + maps.shape[0])


def trace_consistency(maps, port_rows, angles, stiffness, *, displacement=1e-6, perturbation=1e-3, seed=0):
    """Virtual-work and tangent relative errors of the linear trace check.

    The state has common translations and port displacements of order ``displacement`` [m];
    the perturbation direction is drawn like the state and scaled by ``perturbation`` [-].
    Returns dict(virtual_work_rel_err, tangent_rel_err, virtual_work_J).
    """
    H = np.asarray(maps, float)
    traces = radial_traces(H, port_rows, angles, stiffness)
    T = expanded_map(N_RIGID, H)
    rng = np.random.default_rng(seed)

    def state():
        eta = rng.standard_normal(H.shape[1])
        eta *= displacement / np.max(np.abs(H @ eta))
        return np.concatenate([displacement * rng.standard_normal(N_RIGID), eta])

    q_s, dq = state(), perturbation * state()
    dW = dq @ reduce_force(T, traces.force(T @ q_s))

    def energy(q):   # physical traces, not through T_e
        c, eta = np.append(q[:N_RIGID], 0.0), q[N_RIGID:]
        g = np.array([n @ (c - H[rows] @ eta) for n, rows in zip(traces.normals, port_rows)])
        return 0.5 * np.sum(traces.stiffness * g * g)

    dW_ref = -(energy(q_s + dq) - energy(q_s - dq)) / 2.0
    J_contracted = reduce_tangent(T, traces.tangent())
    B = traces.trace_vectors() @ T                            # rows (T_e^T a_j)^T
    J_transformed = -(B.T * traces.stiffness) @ B
    return {"virtual_work_rel_err": abs(dW - dW_ref) / abs(dW_ref),
            "tangent_rel_err": np.linalg.norm(J_contracted - J_transformed) / np.linalg.norm(J_transformed),
            "virtual_work_J": dW}
