"""Fuzz the Feetech answers the driver reads: status streams through the driver's own
receiver and parsing (bus_servo/wire.py, feetech/bus.py, models.py), checked against the
emulator's independent parser."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest
import scservo_sdk
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st
from servo_status import (
    Found,
    check_status_parser,
    check_sync_read,
    status_streams,
    valid_status_packets,
)

sys.path.insert(0, str(Path(__file__).parents[1] / "control"))
from fake_devices.dynamixel import packet1, split1

from facesynth.services.control.drivers.bus_servo import wire
from facesynth.services.control.drivers.feetech import models as m
from facesynth.services.control.drivers.feetech.bus import FeetechBus

pytestmark = [pytest.mark.fuzz, TIMEOUT]


STREAMS = status_streams(
    packet1, errors=[0, 0, 0x20, 0x04], sizes=[m.READ_SIZE, m.READ_SIZE, 0, 2], noise=30
)


def valid(stream: bytes) -> Found:
    return valid_status_packets(stream, b"\xff\xff", split1, lambda body: body or None)


def test_sync_read_answers_are_read_only_from_valid_status_packets() -> None:
    check_sync_read(
        "feetech Sync Read answers (wire.take_status1 + decode)",
        STREAMS,
        lambda: FeetechBus(scservo_sdk, "/dev/null", 1000000, latency_ms=0),
        valid,
        lambda data: m.decode(data, 0, m.STS).position,
        m.READ_SIZE,
    )


def test_status_parser_returns_only_valid_status_packets() -> None:
    check_status_parser("feetech wire.take_status1", wire.take_status1, STREAMS, valid)


def test_read_back_blocks_decode_or_are_refused() -> None:
    target = "feetech decode / model_from_bytes"

    @FUZZ
    @given(st.binary(max_size=16), st.integers(0, 255), st.sampled_from([m.STS, m.SCS]))
    def case(data: bytes, error: int, series: int) -> None:
        def decode() -> Any:
            if len(data) == 2:
                assert 0 <= m.model_from_bytes(data) <= 0xFFFF
            status = m.decode(data, error, series)
            assert -1 <= (status.load or 0) <= 1 and -0x7FFF <= status.position <= 0x7FFF
            return status

        outcome(target, decode, ValueError)

    case()
    check_tally(target, "valid", "refused")
