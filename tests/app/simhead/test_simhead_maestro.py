"""The simulated head's Maestro: every command in both protocols, ramps, and malformed bytes."""

from __future__ import annotations

import random

import pytest

from facesynth.app.simhead.maestro import PROTOCOL_ERROR, Maestro, MaestroError
from facesynth.services.control.drivers.maestro import protocol

MS = 1_000_000


def test_set_target_compact_and_pololu() -> None:
    maestro = Maestro()
    assert maestro.feed(protocol.set_target(3, 6000)) == b""
    assert maestro.outputs()[3] == 1500.0
    # Pololu protocol: 0xAA, device 12, the command with its top bit cleared
    assert maestro.feed(bytes((0xAA, 12, 0x04, 4)) + protocol.set_target(4, 7000)[2:]) == b""
    assert maestro.outputs()[4] == 1750.0
    maestro.feed(bytes((0xAA, 13, 0x04, 5, 0x70, 0x2E)))  # another device's packet: ignored
    assert maestro.outputs()[5] == 0.0
    assert maestro.errors == 0


def test_set_multiple_targets_and_the_micro() -> None:
    maestro = Maestro()
    maestro.feed(protocol.set_multiple_targets(2, [5000, 6000, 7000]))
    assert [maestro.outputs()[ch] for ch in (2, 3, 4)] == [1250.0, 1500.0, 1750.0]
    micro = Maestro(channels=6)
    micro.feed(protocol.set_target(1, 6000))
    micro.feed(protocol.set_multiple_targets(0, [6000, 6000]))
    assert micro.errors == PROTOCOL_ERROR
    assert micro.outputs()[1] == 0.0  # the error state: pulses off


def test_targets_are_clamped_and_zero_is_off() -> None:
    maestro = Maestro()
    maestro.feed(protocol.set_target(0, 12000) + protocol.set_target(1, 100))
    assert maestro.outputs()[0] == 2500.0 and maestro.outputs()[1] == 500.0
    maestro.feed(bytes((0x84, 0, 0, 0)))
    assert maestro.outputs()[0] == 0.0


def test_speed_ramps_the_output_and_get_position_follows() -> None:
    maestro = Maestro()
    maestro.step(0)
    maestro.feed(protocol.set_target(0, 6000))  # from off: at once
    maestro.feed(protocol.set_speed(0, protocol.speed_units(1000.0)))
    maestro.feed(protocol.set_target(0, 8000))
    assert maestro.feed(protocol.get_position(0)) == bytes((6000 & 0xFF, 6000 >> 8))
    assert maestro.feed(bytes((0x93,))) == b"\x01"
    maestro.step(100 * MS)
    assert maestro.outputs()[0] == pytest.approx(1600.0)
    assert protocol.u16(maestro.feed(protocol.get_position(0))) == 6400
    maestro.step(1_000 * MS)
    assert maestro.outputs()[0] == 2000.0
    assert maestro.feed(bytes((0x93,))) == b"\x00"
    assert maestro.limits(0) == (protocol.speed_units(1000.0), 0)


def test_acceleration_starts_and_stops_gently() -> None:
    maestro = Maestro()
    maestro.feed(protocol.set_target(0, 4000))
    maestro.feed(protocol.set_acceleration(0, protocol.acceleration_units(10000.0)))
    maestro.feed(protocol.set_target(0, 8000))  # 1000 µs away, no speed limit
    positions = []
    for i in range(1, 200):
        maestro.step(i * 5 * MS)
        positions.append(maestro.outputs()[0])
    steps = [b - a for a, b in zip([1000.0, *positions], positions, strict=False)]
    assert steps[0] < steps[20]  # speeding up
    assert positions[-1] == 2000.0
    moving = [s for s in steps if s > 0]
    assert moving[-1] < max(moving)  # slowing down before the target


def test_get_errors_answers_and_clears() -> None:
    maestro = Maestro()
    assert maestro.feed(protocol.get_errors()) == b"\x00\x00"
    maestro.feed(b"\x05")  # a data byte outside any command
    assert maestro.feed(protocol.get_errors()) == bytes((PROTOCOL_ERROR, 0))
    assert maestro.feed(protocol.get_errors()) == b"\x00\x00"


def test_go_home_turns_the_pulses_off() -> None:
    maestro = Maestro()
    maestro.feed(protocol.set_multiple_targets(0, [6000] * 24))
    maestro.feed(bytes((0xA2,)))
    assert set(maestro.outputs().values()) == {0.0}
    assert set(maestro.targets().values()) == {0.0}


def test_the_baud_rate_indication() -> None:
    maestro = Maestro()
    maestro.feed(bytes((0xAA,)) + protocol.set_target(0, 6000))
    assert maestro.errors == 0 and maestro.outputs()[0] == 1500.0


MALFORMED = [
    ("data byte alone", b"\x10"),
    ("interrupted", b"\x84\x00\x70\x87\x01\x00\x00"),
    ("unknown command", b"\x85\x00\x70\x2e"),
    ("channel too high", protocol.set_target(24, 6000)),
    ("targets past the end", protocol.set_multiple_targets(20, [6000] * 5)),
    ("no targets", b"\x9f\x00\x00"),
    ("acceleration over 255", b"\x89\x00\x00\x02"),
    ("pololu interrupted", b"\xaa\x0c\x84"),
    ("pololu unknown", b"\xaa\x0c\x05\x00"),
]


@pytest.mark.parametrize(("case", "data"), MALFORMED, ids=[c[0] for c in MALFORMED])
def test_malformed_bytes_are_a_protocol_error(case: str, data: bytes) -> None:
    maestro = Maestro()
    maestro.feed(protocol.set_target(0, 6000))
    assert maestro.feed(data) == b""
    assert maestro.errors & PROTOCOL_ERROR
    assert maestro.outputs()[0] == 0.0
    # and it keeps working
    maestro.feed(protocol.set_target(0, 7000) + protocol.get_errors())
    assert maestro.outputs()[0] == 1750.0


def test_bytes_one_at_a_time_are_the_same_stream() -> None:
    stream = (
        protocol.set_multiple_targets(0, [5000, 6000])
        + protocol.set_speed(1, 10)
        + protocol.get_position(0)
        + bytes((0xAA, 12, 0x10, 1))
        + protocol.get_errors()
    )
    whole, split = Maestro(), Maestro()
    answers = whole.feed(stream)
    assert b"".join(split.feed(bytes((b,))) for b in stream) == answers
    assert answers == bytes((5000 & 0xFF, 5000 >> 8, 6000 & 0xFF, 6000 >> 8, 0, 0))


def test_garbage_never_raises() -> None:
    rng = random.Random(17)
    maestro = Maestro()
    for _ in range(300):
        data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 40)))
        maestro.feed(data)
        maestro.step(rng.randrange(10**9))
        assert all(0 <= v <= 2500 for v in maestro.outputs().values())


def test_bad_models() -> None:
    with pytest.raises(MaestroError, match="6, 12, 18 or 24 channels"):
        Maestro(channels=8)
    with pytest.raises(MaestroError, match="device number 200"):
        Maestro(device_number=200)
