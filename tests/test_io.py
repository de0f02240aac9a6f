"""The rule for what is already where a file is written: real special files, made in tmp_path."""

import os
import re
import socket
import stat

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
