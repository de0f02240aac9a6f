"""Checks of values that enter torqueopt, with messages that name the value and what would be valid.

The one set of validators: the Python API, the CLI and every module use
these, each rule (finite, positive, whole, in a range, a vector of n
numbers) written once:

* :mod:`~torqueopt.checks.numbers`: numbers and vectors given to the API,
  named ``name=value`` (:func:`positive_number`, :func:`whole_number`,
  :func:`finite_numbers`, ...), and the converters of resolver options
  (:func:`number_at_least`, :func:`number_in_interval`, :func:`finite_array`), which raise
  :class:`Refused` for the option machinery to complete;
* :mod:`~torqueopt.checks.text`: the same rules on the text of command-line
  options, named ``--name: text`` (:func:`parse_vector`,
  :func:`parse_number`, :func:`parse_positive`, :func:`parse_whole`, :func:`parse_count`);
* :mod:`~torqueopt.checks.request_size`: bounds on the size of the work a request asks for
  (:func:`bounded_count`, :func:`step_count`);
* :mod:`~torqueopt.checks.robot`: checks that need the robot
  (:func:`configuration_vector`, :func:`joint_vector`, :func:`velocity_vector`,
  :func:`torque_limit_vector`, :func:`weight_matrix_root`, :func:`trajectory_dimension`,
  :func:`check_task_and_frame`,
  :func:`check_task_rank`).
"""

# The package's names are its modules' names, each listed once in its module's ``__all__``.
from . import numbers, request_size, robot, text
from .numbers import *  # noqa: F403
from .request_size import *  # noqa: F403
from .robot import *  # noqa: F403
from .text import *  # noqa: F403

__all__ = numbers.__all__ + request_size.__all__ + robot.__all__ + text.__all__
