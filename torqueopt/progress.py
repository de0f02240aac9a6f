"""Progress of long work, on stderr: a bar on a terminal, one line elsewhere.

Work that can take more than a second (``paper``, ``optimize``'s IPOPT
iterations, the atlas, the grid atlas's inverse kinematics, loading a large
URDF) says what it is doing before it starts. On a terminal,
:func:`progress_bar` is a tqdm bar (done, rate, time left) that redraws itself
in place; when stderr is a pipe or a file, it writes one line when the work
starts and nothing more, since a bar's carriage-return redraws would be
garbage in a log. Work whose length is not known before it starts (loading a
URDF: seconds for a large one, most of them importing yourdfpy and checking
the chain; starting a Dask cluster) goes in :func:`said_if_slow`, which
writes its line, on a terminal and in a log alike, once the work has taken
:func:`slow_after` seconds, so quick work stays silent. stdout is never
touched, so ``torqueopt ... | head`` sees only the results.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextvars import ContextVar

__all__ = [
    "SLOW",
    "SLOW_VARIABLE",
    "command_name",
    "interrupt_deferred",
    "progress_bar",
    "said_if_slow",
    "slow_after",
    "speaking_for",
]

#: Seconds after which work in :func:`said_if_slow` says what it is doing.
SLOW = 1.0
#: The environment variable that sets those seconds instead (e.g. ``0``: say it always; a large number: never).
SLOW_VARIABLE = "TORQUEOPT_SLOW_SECONDS"

#: The command the user typed, when work of one command runs inside another (``tune`` runs an atlas).
_COMMAND: ContextVar[str | None] = ContextVar("torqueopt_command", default=None)


def command_name(default: str) -> str:
    """The command that progress lines name: ``default`` (``"torqueopt atlas"``), or the one
    :func:`speaking_for` set, so that ``torqueopt tune``'s user reads "torqueopt tune", not "torqueopt atlas"."""
    return _COMMAND.get() or default


@contextlib.contextmanager
def speaking_for(command: str) -> Iterator[None]:
    """Progress lines inside the block name ``command`` (see :func:`command_name`)."""
    token = _COMMAND.set(command)
    try:
        yield
    finally:
        _COMMAND.reset(token)


def progress_bar(description: str, total: int | None = None, unit: str = "run", enabled: bool = True, initial: int = 0):
    """A tqdm bar on stderr when it is a terminal; otherwise a disabled one, after one line ``description ...``.

    Args:
        description: what the work is, e.g. ``"torqueopt paper: 13 runs"``;
            the bar's label, or the line written when stderr is not a terminal.
        total: the units of work, when known. unit: their name.
        enabled: False: no bar and no line.
        initial: units already done (a resumed sweep).
    """
    from tqdm import tqdm

    stream = sys.stderr
    terminal = enabled and stream is not None and _isatty(stream)
    if enabled and not terminal and stream is not None:
        print(f"{description} ...", file=stream, flush=True)
    return tqdm(
        total=total,
        initial=initial,
        desc=description,
        unit=unit,
        file=stream,
        disable=not terminal,
        dynamic_ncols=True,
        smoothing=0.1,
        leave=True,
    )


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def slow_after() -> float:
    """Seconds after which :func:`said_if_slow` speaks: ``$TORQUEOPT_SLOW_SECONDS`` when it is a number >= 0, else
    :data:`SLOW`."""
    text = os.environ.get(SLOW_VARIABLE)
    if text is not None:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if value >= 0:
            return value
    return SLOW


@contextlib.contextmanager
def said_if_slow(description: str, enabled: bool = True) -> Iterator[None]:
    """Write ``description ...`` on stderr (a terminal, a pipe or a file) if the block is still running after
    :func:`slow_after` seconds: a plain line, once, whatever the stream."""
    stream = sys.stderr
    if not enabled or stream is None:
        yield
        return

    def say() -> None:
        with contextlib.suppress(OSError, ValueError):  # a closed or broken stderr costs no result
            print(f"{description} ...", file=stream, flush=True)

    if slow_after() <= 0:  # "at once" means before the block, not on a timer the block may beat
        say()
        yield
        return
    timer = threading.Timer(slow_after(), say)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


@contextlib.contextmanager
def interrupt_deferred() -> Iterator[list]:
    """Hold a Ctrl-C (SIGINT) until the block ends, then raise KeyboardInterrupt; yields the list of those held.

    Outside the main thread (where Python runs no signal handler), nothing is held.
    """
    held: list[int] = []
    if not _main_thread():
        yield held
        return
    previous = signal.signal(signal.SIGINT, lambda number, frame: held.append(number))
    try:
        yield held
    finally:
        signal.signal(signal.SIGINT, previous)
    if held:
        raise KeyboardInterrupt


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()
