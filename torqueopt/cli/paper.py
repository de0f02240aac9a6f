"""``torqueopt paper``: rerun the paper's experiment and write Figures 2-7 and a summary."""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..io import writable_path
from ..paper import MOVEMENTS, PAPER, PaperScenario, run_paper, write_paper
from ..whiplash import DEFAULT_GROWTH_FACTOR, DEFAULT_LIMIT_FACTOR
from . import EXIT_OK, EXIT_STOPPED
from .common import parse_positive, parse_vector

__all__ = ["add_parser", "scenario_from_args"]


def add_parser(subparsers) -> None:
    durations = ",".join(f"{d:g}" for d in PAPER.durations)
    parser = subparsers.add_parser(
        "paper",
        help="reproduce Hollerbach & Suh 1987: Figures 2-7, stick figures, summary.json and summary.md",
        description=(
            "Simulate the paper's scenario: the 3-link planar arm (no gravity, limits 54/24/6 N·m) from "
            "q0 = (-45°, 135°, -135°) along (1, 1) with √2 m/s², short, medium and long movements, every resolver, "
            "and the free-swinging arm of Fig. 7. Writes fig2.png ... fig7.png, arm_long_<resolver>.png, "
            "tip_long.png, summary.json and summary.md into DIR, and checks the paper's six claims. "
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
    group.add_argument(
        "--growth-factor",
        metavar="K",
        default=repr(DEFAULT_GROWTH_FACTOR),
        help="for joints without a torque limit: unstable beyond K times the starting torque "
        f"(default {DEFAULT_GROWTH_FACTOR:g})",
    )
    parser.set_defaults(handler=paper_command)


def paper_command(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    scenario, limit_factor, growth_factor = scenario_from_args(args)
    writable_path(args.out, directory=True)
    results = run_paper(scenario, limit_factor=limit_factor, growth_factor=growth_factor)
    written = write_paper(results, args.out)

    print(f"{'movement':<9}{'resolver':<21}{'peak |tau|/limit':>18}{'limit exceeded':>16}  verdict")
    for (movement, name), result in results.runs.items():
        violation = result.first_limit_violation
        report = results.whiplash[movement, name]
        if report.unstable:
            verdict = f"UNSTABLE from t = {report.time:.3f} s"
        else:
            verdict = "not judged" if np.isnan(report.peak_demand) else "stable"
        if not result.completed:
            verdict += f" (stopped early: {result.stop_reason})"
        violation_text = f"t = {violation:.3f} s" if violation is not None else "no"
        print(f"{movement:<9}{name:<21}{result.peak_torque_ratio.max():18.2f}{violation_text:>16}  {verdict}")
    if scenario != PAPER:
        print("the claims below are the paper's, checked on this changed scenario:")
    for claim in results.claims:
        print(f"claim {claim.number}: {'holds' if claim.holds else 'DOES NOT HOLD'}: {claim.statement}")
    print(f"wrote {len(written)} files to {args.out} in {time.perf_counter() - started:.1f} s")
    return EXIT_STOPPED if results.stopped_early else EXIT_OK


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
