"""The ``facesynth`` command's entry point (console script and ``python -m facesynth``).

Ctrl-C at any moment ends the command quietly with exit status 130, also in its first half
second, while the command's modules are still being imported (OpenCV, Zenoh, the services),
before :func:`facesynth.app.cli.main` can catch it. While they are imported, a first Ctrl-C is
held and answered once the imports are done (:func:`held_interrupts`): a ``KeyboardInterrupt``
raised inside an import can crash the process (msgspec building a decoder's type information,
measured: 6 segmentation faults in 300 interrupted starts under load) or be lost (raised in an
import lock's callback, where Python ignores it, and the command then ran to its end).

A process ends without Python's finalization (:func:`leave`). The command has closed what it
opened by then (buses, drivers, files, written atomically); what finalization would add is a
hazard: a thread still inside native code with a catch-all frame (Zenoh's Rust through pyo3, the
tracker's or OpenCV's C++) that returns while the interpreter is finalizing is ended by CPython
with ``pthread_exit``, and that forced unwind, caught by such a frame, aborts the whole process
with glibc's ``FATAL: exception not rethrown`` (exit 134) after a clean shutdown.
``tests/app/test_entry.py`` shows it with a thread waiting in a Zenoh subscriber.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from types import FrameType
from typing import NoReturn

#: Exit status after Ctrl-C (128 + SIGINT), as shells report it.
INTERRUPTED = 130
#: How long :func:`leave` waits, in all, for threads that are not daemons to end, as Python's
#: own exit would (a writer finishing its file); a thread still running after that is left.
THREADS_GRACE_S = 5.0


def main(argv: Sequence[str] | None = None) -> int:
    """Import and run the command; Ctrl-C anywhere in it is exit 130 without a traceback."""
    try:
        with held_interrupts() as held:
            from facesynth.app.cli import build_parser
            from facesynth.app.cli import main as command

            parser = build_parser()  # imports every command's module
        if held:
            return INTERRUPTED
        return command(argv, parser)
    except KeyboardInterrupt:
        return INTERRUPTED


@contextlib.contextmanager
def held_interrupts() -> Iterator[list[int]]:
    """Hold Ctrl-C while the block runs: the list yielded gets the signal if one came, and the
    caller answers it after the block. A second Ctrl-C raises ``KeyboardInterrupt`` at once (a
    hung import stays breakable). Off the main thread, where handlers cannot be set: nothing
    is held."""
    held: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield held
        return

    def hold(signum: int, frame: FrameType | None) -> None:
        held.append(signum)
        if len(held) > 1:
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, hold)
    try:
        yield held
    finally:
        signal.signal(signal.SIGINT, previous)


def run(command: Callable[[], object] = main) -> NoReturn:
    """The console script and ``python -m facesynth`` (``command``: the images' entry point
    passes its own): run the command, then :func:`leave` with its status."""
    try:
        code: object = command()
    except SystemExit as stop:  # argparse's errors and --help, sys.exit in a command
        code = stop.code
    leave(code)


def leave(code: object) -> NoReturn:
    """End the process with ``code`` (as ``SystemExit`` reads it) without finalization.

    Threading's exit hooks run and threads that are not daemons get :data:`THREADS_GRACE_S` to
    end, as at Python's own exit; logging and the standard streams are flushed; then
    ``os._exit``. Daemon threads, and threads still inside native code, end with the process
    instead of being unwound by a finalizing interpreter (see the module's docstring).
    """
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:
        print(code, file=sys.stderr)
        status = 1
    deadline = time.monotonic() + THREADS_GRACE_S
    try:
        # As Python's own exit does first: threading's exit hooks (an executor's idle workers,
        # which are not daemons, are told to end), then the wait for threads.
        for hook in reversed(getattr(threading, "_threading_atexits", [])):
            hook()
        for thread in threading.enumerate():
            if thread is not threading.current_thread() and not thread.daemon:
                thread.join(max(0.0, deadline - time.monotonic()))
    except KeyboardInterrupt:  # Ctrl-C while waiting: leave now
        status = status or INTERRUPTED
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # closed, or its reader went away
            stream.flush()
    os._exit(status & 0xFF)
