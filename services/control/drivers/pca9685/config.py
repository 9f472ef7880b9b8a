"""The ``pca9685`` driver's options, and the seam its bus is opened through."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Protocol

import msgspec

from facesynth.services.control.drivers.base import DriverConfigError


class I2CBus(Protocol):
    """What the driver uses of ``smbus2.SMBus``."""

    def read_byte_data(self, i2c_addr: int, register: int) -> int: ...

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None: ...

    def i2c_rdwr(self, *i2c_msgs: Any) -> None: ...

    def close(self) -> None: ...


BusOpener = Callable[[str], I2CBus]


class PCA9685Config(
    msgspec.Struct, tag="pca9685", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """A PCA9685 16-channel PWM board (Adafruit Servo HAT/Bonnet) on the host's I2C bus."""

    bus: Annotated[
        str,
        msgspec.Meta(
            description="I2C bus: a device path (/dev/i2c-1, a Pi's pins 3 and 5) or its number",
            extra={"flag": "--i2c-bus"},
        ),
    ] = "/dev/i2c-1"
    address: Annotated[
        str | int,
        msgspec.Meta(
            description="the board's I2C address (0x40 unless its A0-A5 pads are bridged)",
            extra={"flag": "--i2c-address"},
        ),
    ] = "0x40"
    oscillator_hz: Annotated[
        float,
        msgspec.Meta(
            gt=0,
            description="the PCA9685's oscillator in Hz (25 MHz nominal; measure a board's "
            "pulses and set it for exact widths)",
            extra={"flag": "--pca9685-oscillator"},
        ),
    ] = 25_000_000.0
    frequency_hz: Annotated[
        float,
        msgspec.Meta(
            gt=0,
            description="servo frame rate in Hz (50: a 20 ms period)",
            extra={"flag": "--pca9685-frequency"},
        ),
    ] = 50.0
    exit_hold_s: Annotated[
        float,
        msgspec.Meta(
            ge=0,
            le=10,
            description="seconds of neutral pulses at close before the board sleeps",
            extra={"flag": "--pca9685-exit-hold"},
        ),
    ] = 0.5


def bus_path(bus: str) -> str:
    """``/dev/i2c-N`` for a bare number, else the path as given."""
    bus = bus.strip()
    if not bus:
        raise DriverConfigError("--i2c-bus: the bus is empty (e.g. /dev/i2c-1)")
    return f"/dev/i2c-{bus}" if bus.isdigit() else bus
