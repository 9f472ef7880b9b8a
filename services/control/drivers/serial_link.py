"""A serial port that reconnects by itself: the transport of the servo board drivers.

``--port`` is opened with pyserial's ``serial_for_url`` on pyserial-asyncio, so a device path
(``/dev/ttyACM0``), ``socket://host:port`` (ser2net, a board on the network) and
``rfc2217://host:port`` all work. Device paths are locked (``flock``), so a second facesynth
process on the same board gets a clear error instead of interleaved frames.

The driver gives the link a *handshake* (run after every open: identify the board, send it
its configuration and the current pose) and a sink for the bytes that arrive. When the port
disappears (unplugged, TCP link down) or the driver declares the device dead (:meth:`lost`),
the link closes it and tries again with exponential backoff; the handshake runs again on each
reconnect. While disconnected, writes are dropped and counted, never raised: the control
service keeps running.
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import logging
import os
import re
import urllib.parse
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

import serial

from facesynth.services.control.drivers.base import (
    DeviceUnavailable,
    DriverConfigError,
    DriverError,
)
from facesynth.services.control.drivers.serial_transport import PolledTransport, Transport

#: Help of every board driver's ``port`` field.
PORT_HELP = "serial port: a device path, socket://HOST:PORT or rfc2217://HOST:PORT"
#: Errors after which the link tries again (anything else is a bug and is raised).
TRANSIENT = (OSError, serial.SerialException, TimeoutError, DriverError)


class Backoff:
    """Delays between reconnection attempts: ``first``, doubling, at most ``cap`` seconds."""

    def __init__(self, first: float = 0.1, cap: float = 2.0) -> None:
        if not 0 < first <= cap:
            raise ValueError("need 0 < first <= cap")
        self.first = first
        self.cap = cap
        self._next = first

    def next(self) -> float:
        """The delay before the next attempt (each call doubles the following one)."""
        delay = self._next
        self._next = min(self.cap, self._next * 2)
        return delay

    def reset(self) -> None:
        """Back to the first delay (after a successful connection)."""
        self._next = self.first


@dataclass
class LinkState:
    """What the link has been through, for status lines and stats."""

    port: str
    connected: bool = False
    connects: int = 0
    losses: int = 0
    failed_attempts: int = 0
    last_error: str = ""
    bytes_out: int = 0
    bytes_in: int = 0
    writes_dropped: int = 0

    def describe(self) -> str:
        """One line: connected, or why not and how often it has tried."""
        if self.connected:
            lost = f", reconnected {self.connects - 1}x" if self.connects > 1 else ""
            return f"connected to {self.port}{lost}"
        tries = f"{self.failed_attempts} attempts" if self.failed_attempts else "connecting"
        why = f"; last: {self.last_error}" if self.last_error else ""
        return f"disconnected from {self.port} ({tries}{why}), {self.writes_dropped} writes dropped"


Handshake = Callable[["SerialLink"], Awaitable[None]]


class SerialLink:
    """One serial device, reopened whenever it goes away.

    ``handshake(link)`` runs after each open, before :attr:`connected` turns true; it may
    :meth:`write` and should raise ``TimeoutError``/:class:`DriverError` if the device does
    not answer (the link then tries again) or :class:`DriverConfigError` if it never can work.
    ``on_bytes`` receives every byte read, in order.
    """

    def __init__(
        self,
        port: str,
        baud: int,
        *,
        handshake: Handshake,
        on_bytes: Callable[[bytes], None],
        log: logging.Logger,
        backoff: Backoff | None = None,
    ) -> None:
        check_port(port)
        self.port = port
        self.baud = baud
        self.state = LinkState(port)
        self._handshake = handshake
        self._on_bytes = on_bytes
        self._log = log
        self._backoff = backoff or Backoff()
        self._transport: Transport | None = None
        self._gone = asyncio.Event()
        self._gone_reason = ""
        self._closed = asyncio.Event()
        self._supervisor: asyncio.Task[None] | None = None
        self._reported = ""

    @property
    def retrying(self) -> bool:
        """Whether the link reconnects by itself (opened with ``retry``)."""
        return self._supervisor is not None

    @property
    def connected(self) -> bool:
        """True once the handshake has succeeded, until the device goes away."""
        return self.state.connected

    async def open(self, *, retry: bool) -> None:
        """Connect now. With ``retry``, a device that cannot be opened is waited for in the
        background; without, :class:`DeviceUnavailable` is raised. A
        :class:`DriverConfigError` from the handshake is always raised."""
        try:
            await self._connect()
        except DriverConfigError:
            raise
        except TRANSIENT as exc:
            if not retry:
                raise DeviceUnavailable(f"{self.port}: {_reason(exc)}") from None
            self._failed(exc, first=True)
        if retry:
            self._supervisor = asyncio.create_task(self._supervise(), name=f"link {self.port}")

    def write(self, data: bytes) -> bool:
        """Queue ``data`` as one write; False (and counted) when the port is not open."""
        transport = self._transport
        if transport is None or transport.is_closing():
            self.state.writes_dropped += 1
            return False
        transport.write(data)
        self.state.bytes_out += len(data)
        return True

    def lost(self, reason: str) -> None:
        """The driver's verdict: the device stopped answering; reopen it."""
        if self._transport is not None and not self._gone.is_set():
            self._gone_reason = reason
            self._gone.set()

    async def close(self) -> None:
        """Write out what is queued, close the port and stop reconnecting."""
        if self._supervisor is not None:
            self._supervisor.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._supervisor
            self._supervisor = None
        await self._drop_transport(flush=True)

    # -- internals ---------------------------------------------------------------------------

    async def _connect(self) -> None:
        instance = await asyncio.to_thread(_open_serial, self.port, self.baud)
        loop = asyncio.get_running_loop()
        self._gone.clear()
        self._closed.clear()
        protocol = _Protocol(self)
        transport_type = Transport if _has_fileno(instance) else PolledTransport
        self._transport = transport_type(loop, protocol, instance)
        await asyncio.sleep(0)  # let connection_made and the reader start
        try:
            await self._handshake(self)
            if self._gone.is_set():
                raise DriverError(self._gone_reason or "the port closed during the handshake")
        except BaseException:
            await self._drop_transport(flush=False)
            raise
        self.state.connected = True
        self.state.connects += 1
        self.state.failed_attempts = 0
        self.state.last_error = ""
        self._reported = ""
        self._backoff.reset()

    async def _supervise(self) -> None:
        while True:
            if self.state.connected:
                await self._gone.wait()
                self.state.connected = False
                self.state.losses += 1
                self.state.last_error = self._gone_reason
                self._log.warning(
                    "%s: device lost (%s); reconnecting, commands are dropped meanwhile",
                    self.port,
                    self._gone_reason,
                )
                await self._drop_transport(flush=False)
            await asyncio.sleep(self._backoff.next())
            try:
                await self._connect()
            except DriverConfigError as exc:
                self._failed(exc, level=logging.ERROR)
            except TRANSIENT as exc:
                self._failed(exc)
            else:
                self._log.info("%s: connected (%s)", self.port, self.state.describe())

    def _failed(self, exc: BaseException, *, first: bool = False, level: int = 0) -> None:
        self.state.failed_attempts += 1
        self.state.last_error = _reason(exc)
        message = self.state.last_error
        if message != self._reported or self.state.failed_attempts % 100 == 0:
            self._reported = message
            self._log.log(
                level or logging.WARNING,
                "%s: %s; %s",
                self.port,
                message,
                f"waiting for it (retrying every <= {self._backoff.cap:.0f} s)"
                if first
                else f"attempt {self.state.failed_attempts}, still retrying",
            )

    async def _drop_transport(self, *, flush: bool) -> None:
        transport, self._transport = self._transport, None
        if transport is None:
            return
        self.state.connected = False
        if flush and not transport.is_closing():
            transport.close()  # writes out what is queued, then connection_lost
            try:
                await asyncio.wait_for(self._closed.wait(), 1.0)
                return
            except TimeoutError:
                pass
        if not self._closed.is_set():
            transport.abort()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._closed.wait(), 1.0)

    def _received(self, data: bytes) -> None:
        self.state.bytes_in += len(data)
        self._on_bytes(data)

    def _connection_lost(self, exc: Exception | None) -> None:
        self._closed.set()
        if not self._gone.is_set():
            self._gone_reason = _reason(exc) if exc is not None else "the port closed"
            self._gone.set()


def check_port(port: str) -> None:
    """:class:`DriverConfigError` for a port that can never work (empty, a malformed URL)."""
    if not port:
        raise DriverConfigError("the port is empty")
    if "://" not in port:
        return
    url = urllib.parse.urlsplit(port)
    if url.scheme not in ("socket", "rfc2217"):
        raise DriverConfigError(
            f"{port}: unknown URL scheme {url.scheme!r} (use a device path, socket://HOST:PORT "
            "or rfc2217://HOST:PORT)"
        )
    try:
        number = url.port
    except ValueError:
        number = None
    if not url.hostname or number is None:
        raise DriverConfigError(f"{port}: expected {url.scheme}://HOST:PORT")


def _open_serial(port: str, baud: int) -> serial.SerialBase:
    """The pyserial port for a path or URL (device paths locked against a second opener)."""
    kwargs: dict[str, Any] = {"baudrate": baud}
    if "://" not in port:
        kwargs["exclusive"] = True
    try:
        return serial.serial_for_url(port, **kwargs)
    except ValueError as exc:  # a malformed URL or setting: never becomes usable
        raise DriverConfigError(f"{port}: {exc}") from None


def _has_fileno(instance: serial.SerialBase) -> bool:
    try:
        instance.fileno()
    except (AttributeError, io.UnsupportedOperation, OSError):
        return False
    return True


def _reason(exc: BaseException) -> str:
    errno = getattr(exc, "errno", None)
    if "exclusively lock" in str(exc):
        return "in use by another program (it holds the port's lock)"
    if isinstance(exc, serial.SerialException) and isinstance(errno, int) and errno > 0:
        return f"cannot open it: {os.strerror(errno)}"
    text = str(exc).strip() or type(exc).__name__
    text = re.sub(r"(?i)^could not open port \S+: ", "cannot open it: ", text)
    if isinstance(exc, TimeoutError) and not str(exc).strip():
        text = "no answer"
    return text.splitlines()[0]


class _Protocol(asyncio.Protocol):
    def __init__(self, link: SerialLink) -> None:
        self.link = link

    def data_received(self, data: bytes) -> None:
        self.link._received(data)

    def connection_lost(self, exc: Exception | None) -> None:
        self.link._connection_lost(exc)
