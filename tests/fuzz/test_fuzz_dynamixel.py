"""Fuzz the Dynamixel answers the driver reads: status streams through the driver's own
receiver and parsing (bus_servo/wire.py, dynamixel/bus.py, models.py), checked against the
emulator's independent parser; and the emulator's instruction parsers (test code, but the
suite relies on them)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import dynamixel_sdk
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged
from servo_status import (
    Found,
    check_status_parser,
    check_sync_read,
    status_streams,
    valid_status_packets,
)

sys.path.insert(0, str(Path(__file__).parents[1] / "control"))
from fake_devices.dynamixel import HEADER2, packet1, packet2, split1, split2

from facesynth.services.control.drivers.bus_servo import wire
from facesynth.services.control.drivers.dynamixel import models as m
from facesynth.services.control.drivers.dynamixel.bus import DynamixelBus

pytestmark = [pytest.mark.fuzz, TIMEOUT]


def status2(body: bytes) -> bytes | None:
    """Error byte and data of a Protocol 2.0 status body (INST 0x55, error, data)."""
    return body[1:] if len(body) >= 2 and body[0] == 0x55 else None


STREAMS = status_streams(
    lambda i, body: packet2(i, b"\x55" + body),
    errors=[0, 0, 0x80, 0x07],
    sizes=[m.X_READ_SIZE, m.X_READ_SIZE, 0, 4],
    noise=40,
)


def valid(stream: bytes) -> Found:
    return valid_status_packets(stream, HEADER2, split2, status2)


def test_sync_read_answers_are_read_only_from_valid_status_packets() -> None:
    def make_bus() -> DynamixelBus:
        bus = DynamixelBus(dynamixel_sdk, "/dev/null", 1000000, protocol=2, latency_ms=0)
        bus._fault = lambda servo_id, error: "alert" if error & 0x80 else ""  # type: ignore[method-assign]
        return bus

    check_sync_read(
        "dynamixel Sync Read answers (wire.take_status2 + decode_x)",
        STREAMS,
        make_bus,
        valid,
        lambda data: m.decode_x(data).position,
        m.X_READ_SIZE,
    )


def test_status_parser_returns_only_valid_status_packets() -> None:
    check_status_parser("dynamixel wire.take_status2", wire.take_status2, STREAMS, valid)


def test_read_back_blocks_decode_or_are_refused() -> None:
    target = "dynamixel decode_x / decode_p1"

    # any bytes, or as many as an AX/MX or an X block holds (random bytes rarely are)
    blocks = st.one_of(
        st.binary(max_size=30),
        st.sampled_from([m.P1_READ_SIZE, m.X_READ_SIZE]).flatmap(
            lambda n: st.binary(min_size=n, max_size=n)
        ),
    )

    @FUZZ
    @given(blocks, st.integers(0, 255))
    def case(data: bytes, error: int) -> None:
        def decode() -> Any:
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
