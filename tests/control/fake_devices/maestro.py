"""A fake Pololu Maestro, from the Maestro User's Guide ("Serial Servo Commands", "Errors").

Compact protocol: a command byte (top bit set) and its data bytes (top bit clear); 14-bit
values low 7 bits first; targets in quarter-µs, 0 = no pulses. A byte with the top bit set in
the middle of a command, an unknown command, or a channel the model does not have is a
*serial protocol error* (bit 4): the error register records it and, as on a real Maestro with
the factory settings, every servo goes to its error state (pulses off). Get Errors answers
the register (two bytes, low first) and clears it. Set Multiple Targets exists on Mini
Maestros only. The first 0xAA byte is the baud-rate indication.
"""

from __future__ import annotations

from pathlib import Path

from fake_devices.pty_device import FakeDevice

PROTOCOL_ERROR = 1 << 4
# Data bytes after the command byte (Set Multiple Targets: 2, then 2 per target).
LENGTHS = {0x84: 3, 0x87: 3, 0x89: 3, 0x90: 1, 0x93: 0, 0xA1: 0, 0xA2: 0, 0x9F: 2}


class FakeMaestro(FakeDevice):
    """A Maestro with ``channels`` channels (6: Micro, no Set Multiple Targets)."""

    def __init__(self, link: Path, channels: int = 24) -> None:
        self.channels = channels
        self.multiple_targets = channels > 6
        super().__init__(link)
        self.reset()

    def reset(self) -> None:
        super().reset()
        self.targets = [0] * self.channels
        self.speeds = [0] * self.channels
        self.accelerations = [0] * self.channels
        self.errors = 0
        self.error_events = 0
        self.baud_detected = False
        self.commands: list[tuple[int, ...]] = []  # (command, channel-or-count, …)
        self.sets: list[tuple[int, int]] = []  # every (channel, target) set, in order
        self._packet = bytearray()

    def handle(self, data: bytes) -> bytes:
        out = bytearray()
        for byte in data:
            out += self._byte(byte)
        return bytes(out)

    def _byte(self, byte: int) -> bytes:
        if byte & 0x80:
            if self._packet:
                self._error()  # a command interrupted by another
            self._packet = bytearray()
            if byte == 0xAA and not self.baud_detected:
                self.baud_detected = True
                return b""
            if byte not in LENGTHS or (byte == 0x9F and not self.multiple_targets):
                self._error()
                return b""
            self._packet.append(byte)
        elif not self._packet:
            self._error()  # a data byte outside any command
            return b""
        else:
            self._packet.append(byte)
        return self._maybe_execute()

    def _maybe_execute(self) -> bytes:
        packet = self._packet
        command = packet[0]
        need = LENGTHS[command]
        if command == 0x9F and len(packet) >= 2:
            need = 2 + 2 * packet[1]
        if len(packet) - 1 < need:
            return b""
        self._packet = bytearray()
        self.commands.append(tuple(packet))
        if command == 0xA1:
            errors, self.errors = self.errors, 0
            return bytes((errors & 0xFF, errors >> 8))
        if command == 0xA2:
            self.targets = [0] * self.channels
            return b""
        if command == 0x93:
            return b"\x00"
        channel = packet[1] if command != 0x9F else packet[2]
        count = 1 if command != 0x9F else packet[1]
        if channel + count > self.channels or count == 0:
            self._error()
            return b""
        if command == 0x90:
            target = self.targets[channel]
            return bytes((target & 0xFF, target >> 8))
        values = [
            packet[i] | packet[i + 1] << 7 for i in range(len(packet) - 2 * count, len(packet), 2)
        ]
        if command in (0x84, 0x9F):
            for offset, value in enumerate(values):
                self.targets[channel + offset] = value
                self.sets.append((channel + offset, value))
        elif command == 0x87:
            self.speeds[channel] = values[0]
        else:
            self.accelerations[channel] = values[0]
        return b""

    def _error(self) -> None:
        self.errors |= PROTOCOL_ERROR
        self.error_events += 1
        self.targets = [0] * self.channels  # the error state: pulses off

    def positions_us(self) -> dict[int, float]:
        """Every channel's target in µs (0 = off)."""
        return {ch: t / 4 for ch, t in enumerate(self.targets)}

    def poses(self) -> list[dict[int, float]]:
        """The targets set, grouped into poses (a channel set twice starts the next pose)."""
        poses: list[dict[int, float]] = []
        current: dict[int, float] = {}
        for channel, value in self.sets:
            if channel in current:
                poses.append(current)
                current = {}
            current[channel] = value / 4
        if current:
            poses.append(current)
        return poses
