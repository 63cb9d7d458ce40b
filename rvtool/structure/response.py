"""Port compliance errors and frequency responses (Eqs. ports_static_error, ports_frf).

Post-processing of reduced and parent models; no reduction happens here.
"""
import numpy as np

FRF_CHUNK_BYTES = 64 * 2 ** 20
"""Memory of one batch of frequency-response system matrices [bytes]."""


def port_row_errors(C, C_ref, port_rows):
    """Per-port static error (Eq. ports_static_error before the max):
    ||(C - C_ref)_{g,:}||_F / ||C_ref_{g,g}||_F for every port g [-]."""
    D = np.asarray(C) - np.asarray(C_ref)
    return np.array([np.linalg.norm(D[rows]) / np.linalg.norm(C_ref[np.ix_(rows, rows)]) for rows in port_rows])


def static_error(C, C_ref, port_rows):
    """epsilon_C of Eq. (ports_static_error) [-]."""
    return float(np.max(port_row_errors(C, C_ref, port_rows)))


def modal_frf(reduced, freqs_hz, s, d, *, include_local=False):
    """G_sd(omega) of Eq. (ports_frf) for a :class:`PortReducedModel` [m/N].

    s: output vector (n_rows,) or several as rows (n_out, n_rows); d: input vector on the
    stacked port rows. Returns complex (n_freq,) or (n_freq, n_out). include_local adds
    the frequency-independent s^T R_local d of the offline correction.
    """
    S = np.atleast_2d(np.asarray(s, float))
    Hs, Hd = reduced.maps.T @ S.T, reduced.maps.T @ np.asarray(d, float)
    K, C, I = np.diag(reduced.omega2), reduced.damping, np.eye(reduced.n_coordinates)
    w = 2 * np.pi * np.asarray(freqs_hz, float)
    out = np.empty((len(w), S.shape[0]), complex)
    chunk = max(1, FRF_CHUNK_BYTES // (16 * reduced.n_coordinates ** 2))
    for k in range(0, len(w), chunk):
        # one batched LAPACK call per chunk of frequencies (bounded memory)
        wk = w[k:k + chunk, None, None]
        A = K - wk * wk * I + 1j * wk * C
        out[k:k + chunk] = np.linalg.solve(A, np.broadcast_to(Hd, (len(wk), len(Hd)))[..., None])[..., 0] @ Hs
    if include_local:
        out += S @ reduced.local_block_matrix() @ d
    return out[:, 0] if np.ndim(s) == 1 else out


def modal_port_frf_matrix(reduced, f_hz):
    """Full port FRF matrix H [K - w^2 I + i w C]^{-1} H^T at one frequency [m/N]."""
    w = 2 * np.pi * f_hz
    K, C = np.diag(reduced.omega2), reduced.damping
    return reduced.maps @ np.linalg.solve(K - w * w * np.eye(len(K)) + 1j * w * C, reduced.maps.T)


def parent_port_frf_matrix(cb, f_hz):
    """Direct complex solve of the parent, S_b [K_r - w^2 M_r + i w C_r]^{-1} S_b^T [m/N]."""
    w = 2 * np.pi * f_hz
    A = cb.stiffness - w * w * cb.mass + 1j * w * cb.damping
    return cb.port_selector @ np.linalg.solve(A, cb.port_selector.T)


def relative_l2(G, G_ref):
    """epsilon_G = ||G - G_ref||_2 / ||G_ref||_2 over the sampled response [-]."""
    return float(np.linalg.norm(G - G_ref) / np.linalg.norm(G_ref))
