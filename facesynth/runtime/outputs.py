"""Output paths checked before anything starts: a service must not connect, wait for its router,
track a whole video or record a session, and only then find it cannot write its result.

:func:`check_output` proves the path can be written the way it will be: not a directory, under
folders that exist or can be made, and in a folder where a file can really be created (a probe
file is made and removed, so a read-only mount or a missing permission shows even to root).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


class OutputError(ValueError):
    """An output path that cannot be written; one line naming the path and the reason."""


def check_output(path: str | os.PathLike[str], what: str = "output") -> Path:
    """``path`` as a :class:`Path` if a file can be written there, else :class:`OutputError`.

    Folders that do not exist yet are fine when the nearest existing one is a writable folder
    (writers make the rest). An existing file is fine if it can be opened for writing.
    """
    target = Path(path)
    if not str(path):
        raise OutputError(f"{what}: no path given")
    if target.is_dir():
        raise OutputError(f"{what} {target} is a directory, not a file")
    folder = target.parent
    while not folder.exists():
        if folder.parent == folder:
            break
        folder = folder.parent
    if not folder.is_dir():
        raise OutputError(f"cannot write {what} {target}: {folder} is not a directory")
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise OutputError(
            f"cannot write {what} {target}: {folder} is not writable ({exc.strerror or exc})"
        ) from None
    if target.exists():
        try:
            with open(target, "ab"):
                pass
        except OSError as exc:
            raise OutputError(f"cannot write {what} {target}: {exc.strerror or exc}") from None
    return target
