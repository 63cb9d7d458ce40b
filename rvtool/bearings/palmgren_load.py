"""Palmgren's load P1 of the load-dependent friction moment M1 = f1 P1 d_m, by bearing type.

Palmgren (*Ball and Roller Bearing Engineering*, 3rd ed., SKF Industries, 1959) defines P1 per bearing type from
the radial load F_r AND the axial load F_a of a row; Harris & Kotzalas (*Essential Concepts of Bearing
Technology*, 5th ed., 2007, the section on the friction torque due to applied load) restate it, and the SKF
general catalogue before 2004 reproduced the table. Forms taken here, per row (status of each below):

- **angular-contact (and preloaded radial) ball row**: P1 = max(0.9 F_a cot(alpha) - 0.1 F_r, F_r), alpha the
  row's contact angle. Status: recalled, not re-read from the book page; the same form, cited to Harris &
  Kotzalas' *Essential Concepts of Bearing Technology* p. 185 ("equivalent load for moment calculation"), was
  read in a public third-party implementation (a sympy bearing-friction module found by the `search` tool's code
  corpus, not a primary source). Alternatives recalled from the type table (SKF before 2004, Schaeffler):
  single-row angular contact P1 = F_a - 0.1 F_r, double row 1.4 F_a - 0.1 F_r. At the rows' alpha = 40 deg and
  F_r -> 0 they give 1.00 F_a (single row) and 1.07 F_a (the form taken): within 7 %. The form taken is the
  one of the book the friction set already cites for f0 and f1 ([HK] in friction_set.toml), chosen before any
  efficiency result was looked at with it.
- **tapered roller row**: P1 = max(2 Y F_a, F_r), Y = 0.4 cot(alpha) the row's axial load factor (ISO 281:2007,
  Table 4, F_a/F_r > e; :func:`rvtool.bearings.skf_friction.tapered_axial_factor`). Status: recalled, not
  re-read (Palmgren's table, "2 Y F_a or F_r, the larger"); no alternative form was recalled. With the induced
  axial load alone, F_a = 0.5 F_r / Y, it gives P1 = F_r exactly: only a preload above the induced force counts.
- **needle / cylindrical (and crossed) roller set**: P1 = F_r (a radial bearing; crossed rollers kept at F_r,
  Palmgren's table has no row for them).

The rows' loads in the planar model (which holds no axial coordinate): each row of a pair carries half the
mounting's radial resultant; its axial load is the declared preload -- a ball row's ``axial_preload`` (or, for a
pair clamped by ``interference``, the row's axial force at its approach), a tapered pair's ``axial_preload``
taken with the induced 0.5 F_r / Y, the larger (as :func:`rvtool.analysis.losses._skf_rows` does). A single
tapered row without a pair carries only the induced force (P1 = F_r).

The mounting's P1 is the sum over its rows (M1 = f1 d_m sum P1_row: one f1 and d_m per mounting, the rows
equal). ``mode = "radial"`` returns the radial resultant itself, today's figures bit for bit.
"""
import math

from ..errors import RvtoolInputError

#: the forms of P1: "typed" (Palmgren's definition by type, the module docstring) and "radial" (F_r alone, the
#: figures before the correction, kept selectable for comparison)
PALMGREN_LOADS = ("typed", "radial")
#: ball row: P1 = max(BALL_AXIAL F_a cot(alpha) - BALL_RADIAL F_r, F_r) [Harris & Kotzalas 2007; recalled]
BALL_AXIAL = 0.9
BALL_RADIAL = 0.1
#: tapered row: P1 = max(TAPERED_AXIAL Y F_a, F_r) [Palmgren 1959 table; recalled]
TAPERED_AXIAL = 2.0
#: a pair's rows share its radial resultant equally (the planar model: both rows on one ring pair)
ROW_SHARE = 0.5


def check_mode(mode, key="palmgren_load"):
    """``mode`` if it is one of :data:`PALMGREN_LOADS`, else a clear error naming ``key``."""
    if mode not in PALMGREN_LOADS:
        raise RvtoolInputError(f"{key} = {mode!r}; valid choices are {list(PALMGREN_LOADS)} (\"typed\": Palmgren's "
                               "P1 by bearing type with the rows' axial preload; \"radial\": the radial resultant)")
    return mode


def ball_row_load(radial, axial, contact_angle):
    """P1 [N] of one ball row at radial load F_r [N], axial load F_a [N], contact angle alpha [rad]."""
    if axial == 0.0:
        return radial
    if not contact_angle > 0.0:
        raise RvtoolInputError(f"a ball row with axial load {axial} N needs contact_angle in (0, pi/2) for Palmgren's "
                               f"P1 (got {contact_angle}); valid: contact_angle_deg > 0, axial_preload = 0, or "
                               "palmgren_load = 'radial'")
    return max(BALL_AXIAL * axial / math.tan(contact_angle) - BALL_RADIAL * radial, radial)


def tapered_row_load(radial, preload, cup_angle):
    """P1 [N] of one tapered row at radial load F_r [N] with the pair's preload [N]: F_a = max(preload,
    0.5 F_r / Y), P1 = max(2 Y F_a, F_r) = max(2 Y preload, F_r) (the induced 0.5 F_r / Y gives exactly
    F_r), Y = 0.4 cot(cup angle)."""
    from .skf_friction import tapered_axial_factor
    return max(TAPERED_AXIAL * tapered_axial_factor(cup_angle) * preload, radial)


def row_loads(bearing, radial):
    """[(row label, F_r [N], F_a [N], P1 [N])] of a mounting's rows at its radial resultant ``radial`` [N]
    (module docstring)."""
    from .skf_friction import tapered_axial_factor
    from .spec import AngularContactPair, BallBearing, CylindricalRollerBearing
    from .tapered import TaperedPair, TaperedRollerBearing
    fr = float(radial)
    if not (math.isfinite(fr) and fr >= 0.0):
        raise RvtoolInputError(f"radial = {radial!r} N is outside the valid range [0, inf)")
    if isinstance(bearing, CylindricalRollerBearing):
        return [("row", fr, 0.0, fr)]
    if isinstance(bearing, BallBearing):
        fa = bearing.axial_preload
        return [("row", fr, fa, ball_row_load(fr, fa, bearing.contact_angle))]
    if isinstance(bearing, AngularContactPair):
        out = []
        for k, (row, s) in enumerate(zip(bearing.rows, bearing.axial_offsets)):
            fa = row.axial_preload if row.axial_preload > 0 else (row.axial_force_at(s) if s > 0 else 0.0)
            out.append((f"row{k}", ROW_SHARE * fr, fa, ball_row_load(ROW_SHARE * fr, fa, row.contact_angle)))
        return out
    if isinstance(bearing, TaperedPair):
        out = []
        for k, row in enumerate(bearing.rows):
            f = ROW_SHARE * fr
            fa = max(bearing.axial_preload, 0.5 * f / tapered_axial_factor(row.cup_angle))
            out.append((f"row{k}", f, fa, tapered_row_load(f, bearing.axial_preload, row.cup_angle)))
        return out
    if isinstance(bearing, TaperedRollerBearing):
        return [("row", fr, 0.0, tapered_row_load(fr, 0.0, bearing.cup_angle))]
    raise RvtoolInputError(f"bearing type {type(bearing).__name__} has no Palmgren load P1; valid: needle/cylindrical "
                           "roller, ball row, angular-contact pair, tapered row or pair")


def palmgren_load(bearing, radial, mode="typed"):
    """Palmgren's P1 [N] of a mounting's ``bearing`` at its radial resultant ``radial`` [N]: ``mode`` "typed"
    (the sum of its rows' P1 by type, :func:`row_loads`) or "radial" (``radial`` itself, unchanged)."""
    check_mode(mode)
    if mode == "radial":
        return radial
    return sum(p for _, _, _, p in row_loads(bearing, radial))
