"""BENCHMARKS.md stays the current table and its method: short, with the blocks the benchmarks write and the
sections that the code and the documentation quote by name."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BENCHMARKS = (ROOT / "BENCHMARKS.md").read_text(encoding="utf-8")
#: A quote of one of its sections: ``BENCHMARKS.md, "Stick strips"`` or ``BENCHMARKS.md ("Stick strips")``.
QUOTE = re.compile(r'BENCHMARKS\.md[ ,(]{1,3}"([^"]+)"')


def test_benchmarks_md_is_at_most_300_lines():
    """The history lives in CHANGELOG.md and docs/decisions/, not here."""
    assert len(BENCHMARKS.splitlines()) <= 300


def test_benchmarks_md_keeps_the_blocks_the_scripts_write():
    """``--write BENCHMARKS.md`` of bench_simulate.py and bench_atlas.py replaces the text between their markers."""
    for name in ("bench", "bench_atlas"):
        begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
        assert BENCHMARKS.count(begin) == BENCHMARKS.count(end) == 1 and BENCHMARKS.index(begin) < BENCHMARKS.index(end)


def quoted_sections() -> dict[str, str]:
    """Section title -> the file quoting it, over the package, the README and the documentation."""
    files = [*sorted((ROOT / "torqueopt").rglob("*.py")), ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    return {title: path.relative_to(ROOT).as_posix() for path in files for title in QUOTE.findall(path.read_text())}


def test_every_section_quoted_by_name_is_a_heading():
    titles = [line.lstrip("#").strip() for line in BENCHMARKS.splitlines() if line.startswith("#")]
    quoted = quoted_sections()
    assert {"Stick strips", "Whole-path optimisation"} <= set(quoted)
    missing = {title: path for title, path in quoted.items() if not any(t.startswith(title) for t in titles)}
    assert not missing, f"BENCHMARKS.md has no section that these quote: {missing}"
