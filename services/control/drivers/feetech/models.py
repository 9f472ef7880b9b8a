"""Feetech models and memory tables (STS and SCS series), and the decoding of read-backs.

Both series share the addresses (Feetech's memory tables for the STS3215 and the SCS0009):
Model Number 3 (2 bytes), ID 5, Torque Enable 40, Acceleration 41 (STS only, 100 steps/s²),
Goal Position 42 (2), Goal Speed 46 (2, steps/s), and the read-back block Present Position 56
to Present Temperature 63 (8 bytes: position 56, speed 58, load 60, voltage 62, temperature
63). STS servos store words low byte first, SCS servos high byte first; in both, bit 15 of a
position and bit 10 of a load are the sign. Status packets carry hardware errors as bits of
their error byte: 0 voltage, 1 angle sensor, 2 overheating, 3 overcurrent, 5 overload.
"""

from __future__ import annotations

import struct

from facesynth.services.control.drivers.bus_servo.bus import Status
from facesynth.services.control.drivers.bus_servo.native import Model

STS, SCS = 0, 1  # the SDK's protocol_end: byte order of the series

MODELS: dict[int, Model] = {
    m.number: m
    for m in (
        Model("STS3215", 777, 4096, 360.0, protocol=STS),
        Model("STS3250", 2825, 4096, 360.0, protocol=STS),
        Model("STS3095", 2569, 4096, 360.0, protocol=STS),
        Model("SCS0009", 1284, 1024, 300.0, protocol=SCS),
    )
}
#: Model names (lower case) -> model, for the profile's ``model``.
BY_NAME = {m.name.lower(): m for m in MODELS.values()}

MODEL_ADDR, TORQUE, ACCEL, GOAL, SPEED = 3, 40, 41, 42, 46
READ, READ_SIZE = 56, 8
SPEED_UNIT = 1.0  # position steps/s per Goal Speed unit
ACCEL_UNIT = 100.0  # steps/s² per Acceleration unit
SPEED_LIMIT, ACCEL_LIMIT = 32767, 254
HW_ERRORS = {
    0: "input voltage error",
    1: "angle sensor error",
    2: "overheating",
    3: "overcurrent",
    5: "overload",
}


def word(value: int, series: int) -> bytes:
    """A 2-byte value in the series' byte order (negative: bit 15 set, as the servos do)."""
    raw = (-value | 0x8000) if value < 0 else value
    return raw.to_bytes(2, "big" if series == SCS else "little")


def wire_word(value: int, series: int) -> int:
    """:func:`word` as the unsigned number whose low byte goes first on the wire."""
    raw = (-value | 0x8000) if value < 0 else value
    return ((raw & 0xFF) << 8 | raw >> 8) if series == SCS else raw


def model_from_bytes(data: bytes) -> int:
    """The model number of a Model Number read: the order that gives a known model (STS low
    byte first, SCS high byte first); little-endian when neither does."""
    little, big = int.from_bytes(data, "little"), int.from_bytes(data, "big")
    if little not in MODELS and big in MODELS and MODELS[big].protocol == SCS:
        return big
    return little


def hardware_errors(bits: int) -> str:
    """The status error bits named, joined ("" when none)."""
    if not bits:
        return ""
    return ", ".join(text for bit, text in sorted(HW_ERRORS.items()) if bits >> bit & 1)


def decode(data: bytes, error: int, series: int) -> Status:
    """The read-back block (Present Position 56 .. Present Temperature 63) of a servo of
    ``series`` and its status error byte. :class:`ValueError` unless it is :data:`READ_SIZE`
    bytes."""
    if len(data) != READ_SIZE:
        raise ValueError(f"a read-back of {len(data)} bytes (expected {READ_SIZE})")
    raw_position, _, raw_load = struct.unpack_from(">HHH" if series == SCS else "<HHH", data)
    position = -(raw_position & 0x7FFF) if raw_position & 0x8000 else raw_position
    magnitude = min(raw_load & 0x3FF, 1000) / 1000
    load = -magnitude if raw_load & 0x400 else magnitude
    return Status(position, load, float(data[7]), hardware_errors(error))
