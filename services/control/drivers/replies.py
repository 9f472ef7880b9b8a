"""Answers of a board that replies in order without framing (Pololu Maestro, SSC-32).

Each request says how its answer ends: after a number of bytes, or at a terminator. Answers
are matched to requests in order; bytes that arrive with no request waiting are counted and
dropped.
"""

from __future__ import annotations

import asyncio
import collections
from dataclasses import dataclass


@dataclass
class _Expected:
    future: asyncio.Future[bytes]
    size: int | None
    until: bytes | None


class ReplyQueue:
    """Requests waiting for their answers, in the order they were sent."""

    def __init__(self, limit: int = 256) -> None:
        self.limit = limit
        self.stray = 0
        self._waiting: collections.deque[_Expected] = collections.deque()
        self._buffer = bytearray()

    @property
    def pending(self) -> int:
        """Requests still waiting."""
        return len(self._waiting)

    def expect(
        self, *, size: int | None = None, until: bytes | None = None
    ) -> asyncio.Future[bytes]:
        """A future for the next answer: ``size`` bytes, or everything up to ``until``
        (included, at most ``limit`` bytes)."""
        if (size is None) == (until is None):
            raise ValueError("give exactly one of size and until")
        future: asyncio.Future[bytes] = asyncio.get_running_loop().create_future()
        self._waiting.append(_Expected(future, size, until))
        return future

    def feed(self, data: bytes) -> None:
        """Bytes from the board: complete the waiting requests they answer."""
        self._buffer += data
        while self._buffer:
            while self._waiting and self._waiting[0].future.done():  # timed out: forget it
                self._waiting.popleft()
            if not self._waiting:
                self.stray += len(self._buffer)
                self._buffer.clear()
                return
            head = self._waiting[0]
            if head.size is not None:
                if len(self._buffer) < head.size:
                    return
                end = head.size
            else:
                assert head.until is not None
                index = self._buffer.find(head.until)
                if index < 0:
                    if len(self._buffer) > self.limit:
                        self._waiting.popleft()
                        head.future.set_exception(ValueError("answer too long"))
                        self.stray += len(self._buffer)
                        self._buffer.clear()
                    return
                end = index + len(head.until)
                if end > self.limit:  # it came in pieces each short of the limit
                    self._waiting.popleft()
                    head.future.set_exception(ValueError("answer too long"))
                    self.stray += end
                    del self._buffer[:end]
                    continue
            self._waiting.popleft()
            head.future.set_result(bytes(self._buffer[:end]))
            del self._buffer[:end]

    def reset(self) -> None:
        """Forget every request and byte (the port was reopened)."""
        for expected in self._waiting:
            if not expected.future.done():
                expected.future.cancel()
        self._waiting.clear()
        self._buffer.clear()
