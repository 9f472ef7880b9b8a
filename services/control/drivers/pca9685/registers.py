"""The PCA9685's registers (NXP datasheet, rev. 4, section 7.3) and the bytes the driver writes.

One channel ``n`` has four registers from ``0x06 + 4n``: ``ON_L, ON_H, OFF_L, OFF_H``. The
channel's counter runs 0..4095 once per PWM period; the output rises at ``ON`` and falls at
``OFF``, so with ``ON = 0`` the pulse is ``OFF`` ticks long. Bit 4 of ``OFF_H`` is *full off*
(the power-on state of every channel). One tick is ``(PRE_SCALE + 1) / f_osc`` seconds, with
``PRE_SCALE = round(f_osc / (4096 × f)) − 1`` (section 7.3.5), at least 3.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping

from facesynth.services.control.drivers.base import DriverConfigError

MODE1 = 0x00
MODE2 = 0x01
LED0_ON_L = 0x06
ALL_LED_ON_L = 0xFA
ALL_LED_OFF_H = 0xFD
PRE_SCALE = 0xFE

# MODE1 bits
RESTART = 0x80
EXTCLK = 0x40
AI = 0x20  # register auto-increment
SLEEP = 0x10  # oscillator off
SUB1, SUB2, SUB3 = 0x08, 0x04, 0x02
ALLCALL = 0x01
#: MODE1 bits the driver keeps as it finds them (EXTCLK can only be cleared by a reset).
KEEP = EXTCLK | SUB1 | SUB2 | SUB3 | ALLCALL
# MODE2 bits
OUTDRV = 0x04  # totem-pole outputs (the power-on default; servo boards need it)
# LEDn_OFF_H / LEDn_ON_H bit
FULL = 0x10

CHANNELS = 16
TICKS = 4096
PRESCALE_MIN, PRESCALE_MAX = 3, 255
#: The oscillator must run this long after SLEEP is cleared before RESTART is written.
WAKE_S = 500e-6
#: Bytes of one channel's registers.
CHANNEL_BYTES = 4


def channel_register(channel: int) -> int:
    """``LEDn_ON_L`` of ``channel``."""
    return LED0_ON_L + CHANNEL_BYTES * channel


def prescale(oscillator_hz: float, frequency_hz: float) -> int:
    """``PRE_SCALE`` for ``frequency_hz``; :class:`DriverConfigError` outside 3..255."""
    value = round(oscillator_hz / (TICKS * frequency_hz)) - 1
    if not PRESCALE_MIN <= value <= PRESCALE_MAX:
        lowest = oscillator_hz / (TICKS * (PRESCALE_MAX + 1))
        highest = oscillator_hz / (TICKS * (PRESCALE_MIN + 1))
        raise DriverConfigError(
            f"--pca9685-frequency: {frequency_hz:g} Hz needs PRE_SCALE {value}, outside "
            f"{PRESCALE_MIN}..{PRESCALE_MAX} (with a {oscillator_hz / 1e6:g} MHz oscillator the "
            f"PCA9685 makes {lowest:.1f}..{highest:.0f} Hz)"
        )
    return value


def tick_us(prescale_value: int, oscillator_hz: float) -> float:
    """One counter tick in microseconds."""
    return (prescale_value + 1) / oscillator_hz * 1e6


def pose_block(pose: Mapping[int, int]) -> bytes:
    """The register address and data of one auto-increment write covering ``pose``.

    ``pose`` is ticks by channel; the block runs from the lowest channel to the highest, and
    the channels between them that the pose leaves out are written full off (as at power-on).
    """
    if not pose:
        raise ValueError("an empty pose")
    first, last = min(pose), max(pose)
    if first < 0 or last >= CHANNELS:
        raise ValueError(f"channels {first}..{last} are outside 0..{CHANNELS - 1}")
    if not all(0 < ticks < TICKS for ticks in pose.values()):
        raise ValueError(f"a pulse outside 1..{TICKS - 1} ticks in {dict(pose)}")
    # ON = 0 and OFF = the pulse's ticks, little-endian; OFF = 0x1000 (bit 4 of OFF_H): full off
    values = [0] * (2 * (last - first + 1))
    values[1::2] = [pose.get(ch, FULL << 8) for ch in range(first, last + 1)]
    return struct.pack(f"<B{len(values)}H", channel_register(first), *values)


def parse_address(text: str | int) -> int:
    """A 7-bit I2C address from ``0x40``, ``64`` or ``40h``; else :class:`DriverConfigError`."""
    try:
        if isinstance(text, int):
            value = text
        else:
            cleaned = text.strip().lower()
            value = int(cleaned[:-1], 16) if cleaned.endswith("h") else int(cleaned, 0)
    except ValueError:
        raise DriverConfigError(
            f"--i2c-address: expected an I2C address such as 0x40, got {text!r}"
        ) from None
    if not 0x03 <= value <= 0x77:
        raise DriverConfigError(
            f"--i2c-address: 0x{value:02x} is outside the 7-bit device addresses 0x03..0x77"
        )
    return value


def pulse_ticks(channel: bytes) -> int:
    """The high time, in ticks, of one channel's ``ON_L, ON_H, OFF_L, OFF_H`` (0: no pulse)."""
    on = channel[0] | (channel[1] & 0x0F) << 8
    off = channel[2] | (channel[3] & 0x0F) << 8
    if channel[3] & FULL:
        return 0
    if channel[1] & FULL:
        return TICKS
    return (off - on) % TICKS
