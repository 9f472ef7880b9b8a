"""A Feetech bus on a pty: STS (STS3215) or SCS (SCS0009) servos behind one port.

Written from Feetech's communication protocol manual and memory tables, not from the SDK.
Packets are ``FF FF ID LEN INST PARAMS CHK`` with CHK = ~(ID + LEN + INST + PARAMS) & 0xFF
(the framing of Dynamixel Protocol 1.0); status packets carry an error byte whose bits are
hardware conditions only: 0 voltage, 1 angle sensor, 2 overheating, 3 overcurrent,
5 overload. A packet with a bad checksum is not answered. Instructions: PING (1), READ (2),
WRITE (3), SYNC READ (0x82: each addressed servo answers in the order of the ids) and SYNC
WRITE (0x83); broadcasts are never answered. STS words are stored low byte first, SCS words
high byte first; a write the memory table refuses (EEPROM with the torque on, a read-only
item, a goal beyond the angle limits) is not applied.
"""

from __future__ import annotations

from pathlib import Path

from fake_devices.bus_servo import SCS_SERIES, STS_SERIES, EmulatedServo
from fake_devices.dynamixel import BROADCAST, packet1, split1
from fake_devices.pty_device import FakeDevice

#: Model numbers (Feetech memory tables) and positions per range.
MODELS = {"STS3215": (777, 4096, STS_SERIES), "SCS0009": (1284, 1024, SCS_SERIES)}


class FakeFeetechBus(FakeDevice):
    """Servos of one model on one pty."""

    def __init__(self, link: Path, ids: list[int], *, model: str = "STS3215") -> None:
        self.model_name = model
        self.ids = list(ids)
        self.garbled = 0
        self.checksum_errors = 0
        self.packets: list[bytes] = []
        super().__init__(link)
        self.reset()

    def reset(self) -> None:
        super().reset()
        number, resolution, layout = MODELS[self.model_name]
        self.servos = {
            i: EmulatedServo(i, number, layout, resolution, velocity_unit=1.0) for i in self.ids
        }
        self._buffer = bytearray()
        self.packets = []

    def garble(self, count: int = 1) -> None:
        """Flip a bit in the checksum of the next ``count`` status packets."""
        with self.lock:
            self.garbled += count

    def handle(self, data: bytes) -> bytes:
        self._buffer += data
        out = bytearray()
        for target, body in split1(self._buffer):
            if body is None:
                self.checksum_errors += 1
                continue
            self.packets.append(bytes((target,)) + body)
            out += self._execute(target, body[0], body[1:])
        return bytes(out)

    def _execute(self, target: int, inst: int, params: bytes) -> bytes:
        if inst == 0x83:
            self._sync_write(params)
            return b""
        if inst == 0x82 and target == BROADCAST:
            if len(params) < 3:
                return b""
            out = bytearray()
            for servo_id in params[2:]:
                out += self._read(servo_id, params[0], params[1])
            return bytes(out)
        servo = self.servos.get(target)
        if servo is None or servo.silent:
            return b""
        if inst == 0x01:
            return self._status(servo, b"")
        if inst == 0x02 and len(params) == 2:
            return self._read(target, params[0], params[1])
        if inst == 0x03 and len(params) >= 2:  # a refused write is not applied, no error bit
            servo.write(params[0], params[1:])
            return self._status(servo, b"")
        return b""

    def _read(self, servo_id: int, addr: int, size: int) -> bytes:
        servo = self.servos.get(servo_id)
        if servo is None or servo.silent:
            return b""
        got = servo.read(addr, size)
        return self._status(servo, got if isinstance(got, bytes) else b"")

    def _sync_write(self, params: bytes) -> None:
        if len(params) < 2:
            return
        addr, size, body = params[0], params[1], params[2:]
        if size == 0 or len(body) % (size + 1):
            return
        for at in range(0, len(body), size + 1):
            servo = self.servos.get(body[at])
            if servo is not None and not servo.silent:
                servo.write(addr, body[at + 1 : at + 1 + size])

    def _status(self, servo: EmulatedServo, params: bytes) -> bytes:
        servo.advance()
        packet = packet1(servo.servo_id, bytes((servo.errors & 0x3F,)) + params)
        if self.garbled:
            self.garbled -= 1
            packet = packet[:-1] + bytes((packet[-1] ^ 0x01,))
        return packet

    def goals(self) -> dict[int, int]:
        """Each servo's goal position (native units)."""
        with self.lock:
            return {i: s.goal for i, s in self.servos.items()}

    def torque(self) -> dict[int, bool]:
        with self.lock:
            return {i: s.torque_on for i, s in self.servos.items()}
