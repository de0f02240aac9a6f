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

from .numbers import (
    Refused,
    count_values,
    finite_array,
    finite_numbers,
    finite_values,
    finite_vector,
    non_negative_number,
    number_at_least,
    number_in_interval,
    number_in_range,
    positive_number,
    show_number,
    whole_number,
)
from .request_size import DEFAULT_MAX_STEPS, bounded_count, step_budget, step_count
from .robot import (
    RANK_SAMPLES,
    TASK_DIMENSIONS,
    check_frame,
    check_rigid_joints,
    check_task,
    check_task_and_frame,
    check_task_rank,
    configuration_vector,
    joint_vector,
    task_ranks,
    torque_limit_vector,
    trajectory_dimension,
    velocity_vector,
    weight_matrix_root,
)
from .text import parse_count, parse_number, parse_positive, parse_vector, parse_whole

__all__ = [
    "Refused",
    "positive_number",
    "non_negative_number",
    "number_at_least",
    "number_in_range",
    "number_in_interval",
    "whole_number",
    "finite_values",
    "finite_vector",
    "finite_numbers",
    "finite_array",
    "show_number",
    "count_values",
    "parse_vector",
    "parse_number",
    "parse_positive",
    "parse_whole",
    "parse_count",
    "bounded_count",
    "step_count",
    "step_budget",
    "DEFAULT_MAX_STEPS",
    "configuration_vector",
    "joint_vector",
    "velocity_vector",
    "torque_limit_vector",
    "weight_matrix_root",
    "trajectory_dimension",
    "check_task_and_frame",
    "check_task",
    "check_frame",
    "task_ranks",
    "check_task_rank",
    "RANK_SAMPLES",
    "TASK_DIMENSIONS",
    "check_rigid_joints",
]
