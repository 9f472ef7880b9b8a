"""The packets of a frame, built and parsed here rather than by the vendor SDKs.

Every frame a smart servo bus sends one Sync Write and reads some servos back. The SDKs build
each packet from Python lists (``GroupSyncWrite`` keeps a dict of parameter lists, the CRC
table is rebuilt on every call) and read answers a few bytes at a time; at 30 frames a second
that was most of the control process's CPU. The SDKs still open the port, ping, configure and
relax the servos; these are only the per-frame packets, checked byte for byte against the SDKs'
own in ``tests/control/test_bus_servo_wire.py``.

- Dynamixel Protocol 2.0 (ROBOTIS e-manual, "Protocol 2.0"): ``FF FF FD 00 ID LEN_L LEN_H INST
  PARAMS CRC_L CRC_H``; LEN counts INST to CRC after byte stuffing (``FF FF FD`` in INST..PARAMS
  gets another ``FD``); CRC-16, polynomial 0x8005, MSB first, initial 0, over the stuffed
  packet from the header. Status packets are INST 0x55 followed by an error byte.
- Dynamixel Protocol 1.0 and Feetech (their shared framing): ``FF FF ID LEN INST PARAMS CHK``,
  LEN = len(PARAMS) + 2, CHK = ~(ID + LEN + INST + PARAMS) & 0xFF; status packets carry an
  error byte where the instruction was.

Parsers take complete packets from the front of a buffer and leave an incomplete one there;
a packet whose CRC or checksum is wrong is skipped (counted), and the search goes on from the
next byte, so one damaged answer never hides the next.
"""

from __future__ import annotations

import struct
from array import array
from collections.abc import Sequence
from functools import lru_cache

BROADCAST = 0xFE
HEADER2 = b"\xff\xff\xfd\x00"
HEADER1 = b"\xff\xff"
STATUS2 = 0x55
SYNC_READ, SYNC_WRITE, READ = 0x82, 0x83, 0x02
#: The longest status packet accepted (beyond: noise that looks like a header).
MAX_STATUS = 1024


def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return tuple(table)


CRC_TABLE = _crc_table()


@lru_cache(maxsize=1)
def _crc_table16() -> array[int]:
    """The CRC of every two-byte word from 0 (built on first use: 128 kB)."""
    table = CRC_TABLE
    out = array("H", bytes(2 * 65536))
    for high in range(256):
        first = table[high]
        base, top = high << 8, first >> 8
        shifted = (first << 8) & 0xFFFF
        for low in range(256):
            out[base | low] = shifted ^ table[top ^ low]
    return out


@lru_cache(maxsize=256)
def _words(count: int) -> struct.Struct:
    return struct.Struct(f">{count}H")


def crc16(data: bytes, crc: int = 0) -> int:
    """CRC-16 of Protocol 2.0 over ``data``, continuing from ``crc``: two bytes a step
    through a 65536-entry table (the packets of a frame are CRC'd in Python)."""
    table = _crc_table16()
    for word in _words(len(data) // 2).unpack_from(data):
        crc = table[crc ^ word]
    if len(data) & 1:
        crc = ((crc << 8) & 0xFFFF) ^ CRC_TABLE[(crc >> 8) ^ data[-1]]
    return crc


def stuff(body: bytes) -> bytes:
    """Byte stuffing of INST..PARAMS: ``FF FF FD`` becomes ``FF FF FD FD``."""
    out = bytearray()
    for byte in body:
        out.append(byte)
        if byte == 0xFD and len(out) >= 3 and out[-3] == 0xFF and out[-2] == 0xFF:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """The inverse of :func:`stuff`."""
    if b"\xff\xff\xfd\xfd" not in body:
        return body
    return body.replace(b"\xff\xff\xfd\xfd", b"\xff\xff\xfd")


def packet2(servo_id: int, body: bytes) -> bytes:
    """A Protocol 2.0 packet of INST + PARAMS ``body`` (unstuffed)."""
    if b"\xff\xff\xfd" in body:
        body = stuff(body)
    length = len(body) + 2
    head = HEADER2 + bytes((servo_id, length & 0xFF, length >> 8)) + body
    return head + struct.pack("<H", crc16(head))


def packet1(servo_id: int, body: bytes) -> bytes:
    """A Protocol 1.0 / Feetech packet of INST + PARAMS ``body``."""
    head = bytes((servo_id, len(body) + 1)) + body
    return HEADER1 + head + bytes((~sum(head) & 0xFF,))


@lru_cache(maxsize=64)
def _sync_write_head2(address: int, size: int, count: int) -> tuple[bytes, int]:
    length = 7 + count * (1 + size)
    head = HEADER2 + struct.pack("<BHBHH", BROADCAST, length, SYNC_WRITE, address, size)
    return head, crc16(head)


@lru_cache(maxsize=64)
def _format(size: int, count: int, signed: bool) -> struct.Struct:
    item = {1: "b", 2: "h", 4: "i"}[size]
    return struct.Struct("<" + ("B" + (item if signed else item.upper())) * count)


def _interleave(goals: Sequence[tuple[int, int]]) -> list[int]:
    flat: list[int] = []
    for servo_id, goal in goals:
        flat.append(servo_id)
        flat.append(goal)
    return flat


def sync_write2(address: int, size: int, goals: Sequence[tuple[int, int]]) -> bytes:
    """A Protocol 2.0 Sync Write of ``size``-byte signed values, (id, value) in order."""
    head, crc = _sync_write_head2(address, size, len(goals))
    params = _format(size, len(goals), True).pack(*_interleave(goals))
    if b"\xff\xff\xfd" in head[7:] + params:  # only values that spell the header: rare
        return packet2(BROADCAST, head[7:] + params)
    return head + params + struct.pack("<H", crc16(params, crc))


@lru_cache(maxsize=64)
def _sync_write_head1(address: int, size: int, count: int) -> tuple[bytes, int]:
    head = bytes((BROADCAST, count * (1 + size) + 4, SYNC_WRITE, address, size))
    return HEADER1 + head, sum(head)


def sync_write1(address: int, size: int, goals: Sequence[tuple[int, int]]) -> bytes:
    """A Protocol 1.0 / Feetech Sync Write of ``size``-byte unsigned words, (id, word) in
    order, each sent low byte first (a big-endian servo's word comes byte-swapped)."""
    head, total = _sync_write_head1(address, size, len(goals))
    params = _format(size, len(goals), False).pack(*_interleave(goals))
    return head + params + bytes((~(total + sum(params)) & 0xFF,))


@lru_cache(maxsize=256)
def sync_read2(address: int, size: int, ids: tuple[int, ...]) -> bytes:
    """A Protocol 2.0 Sync Read request (cached: a read-back asks the same sets in turn)."""
    return packet2(BROADCAST, struct.pack("<BHH", SYNC_READ, address, size) + bytes(ids))


@lru_cache(maxsize=256)
def sync_read1(address: int, size: int, ids: tuple[int, ...]) -> bytes:
    """A Feetech Sync Read request (cached)."""
    return packet1(BROADCAST, bytes((SYNC_READ, address, size)) + bytes(ids))


@lru_cache(maxsize=512)
def read1(servo_id: int, address: int, size: int) -> bytes:
    """A Protocol 1.0 / Feetech READ request for one servo (cached)."""
    return packet1(servo_id, bytes((READ, address, size)))


Status = tuple[int, int, bytes]  # id, error byte, parameters


def take_status2(buffer: bytearray) -> tuple[list[Status], int]:
    """Complete Protocol 2.0 status packets taken from the front of ``buffer`` (consumed),
    and how many packets were skipped as damaged (CRC, or not a status packet). Bytes before
    a header are dropped; an incomplete packet stays in ``buffer``."""
    out: list[Status] = []
    damaged = 0
    while True:
        start = buffer.find(HEADER2)
        if start < 0:
            del buffer[: max(0, len(buffer) - 3)]
            return out, damaged
        if start:
            del buffer[:start]
        if len(buffer) < 7:
            return out, damaged
        length = buffer[5] | buffer[6] << 8
        if length < 4 or length > MAX_STATUS:
            del buffer[:1]
            damaged += 1
            continue
        end = 7 + length
        if len(buffer) < end:
            return out, damaged
        packet = bytes(buffer[:end])
        if crc16(packet[:-2]) != (packet[-2] | packet[-1] << 8):
            del buffer[:1]  # damaged: look for the next header inside it
            damaged += 1
            continue
        del buffer[:end]
        body = unstuff(packet[7:-2])
        if body[0] != STATUS2 or len(body) < 2:
            damaged += 1
            continue
        out.append((packet[4], body[1], body[2:]))


def take_status1(buffer: bytearray) -> tuple[list[Status], int]:
    """Complete Protocol 1.0 / Feetech status packets from the front of ``buffer``
    (consumed), and how many were skipped as damaged (checksum)."""
    out: list[Status] = []
    damaged = 0
    while True:
        start = buffer.find(HEADER1)
        if start < 0:
            del buffer[: max(0, len(buffer) - 1)]
            return out, damaged
        if start:
            del buffer[:start]
        while len(buffer) > 2 and buffer[2] == 0xFF:
            del buffer[:1]  # FF FF FF …: the header is the last two
        if len(buffer) < 4:
            return out, damaged
        length = buffer[3]
        if length < 2:
            del buffer[:2]
            damaged += 1
            continue
        end = 4 + length
        if len(buffer) < end:
            return out, damaged
        packet = bytes(buffer[:end])
        if ~sum(packet[2:-1]) & 0xFF != packet[-1]:
            del buffer[:1]
            damaged += 1
            continue
        del buffer[:end]
        out.append((packet[2], packet[4], packet[5:-1]))
