"""The validators of torqueopt.checks: what each accepts, and the exact message of each refusal."""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

import numpy as np
import pytest

from torqueopt import InvalidInput
from torqueopt.checks import (
    Refused,
    finite_array,
    finite_numbers,
    number_at_least,
    number_in_interval,
    number_in_range,
    parse_count,
    parse_whole,
    positive_number,
    weight_matrix_root,
    whole_number,
)


def refused(call, *args, **kwargs) -> str:
    with pytest.raises(InvalidInput) as error:
        call(*args, **kwargs)
    return str(error.value)


@pytest.mark.parametrize(
    "value, minimum, maximum, expected",
    [(0, 0, None, 0), (np.int64(7), 1, None, 7), (360, 1, 360, 360), (1_000_000, 1, 1_000_000, 1_000_000)],
)
def test_whole_number_accepts_integers_within_the_bounds_as_int(value, minimum, maximum, expected):
    number = whole_number(value, "paths", minimum, maximum)
    assert number == expected and type(number) is int


@pytest.mark.parametrize(
    "value, minimum, maximum, message",
    [
        (0, 1, None, "turns=0 must be a whole number >= 1"),
        (1.5, 1, None, "turns=1.5 must be a whole number >= 1"),
        (2.0, 1, None, "turns=2.0 must be a whole number >= 1"),  # a float is not a count, even a whole one
        (True, 0, None, "turns=True must be a whole number >= 0"),
        ("3", 0, None, "turns='3' must be a whole number >= 0"),
        (np.int64(361), 1, 360, "turns=361 must be a whole number from 1 to 360"),
        (0, 1, 1_000_000, "turns=0 must be a whole number from 1 to 1,000,000"),
    ],
)
def test_whole_number_refuses_other_values_naming_them_and_the_bounds(value, minimum, maximum, message):
    assert refused(whole_number, value, "turns", minimum, maximum) == message


def test_number_in_range_accepts_the_closed_ends_only():
    assert number_in_range(1, "reach_fraction", 0.0, 1.0) == 1.0
    assert number_in_range(0.0, "min_condition", 0.0, 1.0) == 0.0
    assert (
        refused(number_in_range, 0.0, "reach_fraction", 0.0, 1.0, low_open=True)
        == "reach_fraction=0.0 must be a number in (0, 1]"
    )
    assert refused(number_in_range, 1.0, "f", 0.0, 1.0, True, True) == "f=1.0 must be a number in (0, 1)"
    assert refused(number_in_range, math.nan, "f", 0.0, 1.0) == "f=nan must be a number in [0, 1]"
    assert refused(number_in_range, "x", "f", 0.0, 1.0, unit="m") == "f='x' is not a number [m]"
    assert refused(number_in_range, 2, "f", -1.0, 1.5, True, unit="m") == "f=2 must be a number in (-1, 1.5] [m]"


@pytest.mark.parametrize(
    "value, message",
    [
        (1.0, "must be a number in [0, 1)"),
        ("-0.1", "must be a number in [0, 1)"),
        ("half", "is not a number; give a number in [0, 1)"),
        (None, "is not a number; give a number in [0, 1)"),
    ],
)
def test_number_in_interval_refuses_with_the_interval(value, message):
    assert number_in_interval("0.25", 0.0, 1.0, high_open=True) == 0.25
    with pytest.raises(Refused, match=f"^{re.escape(message)}$"):
        number_in_interval(value, 0.0, 1.0, high_open=True)


def test_finite_numbers_accepts_the_sizes_given_and_says_which():
    np.testing.assert_array_equal(finite_numbers([1, 2], "start"), [1.0, 2.0])
    np.testing.assert_array_equal(finite_numbers(np.ones((1, 3)), "normal", 3), [1.0, 1.0, 1.0])
    assert refused(finite_numbers, [1.0], "start") == "start [1.0] must be 2 or 3 finite numbers"
    assert refused(finite_numbers, [1, math.inf], "start", 2) == "start [1.0, inf] must be 2 finite numbers"
    assert refused(finite_numbers, "ab", "start") == "start 'ab' is not a vector of numbers"
    assert (
        refused(finite_numbers, [0], "centre", (2, 3), unit="m", context="for the obstacle")
        == "centre [0.0] must be 2 or 3 finite numbers [m] for the obstacle"
    )


@pytest.mark.parametrize("value, expected", [("2.5", 2.5), (0, 0.0), (np.float64(1e3), 1000.0), ("1e-3", 1e-3)])
def test_number_at_least_converts_numbers_and_their_text(value, expected):
    assert number_at_least(value, 0.0) == expected


@pytest.mark.parametrize(
    "value, strict, message",
    [
        (-1, False, "must be a finite number >= 0 [1/s]"),
        (0, True, "must be a finite number > 0 [1/s]"),
        (math.inf, False, "must be a finite number >= 0 [1/s]"),
        ("nan", False, "must be a finite number >= 0 [1/s]"),
        ("lots", False, "is not a number; give a finite number >= 0 [1/s]"),
        (True, False, "is not a number; give a finite number >= 0 [1/s]"),
        ([1.0], False, "is not a number; give a finite number >= 0 [1/s]"),
    ],
)
def test_number_at_least_refuses_with_what_the_value_must_be(value, strict, message):
    with pytest.raises(Refused, match=f"^{re.escape(message)}$"):
        number_at_least(value, 0.0, strict=strict, unit="1/s")


def test_finite_array_keeps_the_shape_and_refuses_empty_or_non_finite_values():
    assert finite_array("1, 2,3", "a vector").tolist() == [1.0, 2.0, 3.0]
    assert finite_array([[1, 0], [0, 1]], "a matrix").shape == (2, 2)
    for value, message in [
        ("1,x", "is not a vector; give comma-separated numbers, e.g. 0,0.1,0"),
        ("nan,1", "must be a vector of finite numbers"),
        ([], "must be a vector of finite numbers"),
        ({"a": 1}, "is not a vector"),
    ]:
        with pytest.raises(Refused, match=f"^{re.escape(message)}$"):
            finite_array(value, "a vector", example="0,0.1,0")


@pytest.mark.parametrize("text, expected", [("0", 0), ("2e6", 2_000_000), ("3.0", 3), (" 12 ", 12)])
def test_parse_whole_accepts_whole_numbers_in_any_notation(text, expected):
    assert parse_whole(text, "seed") == expected


@pytest.mark.parametrize(
    "text, minimum, maximum, message",
    [
        ("two", 1, None, "--paths: 'two' is not a whole number"),
        ("1.5", 1, None, "--paths: 1.5 must be a whole number >= 1"),
        ("-1", 0, None, "--paths: -1 must be a whole number >= 0"),
        ("inf", 1, None, "--paths: inf must be a whole number >= 1"),
        ("25", 2, 24, "--paths: 25 must be a whole number from 2 to 24"),
    ],
)
def test_parse_whole_names_the_option_and_the_bounds(text, minimum, maximum, message):
    assert refused(parse_whole, text, "paths", minimum, maximum) == message


def test_parse_count_is_a_whole_number_of_at_least_one():
    assert parse_count("2e6", "max-steps") == 2_000_000
    assert refused(parse_count, "0", "max-steps") == "--max-steps: 0 must be a whole number >= 1"


def test_weight_matrix_root_squares_back_to_the_weight():
    np.testing.assert_allclose(weight_matrix_root([4.0, 0.0, 9.0], 3), [2.0, 0.0, 3.0])
    rng = np.random.default_rng(0)
    factor = rng.normal(size=(3, 2))
    weight = factor @ factor.T  # symmetric positive semi-definite, rank 2
    root = weight_matrix_root(weight, 3)
    np.testing.assert_allclose(root.T @ root, weight, atol=1e-12)


@pytest.mark.parametrize(
    "weight, choices, message",
    [
        ([1.0, -1.0, 1.0], (), "weight [1.0, -1.0, 1.0] must be 3 finite non-negative numbers"),
        ([1.0, 1.0], (), "weight must be a vector of 3 values or a symmetric 3x3 matrix, got shape (2,)"),
        (
            np.ones((2, 2)),
            ("identity", "range"),
            "weight must be identity, range, 3 values or a symmetric 3x3 matrix, got shape (2, 2)",
        ),
        (
            np.triu(np.ones((3, 3))),
            (),
            "weight must be a vector of 3 values or a symmetric 3x3 matrix, got shape (3, 3)",
        ),
        (-np.eye(3), (), "weight matrix must be positive semi-definite; its smallest eigenvalue is -1"),
        ({"a": 1}, ("identity",), "weight {'a': 1} is not a name, a vector or a matrix of numbers"),
    ],
)
def test_weight_matrix_root_refuses_what_is_not_a_weight(weight, choices, message):
    assert refused(weight_matrix_root, weight, 3, choices) == message


def test_a_missing_frame_is_refused_once_for_the_robot_the_frame_task_and_the_obstacle(planar3):
    from torqueopt import FrameNotFound, TaskNotFound
    from torqueopt.checks import check_frame, check_task
    from torqueopt.tasks import FrameTask, ObstacleTask

    check_frame(planar3.model, "tip", "planar3")
    message = "robot 'planar3' has no frame 'hand': choose one of "
    for call in (
        lambda: check_frame(planar3.model, "hand", "planar3"),
        lambda: FrameTask("hand", "xy").check(planar3),
        lambda: ObstacleTask([1.0, 0.0], frame="hand").check(planar3),
    ):
        with pytest.raises(FrameNotFound) as error:
            call()
        assert str(error.value).startswith(message) and str(error.value).endswith("tip"), str(error.value)
    with pytest.raises(TaskNotFound, match=r"^unknown task kind 'planar': choose one of xy, position, pose$"):
        FrameTask("tip", "planar")
    with pytest.raises(TaskNotFound, match=r"^unknown task 'planar': choose one of xy, position, pose$"):
        check_task("planar")


def test_torque_limits_broadcast_one_value_and_refuse_what_is_not_a_limit(planar3):
    from torqueopt.checks import torque_limit_vector

    np.testing.assert_array_equal(torque_limit_vector(planar3, 5), [5.0, 5.0, 5.0])
    np.testing.assert_array_equal(torque_limit_vector(planar3, [1, np.inf, 2]), [1.0, np.inf, 2.0])
    joints = ", ".join(planar3.joint_names)
    assert (
        refused(torque_limit_vector, planar3, [1, 2])
        == f"torque limit has 2 values; robot 'planar3' needs 1 or 3 (joints {joints})"
    )
    assert (
        refused(torque_limit_vector, planar3, [1, 0, 2]) == "torque limit [1.0, 0.0, 2.0] must be positive numbers "
        "(inf for unbounded)"
    )
    assert refused(torque_limit_vector, planar3, [1, np.nan, 2]).startswith("torque limit [1.0, nan, 2.0] must be")
    assert refused(torque_limit_vector, planar3, "strong") == "torque limit 'strong' is not a vector of numbers"


def test_a_velocity_vector_has_one_finite_rate_per_joint(planar3):
    from torqueopt.checks import velocity_vector

    np.testing.assert_array_equal(velocity_vector(planar3, [0, 1, 2]), [0.0, 1.0, 2.0])
    joints = ", ".join(planar3.joint_names)
    assert refused(velocity_vector, planar3, [0, 1]) == f"v0 has 2 values but needs 3 (joints {joints})"
    assert refused(velocity_vector, planar3, [0, 1, np.inf], "v") == (
        "v [0.0, 1.0, inf] has a non-finite value; all 3 values must be finite"
    )


def test_finite_values_with_a_minimum_refuse_values_below_it():
    from torqueopt.checks import finite_values

    assert finite_values([0, 2.5], "sweep dampings", minimum=0.0) == (0.0, 2.5)
    assert finite_values(3, "torque_limit", minimum=0.0, strict=True) == (3.0,)
    assert refused(finite_values, [1, -1], "sweep dampings", minimum=0.0) == (
        "sweep dampings [1.0, -1.0] must be finite numbers >= 0"
    )
    assert refused(finite_values, [54, 0], "torque_limit", minimum=0.0, strict=True, unit="N·m") == (
        "torque_limit [54.0, 0.0] must be positive numbers [N·m]"
    )
    assert (
        refused(finite_values, [1, 2], "gains", minimum=1.5, strict=True)
        == "gains [1.0, 2.0] must be finite numbers > 1.5"
    )
    assert (
        refused(finite_values, ["a"], "sweep dampings", minimum=0.0) == "sweep dampings ['a'] is not a list of numbers"
    )
    assert refused(finite_values, [], "sweep dampings") == "sweep dampings [] must be finite numbers"


def test_parse_number_takes_any_finite_number_and_names_the_option():
    from torqueopt.checks import parse_number

    assert parse_number("-0.5", "min-condition") == -0.5 and parse_number("1e-3", "min-condition") == 1e-3
    assert refused(parse_number, "abc", "min-condition") == "--min-condition: 'abc' is not a number"
    assert refused(parse_number, "nan", "min-condition") == "--min-condition: nan must be a finite number"
    assert refused(parse_number, "-inf", "min-condition") == "--min-condition: -inf must be a finite number"


def test_numbers_are_read_as_a_person_types_them():
    from torqueopt.checks import parse_number, parse_vector

    assert parse_number(" 2.5e-1 ", "duration") == 0.25 and parse_vector("1, -2.5,.5", "q0").tolist() == [1, -2.5, 0.5]
    # float() reads these too: digits of other scripts, full-width digits, digit separators.
    assert refused(parse_number, "١", "duration") == "--duration: '١' is not a number"
    assert refused(parse_vector, "1,５", "q0") == "--q0: '５' is not a number (give comma-separated numbers, e.g. 1,1)"
    assert refused(parse_count, "1_000", "paths") == "--paths: '1_000' is not a whole number"
    assert refused(positive_number, "٢", "dt") == "dt='٢' is not a number"
    # A huge count is shown as a number, not as its 309 digits.
    assert refused(whole_number, int(1e308), "paths", 1, 1_000_000) == (
        "paths=1e+308 must be a whole number from 1 to 1,000,000"
    )


def test_one_value_per_joint_is_checked_alike_for_the_paper_scenario_and_the_posture_task(planar3):
    from torqueopt.checks import joint_vector
    from torqueopt.paper import PAPER
    from torqueopt.tasks import PostureTask

    joints = ", ".join(planar3.joint_names)
    np.testing.assert_array_equal(joint_vector(planar3, [1, 2, 3], "q0"), [1.0, 2.0, 3.0])
    assert refused(joint_vector, planar3, [1, 2], "q0") == f"q0 has 2 values but needs 3 (joints {joints})"
    assert refused(PAPER.replace(q0=(-45.0, 135.0)).load_robot) == f"q0 has 2 values but needs 3 (joints {joints})"
    assert refused(PostureTask([0.0, 0.0]).check, planar3) == (
        f"posture target has 2 values but needs 3 (joints {joints})"
    )


def test_a_bad_task_target_names_the_task_it_was_given_to():
    from torqueopt.tasks import FrameTask, PostureTask

    assert refused(PostureTask, [0.0, math.nan]) == (
        "task target [0.0, nan] must be 2 finite numbers for PostureTask(target=[0.0, nan], gain=1)"
    )
    assert (
        refused(FrameTask, "tip", "xy", target=[1.0])
        == "task target [1.0] must be 2 finite numbers for FrameTask('tip', 'xy')"
    )
    assert refused(PostureTask, "abc") == "task target 'abc' is not a vector of numbers"


def test_a_trajectory_must_move_in_as_many_dimensions_as_the_task(planar3):
    from torqueopt import StraightLine
    from torqueopt.checks import trajectory_dimension

    assert trajectory_dimension(planar3, StraightLine([1, 1])) == 2
    assert trajectory_dimension(planar3, SimpleNamespace(dimension=None)) == 2  # one without a dimension of its own
    assert refused(trajectory_dimension, planar3, StraightLine([1, 1, 0])) == (
        "trajectory StraightLine moves in 3 dimensions but task 'xy' moves the tip in 2"
    )


def test_the_checks_never_import_the_robot_module():
    """torqueopt.robot imports the checks; the checks read a robot through its attributes (the data flows one way)."""
    import ast
    from pathlib import Path

    import torqueopt.checks

    for path in Path(torqueopt.checks.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                module = "." * node.level + (node.module or "")
                assert module not in ("..robot", "torqueopt.robot"), f"{path.name} imports {module}"
                assert not (module == ".." and any(alias.name == "robot" for alias in node.names)), path.name
            elif isinstance(node, ast.Import):
                assert all(alias.name != "torqueopt.robot" for alias in node.names), path.name
