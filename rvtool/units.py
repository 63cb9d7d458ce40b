"""Angle unit factors, named by direction: multiply a value in the unit after ``_PER_``
to get the unit before it (``x_rad * ARCSEC_PER_RAD`` is arcseconds)."""
import dataclasses
import math

ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0
ARCMIN_PER_RAD = 180.0 / math.pi * 60.0
RAD_PER_ARCMIN = math.pi / (180.0 * 60.0)
RAD_PER_ARCSEC = math.pi / (180.0 * 3600.0)


# -- angles in specs and design files ------------------------------------------------------------
# A spec holds every angle in radians (specs are SI); a design file gives it in degrees under the
# field name plus ``_deg`` (the one unit conversion of the loader, rvtool.assembly.spec.build_section).

ANGLE_METADATA = {"unit": "rad", "file_suffix": "_deg"}
"""Field metadata of an angle [rad] that a design file gives in degrees as ``NAME_deg``."""


def angle_field(default=dataclasses.MISSING, **kw):
    """A dataclass field holding an angle [rad]; design files give it in degrees as ``NAME_deg``."""
    return dataclasses.field(default=default, metadata=ANGLE_METADATA, **kw)


def angle_table_field(default=None, *, angle_columns=(0,), unit="rad, m", **kw):
    """A dataclass field holding a table of rows whose ``angle_columns`` are angles [rad] (e.g. (phi,
    delta_r) pairs); design files give it as ``NAME_deg`` with those columns in degrees."""
    meta = {"unit": unit, "file_suffix": "_deg", "angle_columns": tuple(angle_columns)}
    return dataclasses.field(default=default, metadata=meta, **kw)


def angle_columns(f):
    """The angle columns of a table field (:func:`angle_table_field`), or None for a plain angle."""
    return f.metadata.get("angle_columns")


def is_angle(f):
    """Whether dataclass field ``f`` is an angle [rad] given in design files as ``NAME_deg``."""
    return f.metadata.get("file_suffix") == "_deg"


def file_key(f):
    """The design-file key of dataclass field ``f``: ``NAME_deg`` for an angle, else its name."""
    return f.name + "_deg" if is_angle(f) else f.name
