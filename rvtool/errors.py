"""Exception types raised by rvtool.

Every input error names the parameter, the offending value and the valid
range, so that a user can correct a specification without reading code.
"""


class RvtoolInputError(ValueError):
    """A parameter or array supplied by the user is outside its valid range."""


class SolverFailure(RuntimeError):
    """The implicit solver could not complete a run.

    Attributes
    ----------
    state_file:
        Path of the ``.npz`` file holding the last accepted state (time,
        coordinates, velocities, accelerations, committed contact history),
        or ``None`` if no output directory was configured.
    """

    def __init__(self, message, state_file=None):
        super().__init__(message if state_file is None else f"{message} (last accepted state saved to {state_file})")
        self.state_file = state_file
