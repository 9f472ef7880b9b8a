"""Native libraries' chatter on file descriptor 2, kept out of the terminal.

Some C++ libraries write informational lines straight to fd 2, below Python's ``sys.stderr``
and its logging: LiteRT prints ``INFO: Created TensorFlow Lite XNNPACK delegate for CPU.`` when
an interpreter first allocates its tensors, and neither ``TF_CPP_MIN_LOG_LEVEL`` nor any other
setting of ``ai_edge_litert`` silences it (tried with ai-edge-litert 2.3.0). :func:`chatter_to_log`
redirects fd 2 around such a call only: the lines that are chatter go to a Python logger at DEBUG
(shown with ``--log-level DEBUG``), every other line (a real error or warning) is written back to
fd 2 as it was.
"""

from __future__ import annotations

import logging
import os
import re
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["LITERT_CHATTER", "chatter_to_log", "sort_lines"]

#: LiteRT/TFLite's informational lines (``tflite::logging_internal::MinimalLogger``, INFO).
LITERT_CHATTER = re.compile(r"^INFO: ")

_LOCK = threading.RLock()  # fd 2 is the process's: one redirection at a time


def sort_lines(text: str, chatter: re.Pattern[str]) -> tuple[list[str], list[str]]:
    """Split captured text into (chatter lines, other lines), each without its newline."""
    quiet: list[str] = []
    loud: list[str] = []
    for line in text.splitlines():
        if line.strip():
            (quiet if chatter.search(line) else loud).append(line)
    return quiet, loud


@contextmanager
def chatter_to_log(logger: logging.Logger, chatter: re.Pattern[str]) -> Iterator[None]:
    """Within the block, lines native code writes to fd 2 that match ``chatter`` are logged to
    ``logger`` at DEBUG; any other line is written back to fd 2 when the block ends."""
    with _LOCK, tempfile.TemporaryFile() as capture:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(capture.fileno(), 2)
        try:
            yield
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            capture.seek(0)
            text = capture.read().decode("utf-8", errors="replace")
            quiet, loud = sort_lines(text, chatter)
            for line in quiet:
                logger.debug("%s", line)
            if loud:
                os.write(2, ("\n".join(loud) + "\n").encode())
