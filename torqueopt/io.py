"""Writing files: the one place every writer of torqueopt goes through (the rules: docs/files.md).

:func:`writable_paths` checks, before any work, every file a command will write (distinct, not one it reads,
writable); :func:`atomic_write` writes one to a temporary name beside its target and renames it into place, so
a file is never left half-written: through a symbolic link to its target, keeping a replaced file's mode,
refusing hard-linked, read-only and special files (:class:`~torqueopt.errors.OutputError`, naming the path and
what it is). Inside :func:`written_together` the renames wait for the end of the block: all of a command's
files land, or none does.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import math
import os
import secrets
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from .errors import InvalidInput, OutputError

__all__ = [
    "atomic_write",
    "held_exclusively",
    "json_file_with",
    "refuse_foreign",
    "sidecar_path",
    "writable_path",
    "writable_paths",
    "written_together",
]


def writable_path(path: str | os.PathLike, directory: bool = False) -> Path:
    """``path`` after making sure a file can be written there; creates nothing.

    Missing folders are fine when the nearest existing one is writable (they
    are made when the file is written). ``directory=True`` checks ``path``
    itself as the folder to write into. Commands call this before they
    simulate, so that a bad output path fails at once, not after the work.

    Raises:
        OutputError: the path, or the folder it would go in, cannot be written.
    """
    path = Path(path)
    if directory:
        folder = path
    else:
        folder = _replaceable(path).parent
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise OutputError(f"cannot write to '{folder}': '{existing}' is {_kind(existing)}, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write to '{folder}': '{existing}' is not writable")
    return path


def writable_paths(paths: Iterable[str | os.PathLike], reading: Iterable[str | os.PathLike] = ()) -> list[Path]:
    """Every path of ``paths`` checked by :func:`writable_path`: the files one command will write, before its work.

    The files must also be distinct from each other and from the files the
    command reads (``reading``), through symbolic links and hard links: two
    outputs at one file would leave only the last one written (``run --out
    a.csv --html a.csv`` said it wrote the run and left a page), and an
    output at an input would replace the data it is made from.

    Raises:
        OutputError: a path cannot be written, or names the same file as
            another output or as an input.
    """
    checked = [writable_path(path) for path in paths]
    seen: dict[str, Path] = {}
    for path in checked:
        key = os.path.realpath(_replaceable(path))
        if key in seen:
            other = "" if str(seen[key]) == str(path) else f": it is the same file as '{seen[key]}'"
            raise OutputError(
                f"cannot write '{path}' as two of this command's files{other}; give each output its own name"
            )
        seen[key] = path
    for source in reading:
        for path in checked:
            if _same_file(path, source):
                other = "" if str(source) == str(path) else f" '{source}'"
                raise OutputError(
                    f"cannot write '{path}': it is the file{other} this command reads; give the output another name"
                )
    return checked


def json_file_with(path: str | os.PathLike, keys: Iterable[str]) -> bool:
    """True when ``path`` holds a JSON object with every one of ``keys``: a file a torqueopt command wrote."""
    try:
        value = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(value, dict) and set(keys) <= value.keys()


def refuse_foreign(paths: Iterable[str | os.PathLike], ours: bool, whose: str, remedy: str) -> None:
    """Refuse, before any work, to replace a file at ``paths`` unless the files there are ``ours``.

    A command replaces the files it wrote before (a second ``torqueopt paper``
    into its folder), never a user's file that happens to share a name with
    one of its outputs.

    Raises:
        OutputError: naming the first such file, ``whose`` it would have to be, and ``remedy``.
    """
    if ours:
        return
    for path in paths:
        if os.path.lexists(path):
            raise OutputError(
                f"cannot write '{path}': it is not {whose}, and torqueopt replaces only its own; {remedy}"
            )


@contextlib.contextmanager
def held_exclusively(path: str | os.PathLike, what: str) -> Iterator[None]:
    """Hold an exclusive lock on the existing file ``path`` (its folder's configuration) for the block.

    Two commands on one folder would both do all the work; the second is refused at once instead, naming
    ``what`` holds it. The lock is the kernel's (``flock``): it goes with the process, even a killed one, and
    the file itself is not changed.

    Raises:
        InvalidInput: another process holds the lock.
    """
    import fcntl

    with open(path, "rb") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            folder = Path(path).parent
            raise InvalidInput(
                f"'{folder}' is in use by another {what} running now: wait for it to finish (then run this again to "
                "read its results), or give another --out"
            ) from None
        yield


def _same_file(first: str | os.PathLike, second: str | os.PathLike) -> bool:
    """True when both paths exist and are one file (through links), or name the same place."""
    try:
        return os.path.samefile(first, second)
    except OSError:
        return os.path.realpath(first) == os.path.realpath(second)


def sidecar_path(path: str | os.PathLike, suffix: str = ".json") -> Path:
    """The sidecar ``<file><suffix>`` of the file a write to ``path`` goes to (through a symbolic link, its target).

    A dangling link or one that cannot be followed gives the sidecar beside
    the link: :func:`writable_path` refuses such a path anyway.
    """
    path = Path(path)
    if path.is_symlink() and path.exists():
        path = Path(os.path.realpath(path))
    return Path(f"{path}{suffix}")


class _Unit:
    """The files of one :func:`written_together` block: (temporary, target, path as given) each, renamed at its end."""

    def __init__(self):
        self.pending: dict[Path, tuple[str, Path]] = {}

    def add(self, temporary: str, target: Path, path: Path) -> None:
        earlier = self.pending.pop(target, None)
        if earlier is not None:  # the same file written twice: the last content wins
            _remove(earlier[0])
        self.pending[target] = (temporary, path)

    def discard(self) -> None:
        for temporary, _ in self.pending.values():
            _remove(temporary)
        self.pending.clear()

    def commit(self) -> None:
        """Rename every temporary into place; on a failure, undo the renames done and raise OutputError."""
        try:
            for _, path in self.pending.values():
                _replaceable(path)  # again: the targets may have changed during the work
        except OutputError:
            self.discard()
            raise
        done: list[tuple[Path, str | None]] = []
        failed = None
        for target, (temporary, path) in self.pending.items():
            backup = _backup(target)
            try:
                os.replace(temporary, target)
            except OSError as error:
                failed = OutputError(f"cannot write '{path}': {error.strerror or error}")
                if backup is not None:
                    _remove(backup)
                break
            done.append((target, backup))
        if failed is not None:
            for target, backup in reversed(done):
                if backup is None:
                    _remove(target)
                else:
                    os.replace(backup, target)
            self.discard()
            raise failed
        for _, backup in done:
            if backup is not None:
                _remove(backup)
        self.pending.clear()


_UNIT: contextvars.ContextVar[_Unit | None] = contextvars.ContextVar("torqueopt_output_unit", default=None)


@contextlib.contextmanager
def written_together() -> Iterator[None]:
    """Every :func:`atomic_write` inside the block lands at its end, all together, or none does.

    On an exception in the block, the temporary files are removed and the
    old files stay as they were; the exception goes on. A block inside
    another joins it: its files land with the outer block's.

    Raises:
        OutputError: a file cannot be renamed into place at the end (the
            files renamed before it are put back).
    """
    if _UNIT.get() is not None:
        yield
        return
    unit = _Unit()
    token = _UNIT.set(unit)
    try:
        yield
    except BaseException:
        unit.discard()
        raise
    finally:
        _UNIT.reset(token)
    unit.commit()


def _backup(target: Path) -> str | None:
    """A second name (a hard link) for the file at ``target``, to put it back; None when there is none to keep."""
    if not target.exists():
        return None
    for _ in range(10):
        name = str(target.with_name(f".{target.name}.{secrets.token_hex(4)}.old"))
        try:
            os.link(target, name)
            return name
        except FileExistsError:
            continue
        except OSError:
            return None  # a file system without hard links: no way back for this file
    return None


def _remove(name: str | os.PathLike) -> None:
    with contextlib.suppress(FileNotFoundError):
        os.unlink(name)


#: What a path holds, by its file type, for the messages of :func:`_replaceable`.
_KINDS = (
    (stat.S_ISDIR, "a folder; give a file name"),
    (stat.S_ISFIFO, "a FIFO (named pipe), not a regular file"),
    (stat.S_ISSOCK, "a socket, not a regular file"),
    (stat.S_ISCHR, "a character device, not a regular file"),
    (stat.S_ISBLK, "a block device, not a regular file"),
)


def _replaceable(path: Path) -> Path:
    """The file a write to ``path`` creates or replaces: ``path``, or the regular file a symbolic link points to.

    Raises:
        OutputError: ``path`` holds something that must not be replaced (see
            docs/files.md); the message says what it is.
    """
    try:
        status = os.lstat(path)
    except FileNotFoundError:
        return path
    except OSError as error:
        raise OutputError(f"cannot write '{path}': {error.strerror or error}") from None
    target = path
    if stat.S_ISLNK(status.st_mode):
        target = Path(os.path.realpath(path))
        try:
            status = os.stat(path)
        except FileNotFoundError:
            raise OutputError(
                f"cannot write '{path}': it is a symbolic link to '{target}', which does not exist"
            ) from None
        except OSError as error:
            raise OutputError(
                f"cannot write '{path}': it is a symbolic link that cannot be followed ({error.strerror})"
            ) from None
    for test, kind in _KINDS:
        if test(status.st_mode):
            link = f" (through the symbolic link to '{target}')" if target != path else ""
            raise OutputError(f"cannot write '{path}'{link}: it is {kind}")
    if status.st_nlink > 1:
        raise OutputError(
            f"cannot write '{path}': it has {status.st_nlink} hard links, and replacing it would split them; "
            "write to a new name or remove the other links"
        )
    if not status.st_mode & 0o222 or not os.access(target, os.W_OK):
        raise OutputError(f"cannot write '{path}': it is read-only; make it writable or write to a new name")
    return target


def atomic_write(path: Path, write) -> None:
    """Call ``write(binary_handle)`` on a temporary file beside ``path``, then rename it into place.

    What is already at ``path`` is treated as docs/files.md says: a
    symbolic link is written through to its target, a replaced file keeps
    its mode, and special, hard-linked and read-only files are refused.
    Inside :func:`written_together`, the rename waits for the end of the block.

    Raises:
        OutputError: the file cannot be created or written (no such folder,
            no permission, disk full, not a regular file); no partial file is
            left behind.
    """
    path = writable_path(path)
    target = _replaceable(path)  # again, at the moment of writing
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        # Not a with-block: the file must outlive the handle, to be renamed into place or removed below.
        handle = tempfile.NamedTemporaryFile(dir=target.parent, prefix=f".{target.name}.", suffix=".part", delete=False)  # noqa: SIM115
    except OSError as error:
        raise OutputError(f"cannot write '{path}': {error.strerror or error}") from None
    try:
        with handle:
            write(handle)
        try:
            existing = os.stat(target)
        except FileNotFoundError:
            existing = None
        if existing is None:
            # NamedTemporaryFile makes the file private (0600); give it the
            # permissions an ordinary new file would get under the user's umask.
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(handle.name, 0o666 & ~umask)
        else:
            # A replaced file keeps its mode, and its owner when we may set it (root).
            os.chmod(handle.name, stat.S_IMODE(existing.st_mode))
            if os.geteuid() == 0:
                os.chown(handle.name, existing.st_uid, existing.st_gid)
        unit = _UNIT.get()
        if unit is not None:
            unit.add(handle.name, target, path)
            return
        os.replace(handle.name, target)
    except OSError as error:
        os.unlink(handle.name)
        raise OutputError(f"cannot write '{path}': {error.strerror or error}") from None
    except BaseException:
        os.unlink(handle.name)
        raise


def _kind(path: Path) -> str:
    """What ``path`` is, in words (a regular file, a FIFO, a socket, a device), for messages."""
    mode = path.lstat().st_mode
    for test, words in _KINDS[1:]:
        if test(mode):
            return words.split(" (")[0].split(",")[0]
    return "a file"


def resumable_folder(out: Path, config_name: str, config: dict, what: str) -> bool:
    """True when ``out`` holds the work ``config`` describes (resume), False when it is new or empty.

    ``what`` names the work in the messages ("atlas", "tune"). Writes nothing.

    Raises:
        InvalidInput: ``out`` holds such work with other settings (naming the settings that
            differ), its configuration cannot be read, or ``out`` is not empty and holds no
            ``config_name``: never adopt a folder that is not ours.
    """
    article = "an" if what[:1] in "aeiou" else "a"
    path = out / config_name
    if path.is_file():
        try:
            existing = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            raise InvalidInput(f"'{path}' is not {article} {what}'s configuration; choose another --out") from None
        if existing != json.loads(json.dumps(config)):
            changed = sorted(key for key in set(existing) | set(config) if existing.get(key) != config.get(key))
            raise InvalidInput(
                f"'{out}' holds {article} {what} with other settings ({', '.join(changed)} differ); give another "
                f"--out to start a new {what}, or the same settings to resume it"
            )
        return True
    if out.is_dir() and any(out.iterdir()):
        raise InvalidInput(
            f"'{out}' is not empty and holds no {what} (no {config_name}), so it is not this {what}'s folder: give "
            f"an empty or new folder, or this {what}'s folder to resume it"
        )
    return False


def json_text(value) -> str:
    """``value`` as the text of an indented JSON file (:func:`json_value` first: no NaN, no numpy types)."""
    return json.dumps(json_value(value), indent=2, allow_nan=False)


def json_value(value):
    """``value`` as a JSON file holds it, through dicts, lists and tuples: numpy arrays and scalars as Python
    lists and numbers, and every NaN or infinite float as None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {key: json_value(item) for key, item in value.items()}
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [json_value(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
