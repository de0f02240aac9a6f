"""The paths pinv handles, across arms: torqueopt.atlas.arms.

The summary is held to counts made by hand on a table built for it, its
intervals to SciPy's binomial test and to the order statistics of a
median's distribution-free interval; merging two atlases is held to one
atlas that ran every resolver; and the README's cross-arm table to what
the committed atlas.json files generate.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom, binomtest

from torqueopt.atlas import run_atlas
from torqueopt.atlas.arms import (
    BEGIN,
    END,
    cross_arm_table,
    load_summaries,
    merge_atlases,
    pinv_paths_summary,
    readme_block,
    write_arm_page,
)
from torqueopt.atlas.pinv_paths import median_interval
from torqueopt.errors import InvalidInput

pandas = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

ROOT = Path(__file__).resolve().parents[1]
#: The arms of the README's table, in its order, and their committed atlas summaries.
ARMS = ("panda", "xarm7", "tiago", "baxter")


def _row(path, resolver, verdict="stable", peak=0.5, vs_pinv=1.0, position=math.nan, velocity=math.nan):
    return {
        "path": path, "resolver": resolver, "verdict": verdict, "peak_torque_ratio": peak, "torque_vs_pinv": vs_pinv,
        "first_position_limit_violation": position, "first_velocity_limit_violation": velocity,
    }  # fmt: skip


@pytest.fixture
def table():
    """pinv handles paths 0-6 of 10: 7 has a peak of 1.2 (stable by the 2x rule, outside the limit), 8 leaves a
    joint limit, 9 loses the path. Resolver A whips on 1 (and on 9, not counted), passes the torque limit on 2 and a
    position limit on 3 (three paths outside a limit, the whip's among them); B is within every limit and saves torque on every path."""
    rows = []
    for path in range(10):
        verdict = {8: "joint limits", 9: "lost path"}.get(path, "stable")
        rows.append(_row(path, "pinv", verdict, peak=1.2 if path == 7 else 0.8))
    a = {1: {"verdict": "whiplash", "peak": 3.0, "vs_pinv": 3.75}, 2: {"peak": 1.1, "vs_pinv": 1.375},
         3: {"position": 0.21}, 9: {"verdict": "whiplash"}}  # fmt: skip
    ratios = [0.9, 0.8, 0.7, 0.95, 0.85, 0.6, 0.99, 0.5, 0.5, 0.5]
    for path in range(10):
        rows.append(_row(path, "A", **{"vs_pinv": ratios[path], **a.get(path, {})}))
        rows.append(_row(path, "B", peak=0.4, vs_pinv=0.5 + 0.01 * path))
    return pandas.DataFrame(rows)


def test_the_summary_counts_on_the_paths_pinv_handles_only(table):
    block = pinv_paths_summary(table)
    assert block["paths"] == 10 and block["pinv_handles"] == 7
    a, b = block["resolvers"]["A"], block["resolvers"]["B"]
    assert (a["paths"], a["whips"], a["over_limits"], a["over_torque"], a["over_position"]) == (7, 1, 3, 2, 1)
    assert a["over_velocity"] == 0
    expected = binomtest(1, 7).proportion_ci(method="wilson")
    assert (a["whip_low"], a["whip_high"]) == pytest.approx((expected.low, expected.high), rel=1e-12)
    expected = binomtest(3, 7).proportion_ci(method="wilson")  # the whip passes the torque limit too
    assert (a["over_low"], a["over_high"]) == pytest.approx((expected.low, expected.high), rel=1e-12)
    # A's ratios on P: paths 0-6 (1 and 2 replaced by the whip's and the excess's).
    assert a["median_torque_vs_pinv"] == pytest.approx(np.median([0.9, 3.75, 1.375, 0.95, 0.85, 0.6, 0.99]))
    assert not a["stable"] and not a["within_limits"] and not a["meets_bar"]
    # B: no whip in 7 paths is still an upper bound above 1 %; within every limit; saves torque.
    assert b["whips"] == 0 and b["whip_high"] > 0.01 and not b["stable"]
    assert b["within_limits"] and b["saves_torque"] and not b["meets_bar"]
    assert block["resolvers"]["pinv"]["median_torque_vs_pinv"] == 1.0


def test_the_median_interval_is_the_order_statistics_of_the_binomial():
    """[x_(k), x_(n-k+1)] with k the largest for which P(Bin(n, 1/2) < k) <= 2.5 %."""
    rng = np.random.default_rng(4)
    for n in (6, 7, 40, 381, 1000):
        values = rng.lognormal(size=n)
        median, low, high = median_interval(values)
        ordered = np.sort(values)
        k = max(j for j in range(1, n + 1) if binom.cdf(j - 1, n, 0.5) <= 0.025)
        assert median == np.median(values) and (low, high) == (ordered[k - 1], ordered[n - k])
    assert all(math.isnan(x) for x in median_interval(np.arange(5.0))[1:])  # five values cannot bracket it


def _summary(entries: dict, handles=1000, paths=1000) -> dict:
    base = {"stable": True, "within_limits": True, "saves_torque": True, "over_limits": 0, "over_rate": 0.0,
            "over_low": 0.0, "over_high": 0.0038, "median_torque_vs_pinv": 1.0, "median_low": 1.0, "median_high": 1.0}  # fmt: skip
    resolvers = {"pinv": {**base, "saves_torque": False}}
    resolvers.update({label: {**base, **entry} for label, entry in entries.items()})
    return {"pinv_paths": {"paths": paths, "pinv_handles": handles, "resolvers": resolvers}}


def test_the_cross_arm_table_lists_each_bar_and_the_nearest_when_none_meets_it():
    summaries = {
        "arm1": _summary({
            "null-space": {"stable": False},
            "bounded-torque": {"median_torque_vs_pinv": 0.9, "median_low": 0.89, "median_high": 0.91},
            "damped-null-space": {"median_torque_vs_pinv": 0.8, "median_low": 0.79, "median_high": 0.81},
            "inertia-pinv": {"saves_torque": False, "median_torque_vs_pinv": 1.1},
        }),
        "arm2": _summary({
            "damped-null-space": {"within_limits": False, "over_limits": 30, "over_rate": 0.03, "over_low": 0.021,
                                  "over_high": 0.043, "median_torque_vs_pinv": 0.8, "median_low": 0.79,
                                  "median_high": 0.81},
            "null-space": {"stable": False},
        }, handles=900),
    }  # fmt: skip
    lines = cross_arm_table(summaries).splitlines()
    assert len(lines) == 4 and lines[1].startswith("|---")
    arm1 = lines[2].split(" | ")
    assert arm1[1] == "1000 of 1000"
    assert arm1[2] == "`bounded-torque`, `damped-null-space`, `inertia-pinv`"  # not null-space, not pinv
    assert (
        arm1[3] == "`bounded-torque` 0.9 [0.89, 0.91]; `damped-null-space` 0.8 [0.79, 0.81]; `inertia-pinv` 1.1 [1, 1]"
    )
    assert arm1[4] == "`damped-null-space` 0.8 [0.79, 0.81]; `bounded-torque` 0.9 [0.89, 0.91] |"  # best first
    arm2 = lines[3].split(" | ")
    assert arm2[1] == "900 of 1000"
    assert arm2[3] == "none (nearest: `damped-null-space` outside a limit on 3 % [2.1, 4.3] of them, 0.8 [0.79, 0.81])"
    assert (
        arm2[4] == "none (nearest: `damped-null-space` 0.8 [0.79, 0.81], outside a limit on 3 % [2.1, 4.3] of them) |"
    )


def test_the_readme_block_is_replaced_between_its_markers():
    text = f"intro\n{BEGIN}\nold\n{END}\nrest\n"
    assert readme_block(text, "| new |") == f"intro\n{BEGIN}\n| new |\n{END}\nrest\n"
    with pytest.raises(ValueError, match="has no"):
        readme_block("no markers", "| new |")


def test_two_atlases_merged_equal_one_that_ran_every_resolver(tmp_path):
    settings = {"paths": 8, "durations": (0.3, 0.6), "seed": 5, "workers": 0, "progress": False, "figures": False}
    run_atlas("planar3", resolvers=["pinv", "null-space"], out=tmp_path / "a", **settings)
    run_atlas("planar3", resolvers=["pinv", "damped-null-space[damping=3]"], out=tmp_path / "b", **settings)
    whole = run_atlas(
        "planar3", resolvers=["pinv", "null-space", "damped-null-space[damping=3]"], out=tmp_path / "c", **settings
    )
    merged = merge_atlases([tmp_path / "a", tmp_path / "b"], tmp_path / "m", figures=False)
    for key in ("resolvers", "verdicts", "torque", "unstable_fraction", "pinv_paths", "rows", "paths"):
        assert json.loads(json.dumps(merged[key])) == json.loads(json.dumps(whole.summary[key])), key
    assert merged["config"]["merged_from"] == [str(tmp_path / "a"), str(tmp_path / "b")]
    assert (tmp_path / "m" / "atlas.md").read_text() == (tmp_path / "c" / "atlas.md").read_text()
    other = {**settings, "seed": 6}
    run_atlas("planar3", resolvers=["pinv", "weighted-null-space"], out=tmp_path / "d", **other)
    with pytest.raises(InvalidInput, match="differs from .* in population; cannot merge"):
        merge_atlases([tmp_path / "a", tmp_path / "d"], tmp_path / "n", figures=False)
    with pytest.raises(InvalidInput, match="repeats null-space; cannot merge"):
        merge_atlases([tmp_path / "a", tmp_path / "c"], tmp_path / "n", figures=False)


@pytest.mark.slow
def test_an_arms_page_shows_its_figures_and_the_commands_that_made_it(tmp_path):
    pytest.importorskip("matplotlib")
    settings = {"paths": 3, "durations": (0.3,), "seed": 5, "workers": 0, "progress": False, "figures": False}
    run_atlas("planar3", resolvers=["pinv", "null-space"], out=tmp_path / "a", **settings)
    run_atlas("planar3", resolvers=["pinv", "bounded-torque[joint_limits=off]"], out=tmp_path / "b", **settings)
    page = write_arm_page([tmp_path / "a", tmp_path / "b"], "planar3", tmp_path / "docs")
    text = page.read_text()
    assert page == tmp_path / "docs" / "planar3.md" and not (tmp_path / "docs" / "planar3" / "atlas.md").exists()
    for name in ("unstable_fraction.png", "instability_time.png", "tradeoff.png"):
        assert f"](planar3/{name})" in text and (tmp_path / "docs" / "planar3" / name).is_file()
    assert "--resolvers 'pinv,bounded-torque[joint_limits=off]'" in text and "--out a" in text
    summary = json.loads((tmp_path / "docs" / "planar3" / "atlas.json").read_text())
    assert summary["resolvers"] == ["pinv", "null-space", "bounded-torque[joint_limits=off]"]


def test_the_readmes_cross_arm_table_is_what_the_committed_atlases_generate():
    """Every arm whose atlas is committed (docs/atlas/ARM/atlas.json), in the README's order; panda's at least."""
    paths = {arm: ROOT / "docs" / "atlas" / arm / "atlas.json" for arm in ARMS}
    paths = {arm: path for arm, path in paths.items() if path.is_file()}
    assert "panda" in paths
    readme = (ROOT / "README.md").read_text()
    table = cross_arm_table(load_summaries(paths))
    assert readme_block(readme, table) == readme, (
        "README's cross-arm table is stale: python -m torqueopt.atlas.arms readme README.md "
        + " ".join(f"{arm}=docs/atlas/{arm}/atlas.json" for arm in paths)
    )
    for arm in paths:
        assert f"| {arm} | " in readme and f"(docs/atlas/{arm}.md)" in readme


@pytest.mark.slow
def test_each_arms_committed_summary_is_the_merge_of_its_committed_rows(tmp_path):
    """docs/atlas/ARM/atlas.json (whence the README's table) is what merging the arm's committed atlases' rows
    (docs/atlas/ARM/NAME/results.parquet and atlas-config.json, NAME each ``--out`` of the page's commands, in
    their order) gives: the pages are of the rows beside them."""
    import re

    arms = [arm for arm in ARMS if list((ROOT / "docs" / "atlas" / arm).glob(f"{arm}-*/results.parquet"))]
    assert "panda" in arms
    for arm in arms:
        page = (ROOT / "docs" / "atlas" / f"{arm}.md").read_text()
        names = re.findall(r"^torqueopt atlas .* --out (\S+)$", page, flags=re.MULTILINE)
        assert len(names) >= 2, arm
        merge_atlases([ROOT / "docs" / "atlas" / arm / name for name in names], tmp_path / arm, figures=False)
        summaries = [
            json.loads((folder / "atlas.json").read_text())
            for folder in (ROOT / "docs" / "atlas" / arm, tmp_path / arm)
        ]
        for summary in summaries:  # where the folders were when merged is not part of what was merged
            summary["config"]["merged_from"] = [Path(folder).name for folder in summary["config"]["merged_from"]]
        assert summaries[0] == summaries[1], arm


def test_an_arms_page_takes_a_note_from_the_command_line(tmp_path):
    """``python -m torqueopt.atlas.arms page ARM DOCS FOLDER ... --note TEXT``: the note follows the commands."""
    from torqueopt.atlas.arms import main as arms_main

    settings = {"paths": 2, "durations": (0.2,), "seed": 5, "workers": 0, "progress": False, "figures": False}
    run_atlas("planar3", resolvers=["pinv"], out=tmp_path / "a", **settings)
    assert arms_main(["page", "planar3", str(tmp_path / "docs"), str(tmp_path / "a"), "--note", "Ran at noon."]) == 0
    text = (tmp_path / "docs" / "planar3.md").read_text()
    assert text.index("--out a") < text.index("Ran at noon.") and text.count("Ran at noon.") == 1


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        ([], "the following arguments are required: command"),
        (["page", "planar3"], "the following arguments are required: docs, FOLDER"),
        (["page", "planar3", "docs", "a", "--note"], "argument --note: expected one argument"),
        (["readme", "README.md", "panda"], "'panda' is not ARM=atlas.json"),
        (["page", "planar3", "docs", "a", "--no"], "unrecognized arguments: --no"),  # no prefix of --note
    ],
)
def test_the_arms_command_refuses_bad_arguments_in_one_line(argv, message, capsys):
    """No traceback: argparse's usage and one error line naming what is wrong, exit code 2."""
    from torqueopt.atlas.arms import main as arms_main

    with pytest.raises(SystemExit) as stop:
        arms_main(argv)
    assert stop.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m torqueopt.atlas.arms") and error.endswith(message)
