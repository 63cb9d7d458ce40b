"""The eccentric journal: its centre and velocity on a crank turning about its own
axis. One definition for every topology that carries a wheel on an eccentric
(cycloid single/double wheel, RV cranks, small-tooth-difference stages).

A journal of eccentricity e [m] at phase phi [rad] on a crank at angle a [rad] has its
centre at e (-sin psi, cos psi), psi = a + phi (phase zero points along +y), and at crank
speed omega [rad/s] the velocity (-e cos psi, -e sin psi) omega.
"""
import numpy as np


def journal_centre(eccentricity, phase, crank_angle=0.0):
    """(x, y) [m] of the journal centre; arrays broadcast (e.g. angles (n, 1) and phases (m,))."""
    psi = np.add(crank_angle, phase)
    return -eccentricity * np.sin(psi), eccentricity * np.cos(psi)


def journal_velocity(eccentricity, phase, crank_angle, crank_speed):
    """(v_x, v_y) [m/s] of the journal centre at crank speed [rad/s]."""
    psi = np.add(crank_angle, phase)
    return -eccentricity * np.cos(psi) * crank_speed, -eccentricity * np.sin(psi) * crank_speed
