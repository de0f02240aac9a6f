"""``torqueopt paper``: rerun the paper's experiment and write Figures 2-7 and a summary."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ..checks import parse_positive, parse_vector
from ..io import json_file_with, refuse_foreign, writable_path, writable_paths
from ..paper import MOVEMENTS, PAPER, PAPER_RUNS, PaperScenario, paper_files, run_paper, write_paper
from ..paper.runner import check_scenario
from ..plots import FIGURE_FORMATS
from ..progress import progress_bar
from ..studies.remedies import RemediesStudy, planned_runs, run_remedies
from ..studies.remedies.report import answer_lines, kept_text
from ..whiplash import DEFAULT_GROWTH_FACTOR, DEFAULT_LIMIT_FACTOR
from . import EXIT_OK, EXIT_STOPPED

__all__ = ["add_parser", "scenario_from_args"]


def add_parser(subparsers) -> None:
    durations = ",".join(f"{d:g}" for d in PAPER.durations)
    parser = subparsers.add_parser(
        "paper",
        help="reproduce Hollerbach & Suh 1987: Figures 2-7, stick figures, summary.json and summary.md",
        description=(
            "Simulate the paper's scenario: the 3-link planar arm (no gravity, limits 54/24/6 N·m) from "
            "q0 = (-45°, 135°, -135°) along (1, 1) with √2 m/s², short, medium and long movements, the paper's four resolvers, "
            "and the free-swinging arm of Fig. 7; then the remedies study (every registered remedy on the three "
            "movements, a sweep of damped-null-space over μ and K_D). Writes fig2.png ... fig7.png, "
            "arm_long_<resolver>.png, tip_long.png, remedies_long.png, remedies_tradeoff.png, summary.json and "
            "summary.md into DIR, checks the paper's six claims and answers the Discussion's questions. "
            "Give negative vectors as --q0=-0.78,..."
        ),
    )
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")
    group = parser.add_argument_group("scenario (default: the paper's)")
    group.add_argument("--q0", metavar="ANGLES", help="start joint angles [rad], 3 values (default -45°,135°,-135°)")
    group.add_argument("--degrees", action="store_true", help="read --q0 in degrees")
    group.add_argument("--direction", metavar="D", help="line direction in the xy plane, 2 values (default 1,1)")
    group.add_argument(
        "--durations", metavar="S,M,L", help=f"short, medium and long durations [s] (default {durations})"
    )
    group = parser.add_argument_group("whiplash detector (see torqueopt.whiplash)")
    group.add_argument(
        "--limit-factor",
        metavar="K",
        default=repr(DEFAULT_LIMIT_FACTOR),
        help=f"unstable once a joint needs more than K times its torque limit (default {DEFAULT_LIMIT_FACTOR:g})",
    )
    group = parser.add_argument_group("remedies study (see torqueopt.studies.remedies)")
    group.add_argument(
        "--no-remedies",
        action="store_true",
        help="skip the remedies study (every registered remedy on the three movements, remedies_*.png, and the "
        "summary's answers to the Discussion's questions)",
    )
    group.add_argument(
        "--no-remedy-sweep",
        action="store_true",
        help="run the remedies but not the sweep of damped-null-space over μ and K_D (and no remedies_tradeoff.png)",
    )
    group.add_argument(
        "--growth-factor",
        metavar="K",
        default=repr(DEFAULT_GROWTH_FACTOR),
        help="for joints without a torque limit: unstable beyond K times the starting torque "
        f"(default {DEFAULT_GROWTH_FACTOR:g})",
    )
    parser.add_argument(
        "--format",
        dest="figure_format",
        choices=FIGURE_FORMATS,
        default="png",
        help="format of every figure: png (default), or pdf / svg for vector output in a paper",
    )
    parser.set_defaults(handler=paper_command)


def paper_command(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    scenario, limit_factor, growth_factor = scenario_from_args(args)
    writable_path(args.out, directory=True)
    remedies, sweep = not args.no_remedies, not args.no_remedy_sweep
    outputs = writable_paths(paper_files(args.out, args.figure_format, remedies=remedies, sweep=sweep))
    refuse_foreign(
        outputs,
        json_file_with(Path(args.out) / "summary.json", ("runs", "claims")),
        f"a file of a torqueopt paper folder ('{args.out}' holds no summary.json of one)",
        "give an empty or new --out",
    )
    check_scenario(scenario)  # a singular start is refused before the progress line
    remedy_runs = planned_runs(sweep) if remedies else 0
    then = f", then the remedies study ({remedy_runs} runs)" if remedies else ""
    with progress_bar(
        f"torqueopt paper: {PAPER_RUNS - 1} runs and the free swing{then}", total=PAPER_RUNS + remedy_runs
    ) as bar:
        results = run_paper(scenario, limit_factor=limit_factor, growth_factor=growth_factor, on_run=bar.update)
        studies = [run_remedies(results, sweep=sweep, on_run=bar.update)] if remedies else []
    written = write_paper(results, args.out, studies, figure_format=args.figure_format)

    print(f"{'movement':<9}{'resolver':<21}{'peak |tau|/limit':>18}{'limit exceeded':>16}  verdict")
    for (movement, name), result in results.runs.items():
        violation = result.first_limit_violation
        report = results.whiplash[movement, name]
        verdict = _shouted(report.summary)
        if report.verdict == "lost path":
            verdict += (
                f" (the tip {report.max_tip_error * 1e3:.4g} mm off, tolerance {report.path_tolerance * 1e3:g} mm)"
            )
        if not result.completed:
            verdict = verdict.replace("stopped early", "stopped") + f" (stopped early: {result.stop_reason})"
        violation_text = f"t = {violation:.3f} s" if violation is not None else "no"
        print(f"{movement:<9}{name:<21}{result.peak_torque_ratio.max():18.2f}{violation_text:>16}  {verdict}")
    for study in studies:
        print_remedies(study)
    if scenario != PAPER:
        print("the claims below are the paper's, checked on this changed scenario:")
    for claim in results.claims:
        print(f"claim {claim.number}: {'holds' if claim.holds else 'DOES NOT HOLD'}: {claim.statement}")
    print(f"wrote {len(written)} files to {args.out} in {time.perf_counter() - started:.1f} s")
    return EXIT_STOPPED if results.stopped_early else EXIT_OK


def print_remedies(study: RemediesStudy) -> None:
    """The remedies' runs, one line each, and the numbers of the answers to the Discussion's questions."""
    print(
        f"remedies ({', '.join(study.remedies)}"
        + (f"; not registered: {', '.join(study.skipped)})" if study.skipped else ")")
    )
    for row in study.entries():
        if row["resolver"] not in study.remedies:
            continue
        when = _shouted(study.verdict(row["movement"], row["resolver"]))
        kept = (
            ""
            if row["null_space_cut_kept"] is None
            else f", keeps {kept_text(row['null_space_cut_kept'])} of null-space's cut"
            + (" (it costs more than pinv)" if row["null_space_cut_kept"] < 0 else "")
        )
        print(f"{row['movement']:<9}{row['resolver']:<32}{row['peak_torque_ratio']:8.2f}  {when}{kept}")
    for line in answer_lines(study.summary()["answers"]):
        print(line)


def _shouted(verdict: str) -> str:
    """A verdict as the console table prints it: the bad ones' first words in capitals (UNSTABLE from t = ...)."""
    for word in ("unstable", "lost path"):
        if verdict.startswith(word):
            return word.upper() + verdict[len(word) :]
    return verdict


def scenario_from_args(args: argparse.Namespace) -> tuple[PaperScenario, float, float]:
    """The scenario and the whiplash thresholds the options ask for."""
    changes = {}
    if args.q0 is not None:
        angles = parse_vector(args.q0, "q0", len(PAPER.q0))
        changes["q0"] = tuple(np.radians(angles) if args.degrees else angles)
    if args.direction is not None:
        changes["direction"] = tuple(parse_vector(args.direction, "direction", 2))
    if args.durations is not None:
        durations = parse_vector(args.durations, "durations", len(MOVEMENTS))
        changes["durations"] = tuple(parse_positive(f"{d!r}", "durations") for d in durations.tolist())
    limit_factor = parse_positive(args.limit_factor, "limit-factor")
    growth_factor = parse_positive(args.growth_factor, "growth-factor")
    return PAPER.replace(**changes), limit_factor, growth_factor
