"""Progress on stderr: a bar that redraws itself on a terminal, one plain line in a pipe or a file."""

import io
import math
import re

import pytest

from torqueopt.cli import main
from torqueopt.progress import progress_bar


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_terminal_gets_a_bar_that_counts_to_its_total(monkeypatch):
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    with progress_bar("torqueopt paper: 13 runs", total=13) as bar:
        for _ in range(13):
            bar.update()
    assert bar.n == 13
    drawn = terminal.getvalue()
    assert "\r" in drawn and "torqueopt paper: 13 runs" in drawn and "13/13" in drawn


def test_a_pipe_gets_one_line_and_no_redraws(monkeypatch):
    pipe = io.StringIO()
    monkeypatch.setattr("sys.stderr", pipe)
    with progress_bar("torqueopt paper: 13 runs", total=13) as bar:
        for _ in range(13):
            bar.update()
    assert pipe.getvalue() == "torqueopt paper: 13 runs ...\n"
    quiet = io.StringIO()
    monkeypatch.setattr("sys.stderr", quiet)
    with progress_bar("nothing", total=3, enabled=False) as bar:
        bar.update(3)
    assert quiet.getvalue() == ""


PAPER_Q0 = "--q0=-0.7853981634,2.3561944902,-2.3561944902"


def test_paper_says_what_it_does_before_its_work(tmp_path, capsys, monkeypatch):
    """About 20 s of work: its first line is on stderr before the first run starts."""
    import torqueopt.cli.paper as paper_module

    seen = []

    def first_run(*args, **kwargs):
        seen.append(capsys.readouterr())
        raise KeyboardInterrupt

    monkeypatch.setattr(paper_module, "run_paper", first_run)
    assert main(["paper", "--out", str(tmp_path)]) == 130
    assert seen[0].out == ""
    assert seen[0].err.startswith("torqueopt paper: 12 runs and the free swing, then the remedies study (")
    assert seen[0].err.endswith(" ...\n") and seen[0].err.count("\n") == 1


def test_optimize_counts_ipopt_iterations_as_they_happen(capsys):
    import torqueopt
    from torqueopt.paper import PAPER

    robot = torqueopt.load_robot("planar3")
    calls = []
    result = torqueopt.optimize(
        robot,
        PAPER.line("short"),
        PAPER.q0,
        transcription="direct",
        hessian="gauss-newton",
        max_iterations=4,
        progress=calls.append,
    )
    assert result.iterations == 4 and calls == [0, 1, 2, 3, 4]  # IPOPT reports its start as iteration 0


def test_optimize_says_what_it_does_when_ipopt_starts(capsys):
    arguments = ["optimize", "--robot", "planar3", PAPER_Q0, "--direction", "1,1", "--duration", "0.5"]
    assert main([*arguments, "--max-iterations", "2"]) == 3
    assert capsys.readouterr().err == (
        "torqueopt optimize: IPOPT on 100 intervals of 5 ms (up to 2 iterations per run) ...\n"
    )


@pytest.mark.parametrize("no_progress", [False, True])
def test_the_atlas_bar_leaves_no_redraws_in_a_pipe(tmp_path, capsys, no_progress):
    pytest.importorskip("pandas")
    pytest.importorskip("distributed")
    pytest.importorskip("pyarrow")
    arguments = ["atlas", "--paths", "2", "--durations", "0.2", "--workers", "0", "--no-figures",
                 "--out", str(tmp_path)]  # fmt: skip
    assert main([*arguments, *(["--no-progress"] if no_progress else [])]) == 0
    error = capsys.readouterr().err
    assert "\r" not in error
    assert error == ("" if no_progress else "torqueopt atlas: 2 paths x 4 resolvers ...\n")


@pytest.mark.parametrize("stream", ["terminal", "pipe"])
def test_loading_a_slow_robot_says_so_within_a_second_and_a_quick_one_stays_silent(monkeypatch, stream):
    """A URDF that takes seconds to load (a long chain, a cold import of yourdfpy) gets a plain line once it is
    slow, on a terminal and in a pipe or a log alike (it was a terminal's only: a log waited in silence)."""
    import threading

    import torqueopt.atlas.jobs as jobs  # where every command's robot is loaded (RobotSpec.load)
    from torqueopt.progress import SLOW, SLOW_VARIABLE, slow_after

    monkeypatch.delenv(SLOW_VARIABLE)
    assert slow_after() == SLOW <= 1.0  # "within a second"
    for text, seconds in (("0", 0.0), ("2.5", 2.5), ("-1", SLOW), ("soon", SLOW), ("nan", SLOW)):
        monkeypatch.setenv(SLOW_VARIABLE, text)
        assert slow_after() == seconds
    error = _Terminal() if stream == "terminal" else io.StringIO()
    monkeypatch.setattr("sys.stderr", error)
    monkeypatch.setenv(SLOW_VARIABLE, "0")
    real_load = jobs.load_robot

    def slow_load(*args, **kwargs):
        waited = threading.Event()
        for _ in range(1000):  # until the line is there (the timer fires at once), at most 10 s
            if "loading" in error.getvalue():
                break
            waited.wait(0.01)
        return real_load(*args, **kwargs)

    monkeypatch.setattr(jobs, "load_robot", slow_load)
    arguments = ["run", "--robot", "planar3", PAPER_Q0, "--direction", "1,1", "--resolver", "pinv", "--duration", "0.1"]
    assert main(arguments) == 0
    assert error.getvalue() == "torqueopt run: loading robot 'planar3' ...\n"
    quick = _Terminal() if stream == "terminal" else io.StringIO()
    monkeypatch.setattr("sys.stderr", quick)
    monkeypatch.setattr(jobs, "load_robot", real_load)
    monkeypatch.setenv(SLOW_VARIABLE, "30")
    assert main(arguments) == 0
    assert quick.getvalue() == ""


def test_the_grid_atlas_says_it_is_solving_its_inverse_kinematics(tmp_path, capsys):
    """The grid's inverse kinematics (a minute and more for a fine grid) ran before any line: now a bar on a
    terminal, one line in a pipe, before the sweep's."""
    pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    arguments = ["atlas", "--mode", "grid", "--paths", "1", "--grid-spacing", "1.2", "--grid-directions", "2", "--durations", "0.2",
                 "--workers", "0", "--no-figures", "--resolvers", "pinv", "--out", str(tmp_path / "grid")]  # fmt: skip
    assert main(arguments) == 0
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2 and "\r" not in lines[0]
    count = int(re.fullmatch(r"torqueopt atlas: inverse kinematics of (\d+) grid points \.\.\.", lines[0]).group(1))
    # The grid points of spacing 1.2 m within 0.9 of planar3's 3 m reach, counted here.
    assert count == sum(1.2 * math.hypot(i, j) <= 2.7 for i in range(-2, 3) for j in range(-2, 3)) == 21
    assert re.fullmatch(r"torqueopt atlas: \d+ paths x 1 resolvers \.\.\.", lines[1])
