"""benchmarks/horizon_curve.py: its shares and intervals against a hand computation, and the README's answer and
the figure against the committed docs/data/horizon_curve.json (the page's numbers: tests/test_docs.py)."""

import importlib.util
import json
import math
import sys
from pathlib import Path

import pytest

pandas = pytest.importorskip("pandas")

ROOT = Path(__file__).resolve().parent.parent
_SPEC = importlib.util.spec_from_file_location("horizon_curve", ROOT / "benchmarks" / "horizon_curve.py")
horizon_curve = importlib.util.module_from_spec(_SPEC)
sys.modules["horizon_curve"] = horizon_curve  # its dataclass looks its module up there
_SPEC.loader.exec_module(horizon_curve)

#: z of a two-sided 95 % interval, the normal's 0.975 quantile.
Z = 1.959963984540054


def wilson_by_hand(k: int, n: int) -> tuple[float, float]:
    """The Wilson score interval, written out: (p + z²/2n ± z √(p(1−p)/n + z²/4n²)) / (1 + z²/n)."""
    p = k / n
    centre = p + Z * Z / (2 * n)
    spread = Z * math.sqrt(p * (1 - p) / n + Z * Z / (4 * n * n))
    return (centre - spread) / (1 + Z * Z / n), (centre + spread) / (1 + Z * Z / n)


def test_a_share_and_its_share_of_the_feasible_paths_are_counted_as_by_hand():
    free = [True, True, False, True, False, False, False, True, False, False]
    feasible = [True, True, False, False, True, True, True, True, True, True]
    everywhere = horizon_curve.share(free)
    assert (everywhere["successes"], everywhere["trials"], everywhere["fraction"]) == (4, 10, 0.4)
    # 4 of 10: the textbook Wilson interval, 0.168 to 0.687
    assert (round(everywhere["low"], 4), round(everywhere["high"], 4)) == (0.1682, 0.6873)
    assert (everywhere["low"], everywhere["high"]) == pytest.approx(wilson_by_hand(4, 10), abs=1e-12)
    # of the 8 feasible paths (the 3rd and 4th left out), 3 are problem-free: paths 1, 2 and 8
    of_feasible = horizon_curve.feasible_share(free, feasible)
    assert (of_feasible["successes"], of_feasible["trials"], of_feasible["fraction"]) == (3, 8, 0.375)
    assert (of_feasible["low"], of_feasible["high"]) == pytest.approx(wilson_by_hand(3, 8), abs=1e-12)
    none = horizon_curve.share([False] * 5)
    assert (none["low"], none["high"]) == pytest.approx((0.0, wilson_by_hand(0, 5)[1]), abs=1e-12)


def _rows():
    """Four paths, three methods; the optimum infeasible on path 3 and not converged on path 2."""
    rows = []
    for path in range(4):
        optimum = {
            "verdict": ["stable", "stable", "stable", "infeasible for every resolver"][path],
            "peak_torque_ratio": [1.0, 0.9, 1.2, 3.0][path],
            "cost": [10.0, 20.0, 30.0, 40.0][path],
            "optimizer_status": ["converged", "converged", "acceptable", "infeasible"][path],
        }
        pinv = {
            "verdict": ["stable", "whiplash", "stable", "stable"][path],
            "peak_torque_ratio": [0.8, 3.0, 1.5, 0.5][path],
            "cost": [30.0, 100.0, 60.0, 50.0][path],
        }
        window = {
            "verdict": ["stable", "stable", "lost path", "stable"][path],
            "peak_torque_ratio": [1.0, 0.95, 1.0, 1.0][path],
            "cost": [12.0, 30.0, 31.0, 41.0][path],
        }
        for label, row in [("pinv", pinv), ("receding-horizon[horizon=0.5,replan_every=10]", window),
                           ("global-optimum", optimum)]:  # fmt: skip
            rows.append({"path": path, "duration": 2.0, "resolver": label, "optimizer_status": None, **row})
    table = pandas.DataFrame(rows)
    from torqueopt.atlas.global_optimum import add_global_ratios

    return add_global_ratios(table.assign(optimizer_excess=float("nan")))


def test_the_summary_of_a_table_counts_as_by_hand():
    summary = horizon_curve.summarise_table(_rows())
    assert (summary["paths"], summary["feasible_paths"], summary["infeasible_paths"]) == (4, 3, 1)
    assert summary["optimum_converged"] == 2
    methods = {m["key"]: m for m in summary["methods"]}
    assert list(methods) == ["pinv", "h500ms", "optimum"]
    pinv, window, optimum = methods["pinv"], methods["h500ms"], methods["optimum"]
    # pinv: problem-free on paths 0 and 3 (stable, within the limits); path 3 is infeasible, so 1 of 3 feasible
    assert (pinv["problem_free"]["successes"], pinv["problem_free"]["trials"]) == (2, 4)
    assert (pinv["problem_free_of_feasible"]["successes"], pinv["problem_free_of_feasible"]["trials"]) == (1, 3)
    assert (pinv["whiplash"]["successes"], pinv["whiplash"]["trials"]) == (1, 4)
    # cost ratios on the paths where the optimum converged (0, 1): 30/10 and 100/20, median 4
    assert pinv["median_cost_vs_optimum"] == pytest.approx(4.0, rel=1e-15)
    assert pinv["median_cost"] == pytest.approx(55.0, rel=1e-15)
    # the window: problem-free on 0, 1, 3; lost on 2; cost ratios 1.2 and 1.5
    assert window["problem_free"]["successes"] == 3 and window["lost_path"] == 1
    assert window["problem_free_of_feasible"]["successes"] == 2
    assert window["median_cost_vs_optimum"] == pytest.approx(1.35, rel=1e-15)
    assert (window["horizon"], window["horizon_text"], window["kind"]) == (0.5, "500 ms", "window")
    # the optimum: problem-free on 0 and 1 (1.2 is over a limit; infeasible is not stable)
    assert optimum["problem_free"]["successes"] == 2 and optimum["problem_free_of_feasible"]["trials"] == 3
    assert summary["answer"] == {
        "best_local": "pinv",
        "best_local_problem_free": "50 % [15, 85]",
        "best_window": "h500ms",
        "first_window_matching_optimum": "h500ms",
        "first_window_matching_optimum_text": "500 ms",
    }


def test_the_readme_answer_is_written_from_the_committed_curve():
    """The README's block is what horizon_answer writes from docs/data/horizon_curve.json (a regression pin of a
    run: `benchmarks/horizon_curve.py summary ... --readme README.md` writes both)."""
    summary = json.loads((ROOT / "docs" / "data" / "horizon_curve.json").read_text())
    readme = (ROOT / "README.md").read_text()
    block = readme.split(horizon_curve.ANSWER_BEGIN + "\n", 1)[1].split("\n" + horizon_curve.ANSWER_END, 1)[0]
    assert block == horizon_curve.horizon_answer(summary)
    assert horizon_curve.readme_with_answer(readme, summary) == readme
    curve = summary["curves"][0]
    assert f"the first {curve['paths']:,} of {curve['planned_paths']:,}" in block


def test_the_figure_draws_the_shares_of_the_json(tmp_path):
    summary = json.loads((ROOT / "docs" / "data" / "horizon_curve.json").read_text())
    figure = horizon_curve.draw_figure(summary, tmp_path / "curve.png")
    share_axes = figure.axes[0]
    windows = sorted((m for m in summary["curves"][0]["methods"] if m["kind"] == "window"), key=lambda m: m["horizon"])
    drawn = {line.get_label(): list(line.get_ydata()) for line in share_axes.get_lines()}
    problem_free = next(line for line in share_axes.get_lines() if line.get_gid() == "problem-free")
    assert list(problem_free.get_ydata()) == pytest.approx([100 * m["problem_free"]["fraction"] for m in windows])
    assert drawn["of the feasible paths"] == pytest.approx(
        [100 * m["problem_free_of_feasible"]["fraction"] for m in windows]
    )


def test_the_cost_of_a_curve_is_counted_as_by_hand():
    def chunk(path, part, cpu):
        return {"path": path, "paths": 1, "part": part, "cpu_seconds": cpu, "load": 2.0}

    rows = [
        chunk(0, "resolvers", 10.0), chunk(0, "optimum", 2.0),
        chunk(1, "resolvers", 99.0), chunk(1, "resolvers", 30.0), chunk(1, "optimum", 4.0),  # redone: the last counts
        chunk(2, "resolvers", 5.0),  # its optimum not timed: left out
    ]  # fmt: skip
    methods = [
        {"path": 0, "method": "pinv", "cpu_seconds": 1.0}, {"path": 1, "method": "pinv", "cpu_seconds": 3.0},
        {"path": 0, "method": "receding-horizon[horizon=0.001]", "cpu_seconds": 6.0},
    ]  # fmt: skip
    cost = horizon_curve.run_cost(horizon_curve.CURVES["planar3"], rows, methods)
    # paths 0 and 1: 12 and 34 s; mean 23, sample deviation √242, standard error √242/√2 = 11
    assert cost["paths"] == [0, 1] and cost["timed_paths"] == 2
    spread = cost["cpu_per_path"]
    assert (spread["mean"], spread["median"], spread["min"], spread["max"]) == (23.0, 23.0, 12.0, 34.0)
    assert spread["p90"] == pytest.approx(12 + 0.9 * 22, abs=1e-12)  # linear between the two
    assert (spread["low"], spread["high"]) == pytest.approx((23 - 1.96 * 11, 23 + 1.96 * 11), abs=1e-12)
    assert cost["cpu_per_path_by_part"] == {"resolvers": 20.0, "optimum": 3.0}
    # 1,000 planned paths at 23 s: 23,000 s = 6.39 CPU hours, 3.19 h on two cores
    assert cost["cpu_hours"] == pytest.approx(23000 / 3600, abs=1e-12)
    assert cost["hours_on"] == [{"workers": 1, "hours": pytest.approx(23000 / 3600)},
                                {"workers": 2, "hours": pytest.approx(11500 / 3600)}]  # fmt: skip
    shares = {item["key"]: (item["cpu_seconds_per_path"], item["share"]) for item in cost["methods"]}
    assert shares == {"pinv": (2.0, 0.25), "h1ms": (6.0, 0.75)}
    # 12 and 134 s: the mean's interval, 73 ± 1.96 × 61, would reach below 0, where no mean can be
    wide = horizon_curve.run_cost(horizon_curve.CURVES["planar3"], [*rows[:2], chunk(1, "resolvers", 130.0), *rows[4:]])
    assert (wide["cpu_per_path"]["low"], wide["cpu_hours_low"]) == (0.0, 0.0)
    assert wide["cpu_per_path"]["high"] == pytest.approx(73 + 1.96 * 61, abs=1e-12)
    with pytest.raises(ValueError, match="a chunk of 2 paths at path 0"):
        horizon_curve.path_seconds([{**chunk(0, "optimum", 1.0), "paths": 2}])
