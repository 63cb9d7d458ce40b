"""Transmission error, Eq. (obs_te): e_TE = [theta_out - theta_out,0] - [theta_in - theta_in,0] / i
with the signed nominal ratio i; one definition for every protocol and every backend."""
import numpy as np


def transmission_error(theta_in, theta_out, ratio, *, unwrap=True):
    """Eq. (obs_te) [rad] from angle histories and the signed ratio i. unwrap=True unwraps
    sampled (wrapped) angles; histories of integrated coordinates are already continuous and
    may be sampled more coarsely than pi per sample, so they are passed with unwrap=False."""
    theta_in = np.asarray(theta_in, float)
    theta_out = np.asarray(theta_out, float)
    if unwrap:
        theta_in, theta_out = np.unwrap(theta_in), np.unwrap(theta_out)
    return (theta_out - theta_out[0]) - (theta_in - theta_in[0]) / ratio
