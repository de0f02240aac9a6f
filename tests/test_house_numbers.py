"""benchmarks/house_numbers.py: its comparisons catch every change beyond their tolerances and nothing within."""

import importlib.util
import math
from pathlib import Path

import pytest

pandas = pytest.importorskip("pandas")

_PATH = Path(__file__).resolve().parent.parent / "benchmarks" / "house_numbers.py"
_SPEC = importlib.util.spec_from_file_location("house_numbers", _PATH)
house_numbers = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(house_numbers)


def _rows():
    return pandas.DataFrame(
        {
            "path": [0, 0, 1, 1],
            "resolver": ["pinv", "null-space", "pinv", "null-space"],
            "peak_torque_ratio": [1.5, 3.25, 0.75, -2.0],
            "instability_time": [math.nan, 0.25, math.nan, math.nan],
            "unstable": [False, True, False, False],
            "verdict": ["stable", "whiplash", "stable", "stable"],
            "stop_reason": [None, "torque of joint joint2 reached 3e4 N·m", None, None],
        }
    )


def test_identical_rows_pass_and_the_table_says_zero():
    problems, table = house_numbers.compare_rows(_rows(), _rows())
    assert problems == []
    assert [(entry["resolver"], entry["rows"], entry["largest"]) for entry in table] == [
        ("pinv", 2, 0.0),
        ("null-space", 2, 0.0),
    ]


@pytest.mark.parametrize("factor, fails", [(1 + 5e-10, False), (1 + 2e-9, True), (-1, True)])
def test_a_number_fails_beyond_1e_9_relative(factor, fails):
    after = _rows()
    after.loc[3, "peak_torque_ratio"] *= factor
    problems, table = house_numbers.compare_rows(_rows(), after)
    assert bool(problems) == fails
    if fails:
        assert problems[0].startswith("null-space peak_torque_ratio: relative") and "on path 1" in problems[0]
    assert table[1]["column"] == "peak_torque_ratio"
    assert table[1]["largest"] == pytest.approx(abs(factor - 1) / max(abs(factor), 1), rel=1e-6)


def test_nan_against_a_number_fails_and_nan_against_nan_passes():
    after = _rows()
    after.loc[0, "instability_time"] = 1.0
    problems, _ = house_numbers.compare_rows(_rows(), after)
    assert problems == ["pinv instability_time: relative inf on path 0, stable (nan -> 1.0), 1 rows"]


def test_a_changed_verdict_or_stop_reason_fails():
    after = _rows()
    after.loc[2, "verdict"] = "whiplash"
    after.loc[1, "stop_reason"] = "torque of joint joint2 reached 3.1e4 N·m"
    problems, table = house_numbers.compare_rows(_rows(), after)
    assert problems == [
        "pinv verdict: 1 rows differ, e.g. path 1: 'stable' -> 'whiplash'",
        "null-space stop_reason: 1 rows differ, e.g. path 0: 'torque of joint joint2 reached 3e4 N·m' -> "
        "'torque of joint joint2 reached 3.1e4 N·m'",
    ]
    assert table[0]["unequal"] == "verdict"


def test_a_lost_row_or_column_fails_and_a_skipped_column_does_not():
    problems, _ = house_numbers.compare_rows(_rows(), _rows().iloc[:3])
    assert problems == ["1 rows in one table only, e.g. [{'path': 1, 'resolver': 'null-space'}]"]
    problems, _ = house_numbers.compare_rows(_rows(), _rows().drop(columns="verdict"))
    assert problems == ["columns missing: verdict"]
    assert house_numbers.compare_rows(_rows(), _rows().drop(columns="verdict"), skip_columns=("verdict",))[0] == []


def test_the_summary_comparison_names_the_key_and_the_size():
    before = {"runs": [{"peak": 2.0, "stable": True, "name": "pinv"}], "claims": {"count": 3}}
    assert house_numbers.compare_json(before, {"runs": [{"peak": 2.0 * (1 + 5e-13), "stable": True,
                                                          "name": "pinv"}], "claims": {"count": 3}}) == []  # fmt: skip
    after = {"runs": [{"peak": 2.0 * (1 + 4e-12), "stable": 1, "name": "pinv"}], "claims": {"count": 3, "new": 0}}
    problems = house_numbers.compare_json(before, after)
    assert sorted(problems) == [
        "summary.claims.new: new",
        "summary.runs[0].peak: 2.0 -> 2.000000000008 (relative 4.00e-12)",
        "summary.runs[0].stable: True -> 1",
    ]
    assert house_numbers.compare_json([1, 2], [1]) == ["summary: 2 items -> 1"]


def test_round_off_of_a_zero_quantity_passes_unless_strict():
    """A tip error of 4.4233e-13 m that became 4.4234e-13 m when one RK4 sum was reordered: 1e-5 relative, round-off."""
    before, after = _rows(), _rows()
    before.loc[1, "peak_torque_ratio"], after.loc[1, "peak_torque_ratio"] = (
        4.4233470023344283e-13,
        4.4234028726447585e-13,
    )
    assert house_numbers.compare_rows(before, after)[0] == []
    problems, _ = house_numbers.compare_rows(before, after, round_off=0.0)
    assert problems == [
        "null-space peak_torque_ratio: relative 1.26e-05 on path 0, whiplash (4.4233470023344283e-13 -> 4.4234028726447585e-13), "
        "1 rows"
    ]
    assert house_numbers.compare_json([1e-15], [2e-15]) == []
    assert house_numbers.compare_json([1e-15], [2e-15], round_off=0.0) == [
        "summary[0]: 1e-15 -> 2e-15 (relative 5.00e-01)"
    ]
