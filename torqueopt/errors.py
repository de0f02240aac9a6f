"""The exceptions torqueopt raises for bad input and failed computations.

Every message names the offending value and, where there is a finite set of
valid choices, lists them. The CLI prints the message on one line and exits
with code 2.
"""

__all__ = [
    "TorqueoptError",
    "InvalidInput",
    "RobotNotFound",
    "UrdfError",
    "FrameNotFound",
    "ResolverNotFound",
    "TaskNotFound",
    "NoRedundancy",
    "SingularJacobian",
    "TorqueBoundsInfeasible",
    "SolverFailure",
    "MissingDependency",
    "PlantError",
    "OutputError",
    "TorqueoptWarning",
]


class TorqueoptError(Exception):
    """Base class of every error torqueopt raises on purpose."""


class InvalidInput(TorqueoptError, ValueError):
    """A value given by the user is malformed: wrong length, NaN, out of range."""


class RobotNotFound(TorqueoptError, LookupError):
    """No URDF file or known robot answers to the given name."""


class UrdfError(TorqueoptError):
    """A URDF file exists but cannot be parsed into a robot model."""


class FrameNotFound(TorqueoptError, LookupError):
    """The robot has no frame of the given name."""


class ResolverNotFound(TorqueoptError, LookupError):
    """No resolver is registered under the given name."""


class TaskNotFound(TorqueoptError, LookupError):
    """The task kind is not one of the known ones."""


class NoRedundancy(TorqueoptError):
    """The task leaves no null space where the resolver needs one (m >= n)."""


class SingularJacobian(TorqueoptError):
    """The task Jacobian lost rank, so the task acceleration cannot be realised."""


class TorqueBoundsInfeasible(TorqueoptError):
    """No torque within the torque bounds realises the task, and the resolver was told to stop."""


class SolverFailure(TorqueoptError):
    """A QP/LP solver returned no answer that passes its optimality checks."""


class MissingDependency(TorqueoptError, ImportError):
    """An optional package needed for this feature is not installed."""


class PlantError(TorqueoptError):
    """The plant's model cannot be built: its joints do not match the robot's, or MuJoCo refuses it."""


class OutputError(TorqueoptError, OSError):
    """A result file cannot be written where the user asked for it."""


class TorqueoptWarning(UserWarning):
    """Something the user should know that does not stop the work (a near-singular start, an odd inertia).

    The CLI prints each as one line, ``torqueopt <command>: note: ...``.
    """
