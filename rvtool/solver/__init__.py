"""Run specification and the accepted-step driver around Exudyn's implicit solver."""
from .run_spec import RunSpec
from .driver import simulate, RunRecord

__all__ = ["RunSpec", "simulate", "RunRecord"]
