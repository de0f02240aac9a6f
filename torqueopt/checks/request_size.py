"""Bounds on the size of the work a request asks for (steps, frames, sweep cells), checked before the work starts."""

from __future__ import annotations

import math

from ..errors import InvalidInput
from .numbers import show_number

__all__ = ["DEFAULT_MAX_STEPS", "bounded_count", "step_budget", "step_count"]

#: Most steps one run may take (1000 s at the paper's 1 ms); ``max_steps`` raises it.
DEFAULT_MAX_STEPS = 1_000_000


def bounded_count(
    count: float, limit: int, what: str, noun: str, option: str, remedy: str = "", item_bytes: int | None = None
) -> int:
    """``count`` as an int when it is at most ``limit``, else InvalidInput naming both and how to raise the limit.

    Every piece of work whose size the user controls (simulation steps,
    playback frames, sweep cells) is checked here before it starts, so a
    mistyped ``1e9`` fails at once with one line instead of exhausting memory.

    Args:
        count: the number of items the request needs (a float is fine: huge
            or infinite requests are refused before any int conversion).
        limit: the largest count accepted.
        what: the request, e.g. ``"duration 1e+09 s at dt 0.001 s"``.
        noun: the items, plural, e.g. ``"steps"``.
        option: the option that raises the limit, e.g. ``"--max-steps"`` or ``"max_steps"``; None where the
            caller has no such option (the message then offers only ``remedy``).
        remedy: appended as ``"; remedy"``, e.g. "or give a larger dt".
        item_bytes: memory one item takes [bytes]; when given, the message
            says how much memory the request would need.

    Example message: ``duration 1e+09 s at dt 0.001 s needs 1e+12 steps, more
    than the limit of 1,000,000 steps (raise it with --max-steps)``.
    """
    try:
        limit = int(limit)
    except (TypeError, ValueError):
        raise InvalidInput(f"{option}={limit!r} is not a whole number") from None
    if limit < 1:
        raise InvalidInput(f"{option}={limit} must be a positive whole number")
    if not (math.isfinite(count) and count <= limit):
        shown = f"{count:.4g}" if math.isfinite(count) else "infinitely many"
        memory = f" (about {_bytes_text(count * item_bytes)} of memory)" if item_bytes and math.isfinite(count) else ""
        if option is None:
            extra = f"; {remedy.removeprefix('or ')}" if remedy else ""
            raise InvalidInput(f"{what} needs {shown} {noun}{memory}, more than the limit of {limit:,} {noun}{extra}")
        extra = f"; {remedy}" if remedy else ""
        raise InvalidInput(
            f"{what} needs {shown} {noun}{memory}, more than the limit of {limit:,} {noun} "
            f"(raise it with {option}){extra}"
        )
    return int(count)


def step_count(duration: float, dt: float) -> int:
    """The number of steps of length ``dt`` that make up ``duration``, or InvalidInput when dt does not divide it.

    A step that stopped short of the duration, or overshot it, would
    simulate a different movement than the one asked for (the reference
    would be sampled past its end), so a dt that does not divide the
    duration is refused, and the message offers the nearest steps that do.
    Within a relative 1e-9 (the rounding of decimal inputs such as 0.1 or
    0.001) the quotient counts as whole.
    """
    ratio = duration / dt
    if not math.isfinite(ratio):
        raise InvalidInput(f"duration {show_number(duration)} s at dt {show_number(dt)} s needs infinitely many steps")
    steps = round(ratio)
    if steps >= 1 and abs(ratio - steps) <= 1e-9 * max(ratio, 1.0):
        return int(steps)
    lower, upper = max(math.floor(ratio), 1), math.floor(ratio) + 1
    choices = " or ".join(f"{duration / count:.6g} s ({count} steps)" for count in sorted({lower, upper}))
    raise InvalidInput(
        f"dt={dt:g} s does not divide the duration {duration:g} s ({ratio:.4g} steps); "
        f"give a dt that does, such as {choices}"
    )


def step_budget(
    duration: float, dt: float, max_steps: int = DEFAULT_MAX_STEPS, option: str | None = "max_steps", row_bytes=None
) -> int:
    """The steps of a run of ``duration`` [s] at ``dt`` [s], checked before any work starts.

    Raises:
        InvalidInput: dt longer than the duration, more than ``max_steps``
            steps (the message names ``option``, the option that raises the
            limit, and the memory the run would need when ``row_bytes``, the
            bytes per recorded step, is given), or a dt that does not divide
            the duration (see :func:`step_count`).
    """
    if dt > duration:
        raise InvalidInput(f"dt={show_number(dt)} s is longer than the duration {show_number(duration)} s")
    bounded_count(
        duration / dt,
        max_steps,
        f"duration {duration:g} s at dt {dt:g} s",
        "steps",
        option,
        remedy="or give a larger dt or a shorter duration",
        item_bytes=row_bytes,
    )
    return step_count(duration, dt)


def _bytes_text(size: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if size < 1000 or unit == "PB":
            return f"{size:.3g} {unit}"
        size /= 1000
