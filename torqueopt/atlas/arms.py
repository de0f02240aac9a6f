"""The arms' atlases: one report from several atlases of a population, an arm's docs page, the cross-arm table.

:func:`merge_atlases` joins atlases of the same population that ran different resolvers;
:func:`write_arm_page` writes an arm's page from them; :func:`cross_arm_table` turns the ``atlas.json`` of
several arms into one Markdown table (the README's, checked by the tests against what it generates), from
the summary of the paths ``pinv`` handles (:mod:`torqueopt.atlas.pinv_paths`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from .pinv_paths import BASELINE, WHIPLASH_BOUND, median_text, over_text, pinv_paths_markdown, pinv_paths_summary
from .report import summarise, write_figures, write_markdown

__all__ = [
    "WHIPLASH_BOUND",
    "cross_arm_table",
    "load_summaries",
    "merge_atlases",
    "pinv_paths_markdown",
    "pinv_paths_summary",
    "readme_block",
    "write_arm_page",
]

#: The README's table sits between these two lines (what :func:`readme_block` replaces).
BEGIN, END = "<!-- cross-arm table: begin -->", "<!-- cross-arm table: end -->"


def cross_arm_table(summaries: dict[str, dict]) -> str:
    """One Markdown table over arms from each arm's ``atlas.json`` summary (``{arm: summary}``, in that order).

    One row per arm: the paths pinv handles; the resolvers stable there (whiplash's 95 % upper bound at most 1 %);
    of those, the ones also within every limit on every such path, each with its median peak torque ratio
    against pinv and that median's 95 % interval; of those, the ones that save torque (the median below 1), best
    first; and the resolver nearest the bar when none meets it (the fewest runs outside a limit among the stable
    ones that save torque, with that share's Wilson interval).
    """
    lines = [
        "| arm | paths pinv handles | stable: whiplash ≤ 1 % (95 % upper bound) | and within all limits "
        "(torque, position, velocity) on every one: median peak vs pinv [95 % CI] | and saving torque (median below 1) |",
        "|---|---|---|---|---|",
    ]
    for arm, summary in summaries.items():
        block = summary["pinv_paths"]
        entries = {label: e for label, e in block["resolvers"].items() if label != BASELINE}
        stable = [label for label, e in entries.items() if e["stable"]]
        within = [label for label in stable if entries[label]["within_limits"]]
        saving = sorted(
            (label for label in within if entries[label]["saves_torque"]),
            key=lambda label: entries[label]["median_torque_vs_pinv"],
        )
        stable_text = ", ".join(f"`{label}`" for label in stable) or "none"
        within_text = "; ".join(f"`{label}` {median_text(entries[label])}" for label in within)
        if not within:  # nearest: the stable one outside a limit on the fewest paths
            near = _fewest_over(stable, entries)
            within_text = "none" + (
                f" (nearest: `{near}` outside a limit on {over_text(entries[near])} of them, {median_text(entries[near])})"
                if near
                else ""
            )
        saving_text = "; ".join(f"`{label}` {median_text(entries[label])}" for label in saving)
        if not saving:  # nearest the bar: stable and saving torque, the fewest paths outside a limit
            near = _fewest_over([label for label in stable if entries[label]["saves_torque"]], entries)
            saving_text = "none" + (
                f" (nearest: `{near}` {median_text(entries[near])}, outside a limit on {over_text(entries[near])} of them)"
                if near
                else ""
            )
        lines.append(
            f"| {arm} | {block['pinv_handles']} of {block['paths']} | {stable_text} | {within_text} | {saving_text} |"
        )
    return "\n".join(lines)


def _fewest_over(labels: list[str], entries: dict) -> str | None:
    """The label outside a limit on the fewest paths (then the lowest median torque), None when there is none."""
    return min(
        labels, key=lambda label: (entries[label]["over_limits"], entries[label]["median_torque_vs_pinv"]), default=None
    )


def load_summaries(paths: dict[str, str | os.PathLike]) -> dict[str, dict]:
    """``{arm: atlas.json's summary}`` from ``{arm: path of its atlas.json}``."""
    return {arm: json.loads(Path(path).read_text()) for arm, path in paths.items()}


def readme_block(text: str, table: str) -> str:
    """``text`` with the lines between the markers ``BEGIN`` and ``END`` replaced by ``table``.

    Raises:
        ValueError: the markers are missing.
    """
    if BEGIN not in text or END not in text:
        raise ValueError(f"the text has no '{BEGIN}' ... '{END}' block")
    before, rest = text.split(BEGIN, 1)
    after = rest.split(END, 1)[1]
    return f"{before}{BEGIN}\n{table}\n{END}{after}"


#: The settings two atlases must share to be merged into one (the same population, thresholds, step and robot).
_SHARED = ("format", "robot", "robot_name", "task", "joint_names", "torque_limit", "population", "thresholds", "dt")


def merge_atlases(folders, out: str | os.PathLike, *, figures: bool = True) -> dict:
    """One atlas's report from several finished atlases of the same population that ran different resolvers.

    A sweep that runs the cheap resolvers first and the costly ones later (each its own resumable atlas, both
    with pinv, the baseline) ends as one report: the tables are joined (pinv's rows once, after checking that
    every atlas's pinv rows are the same), summarised, and ``atlas.json``, ``atlas.md`` and (with ``figures``)
    the figures are written into ``out``. No ``results.parquet`` and no explorer are written (each atlas keeps
    its own).

    Returns:
        The merged summary.

    Raises:
        InvalidInput: an atlas that is missing or unfinished, or atlases that differ in a shared setting, in
            their pinv rows, or that repeat a resolver.
    """
    import pandas

    from ..errors import InvalidInput
    from ..io import atomic_write, json_text, written_together
    from .jobs import RobotSpec

    configs, tables = [], []
    for folder in map(Path, folders):
        try:
            configs.append(json.loads((folder / "atlas-config.json").read_text()))
            tables.append(pandas.read_parquet(folder / "results.parquet"))
        except (OSError, ValueError) as error:
            raise InvalidInput(f"'{folder}' holds no finished atlas ({error})") from None
    first = configs[0]
    for folder, config in zip(folders, configs):
        differ = [key for key in _SHARED if config.get(key) != first.get(key)]
        if differ:
            raise InvalidInput(f"atlas '{folder}' differs from '{folders[0]}' in {', '.join(differ)}; cannot merge")
    baseline = tables[0][tables[0]["resolver"] == BASELINE].reset_index(drop=True)
    columns = [c for c in ("path", "verdict", "peak_torque_ratio", "max_tip_error") if c in baseline]
    parts, labels, described = [tables[0]], list(dict.fromkeys(tables[0]["resolver"])), list(first["resolvers"])
    for folder, config, table in zip(folders[1:], configs[1:], tables[1:]):
        own = table[table["resolver"] == BASELINE].reset_index(drop=True)
        if not own[columns].equals(baseline[columns]):
            raise InvalidInput(f"atlas '{folder}' has other pinv rows than '{folders[0]}'; cannot merge")
        others = [label for label in dict.fromkeys(table["resolver"]) if label != BASELINE]
        repeated = sorted(set(others) & set(labels))
        if repeated:
            raise InvalidInput(f"atlas '{folder}' repeats {', '.join(repeated)}; cannot merge")
        parts.append(table[table["resolver"] != BASELINE])
        labels += others
        described += [r for r in config["resolvers"] if r.get("label", r["name"]) != BASELINE]
    merged = pandas.concat(parts, ignore_index=True, sort=False)
    rank = {label: i for i, label in enumerate(labels)}
    merged = merged.assign(_rank=merged["resolver"].map(rank)).sort_values(["path", "_rank"], kind="stable")
    merged = merged.drop(columns="_rank").reset_index(drop=True)
    config = {**first, "resolvers": described, "merged_from": [str(Path(folder)) for folder in folders]}
    summary = summarise(merged, config)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    robot = RobotSpec(**first["robot"]).load() if figures else None
    with written_together():
        text = json_text(summary).encode()
        atomic_write(out / "atlas.json", lambda handle: handle.write(text))
        if figures:
            summary["figures"] = write_figures(merged, summary, out, robot)
        markdown = write_markdown(summary).encode()
        atomic_write(out / "atlas.md", lambda handle: handle.write(markdown))
    return summary


def write_arm_page(folders, arm: str, docs: str | os.PathLike = "docs/atlas", note: str = "") -> Path:
    """The docs' page of one arm's atlas: :func:`merge_atlases` of ``folders`` into ``docs/ARM/`` (atlas.json and
    the figures), and ``docs/ARM.md``: its atlas.md with the figures shown, the commands that made it and ``note``
    (when and on which code they ran, say) after them."""
    docs = Path(docs)
    folder = docs / arm
    merge_atlases(folders, folder)
    text = (folder / "atlas.md").read_text()
    (folder / "atlas.md").unlink()
    lines = []
    for line in text.splitlines():
        if line.startswith("- ") and line.endswith(".png`"):
            title, name = line[2:].rsplit(": `", 1)
            line = f"![{title}]({arm}/{name[:-1]})"
        lines.append(line)
    commands = []
    for path in map(Path, folders):
        config = json.loads((path / "atlas-config.json").read_text())
        population = config["population"]
        labels = ",".join(r.get("label", r["name"]) for r in config["resolvers"])
        durations = ",".join(f"{d:g}" for d in population["durations"])
        commands.append(
            f"torqueopt atlas --robot {config['robot']['source']} --task {config['task']} --paths "
            f"{population['paths']} --durations {durations} --seed {population['seed']} --path {population['path']} "
            f"--resolvers '{labels}' --workers 2 --out {path.name}"
        )
    lines += [
        "",
        "## How it was made",
        "",
        f"{len(commands)} atlases of the same population (the same seed, paths, durations and acceleration: "
        "their pinv rows are the same), merged by `torqueopt.atlas.arms.merge_atlases`; the summary is "
        f"`{arm}/atlas.json`:",
        "",
        "```text",
        *commands,
        "```",
        "",
    ]
    if note:
        lines += [note, ""]
    page = docs / f"{arm}.md"
    page.write_text("\n".join(lines))
    return page


def main(argv=None) -> int:
    """``python -m torqueopt.atlas.arms readme README.md ARM=atlas.json ...``: rewrite the README's cross-arm table;
    ``python -m torqueopt.atlas.arms page ARM DOCS FOLDER ... [--note TEXT]``: write an arm's page
    (:func:`write_arm_page`). Bad arguments: a one-line error, exit code 2."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m torqueopt.atlas.arms", description="The arms' atlas pages and the README's cross-arm table.",
        allow_abbrev=False,
    )  # fmt: skip
    commands = parser.add_subparsers(dest="command", required=True)
    readme = commands.add_parser("readme", help="rewrite the README's cross-arm table", allow_abbrev=False)
    readme.add_argument("readme", type=Path, help="the README to rewrite")
    readme.add_argument("summaries", nargs="+", metavar="ARM=atlas.json", help="each arm's atlas summary")
    page = commands.add_parser("page", help="write an arm's page from its atlas folders", allow_abbrev=False)
    page.add_argument("arm", help="the page's name (docs/ARM.md)")
    page.add_argument("docs", help="the docs folder of the atlas pages")
    page.add_argument("folders", nargs="+", metavar="FOLDER", help="atlas output folders of one population")
    page.add_argument("--note", default="", help="text after the commands (when and on which code they ran)")
    args = parser.parse_args(argv)
    if args.command == "page":
        write_arm_page(args.folders, args.arm, args.docs, args.note)
        return 0
    pairs = [summary.split("=", 1) for summary in args.summaries]
    malformed = [summary for summary, pair in zip(args.summaries, pairs) if len(pair) != 2]
    if malformed:
        parser.error(f"'{malformed[0]}' is not ARM=atlas.json")
    table = cross_arm_table(load_summaries(dict(pairs)))
    args.readme.write_text(readme_block(args.readme.read_text(), table))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
