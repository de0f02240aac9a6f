r"""Numbers in the documentation's pages, read from the JSON the commands wrote.

A page says its sentences; the numbers in them come from a committed JSON
file, between markers that name the key, so that ``python -m torqueopt.pages
PAGE ...`` writes them again and a test checks that the pages are current.
Three kinds of marker, each on one line:

``<!-- numbers NAME: PATH -->``
    the JSON file ``PATH`` (relative to the page) is the source ``NAME``.
``<!-- NAME:EXPR -->VALUE<!-- / -->``
    ``VALUE`` is ``EXPR`` evaluated on the source ``NAME``.
``<!-- table NAME:ROWS ;; EXPR ;; EXPR ... -->`` ... ``<!-- /table -->``
    between the two lines: a Markdown table whose header (the first two lines)
    the page writes and whose rows are one per element of the list ``ROWS``,
    one cell per ``EXPR`` evaluated on that element.

``EXPR`` is a key, optionally followed by `` as FORMAT`` (no ``|``: a page's
tables would split there). A key is a dotted path:
``runs.0.peak_torque`` indexes lists by position, ``runs[movement=short,
resolver=pinv]`` picks the one element of a list whose fields have those
values, and a key starting with ``/`` in a table's cell is read from the
source's root, with ``{field}`` replaced by the row's field. Two keys joined
by `` / `` or `` - `` give their quotient or difference (left to right; a
number may stand for a key). ``FORMAT`` is a Python format specification, one
of :data:`FORMATS`, or ``count`` (a list's length); a list is formatted
element by element, joined by ", ", and a null reads "-".
"""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

from .errors import InvalidInput

__all__ = ["FORMATS", "evaluate", "render_page", "stale_pages"]

#: Formats by name, beside Python's format specifications.
FORMATS = {
    "pct": lambda x: f"{round(100 * x)} %",  # a share as a whole percentage
    "pct1": lambda x: f"{100 * x:.1f} %",
    "mm": lambda x: f"{1e3 * x:.3g}",  # metres as millimetres
    "holds": lambda x: "holds" if x else "does not hold",
}

_SOURCE = re.compile(r"<!-- numbers ([\w-]+): (\S+) -->")
_VALUE = re.compile(r"<!-- ([\w-]+):([^\n]+?) -->(.*?)<!-- / -->")
_TABLE = re.compile(r"^<!-- table ([\w-]+):([^\n]+?) -->\n((?:.*\n)*?)<!-- /table -->$", re.M)
_FILTER = re.compile(r"^([\w-]+)\[(.*)\]$")


def lookup(data, key: str, rows: bool = False):
    """The value at the dotted ``key`` of ``data`` (module docstring); with ``rows``, a last ``field[...]`` gives
    every element that matches, not one."""
    value = data
    parts = re.split(r"\.(?![^\[]*\])", key)
    for index, part in enumerate(parts):
        match = _FILTER.match(part)
        if match:
            field, wanted = match.groups()
            conditions = dict(item.split("=", 1) for item in re.split(r",\s*(?=[\w-]+=)", wanted))
            found = [
                row
                for row in value[field]
                if all(str(row.get(name)) == text.strip() for name, text in conditions.items())
            ]
            if rows and index == len(parts) - 1:
                return found
            if len(found) != 1:
                raise InvalidInput(f"'{part}' picks {len(found)} rows of '{field}', not one")
            value = found[0]
        elif isinstance(value, list):
            if not part.isdigit() or int(part) >= len(value):
                raise InvalidInput(f"'{part}' in '{key}' is no index of a list of {len(value)}")
            value = value[int(part)]
        else:
            if part not in value:
                raise InvalidInput(f"no key '{part}' in '{key}'; the keys there are {', '.join(value)}")
            value = value[part]
    return value


def evaluate(source, expression: str, row=None) -> str:
    """``expression`` (``KEY[ / KEY][ as FORMAT]``) evaluated on ``source``, or on ``row`` for a key not starting
    with ``/``, as the text the page shows."""
    expression, _, spec = expression.partition(" as ")
    parts = re.split(r" ([/-]) ", expression.strip())

    def read(key):
        if re.fullmatch(r"-?[\d.]+(e-?\d+)?", key):
            return float(key)
        if row is None or key.startswith("/"):
            return lookup(source, key.lstrip("/").format(**(row or {})))
        return lookup(row, key)

    value = read(parts[0])
    for operator, key in zip(parts[1::2], parts[2::2]):
        other = read(key)
        value = value / other if operator == "/" else value - other
    return _formatted(value, spec.strip())


def _formatted(value, spec: str) -> str:
    if spec == "count":
        return str(len(value))
    if isinstance(value, list):
        return ", ".join(_formatted(item, spec) for item in value)
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if spec in FORMATS:
        return FORMATS[spec](value)
    try:
        return format(value, spec) if spec else str(value)
    except ValueError:
        raise InvalidInput(
            f"format '{spec}' is neither a Python format specification for {value!r} nor one of "
            f"{', '.join(FORMATS)}, count"
        ) from None


def render_page(text: str, folder: Path) -> str:
    """``text`` (a page in ``folder``) with every marked number and table written from its sources."""
    first = re.search(r"^[ \t]*<!-- [\w-]+:[^\n]*?<!-- / -->", text, re.M)
    if first:  # a line that opens with a comment would be read as a block of raw HTML, not as prose
        raise InvalidInput(f"a marked number starts a line: '{first[0].strip()[:60]}'; move a word before it")
    sources = {name: json.loads((folder / path).read_text()) for name, path in _SOURCE.findall(text)}

    def source(name):
        if name not in sources:
            raise InvalidInput(f"the page names no source '{name}' (<!-- numbers {name}: PATH -->)")
        return sources[name]

    def table(match):
        name, spec, body = match.groups()
        rows_key, *columns = [part.strip() for part in spec.split(";;")]
        header = body.splitlines()[:2]
        rows = [
            "| " + " | ".join(evaluate(source(name), column, row) for column in columns) + " |"
            for row in lookup(source(name), rows_key, rows=True)
        ]
        return "\n".join([f"<!-- table {name}:{spec} -->", *header, *rows, "<!-- /table -->"])

    text = _TABLE.sub(table, text)
    return _VALUE.sub(lambda m: f"<!-- {m[1]}:{m[2]} -->{evaluate(source(m[1]), m[2])}<!-- / -->", text)


def stale_pages(paths) -> list[Path]:
    """The pages among ``paths`` whose marked numbers differ from what their sources give."""
    return [Path(p) for p in paths if render_page(Path(p).read_text(), Path(p).parent) != Path(p).read_text()]


def main(argv=None) -> int:
    """``python -m torqueopt.pages PAGE ...``: write every page's marked numbers from its sources."""
    for path in map(Path, sys.argv[1:] if argv is None else argv):
        text = path.read_text()
        try:
            rendered = render_page(text, path.parent)
        except InvalidInput as error:
            print(f"torqueopt.pages: {path}: {error}", file=sys.stderr)
            return 2
        if rendered != text:
            path.write_text(rendered)
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
