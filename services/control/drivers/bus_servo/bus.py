"""What a bus driver asks of its vendor's SDK, on the bus thread: the :class:`ServoBus` seam.

Each vendor (``dynamixel``, ``feetech``) implements it with its own SDK (PortHandler,
PacketHandler, GroupSyncWrite). Every method blocks (pyserial) and runs on the driver's bus
thread, never on the event loop. A port that fails raises ``OSError``/``SerialException``
(the thread then reopens it); a servo that does not answer is a ``None``, not an exception.
"""

from __future__ import annotations

import abc
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from services.control.drivers.bus_servo.native import Model, NativeServo
from services.control.drivers.bus_servo.sdk_port import port_class


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
