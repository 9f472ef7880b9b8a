"""A device on a pseudo-terminal at a fixed path, that can be unplugged and plugged in again."""

from __future__ import annotations

import asyncio
import contextlib
import os
import select
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path


def point_link(link: Path, target: str) -> None:
    """Make ``link`` a symlink to ``target``, atomically (a reader never sees it missing)."""
    tmp = link.with_name(link.name + ".new")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    tmp.symlink_to(target)
    os.replace(tmp, link)


class PtyEnd:
    """Our end of a pty whose other end a driver opens through ``link``.

    A reader thread hands every chunk the driver writes to ``on_bytes`` and writes back what
    it returns. :meth:`unplug` closes the pty (the driver sees its port vanish) and removes the
    link; :meth:`plug` makes a new pty at the same link.
    """

    def __init__(self, link: Path, on_bytes: Callable[[bytes], bytes]) -> None:
        self.link = link
        self.on_bytes = on_bytes
        self.plugged = False
        self.plugs = 0
        self._master = -1
        self._slave = -1
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.write_lock = threading.Lock()

    def plug(self) -> None:
        """A new pty behind ``link``."""
        assert not self.plugged
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no line editing: bytes pass as they are
        self._master, self._slave = master, slave
        point_link(self.link, os.ttyname(slave))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"pty {self.link}", daemon=True)
        self._thread.start()
        self.plugged = True
        self.plugs += 1

    def unplug(self) -> None:
        """Close the pty (the driver's reads and writes fail) and remove the link."""
        if not self.plugged:
            return
        self._stop.set()
        assert self._thread is not None
        self._thread.join(timeout=5)
        with contextlib.suppress(FileNotFoundError):
            self.link.unlink()
        os.close(self._master)
        os.close(self._slave)
        self.plugged = False

    def write(self, data: bytes) -> None:
        """Send bytes to the driver."""
        with self.write_lock:
            view = memoryview(data)
            deadline = time.monotonic() + 2
            while view and time.monotonic() < deadline:
                try:
                    written = os.write(self._master, view)
                except BlockingIOError:
                    time.sleep(0.001)
                    continue
                view = view[written:]

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.02)
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                time.sleep(0.01)  # no reader on the driver side right now
                continue
            if data:
                reply = self.on_bytes(data)
                if reply:
                    self.write(reply)


class FakeDevice:
    """A fake board behind a :class:`PtyEnd`; subclasses implement :meth:`handle`.

    Every byte received is kept in :attr:`received`; :meth:`handle` is called under a lock,
    so tests can read the device's state with :meth:`snapshot`-style methods safely.
    :attr:`bytes_in` and :attr:`bytes_out` count the bytes on the line in each direction
    (what the driver sent, what the device answered) since :meth:`count_bytes` last read them:
    the bus time a driver really used.
    """

    def __init__(self, link: Path) -> None:
        self.lock = threading.RLock()
        self.received = bytearray()
        self.bytes_in = 0
        self.bytes_out = 0
        self.end = PtyEnd(link, self._on_bytes)

    @property
    def link(self) -> Path:
        return self.end.link

    def plug(self, *, reset: bool = True) -> None:
        """Plug in (again); with ``reset`` the device forgets everything, as after power-up."""
        with self.lock:
            if reset:
                self.reset()
        self.end.plug()

    def unplug(self) -> None:
        self.end.unplug()

    def close(self) -> None:
        self.end.unplug()

    def reset(self) -> None:
        """Power-up state (subclasses extend it)."""
        self.received.clear()

    def count_bytes(self, *, restart: bool = False) -> tuple[int, int]:
        """Bytes (from the driver, to the driver) so far; ``restart`` zeroes the counts."""
        with self.lock:
            counts = self.bytes_in, self.bytes_out
            if restart:
                self.bytes_in = self.bytes_out = 0
            return counts

    def _on_bytes(self, data: bytes) -> bytes:
        with self.lock:
            self.received += data
            self.bytes_in += len(data)
            reply = self.handle(data)
            self.bytes_out += len(reply) if reply else 0
            return reply

    def handle(self, data: bytes) -> bytes:
        """Bytes from the driver in, the device's answer out."""
        raise NotImplementedError

    def wait_for(self, what: Callable[[], bool], timeout: float = 5.0) -> None:
        """Poll until ``what()`` holds (under the device's lock)."""
        deadline = time.monotonic() + timeout
        while True:
            with self.lock:
                if what():
                    return
            if time.monotonic() > deadline:
                raise TimeoutError(f"{type(self).__name__}: condition not met in {timeout} s")
            time.sleep(0.01)

    async def until(self, what: Callable[[], bool], timeout: float = 5.0) -> None:
        """Wait, letting the event loop run, until ``what()`` holds (under the device's lock)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            with self.lock:
                if what():
                    return
            if loop.time() > deadline:
                raise TimeoutError(f"{type(self).__name__}: condition not met in {timeout} s")
            await asyncio.sleep(0.01)
