"""torqueopt: redundancy resolution of robot arms through torque optimisation.

Reproduces and extends Hollerbach & Suh, "Redundancy resolution of
manipulators through torque optimization" (IEEE J. Robotics and Automation,
1987) on top of Pinocchio.
"""

from . import atlas  # the subpackage (torqueopt.atlas.run_atlas); pandas and Dask load only when it runs
from .dexterity import Dexterity, dexterity, dexterity_along
from .errors import (
    FrameNotFound,
    InvalidInput,
    MissingDependency,
    NoRedundancy,
    OutputError,
    ResolverNotFound,
    RobotNotFound,
    SingularJacobian,
    TaskNotFound,
    TorqueoptError,
    TorqueoptWarning,
    UrdfError,
)
from .integrators import rk4_step
from .loading import load_robot
from .optimal import OptimalResult, optimize
from .payload import Payload
from .resolvers import NullSpaceResolver, Option, Resolution, Resolver, get_resolver, resolver_names
from .result import SimResult, load_result
from .robot import Robot, TaskTerms
from .simulate import Feedback, resolve, simulate
from .stability import stability_margin
from .trajectory import Circle, MinimumJerkLine, Reference, StraightLine, Trajectory, WaypointPath

__version__ = "0.1.0"

__all__ = [
    "load_robot",
    "Payload",
    "Robot",
    "TaskTerms",
    "Trajectory",
    "Reference",
    "StraightLine",
    "MinimumJerkLine",
    "Circle",
    "WaypointPath",
    "optimize",
    "OptimalResult",
    "simulate",
    "stability_margin",
    "dexterity",
    "dexterity_along",
    "Dexterity",
    "rk4_step",
    "resolve",
    "Feedback",
    "resolver_names",
    "get_resolver",
    "Resolver",
    "NullSpaceResolver",
    "Option",
    "Resolution",
    "SimResult",
    "load_result",
    "TorqueoptError",
    "TorqueoptWarning",
    "InvalidInput",
    "RobotNotFound",
    "UrdfError",
    "FrameNotFound",
    "ResolverNotFound",
    "TaskNotFound",
    "NoRedundancy",
    "SingularJacobian",
    "MissingDependency",
    "OutputError",
    "atlas",
]
