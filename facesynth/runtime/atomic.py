"""Atomic file writes: a reader sees the old file or the new one, never half of either.

The new contents go to a temporary file in the same folder, which is fsynced and renamed over
the target; the folder is then fsynced too (where the OS allows it) so that the rename survives
a power loss. On an error the target is left as it was and the temporary file is removed.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO


@contextlib.contextmanager
def open_atomic(path: str | os.PathLike[str], mode: int | None = None) -> Iterator[BinaryIO]:
    """A binary file that replaces ``path`` when the ``with`` block ends without an exception.

    For contents written piece by piece (a track file, frame after frame); an exception in the
    block leaves ``path`` untouched and no temporary file behind. The file is readable by its
    owner only (0600) unless ``mode`` says otherwise; the mode is set before the file takes its
    name, so it is never readable more widely (private keys stay 0600 throughout).
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    with contextlib.suppress(OSError):  # make the rename durable where the OS allows it
        folder = os.open(target.parent, os.O_RDONLY)
        try:
            os.fsync(folder)
        finally:
            os.close(folder)


def write_atomic(path: str | os.PathLike[str], data: bytes | str, mode: int | None = None) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` atomically, with file ``mode`` (default 0600);
    returns the path written."""
    raw = data.encode() if isinstance(data, str) else data
    with open_atomic(path, mode) as handle:
        handle.write(raw)
    return Path(path)
