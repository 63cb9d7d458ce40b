"""Free play of an RV design: the needle clearance of the eccentric bearings and the tooth
thickness allowances (backlash) of the involute stage(s), and the clearance-free variant.

rv40e carries both (its design file declares them); :func:`without_free_play` gives the
same design with every one of them zero -- the zero-play model rv40e was before, kept for the
tests whose measured bounds belong to it (exact kinematic equilibrium at zero load, crank
shares within 0.01 of 1/3 pointwise) and for comparisons of lost motion with and without play.
"""
from .spec import RVDesign
from ...errors import RvtoolInputError

GEAR_SECTIONS = ("sun_gear", "crank_gear", "input_pinion", "compound_gear")
"""Sections whose ``thickness_allowance`` is backlash (the three-stage pair only where present)."""


def free_play(design: RVDesign):
    """{"eccentric_bearing.radial_clearance": c [m], "<gear>.thickness_allowance": A_s [m], ...} of ``design``."""
    if not isinstance(design, RVDesign):
        raise RvtoolInputError(f"design must be an RVDesign; got {type(design).__name__}")
    out = {"eccentric_bearing.radial_clearance": float(design.eccentric_bearing.radial_clearance)}
    for sec in GEAR_SECTIONS:
        gear = getattr(design, sec)
        if gear is not None:
            out[f"{sec}.thickness_allowance"] = float(gear.thickness_allowance)
    return out


def without_free_play(design: RVDesign):
    """``design`` with zero needle clearance and zero tooth thickness allowances (everything else unchanged)."""
    changes = {"eccentric_bearing": {"radial_clearance": 0.0}}
    for key in free_play(design):
        sec, _, name = key.partition(".")
        if sec in GEAR_SECTIONS:
            changes[sec] = {name: 0.0}
    return design.replace(**changes)
