"""Kinematic marker frequencies of a rolling bearing (cage, ball pass, ball spin)."""
import numpy as np


def bearing_frequencies(ring_speed_hz, n_elements, element_diameter, pitch_diameter, contact_angle=0.0):
    """Rolling-bearing marker frequencies [Hz] at relative ring speed f_r: FTF = f_r/2 (1 - g),
    BPFO = Z FTF, BPFI = Z f_r/2 (1 + g), BSF = D/(2d) f_r (1 - g^2), g = d cos(alpha)/D; contact_angle
    alpha [rad]."""
    g = element_diameter * np.cos(contact_angle) / pitch_diameter
    f = abs(ring_speed_hz)
    return {"ftf": f / 2 * (1 - g), "bpfo": n_elements * f / 2 * (1 - g), "bpfi": n_elements * f / 2 * (1 + g),
            "bsf": pitch_diameter / (2 * element_diameter) * f * (1 - g * g)}
