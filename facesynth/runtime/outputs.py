"""Output paths checked before anything starts: a service must not connect, wait for its router,
track a whole video or record a session, and only then find it cannot write its result.

:func:`check_output` proves the path can be written the way it will be: not a directory, under
folders that exist or can be made, and in a folder where a file can really be created (a probe
file is made and removed, so a read-only mount or a missing permission shows even to root).

A path given by the user may name one folder that does not exist yet (the file's own, made by
the writer and said in one log line); a deeper missing tree is refused, since a typo in a
folder name would otherwise silently grow a new tree. facesynth's own default places
(``make_parents=True``) are made whole.
"""

from __future__ import annotations

import logging
import os
import tempfile
from pathlib import Path

log = logging.getLogger("facesynth.outputs")


class OutputError(ValueError):
    """An output path that cannot be written; one line naming the path and the reason."""


def check_output(
    path: str | os.PathLike[str], what: str = "output", *, make_parents: bool = False
) -> Path:
    """``path`` as a :class:`Path` if a file can be written there, else :class:`OutputError`.

    The file's own folder may be missing when its parent is a writable folder (the writer makes
    it; logged); with ``make_parents`` any missing folders are fine (a default place of
    facesynth's own). An existing file is fine if it can be opened for writing.
    """
    target = Path(path)
    if not str(path):
        raise OutputError(f"{what}: no path given")
    if target.is_dir():
        raise OutputError(f"{what} {target} is a directory, not a file")
    folder = target.parent
    missing: list[Path] = []
    while not folder.exists():
        missing.append(folder)
        if folder.parent == folder:
            break
        folder = folder.parent
    if len(missing) > 1 and not make_parents:
        raise OutputError(
            f"cannot write {what} {target}: folder {missing[-1]} does not exist (only the "
            f"file's own folder is made; make {missing[-1]} first if the path is right)"
        )
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
    if missing and not make_parents:
        log.info("%s %s: making its folder %s", what, target, missing[0])
    return target
