"""The ``facesynth`` command's entry point (console script and ``python -m facesynth``).

Ctrl-C at any moment ends the command quietly with exit status 130, also in its first half
second, while the command's modules are still being imported (OpenCV, Zenoh, the services),
before :func:`facesynth.app.cli.main` can catch it.
"""

from __future__ import annotations

from collections.abc import Sequence

#: Exit status after Ctrl-C (128 + SIGINT), as shells report it.
INTERRUPTED = 130


def main(argv: Sequence[str] | None = None) -> int:
    """Import and run the command; Ctrl-C anywhere in it is exit 130 without a traceback."""
    try:
        from facesynth.app.cli import main as command

        return command(argv)
    except KeyboardInterrupt:
        return INTERRUPTED
