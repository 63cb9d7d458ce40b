"""Observation of accepted steps: snapshots, the observer registry, exposure
statistics of Eq. (obs_statistics) and the sampling windows that hold them."""
from .contact_peaks import ContactPeaks
from .registry import AcceptedStep, ContactSnapshot, Observer, ObserverRegistry
from .statistics import ExposureAccumulator
from .windows import PhaseWindows, StepRecorder, TimeWindows, WholeRun, Window

__all__ = ["AcceptedStep", "ContactPeaks", "ContactSnapshot", "Observer", "ObserverRegistry", "ExposureAccumulator",
           "PhaseWindows", "StepRecorder", "TimeWindows", "WholeRun", "Window"]
