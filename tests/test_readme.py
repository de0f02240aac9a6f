"""Every command and Python snippet of the README and of the documentation's pages runs and does what the page says.

The pages are README.md, then every Markdown page of docs/ (the site's sources, docs/guide/ included) in
path order. The ``torqueopt`` commands of their ```bash blocks run in that order in one temporary folder
(later ones read the files earlier ones wrote), each as a separate process with a timeout. Left out: the
placeholder for the reader's own URDF (``my_arm/...``), and live playback (``--play``, or ``play`` without
``--html``), which waits for a browser. The waypoint file the ``csv:waypoints.csv`` example reads is
written first, in the format the page gives, and docs/paths.md's ``turn.csv`` from the page itself. A command whose page shows its output right after its block
must print exactly that.

The ```python blocks of one page run one after the other in one fresh interpreter (a later block may use
the names an earlier one defined), in a temporary folder of their own.
"""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted(path for path in (ROOT / "docs").rglob("*.md") if "_build" not in path.parts)]
#: The pages whose snippets are quick enough for the quick selection (the first five minutes of a reader).
QUICK_PAGES = {"README.md", "docs/getting-started.md"}


def page_name(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def page_commands(text: str) -> list[tuple[str, str | None]]:
    """(command, the output the page shows right after its block, or None), in page order."""
    found = []
    for match in re.finditer(r"```bash\n(.*?)```(\n\n```\n(.*?)```)?", text, re.S):
        block, shown = match.group(1), match.group(3)
        lines = [line.strip() for line in re.sub(r"\\\n\s*", " ", block).splitlines()]
        commands = [line.split("  #")[0].strip() for line in lines if line.startswith("torqueopt ")]
        for index, command in enumerate(commands):
            found.append((command, shown if index == len(commands) - 1 else None))
    return found


def page_snippets(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, re.S)


def _skipped(command: str) -> str | None:
    words = shlex.split(command)
    if any(word.startswith("my_arm/") for word in words):
        return "a placeholder for the reader's own URDF"
    if "--play" in words or (words[1] == "play" and "--html" not in words):
        return "live playback waits for a browser"
    return None


COMMANDS = [(page_name(page), command, shown) for page in PAGES for command, shown in page_commands(page.read_text())]
SNIPPETS = {page_name(page): page_snippets(page.read_text()) for page in PAGES}
SNIPPETS = {name: blocks for name, blocks in SNIPPETS.items() if blocks}


def test_the_pages_have_commands_and_snippets_to_run():
    assert len(COMMANDS) >= 10 and {page for page, _, _ in COMMANDS} >= {"README.md", "docs/running.md"}
    shown = [output for _, _, output in COMMANDS if output is not None]
    assert any(output.startswith("planar3: resolver null-space") for output in shown)
    assert {"README.md", "docs/running.md", "docs/dexterity.md"} <= set(SNIPPETS)


def test_the_readme_stays_the_first_five_minutes():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 250
    first_block = re.search(r"```bash\n(.*?)```", text, re.S).group(1).splitlines()
    assert first_block == [
        "python3 -m venv .venv && . .venv/bin/activate && pip install . && torqueopt paper --out paper-out",
        "python3 -m venv .venv && . .venv/bin/activate && pip install '.[test]' && python -m pytest -q -n auto --dist loadfile",
    ]


def test_ci_runs_the_readmes_test_command():
    """`.ci/run`'s full-install job runs the README's test command as the README gives it."""
    first_block = re.search(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), re.S).group(1).splitlines()
    command = first_block[1].split(" && ", 2)[2]  # after the venv's creation and activation
    assert command.startswith("pip install '.[test]' && python -m pytest")
    assert command in (ROOT / ".ci" / "run").read_text().splitlines()


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    path = tmp_path_factory.mktemp("pages")
    (path / "waypoints.csv").write_text("t,x,y\n0,0,0\n0.5,0.05,0.02\n1.0,0.1,0.0\n")
    # docs/paths.md's orientation path, as the page gives it
    page = (ROOT / "docs" / "paths.md").read_text()
    (path / "turn.csv").write_text(re.search(r"```text\n(t,x,y,z,qw,qx,qy,qz\n.*?)```", page, re.S).group(1))
    return path


@pytest.mark.slow
@pytest.mark.parametrize(
    "page, command, shown", COMMANDS, ids=[f"{page}: {command[:60]}" for page, command, _ in COMMANDS]
)
def test_every_command_on_the_pages_does_what_the_page_says(folder, page, command, shown):
    reason = _skipped(command)
    if reason:
        pytest.skip(reason)
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    process = subprocess.run(
        [sys.executable, "-m", "torqueopt", *shlex.split(command)[1:]],
        capture_output=True, text=True, cwd=folder, env=environment, timeout=300, check=False,
    )  # fmt: skip
    assert process.returncode == 0, f"{page}: {command}\n{process.stdout}\n{process.stderr}"
    assert "Traceback" not in process.stderr and "error" not in process.stderr, process.stderr
    if shown is not None:
        assert process.stdout == shown, f"{page}: {command} printed\n{process.stdout}"


@pytest.mark.parametrize(
    "page",
    [
        pytest.param(name, marks=() if name in QUICK_PAGES else pytest.mark.slow, id=name)
        for name in SNIPPETS
    ],
)  # fmt: skip
def test_every_python_snippet_on_the_pages_runs(tmp_path, page):
    environment = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    process = subprocess.run(
        [sys.executable, "-c", "\n".join(SNIPPETS[page])],
        capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=300, check=False,
    )  # fmt: skip
    assert process.returncode == 0, f"{page}\n{process.stdout}\n{process.stderr}"
    assert "Traceback" not in process.stderr, process.stderr
