"""The vendor SDKs' PortHandler, made to behave on any serial port facesynth opens.

Both SDKs (ROBOTIS ``dynamixel_sdk``, Feetech ``scservo_sdk``) share one PortHandler shape:
``serial.Serial(port, timeout=0)`` and a receive loop that polls ``read`` until a packet
timeout. :func:`port_class` derives from the SDK's own class and changes three things:

- the port is opened with ``serial_for_url`` (device paths, ``socket://``, ``rfc2217://``)
  and device paths are locked, as the other board drivers do;
- ``readPort`` waits (``select``, at most 1 ms) for bytes instead of spinning on an empty
  port, so a read-back costs the control process no CPU while the servos answer;
- on a local serial port (a device path), ``readPort`` and ``writePort`` call ``os.read`` and
  ``os.write`` on its descriptor (pyserial's own loop costs more than the packet a frame);
- the packet timeout's latency allowance is the driver's (``--bus-latency-ms``; the SDKs
  assume a 16 ms FTDI latency timer; 0 on a pty or an adapter set to 1 ms).

Any baud rate the port accepts is allowed (the SDKs list a fixed set).
"""

from __future__ import annotations

import os
import select
from typing import Any

import serial
import serial.serialposix

from facesynth.services.control.drivers.base import DriverConfigError


def port_class(base: type[Any]) -> type[Any]:
    """A subclass of the SDK's ``PortHandler`` ``base`` with the changes above."""

    class BusPort(base):
        latency_ms = 16.0
        is_open: bool
        fd: int | None = None  # a local serial port's descriptor, while open

        def setupPort(self, cflag_baud: int) -> bool:
            if self.is_open:
                self.closePort()
            kwargs: dict[str, Any] = {"baudrate": self.baudrate, "timeout": 0}
            if "://" not in self.port_name:
                kwargs["exclusive"] = True
            try:
                self.ser = serial.serial_for_url(self.port_name, **kwargs)
            except ValueError as exc:
                raise DriverConfigError(f"{self.port_name}: {exc}") from None
            self.is_open = True
            self.is_using = False  # an SDK call cut short by a vanished port left it set
            self.ser.reset_input_buffer()
            local = isinstance(self.ser, serial.serialposix.Serial)
            self.fd = self.ser.fileno() if local else None
            self.tx_time_per_byte = (1000.0 / self.baudrate) * 10.0
            return True

        def getCFlagBaud(self, baudrate: int) -> int:
            return baudrate

        def closePort(self) -> None:
            self.fd = None  # (a closed descriptor's number may soon be another file's)
            if self.ser is not None:
                self.ser.close()
            self.is_open = False

        def readPort(self, length: int) -> bytes:
            fd = self.fd
            if fd is not None and length > 0:
                return _read_fd(fd, length)
            data = self.ser.read(length)
            if data or length <= 0:
                return bytes(data)
            try:
                fileno = self.ser.fileno()
            except Exception:  # ports without a descriptor (rfc2217)
                return bytes(data)
            select.select([fileno], [], [], 0.001)
            return bytes(self.ser.read(length))

        def writePort(self, packet: Any) -> int:
            fd = self.fd
            if fd is not None:
                data = bytes(packet)
                try:
                    written = os.write(fd, data)
                except BlockingIOError:
                    written = 0
                if written == len(data):
                    return written
                return written + int(self.ser.write(data[written:]) or 0)
            return int(self.ser.write(packet) or 0)

        def setPacketTimeout(self, packet_length: int) -> None:
            self.packet_start_time = self.getCurrentTime()
            self.packet_timeout = (
                self.tx_time_per_byte * packet_length + self.latency_ms * 2.0 + 2.0
            )

    return BusPort


def _read_fd(fd: int, length: int) -> bytes:
    """Up to ``length`` bytes from a serial port's descriptor (VMIN = VTIME = 0: a read
    returns what is there), waiting at most 1 ms for them."""
    data = _try_read(fd, length)
    if data:
        return data
    ready, _, _ = select.select([fd], [], [], 0.001)
    if not ready:
        return b""
    data = _try_read(fd, length)
    if not data:  # readable, nothing there: the device went away (as pyserial says)
        raise serial.SerialException("device reports readiness to read but returned no data")
    return data


def _try_read(fd: int, length: int) -> bytes:
    try:
        return os.read(fd, length)
    except BlockingIOError:
        return b""
