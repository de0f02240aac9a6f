"""The ``torqueopt`` command line: a thin layer over the Python API.

Exit codes:
    0  success (torque-limit violations are findings, not failures);
    2  bad input: the message names the bad value and what would be valid;
    3  the work stopped short: a simulation stopped early (diverged, or the
       Jacobian went singular), or ``optimize``'s solver did not converge;
       everything computed up to then is still written and summarised;
    4  ``tune`` found no setting that meets its criteria (its evidence is
       still written);
    130  interrupted (Ctrl-C), with one line ``torqueopt COMMAND: interrupted``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from functools import partial

from ..errors import TorqueoptError, TorqueoptWarning

__all__ = ["main", "EXIT_OK", "EXIT_BAD_INPUT", "EXIT_STOPPED", "EXIT_NONE_QUALIFIES"]

EXIT_OK = 0
EXIT_BAD_INPUT = 2
EXIT_STOPPED = 3
EXIT_NONE_QUALIFIES = 4

# One module per subcommand, each with ``add_parser(subparsers)`` that sets
# ``handler`` (a function of the parsed arguments returning an exit code).
_COMMANDS = ("run", "robots", "resolvers", "play", "paper", "plot", "atlas", "optimize", "tune")


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (and exit code 2), not usage text, and no option is taken
    by an abbreviation (``--dur`` for ``--durations``): a prefix is an unknown option."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="torqueopt",
        description=(
            "Redundancy resolution of robot arms through torque optimisation "
            "(Hollerbach & Suh 1987), simulated with Pinocchio."
        ),
        epilog=(
            "Exit codes: 0 success, 2 bad input, 3 stopped short (a simulation diverged or went singular, "
            "or the optimiser did not converge), 4 tune: no setting qualifies."
        ),
    )
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"torqueopt {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    subparsers.required = True
    for name in _COMMANDS:
        importlib.import_module(f"{__name__}.{name}").add_parser(subparsers)
    for subparser in subparsers.choices.values():
        subparser.set_defaults(parser=subparser)
    return parser


#: Options whose empty text means something: an empty figure title is no title.
_MAY_BE_EMPTY = frozenset({"title"})


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script exits with it).

    A Ctrl-C ends it with one line, ``torqueopt: interrupted`` while it imports the commands' modules (a second
    or more on a loaded machine), ``torqueopt COMMAND: interrupted`` once a command runs, and exit code 130.
    """
    try:
        parser = build_parser()  # imports every command's module
    except KeyboardInterrupt:
        print("torqueopt: interrupted", file=sys.stderr)
        return 130
    args, unknown = parser.parse_known_args(_bare_gravity_last(sys.argv[1:] if argv is None else list(argv)))
    if unknown:
        # Name the subcommand's own help, where its options are listed.
        args.parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    # An empty value (--out '', --frame '') would fall back to a default or write nothing, silently.
    empty = [name for name, value in vars(args).items() if value == "" and name not in _MAY_BE_EMPTY]
    if empty:
        action = next((a for a in args.parser._actions if a.dest == empty[0]), None)
        if action is not None and not action.option_strings:  # a positional argument
            args.parser.error(f"{action.metavar or action.dest.upper()} is empty; give a value")
        option = action.option_strings[-1] if action is not None else "--" + empty[0].replace("_", "-")
        args.parser.error(f"{option} is empty; give a value, or leave the option out for its default")
    # A reader that goes away (``torqueopt run ... | head -1``) must cost no
    # result: commands write their files before they print, and a closed
    # stdout only swallows the rest of what they print, so the command runs
    # to its end and exits with its own code.
    _replace_what_the_terminal_cannot_show()
    backend_problem = _unusable_matplotlib_backend()
    if backend_problem:
        print(f"torqueopt {args.command}: error: {backend_problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    stdout = sys.stdout
    sys.stdout = _ForgivingStdout(stdout)
    show_warning = warnings.showwarning
    warnings.showwarning = partial(_note, args.command, show_warning)
    try:
        return args.handler(args)
    except TorqueoptError as error:
        print(f"torqueopt {args.command}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"torqueopt {args.command}: interrupted", file=sys.stderr)
        return 130
    finally:
        warnings.showwarning = show_warning
        sys.stdout.flush()
        sys.stdout = stdout


def _bare_gravity_last(argv: list[str]) -> list[str]:
    """``--gravity`` takes an optional vector, so argparse would read the word after a bare ``--gravity`` as one:
    ``plot --gravity RUN.csv`` would lose its RUN. A bare ``--gravity`` before a word that is not X,Y,Z (three
    comma-separated parts) but names a file moves to the end, where it takes no value."""
    if "--" in argv:  # past a "--" every word is positional: leave the line as written
        return argv
    for index, word in enumerate(argv[:-1]):
        following = argv[index + 1]
        if word == "--gravity" and following.count(",") != 2 and os.path.exists(following):
            return [*_bare_gravity_last([*argv[:index], *argv[index + 1 :]]), "--gravity"]
    return argv


def _replace_what_the_terminal_cannot_show() -> None:
    """On a stream whose encoding lacks the output's characters (N·m, σ, →; PYTHONIOENCODING=ascii), print them
    as '?' rather than fail after the work is done."""
    for stream in (sys.stdout, sys.stderr):
        encoding = getattr(stream, "encoding", None) or "utf-8"
        try:
            "·σ→²".encode(encoding)
        except (UnicodeEncodeError, LookupError):
            reconfigure = getattr(stream, "reconfigure", None)
            if reconfigure is not None:
                reconfigure(errors="replace")


def _unusable_matplotlib_backend() -> str | None:
    """What is wrong with MPLBACKEND when matplotlib refuses it (its import then fails with ValueError), else None.

    torqueopt draws on Agg canvases of its own and never needs the backend, but an invalid one breaks the import."""
    backend = os.environ.get("MPLBACKEND")
    if not backend:
        return None
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return None  # the commands that draw say that matplotlib is missing
    except ValueError:
        return (
            f"MPLBACKEND={backend!r} is not a matplotlib backend; unset it or give one such as Agg "
            "(torqueopt draws its figures on its own canvas)"
        )
    return None


def _note(command: str, fallback, message, category, *args, **kwargs) -> None:
    """Print torqueopt's own warnings as one line, ``torqueopt <command>: note: ...``; others as Python does."""
    if issubclass(category, TorqueoptWarning):
        print(f"torqueopt {command}: note: {message}", file=sys.stderr)
    else:
        fallback(message, category, *args, **kwargs)


class _ForgivingStdout:
    """A text stream that, once its reader has gone (EPIPE), drops what is written instead of raising."""

    def __init__(self, stream):
        self._stream = stream
        self._reader_gone = False

    def write(self, text: str) -> int:
        if not self._reader_gone:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._gone()
        return len(text)

    def flush(self) -> None:
        if not self._reader_gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._gone()

    def _gone(self) -> None:
        self._reader_gone = True
        # What is still buffered goes to /dev/null at exit, so the interpreter's
        # last flush cannot fail again (which would exit 120 with a message).
        _silence_stdout()

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _silence_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass  # stdout is not a real file (a test's capture): nothing can fail at exit
