"""Dynamixel models and control tables (ROBOTIS e-manual), and the decoding of read-backs.

Protocol 2.0, X series (XL430/XM430/XH430/XL330/XM540, MX 2.0): 4096 positions per turn;
Profile Acceleration 108 (4 bytes, 214.577 rev/min²), Profile Velocity 112 (4, 0.229 rev/min),
Goal Position 116 (4); the read-back is one block from Present Load 126 to Present
Temperature 146 (21 bytes: load 126, velocity 128, position 132, input voltage 144,
temperature 146); Hardware Error Status 70 (bit 0 input voltage, 2 overheating, 3 motor
encoder, 4 electrical shock, 5 overload).

Protocol 1.0, AX and MX (1.0 firmware): Torque Enable 24, Goal Position 30 (2), Moving Speed
32 (2; AX 0.111 rev/min, MX 0.114), Goal Acceleration 73 (MX only, 8.583°/s²); the read-back
is Present Position 36 to Present Temperature 43 (8 bytes); hardware errors are bits of
every status packet's error byte (0 voltage, 2 overheating, 5 overload).
"""

from __future__ import annotations

import struct

from facesynth.services.control.drivers.bus_servo.bus import Status
from facesynth.services.control.drivers.bus_servo.native import Model


def _x(name: str, number: int) -> Model:
    return Model(name, number, 4096, 360.0, protocol=2)


MODELS: dict[int, Model] = {
    m.number: m
    for m in (
        _x("XL430-W250", 1060),
        _x("XM430-W350", 1020),
        _x("XM430-W210", 1030),
        _x("XH430-W350", 1010),
        _x("XH430-W210", 1000),
        _x("XC430-W150", 1070),
        _x("XC430-W240", 1080),
        _x("XL330-M288", 1200),
        _x("XL330-M077", 1190),
        _x("XM540-W270", 1120),
        _x("XM540-W150", 1130),
        _x("XH540-W270", 1110),
        _x("MX-28(2.0)", 30),
        _x("MX-64(2.0)", 311),
        _x("MX-106(2.0)", 321),
        Model("AX-12A", 12, 1024, 300.0, protocol=1),
        Model("AX-18A", 18, 1024, 300.0, protocol=1),
        Model("AX-12W", 300, 1024, 300.0, protocol=1),
        Model("MX-28", 29, 4096, 360.0, protocol=1),
        Model("MX-64", 310, 4096, 360.0, protocol=1),
        Model("MX-106", 320, 4096, 360.0, protocol=1),
    )
}
#: Model names (lower case) -> model, for the profile's ``model``.
BY_NAME = {m.name.lower(): m for m in MODELS.values()}

# Protocol 2.0, X series.
X_TORQUE, X_HW_ERROR, X_ACCEL, X_VELOCITY, X_GOAL = 64, 70, 108, 112, 116
X_READ, X_READ_SIZE = 126, 21
X_VELOCITY_UNIT = 0.229 / 60 * 4096  # position units/s per Profile Velocity unit
X_ACCEL_UNIT = 214.577 / 3600 * 4096  # position units/s² per Profile Acceleration unit
X_LIMIT = 32767
ALERT = 0x80
HW_ERRORS = {
    0: "input voltage error",
    2: "overheating",
    3: "motor encoder error",
    4: "electrical shock",
    5: "overload",
}

# Protocol 1.0, AX / MX.
P1_TORQUE, P1_GOAL, P1_SPEED, P1_ACCEL = 24, 30, 32, 73
P1_READ, P1_READ_SIZE = 36, 8
P1_HW_ERRORS = {0: "input voltage error", 2: "overheating", 5: "overload"}


def p1_speed_unit(model: Model) -> float:
    """Position units/s per Moving Speed unit (AX 0.111 rev/min, MX 0.114)."""
    rpm = 0.111 if model.name.startswith("AX") else 0.114
    return rpm / 60 * model.positions * 360 / model.degrees


def hardware_errors(bits: int, names: dict[int, str]) -> str:
    """The hardware error bits named, joined ("" when none)."""
    if not bits:
        return ""
    return ", ".join(text for bit, text in sorted(names.items()) if bits >> bit & 1)


def decode_x(data: bytes) -> Status:
    """The X series read-back block (Present Load 126 .. Present Temperature 146).

    :class:`ValueError` unless it is exactly :data:`X_READ_SIZE` bytes.
    """
    if len(data) != X_READ_SIZE:
        raise ValueError(f"a read-back of {len(data)} bytes (expected {X_READ_SIZE})")
    load, _velocity, position = struct.unpack_from("<hii", data, 0)
    temperature = data[20]
    return Status(position, max(-1.0, min(1.0, load / 1000)), float(temperature))


def decode_p1(data: bytes, error: int) -> Status:
    """The AX/MX read-back block (Present Position 36 .. Present Temperature 43) and the
    status packet's error byte. :class:`ValueError` unless it is :data:`P1_READ_SIZE` bytes."""
    if len(data) != P1_READ_SIZE:
        raise ValueError(f"a read-back of {len(data)} bytes (expected {P1_READ_SIZE})")
    position, _speed, load = struct.unpack_from("<HHH", data, 0)
    magnitude = min(load & 0x3FF, 1000) / 1000
    return Status(
        position,
        -magnitude if load & 0x400 else magnitude,
        float(data[7]),
        hardware_errors(error, P1_HW_ERRORS),
    )
