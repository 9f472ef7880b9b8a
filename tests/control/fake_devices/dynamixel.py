"""A Dynamixel bus on a pty: several servos behind one port, Protocol 2.0 or 1.0.

Written from the ROBOTIS e-manual ("Protocol 2.0", "Protocol 1.0", the XL430-W250 and AX-12A
control tables), not from the SDK, so the driver's SDK is checked against the documents.

Protocol 2.0 packets are ``FF FF FD 00 ID LEN_L LEN_H INST PARAMS CRC_L CRC_H``; LEN counts
INST to CRC after byte stuffing (an ``FD`` following ``FF FF`` in INST..PARAMS gets another
``FD``), and the CRC-16 (polynomial 0x8005, not reflected, initial 0) covers the stuffed
packet from the header. Status packets are instruction 0x55 with an error byte: bit 7 is the
Alert (a hardware error status is set), bits 0-6 the error number (1 result fail,
2 instruction, 3 CRC, 4 data range, 5 data length, 6 data limit, 7 access).

Protocol 1.0 packets are ``FF FF ID LEN INST PARAMS CHK`` with CHK = ~(ID + LEN + … ) & 0xFF;
status error bits: 0 voltage, 1 angle limit, 2 overheating, 3 range, 4 checksum, 5 overload,
6 instruction.

Both answer PING, READ, WRITE and SYNC WRITE (0x83); Protocol 2.0 also SYNC READ (0x82), each
addressed servo answering in the order of the ids, a silent one leaving a gap, and the
broadcast PING (every servo answers, in id order). Other broadcasts are never answered.
:meth:`FakeDynamixelBus.garble` corrupts the next status packets.
"""

from __future__ import annotations

from pathlib import Path

from fake_devices.bus_servo import (
    ACCESS,
    AX_SERIES,
    HW_OVERHEATING,
    HW_OVERLOAD,
    HW_VOLTAGE,
    LIMIT,
    RANGE,
    X_SERIES,
    EmulatedServo,
)
from fake_devices.pty_device import FakeDevice

BROADCAST = 0xFE
HEADER2 = b"\xff\xff\xfd\x00"
ERR_INSTRUCTION, ERR_CRC, ERR_RANGE, ERR_LENGTH, ERR_LIMIT, ERR_ACCESS = 2, 3, 4, 5, 6, 7
ALERT = 0x80
P2_ERRORS = {ACCESS: ERR_ACCESS, LIMIT: ERR_LIMIT, RANGE: ERR_RANGE}
P1_ERRORS = {ACCESS: 1 << 3, LIMIT: 1 << 1, RANGE: 1 << 3}
P1_CHECKSUM, P1_INSTRUCTION = 1 << 4, 1 << 6
#: Model numbers (ROBOTIS e-manual).
MODELS = {"XL430-W250": 1060, "XM430-W350": 1020, "AX-12A": 12, "MX-28": 29}


def crc16(data: bytes) -> int:
    """CRC-16 of Protocol 2.0 (polynomial 0x8005, MSB first, initial value 0)."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Byte stuffing of INST..PARAMS: ``FF FF FD`` becomes ``FF FF FD FD``."""
    out = bytearray()
    for byte in body:
        out.append(byte)
        if byte == 0xFD and out[-3:-1] == b"\xff\xff" and len(out) >= 3:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """The inverse of :func:`stuff`."""
    out = bytearray()
    i = 0
    while i < len(body):
        out.append(body[i])
        if body[i] == 0xFD and out[-3:-1] == b"\xff\xff" and body[i + 1 : i + 2] == b"\xfd":
            i += 1
        i += 1
    return bytes(out)


def packet2(servo_id: int, body: bytes) -> bytes:
    """A Protocol 2.0 packet: ``body`` is INST + PARAMS, unstuffed."""
    stuffed = stuff(body)
    length = len(stuffed) + 2
    head = HEADER2 + bytes((servo_id, length & 0xFF, length >> 8)) + stuffed
    crc = crc16(head)
    return head + bytes((crc & 0xFF, crc >> 8))


def packet1(servo_id: int, body: bytes) -> bytes:
    """A Protocol 1.0 packet: ``body`` is INST (or ERROR) + PARAMS."""
    head = bytes((servo_id, len(body) + 1)) + body
    return b"\xff\xff" + head + bytes((~sum(head) & 0xFF,))


Packet = tuple[int, bytes | None]


def split2(buffer: bytearray) -> list[Packet]:
    """Complete Protocol 2.0 packets taken from the front of ``buffer``: (id, INST + PARAMS
    unstuffed), None in place of the body when the CRC is wrong. Garbage before a header is
    dropped; an incomplete packet stays in ``buffer``."""
    out: list[Packet] = []
    while True:
        start = buffer.find(HEADER2)
        if start < 0:
            del buffer[: max(0, len(buffer) - 3)]
            return out
        del buffer[:start]
        if len(buffer) < 7:
            return out
        length = buffer[5] | buffer[6] << 8
        if length < 3 or length > 1024:
            del buffer[:1]
            continue
        if len(buffer) < 7 + length:
            return out
        packet = bytes(buffer[: 7 + length])
        del buffer[: 7 + length]
        crc = packet[-2] | packet[-1] << 8
        out.append((packet[4], unstuff(packet[7:-2]) if crc16(packet[:-2]) == crc else None))


def split1(buffer: bytearray) -> list[Packet]:
    """Complete Protocol 1.0 packets from the front of ``buffer``: (id, INST + PARAMS), None
    in place of the body when the checksum is wrong."""
    out: list[Packet] = []
    while True:
        start = buffer.find(b"\xff\xff")
        if start < 0:
            del buffer[: max(0, len(buffer) - 1)]
            return out
        del buffer[:start]
        while len(buffer) > 2 and buffer[2] == 0xFF:
            del buffer[:1]  # FF FF FF …: the header is the last two
        if len(buffer) < 4:
            return out
        length = buffer[3]
        if length < 2:
            del buffer[:2]
            continue
        if len(buffer) < 4 + length:
            return out
        packet = bytes(buffer[: 4 + length])
        del buffer[: 4 + length]
        good = ~sum(packet[2:-1]) & 0xFF == packet[-1]
        out.append((packet[2], packet[4:-1] if good else None))


class FakeDynamixelBus(FakeDevice):
    """Servos of one model family on one pty; ``protocol`` 2 (X series) or 1 (AX/MX)."""

    def __init__(
        self, link: Path, ids: list[int], *, model: str = "XL430-W250", protocol: int = 2
    ) -> None:
        self.protocol = protocol
        self.model_name = model
        self.ids = list(ids)
        self.garbled = 0
        self.crc_errors = 0
        self.packets: list[bytes] = []  # every good instruction: id, INST, PARAMS
        super().__init__(link)
        self.reset()

    def reset(self) -> None:
        super().reset()
        number = MODELS[self.model_name]
        layout = X_SERIES if self.protocol == 2 else AX_SERIES
        ax = self.model_name.startswith("AX")
        resolution = 1024 if ax else 4096
        per_turn = resolution * 360 / 300 if ax else resolution  # AX: 1024 over 300°
        unit = 0.229 if self.protocol == 2 else 0.111 if ax else 0.114  # rev/min
        self.servos = {
            i: EmulatedServo(i, number, layout, resolution, velocity_unit=unit / 60 * per_turn)
            for i in self.ids
        }
        self._buffer = bytearray()
        self.packets = []

    def garble(self, count: int = 1) -> None:
        """Flip a bit in the CRC/checksum of the next ``count`` status packets."""
        with self.lock:
            self.garbled += count

    def handle(self, data: bytes) -> bytes:
        self._buffer += data
        split = split2 if self.protocol == 2 else split1
        out = bytearray()
        for target, body in split(self._buffer):
            servo = self.servos.get(target)
            if body is None:
                self.crc_errors += 1
                if servo is not None and not servo.silent:  # unicast: a CRC error status
                    out += self._status(servo, b"", ERR_CRC if self.protocol == 2 else P1_CHECKSUM)
                continue
            if not body:
                continue
            self.packets.append(bytes((target,)) + body)
            out += self._execute(target, body[0], body[1:])
        return bytes(out)

    # -- instructions ----------------------------------------------------------------------

    def _execute(self, target: int, inst: int, params: bytes) -> bytes:
        if inst == 0x83:
            self._sync_write(params)
            return b""
        if inst == 0x82 and self.protocol == 2 and target == BROADCAST:
            return self._sync_read(params)
        if inst == 0x01 and self.protocol == 2 and target == BROADCAST:
            return b"".join(  # every servo answers, in the order of the ids
                self._status(s, bytes((s.model & 0xFF, s.model >> 8, 45)))
                for _, s in sorted(self.servos.items())
                if not s.silent
            )
        servo = self.servos.get(target)
        if servo is None or servo.silent:
            return b""
        if inst == 0x01:
            if self.protocol == 2:
                fw = 45
                return self._status(servo, bytes((servo.model & 0xFF, servo.model >> 8, fw)))
            return self._status(servo, b"")
        if inst == 0x02:
            addr, size = self._address(params)
            if size is None:
                return self._status(
                    servo, b"", ERR_LENGTH if self.protocol == 2 else P1_INSTRUCTION
                )
            got = servo.read(addr, size)
            if isinstance(got, str):
                return self._status(servo, b"", self._code(got))
            return self._status(servo, got)
        if inst == 0x03:
            head = 2 if self.protocol == 2 else 1
            if len(params) <= head:
                return self._status(
                    servo, b"", ERR_LENGTH if self.protocol == 2 else P1_INSTRUCTION
                )
            addr = params[0] | (params[1] << 8 if self.protocol == 2 else 0)
            error = servo.write(addr, params[head:])
            return self._status(servo, b"", self._code(error) if error else 0)
        return self._status(servo, b"", ERR_INSTRUCTION if self.protocol == 2 else P1_INSTRUCTION)

    def _address(self, params: bytes) -> tuple[int, int | None]:
        if self.protocol == 2:
            if len(params) != 4:
                return 0, None
            return params[0] | params[1] << 8, params[2] | params[3] << 8
        if len(params) != 2:
            return 0, None
        return params[0], params[1]

    def _sync_write(self, params: bytes) -> None:
        head = 4 if self.protocol == 2 else 2
        if len(params) < head:
            return
        addr = params[0] | (params[1] << 8 if self.protocol == 2 else 0)
        size = params[2] | params[3] << 8 if self.protocol == 2 else params[1]
        body = params[head:]
        if size == 0 or len(body) % (size + 1):
            return
        for at in range(0, len(body), size + 1):
            servo = self.servos.get(body[at])
            if servo is not None and not servo.silent:
                servo.write(addr, body[at + 1 : at + 1 + size])

    def _sync_read(self, params: bytes) -> bytes:
        if len(params) < 5:
            return b""
        addr, size = params[0] | params[1] << 8, params[2] | params[3] << 8
        out = bytearray()
        for servo_id in params[4:]:
            servo = self.servos.get(servo_id)
            if servo is None or servo.silent:
                continue
            got = servo.read(addr, size)
            if isinstance(got, str):
                out += self._status(servo, b"", self._code(got))
            else:
                out += self._status(servo, got)
        return bytes(out)

    def _code(self, error: str) -> int:
        return (P2_ERRORS if self.protocol == 2 else P1_ERRORS)[error]

    def _status(self, servo: EmulatedServo, params: bytes, error: int = 0) -> bytes:
        servo.advance()
        if self.protocol == 2:
            error |= ALERT if servo.errors else 0
            packet = packet2(servo.servo_id, bytes((0x55, error)) + params)
        else:
            hw = servo.errors
            error |= (1 << 5 if hw & HW_OVERLOAD else 0) | (1 << 2 if hw & HW_OVERHEATING else 0)
            error |= 1 if hw & HW_VOLTAGE else 0
            packet = packet1(servo.servo_id, bytes((error,)) + params)
        if self.garbled:
            self.garbled -= 1
            packet = packet[:-1] + bytes((packet[-1] ^ 0x01,))
        return packet

    # -- what tests look at ----------------------------------------------------------------

    def goals(self) -> dict[int, int]:
        """Each servo's goal position (native units)."""
        with self.lock:
            return {i: s.goal for i, s in self.servos.items()}

    def torque(self) -> dict[int, bool]:
        with self.lock:
            return {i: s.torque_on for i, s in self.servos.items()}
