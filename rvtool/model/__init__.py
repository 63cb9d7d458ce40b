"""The topology-neutral reducer model (see :mod:`rvtool.model.reducer`)."""
from .reducer import (BodyCoordinate, ClearanceVariant, SeriesBeam, Family, FamilyObservation, KinematicState, ReducerModel,
                      physical_contact)

__all__ = ["BodyCoordinate", "ClearanceVariant", "SeriesBeam", "Family", "FamilyObservation", "KinematicState", "ReducerModel", "physical_contact"]
