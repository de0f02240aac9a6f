"""The paper's equations are cited in one format, ``Eq. (N)``, and each resolver's list of them agrees everywhere.

A reader finds any equation by grepping ``Eq. (N)``: in the package, in the
README and the other Markdown files and in the examples every citation is written that way (never
``Eq.(N)``, ``eq. N``, ``Eqs. (1)-(3)``, ``equation (N)`` or ``(Eq. 31)``).
Each registered resolver lists its equations in its class attribute
``equations``; the registry's tables (the docstrings of
:mod:`torqueopt.resolvers` and :mod:`torqueopt.resolvers.velocity`), the
tables of the README and of docs/, the resolver's docstrings and the comments at the lines
that compute them all carry exactly those numbers. And the code, the README,
the examples and the tests cite no issue, pull-request or session numbers.
"""

from __future__ import annotations

import inspect
import re
import sys
from pathlib import Path

import pytest

import torqueopt.resolvers
import torqueopt.resolvers.velocity
from torqueopt.resolvers import RESOLVERS

ROOT = Path(__file__).resolve().parents[1]
CITED = re.compile(r"Eq\. \((\d+)\)")
#: Any mention of an equation by number: "Eq", "Eqs", "eq", "equation(s)", with or without "." and "(".
MENTION = re.compile(r"\b(?:[Ee]qs?|[Ee]quations?)\b\.?\s*\(?\s*\d+")
#: A number in parentheses that continues a citation list without its own "Eq.": "Eq. (1), (2)", "Eq. (1)-(3)".
CONTINUED = re.compile(r"\)\s*(?:,|-|–|—|and|or|to)\s*\(\d+\)")
LISTED = re.compile(r"(?:[Ee]qs?|[Ee]quations?)\.?\s*\(\d+\)$")
#: A number of an issue, a pull request or a work session.
WORK_ITEM = re.compile(r"\b[Ii]ssues? #?\d+|\b(?:[Pp]ull request|PR) #?\d+|(?<![\w/&])#\d+\b|\b[Ss]ession \d+")
#: The paper numbers its equations (1) to (37).
PAPER_EQUATIONS = range(1, 38)


def cited_files() -> list[Path]:
    return [
        *sorted((ROOT / "torqueopt").rglob("*.py")),
        *sorted((ROOT / "examples").glob("*.py")),
        *sorted(ROOT.glob("*.md")),
        *sorted((ROOT / "examples").glob("*.md")),
        *sorted((ROOT / "docs").rglob("*.md")),
    ]


def miscited(text: str) -> list[str]:
    """The citations in ``text`` not written ``Eq. (N)``, and numbers of the paper it cites outside its range."""
    found = [match.group(0) for match in MENTION.finditer(text) if not CITED.match(text, match.start())]
    for match in CONTINUED.finditer(text):
        # "f(x) - (3)" in code is not a citation; a list is one only when it follows a citation.
        if LISTED.search(text, max(match.start() - 16, 0), match.start() + 1):
            found.append(match.group(0))
    found += [f"Eq. ({number})" for number in CITED.findall(text) if int(number) not in PAPER_EQUATIONS]
    return found


@pytest.mark.parametrize(
    "text, expected",
    [
        ("torque of Eq. (31) and Eq. (20)", []),
        ("as Eq.(5) says", ["Eq.(5"]),
        ("see eq. 31", ["eq. 31"]),
        ("Eqs. (1)-(3)", ["Eqs. (1", ")-(3)"]),
        ("Eq. (1), (2)", ["), (2)"]),
        ("from equation (12)", ["equation (12"]),
        ("(Eq. 31)", ["Eq. 31"]),
        ("Eq. (38)", ["Eq. (38)"]),
        ("equations of the paper", []),
        ("x = f(a) - (3) * b", []),
    ],
)
def test_the_citation_check_finds_each_variant(text, expected):
    assert miscited(text) == expected


@pytest.mark.parametrize("path", cited_files(), ids=lambda path: str(path.relative_to(ROOT)))
def test_every_equation_is_cited_as_eq_n(path):
    text = path.read_text(encoding="utf-8")
    wrong = [
        f"line {text.count(chr(10), 0, text.find(found)) + 1}: {found!r}" for found in dict.fromkeys(miscited(text))
    ]
    assert not wrong, f"{path.relative_to(ROOT)} cites equations not written Eq. (N): {'; '.join(wrong)}"


def registry_rows() -> dict[str, set[int]]:
    """Resolver name -> the equations in its row of the registry's reStructuredText tables."""
    rows = {}
    for module in (torqueopt.resolvers, torqueopt.resolvers.velocity):
        for line in module.__doc__.splitlines():
            name = re.match(r"``([a-z0-9-]+)``\s", line)
            if name:
                rows[name.group(1)] = {int(number) for number in CITED.findall(line)}
    return rows


def readme_rows() -> dict[str, set[int]]:
    """Resolver name -> the equations in its row of the documentation's tables with a ``paper`` column.

    The tables are in the README and in the pages of docs/ (the resolvers' pages and the Discussion's)."""
    rows = {}
    table: list[list[str]] = []
    pages = [ROOT / "README.md", *sorted(path for path in (ROOT / "docs").rglob("*.md") if "_build" not in path.parts)]
    lines = [line for page in pages for line in [*page.read_text(encoding="utf-8").splitlines(), ""]]
    for line in lines:
        if line.startswith("|"):
            table.append([cell.strip() for cell in re.split(r"(?<!\\)\|", line.strip())[1:-1]])
            continue
        if table and "paper" in table[0]:
            column = table[0].index("paper")
            for cells in table[2:]:
                name = re.fullmatch(r"`([a-z0-9-]+)`", cells[0])
                if name:
                    rows[name.group(1)] = {int(number) for number in CITED.findall(cells[column])}
        table = []
    return rows


def test_the_tables_list_every_registered_resolver():
    assert set(registry_rows()) == set(RESOLVERS)
    assert set(readme_rows()) == set(RESOLVERS)


@pytest.mark.parametrize("name", list(RESOLVERS))
def test_each_resolvers_equations_agree_between_class_registry_readme_and_docstrings(name):
    cls = RESOLVERS[name]
    declared = set(cls.equations)
    assert declared <= set(PAPER_EQUATIONS)
    assert registry_rows()[name] == declared, "the registry's table"
    assert readme_rows()[name] == declared, "the table in the README or docs/"
    documented = set(map(int, CITED.findall((cls.__doc__ or "") + (sys.modules[cls.__module__].__doc__ or ""))))
    assert declared <= documented, (
        f"the docstrings of {cls.__name__} and its module miss {sorted(declared - documented)}"
    )


@pytest.mark.parametrize("name", [name for name, cls in RESOLVERS.items() if cls.equations])
def test_each_declared_equation_is_cited_at_a_line_of_code(name):
    """``grep "Eq. (N)"`` lands on code: a comment citing N in the resolver's module, or in one of a base it
    inherits or of a function or class of torqueopt it calls (a criterion's module)."""
    modules = {inspect.getmodule(base) for base in RESOLVERS[name].__mro__}
    modules |= {inspect.getmodule(value) for module in list(modules) for value in vars(module).values()}
    comments = "".join(
        line.split("#", 1)[1]
        for module in modules
        if module is not None and module.__name__.startswith("torqueopt")
        for line in inspect.getsource(module).splitlines()
        if "#" in line and not line.lstrip().startswith(('"', "'"))
    )
    cited = set(map(int, CITED.findall(comments)))
    assert set(RESOLVERS[name].equations) <= cited, f"no comment cites {sorted(set(RESOLVERS[name].equations) - cited)}"


def test_the_work_item_check_finds_issue_and_pull_request_numbers():
    # Built from pieces, so that this file itself cites none.
    cited = ["issue" + " 3", "#" + "12", "PR" + " 7", "session" + " 2"]
    text = f"as {cited[0]} asks; see {cited[1]} and {cited[2]} ({cited[3]}); colour #ff0000, Eq. (3), the issues found"
    assert WORK_ITEM.findall(text) == cited


@pytest.mark.parametrize(
    "path",
    [path for path in cited_files() if path.relative_to(ROOT).parts[0] != "docs"]
    + sorted((ROOT / "tests").glob("*.py")),
    ids=lambda path: str(path.relative_to(ROOT)),
)
def test_no_issue_numbers_in_code_docstrings_or_tests(path):
    """The code says what it does, not which piece of work brought it: no issue, pull-request or session numbers."""
    found = WORK_ITEM.findall(path.read_text(encoding="utf-8"))
    assert not found, f"{path.relative_to(ROOT)} cites work items: {found}"


def test_every_equation_the_package_cites_lands_on_a_line_of_code():
    """``grep "Eq. (N)" torqueopt`` finds, for every N the package cites, a comment at a line that computes it."""
    cited, at_code = set(), set()
    for path in (ROOT / "torqueopt").rglob("*.py"):
        for line in path.read_text(encoding="utf-8").splitlines():
            cited |= set(map(int, CITED.findall(line)))
            if "#" in line and not line.lstrip().startswith(('"', "'")):
                at_code |= set(map(int, CITED.findall(line.split("#", 1)[1])))
    assert cited and not cited - at_code, f"cited only in prose: {sorted(cited - at_code)}"
