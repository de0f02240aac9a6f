"""Every torqueopt command in the README's ```bash blocks runs and does what the README says.

The commands run in order in one temporary folder (later ones read the files
earlier ones wrote), each as a separate process with a timeout. Left out:
the placeholder for the reader's own URDF (``my_arm/...``), and live
playback (``--play``, or ``play`` without ``--html``), which waits for a
browser. The waypoint file the README's ``csv:waypoints.csv`` example reads is
written first, in the format the README gives. A command whose README text
shows its output must print exactly that.
"""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()


def readme_commands() -> list[tuple[str, str | None]]:
    """(command, the output the README shows right after its block, or None), in README order."""
    found = []
    for match in re.finditer(r"```bash\n(.*?)```(\n\n```\n(.*?)```)?", README, re.S):
        block, shown = match.group(1), match.group(3)
        lines = [line.strip() for line in re.sub(r"\\\n\s*", " ", block).splitlines()]
        commands = [line.split("  #")[0].strip() for line in lines if line.startswith("torqueopt ")]
        for index, command in enumerate(commands):
            found.append((command, shown if index == len(commands) - 1 else None))
    return found


def _skipped(command: str) -> str | None:
    words = shlex.split(command)
    if any(word.startswith("my_arm/") for word in words):
        return "a placeholder for the reader's own URDF"
    if "--play" in words or (words[1] == "play" and "--html" not in words):
        return "live playback waits for a browser"
    return None


COMMANDS = readme_commands()


def test_the_readme_has_commands_to_run():
    assert len(COMMANDS) >= 10
    assert COMMANDS[0][1] is not None and COMMANDS[0][1].startswith("planar3: resolver null-space")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    path = tmp_path_factory.mktemp("readme")
    (path / "waypoints.csv").write_text("t,x,y\n0,0,0\n0.5,0.05,0.02\n1.0,0.1,0.0\n")
    return path


@pytest.mark.slow
@pytest.mark.parametrize("command, shown", COMMANDS, ids=[command[:70] for command, _ in COMMANDS])
def test_every_readme_command_does_what_the_readme_says(folder, command, shown):
    reason = _skipped(command)
    if reason:
        pytest.skip(reason)
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    process = subprocess.run(
        [sys.executable, "-m", "torqueopt", *shlex.split(command)[1:]],
        capture_output=True, text=True, cwd=folder, env=environment, timeout=300, check=False,
    )  # fmt: skip
    assert process.returncode == 0, f"{command}\n{process.stdout}\n{process.stderr}"
    assert "Traceback" not in process.stderr and "error" not in process.stderr, process.stderr
    if shown is not None:
        assert process.stdout == shown, f"{command} printed\n{process.stdout}"
