"""Writing files: the one place every writer of torqueopt goes through.

:func:`writable_path` checks, before any work, that a file can be written
where the user asked; :func:`atomic_write` writes it to a temporary name
beside the target and renames it into place, so a file is never left
half-written.
"""

from __future__ import annotations

import os
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
    if not directory and path.is_dir():
        raise OutputError(f"cannot write '{path}': it is a folder; give a file name")
    folder = path if directory else path.parent
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise OutputError(f"cannot write to '{folder}': '{existing}' is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write to '{folder}': '{existing}' is not writable")
    return path


def atomic_write(path: Path, write) -> None:
    """Call ``write(binary_handle)`` on a temporary file beside ``path``, then rename it into place.

    Raises:
        OutputError: the file cannot be created or written (no such folder,
            no permission, disk full); no partial file is left behind.
    """
    path = writable_path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = tempfile.NamedTemporaryFile(dir=path.parent, prefix=f".{path.name}.", suffix=".part", delete=False)
    except OSError as error:
        raise OutputError(f"cannot write '{path}': {error.strerror or error}") from None
    try:
        with handle:
            write(handle)
        # NamedTemporaryFile makes the file private (0600); give it the
        # permissions an ordinary new file would get under the user's umask.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(handle.name, 0o666 & ~umask)
        os.replace(handle.name, path)
    except OSError as error:
        os.unlink(handle.name)
        raise OutputError(f"cannot write '{path}': {error.strerror or error}") from None
    except BaseException:
        os.unlink(handle.name)
        raise
