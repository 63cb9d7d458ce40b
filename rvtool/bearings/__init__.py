"""Bearings from rolling elements: specifications, Hertz constants, the element set evaluator and checks."""
from .hertz import HertzConstants, hertz_constants, roller_stiffness
from .set import BearingLoads, BearingSet, Mounting
from .spec import (AngularContactPair, Arrangement, BallBearing, CrossedRollerBearing, CylindricalRollerBearing,
                   LaminaLaw, NeedleBearing)
from .tapered import TaperedPair, TaperedRollerBearing

__all__ = ["AngularContactPair", "Arrangement", "BallBearing", "BearingLoads", "BearingSet", "CrossedRollerBearing",
           "CylindricalRollerBearing", "HertzConstants", "LaminaLaw", "Mounting", "NeedleBearing", "hertz_constants",
           "roller_stiffness", "TaperedPair", "TaperedRollerBearing"]
