"""services.control.drivers.maestro.protocol against the examples of Pololu's user's guide."""

from __future__ import annotations

import pytest

from facesynth.services.control.drivers.maestro import protocol as mp


def test_set_target_in_quarter_microseconds() -> None:
    # Guide: 1500 us = 6000 quarter-us -> 0x84, channel, 0x70, 0x2E.
    assert mp.set_target(0, 6000) == bytes([0x84, 0x00, 0x70, 0x2E])
    assert mp.set_target(5, 4000) == bytes([0x84, 0x05, 0x20, 0x1F])


def test_set_multiple_targets() -> None:
    # Guide: channel 3 to 0 and channel 4 to 6000 is 9F 02 03 00 00 70 2E; facesynth never
    # sends 0 (it stops the pulses), so the same layout with channel 3 at 4000:
    assert mp.set_multiple_targets(3, [4000, 6000]) == bytes(
        [0x9F, 0x02, 0x03, 0x20, 0x1F, 0x70, 0x2E]
    )


def test_speed_and_acceleration_units() -> None:
    # Guide: speed 140 = 3.5 us/ms, sent as 87 05 0C 01.
    assert mp.speed_units(3500) == 140
    assert mp.set_speed(5, 140) == bytes([0x87, 0x05, 0x0C, 0x01])
    assert mp.speed_units(0) == 0 and mp.speed_units(1) == 1  # a limit never becomes "none"
    # (0.25 us)/(10 ms)/(80 ms): 30000 us/s^2 -> 30000 * 4 / 100 * 0.08 = 96.
    assert mp.acceleration_units(30000) == 96
    assert mp.acceleration_units(1e9) == 255 and mp.acceleration_units(0) == 0
    assert mp.set_acceleration(11, 96) == bytes([0x89, 0x0B, 0x60, 0x00])


def test_runs_of_neighbours_become_multiple_targets() -> None:
    pose = {0: 4000, 1: 4004, 2: 4008, 5: 6000, 7: 7000, 8: 7004}
    multiple = mp.targets(pose, multiple=True)
    assert multiple == (
        mp.set_multiple_targets(0, [4000, 4004, 4008])
        + mp.set_target(5, 6000)
        + mp.set_multiple_targets(7, [7000, 7004])
    )
    single = mp.targets(pose, multiple=False)
    assert single == b"".join(mp.set_target(ch, q) for ch, q in sorted(pose.items()))
    assert len(mp.targets({ch: 6000 for ch in range(16)}, True)) == 3 + 2 * 16
    assert len(mp.targets({ch: 6000 for ch in range(16)}, False)) == 4 * 16


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: mp.set_target(0, 0), "would stop the pulses"),
        (lambda: mp.set_target(0, 16384), "not in 0..16383"),
        (lambda: mp.set_target(128, 6000), "channel 128"),
        (lambda: mp.set_multiple_targets(0, []), "do not fit"),
        (lambda: mp.set_acceleration(0, 256), "not in 0..255"),
        (lambda: mp.u16(b"\x01"), "expected 2 bytes"),
    ],
)
def test_values_that_cannot_be_encoded_are_refused(call: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()  # type: ignore[operator]


def test_error_register() -> None:
    assert mp.u16(bytes([0x10, 0x00])) == 0x10
    assert mp.error_names(0x10) == ["serial protocol error"]
    assert mp.error_names(0x0003) == ["serial signal error", "serial overrun error"]
    assert mp.error_names(0x8000) == ["unknown bits 0x8000"]
    assert mp.error_names(0) == []
