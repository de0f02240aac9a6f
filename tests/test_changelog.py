"""CHANGELOG.md keeps the shape of Keep a Changelog (https://keepachangelog.com/en/1.1.0/).

The file opens with ``# Changelog``; then ``## [Unreleased]``; then one ``## [X.Y.Z] - YYYY-MM-DD`` section per
release, newest first, the newest being the package's own version. Inside a section only the six kinds of
change, each at most once and in the order the format lists them; a release says at least one change, the
Unreleased section may be empty.
"""

import datetime
import re
from pathlib import Path

import pytest

import torqueopt

ROOT = Path(__file__).resolve().parent.parent
#: The kinds of change Keep a Changelog names, in its order.
KINDS = ["Added", "Changed", "Deprecated", "Removed", "Fixed", "Security"]
RELEASE = re.compile(r"## \[(\d+)\.(\d+)\.(\d+)\] - (\d{4}-\d{2}-\d{2})")


def headings(text: str) -> list[tuple[int, str]]:
    """(line number, heading line) of every Markdown heading outside code blocks."""
    found, fenced = [], False
    for number, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced and line.startswith("#"):
            found.append((number, line.rstrip()))
    return found


def sections(text: str) -> list[tuple[str, list[str], str]]:
    """(version heading, its kind headings, its body text) for every ``##`` section, in file order."""
    found = []
    for part in re.split(r"^(?=## )", text, flags=re.M)[1:]:
        title, _, body = part.partition("\n")
        kinds = [line[4:].strip() for line in body.splitlines() if line.startswith("### ")]
        found.append((title.rstrip(), kinds, body))
    return found


def shape_errors(text: str) -> list[str]:
    """What in ``text`` breaks the changelog's shape, one line each (empty when it keeps it)."""
    errors = []
    if not text.startswith("# Changelog\n"):
        errors.append("the first line is not '# Changelog'")
    for number, line in headings(text):
        level = len(line) - len(line.lstrip("#"))
        if level > 3 or (level == 1 and number != 1):
            errors.append(f"line {number}: heading {line!r} is not a version (##) or a kind of change (###)")
    parts = sections(text)
    if not parts or parts[0][0] != "## [Unreleased]":
        errors.append("the first section is not '## [Unreleased]'")
    releases = []
    for index, (title, kinds, body) in enumerate(parts):
        if index == 0 and title == "## [Unreleased]":
            pass  # it may be empty and has no date
        elif not RELEASE.fullmatch(title):
            errors.append(f"{title!r} is not '## [X.Y.Z] - YYYY-MM-DD'")
        else:
            major, minor, patch, day = RELEASE.fullmatch(title).groups()
            try:
                date = datetime.date.fromisoformat(day)
            except ValueError:
                errors.append(f"{title!r}: {day} is not a date")
                continue
            releases.append(((int(major), int(minor), int(patch)), date, title))
            if not re.search(r"^- ", body, re.M):
                errors.append(f"{title!r} lists no change")
        unknown = [kind for kind in kinds if kind not in KINDS]
        if unknown:
            errors.append(f"{title!r}: {', '.join(unknown)} not one of {', '.join(KINDS)}")
        known = [kind for kind in kinds if kind in KINDS]
        if known != sorted(set(known), key=KINDS.index):
            errors.append(
                f"{title!r}: the kinds {', '.join(known)} are repeated or not in the order {', '.join(KINDS)}"
            )
    for (newer, newer_date, newer_title), (older, older_date, older_title) in zip(releases, releases[1:]):
        if not (newer > older and newer_date >= older_date):
            errors.append(f"{newer_title!r} is not newer than {older_title!r}, which follows it")
    return errors


CHANGELOG = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")


def test_the_changelog_keeps_its_shape():
    assert shape_errors(CHANGELOG) == []


def test_the_changelog_has_an_unreleased_section_with_its_kinds_of_change():
    title, kinds, _ = sections(CHANGELOG)[0]
    # The order of the kinds is keep-a-changelog's (the shape test); these three are always there to fill.
    assert title == "## [Unreleased]" and {"Added", "Changed", "Fixed"} <= set(kinds)


def test_the_newest_release_is_the_package_version():
    newest = next(RELEASE.fullmatch(title) for title, _, _ in sections(CHANGELOG) if RELEASE.fullmatch(title))
    assert ".".join(newest.groups()[:3]) == torqueopt.__version__


GOOD = """# Changelog

## [Unreleased]

### Added

## [0.2.0] - 2026-12-10

### Added

- a thing

### Fixed

- a bug

## [0.1.0] - 2026-12-03

### Changed

- another thing
"""


@pytest.mark.parametrize(
    "broken, error",
    [
        (GOOD.replace("# Changelog\n", "# Changes\n"), "the first line is not '# Changelog'"),
        (GOOD.replace("## [Unreleased]\n\n### Added\n\n", ""), "the first section is not '## [Unreleased]'"),
        (GOOD.replace(" - 2026-12-10", ""), "'## [0.2.0]' is not '## [X.Y.Z] - YYYY-MM-DD'"),
        (GOOD.replace("2026-12-10", "2026-13-10"), "'## [0.2.0] - 2026-13-10': 2026-13-10 is not a date"),
        (GOOD.replace("### Fixed", "### Bugs"), "'## [0.2.0] - 2026-12-10': Bugs not one of"),
        (GOOD.replace("### Fixed\n\n- a bug", "### Added\n\n- a bug"), "are repeated or not in the order"),
        (
            GOOD.replace("### Added\n\n- a thing\n\n### Fixed", "### Fixed\n\n- a thing\n\n### Added"),
            "not in the order",
        ),
        (GOOD.replace("[0.1.0] - 2026-12-03", "[0.3.0] - 2026-12-03"), "is not newer than"),
        (GOOD.replace("- another thing", ""), "'## [0.1.0] - 2026-12-03' lists no change"),
        (GOOD + "\n#### Detail\n", "heading '#### Detail' is not a version"),
    ],
)
def test_the_shape_check_finds_each_break(broken, error):
    assert shape_errors(GOOD) == []
    assert any(error in found for found in shape_errors(broken)), shape_errors(broken)
