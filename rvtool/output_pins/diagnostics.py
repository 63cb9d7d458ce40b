"""Checks of the shared-pin reactions and tangent (paper, subsection
"Reaction and tangent consistency" and Appendix "Independent check of the
geometric moment derivative").

* :func:`balance`: total force and total moment about a common origin.
* :func:`central_difference_tangent`: K_q from central differences of the
  production force map (0.5 um translation steps, the paper's choice).
* :func:`complex_step_tangent`: an independent derivative, Im Q(q + i h e_j)/h
  of the NumPy reference force routine (no subtraction, so exact to round-off).
* :func:`separate_moment_assembly`: forces and sleeve offset from the
  production routine; moments and their derivatives assembled independently
  by Eq. (moment_chain_rule), optionally without the force-arm term.
* :func:`moment_comparison_error`: e_K of Eq. (moment_comparison_error).
"""
import numpy as np

from warp_contacts import output_pins_ref as ref

from ..validation import check_positive
from .shared_pin import SharedPinModel, as_poses, scaling_matrix


def balance(Q, q, origin=(0.0, 0.0)):
    """(total force (2,), total z moment) of the three body triples about ``origin`` [N, N m].

    Each body's moment M_z is about its own origin (x_b, y_b); translating it to
    the common origin adds (x_b - o) x F_b.
    """
    Q = np.asarray(Q, float).reshape(3, 3)
    x = as_poses(np.asarray(q, float))[:, :2] - np.asarray(origin, float)
    force = Q[:, :2].sum(axis=0)
    moment = np.sum(Q[:, 2] + x[:, 0] * Q[:, 1] - x[:, 1] * Q[:, 0])
    return force, float(moment)


def central_difference_tangent(model: SharedPinModel, q, step=0.5e-6, columns=range(9), tilt=None):
    """K_q = -dQ/dq by central differences; translations step [m], rotations step/R [rad]."""
    check_positive("step", step)
    q = np.asarray(q, float)
    K = np.full((9, 9), np.nan)
    for j in columns:
        h = step if j % 3 < 2 else step / model.radius
        qp, qm = q.copy(), q.copy()
        qp[j] += h
        qm[j] -= h
        K[:, j] = -(model.forces(qp, tilt) - model.forces(qm, tilt)) / (2.0 * h)
    return K


def column_relative_error(K, K_ref, columns, radius):
    """Relative 2-norm error of selected columns of the scaled tangents S K S."""
    s = np.diag(scaling_matrix(radius))
    # element-wise scaling: unevaluated (NaN) columns of a partial FD tangent must not spread
    A, B = K * np.outer(s, s), K_ref * np.outer(s, s)
    return [float(np.linalg.norm(A[:, j] - B[:, j]) / np.linalg.norm(B[:, j])) for j in columns]


def complex_step_tangent(mechanism, q, h=1e-30, tilt=None):
    """Independent K_q = -Im Q(q + i h e_j)/h from the NumPy reference (complex-safe force routine).

    The step is scaled by the radius for rotations so both see the same relative perturbation.
    """
    fp, ip = mechanism.packed(0, (1, 2))
    q = np.asarray(q, float)
    K = np.zeros((9, 9))
    for j in range(9):
        hj = h if j % 3 < 2 else h / mechanism.pin_circle_radius
        qc = q.astype(complex)
        qc[j] += 1j * hj
        r = ref.evaluate_shared(qc.reshape(3, 3), fp, ip, mechanism.stations, tilt=tilt, tangent=False)
        K[:, j] = -np.imag(r["Q"].sum(axis=0)) / hj
    return K


def _perp(a):
    return np.array([-a[1], a[0]])


def _rot(th, xi):
    c, s = np.cos(th), np.sin(th)
    return np.array([c * xi[0] - s * xi[1], s * xi[0] + c * xi[1]])


def separate_moment_assembly(mechanism, q, response, include_arm_term=True):
    """Reassemble Q and K_q from the production slice forces and sleeve offset.

    The force rows come from the production slice-force vectors f_is (force on
    wheel i) and their tangents; the moments are rebuilt here from the
    geometry, M = r x f about each body origin, with the wheel arm r = R(theta_i)
    xi_h (hole centre) and the flange arm R(theta_f) xi_p + u_fit (sleeve centre),
    and differentiated by Eq. (moment_chain_rule): r x df + dr x f.
    ``include_arm_term=False`` drops dr x f, the force-arm contribution, to show
    what a force-only moment derivative misses. Tilts are zero (planar check).
    Returns (Q_sep (9,), K_sep (9, 9)).
    """
    if response.slice_force_tangent is None:
        raise ValueError("response must come from a SharedPinModel with slice_tangent=True")
    pose = as_poses(np.asarray(q, float))
    fp, _ = mechanism.packed(0, (1, 2))
    Q = np.zeros(9)
    dQ = np.zeros((9, 9))
    for pin in range(fp.shape[0]):
        pf = _rot(pose[0, 2], fp[pin, ref.P_XI_PIN:ref.P_XI_PIN + 2])
        u = response.sleeve_offset[pin]
        du = response.sleeve_tangent[pin]
        arm_f = pf + u
        darm_f = du.copy()
        darm_f[:, 2] += _perp(pf)
        for i in range(2):
            ph = _rot(pose[1 + i, 2], fp[pin, ref.P_XI_HOLE0 + 2 * i:ref.P_XI_HOLE0 + 2 * i + 2])
            darm_w = np.zeros((2, 9))
            darm_w[:, 5 + 3 * i] = _perp(ph)
            for s in range(response.slice_force.shape[2]):
                f = response.slice_force[pin, i, s] * response.slice_normal[pin, i, s]
                df = response.slice_force_tangent[pin, i, s]
                Q[0:2] -= f
                Q[3 + 3 * i:5 + 3 * i] += f
                Q[5 + 3 * i] += ph[0] * f[1] - ph[1] * f[0]
                Q[2] -= arm_f[0] * f[1] - arm_f[1] * f[0]
                dQ[0:2] -= df
                dQ[3 + 3 * i:5 + 3 * i] += df
                dmw = ph[0] * df[1] - ph[1] * df[0]
                dmf = arm_f[0] * df[1] - arm_f[1] * df[0]
                if include_arm_term:
                    dmw = dmw + darm_w[0] * f[1] - darm_w[1] * f[0]
                    dmf = dmf + darm_f[0] * f[1] - darm_f[1] * f[0]
                dQ[5 + 3 * i] += dmw
                dQ[2] -= dmf
    return Q, -dQ


def moment_comparison_error(K_prod, K_ref, radius):
    """e_K = ||S (K_prod - K_ref) S||_F / ||S K_ref S||_F, Eq. (moment_comparison_error)."""
    S = scaling_matrix(radius)
    return float(np.linalg.norm(S @ (np.asarray(K_prod) - np.asarray(K_ref)) @ S) / np.linalg.norm(S @ K_ref @ S))
