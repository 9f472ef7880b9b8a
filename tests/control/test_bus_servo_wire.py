"""The per-frame packets the smart servo drivers build and parse themselves (bus_servo/wire.py):
every packet built is the vendor SDK's own, byte for byte (dynamixel-sdk, scservo_sdk); status
packets made by the emulators (written from the vendors' documents) are parsed back, damaged
ones skipped without hiding the next."""

from __future__ import annotations

import random
from typing import Any

import dynamixel_sdk
import pytest
import scservo_sdk
from fake_devices.dynamixel import packet1 as doc_packet1
from fake_devices.dynamixel import packet2 as doc_packet2

from facesynth.services.control.drivers.bus_servo import wire
from facesynth.services.control.drivers.dynamixel import models as dxl
from facesynth.services.control.drivers.dynamixel.bus import DynamixelBus
from facesynth.services.control.drivers.feetech import models as ft
from facesynth.services.control.drivers.feetech.bus import FeetechBus


class CapturePort:
    """An SDK port that keeps what is written and answers nothing."""

    def __init__(self) -> None:
        self.written = bytearray()
        self.is_using = False
        self.baudrate = 1000000

    def clearPort(self) -> None:  # the SDKs' names
        pass

    def writePort(self, packet: Any) -> int:
        self.written += bytes(packet)
        return len(packet)

    def setPacketTimeout(self, _: int) -> None:
        pass


def _sdk_sync_write(sdk: Any, ph: Any, address: int, size: int, params: dict[int, bytes]) -> bytes:
    port = CapturePort()
    group = sdk.GroupSyncWrite(port, ph, address, size)
    for servo_id, data in params.items():
        assert group.addParam(servo_id, list(data))
    assert group.txPacket() == sdk.COMM_SUCCESS
    return bytes(port.written)


def _captured(call: Any) -> bytes:
    port = CapturePort()
    call(port)
    return bytes(port.written)


def test_crc16_is_the_sdks() -> None:
    ph = dynamixel_sdk.PacketHandler(2.0)
    rng = random.Random(26)
    for length in [*range(40), 93, 94, 255, 600]:
        data = bytes(rng.randrange(256) for _ in range(length))
        assert wire.crc16(data) == ph.updateCRC(0, list(data), length), length
        cut = rng.randrange(length + 1)
        assert wire.crc16(data[cut:], wire.crc16(data[:cut])) == wire.crc16(data)


GOALS = [
    {i: 2048 + 37 * i for i in range(1, 17)},  # a face: sixteen X series goals
    {7: 0},
    {1: 4095, 2: -3, 252: 100},
]


@pytest.mark.parametrize("goals", GOALS)
def test_protocol2_sync_write_is_the_sdks(goals: dict[int, int]) -> None:
    ph = dynamixel_sdk.PacketHandler(2.0)
    params = {i: int(g).to_bytes(4, "little", signed=True) for i, g in sorted(goals.items())}
    expected = _sdk_sync_write(dynamixel_sdk, ph, 116, 4, params)
    assert wire.sync_write2(116, 4, sorted(goals.items())) == expected
    bus = DynamixelBus(dynamixel_sdk, "/dev/null", 1000000, protocol=2, latency_ms=0)
    bus.port = CapturePort()
    assert bus.write_goals(goals) == len(expected)
    assert bytes(bus.port.written) == expected


def test_protocol2_sync_write_stuffs_what_spells_a_header() -> None:
    """``FF FF FD`` inside the parameters gets another ``FD`` (e-manual, Protocol 2.0), as the
    emulator's packet has it. (dynamixel-sdk 4.1.0 sends such a packet unstuffed: its
    ``txPacket`` drops what ``addStuffing`` returns when the length grows.)"""
    goals = [(3, 0x00FDFFFF), (4, 2048)]
    body = bytes((0x83, 116, 0, 4, 0)) + b"".join(
        bytes((i,)) + g.to_bytes(4, "little", signed=True) for i, g in goals
    )
    packet = wire.sync_write2(116, 4, goals)
    assert packet == doc_packet2(0xFE, body)
    assert b"\xff\xff\xfd\xfd" in packet and len(packet) == 14 + 2 * 5 + 1
    assert wire.unstuff(wire.stuff(body)) == body


def test_protocol1_sync_write_is_the_sdks() -> None:
    ph = dynamixel_sdk.PacketHandler(1.0)
    goals = {i: 512 + 9 * i for i in range(1, 17)}
    params = {i: g.to_bytes(2, "little") for i, g in goals.items()}
    expected = _sdk_sync_write(dynamixel_sdk, ph, 30, 2, params)
    bus = DynamixelBus(dynamixel_sdk, "/dev/null", 1000000, protocol=1, latency_ms=0)
    bus.port = CapturePort()
    assert bus.write_goals(goals) == len(expected) == 8 + 16 * 3
    assert bytes(bus.port.written) == expected


def test_feetech_sync_write_is_the_sdks_on_a_bus_of_both_series() -> None:
    """STS words go low byte first, SCS words high byte first, in one Sync Write."""
    ph = scservo_sdk.PacketHandler(ft.STS)
    goals = {1: 2048, 2: 4095, 3: 300, 4: -20, 5: 0}
    series = {1: ft.STS, 2: ft.STS, 3: ft.SCS, 4: ft.STS, 5: ft.SCS}
    params = {i: ft.word(goals[i], series[i]) for i in sorted(goals)}
    expected = _sdk_sync_write(scservo_sdk, ph, ft.GOAL, 2, params)
    bus = FeetechBus(scservo_sdk, "/dev/null", 1000000, latency_ms=0)
    bus.port = CapturePort()
    bus.series = series
    assert bus.write_goals(goals) == len(expected)
    assert bytes(bus.port.written) == expected


def test_read_requests_are_the_sdks() -> None:
    ids = (3, 4, 5, 6, 7)
    p2 = dynamixel_sdk.PacketHandler(2.0)
    assert wire.sync_read2(dxl.X_READ, dxl.X_READ_SIZE, ids) == _captured(
        lambda port: p2.syncReadTx(port, dxl.X_READ, dxl.X_READ_SIZE, list(ids), 5, False)
    )
    p1 = dynamixel_sdk.PacketHandler(1.0)
    assert wire.read1(9, dxl.P1_READ, dxl.P1_READ_SIZE) == _captured(
        lambda port: p1.readTx(port, 9, dxl.P1_READ, dxl.P1_READ_SIZE)
    )
    scs = scservo_sdk.PacketHandler(ft.STS)
    assert wire.sync_read1(ft.READ, ft.READ_SIZE, ids) == _captured(
        lambda port: scs.syncReadTx(port, ft.READ, ft.READ_SIZE, list(ids), 5)
    )
    assert wire.read1(12, ft.READ, ft.READ_SIZE) == _captured(
        lambda port: scs.readTx(port, 12, ft.READ, ft.READ_SIZE)
    )


def _chunks(stream: bytes, rng: random.Random) -> list[bytes]:
    cuts = sorted(rng.sample(range(1, len(stream)), 4)) if len(stream) > 5 else []
    return [stream[a:b] for a, b in zip([0, *cuts], [*cuts, len(stream)], strict=True)]


def test_protocol2_status_packets_are_parsed_across_chunks() -> None:
    answers = [
        (1, 0, bytes(range(21))),
        (2, 0x80, b"\xff\xff\xfd\x01" + bytes(17)),  # stuffed on the wire, not in the data
        (3, 0x07, b""),
    ]
    good = [doc_packet2(i, bytes((0x55, error)) + data) for i, error, data in answers]
    broken = bytearray(good[0])
    broken[-1] ^= 1
    instruction = doc_packet2(4, bytes((0x02, 0, 0)))  # not a status packet
    stream = b"\x00\xfd\xff" + bytes(broken) + good[0] + instruction + good[1] + good[2]
    for seed in range(20):
        buffer, got, damaged = bytearray(), [], 0
        for chunk in _chunks(stream, random.Random(seed)):
            buffer += chunk
            packets, skipped = wire.take_status2(buffer)
            got += packets
            damaged += skipped
        assert got == answers and damaged >= 2 and not buffer


def test_protocol2_leaves_an_incomplete_packet_in_the_buffer() -> None:
    packet = doc_packet2(5, bytes((0x55, 0)) + bytes(21))
    buffer = bytearray(packet[:-3])
    assert wire.take_status2(buffer) == ([], 0) and bytes(buffer) == packet[:-3]
    buffer += packet[-3:]
    assert wire.take_status2(buffer) == ([(5, 0, bytes(21))], 0) and not buffer


def test_protocol1_status_packets_are_parsed_across_chunks() -> None:
    answers = [(1, 0, bytes(range(8))), (2, 0x20, b"\xff\xff" + bytes(6)), (3, 0x04, b"")]
    good = [doc_packet1(i, bytes((error,)) + data) for i, error, data in answers]
    broken = bytearray(good[1])
    broken[-1] ^= 1
    stream = b"\x07\xff" + bytes(broken) + b"\xff" + good[0] + good[1] + good[2]
    for seed in range(20):
        buffer, got, damaged = bytearray(), [], 0
        for chunk in _chunks(stream, random.Random(seed)):
            buffer += chunk
            packets, skipped = wire.take_status1(buffer)
            got += packets
            damaged += skipped
        assert got == answers and damaged >= 1 and not buffer
