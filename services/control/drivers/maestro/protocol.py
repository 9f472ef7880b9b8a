"""Pololu Maestro compact serial protocol: the commands facesynth sends, and their answers.

From Pololu's Maestro Servo Controller User's Guide, "Serial Servo Commands". A command byte
has its top bit set, data bytes have it clear; 14-bit values go low 7 bits first. Targets are
in quarter-microseconds (1500 µs → 6000 → ``84 ch 70 2E``); a target of 0 stops the pulses, so
facesynth never sends it. Set Multiple Targets (``0x9F``) exists on the Mini Maestro 12, 18
and 24 only; the Micro Maestro 6 takes one Set Target (``0x84``) per channel.

Speed is in (0.25 µs)/(10 ms) and acceleration in (0.25 µs)/(10 ms)/(80 ms), 0 = no limit
(with the default 20 ms servo period; see the guide's "Channel Settings" for other periods).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

SET_TARGET = 0x84
SET_SPEED = 0x87
SET_ACCELERATION = 0x89
GET_POSITION = 0x90
SET_MULTIPLE_TARGETS = 0x9F
GET_ERRORS = 0xA1
GO_HOME = 0xA2
#: Baud-rate indication byte, for a Maestro in "UART, detect baud rate" mode.
BAUD_INDICATION = 0xAA

MAX_14BIT = 0x3FFF
MAX_ACCELERATION = 255
#: The widest pulse a target can ask for (14 bits of quarter-µs).
MAX_PULSE_US = MAX_14BIT / 4

#: Bits of the two-byte error register (Get Errors answers and clears it).
ERROR_BITS = (
    "serial signal error",
    "serial overrun error",
    "serial buffer full",
    "serial CRC error",
    "serial protocol error",
    "serial timeout",
    "script stack error",
    "script call stack error",
    "script program counter error",
)


@dataclass(frozen=True)
class Model:
    """A Maestro model: channel count and whether it has Set Multiple Targets."""

    name: str
    channels: int
    multiple_targets: bool


MODELS: dict[str, Model] = {
    "micro6": Model("Micro Maestro 6", 6, False),
    "mini12": Model("Mini Maestro 12", 12, True),
    "mini18": Model("Mini Maestro 18", 18, True),
    "mini24": Model("Mini Maestro 24", 24, True),
}
#: Pololu's USB vendor id and the product id of each model (both of a Maestro's serial ports).
USB_VENDOR = 0x1FFB
USB_PRODUCTS = {0x0089: "micro6", 0x008A: "mini12", 0x008B: "mini18", 0x008C: "mini24"}


def _value14(value: int, what: str) -> bytes:
    if not 0 <= value <= MAX_14BIT:
        raise ValueError(f"{what} {value} is not in 0..{MAX_14BIT}")
    return bytes((value & 0x7F, (value >> 7) & 0x7F))


def _channel(channel: int) -> int:
    if not 0 <= channel <= 0x7F:
        raise ValueError(f"channel {channel} is not in 0..127")
    return channel


def _target(quarter_us: int) -> bytes:
    if quarter_us <= 0:
        raise ValueError(f"target {quarter_us} would stop the pulses")
    return _value14(quarter_us, "target")


def set_target(channel: int, quarter_us: int) -> bytes:
    """Set Target: one channel, in quarter-microseconds."""
    return bytes((SET_TARGET, _channel(channel))) + _target(quarter_us)


def set_multiple_targets(first: int, targets: Sequence[int]) -> bytes:
    """Set Multiple Targets: channels ``first``, ``first + 1``, … (Mini Maestro only)."""
    if not 1 <= len(targets) <= 0x7F or first + len(targets) - 1 > 0x7F:
        raise ValueError(f"{len(targets)} targets from channel {first} do not fit")
    head = bytes((SET_MULTIPLE_TARGETS, len(targets), _channel(first)))
    return head + b"".join(_target(t) for t in targets)


def set_speed(channel: int, units: int) -> bytes:
    """Set Speed in (0.25 µs)/(10 ms); 0 = unlimited."""
    return bytes((SET_SPEED, _channel(channel))) + _value14(units, "speed")


def set_acceleration(channel: int, units: int) -> bytes:
    """Set Acceleration in (0.25 µs)/(10 ms)/(80 ms), 0..255; 0 = unlimited."""
    if not 0 <= units <= MAX_ACCELERATION:
        raise ValueError(f"acceleration {units} is not in 0..{MAX_ACCELERATION}")
    return bytes((SET_ACCELERATION, _channel(channel))) + _value14(units, "acceleration")


def get_position(channel: int) -> bytes:
    """Get Position: answered by two bytes, low first, quarter-µs."""
    return bytes((GET_POSITION, _channel(channel)))


def get_errors() -> bytes:
    """Get Errors: answered by two bytes, low first; reading clears the register."""
    return bytes((GET_ERRORS,))


def speed_units(max_speed_us_s: float) -> int:
    """A profile's ``max_speed`` (µs/s) in Set Speed units (0 = unlimited)."""
    if max_speed_us_s <= 0:
        return 0
    return min(MAX_14BIT, max(1, round(max_speed_us_s * 4 / 100)))


def acceleration_units(max_accel_us_s2: float) -> int:
    """A profile's ``max_accel`` (µs/s²) in Set Acceleration units (0 = unlimited); above
    255 units (79 688 µs/s²) the Maestro's highest limit is used."""
    if max_accel_us_s2 <= 0:
        return 0
    return min(MAX_ACCELERATION, max(1, round(max_accel_us_s2 * 4 / 100 * 0.08)))


def targets(pose: Mapping[int, int], multiple: bool) -> bytes:
    """The commands that move every channel of ``pose`` (quarter-µs by channel).

    With ``multiple``, each run of two or more neighbouring channels is one Set Multiple
    Targets (3 + 2n bytes instead of 4n); everything else is Set Target.
    """
    out = bytearray()
    channels = sorted(pose)
    i = 0
    while i < len(channels):
        j = i
        while j + 1 < len(channels) and channels[j + 1] == channels[j] + 1:
            j += 1
        run = channels[i : j + 1]
        if multiple and len(run) > 1:
            out += set_multiple_targets(run[0], [pose[ch] for ch in run])
        else:
            for ch in run:
                out += set_target(ch, pose[ch])
        i = j + 1
    return bytes(out)


def u16(answer: bytes) -> int:
    """A two-byte answer, low byte first."""
    if len(answer) != 2:
        raise ValueError(f"expected 2 bytes, got {len(answer)}")
    return answer[0] | answer[1] << 8


def error_names(bits: int) -> list[str]:
    """The errors set in an error register value."""
    names = [name for i, name in enumerate(ERROR_BITS) if bits & (1 << i)]
    unknown = bits & ~((1 << len(ERROR_BITS)) - 1)
    if unknown:
        names.append(f"unknown bits 0x{unknown:04x}")
    return names
