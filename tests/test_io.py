"""The rule for what is already where a file is written: real special files, made in tmp_path."""

import math
import os
import re
import socket
import stat
from pathlib import Path

import pytest

from torqueopt.cli import main
from torqueopt.errors import OutputError
from torqueopt.io import atomic_write, writable_path

PAPER = ["--robot", "planar3", "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--direction", "1,1"]


def write_text(path, text="new"):
    atomic_write(path, lambda handle: handle.write(text.encode()))


def test_a_new_name_is_written_with_the_umask(tmp_path):
    path = tmp_path / "deep" / "new.txt"
    write_text(path)
    umask = os.umask(0)
    os.umask(umask)
    assert path.read_text() == "new" and stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask


def test_a_replaced_file_keeps_its_mode(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text("old")
    path.chmod(0o640)
    write_text(path)
    assert path.read_text() == "new" and stat.S_IMODE(path.stat().st_mode) == 0o640
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left


def test_a_symlink_is_written_through_and_stays_a_link(tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("old")
    target.chmod(0o600)
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    write_text(link)
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new" and stat.S_IMODE(target.stat().st_mode) == 0o600


def test_a_dangling_symlink_is_refused(tmp_path):
    link = tmp_path / "link.csv"
    link.symlink_to(tmp_path / "missing.csv")
    with pytest.raises(OutputError, match=r"it is a symbolic link to '.*missing.csv', which does not exist"):
        write_text(link)
    assert link.is_symlink() and not (tmp_path / "missing.csv").exists()


def test_a_hard_linked_file_is_refused_and_both_names_keep_their_content(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text("old")
    other = tmp_path / "other.csv"
    os.link(path, other)
    with pytest.raises(OutputError, match="it has 2 hard links, and replacing it would split them"):
        write_text(path)
    assert path.read_text() == other.read_text() == "old" and path.stat().st_ino == other.stat().st_ino


def test_a_read_only_file_is_refused_even_for_root(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text("old")
    path.chmod(0o444)
    with pytest.raises(OutputError, match="it is read-only"):
        write_text(path)
    with pytest.raises(OutputError, match="it is read-only"):
        writable_path(path)
    assert path.read_text() == "old"


def _fifo(path):
    os.mkfifo(path)
    return path


def _socket(path):
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(str(path))
    return path


def _device(path):
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    null = os.stat("/dev/null")
    os.mknod(path, stat.S_IFCHR | 0o666, null.st_rdev)
    return path


def _folder(path):
    path.mkdir()
    return path


@pytest.mark.parametrize(
    "make, kind, test",
    [
        (_fifo, "a FIFO (named pipe)", stat.S_ISFIFO),
        (_socket, "a socket", stat.S_ISSOCK),
        (_device, "a character device", stat.S_ISCHR),
        (_folder, "a folder", stat.S_ISDIR),
    ],
)
def test_special_files_are_refused_and_left_as_they_are(tmp_path, make, kind, test):
    path = make(tmp_path / "special")
    for check in (writable_path, write_text):
        with pytest.raises(OutputError, match=f"cannot write '.*special': it is {re.escape(kind)}"):
            check(path)
    assert test(os.lstat(path).st_mode)
    # Through a symbolic link too.
    link = tmp_path / "link"
    link.symlink_to(path)
    with pytest.raises(OutputError, match=f"through the symbolic link to .*: it is {re.escape(kind)}"):
        write_text(link)
    assert test(os.lstat(path).st_mode)


@pytest.fixture
def saved_run(tmp_path):
    out = tmp_path / "run.csv"
    assert main(["run", *PAPER, "--resolver", "pinv", "--duration", "0.1", "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize(
    "name, command",
    [
        ("out.csv", lambda run, fifo: ["run", *PAPER, "--resolver", "pinv", "--duration", "0.1", "--out", fifo]),
        ("out.pdf", lambda run, fifo: ["plot", run, "--out", fifo]),
        ("out.html", lambda run, fifo: ["play", run, "--html", fifo]),
    ],
    ids=["run --out", "plot --out", "play --html"],
)
def test_every_writer_refuses_a_fifo_with_exit_2(tmp_path, saved_run, name, command, capsys):
    fifo = _fifo(tmp_path / name)
    capsys.readouterr()
    assert main(command(str(saved_run), str(fifo))) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "it is a FIFO (named pipe), not a regular file" in err[0]
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


# -- the files of one command: checked before any work, written as one unit ------------------------------


RUN = ["run", *PAPER, "--resolver", "pinv", "--duration", "0.1"]


def _old_run(tmp_path, name="old.csv"):
    """A run file and its sidecar as an earlier run left them: their contents, to check they are untouched."""
    out = tmp_path / name
    assert main([*RUN, "--out", str(out)]) == 0
    return out, out.read_bytes(), Path(f"{out}.json").read_bytes()


def _read_only(path):
    path.chmod(0o444)
    return path


def _folder_instead(path):
    path.unlink()
    path.mkdir()
    return path


@pytest.mark.parametrize(
    "spoil, message",
    [(_read_only, "it is read-only; make it writable or write to a new name"), (_folder_instead, "it is a folder")],
    ids=["read-only sidecar", "folder at the sidecar"],
)
def test_run_refuses_a_sidecar_it_cannot_write_before_it_simulates(tmp_path, capsys, monkeypatch, spoil, message):
    out, data, sidecar = _old_run(tmp_path)
    spoil(Path(f"{out}.json"))
    import torqueopt.cli.run as run_module

    monkeypatch.setattr(run_module, "simulate", lambda *args, **kwargs: pytest.fail("simulated before the check"))
    capsys.readouterr()
    assert main([*RUN, "--resolver", "null-space", "--out", str(out)]) == 2
    assert capsys.readouterr().err == f"torqueopt run: error: cannot write '{out}.json': {message}" + (
        "; give a file name\n" if spoil is _folder_instead else "\n"
    )
    assert out.read_bytes() == data
    if spoil is _read_only:
        assert Path(f"{out}.json").read_bytes() == sidecar


def test_optimize_refuses_an_optimal_sidecar_it_cannot_write_before_it_solves(tmp_path, capsys, monkeypatch):
    out, data, sidecar = _old_run(tmp_path, "o.csv")
    optimal = Path(f"{out}.optimal.json")
    optimal.write_text("{}")
    _read_only(optimal)
    import torqueopt.cli.optimize as optimize_module

    monkeypatch.setattr(optimize_module, "optimize", lambda *args, **kwargs: pytest.fail("solved before the check"))
    capsys.readouterr()
    assert main(["optimize", *PAPER, "--duration", "0.1", "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"torqueopt optimize: error: cannot write '{out}.optimal.json': it is read-only; "
        "make it writable or write to a new name\n"
    )
    assert out.read_bytes() == data and Path(f"{out}.json").read_bytes() == sidecar


def test_files_written_together_all_land_or_none(tmp_path):
    from torqueopt.io import written_together

    first, second = tmp_path / "first.txt", tmp_path / "second.txt"
    first.write_text("old first")
    second.write_text("old second")
    with pytest.raises(RuntimeError, match="the work failed"), written_together():
        write_text(first, "new first")
        assert first.read_text() == "old first"  # nothing lands before the unit ends
        write_text(second, "new second")
        raise RuntimeError("the work failed")
    assert first.read_text() == "old first" and second.read_text() == "old second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["first.txt", "second.txt"]  # no temporaries left
    with written_together():
        write_text(first, "new first")
        write_text(second, "new second")
        write_text(Path(tmp_path / "deep" / "third.txt"), "new third")
    assert (first.read_text(), second.read_text()) == ("new first", "new second")
    assert (tmp_path / "deep" / "third.txt").read_text() == "new third"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deep", "first.txt", "second.txt"]


def test_a_unit_whose_last_rename_fails_puts_the_first_files_back(tmp_path, monkeypatch):
    """The renames at the end of a unit can fail too (a file made read-only meanwhile): the ones done are undone."""
    from torqueopt.io import written_together

    first, second = tmp_path / "first.txt", tmp_path / "second.txt"
    first.write_text("old first")
    real_replace = os.replace

    def failing_replace(source, target):
        if Path(target) == second:
            raise OSError(28, "No space left on device")
        return real_replace(source, target)

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OutputError, match=f"cannot write '{second}': No space left on device"), written_together():
        write_text(first, "new first")
        write_text(second, "new second")
    assert first.read_text() == "old first" and not second.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["first.txt"]


def test_a_symlinked_run_file_has_its_sidecar_beside_its_target(tmp_path, capsys):
    data = tmp_path / "data"
    data.mkdir()
    target = data / "target.csv"
    target.write_text("")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    assert main([*RUN, "--out", str(link)]) == 0
    assert f"wrote {link} and {target}.json" in capsys.readouterr().out
    assert Path(f"{target}.json").is_file() and not Path(f"{link}.json").exists()
    assert link.is_symlink()
    from torqueopt.result import load_result

    assert load_result(target).resolver == load_result(link).resolver == "pinv"
    assert main(["plot", str(target), "--out", str(tmp_path / "figure.png")]) == 0


def test_plot_checks_the_stick_figure_file_before_it_draws(tmp_path, capsys):
    out, _, _ = _old_run(tmp_path)
    (tmp_path / "figure-stick.png").mkdir()
    capsys.readouterr()
    code = main(["plot", str(out), "--out", str(tmp_path / "figure.png"), "--stick-figures"])
    assert code == 2
    assert capsys.readouterr().err.startswith(f"torqueopt plot: error: cannot write '{tmp_path}/figure-stick.png'")
    assert not (tmp_path / "figure.png").exists()


def test_json_value_is_what_a_json_file_holds():
    """The atlas's and tune's summaries go through it: NaN and infinities (numpy's too, inside arrays too) become
    null, numpy scalars and arrays Python numbers and lists, tuples lists, through dicts; the rest as it was."""
    import json

    import numpy as np

    from torqueopt.io import json_value

    value = {
        "ratio": np.float64(0.5), "count": np.int64(3), "flag": np.bool_(True), "none": math.nan, "top": -math.inf,
        "limits": np.array([[1.0, np.inf], [np.nan, 2.0]]), "pair": (np.float32(0.25), "a"), "name": "pinv", "n": 7,
    }  # fmt: skip
    converted = json_value(value)
    assert converted == {
        "ratio": 0.5, "count": 3, "flag": True, "none": None, "top": None, "limits": [[1.0, None], [None, 2.0]],
        "pair": [0.25, "a"], "name": "pinv", "n": 7,
    }  # fmt: skip
    assert [type(converted[key]) for key in ("ratio", "count", "flag")] == [float, int, bool]
    assert json.loads(json.dumps(converted, allow_nan=False)) == converted
