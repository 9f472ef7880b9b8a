"""A register-exact PCA9685 behind smbus2's interface, from NXP's datasheet (rev. 4, sections 7.3
and 9): for the ``pca9685`` driver, since a real ``/dev/i2c-*`` needs a kernel driver.

Registers: MODE1 (0x00; power-on 0x11: SLEEP and ALLCALL), MODE2 (0x01; 0x04), LEDn_ON_L..
LEDn_OFF_H at 0x06 + 4n (power-on: bit 4 of OFF_H, full off), ALL_LED_ON_L..ALL_LED_OFF_H
(0xFA..0xFD: written to every channel, read as 0) and PRE_SCALE (0xFE; 0x1E, at least 3).

Behaviour kept: a write's first byte is the control register (the register pointer); with MODE1's
AI bit the pointer advances after each byte, without it every byte lands on the same register.
PRE_SCALE writes are blocked while the oscillator runs (SLEEP = 0). Putting the chip to sleep
while channels are active sets RESTART and stops the outputs; they run again when RESTART is
written with 1 (cleared by that write; a 0 has no effect), which must come at least 500 µs
after SLEEP was cleared, or when a PWM register is written. Outputs change at the end of the
I2C message (MODE2 OCH = 0). Everything a careful driver must not do is recorded in
:attr:`FakePCA9685.violations` (a PRE_SCALE write while awake, a RESTART too early, a write
to the reserved registers 0x46..0xF9, e.g. one running past LED15_OFF_H, a wrong address).

The pulse on a channel is ``(OFF − ON) mod 4096`` ticks of ``(PRE_SCALE + 1) / f_osc``, i.e.
``(OFF − ON) / 4096 × period``; full on and full off are the whole period and nothing.
"""

from __future__ import annotations

import errno
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

MODE1, MODE2, LED0, ALL_LED, PRE_SCALE = 0x00, 0x01, 0x06, 0xFA, 0xFE
LED15_OFF_H = LED0 + 4 * 15 + 3
RESTART, AI, SLEEP = 0x80, 0x20, 0x10
I2C_M_RD = 0x0001


@dataclass
class Transfer:
    """One I2C message the chip received: its first register and the data bytes after it."""

    register: int
    data: bytes


@dataclass
class FakePCA9685:
    """One PCA9685 at ``address`` with an oscillator of ``oscillator_hz``."""

    address: int = 0x40
    oscillator_hz: float = 25e6
    regs: bytearray = field(default_factory=lambda: bytearray(256))
    violations: list[str] = field(default_factory=list)
    writes: list[Transfer] = field(default_factory=list)
    #: The outputs' widths (µs by channel) after each write that changed a PWM register while
    #: the outputs ran: what the servos saw, in order.
    history: list[dict[int, float]] = field(default_factory=list)
    present: bool = True
    lock: threading.Lock = field(default_factory=threading.Lock)
    _woke_ns: int | None = None
    _paused: bool = False
    _pointer: int = 0

    def __post_init__(self) -> None:
        self.power_on()

    def power_on(self) -> None:
        """The power-on reset state (datasheet table 4)."""
        with self.lock:
            self.regs[:] = bytes(256)
            self.regs[MODE1] = SLEEP | 0x01
            self.regs[MODE2] = 0x04
            self.regs[0x02], self.regs[0x03], self.regs[0x04], self.regs[0x05] = (
                0xE2,
                0xE4,
                0xE8,
                0xE0,
            )
            for ch in range(16):
                self.regs[LED0 + 4 * ch + 3] = 0x10
            self.regs[PRE_SCALE] = 0x1E
            self._woke_ns = None
            self._paused = False
            self._pointer = 0

    # -- what a test reads --------------------------------------------------------------------

    @property
    def asleep(self) -> bool:
        return bool(self.regs[MODE1] & SLEEP)

    @property
    def period_us(self) -> float:
        """The PWM period the registers give: 4096 ticks of ``(PRE_SCALE + 1) / f_osc``."""
        return 4096 * (self.regs[PRE_SCALE] + 1) / self.oscillator_hz * 1e6

    def running(self) -> bool:
        """Whether the outputs make pulses (oscillator on, not waiting for RESTART)."""
        return not self.asleep and not self._paused

    def width_us(self, channel: int, *, programmed: bool = False) -> float:
        """The pulse on ``channel`` in µs, measured from its registers (0: no pulse); with
        ``programmed``, what the registers hold even while the outputs are stopped."""
        with self.lock:
            return self._width(channel, programmed)

    def _width(self, channel: int, programmed: bool) -> float:
        if not programmed and not self.running():
            return 0.0
        on_l, on_h, off_l, off_h = self.regs[LED0 + 4 * channel : LED0 + 4 * channel + 4]
        if off_h & 0x10:
            return 0.0
        if on_h & 0x10:
            return self.period_us
        ticks = ((off_l | (off_h & 0x0F) << 8) - (on_l | (on_h & 0x0F) << 8)) % 4096
        return ticks / 4096 * self.period_us

    def widths_us(self) -> dict[int, float]:
        """Every channel with a pulse, in µs."""
        widths = {ch: self.width_us(ch) for ch in range(16)}
        return {ch: w for ch, w in widths.items() if w > 0}

    # -- the chip's side of the bus -----------------------------------------------------------

    def check(self, address: int) -> None:
        """An I2C transfer to ``address``: no acknowledge unless the chip is there."""
        if not self.present or address != self.address:
            if self.present:
                self.violations.append(f"a transfer to 0x{address:02x}")
            raise OSError(errno.EREMOTEIO, os.strerror(errno.EREMOTEIO))

    def write(self, data: bytes) -> None:
        """One write message: the control register, then data bytes (then STOP)."""
        with self.lock:
            if not data:
                return
            self._pointer = data[0]
            self.writes.append(Transfer(data[0], bytes(data[1:])))
            pwm_written = False
            for value in data[1:]:
                register = self._pointer
                pwm_written |= LED0 <= register <= LED15_OFF_H or ALL_LED <= register < PRE_SCALE
                self._store(register, value)
                if self.regs[MODE1] & AI:
                    self._pointer = (register + 1) & 0xFF
            if pwm_written:
                self._paused = False  # OCH = 0: the outputs update at STOP, RESTART cleared
                self.regs[MODE1] &= ~RESTART
                if self.running():
                    widths = {ch: self._width(ch, False) for ch in range(16)}
                    self.history.append({ch: w for ch, w in widths.items() if w > 0})

    def read(self, length: int) -> bytes:
        """A read message: ``length`` bytes from the register pointer."""
        with self.lock:
            out = bytearray()
            for _ in range(length):
                register = self._pointer
                out.append(0 if ALL_LED <= register < PRE_SCALE else self.regs[register])
                if self.regs[MODE1] & AI:
                    self._pointer = (register + 1) & 0xFF
            return bytes(out)

    def _store(self, register: int, value: int) -> None:
        if register == MODE1:
            self._write_mode1(value)
        elif register == PRE_SCALE:
            if not self.asleep:
                self.violations.append("PRE_SCALE written while awake (blocked)")
            else:
                self.regs[PRE_SCALE] = max(value, 3)
        elif ALL_LED <= register < PRE_SCALE:
            for ch in range(16):
                self.regs[LED0 + 4 * ch + register - ALL_LED] = value
        elif 0x46 <= register < ALL_LED:
            self.violations.append(f"a write to reserved register 0x{register:02x}")
        else:
            self.regs[register] = value

    def _write_mode1(self, value: int) -> None:
        old = self.regs[MODE1]
        restart = old & RESTART
        if value & SLEEP and not old & SLEEP:  # going to sleep
            active = any(not self.regs[LED0 + 4 * ch + 3] & 0x10 for ch in range(16))
            if active and not self._paused:
                restart = RESTART
                self._paused = True
            self._woke_ns = None
        elif not value & SLEEP and old & SLEEP:  # waking: the oscillator starts
            self._woke_ns = time.monotonic_ns()
        if value & RESTART and restart:
            if value & SLEEP:
                self.violations.append("RESTART written while asleep")
            else:
                woke = self._woke_ns
                if woke is None or time.monotonic_ns() - woke < 500_000:
                    self.violations.append("RESTART less than 500 us after SLEEP was cleared")
                restart = 0
                self._paused = False
        self.regs[MODE1] = (value & ~RESTART & 0xFF) | restart


class I2CMessageError(ValueError):
    """A message object smbus2 would not have built."""


class FakeSMBus:
    """``smbus2.SMBus`` in front of a :class:`FakePCA9685`: the calls the driver makes.

    ``read_byte_data`` / ``write_byte_data`` are SMBus byte transfers; ``i2c_rdwr`` takes
    smbus2's own ``i2c_msg`` objects (address, flags, bytes), each one message ended by STOP
    (a write then a read in one call is a repeated start: the pointer carries over).
    """

    def __init__(self, chip: FakePCA9685, path: str) -> None:
        self.chip = chip
        self.path = path
        self.closed = False
        self.calls = 0

    def _use(self, address: int) -> None:
        if self.closed:
            raise OSError(errno.EBADF, os.strerror(errno.EBADF))
        self.calls += 1
        self.chip.check(address)

    def read_byte_data(self, i2c_addr: int, register: int, force: bool | None = None) -> int:
        self._use(i2c_addr)
        self.chip.write(bytes((register,)))
        return self.chip.read(1)[0]

    def write_byte_data(
        self, i2c_addr: int, register: int, value: int, force: bool | None = None
    ) -> None:
        if not 0 <= value <= 0xFF:
            raise ValueError(f"{value} is not a byte")
        self._use(i2c_addr)
        self.chip.write(bytes((register, value)))

    def i2c_rdwr(self, *i2c_msgs: Any) -> None:
        for message in i2c_msgs:
            self._use(message.addr)
            if message.flags & I2C_M_RD:
                data = self.chip.read(message.len)
                for i, byte in enumerate(data):
                    message.buf[i] = bytes((byte,))
            else:
                self.chip.write(bytes(message))

    def close(self) -> None:
        self.closed = True


class FakeI2CAdapter:
    """The host's I2C adapter at ``path`` (``/dev/i2c-N``) with chips on it: ``open`` is the
    driver's bus seam. :meth:`unplug` takes the chip's power away (no acknowledge), :meth:`plug`
    powers it again (a power-on reset: the driver must program it again)."""

    def __init__(self, path: Path, chip: FakePCA9685) -> None:
        self.path = path
        self.chip = chip
        self.opened: list[FakeSMBus] = []

    def open(self, path: str) -> FakeSMBus:
        if path != str(self.path):
            raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), path)
        bus = FakeSMBus(self.chip, path)
        self.opened.append(bus)
        return bus

    def unplug(self) -> None:
        self.chip.present = False

    def plug(self) -> None:
        self.chip.power_on()
        self.chip.present = True
