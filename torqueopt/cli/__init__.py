"""The ``torqueopt`` command line: a thin layer over the Python API.

Exit codes:
    0  success (torque-limit violations are findings, not failures);
    2  bad input: the message names the bad value and what would be valid;
    3  the simulation stopped early (diverged, or the Jacobian went singular);
       everything computed up to then is still written and summarised.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import TorqueoptError

__all__ = ["main", "EXIT_OK", "EXIT_BAD_INPUT", "EXIT_STOPPED"]

EXIT_OK = 0
EXIT_BAD_INPUT = 2
EXIT_STOPPED = 3

# One module per subcommand, each with ``add_parser(subparsers)`` that sets
# ``handler`` (a function of the parsed arguments returning an exit code).
_COMMANDS = ("run", "robots", "resolvers", "play", "paper", "plot")


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (and exit code 2), not usage text."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="torqueopt",
        description=(
            "Redundancy resolution of robot arms through torque optimisation "
            "(Hollerbach & Suh 1987), simulated with Pinocchio."
        ),
        epilog="Exit codes: 0 success, 2 bad input, 3 simulation stopped early (diverged or singular).",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    subparsers.required = True
    for name in _COMMANDS:
        importlib.import_module(f"{__name__}.{name}").add_parser(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script exits with it)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.handler(args)
    except TorqueoptError as error:
        print(f"torqueopt {args.command}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # The reader went away (``torqueopt robots | head``): nothing left to say.
        sys.stderr.close()
        return EXIT_OK
    except KeyboardInterrupt:
        print(f"torqueopt {args.command}: interrupted", file=sys.stderr)
        return 130
