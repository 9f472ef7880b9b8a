"""Fuzz the Feetech answers the driver reads: status streams through the SDK's receiver and
the driver's own parsing (feetech/bus.py, models.py), checked against the emulator's
independent parser."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest
import scservo_sdk
from fuzzing import FUZZ, check_tally, outcome, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged
from sdk_ports import MemoryPort

sys.path.insert(0, str(Path(__file__).parents[1] / "control"))
from fake_devices.dynamixel import packet1, split1

from services.control.drivers.feetech import models as m
from services.control.drivers.feetech.bus import FeetechBus, parse_status

pytestmark = [pytest.mark.fuzz, pytest.mark.timeout(600)]


@st.composite
def status_streams(draw: st.DrawFn) -> bytes:
    parts = []
    for _ in range(draw(st.integers(0, 5))):
        servo_id = draw(st.integers(1, 6))
        error = draw(st.sampled_from([0, 0, 0x20, 0x04]))
        size = draw(st.sampled_from([m.READ_SIZE, m.READ_SIZE, 0, 2]))
        packet = packet1(servo_id, bytes((error,)) + draw(st.binary(min_size=size, max_size=size)))
        kind = draw(st.sampled_from(["good", "good", "damaged", "noise"]))
        if kind == "damaged":
            packet = draw(damaged(packet))
        elif kind == "noise":
            packet = draw(st.binary(max_size=30))
        parts.append(packet)
    return b"".join(parts)


def valid_status_packets(stream: bytes) -> set[tuple[int, bytes]]:
    """(id, data) of every packet with a good checksum anywhere in ``stream``: the oracle."""
    found = set()
    at = stream.find(b"\xff\xff")
    while at >= 0:
        for servo_id, body in split1(bytearray(stream[at:])):
            if body is not None:
                found.add((servo_id, body[1:]))
            break
        at = stream.find(b"\xff\xff", at + 1)
    return found


def test_sync_read_answers_are_read_only_from_valid_status_packets() -> None:
    target = "feetech Sync Read answers (SDK rxPacket + parse_status/decode)"
    record = tally(target)
    ids = [1, 2, 3, 4, 5]

    @FUZZ
    @given(status_streams(), st.integers(1, 64))
    def case(stream: bytes, chunk: int) -> None:
        bus = FeetechBus(scservo_sdk, "/dev/null", 1000000, latency_ms=0)
        bus.port = MemoryPort(stream, chunk)
        statuses = bus.read(ids)
        assert set(statuses) == set(ids)
        valid = valid_status_packets(stream)
        for servo_id, status in statuses.items():
            if status is None:
                continue
            assert any(
                i == servo_id
                and len(data) == m.READ_SIZE
                and m.decode(data, 0, m.STS).position == status.position
                for i, data in valid
            ), (servo_id, status)
        record.count("read" if any(statuses.values()) else "none")

    case()
    check_tally(target, "read", "none")


def test_read_back_blocks_decode_or_are_refused() -> None:
    target = "feetech decode / parse_status / model_from_bytes"

    @FUZZ
    @given(st.binary(max_size=16), st.integers(0, 255), st.sampled_from([m.STS, m.SCS]))
    def case(data: bytes, error: int, series: int) -> None:
        def decode() -> Any:
            parsed = parse_status(list(data), m.READ_SIZE)
            if parsed is not None:
                assert len(parsed[2]) == m.READ_SIZE
            if len(data) == 2:
                assert 0 <= m.model_from_bytes(data) <= 0xFFFF
            status = m.decode(data, error, series)
            assert -1 <= (status.load or 0) <= 1 and -0x7FFF <= status.position <= 0x7FFF
            return status

        outcome(target, decode, ValueError)

    case()
    check_tally(target, "valid", "refused")
