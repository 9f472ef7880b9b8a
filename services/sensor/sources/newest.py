"""A live stream's newest frame only: read in a thread, each frame stamped when it arrived.

A reader that takes frames more slowly than a camera sends them (a loaded machine, a slow
tracker sharing the sensor's event loop) leaves the stream's frames queued in the socket's
buffers. Taken in order, each is then seconds older than the moment it is taken, and a stamp
given on taking it says it is new. :class:`NewestFrame` reads the stream in a thread of its
own, as fast as it comes, stamps each frame with the wall and monotonic clocks when it
arrives, and keeps only the newest: :meth:`NewestFrame.take` gives it (waiting for one newer
than the last taken); a frame nobody took before the next one arrived is dropped and counted
in :attr:`NewestFrame.dropped`. The stream's error (the camera stopped) is raised by the
:meth:`~NewestFrame.take` after its last frame.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Generic, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class Arrived(Generic[T]):
    """A frame and when it arrived: wall clock (``time_ns``) and monotonic clock, in ns."""

    frame: T
    wall_ns: int
    monotonic_ns: int


class NewestFrame(Generic[T]):
    """The newest frame of ``frames``, read in a daemon thread (see the module docstring).

    ``wall`` and ``monotonic`` are the clocks the arrivals are stamped with.
    """

    def __init__(
        self,
        frames: Iterator[T],
        *,
        name: str = "camera",
        wall: Callable[[], int] = time.time_ns,
        monotonic: Callable[[], int] = time.monotonic_ns,
    ) -> None:
        self.dropped = 0
        self._wall = wall
        self._monotonic = monotonic
        self._ready = threading.Condition()
        self._slot: Arrived[T] | None = None
        self._error: BaseException | None = None
        self._ended = False
        self._thread = threading.Thread(
            target=self._read, args=(frames,), name=f"{name}-newest", daemon=True
        )
        self._thread.start()

    def _read(self, frames: Iterator[T]) -> None:
        try:
            for frame in frames:
                arrived = Arrived(frame, self._wall(), self._monotonic())
                with self._ready:
                    if self._slot is not None:
                        self.dropped += 1
                    self._slot = arrived
                    self._ready.notify_all()
        except BaseException as exc:  # handed to the taker, raised there
            with self._ready:
                self._error = exc
                self._ready.notify_all()
        else:
            with self._ready:
                self._ended = True
                self._ready.notify_all()

    def take(self) -> Arrived[T] | None:
        """The newest frame not taken yet, waiting for one; ``None`` once the stream ended
        (its error, if it ended with one, raised instead)."""
        with self._ready:
            self._ready.wait_for(
                lambda: self._slot is not None or self._error is not None or self._ended
            )
            if self._slot is not None:
                arrived, self._slot = self._slot, None
                return arrived
            if self._error is not None:
                raise self._error
            return None

    def __iter__(self) -> Iterator[Arrived[T]]:
        while (arrived := self.take()) is not None:
            yield arrived

    def join(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for the reading thread to end; whether it did."""
        self._thread.join(timeout)
        return not self._thread.is_alive()
