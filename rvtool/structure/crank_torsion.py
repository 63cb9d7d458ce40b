"""Torsion of an RV crankshaft between its spur gear and its eccentric journals (issue 30,
Deliver 1, "crank torsion (bending exists)"; design key ``[cranks.shaft] torsion = "rigid" |
"elastic"``).

The crank is the prismatic solid circular shaft of :mod:`rvtool.structure.crank_beam` (radius r,
one section: the declared simplification of the bending model), shear modulus G = E / (2 (1 +
nu)) of the crank material. A length L of it twists by

    phi = T L / (G J),   J = pi r^4 / 2                                               (1)

(Young and Budynas, Roark's Formulas for Stress and Strain, 7th ed., McGraw-Hill 2002, Table 10.1
case 1, solid circular section; the same in Shigley's Mechanical Engineering Design, Sec. 3-12).
The torque enters at the gear (axial position z_g, the crank body's rotation is the gear's) and
leaves at the journals (the wheel midplanes z_k, each a point of the shaft: the needle rollers'
length is short against the distances). A torque T_i at journal i twists the shaft over
[z_g, z_i], so the journal rotations relative to the gear are phi = C T with the station
compliance

    C_ij = overlap([z_g, z_i], [z_g, z_j]) / (G J)                                    (2)

(min(|z_i - z_g|, |z_j - z_g|) / GJ for journals on the gear's side, 0 across it): symmetric,
positive definite for distinct journal distances. It enters the needle bearings in series through
the per-crank closure of :mod:`rvtool.contact.pin_closure` with ``dofs = (2,)`` (each journal a
station body rotated about the crank axis by phi).
"""
import math

import numpy as np

from ..errors import RvtoolInputError
from ..validation import check_finite, check_positive, check_range


def polar_moment(radius):
    """J = pi r^4 / 2 [m^4] of a solid circular section."""
    check_positive("radius", radius)
    return math.pi * radius ** 4 / 2.0


def shear_modulus(youngs_modulus, poisson_ratio):
    """G = E / (2 (1 + nu)) [Pa]."""
    check_positive("youngs_modulus", youngs_modulus)
    check_range("poisson_ratio", poisson_ratio, -1.0, 0.5, low_open=True, high_open=True)
    return youngs_modulus / (2.0 * (1.0 + poisson_ratio))


def torsion_compliance(radius, youngs_modulus, poisson_ratio, gear_position, journal_positions):
    """C (k, k) [rad/(N m)] of Eq. (2): journal rotations relative to the gear per journal torque."""
    z = np.asarray(journal_positions, float)
    check_finite("journal_positions", z)
    check_finite("gear_position", gear_position)
    GJ = shear_modulus(youngs_modulus, poisson_ratio) * polar_moment(radius)
    d = z - gear_position
    if np.any(d == 0.0):
        raise RvtoolInputError(f"gear_position = {gear_position} m coincides with a journal (positions {z} m); "
                               "valid: a gear off the journals")
    same = np.sign(d)[:, None] == np.sign(d)[None, :]
    return np.where(same, np.minimum(np.abs(d)[:, None], np.abs(d)[None, :]), 0.0) / GJ


def output_torsional_stiffness(C, crank_rate_per_output, n_cranks):
    """Closed-form estimate [N m/rad] of the cranks' torsion as an output stiffness: the journals
    of every crank turn rigidly together relative to the gear by ``crank_rate_per_output`` rad per
    rad of output (the crank's rotation relative to the carrier per output rotation at a held input),
    each crank taking 1 / n_cranks of the torque, split between its journals so that both turn
    alike (the journals' stiffness 1^T C^-1 1): k = n_cranks rate^2 1^T C^-1 1. The wheels are
    shared by the journals of both wheels, so this is the rigid-wheel estimate, not a bound."""
    return float(n_cranks * crank_rate_per_output ** 2 * np.sum(np.linalg.inv(C)))
