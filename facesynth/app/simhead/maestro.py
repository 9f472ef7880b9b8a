"""A Pololu Maestro's serial side and pulse outputs, as the simulated head speaks it (pure).

From Pololu's Maestro Servo Controller User's Guide ("Serial Servo Commands", "Errors").
:meth:`Maestro.feed` takes the bytes a driver wrote and returns the Maestro's answers;
:meth:`Maestro.step` moves every channel's output pulse toward its target within the channel's
speed and acceleration limits, with time as data; :meth:`Maestro.outputs` are the pulses the
servos (the head's actuators) receive.

* Compact protocol: a command byte (top bit set) and its data bytes (top bit clear).
  Pololu protocol: ``0xAA``, the device number, the command byte with its top bit cleared, the
  data; a packet for another device number is ignored. A lone ``0xAA`` followed by a command
  byte is the baud-rate indication.
* Commands: Set Target (``0x84``; 0 = pulses off), Set Multiple Targets (``0x9F``, not on a
  Micro Maestro 6), Set Speed (``0x87``, 0.25 µs / 10 ms), Set Acceleration (``0x89``,
  0.25 µs / 10 ms / 80 ms, 0..255), Get Position (``0x90``: two bytes, low first,
  quarter-µs), Get Moving State (``0x93``: one byte, 1 while an output is still ramping), Get
  Errors (``0xA1``: two bytes, low first; reading clears them), Go Home (``0xA2``: every
  channel to its home, pulses off here).
* 14-bit values go low 7 bits first. Targets are clamped to the channel range (here
  500..2500 µs, a Maestro configured for wide servos).
* A command byte in the middle of a command, an unknown command, a data byte outside any
  command, a channel the model does not have or an acceleration above 255 are a *serial
  protocol error* (bit 4): the error register records it and, as with the factory settings,
  every servo goes to its error state (pulses off).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Final

__all__ = ["PROTOCOL_ERROR", "Maestro", "MaestroError"]

SET_TARGET: Final = 0x84
SET_SPEED: Final = 0x87
SET_ACCELERATION: Final = 0x89
GET_POSITION: Final = 0x90
GET_MOVING_STATE: Final = 0x93
SET_MULTIPLE_TARGETS: Final = 0x9F
GET_ERRORS: Final = 0xA1
GO_HOME: Final = 0xA2
POLOLU_START: Final = 0xAA
#: Data bytes after the command byte (Set Multiple Targets: 2, then 2 per target).
LENGTHS: Final = {
    SET_TARGET: 3,
    SET_SPEED: 3,
    SET_ACCELERATION: 3,
    GET_POSITION: 1,
    GET_MOVING_STATE: 0,
    SET_MULTIPLE_TARGETS: 2,
    GET_ERRORS: 0,
    GO_HOME: 0,
}
#: The serial protocol error bit of the error register.
PROTOCOL_ERROR: Final = 1 << 4
#: The pulse range a target is clamped to (quarter-µs).
MIN_TARGET: Final = 2000
MAX_TARGET: Final = 10000
#: Speed units -> µs/s, acceleration units -> µs/s².
SPEED_UNIT: Final = 0.25 / 0.01
ACCEL_UNIT: Final = 0.25 / 0.01 / 0.08


class MaestroError(ValueError):
    """A Maestro that cannot be built as asked."""


@dataclass
class _Channel:
    target: int = 0  # quarter-µs, 0 = off
    position: float = 0.0  # quarter-µs of the output, 0 = off
    speed: int = 0
    acceleration: int = 0
    velocity: float = 0.0  # µs/s, toward the target


@dataclass
class Maestro:
    """A Maestro with ``channels`` channels (6: a Micro, without Set Multiple Targets) and a
    Pololu-protocol ``device_number`` (12, the factory default)."""

    channels: int = 24
    device_number: int = 12
    errors: int = 0
    error_events: int = 0
    commands: list[tuple[int, ...]] = field(default_factory=list)
    _state: list[_Channel] = field(default_factory=list)
    _packet: bytearray = field(default_factory=bytearray)
    _pololu: int = 0  # 0 none, 1 device number expected, 2 command expected, 3 skipping
    _t_ns: int | None = None

    def __post_init__(self) -> None:
        if self.channels not in (6, 12, 18, 24):
            raise MaestroError(f"a Maestro has 6, 12, 18 or 24 channels, not {self.channels}")
        if not 0 <= self.device_number <= 127:
            raise MaestroError(f"device number {self.device_number} is not in 0..127")
        self._state = [_Channel() for _ in range(self.channels)]

    @property
    def multiple_targets(self) -> bool:
        """Whether the model has Set Multiple Targets (the Mini Maestros)."""
        return self.channels > 6

    def feed(self, data: bytes) -> bytes:
        """The bytes a driver wrote in; the Maestro's answers out."""
        out = bytearray()
        for byte in data:
            out += self._byte(byte)
        return bytes(out)

    def _byte(self, byte: int) -> bytes:
        if byte & 0x80:
            # (after a lone 0xAA, the baud-rate indication, a command byte is fine)
            if self._packet or self._pololu == 2:
                self._error()  # a command interrupted by another
            self._packet = bytearray()
            self._pololu = 0
            if byte == POLOLU_START:
                self._pololu = 1
                return b""
            return self._start(byte)
        if self._pololu == 1:
            self._pololu = 2 if byte == self.device_number else 3
            return b""
        if self._pololu == 2:
            self._pololu = 0
            return self._start(byte | 0x80)
        if self._pololu == 3:
            return b""  # a packet for another device
        if not self._packet:
            self._error()  # a data byte outside any command
            return b""
        self._packet.append(byte)
        return self._maybe_execute()

    def _start(self, command: int) -> bytes:
        if command not in LENGTHS or (
            command == SET_MULTIPLE_TARGETS and not self.multiple_targets
        ):
            self._error()
            return b""
        self._packet = bytearray((command,))
        return self._maybe_execute()

    def _maybe_execute(self) -> bytes:
        packet = self._packet
        command = packet[0]
        need = LENGTHS[command]
        if command == SET_MULTIPLE_TARGETS and len(packet) >= 2:
            need = 2 + 2 * packet[1]
        if len(packet) - 1 < need:
            return b""
        self._packet = bytearray()
        self.commands.append(tuple(packet))
        return self._execute(command, packet)

    def _execute(self, command: int, packet: bytearray) -> bytes:
        if command == GET_ERRORS:
            errors, self.errors = self.errors, 0
            return bytes((errors & 0xFF, errors >> 8))
        if command == GO_HOME:
            for channel in self._state:
                channel.target = 0
                channel.position = 0.0
            return b""
        if command == GET_MOVING_STATE:
            return b"\x01" if self.moving() else b"\x00"
        first = packet[2] if command == SET_MULTIPLE_TARGETS else packet[1]
        count = packet[1] if command == SET_MULTIPLE_TARGETS else 1
        if count == 0 or first + count > self.channels:
            self._error()
            return b""
        if command == GET_POSITION:
            position = round(self._state[first].position)
            return bytes((position & 0xFF, position >> 8))
        values = [
            packet[i] | packet[i + 1] << 7 for i in range(len(packet) - 2 * count, len(packet), 2)
        ]
        if command == SET_SPEED:
            self._state[first].speed = values[0]
        elif command == SET_ACCELERATION:
            if values[0] > 255:
                self._error()
                return b""
            self._state[first].acceleration = values[0]
        else:
            for offset, value in enumerate(values):
                self._set_target(first + offset, value)
        return b""

    def _set_target(self, channel: int, value: int) -> None:
        state = self._state[channel]
        state.target = 0 if value == 0 else min(max(value, MIN_TARGET), MAX_TARGET)
        if state.target == 0:
            state.position = 0.0
            state.velocity = 0.0
        elif state.position == 0 or (state.speed == 0 and state.acceleration == 0):
            state.position = float(state.target)  # from off, or unlimited: at once
            state.velocity = 0.0

    def _error(self) -> None:
        self.errors |= PROTOCOL_ERROR
        self.error_events += 1
        self._packet = bytearray()
        self._pololu = 0
        for channel in self._state:  # the error state: pulses off
            channel.target = 0
            channel.position = 0.0
            channel.velocity = 0.0

    def step(self, t_ns: int) -> None:
        """Ramp every output toward its target up to ``t_ns`` (speed and acceleration)."""
        dt = 0.0 if self._t_ns is None else max(0.0, (t_ns - self._t_ns) / 1e9)
        self._t_ns = t_ns
        if dt == 0.0:
            return
        for state in self._state:
            if state.target == 0 or state.position == state.target:
                state.velocity = 0.0
                continue
            gap_us = (state.target - state.position) / 4.0
            distance = abs(gap_us)
            limit = state.speed * SPEED_UNIT if state.speed else math.inf
            if state.acceleration:
                accel = state.acceleration * ACCEL_UNIT
                stop = math.sqrt(2.0 * accel * distance)  # slow down to stop at the target
                state.velocity = min(state.velocity + accel * dt, limit, stop + accel * dt)
            else:
                state.velocity = limit
            move = min(distance, state.velocity * dt)
            state.position += math.copysign(move * 4.0, gap_us)
            if move >= distance:
                state.position = float(state.target)
                state.velocity = 0.0

    def moving(self) -> bool:
        """Whether some output is still on its way to its target."""
        return any(s.target and s.position != s.target for s in self._state)

    def outputs(self) -> dict[int, float]:
        """Every channel's output pulse in µs (0 = off)."""
        return {ch: s.position / 4.0 for ch, s in enumerate(self._state)}

    def targets(self) -> dict[int, float]:
        """Every channel's target in µs (0 = off)."""
        return {ch: s.target / 4.0 for ch, s in enumerate(self._state)}

    def limits(self, channel: int) -> tuple[int, int]:
        """(speed, acceleration) of ``channel`` in the Maestro's units."""
        state = self._state[channel]
        return state.speed, state.acceleration
