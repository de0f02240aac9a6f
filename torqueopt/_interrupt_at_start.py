"""A Ctrl-C while the ``torqueopt`` command is still importing its modules ends it quietly, exit code 130.

Python's own handler would print the traceback of whichever import the Ctrl-C cut short (numpy's,
Pinocchio's: a second or more on a loaded machine, before any of the command's code runs). The handler is
installed only when this process is the command (``torqueopt ...`` or ``python -m torqueopt ...``), by the
first line of the package, and handed back to Python's by :func:`torqueopt.cli.main`, which from there on
turns a Ctrl-C into ``torqueopt COMMAND: interrupted`` itself. Nothing is written before then.
"""

from __future__ import annotations

import os
import signal
import sys
import threading


def _is_the_command() -> bool:
    if os.path.basename(sys.argv[0] if sys.argv else "") in ("torqueopt", "torqueopt.exe"):
        return True
    arguments = list(getattr(sys, "orig_argv", []))
    return any(flag == "-m" and module == "torqueopt" for flag, module in zip(arguments, arguments[1:]))


def _interrupted(number, frame) -> None:
    os.write(2, b"torqueopt: interrupted\n")
    os._exit(130)


def install() -> None:
    """Our handler, when this process is the command and SIGINT still has Python's."""
    if (
        _is_the_command()
        and threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    ):
        signal.signal(signal.SIGINT, _interrupted)


def release() -> None:
    """Python's handler back (KeyboardInterrupt), where :func:`install` put ours."""
    if signal.getsignal(signal.SIGINT) is _interrupted:
        signal.signal(signal.SIGINT, signal.default_int_handler)


install()
