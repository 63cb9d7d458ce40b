"""Angle unit factors, named by direction: multiply a value in the unit after ``_PER_``
to get the unit before it (``x_rad * ARCSEC_PER_RAD`` is arcseconds)."""
import math

ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0
ARCMIN_PER_RAD = 180.0 / math.pi * 60.0
RAD_PER_ARCMIN = math.pi / (180.0 * 60.0)
RAD_PER_ARCSEC = math.pi / (180.0 * 3600.0)
