"""Writing files: the one place every writer of torqueopt goes through.

:func:`writable_path` checks, before any work, that a file can be written
where the user asked; :func:`atomic_write` writes it to a temporary name
beside the target and renames it into place, so a file is never left
half-written.

The rule for what is already at the path (as a careful Unix tool does it):

* nothing, or a regular file: written atomically; a file that is replaced
  keeps its permission bits (and, when run as root, its owner);
* a symbolic link: written through to the regular file it points to, which
  is replaced atomically as above, so the link stays a link; a link whose
  target does not exist (or a loop of links) is refused;
* a regular file with more than one hard link: refused, since an atomic
  rename would split the names (the others would keep the old content) and
  writing in place could leave every name half-written; write to a new
  name, or remove the other links first;
* a read-only file (no write bit, even for root): refused, since the user
  marked it as not to be changed;
* anything else (a folder, a FIFO, a socket, a device): refused, since
  renaming over it would replace what is not ours by a regular file.

Every refusal is an :class:`~torqueopt.errors.OutputError` (exit 2 from the
CLI) that names the path and what it is.
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from .errors import OutputError

__all__ = ["atomic_write", "writable_path"]


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
            the module docstring); the message says what it is.
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

    What is already at ``path`` is treated as the module docstring says: a
    symbolic link is written through to its target, a replaced file keeps
    its mode, and special, hard-linked and read-only files are refused.

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
