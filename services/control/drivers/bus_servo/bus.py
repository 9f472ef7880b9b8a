"""What a bus driver asks of its vendor's SDK, on the bus thread: the :class:`ServoBus` seam.

Each vendor (``dynamixel``, ``feetech``) implements it with its own SDK (PortHandler,
PacketHandler) for the port, pings and settings, and with :mod:`.wire` for the packets of
every frame (:meth:`ServoBus.send`, :meth:`ServoBus.transact`). Every method blocks (pyserial)
and runs on the driver's bus thread, except :meth:`ServoBus.write_goals`, which the worker
also calls from the event loop while it holds the bus (a write into the port's buffer). A port
that fails raises ``OSError``/``SerialException`` (the thread then reopens it); a servo that
does not answer is a ``None``, not an exception.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from facesynth.services.control.drivers.bus_servo.native import Model, NativeServo
from facesynth.services.control.drivers.bus_servo.sdk_port import port_class
from facesynth.services.control.drivers.bus_servo.wire import Status as WireStatus

#: Default read-back rates (C's CPU per frame within the Maestro's, ``bench drivers --emulated``).
SYNC_READ_HZ, READ_EACH_HZ = 15.0, 5.0
#: A parser of status packets (:mod:`.wire`): complete packets from a buffer, and the damaged.
Take = Callable[[bytearray], tuple[list[WireStatus], int]]


@dataclass(frozen=True)
class Status:
    """One servo's answer to a read-back: native position, load (fraction of the maximum,
    signed), temperature in °C, and the hardware error it reports ("" when none)."""

    position: int
    load: float | None
    temperature_c: float | None
    fault: str = ""


@dataclass(frozen=True)
class Ping:
    """A servo's answer to a ping: its model number and the hardware error it reports."""

    model_number: int
    fault: str = ""


class ServoBus(abc.ABC):
    """One vendor's servos on one serial port, through the vendor's SDK."""

    #: Name of the bus in messages ("Dynamixel Protocol 2.0").
    name = "servo bus"

    def __init__(self, sdk: Any, port: str, baud: int, latency_ms: float) -> None:
        """The vendor SDK's port on ``port`` (``sdk``: the SDK's module, whose ``PortHandler``
        this project's :func:`port_class` adapts), opened at ``baud`` by :meth:`open`."""
        self.sdk = sdk
        self.baud = baud
        self.port = port_class(sdk.PortHandler)(port)
        self.port.latency_ms = latency_ms
        self.garbled = 0  # status packets dropped (checksum, length)

    def open(self) -> None:
        """Open the port at the bus's baud rate (raise ``OSError`` if it cannot be opened)."""
        self.port.setBaudRate(self.baud)

    def close(self) -> None:
        """Close the port (harmless when closed)."""
        if self.port.is_open:
            self.port.closePort()

    @abc.abstractmethod
    def model(self, number: int) -> Model | None:
        """The model with this model number (None: one the driver does not know)."""

    @abc.abstractmethod
    def ping(self, servo_id: int) -> Ping | None:
        """Ping one servo (None: no answer, or only garbled ones)."""

    @abc.abstractmethod
    def prepare(self, servo: NativeServo, speed: float, accel: float) -> None:
        """Set the servo's profile velocity/acceleration (µs/s, µs/s²; 0 = unlimited) and
        turn its torque on."""

    @abc.abstractmethod
    def write_goals(self, goals: Mapping[int, int]) -> int:
        """Every goal position (native units, by id) as one Sync Write; the bytes sent."""

    @abc.abstractmethod
    def read(self, ids: Sequence[int]) -> dict[int, Status | None]:
        """Present position, load and temperature of ``ids`` (one Sync Read where the protocol
        has it); None for a servo that did not answer or answered garbled."""

    @abc.abstractmethod
    def relax(self, ids: Sequence[int]) -> None:
        """Torque off (the face goes limp)."""

    def send(self, packet: bytes) -> None:
        """Write one packet built by :mod:`.wire` (``OSError`` if the port takes less)."""
        written = self.port.writePort(packet)
        if written != len(packet):
            raise OSError(f"a {len(packet)}-byte packet, {written} bytes written")

    def transact(
        self, request: bytes, answer_bytes: int, take: Take, ids: Sequence[int], size: int
    ) -> dict[int, tuple[int, bytes]]:
        """Send ``request`` and read the status packets of ``ids`` (``answer_bytes`` in all)
        until each has answered with ``size`` data bytes or the answer timeout passes:
        (error byte, data) by id. Damaged packets, other ids and other sizes are counted in
        :attr:`garbled` and skipped."""
        self.send(request)
        self.port.setPacketTimeout(answer_bytes)
        waiting = set(ids)
        got: dict[int, tuple[int, bytes]] = {}
        buffer = bytearray()
        while waiting:
            chunk = self.port.readPort(4096)
            if not chunk:
                if self.port.isPacketTimeout():
                    break
                continue
            buffer += chunk
            packets, damaged = take(buffer)
            self.garbled += damaged
            for servo_id, error, data in packets:
                if servo_id in waiting and len(data) == size:
                    waiting.discard(servo_id)
                    got[servo_id] = (error, data)
                else:
                    self.garbled += 1
        return got

    def read_hz(self, ids: Sequence[int]) -> float:
        """Read-backs a second unless the driver is told (``--bus-read-hz``): one Sync Read
        for all is cheap enough at :data:`SYNC_READ_HZ`; a bus that reads each servo on its
        own (a round trip each, parsed in Python) reads at :data:`READ_EACH_HZ`."""
        return SYNC_READ_HZ

    def scan(self) -> dict[int, int]:
        """Every servo on the bus, id -> model number, where the protocol can ask them all
        at once (Dynamixel 2.0's broadcast ping); empty otherwise (doctor then lists the
        profile's ids only)."""
        return {}

    @abc.abstractmethod
    def write_bytes(self, count: int) -> int:
        """Bytes on the wire of one Sync Write of ``count`` servos."""

    @abc.abstractmethod
    def read_bytes(self, count: int) -> int:
        """Bytes on the wire (both ways) of one read-back of ``count`` servos."""
