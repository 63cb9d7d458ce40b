"""Elastic housing of a cycloid reducer represented through ports at the ring pins.

The housing is an annulus (NGSolve first-order tetrahedra, Section "Structural
operators, contact ports, and coupled deformation") with translational mount
springs on its lower face. Each ring pin k is carried by one nodal port at the
bore vertex nearest to the pin's angle, at mid-height, sampling the in-plane
translations (x, y). The parent is reduced by Craig--Bampton (Eq. cb_reduction)
and then to structural coordinates eta with port maps H (retained parent modes
plus residual attachment modes, Eq. port_residual_flexibility); at run time the
pin centres move with their ports, u_k = H_k eta (Eq. port_runtime_transform).

Modelling choices (stated, not hidden): the pins themselves are rigid and
carried at one point each (their bending and the groove compliance are in the
contact law's calibration, not here); the bearings stay grounded (their seats
are not ported). The reduction is cached per (housing, material, pin layout)
within a process because it costs seconds and every model of a study shares it.
"""
import functools
import math

import numpy as np

from ..structure import NodalPort, PortReductionSpec, craig_bampton, fe_model_from_geometry, parent_modes, reduce_ports


def pin_port_angles(n_pins):
    """Polar angles [rad] of the ring pins (pin k at 2 pi k / z_b from +y, clockwise; see
    :func:`rvtool.geometry.cycloid.pin_centres`)."""
    return math.pi / 2 - 2 * math.pi * np.arange(n_pins) / n_pins


@functools.lru_cache(maxsize=8)
def _reduced(housing):
    h = housing
    spec = h.structure                      # the design's [housing.structure] is the housing spec
    n_pins = spec.n_ports
    z = 0.5 * spec.height if spec.port_height is None else spec.port_height
    ports = tuple(NodalPort(name=f"pin{k}", point=(spec.inner_radius * math.cos(a), spec.inner_radius * math.sin(a), z),
                            directions=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)))
                  for k, a in enumerate(pin_port_angles(n_pins)))
    fe = fe_model_from_geometry(spec.geometry(), mesh_size=spec.mesh_size, material=spec.material, ports=ports,
                                supports=spec.supports(), damping=spec.damping, info={"component": "reducer housing"})
    cb = craig_bampton(fe, n_modes=h.n_fixed_interface_modes)
    modes = parent_modes(cb)
    n_res = h.n_residual if h.n_residual >= 0 else min(2 * n_pins, len(modes.omega2) - h.n_modes)
    red = reduce_ports(cb, PortReductionSpec(n_modes=h.n_modes, n_residual=n_res), modes)
    info = {"vertices": int(len(fe.vertices)), "tetrahedra": int(len(fe.tetrahedra)), "dofs": int(fe.n_dofs),
            "port_offset_max_m": float(max(p.distance for p in fe.ports)), "n_eta": int(red.n_coordinates),
            "first_hz": float(np.sqrt(red.omega2.min()) / (2 * np.pi))}
    return red, modes.reference_compliance, info


def housing_ports(design):
    """(PortReducedModel, reference port compliance C_ref [m/N] of the parent, info dict) of
    ``design.housing`` (model "ports"); port k carries ring pin k, rows (2k, 2k + 1) = (x, y)."""
    return _reduced(design.housing)


def annulus_ports(housing, n_ports):
    """As :func:`housing_ports` for ``n_ports`` bore ports at the angles of
    :func:`pin_port_angles` (``housing``: a design's ``[housing]`` whose ``structure`` is the
    annulus); for topologies whose ring is not a set of pins."""
    import dataclasses
    return _reduced(dataclasses.replace(housing, structure=dataclasses.replace(housing.structure, n_ports=int(n_ports))))
