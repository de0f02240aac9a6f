"""Checks of values that enter torqueopt, with messages that name the value and what would be valid.

The one set of validators, each rule (finite, positive, whole, in a range, a vector of n numbers) written once:
:mod:`~torqueopt.checks.numbers` for values given to the API (``name=value``) and the resolver options'
converters (which raise :class:`Refused` for the option machinery to complete), :mod:`~torqueopt.checks.text`
for the text of command-line options (``--name: text``), :mod:`~torqueopt.checks.request_size` for the size of
the work a request asks for, :mod:`~torqueopt.checks.robot` for checks that need the robot.
"""

# The package's names are its modules' names, each listed once in its module's ``__all__``.
from . import numbers, request_size, robot, text
from .numbers import *  # noqa: F403
from .request_size import *  # noqa: F403
from .robot import *  # noqa: F403
from .text import *  # noqa: F403

__all__ = numbers.__all__ + request_size.__all__ + robot.__all__ + text.__all__
