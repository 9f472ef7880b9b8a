"""A serial cable on pseudo-terminals: a driver at one end, a device's pty at the other.

It relays bytes both ways, keeps what the host sent, can inject bytes towards the device (a
man in the middle for corrupted, cut-off and replayed frames), and can be pulled out and
plugged in again at the same path while the device keeps running: a USB cable pulled from a
board with its own power.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time
import tty
from pathlib import Path

from fake_devices.pty_device import PtyEnd


class Cable:
    """Relays between ``link`` (the driver's port) and the device pty at ``device``."""

    def __init__(self, device: Path, link: Path) -> None:
        self.device_fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self.device_fd)
        self.from_host = bytearray()
        self.lock = threading.Lock()
        self.end = PtyEnd(link, self._from_host)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._to_host, name="cable", daemon=True)
        self._thread.start()
        self.end.plug()

    @property
    def link(self) -> Path:
        return self.end.link

    def unplug(self) -> None:
        """Pull the cable: the driver's port vanishes; the device notices nothing."""
        self.end.unplug()

    def plug(self) -> None:
        """Plug it in again at the same path."""
        self.end.plug()

    def switch(self, device: Path) -> None:
        """Connect the cable to another device pty (a board that rebooted behind a USB
        adapter that stayed plugged in): the driver's port stays open."""
        fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(fd)
        with self.lock:
            old, self.device_fd = self.device_fd, fd
        with contextlib.suppress(OSError):
            os.close(old)

    def inject(self, data: bytes) -> None:
        """Bytes to the device as if the host had sent them."""
        with self.lock:
            view = memoryview(data)
            deadline = time.monotonic() + 2
            while view and time.monotonic() < deadline:
                try:
                    view = view[os.write(self.device_fd, view) :]
                except BlockingIOError:
                    time.sleep(0.001)

    def close(self) -> None:
        self.end.unplug()
        self._stop.set()
        self._thread.join(timeout=5)
        with contextlib.suppress(OSError):
            os.close(self.device_fd)

    def _from_host(self, data: bytes) -> bytes:
        with self.lock:
            self.from_host += data
        with contextlib.suppress(OSError):  # the board is off (rebooting): the bytes are lost
            self.inject(data)
        return b""

    def _to_host(self) -> None:
        while not self._stop.is_set():
            fd = self.device_fd
            try:
                ready, _, _ = select.select([fd], [], [], 0.02)
                if not ready:
                    continue
                data = os.read(fd, 4096)
            except OSError:
                time.sleep(0.01)
                continue
            if data and self.end.plugged:
                with contextlib.suppress(OSError):
                    self.end.write(data)
