"""A fake board served over TCP, as ser2net or an RFC 2217 server would serve a real one.

``socket://`` gets the raw bytes; ``rfc2217://`` gets a Telnet/RFC 2217 session handled by
pyserial's own server side (``serial.rfc2217.PortManager``), whose port settings go to a
``loop://`` stand-in while the data goes to the fake board.
"""

from __future__ import annotations

import contextlib
import socket
import threading

import serial
import serial.rfc2217

from fake_devices.pty_device import FakeDevice


class NetworkPort:
    """``device`` on 127.0.0.1; :meth:`unplug` drops the connection and stops listening."""

    def __init__(self, device: FakeDevice, *, rfc2217: bool) -> None:
        self.device = device
        self.rfc2217 = rfc2217
        self.port = 0
        self.connections = 0
        self._listener: socket.socket | None = None
        self._conn: socket.socket | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.plug()

    @property
    def url(self) -> str:
        return f"{'rfc2217' if self.rfc2217 else 'socket'}://127.0.0.1:{self.port}"

    def plug(self) -> None:
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(("127.0.0.1", self.port))
        listener.listen(1)
        listener.settimeout(0.05)
        self.port = listener.getsockname()[1]
        self._listener = listener
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="network port", daemon=True)
        self._thread.start()

    def unplug(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        for sock in (self._conn, self._listener):
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.close()
        self._conn = self._listener = None

    close = unplug

    def _serve(self) -> None:
        assert self._listener is not None
        while not self._stop.is_set():
            try:
                conn, _ = self._listener.accept()
            except (TimeoutError, OSError):
                continue
            self.connections += 1
            self._conn = conn
            with contextlib.suppress(OSError):
                self._session(conn)
            with contextlib.suppress(OSError):
                conn.close()

    def _session(self, conn: socket.socket) -> None:
        conn.settimeout(0.05)
        lock = threading.Lock()

        class Connection:
            def write(self, data: bytes) -> None:
                with lock:
                    conn.sendall(data)

        manager = None
        if self.rfc2217:
            stand_in = serial.serial_for_url("loop://", do_not_open=False)
            manager = serial.rfc2217.PortManager(stand_in, Connection())
        while not self._stop.is_set():
            try:
                data = conn.recv(4096)
            except TimeoutError:
                continue
            if not data:
                return
            chunks = list(manager.filter(data)) if manager else [data]
            for chunk in chunks:
                reply = self.device._on_bytes(bytes(chunk))
                if reply:
                    out = b"".join(manager.escape(reply)) if manager else reply
                    Connection().write(out)
