"""pyserial-asyncio transports for the serial link (facesynth.services.control.drivers.serial_link).

:class:`Transport` is pyserial-asyncio's own, quiet about a port that vanishes (the link logs
that); :class:`PolledTransport` serves ports without a file descriptor (``rfc2217://``) by
polling, as pyserial-asyncio does on Windows.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

import serial
import serial_asyncio


class Transport(serial_asyncio.SerialTransport):
    """pyserial-asyncio's transport; a vanished port is the link's business, not an asyncio
    "Fatal error" with a traceback in the log."""

    def _fatal_error(self, exc: BaseException, message: str = "") -> None:
        self._abort(exc)

    def _call_connection_lost(self, exc: BaseException | None) -> None:
        with contextlib.suppress(OSError, serial.SerialException):  # a port already gone
            super()._call_connection_lost(exc)


class PolledTransport(Transport):
    """For ports without a file descriptor (``rfc2217://``): poll them, as pyserial-asyncio
    does on Windows, every 2 ms."""

    _POLL_S = 0.002

    def __init__(self, loop: asyncio.AbstractEventLoop, protocol: Any, serial_instance: Any):
        # SerialTransport.__init__ also sets write_timeout = 0, which rfc2217 ports refuse;
        # their writes go to a socket and do not block for long anyway.
        asyncio.Transport.__init__(self)
        self._loop = loop
        self._protocol = protocol
        self._serial = serial_instance
        self._closing = False
        self._protocol_paused = False
        self._max_read_size = 1024
        self._write_buffer: list[bytes] = []
        self._set_write_buffer_limits()
        self._has_reader: Any = False
        self._has_writer: Any = False
        self._poll_wait_time = self._POLL_S
        self._max_out_waiting = 1024
        self._serial.timeout = 0
        loop.call_soon(protocol.connection_made, self)
        loop.call_soon(self._ensure_reader)

    def _ensure_reader(self) -> None:
        if not self._has_reader and not self._closing:
            self._has_reader = self._loop.call_later(self._POLL_S, self._poll_read)

    def _poll_read(self) -> None:
        if self._has_reader and not self._closing:
            self._has_reader = self._loop.call_later(self._POLL_S, self._poll_read)
            try:
                if self._serial.in_waiting:
                    self._read_ready()
            except serial.SerialException as exc:
                self._fatal_error(exc)

    def _remove_reader(self) -> None:
        if self._has_reader:
            self._has_reader.cancel()
        self._has_reader = False

    def _ensure_writer(self) -> None:
        if not self._has_writer and not self._closing:
            self._has_writer = self._loop.call_soon(self._poll_write)

    def _poll_write(self) -> None:
        if self._has_writer and not self._closing:
            self._write_ready()  # removes the writer once everything is written
            if self._has_writer:
                self._has_writer = self._loop.call_later(self._POLL_S, self._poll_write)

    def _remove_writer(self) -> None:
        if self._has_writer:
            self._has_writer.cancel()
        self._has_writer = False
