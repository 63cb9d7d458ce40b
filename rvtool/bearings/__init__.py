"""Bearings from rolling elements: specifications, the element set evaluator and checks."""
from .spec import AngularContactPair, BallBearing, CrossedRollerBearing, RollerBearing
from .set import BearingSet, Mounting

__all__ = ["AngularContactPair", "BallBearing", "CrossedRollerBearing", "RollerBearing", "BearingSet", "Mounting"]
