"""The topology-neutral reducer model (see :mod:`rvtool.model.reducer`)."""
from .reducer import (BodyCoordinate, Family, FamilyObservation, KinematicState, ReducerModel,
                      physical_contact)

__all__ = ["BodyCoordinate", "Family", "FamilyObservation", "KinematicState", "ReducerModel", "physical_contact"]
