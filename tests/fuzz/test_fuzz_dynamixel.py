"""Fuzz the Dynamixel answers the driver reads: status streams through the SDK's receiver and
the driver's own status parsing (dynamixel/bus.py, models.py), checked against the emulator's
independent parser; and the emulator's instruction parsers (test code, but the suite relies
on them)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import dynamixel_sdk
import pytest
from fuzzing import FUZZ, check_tally, outcome, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged
from sdk_ports import MemoryPort

sys.path.insert(0, str(Path(__file__).parents[1] / "control"))
from fake_devices.dynamixel import HEADER2, packet1, packet2, split1, split2

from services.control.drivers.dynamixel import models as m
from services.control.drivers.dynamixel.bus import DynamixelBus

pytestmark = [pytest.mark.fuzz, pytest.mark.timeout(600)]


@st.composite
def status_streams(draw: st.DrawFn) -> bytes:
    parts = []
    for _ in range(draw(st.integers(0, 5))):
        servo_id = draw(st.integers(1, 6))
        error = draw(st.sampled_from([0, 0, 0x80, 0x07]))
        size = draw(st.sampled_from([m.X_READ_SIZE, m.X_READ_SIZE, 0, 4]))
        packet = packet2(
            servo_id, bytes((0x55, error)) + draw(st.binary(min_size=size, max_size=size))
        )
        kind = draw(st.sampled_from(["good", "good", "damaged", "noise"]))
        if kind == "damaged":
            packet = draw(damaged(packet))
        elif kind == "noise":
            packet = draw(st.binary(max_size=40))
        parts.append(packet)
    return b"".join(parts)


def valid_status_packets(stream: bytes) -> set[tuple[int, bytes]]:
    """(id, data) of every status packet with a good CRC anywhere in ``stream`` (whatever
    precedes it), by the emulator's own CRC and unstuffing: the oracle."""
    found = set()
    at = stream.find(HEADER2)
    while at >= 0:
        for _, body in split2(bytearray(stream[at:])):
            if body and body[0] == 0x55:
                found.add((stream[at + 4], body[2:]))
            break
        at = stream.find(HEADER2, at + 1)
    return found


def test_sync_read_answers_are_read_only_from_valid_status_packets() -> None:
    target = "dynamixel Sync Read answers (SDK rxPacket + parse_status2/decode_x)"
    record = tally(target)
    ids = [1, 2, 3, 4, 5]

    @FUZZ
    @given(status_streams(), st.integers(1, 64))
    def case(stream: bytes, chunk: int) -> None:
        bus = DynamixelBus(dynamixel_sdk, "/dev/null", 1000000, protocol=2, latency_ms=0)
        bus.port = MemoryPort(stream, chunk)
        bus._fault = lambda servo_id, error: "alert" if error & 0x80 else ""  # type: ignore[method-assign]
        statuses = bus.read(ids)
        assert set(statuses) == set(ids)
        valid = valid_status_packets(stream)
        for servo_id, status in statuses.items():
            if status is None:
                continue
            assert any(
                i == servo_id
                and len(data) == m.X_READ_SIZE
                and m.decode_x(data).position == status.position
                for i, data in valid
            ), (servo_id, status)
        record.count("read" if any(statuses.values()) else "none")

    case()
    check_tally(target, "read", "none")


def test_read_back_blocks_decode_or_are_refused() -> None:
    target = "dynamixel decode_x / decode_p1 / parse_status2"

    @FUZZ
    @given(st.binary(max_size=30), st.integers(0, 255))
    def case(data: bytes, error: int) -> None:
        def decode() -> Any:
            parsed = m.parse_status2(list(data), m.X_READ_SIZE)
            if parsed is not None:
                assert len(parsed[2]) == m.X_READ_SIZE
            p1 = m.decode_p1(data, error) if len(data) == m.P1_READ_SIZE else None
            if p1 is not None:
                assert -1 <= (p1.load or 0) <= 1
            status = m.decode_x(data)
            assert -1 <= (status.load or 0) <= 1
            return status

        outcome(target, decode, ValueError)

    case()
    check_tally(target, "valid", "refused")


def test_emulator_instruction_parsers_take_only_whole_checked_packets() -> None:
    target = "fake Dynamixel bus split2/split1 (instruction packets)"
    record = tally(target)

    @FUZZ
    @given(
        st.lists(st.tuples(st.integers(0, 0xFE), st.binary(min_size=1, max_size=12)), max_size=4),
        st.sampled_from([1, 2]),
        st.booleans(),
        st.data(),
    )
    def case(packets: list[tuple[int, bytes]], protocol: int, damage: bool, data: Any) -> None:
        encode, split = (packet2, split2) if protocol == 2 else (packet1, split1)
        stream = b"".join(encode(i, body) for i, body in packets)
        if damage:
            stream = data.draw(damaged(stream))
        buffer = bytearray(stream)
        found = split(buffer)
        assert len(buffer) <= len(stream)
        if not damage:
            assert [(i, b) for i, b in found] == packets and not buffer
        for _, body in found:
            assert body is None or isinstance(body, bytes)
        record.count("packets" if found else "none")

    case()
    check_tally(target, "packets", "none")
