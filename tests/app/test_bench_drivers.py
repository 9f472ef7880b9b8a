"""``facesynth bench drivers``: bytes and wire time of one pose per driver."""

from __future__ import annotations

import pytest

from facesynth.app.bench.drivers import bench_drivers
from facesynth.app.cli import main


def test_wire_costs_of_a_sixteen_servo_pose() -> None:
    _, costs = bench_drivers("paper16")
    by_how = {(c.driver, c.how): c for c in costs}
    arduino = by_how["arduino", "SET_ALL, CRC, ACK back"]
    assert (arduino.frame_bytes, arduino.reply_bytes) == (39, 10)  # PROTOCOL.md: 32 + 7
    assert arduino.wire_ms == pytest.approx(39 * 10 / 115200 * 1000)
    assert by_how["maestro", "Mini: Set Multiple Targets"].frame_bytes == 3 + 2 * 16
    assert by_how["maestro", "Micro/auto: Set Target each"].frame_bytes == 4 * 16
    plain = by_how["ssc32", "group move"]
    assert plain.frame_bytes == len("".join(f"#{ch}P1234" for ch in range(16))) + 1
    slow = by_how["ssc32", "group move, S, factory 9600"]
    assert slow.wire_ms > 150 and slow.poses_per_s < 6
    assert all(c.encode_us > 0 for c in costs)


def test_the_command_prints_the_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "drivers"]) == 0
    out = capsys.readouterr().out
    assert "one pose of profile paper16 (16 servos), per driver" in out
    assert "arduino  SET_ALL, CRC, ACK back       115200    39   10     3.39      295" in out


def test_smart_bus_frames_fit_three_ms_at_one_mbps() -> None:
    """Issue 26's goal: 16 servos, Sync Write plus read-back <= 3 ms of bus time a frame at
    1 Mbps, from the bytes the vendors' SDKs write and the status packets' sizes."""
    from facesynth.app.bench.bus_time import bus_frames
    from facesynth.runtime.profiles import load_profile

    frames = {(f.driver, f.how): f for f in bus_frames(load_profile("paper16"))}
    x = frames["dynamixel", "2.0 XL430, Sync Read"]
    # Sync Write: header 7 + INST + address 2 + length 2 + CRC 2 + 16 x (id + 4 bytes)
    assert (x.write_bytes, x.request_bytes) == (14 + 16 * 5, 14 + x.servos_read)
    assert x.answer_bytes == x.servos_read * (11 + 21) and x.servos_read == 5
    sts = frames["feetech", "STS3215, Sync Read"]
    assert sts.write_bytes == 8 + 16 * 3 and sts.answer_bytes == sts.servos_read * 14
    for frame in frames.values():
        if frame.baud == 1000000:
            assert frame.bus_ms <= 3.0, frame
    assert frames["dynamixel", "2.0 XL430, factory 57600"].bus_ms > 20
